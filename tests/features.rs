//! The paper's future work, each on both tracers (validation layer on): smooth shading,
//! texture mapping, environment mapping, anti-aliasing with progressive accumulation,
//! adaptive sampling. Tolerance: `common::tolerance::SAME_MATHS`.

mod common;

use common::*;
use glam::{Vec2, Vec3};
use meshtracer::gpu::ComputeTracer;
use meshtracer::render_settings::{Aov, RenderSettings};
use meshtracer::scene::paper::{open_scene, prepare_mesh, LightOrbit};
use meshtracer::scene::primitives::{uv_sphere, PaperModel};
use meshtracer::scene::{
    Camera, EnvironmentSource, Instance, Material, PointLight, Scene, TextureSource,
};
use meshtracer::tracer::textures::{direction_to_equirect, sky_image, TextureAtlas};
use meshtracer::tracer::{cpu, FrameParams, Image, PackedScene};

fn settings(size: u32) -> RenderSettings {
    RenderSettings { width: size, height: size, bounces: 2, ..RenderSettings::default() }
}

#[test]
fn smooth_shading_matches_cpu_and_hides_facets() {
    let mut sphere = uv_sphere(12, 6); // coarse on purpose
    prepare_mesh(&mut sphere);
    for m in &mut sphere.materials {
        m.specular = Vec3::ZERO; // diffuse only: facets are the only sharp steps
    }
    let scene = open_scene(sphere, 1, LightOrbit::default());
    let (flat, _) = render_both(&scene, RenderSettings { bounces: 0, ..settings(96) });
    let (smooth, smooth_cpu) =
        render_both(&scene, RenderSettings { bounces: 0, smooth: true, ..settings(96) });
    assert_close(&smooth, &smooth_cpu, "smooth");
    // Steps above 0.1 per pixel: facet edges of the flat sphere (about 270 here); the
    // smooth sphere's steepest honest gradient, at its rim, stays mostly below it.
    let (f, s) = (large_neighbour_steps(&flat, 0.1), large_neighbour_steps(&smooth, 0.1));
    assert!(s * 2 < f, "smooth shading should remove facet steps: flat {f}, smooth {s}");
}

/// Issue #15, the shadow terminator: a smooth sphere of 100 triangles lit from the side and
/// a little from behind. Without Hanika's offset the light test sees the flat triangles, so
/// the terminator runs along triangle edges in stair steps: rows jump from lit to ambient,
/// and some get brighter again towards the dark side. With it, every row darkens smoothly.
#[test]
fn smooth_terminator_has_no_stair_steps() {
    let mut sphere = uv_sphere(10, 6);
    assert_eq!(sphere.triangles.len(), 100);
    prepare_mesh(&mut sphere);
    for m in &mut sphere.materials {
        m.specular = Vec3::ZERO; // diffuse only: brightness follows N.L
        m.mirror = 0.0;
    }
    let scene = Scene {
        meshes: vec![sphere],
        instances: vec![Instance::placed(0, Vec3::ZERO, 1.0)],
        camera: Camera {
            position: Vec3::new(0.0, 0.0, 3.2),
            target: Vec3::ZERO,
            up: Vec3::Y,
            vfov_deg: 45.0,
        },
        light: PointLight { position: Vec3::new(10.0, 4.0, -1.0), color: Vec3::ONE },
        background: Vec3::ZERO,
        ambient: 0.1,
        environment: None,
        assembly: Default::default(),
    };
    let size = 128;
    let (gpu, cpu) =
        render_both(&scene, RenderSettings { bounces: 0, smooth: true, ..settings(size) });
    assert_close(&gpu, &cpu, "smooth sphere at the terminator");
    for (tracer, img) in [("GPU", &gpu), ("CPU", &cpu)] {
        // The criterion, on the red channel, for every pair of horizontal neighbours (x, x+1)
        // at least 2 pixels inside the sphere's outline (the outline itself is an honest
        // edge): going one pixel away from the light (right to left) brightness never
        // increases by more than 1e-4, and never drops by more than 0.05 (a smooth N.L falls
        // by at most ~0.02 per pixel here; the stair steps drop by up to 0.25).
        let background = |x: u32, y: u32| img.get(x, y)[..3].iter().all(|&c| c < 1e-6);
        let ambient = 0.85 * 0.1; // the model material's red, times the ambient
        let mut rows_crossing = 0;
        for y in 1..size - 1 {
            let (mut lit, mut dark) = (false, false);
            for x in 1..size - 2 {
                if (x - 1..=x + 2)
                    .any(|xx| background(xx, y) || background(xx, y - 1) || background(xx, y + 1))
                {
                    continue;
                }
                let (here, towards_light) = (img.get(x, y)[0], img.get(x + 1, y)[0]);
                assert!(here <= towards_light + 1e-4, "{tracer}: row {y} gets brighter away from the light at x = {x}: {towards_light} -> {here}");
                assert!(
                    towards_light - here <= 0.05,
                    "{tracer}: row {y} steps down at x = {x}: {towards_light} -> {here}"
                );
                lit |= here > ambient + 0.2;
                dark |= here < ambient + 1e-4;
            }
            rows_crossing += (lit && dark) as u32;
        }
        assert!(rows_crossing > 60, "{tracer}: the terminator crosses only {rows_crossing} rows");
    }
}

