//! The ambient-occlusion view (`--aov ao`): known answers (a lone quad is open everywhere,
//! the inside of a closed box is enclosed), our GPU tracer against the CPU reference, the
//! vendor's any-hit queries against ours, accumulation, and the flags. Every GPU test runs
//! under the validation layer on the test device (CI: Mesa 25's lavapipe, which has the
//! vendor's ray tracing too).
//!
//! Tolerance: `common::tolerance::AO` against the CPU and between our layouts,
//! `common::tolerance::AO_VENDOR` against the vendor's (why, there).

mod common;

use std::process::Command;

use common::tolerance::{AO, AO_VENDOR};
use common::*;
use glam::Vec3;
use meshtracer::gpu::khr_rt::VendorKernel;
use meshtracer::gpu::{ComputeTracer, GpuContext};
use meshtracer::render_settings::{Accel, Aov, BvhLayout, RenderSettings};
use meshtracer::scene::primitives::PaperModel;
use meshtracer::scene::{Camera, Instance, Material, Mesh, PointLight, Scene};
use meshtracer::tracer::{cpu, FrameParams, Image, PackedScene};

fn ao(size: u32, samples: u32, radius: f32) -> RenderSettings {
    RenderSettings {
        width: size,
        height: size,
        aov: Aov::Ao,
        ao_samples: samples,
        ao_radius: radius,
        ..RenderSettings::default()
    }
}

/// Every kind of vendor tracing the device has (at least one: CI's lavapipe has both).
fn kernels(ctx: &GpuContext) -> Vec<VendorKernel> {
    let support = &ctx.info.vendor;
    assert!(
        support.available(),
        "the AO vendor tests need VK_KHR_acceleration_structure (Mesa 25's lavapipe): {:?}",
        support.missing
    );
    VendorKernel::ALL.into_iter().filter(|k| k.supported(support)).collect()
}

/// `scene` traced by our BVH, brute force, each vendor kind (on one tracer) and the CPU
/// reference: (what, image) pairs, the CPU's last.
fn render_every_way(scene: &Scene, settings: RenderSettings) -> Vec<(String, Image)> {
    let ctx = ctx();
    let packed = PackedScene::new(scene);
    let mut tracer = ComputeTracer::with_scene(&ctx, &packed).expect("upload");
    let mut out = Vec::new();
    for accel in [Accel::Bvh, Accel::Brute] {
        let (image, _) = tracer
            .render(&FrameParams::new(scene, RenderSettings { accel, ..settings }))
            .expect("trace");
        out.push((format!("GPU {accel}"), image));
    }
    for kernel in kernels(&ctx) {
        tracer.set_vendor_kernel(kernel).expect("a kind the device has");
        let (image, _) = tracer
            .render(&FrameParams::new(scene, RenderSettings { accel: Accel::Vendor, ..settings }))
            .expect("trace with the vendor's");
        out.push((format!("vendor {kernel}"), image));
    }
    drop(tracer);
    assert_validation_clean(&ctx);
    out.push(("CPU".into(), cpu::render(&packed, &FrameParams::new(scene, settings))));
    out
}

#[test]
fn a_lone_quad_facing_the_camera_is_open_wherever_it_is_hit() {
    let scene = quad_scene(Material::default(), 3.0, Vec3::new(0.0, 0.0, 3.0));
    for smooth in [false, true] {
        for (what, image) in render_every_way(&scene, RenderSettings { smooth, ..ao(33, 16, 2.0) })
        {
            let hits = image.pixels.iter().filter(|p| p[3] == 1.0).count();
            assert!(
                hits > 33 * 33 / 4,
                "{what}: the quad should fill much of the frame ({hits} hits)"
            );
            for (i, p) in image.pixels.iter().enumerate() {
                // A hit: nothing above the quad, so every ray is open. A miss: open sky, alpha 0.
                assert!(
                    p[..3] == [1.0; 3] && (p[3] == 1.0 || p[3] == 0.0),
                    "{what}, smooth {smooth}: pixel {i} is {p:?}"
                );
            }
            assert_eq!(image.get(0, 0)[3], 0.0, "{what}: the corner misses the quad");
        }
    }
}

