//! Issue #13, "Real exported files": what other OBJ loaders accept must load and draw
//! right here too. One hand-written file per case in `tests/data/obj/`, each loaded and
//! traced on both tracers (validation layer on), within `common::tolerance::SAME_MATHS`.
//! Last, the `--crease-angle` flag through the binary.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::*;
use glam::Vec3;
use meshtracer::render_settings::{Aov, RenderSettings};
use meshtracer::scene::obj::load_obj;
use meshtracer::scene::{Camera, Instance, Mesh, PointLight, Scene};
use meshtracer::tracer::Image;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/obj").join(name)
}

/// `mesh` as it is in the file (no normalising), seen head-on from `eye` along -z with a
/// 60 degree field of view, lit from `light`, on black.
fn scene_of(mesh: Mesh, eye: Vec3, light: Vec3) -> Scene {
    scene_looking(mesh, eye, Vec3::new(eye.x, eye.y, 0.0), light)
}

/// `mesh` as it is in the file, seen from `eye` looking at `target` (60 degree field of
/// view), lit from `light`, on black.
fn scene_looking(mesh: Mesh, eye: Vec3, target: Vec3, light: Vec3) -> Scene {
    Scene {
        meshes: vec![mesh],
        instances: vec![Instance::placed(0, Vec3::ZERO, 1.0)],
        camera: Camera { position: eye, target, up: Vec3::Y, vfov_deg: 60.0 },
        light: PointLight { position: light, color: Vec3::ONE },
        background: Vec3::ZERO,
        ambient: 0.0,
        environment: None,
        assembly: Default::default(),
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
        assert_eq!(
            m.diffuse_texture.as_ref().and_then(|t| t.path()),
            Some(data("halves.png").as_path()),
            "{}: options taken for the file name",
            m.name
        );
    }
    // The options that are read and not applied: one warning per material, naming them.
    assert_eq!(loaded.warnings.len(), 2, "{:?}", loaded.warnings);
    assert!(
        loaded.warnings[0].contains("material offset")
            && loaded.warnings[0].contains("-colorspace"),
        "{}",
        loaded.warnings[0]
    );
    assert!(
        loaded.warnings[1].contains("material scaled")
            && loaded.warnings[1].contains("-bm, -texres"),
        "{}",
        loaded.warnings[1]
    );

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
            assert!(
                ok,
                "{what}: quarter {q} should be {}: {got:?}",
                if *red { "red" } else { "blue" }
            );
        }
    };
    check("plain", left, top, [true, true, false, false]);
    check("offset by half a tile", right, top, [false, false, true, true]);
    check("offset and clamped", left, bottom, [false, false, false, false]);
    check("scaled twice", right, bottom, [true, false, true, false]);
}

/// The pixels that hit the model, as (x, y).
fn hits(prim: &Image) -> Vec<(u32, u32)> {
    (0..prim.height)
        .flat_map(|y| (0..prim.width).map(move |x| (x, y)))
        .filter(|&(x, y)| prim.get(x, y)[0] >= 0.0)
        .collect()
}

/// The triangle a pixel of a prim-id image hit.
fn prim_at(prim: &Image, x: u32, y: u32) -> i64 {
    prim.get(x, y)[0] as i64
}

fn normal_at(normals: &Image, x: u32, y: u32) -> Vec3 {
    let [a, b, c, _] = normals.get(x, y);
    Vec3::new(a, b, c)
}

#[test]
fn faces_naming_missing_normals_are_drawn_with_computed_ones() {
    let loaded = load_obj(&data("missing_normals.obj")).unwrap();
    assert_eq!(loaded.warnings.len(), 1, "{:?}", loaded.warnings);
    assert!(
        loaded.warnings[0]
            .contains("missing_normals.obj line 18: face normal index 1 is out of range"),
        "{}",
        loaded.warnings[0]
    );
    let eye = Vec3::new(2.5, 2.0, 3.5);
    let scene = scene_looking(loaded.mesh, eye, Vec3::ZERO, eye);
    let smooth = RenderSettings { smooth: true, ..settings(48) };
    let (gpu, cpu) = render_both(&scene, smooth);
    assert_close(&gpu, &cpu, "missing normals, colour");
    let (prim, _) = render_both(&scene, RenderSettings { aov: Aov::PrimId, ..smooth });
    let (normals, normals_cpu) = render_both(&scene, RenderSettings { aov: Aov::Normal, ..smooth });
    assert_close(&normals, &normals_cpu, "missing normals, normals");
    // The cube covers a good part of the image with unit normals, and is mostly lit (with
    // every edge smoothed, normals turn away from the light towards the far corners).
    let hit = hits(&prim);
    assert!(hit.len() > 48 * 48 / 5, "{} pixels hit", hit.len());
    for &(x, y) in &hit {
        let n = normal_at(&normals, x, y);
        assert!((n.length() - 1.0).abs() < 1e-3, "pixel {x},{y}: normal {n}");
    }
    let lit = hit.iter().filter(|&&(x, y)| gpu.get(x, y)[..3].iter().any(|&c| c > 0.05)).count();
    assert!(lit * 3 > hit.len() * 2, "{lit} of {} pixels lit", hit.len());
}