fn checker_quad_scene(
    dir: &std::path::Path,
    cells: u32,
    distance: f32,
) -> meshtracer::scene::Scene {
    // A cells x cells checker: red and blue texels.
    let tex = image::RgbaImage::from_fn(cells, cells, |x, y| {
        if (x + y) % 2 == 0 {
            image::Rgba([255, 0, 0, 255])
        } else {
            image::Rgba([0, 0, 255, 255])
        }
    });
    let path = dir.join(format!("checker{cells}.png"));
    tex.save(&path).unwrap();
    let m = Material {
        diffuse: Vec3::ONE,
        specular: Vec3::ZERO,
        mirror: 0.0,
        diffuse_texture: Some(TextureSource::File(path)),
        ..Material::default()
    };
    let mut scene = quad_scene(m, distance, Vec3::new(0.0, 0.0, distance));
    scene.ambient = 0.0;
    scene.meshes[0].texcoords =
        vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)];
    scene
}

/// A 4x4 DXT1-compressed DDS file of one colour (RGB565), written by hand: the image
/// crate reads DDS but cannot write it.
fn write_dxt1_dds(path: &std::path::Path, rgb565: u16) {
    let mut bytes = b"DDS ".to_vec();
    let mut header = [0u32; 31];
    header[0] = 124; // header size
    header[1] = 0x1 | 0x2 | 0x4 | 0x1000 | 0x80000; // caps, height, width, pixel format, linear size
    header[2] = 4; // height
    header[3] = 4; // width
    header[4] = 8; // bytes of the one block
    header[18] = 32; // pixel format size
    header[19] = 0x4; // four-cc
    header[20] = u32::from_le_bytes(*b"DXT1");
    header[26] = 0x1000; // texture
    bytes.extend(header.iter().flat_map(|w| w.to_le_bytes()));
    bytes.extend(rgb565.to_le_bytes());
    bytes.extend(rgb565.to_le_bytes());
    bytes.extend([0u8; 4]); // every texel: colour 0
    std::fs::write(path, bytes).unwrap();
}

#[test]
fn dds_textures_are_read() {
    // Crytek Sponza's bricks are a DDS file: it must load like PNG and TGA do.
    let dir = std::env::temp_dir().join(format!("meshtracer-dds-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("red.dds");
    write_dxt1_dds(&path, 0xF800);
    let m = Material {
        diffuse: Vec3::ONE,
        specular: Vec3::ZERO,
        mirror: 0.0,
        diffuse_texture: Some(TextureSource::File(path)),
        ..Material::default()
    };
    let mut scene = quad_scene(m, 3.0, Vec3::new(0.0, 0.0, 3.0));
    scene.meshes[0].texcoords =
        vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)];
    let packed = PackedScene::new(&scene);
    std::fs::remove_dir_all(&dir).ok();
    assert!(packed.warnings.is_empty(), "{:?}", packed.warnings);
    assert_eq!(packed.textures.infos.len(), 1);
    let texel = packed.textures.sample(0, Vec2::splat(0.5), 0.0);
    assert!((texel - glam::Vec4::new(1.0, 0.0, 0.0, 1.0)).abs().max_element() < 0.01, "{texel}");
}