/// A closed cube of half-size `h` around the origin, faces wound outwards.
fn cube(h: f32) -> Mesh {
    let positions = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 1 == 0 { -h } else { h },
                if i & 2 == 0 { -h } else { h },
                if i & 4 == 0 { -h } else { h },
            )
        })
        .collect();
    let quads =
        [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    let triangles: Vec<[u32; 3]> =
        quads.iter().flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]]).collect();
    let mut m = Mesh {
        name: "cube".into(),
        positions,
        triangle_materials: vec![0; triangles.len()],
        triangles,
        materials: vec![Material::default()],
        ..Default::default()
    };
    m.compute_vertex_normals();
    m
}

#[test]
fn the_inside_of_a_closed_box_is_enclosed_when_the_radius_spans_it() {
    // Camera at the centre of a cube of side 2; every AO ray meets a wall within 2*sqrt(3).
    let scene = Scene {
        meshes: vec![cube(1.0)],
        instances: vec![Instance::placed(0, Vec3::ZERO, 1.0)],
        camera: Camera {
            position: Vec3::new(0.1, 0.2, 0.3),
            target: Vec3::new(0.5, -0.3, -1.0),
            up: Vec3::Y,
            vfov_deg: 90.0,
        },
        light: PointLight { position: Vec3::ZERO, color: Vec3::ONE },
        background: Vec3::ZERO,
        ambient: 0.1,
        environment: None,
        assembly: Default::default(),
    };
    for (what, image) in render_every_way(&scene, ao(32, 16, 4.0)) {
        assert!(image.pixels.iter().all(|p| p[3] == 1.0), "{what}: every camera ray hits a wall");
        let open: Vec<_> = image.pixels.iter().enumerate().filter(|(_, p)| p[0] != 0.0).collect();
        assert!(
            open.is_empty(),
            "{what}: {} pixel(s) see out of a closed box, first {:?}",
            open.len(),
            open[0]
        );
    }
    // A radius shorter than the distance to the walls opposite leaves the rays open again.
    let short = render_every_way(&scene, ao(16, 16, 0.05));
    for (what, image) in short {
        let mean = image.pixels.iter().map(|p| p[0]).sum::<f32>() / image.pixels.len() as f32;
        assert!(mean > 0.8, "{what}: with radius 0.05 only corners are occluded (mean {mean})");
    }
}