#[test]
fn smoothing_groups_keep_hard_edges_under_smooth_shading() {
    // Sides in one group (triangles 0..8), the top alone in another (8, 9), the bottom flat.
    let loaded = load_obj(&data("smoothing_groups.obj")).unwrap();
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let eye = Vec3::new(2.2, 2.4, 3.0);
    let scene = scene_looking(loaded.mesh, eye, Vec3::ZERO, Vec3::new(1.0, 3.0, 4.0));
    let smooth = RenderSettings { smooth: true, ..settings(64) };
    let (gpu, cpu) = render_both(&scene, smooth);
    assert_close(&gpu, &cpu, "smoothing groups, colour");
    let (normals, normals_cpu) = render_both(&scene, RenderSettings { aov: Aov::Normal, ..smooth });
    assert_close(&normals, &normals_cpu, "smoothing groups, normals");
    let (prim, prim_cpu) = render_both(&scene, RenderSettings { aov: Aov::PrimId, ..smooth });
    assert_close(&prim, &prim_cpu, "smoothing groups, triangle ids");

    let is_top = |p: i64| p == 8 || p == 9;
    let is_side = |p: i64| (0..8).contains(&p);
    let (mut side_normals, mut across_sides, mut across_top_edge) = (Vec::new(), 0, 0);
    for (x, y) in hits(&prim) {
        let (p, n) = (prim_at(&prim, x, y), normal_at(&normals, x, y));
        if is_top(p) {
            // Flat: the top's own normal everywhere, even next to the sides.
            assert!((n - Vec3::Y).length() < 1e-4, "top pixel {x},{y}: {n}");
        } else {
            assert!(is_side(p), "pixel {x},{y} sees triangle {p}: the bottom is out of sight");
            // Smoothed with the other sides only: level, bending round the box.
            assert!(n.y.abs() < 1e-4, "side pixel {x},{y}: {n}");
            side_normals.push(n);
        }
        for (ox, oy) in [(x + 1, y), (x, y + 1)] {
            if ox >= prim.width || oy >= prim.height || prim_at(&prim, ox, oy) < 0 {
                continue;
            }
            let (q, m) = (prim_at(&prim, ox, oy), normal_at(&normals, ox, oy));
            let step = (n - m).length();
            if is_side(p) && is_side(q) && p / 2 != q / 2 {
                // From one side to the next: the normals meet, no visible edge.
                assert!(
                    step < 0.25,
                    "pixels {x},{y} and {ox},{oy} across the sides' edge: {n} then {m}"
                );
                across_sides += 1;
            }
            if is_top(p) != is_top(q) {
                // From the top to a side: a hard edge.
                assert!(
                    step > 1.0,
                    "pixels {x},{y} and {ox},{oy} across the top's edge: {n} then {m}"
                );
                across_top_edge += 1;
            }
        }
    }
    assert!(
        across_sides > 5 && across_top_edge > 20,
        "edges seen: {across_sides} between sides, {across_top_edge} round the top"
    );
    // The sides are not flat: their normals turn across each face.
    let spread = side_normals.iter().map(|n| n.dot(side_normals[0])).fold(1.0f32, f32::min);
    assert!(spread < 0.5, "side normals barely vary: {spread}");
}

#[test]
fn escaped_mtllib_names_give_both_squares_their_colours() {
    let loaded = load_obj(&data("escaped_mtllib.obj")).unwrap();
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    // The squares span ±2.1 along x, ±1 along y; at this distance the image spans ±2.3.
    let distance = 2.3 / 30f32.to_radians().tan();
    let scene = scene_of(loaded.mesh, Vec3::new(0.0, 0.0, distance), Vec3::new(0.0, 0.0, distance));
    let size = 48;
    let (gpu, cpu) = render_both(&scene, settings(size));
    assert_close(&gpu, &cpu, "escaped mtllib");
    let to_pixel = |w: f32| ((w / 2.3 * 0.5 + 0.5) * size as f32) as u32;
    let (left, right) = (gpu.get(to_pixel(-1.1), size / 2), gpu.get(to_pixel(1.1), size / 2));
    assert!(is_red(left), "the left square takes red from the first library: {left:?}");
    assert!(
        right[1] > 0.5 && right[0] < 0.2 && right[2] < 0.2,
        "the right square takes green from `escaped second.mtl`: {right:?}"
    );
}

/// Run the binary's `render --cpu` on `model` with `flags`, returning the image.
fn render_cpu(model: &Path, flags: &[&str], out: &Path) -> image::RgbaImage {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_meshtracer"));
    cmd.args([
        "render",
        "--cpu",
        "--width",
        "48",
        "--height",
        "48",
        "--bounces",
        "0",
        "--no-box",
        "--eye",
        "2.5,2,3",
    ]);
    cmd.arg("--model").arg(model).arg("-o").arg(out).args(flags);
    let run = cmd.output().expect("the binary runs");
    assert!(run.status.success(), "render {flags:?}: {}", String::from_utf8_lossy(&run.stderr));
    image::open(out).unwrap().to_rgba8()
}

#[test]
fn crease_angle_flag_keeps_a_cube_without_normals_sharp_under_smooth() {
    let dir = std::env::temp_dir().join(format!("meshtracer-real-files-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let cube = data("cube.obj");
    let flat = render_cpu(&cube, &[], &dir.join("flat.png"));
    let creased =
        render_cpu(&cube, &["--smooth", "--crease-angle", "30"], &dir.join("creased.png"));
    let blob = render_cpu(&cube, &["--smooth"], &dir.join("blob.png"));
    let _ = std::fs::remove_dir_all(&dir);
    // Pixels whose channels differ by more than `by` (of 255).
    let differ = |a: &image::RgbaImage, b: &image::RgbaImage, by: u8| {
        a.pixels()
            .zip(b.pixels())
            .filter(|(p, q)| p.0.iter().zip(q.0).any(|(&u, v)| u.abs_diff(v) > by))
            .count()
    };
    // Every edge of the cube bends by 90 degrees: with the angle at 30, smooth shading
    // keeps every face flat; without it, the cube rounds off.
    assert_eq!(differ(&flat, &creased, 2), 0, "--crease-angle 30 should shade the cube as flat");
    assert!(
        differ(&flat, &blob, 8) > 100,
        "without --crease-angle the cube should be smooth all over"
    );
}
