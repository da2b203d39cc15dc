//! Shared test helpers: one validated Vulkan context per test binary, scene builders, the
//! image tolerances (`tolerance`), the BVH oracle (`bvh_oracle`), and [`require`] for what
//! a test needs of the machine.
#![allow(dead_code)]

pub mod bvh_oracle;
pub mod gltf;
pub mod random;
pub mod tolerance;

#[allow(unused_imports)] // each test binary uses some of common
pub use tolerance::{assert_close, assert_same_cost, assert_within};

use std::path::PathBuf;
use std::sync::{Arc, OnceLock};

use glam::Vec3;
use meshtracer::gpu::{ComputeTracer, ContextOptions, GpuContext};
use meshtracer::render_settings::{Accel, Aov, RenderSettings};
use meshtracer::scene::paper::{paper_scene, prepare_mesh, LightOrbit};
use meshtracer::scene::primitives::PaperModel;
use meshtracer::scene::{Camera, Instance, Material, Mesh, PointLight, Scene};
use meshtracer::tracer::packed::Layouts;
use meshtracer::tracer::{cpu, FrameParams, Image, PackedScene};

/// The Vulkan context every GPU test uses: validation (with synchronization validation)
/// on. There is no skip: a machine without Vulkan fails these tests.
pub fn ctx() -> Arc<GpuContext> {
    static CTX: OnceLock<Arc<GpuContext>> = OnceLock::new();
    CTX.get_or_init(|| {
        GpuContext::new(&ContextOptions::validated()).unwrap_or_else(|e| {
            panic!("GPU tests need Vulkan with the validation layer (CI installs lavapipe): {e}")
        })
    })
    .clone()
}

/// Whether the machine has what a test needs (`condition`). Where it does not, the test
/// cannot run: in CI (`CI` set and not empty, as `.ci/run` sets it) that fails the test
/// with `why`, so nothing passes there without running; elsewhere it prints `why` as one
/// line and returns false, and the test returns.
pub fn require(condition: bool, why: &str) -> bool {
    if condition {
        return true;
    }
    let in_ci = std::env::var_os("CI").is_some_and(|v| !v.is_empty());
    assert!(!in_ci, "cannot run in CI (CI is set): {why}");
    eprintln!("not run here: {why}");
    false
}

/// Fail if the validation layer has said anything.
pub fn assert_validation_clean(ctx: &GpuContext) {
    let m = ctx.validation_messages();
    assert!(m.is_empty(), "{} validation message(s), first: {}", m.len(), m[0]);
}

/// The paper's scene with `model` repeated `count` times.
/// The colour view of our BVH at `size`² with `bounces` and the paper's blend of 0.5: the
/// settings the GPU-vs-CPU and vendor tests trace with.
pub fn settings(size: u32, bounces: u32) -> RenderSettings {
    RenderSettings {
        width: size,
        height: size,
        bounces,
        blend: 0.5,
        accel: Accel::Bvh,
        aov: Aov::Color,
        ..RenderSettings::default()
    }
}

pub fn paper(model: PaperModel, count: u32) -> Scene {
    let mut mesh = model.mesh();
    prepare_mesh(&mut mesh);
    paper_scene(mesh, count, LightOrbit::default())
}

/// Render on both tracers; returns (gpu, cpu).
pub fn render_both(scene: &Scene, settings: RenderSettings) -> (Image, Image) {
    render_both_with(scene, settings, |_| {})
}

/// The paper's scene (mirror box, light orbit) around [`random::room`]: big walls, a
/// slanted roof and beams around small triangles, the architecture whose big triangles the
/// build cuts into pieces.
pub fn room_scene() -> Scene {
    // Enough triangles that the tracers cut (16K and up).
    let tris = random::room(&mut random::Rng(23), 17_000);
    paper_scene(mesh_of("room", &tris), 1, LightOrbit::default())
}

/// A mesh of the triangles `tris` (three vertices each), one material, with computed
/// normals, scaled as every model is.
pub fn mesh_of(name: &str, tris: &[[Vec3; 3]]) -> Mesh {
    let mut mesh = Mesh {
        name: name.into(),
        positions: tris.iter().flatten().copied().collect(),
        triangles: (0..tris.len() as u32).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect(),
        triangle_materials: vec![0; tris.len()],
        materials: vec![Material::default()],
        ..Default::default()
    };
    mesh.compute_vertex_normals();
    prepare_mesh(&mut mesh);
    mesh
}

/// A closed UV sphere with `rings` x `segments` quads (two triangles each).
pub fn sphere(rings: usize, segments: usize, radius: f32) -> Vec<[Vec3; 3]> {
    let p = |i: usize, j: usize| {
        let (theta, phi) = (
            std::f32::consts::PI * i as f32 / rings as f32,
            std::f32::consts::TAU * j as f32 / segments as f32,
        );
        Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin()) * radius
    };
    let mut tris = Vec::new();
    for i in 0..rings {
        for j in 0..segments {
            let (a, b, c, d) = (p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1));
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        }
    }
    tris
}