#[test]
fn gpu_ao_matches_the_cpu_reference() {
    let knot = paper(PaperModel::TorusKnot, 1);
    for (settings, what) in [
        (ao(48, 8, 0.5), "knot, 8 rays"),
        (RenderSettings { smooth: true, spp: 2, ..ao(40, 16, 1.0) }, "knot smooth, 2 spp, 16 rays"),
        (RenderSettings { accel: Accel::Brute, ..ao(32, 4, 0.25) }, "knot brute force"),
        (RenderSettings { bvh: BvhLayout::Wide, ..ao(48, 8, 0.5) }, "knot, 8 rays, wide BVH"),
        (
            RenderSettings { bvh: BvhLayout::WideRuns, ..ao(48, 8, 0.5) },
            "knot, 8 rays, wide BVH in leaf runs",
        ),
    ] {
        let (gpu, cpu) = render_both(&knot, settings);
        assert_within(&gpu, &cpu, AO, what);
        // Not a flat image: the knot's crossings occlude each other.
        let values: Vec<f32> = gpu.pixels.iter().filter(|p| p[3] == 1.0).map(|p| p[0]).collect();
        let (lo, hi) = values.iter().fold((1.0f32, 0.0f32), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        assert!(hi - lo > 0.4, "{what}: AO spans only {lo}..{hi}");
    }
    let (gpu, cpu) = render_both(&paper(PaperModel::Geosphere, 3), ao(48, 8, 2.0));
    assert_within(&gpu, &cpu, AO, "three geospheres in the mirror box");
    // The wide tree's occlusion queries answer as the binary tree's.
    let (binary, _) = render_both(&knot, ao(48, 8, 0.5));
    let (wide, _) = render_both(&knot, RenderSettings { bvh: BvhLayout::Wide, ..ao(48, 8, 0.5) });
    assert_within(&wide, &binary, AO, "knot AO, wide against binary BVH");
}

#[test]
fn the_vendors_ao_matches_ours() {
    let knot = paper(PaperModel::TorusKnot, 2);
    for settings in [ao(48, 8, 0.5), RenderSettings { smooth: true, ..ao(40, 16, 1.5) }] {
        let all = render_every_way(&knot, settings);
        let ours = &all[0].1;
        for (what, image) in &all[2..all.len() - 1] {
            assert_within(image, ours, AO_VENDOR, &format!("{what} against our BVH"));
        }
    }
}

#[test]
fn ao_over_cut_triangles_matches_every_way() {
    // The room's big triangles are cut into pieces that several leaves hold: an occlusion
    // ray may meet one triangle in several leaves, brute force tests every slot, and the
    // vendor holds each triangle once. All must see the same occlusion.
    let room = room_scene();
    let (slots, triangles) = slots_and_triangles(&room);
    assert!(
        slots > triangles,
        "the room's big triangles are cut ({slots} slots for {triangles} triangles)"
    );
    let settings = ao(40, 8, 0.5);
    let all = render_every_way(&room, settings);
    let ours = &all[0].1;
    for (what, image) in &all[1..] {
        assert_within(image, ours, AO_VENDOR, &format!("room: {what} against our BVH"));
    }
    for bvh in [BvhLayout::Wide, BvhLayout::WideRuns] {
        let (gpu, cpu) = render_both(&room, RenderSettings { bvh, ..settings });
        assert_within(&gpu, &cpu, AO, &format!("room, {bvh:?}"));
        assert_within(&gpu, ours, AO, &format!("room, {bvh:?} against the binary tree"));
    }
    let open = ours.pixels.iter().filter(|p| p[3] == 1.0 && p[0] > 0.9).count();
    let occluded = ours.pixels.iter().filter(|p| p[3] == 1.0 && p[0] < 0.7).count();
    assert!(open > 0 && occluded > 0, "the room has open and occluded hits ({open}, {occluded})");
}

#[test]
fn accumulation_averages_new_ao_rays_on_both_tracers() {
    let ctx = ctx();
    let scene = paper(PaperModel::TorusKnot, 1);
    let packed = PackedScene::new(&scene);
    let first = FrameParams::new(&scene, ao(32, 4, 0.5));
    let mut second = first;
    second.frame_index = 1;
    let mut tracer = ComputeTracer::with_scene(&ctx, &packed).expect("upload");
    let (one, _) = tracer.render(&first).unwrap();
    let (two, _) = tracer.render(&second).unwrap();
    drop(tracer);
    assert_validation_clean(&ctx);
    let mut cpu_two = cpu::render(&packed, &first);
    cpu::accumulate(&packed, &second, &mut cpu_two);
    assert_within(&two, &cpu_two, AO, "two accumulated frames");
    // A second frame draws other rays: the mean of two frames is not the first frame.
    let changed =
        one.pixels.iter().zip(&two.pixels).filter(|(a, b)| (a[0] - b[0]).abs() > 1e-3).count();
    assert!(changed > 32, "only {changed} pixels changed after a second frame");
    // And it is a mean: 4 rays a frame, so two frames give eighths.
    for p in two.pixels.iter().filter(|p| p[3] == 1.0) {
        assert!((p[0] * 8.0 - (p[0] * 8.0).round()).abs() < 1e-4, "{p:?}");
    }
}

fn meshtracer() -> Command {
    Command::new(env!("CARGO_BIN_EXE_meshtracer"))
}

#[test]
fn render_writes_the_ao_view_on_the_gpu_the_vendors_and_the_cpu() {
    let dir = Scratch::new("ao");
    let scene = [
        "render",
        "--aov",
        "ao",
        "--model",
        "torusknot",
        "--width",
        "32",
        "--height",
        "32",
        "--ao-samples",
        "8",
        "--ao-radius",
        "0.5",
    ];
    let mut images = Vec::new();
    for (name, extra) in
        [("gpu.png", vec![]), ("cpu.png", vec!["--cpu"]), ("vendor.png", vec!["--accel", "vendor"])]
    {
        let out = dir.join(name);
        let o = meshtracer()
            .args(scene)
            .args(&extra)
            .arg("-o")
            .arg(&out)
            .env("MESHTRACER_VALIDATION", "1")
            .output()
            .unwrap();
        assert!(o.status.success(), "{name}: {}", String::from_utf8_lossy(&o.stderr));
        assert!(
            String::from_utf8_lossy(&o.stdout).contains("8 AO rays within 0.5"),
            "{}",
            String::from_utf8_lossy(&o.stdout)
        );
        images.push(image::open(&out).unwrap().to_rgb8());
    }
    // Grey, and the three agree but for a few pixels.
    for img in &images {
        assert!(img.pixels().all(|p| p[0] == p[1] && p[1] == p[2]), "AO is grey");
    }
    for other in &images[1..] {
        let far =
            images[0].pixels().zip(other.pixels()).filter(|(a, b)| a[0].abs_diff(b[0]) > 1).count();
        assert!(far <= 32 * 32 / 50, "{far} pixels differ by more than one step");
    }
    // The preset of the PNG holds the AO knobs.
    let text =
        meshtracer::files::image_files::png_settings(&std::fs::read(dir.join("gpu.png")).unwrap())
            .unwrap()
            .unwrap();
    assert!(
        text.contains("aov = \"ao\"")
            && text.contains("ao_samples = 8")
            && text.contains("ao_radius = 0.5"),
        "{text}"
    );
}

#[test]
fn bad_ao_flags_are_one_clear_line() {
    for (flag, value, says) in [
        ("--ao-samples", "0", "1..=256"),
        ("--ao-samples", "1000", "1..=256"),
        ("--ao-radius", "-1", "out of range (0..1000 scene units)"),
        ("--ao-radius", "0", "0..1000"),
        ("--ao-radius", "x", "not a number"),
    ] {
        for command in ["render", "bench"] {
            let mut args = vec![command, flag, value];
            if command == "render" {
                args.extend(["--aov", "ao", "-o", "never.png"]);
            } else {
                args.push("--ao");
            }
            let o = meshtracer().args(&args).output().unwrap();
            assert!(!o.status.success(), "{args:?} should fail");
            let err = String::from_utf8_lossy(&o.stderr);
            let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
            assert_eq!(lines.len(), 1, "{args:?}: one line, got:\n{err}");
            assert!(lines[0].contains(flag) && lines[0].contains(says), "{args:?}: {err}");
        }
    }
}

#[test]
fn bench_compare_ao_pairs_our_ao_with_the_vendors() {
    let dir = Scratch::new("bench-ao");
    let json = dir.join("ao.json");
    let o = meshtracer()
        .args([
            "bench",
            "--compare",
            "--ao",
            "--triangles",
            "2000",
            "--size",
            "32",
            "--ao-samples",
            "4",
            "--frames",
            "2",
            "--warmup",
            "1",
            "--validation",
            "--json",
        ])
        .arg(&json)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{stdout}\n{}", String::from_utf8_lossy(&o.stderr));
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let rows = report["rows"].as_array().unwrap();
    assert!(
        rows.iter().all(|r| r["series"] == "ao"
            && r["features"].as_str().unwrap().starts_with("ao 4 rays, r 0.25, framed")),
        "{rows:?}"
    );
    assert!(
        rows.iter().all(|r| r["rays_per_frame"] == 32 * 32 * 5),
        "a primary and 4 AO rays per pixel: {rows:?}"
    );
    let vendor = rows.iter().filter(|r| r["accel"] == "vendor").count();
    assert_eq!(vendor, kernels(&ctx()).len(), "{rows:?}");
    for r in rows {
        let ratio = r["ours_over_vendor"].as_f64().unwrap_or_else(|| panic!("no ratio on {r}"));
        assert!(ratio.is_finite() && ratio > 0.0, "{r}");
    }
}
