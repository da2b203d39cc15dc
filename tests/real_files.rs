//! Issue #13, "Real exported files": what other OBJ loaders accept must load and draw
//! right here too. One hand-written file per case in `tests/data/obj/`, each loaded and
//! traced on both tracers (validation layer on). Tolerance as in features.rs: at most
//! 0.2% of pixels may differ by more than 1e-4, mean difference under 1e-4.

mod common;

use std::path::{Path, PathBuf};

use common::*;
use glam::Vec3;
use meshtracer::scene::obj::load_obj;
use meshtracer::scene::{Camera, Instance, Mesh, PointLight, Scene};
use meshtracer::tracer::{Image, RenderSettings};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/obj").join(name)
}

fn assert_close(gpu: &Image, cpu: &Image, what: &str) {
    let d = gpu.compare(cpu, 1e-4);
    assert!(d.fraction_over <= 0.002 && d.mean < 1e-4, "{what}: GPU and CPU differ: {d:?}");
}

/// `mesh` as it is in the file (no normalising), seen head-on from `eye` along -z with a
/// 60 degree field of view, lit from `light`, on black.
fn scene_of(mesh: Mesh, eye: Vec3, light: Vec3) -> Scene {
    Scene {
        meshes: vec![mesh],
        instances: vec![Instance { mesh: 0, translation: Vec3::ZERO, scale: 1.0 }],
        camera: Camera { position: eye, target: Vec3::new(eye.x, eye.y, 0.0), up: Vec3::Y, vfov_deg: 60.0 },
        light: PointLight { position: light, color: Vec3::ONE },
        background: Vec3::ZERO,
        ambient: 0.0,
        environment: None,
    }
}

fn settings(size: u32) -> RenderSettings {
    RenderSettings { width: size, height: size, bounces: 0, ..RenderSettings::default() }
}

fn is_red(c: [f32; 4]) -> bool {
    c[0] > 0.5 && c[1] < 0.1 && c[2] < 0.1
}

fn is_blue(c: [f32; 4]) -> bool {
    c[2] > 0.5 && c[0] < 0.1 && c[1] < 0.1
}

#[test]
fn texture_options_are_read_and_applied_on_both_tracers() {
    let loaded = load_obj(&data("texture_options.obj")).unwrap();
    let mesh = loaded.mesh;
    let names: Vec<&str> = mesh.materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["plain", "offset", "clamped", "scaled"]);
    for m in &mesh.materials {
        assert_eq!(m.diffuse_texture.as_deref(), Some(data("halves.png").as_path()), "{}: options taken for the file name", m.name);
    }
    // The options that are read and not applied: one warning per material, naming them.
    assert_eq!(loaded.warnings.len(), 2, "{:?}", loaded.warnings);
    assert!(loaded.warnings[0].contains("material offset") && loaded.warnings[0].contains("-colorspace"), "{}", loaded.warnings[0]);
    assert!(loaded.warnings[1].contains("material scaled") && loaded.warnings[1].contains("-bm, -texres"), "{}", loaded.warnings[1]);

    // The grid spans ±2.1; at this distance the image spans ±2.3.
    let distance = 2.3 / 30f32.to_radians().tan();
    let scene = scene_of(mesh, Vec3::new(0.0, 0.0, distance), Vec3::new(0.0, 0.0, distance));
    let size = 64;
    let (gpu, cpu) = render_both(&scene, settings(size));
    assert_close(&gpu, &cpu, "texture options");
    // The colour at texture coordinate u (v = 0.5) of the square whose left edge is at x.
    let at = |x: f32, y: f32, u: f32| {
        let to_pixel = |w: f32| ((w / 2.3 * 0.5 + 0.5) * size as f32) as u32;
        gpu.get(to_pixel(x + 2.0 * u), size - 1 - to_pixel(y + 1.0))
    };
    let quarters = |x: f32, y: f32| [0.125, 0.375, 0.625, 0.875].map(|u| at(x, y, u));
    let (top, bottom, left, right) = (0.1, -2.1, -2.1, 0.1);
    let check = |what: &str, x: f32, y: f32, expect: [bool; 4]| {
        let got = quarters(x, y);
        for (q, (&c, red)) in got.iter().zip(&expect).enumerate() {
            let ok = if *red { is_red(c) } else { is_blue(c) };
            assert!(ok, "{what}: quarter {q} should be {}: {got:?}", if *red { "red" } else { "blue" });
        }
    };
    check("plain", left, top, [true, true, false, false]);
    check("offset by half a tile", right, top, [false, false, true, true]);
    check("offset and clamped", left, bottom, [false, false, false, false]);
    check("scaled twice", right, bottom, [true, false, true, false]);
}