/// Triangle slots of `scene` packed for tracing against its triangles: more where the
/// build cut triangles into pieces.
pub fn slots_and_triangles(scene: &Scene) -> (usize, usize) {
    let packed = PackedScene::new(scene);
    (packed.meshes.iter().map(|m| m.triangle_count as usize).sum(), scene.triangle_count())
}

/// A unit quad in the z = 0 plane facing +z, as one mesh with one material.
pub fn quad_mesh(material: Material) -> Mesh {
    let mut m = Mesh {
        name: "quad".into(),
        positions: vec![
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(-1.0, 1.0, 0.0),
        ],
        triangles: vec![[0, 1, 3], [1, 2, 3]],
        triangle_materials: vec![0, 0],
        materials: vec![material],
        ..Default::default()
    };
    m.compute_vertex_normals();
    m
}

/// A quad seen head-on from `distance` with the light at `light`, black background.
pub fn quad_scene(material: Material, distance: f32, light: Vec3) -> Scene {
    Scene {
        meshes: vec![quad_mesh(material)],
        instances: vec![Instance::placed(0, Vec3::ZERO, 1.0)],
        camera: Camera {
            position: Vec3::new(0.0, 0.0, distance),
            target: Vec3::ZERO,
            up: Vec3::Y,
            vfov_deg: 60.0,
        },
        light: PointLight { position: light, color: Vec3::ONE },
        background: Vec3::ZERO,
        ambient: 0.1,
        environment: None,
        assembly: Default::default(),
    }
}

/// Render on both tracers from a prepared scene with params adjusted by `tweak`.
pub fn render_both_with(
    scene: &Scene,
    settings: RenderSettings,
    tweak: impl Fn(&mut FrameParams),
) -> (Image, Image) {
    let packed = PackedScene::with_layouts(scene, Layouts::only(settings.bvh));
    let mut params = FrameParams::new(scene, settings);
    tweak(&mut params);
    let ctx = ctx();
    let mut tracer = ComputeTracer::with_scene(&ctx, &packed).expect("upload");
    let (gpu, _) = tracer.render(&params).expect("trace");
    drop(tracer);
    assert_validation_clean(&ctx);
    (gpu, cpu::render(&packed, &params))
}

/// Count of neighbour pairs (right and below) on the surface whose largest RGB difference
/// exceeds `step`: a measure of visible facets. Pairs touching the black background
/// (silhouettes) are left out.
pub fn large_neighbour_steps(img: &Image, step: f32) -> usize {
    let mut n = 0;
    for y in 0..img.height - 1 {
        for x in 0..img.width - 1 {
            let c = img.get(x, y);
            let background = |p: [f32; 4]| p[..3].iter().all(|&v| v < 1e-6);
            for o in [img.get(x + 1, y), img.get(x, y + 1)] {
                if !background(c)
                    && !background(o)
                    && (0..3).map(|i| (c[i] - o[i]).abs()).fold(0.0, f32::max) > step
                {
                    n += 1;
                }
            }
        }
    }
    n
}

/// A fresh scratch folder under the system's temporary folder, removed again when dropped.
pub struct Scratch(pub PathBuf);

impl Scratch {
    /// `meshtracer-<test binary>-<pid>-<tag>`, emptied first.
    pub fn new(tag: &str) -> Self {
        let binary = std::env::current_exe()
            .ok()
            .and_then(|p| p.file_stem().map(|s| s.to_string_lossy().into_owned()))
            .unwrap_or_default();
        let dir =
            std::env::temp_dir().join(format!("meshtracer-{binary}-{}-{tag}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        Scratch(dir)
    }

    /// A path in the folder.
    pub fn join(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }

    /// The names in the folder, sorted.
    pub fn names(&self) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(&self.0)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// The test device's storage-buffer limit in bytes, and a torus-knot triangle count whose
/// triangle buffer (40 bytes a triangle) just passes it: a model the device cannot hold.
pub fn storage_limit_and_a_knot_past_it() -> (u64, u64) {
    let ctx = ctx();
    let limit = ctx.info.max_storage_buffer_range;
    drop(ctx);
    assert!(limit <= 1 << 30, "the test device (CI: lavapipe) allows {limit} bytes a buffer");
    (limit, limit / 40 + 1)
}

/// Fail unless `out` is a failed run with one `error:` line that refuses the model before
/// its BVH build, naming the device's `limit` (issue #43: the count is known once the model
/// is made; the upload's own refusal, after the build, could not name it).
pub fn assert_refused_before_build(out: &std::process::Output, limit: u64) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    let errors: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error:")).collect();
    assert_eq!(errors.len(), 1, "{stderr}");
    assert!(errors[0].contains("triangles, before its BVH is built"), "{}", errors[0]);
    assert!(errors[0].contains(&format!("the device allows {limit}")), "{}", errors[0]);
}