#[test]
fn textured_quad_shows_the_checker_texels() {
    let dir = std::env::temp_dir().join(format!("meshtracer-tex-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = checker_quad_scene(&dir, 2, 3.0);
    let (gpu, cpu) = render_both(&scene, RenderSettings { bounces: 0, ..settings(65) });
    assert_close(&gpu, &cpu, "textured quad");
    // uv (0.25, 0.75) is texel (0, 0) (v = 1 is the top row): red; (0.75, 0.75) blue.
    // Pixels near the quadrant centres: the light is on the axis, N.L close to 1.
    let (top_left, top_right) = (gpu.get(23, 23), gpu.get(41, 23));
    assert!(top_left[0] > 0.85 && top_left[2] < 0.1, "top-left {top_left:?} should be red");
    assert!(top_right[2] > 0.85 && top_right[0] < 0.1, "top-right {top_right:?} should be blue");
    // Texture off: the material's Kd (white).
    let (plain, _) =
        render_both(&scene, RenderSettings { bounces: 0, textures: false, ..settings(65) });
    let c = plain.get(23, 23);
    assert!(c[0] > 0.9 && c[1] > 0.9 && c[2] > 0.9, "untextured {c:?}");
    // Far away, a fine checker is minified to its mip average (purple), not aliased.
    let far = checker_quad_scene(&dir, 64, 40.0);
    let (gpu, cpu) = render_both(&far, RenderSettings { bounces: 0, ..settings(65) });
    assert_close(&gpu, &cpu, "minified quad");
    let c = gpu.get(32, 32);
    assert!(
        (c[0] - c[2]).abs() < 0.1 && c[0] > 0.3,
        "minified checker should average to purple: {c:?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn environment_is_seen_on_misses_and_in_mirrors() {
    let mut mesh = PaperModel::Sphere.mesh();
    prepare_mesh(&mut mesh);
    let mut scene = open_scene(mesh, 1, LightOrbit::default());
    scene.environment = Some(EnvironmentSource::Sky);
    let (gpu, cpu) = render_both(&scene, RenderSettings { smooth: true, ..settings(64) });
    assert_close(&gpu, &cpu, "environment");
    // A corner pixel misses: it shows the sky texel in its direction.
    let packed = PackedScene::new(&scene);
    let params = FrameParams::new(&scene, settings(64));
    let dir = params.camera.primary_ray(0, 0, 64, 64).dir;
    let sky = sky_image(512, 256);
    let uv = direction_to_equirect(dir);
    let mut atlas = TextureAtlas::default();
    let i = atlas.add(&sky);
    let expect = atlas.sample(i, uv, 0.0);
    let got = gpu.get(0, 0);
    assert!((0..3).all(|c| (got[c] - expect[c]).abs() < 0.02), "miss {got:?} vs sky {expect:?}");
    assert!(packed.environment.is_some());
    // A perfect mirror sphere reflects the sky: its centre pixel shows the sky behind the camera.
    let mut mirror = scene.clone();
    for m in &mut mirror.meshes[0].materials {
        *m = Material { diffuse: Vec3::ZERO, specular: Vec3::ZERO, mirror: 1.0, ..m.clone() };
    }
    let mirror_settings = RenderSettings { blend: 1.0, bounces: 1, smooth: true, ..settings(64) };
    let (gpu, cpu) = render_both(&mirror, mirror_settings);
    assert_close(&gpu, &cpu, "mirror");
    let centre = gpu.get(32, 32);
    assert!(
        centre[2] > 0.2 && centre[2] >= centre[0],
        "the mirror should show sky colours: {centre:?}"
    );
    // Without the environment the same mirror shows black.
    mirror.environment = None;
    let (dark, _) = render_both(&mirror, mirror_settings);
    assert!(dark.get(32, 32)[..3].iter().all(|&c| c < 1e-6));
}

#[test]
fn hdr_environment_keeps_values_above_one() {
    // A uniform EXR sky of radiance 4 around a mirror sphere at blend 0.25: the reflected
    // quarter of 4 is a full 1.0, where an 8-bit sky (clamped to 1) would give 0.25.
    let dir = std::env::temp_dir().join(format!("meshtracer-hdr-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("bright.exr");
    image::Rgba32FImage::from_pixel(16, 8, image::Rgba([4.0, 4.0, 4.0, 1.0])).save(&path).unwrap();
    let mut mesh = PaperModel::Sphere.mesh();
    prepare_mesh(&mut mesh);
    for m in &mut mesh.materials {
        *m = Material { diffuse: Vec3::ZERO, specular: Vec3::ZERO, mirror: 1.0, ..m.clone() };
    }
    let mut scene = open_scene(mesh, 1, LightOrbit::default());
    scene.ambient = 0.0;
    scene.environment = Some(EnvironmentSource::File(path));
    let s = RenderSettings { blend: 0.25, bounces: 1, smooth: true, ..settings(48) };
    let (gpu, cpu) = render_both(&scene, s);
    std::fs::remove_dir_all(&dir).ok();
    assert_close(&gpu, &cpu, "HDR environment");
    let centre = gpu.get(24, 24);
    assert!(
        (0..3).all(|c| (centre[c] - 1.0).abs() < 0.01),
        "a quarter of radiance 4 is 1: {centre:?}"
    );
    let miss = gpu.get(0, 0);
    assert!(
        (0..3).all(|c| (miss[c] - 4.0).abs() < 0.04),
        "misses see the sky's own radiance: {miss:?}"
    );
}

#[test]
fn supersampling_matches_cpu_and_accumulation_converges() {
    let scene = paper(PaperModel::Cylinder, 1);
    let (gpu, cpu) = render_both(&scene, RenderSettings { spp: 4, ..settings(48) });
    assert_close(&gpu, &cpu, "4 spp");

    // Progressive accumulation of 1-spp frames: successive frames differ less and less.
    let packed = PackedScene::new(&scene);
    let ctx = ctx();
    let mut tracer = ComputeTracer::with_scene(&ctx, &packed).unwrap();
    let mut params = FrameParams::new(&scene, settings(48));
    let mut previous: Option<Image> = None;
    let mut cpu_acc = Image::new(48, 48);
    let mut deltas = Vec::new();
    for frame in 0..16 {
        params.frame_index = frame;
        tracer.trace(&params).unwrap();
        let img = tracer.read_image().unwrap();
        cpu::accumulate(&packed, &params, &mut cpu_acc);
        if let Some(p) = &previous {
            deltas.push(img.compare(p, 0.0).mean);
        }
        previous = Some(img);
    }
    assert_close(previous.as_ref().unwrap(), &cpu_acc, "16 accumulated frames");
    let early = deltas[..3].iter().sum::<f32>() / 3.0;
    let late = deltas[deltas.len() - 3..].iter().sum::<f32>() / 3.0;
    assert!(late * 3.0 < early, "accumulation should converge: {deltas:?}");
    drop(tracer);
    assert_validation_clean(&ctx);
}

#[test]
fn adaptive_sampling_spends_samples_on_edges_only() {
    let scene = paper(PaperModel::Geosphere, 1);
    let s = RenderSettings { spp: 8, adaptive: true, ..settings(64) };
    let (gpu, cpu) = render_both(&scene, s);
    assert_close(&gpu, &cpu, "adaptive colour");
    let (counts, counts_cpu) = render_both(&scene, RenderSettings { aov: Aov::Samples, ..s });
    let disagree =
        counts.pixels.iter().zip(&counts_cpu.pixels).filter(|(a, b)| a[0] != b[0]).count();
    assert!(
        disagree as f32 <= 0.002 * (64 * 64) as f32,
        "both tracers choose the same pixels: {disagree} differ"
    );
    let total: f32 = counts.pixels.iter().map(|p| p[0]).sum();
    let edges = counts.pixels.iter().filter(|p| p[0] == 8.0).count();
    assert!(counts.pixels.iter().all(|p| p[0] == 1.0 || p[0] == 8.0));
    assert!(edges > 50, "the model's silhouette and facets are edges: {edges}");
    assert!(
        total < 0.5 * 8.0 * 64.0 * 64.0,
        "adaptive should spend far fewer samples than uniform: {total}"
    );
}

#[test]
fn adaptive_sampling_finds_edges_seen_only_in_the_mirrors() {
    // With no bounces the pre-pass sees only what the camera sees; with two, the model's
    // reflections in the mirror walls have edges too, and they get the extra samples.
    let scene = paper(PaperModel::Geosphere, 1);
    let s = RenderSettings { spp: 8, adaptive: true, aov: Aov::Samples, ..settings(64) };
    let (direct, direct_cpu) = render_both(&scene, RenderSettings { bounces: 0, ..s });
    let (mirrored, mirrored_cpu) = render_both(&scene, s);
    for (gpu, cpu) in [(&direct, &direct_cpu), (&mirrored, &mirrored_cpu)] {
        let disagree = gpu.pixels.iter().zip(&cpu.pixels).filter(|(a, b)| a[0] != b[0]).count();
        assert!(
            disagree as f32 <= 0.002 * (64 * 64) as f32,
            "both tracers choose the same pixels: {disagree} differ"
        );
    }
    let edge = |img: &Image, i: usize| img.pixels[i][0] == 8.0;
    let n = 64 * 64;
    let direct_edges = (0..n).filter(|&i| edge(&direct, i)).count();
    let mirror_only = (0..n).filter(|&i| edge(&mirrored, i) && !edge(&direct, i)).count();
    let lost = (0..n).filter(|&i| edge(&direct, i) && !edge(&mirrored, i)).count();
    assert!(direct_edges > 50, "the model's silhouette and facets are edges: {direct_edges}");
    assert_eq!(lost, 0, "an edge seen directly stays an edge when the path goes on");
    assert!(mirror_only > direct_edges / 2, "reflected edges should get samples: {mirror_only} mirror-only edges, {direct_edges} direct");
}
