//! The vendor's ray tracing (`--accel vendor`) against our compute BVH on the same scenes:
//! the driver's acceleration structures traced by ray queries and by a ray tracing
//! pipeline, each kind the device has. CI's lavapipe (Mesa 25) has both. Every test runs
//! under the validation layer.
//! Tolerance: `common::tolerance::VENDOR` (why, there).

mod common;

use std::path::Path;
use std::process::Command;

use common::tolerance::{VENDOR, VENDOR_IDS};
use common::*;
use meshtracer::gpu::khr_rt::VendorKernel;
use meshtracer::gpu::{ComputeTracer, GpuContext};
use meshtracer::render_settings::{Accel, Aov, RenderSettings};
use meshtracer::scene::obj::load_obj;
use meshtracer::scene::paper::{open_scene, prepare_mesh, LightOrbit};
use meshtracer::scene::primitives::PaperModel;
use meshtracer::scene::{EnvironmentSource, Scene};
use meshtracer::tracer::{FrameParams, Image, PackedScene};

/// Every kind of vendor tracing the device has; CI's lavapipe must have one at least.
fn kernels(ctx: &GpuContext) -> Vec<VendorKernel> {
    let support = &ctx.info.vendor;
    assert!(support.available(), "the vendor tests need VK_KHR_acceleration_structure (CI installs Mesa 25's lavapipe): {:?}", support.missing);
    VendorKernel::ALL.into_iter().filter(|k| k.supported(support)).collect()
}

/// `scene` with `settings` traced by our BVH and by each vendor kind, on one tracer (so a
/// kind switch reuses the structures): (kind, vendor image, our image).
fn render_all(scene: &Scene, settings: RenderSettings) -> Vec<(VendorKernel, Image, Image)> {
    let ctx = ctx();
    let packed = PackedScene::new(scene);
    let mut tracer = ComputeTracer::with_scene(&ctx, &packed).expect("upload");
    let (ours, _) = tracer.render(&FrameParams::new(scene, settings)).expect("trace with the BVH");
    let mut out = Vec::new();
    for kernel in kernels(&ctx) {
        tracer.set_vendor_kernel(kernel).expect("a kind the device has");
        let (vendor, _) = tracer
            .render(&FrameParams::new(scene, RenderSettings { accel: Accel::Vendor, ..settings }))
            .expect("trace with the vendor's");
        out.push((kernel, vendor, ours.clone()));
    }
    drop(tracer);
    assert_validation_clean(&ctx);
    out
}

fn assert_all_close(
    scene: &Scene,
    settings: RenderSettings,
    what: &str,
) -> Vec<(VendorKernel, Image, Image)> {
    let all = render_all(scene, settings);
    for (kernel, vendor, ours) in &all {
        assert_within(vendor, ours, VENDOR, &format!("{what} ({kernel}) against our BVH"));
    }
    all
}

#[test]
fn the_papers_scene_matches_the_compute_bvh() {
    for model in PaperModel::ALL {
        let all = assert_all_close(&paper(model, 1), settings(64, 2), model.name());
        // Not two black images: the warm model is in the middle.
        let c = all[0].1.get(32, 32);
        assert!(c[0] > c[2] && c[0] > 0.1, "{}: centre {c:?}", model.name());
    }
}

#[test]
fn one_and_twenty_seven_copies_match() {
    for count in [1, 27] {
        assert_all_close(
            &paper(PaperModel::Geosphere, count),
            settings(48, 2),
            &format!("{count} copies"),
        );
    }
}

#[test]
fn smooth_shading_with_samples_and_an_environment_matches() {
    let mut mesh = PaperModel::TorusKnot.mesh();
    prepare_mesh(&mut mesh);
    let mut scene = open_scene(mesh, 1, LightOrbit::default());
    scene.environment = Some(EnvironmentSource::Sky);
    let s = RenderSettings { smooth: true, spp: 4, adaptive: true, ..settings(48, 2) };
    assert_all_close(&scene, s, "smooth, adaptive 4 spp, sky");
}

#[test]
fn vertex_colours_match() {
    // The shading is shared, but the hit's corners come from the driver's primitive id:
    // a wrong triangle would show the wrong colours.
    let mut mesh = PaperModel::TorusKnot.mesh();
    prepare_mesh(&mut mesh);
    mesh.colors = mesh
        .positions
        .iter()
        .map(|p| [(p.x.abs() * 255.0) as u8, 64, (p.z.abs() * 255.0) as u8, 255])
        .collect();
    let scene = open_scene(mesh, 1, LightOrbit::default());
    assert_all_close(&scene, RenderSettings { smooth: true, ..settings(48, 2) }, "vertex colours");
}

#[test]
fn a_textured_mesh_matches() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/obj");
    let mut mesh = load_obj(&data.join("texture_options.obj")).expect("the test file loads").mesh;
    prepare_mesh(&mut mesh);
    let scene = open_scene(mesh, 1, LightOrbit::default());
    let all = assert_all_close(&scene, settings(48, 1), "textured");
    let (_, vendor, _) = &all[0];
    let lit = vendor.pixels.iter().filter(|p| p[0] + p[1] + p[2] > 0.05).count();
    assert!(
        lit > 48 * 48 / 10,
        "the textured mesh should cover part of the frame ({lit} lit pixels)"
    );
}

#[test]
fn depth_and_primitive_id_outputs_match() {
    let scene = paper(PaperModel::Sphere, 2);
    for aov in [Aov::Depth, Aov::PrimId, Aov::Normal] {
        for (kernel, vendor, ours) in render_all(&scene, RenderSettings { aov, ..settings(48, 0) })
        {
            assert_within(&vendor, &ours, VENDOR_IDS, &format!("{aov} ({kernel})"));
        }
    }
}

#[test]
fn a_scene_of_cut_triangles_matches() {
    // Our build cuts the room's big triangles into pieces held by several leaves: the
    // vendor gets each triangle once and its primitives are mapped to our slots, or the
    // colours and the ids below would differ.
    let scene = room_scene();
    let (slots, triangles) = slots_and_triangles(&scene);
    assert!(
        slots > triangles,
        "the room's big triangles are cut ({slots} slots for {triangles} triangles)"
    );
    let all = assert_all_close(&scene, settings(64, 2), "room of cut triangles");
    let lit = all[0].1.pixels.iter().filter(|p| p[0] + p[1] + p[2] > 0.05).count();
    assert!(lit > 64 * 64 / 4, "the room fills part of the frame ({lit} lit pixels)");
    for (kernel, vendor, ours) in
        render_all(&scene, RenderSettings { aov: Aov::PrimId, ..settings(64, 0) })
    {
        assert_within(&vendor, &ours, VENDOR_IDS, &format!("room, prim-id ({kernel})"));
    }
    // The driver's structures hold each triangle once, not each slot.
    let ctx = ctx();
    let mut tracer = ComputeTracer::with_scene(&ctx, &PackedScene::new(&scene)).expect("upload");
    tracer
        .render(&FrameParams::new(
            &scene,
            RenderSettings { accel: Accel::Vendor, ..settings(16, 0) },
        ))
        .expect("trace with the vendor's");
    let mesh_triangles: usize = scene.meshes.iter().map(|m| m.triangle_count()).sum();
    assert_eq!(tracer.vendor_stats().unwrap().primitives, mesh_triangles as u64);
    drop(tracer);
    assert_validation_clean(&ctx);
}

#[test]
fn a_new_model_count_or_model_rebuilds_the_structures_and_still_matches() {
    let ctx = ctx();
    let kernel = kernels(&ctx)[0];
    let s = settings(40, 2);
    let vendor = RenderSettings { accel: Accel::Vendor, ..s };
    let two = paper(PaperModel::Geosphere, 2);
    let mut packed = PackedScene::new(&two);
    let mut tracer = ComputeTracer::with_scene(&ctx, &packed).expect("upload");
    tracer.set_vendor_kernel(kernel).unwrap();
    tracer.render(&FrameParams::new(&two, vendor)).expect("first vendor frame");
    let first = tracer.vendor_stats().expect("built on first use");
    assert_eq!(first.rebuilt, "bottom and top levels");
    assert_eq!(first.bottom_count, 2, "one bottom level per mesh: the model and the mirror box");

    // Five copies: the instance list changes, only the top level is rebuilt.
    let five = paper(PaperModel::Geosphere, 5);
    packed.set_instances(&five.instances);
    tracer.set_instances(&packed.top_level).unwrap();
    let (theirs, _) = tracer.render(&FrameParams::new(&five, vendor)).unwrap();
    let after = tracer.vendor_stats().unwrap();
    assert_eq!(after.rebuilt, "top level");
    let (ours, _) = tracer.render(&FrameParams::new(&five, s)).unwrap();
    assert_within(&theirs, &ours, VENDOR, "five copies after a top-level rebuild");

    // Another model: both levels again.
    let knot = paper(PaperModel::TorusKnot, 1);
    tracer.set_scene(&PackedScene::new(&knot)).unwrap();
    let (theirs, _) = tracer.render(&FrameParams::new(&knot, vendor)).unwrap();
    assert_eq!(tracer.vendor_stats().unwrap().rebuilt, "bottom and top levels");
    let (ours, _) = tracer.render(&FrameParams::new(&knot, s)).unwrap();
    assert_within(&theirs, &ours, VENDOR, "another model");
    drop(tracer);
    assert_validation_clean(&ctx);
}

fn meshtracer() -> Command {
    Command::new(env!("CARGO_BIN_EXE_meshtracer"))
}

#[test]
fn without_the_extensions_render_and_bench_end_with_one_line() {
    let out = std::env::temp_dir().join(format!("meshtracer-vendor-{}.png", std::process::id()));
    for args in [
        vec![
            "render",
            "--accel",
            "vendor",
            "--width",
            "16",
            "--height",
            "16",
            "-o",
            out.to_str().unwrap(),
        ],
        vec!["bench", "--compare", "--resolutions", "16", "--frames", "1", "--warmup", "0"],
    ] {
        let o = meshtracer().args(&args).env("MESHTRACER_NO_VENDOR_RT", "1").output().unwrap();
        assert!(!o.status.success(), "{args:?} should fail");
        let err = String::from_utf8_lossy(&o.stderr);
        let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
        assert_eq!(lines.len(), 1, "{args:?}: one line, got {err}");
        assert!(
            lines[0].contains("vendor's ray tracing is switched off") && !err.contains("panicked"),
            "{args:?}: {err}"
        );
    }
    assert!(!out.exists(), "no image is written");
}

#[test]
fn bench_compare_gives_the_ratio_for_each_row() {
    let dir = std::env::temp_dir().join(format!("meshtracer-compare-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let json = dir.join("compare.json");
    let o = meshtracer()
        .args([
            "bench",
            "--compare",
            "--framed",
            "--triangles",
            "2000",
            "--bvh",
            "binary,wide",
            "--size",
            "32",
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
    assert!(stdout.contains("ours (BVH) / vendor"), "{stdout}");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let rows = report["rows"].as_array().unwrap();
    let vendor: Vec<_> = rows.iter().filter(|r| r["accel"] == "vendor").collect();
    let ctx = ctx();
    assert_eq!(vendor.len(), kernels(&ctx).len(), "a vendor row per kind the device has: {rows:?}");
    for r in vendor.iter().copied().chain(rows.iter().filter(|r| r["accel"] == "bvh")) {
        let ratio = r["ours_over_vendor"].as_f64().unwrap_or_else(|| panic!("no ratio on {r}"));
        assert!(ratio.is_finite() && ratio > 0.0, "{r}");
    }
    // The vendor rows' build and memory columns are the driver's structures, not our scene:
    // the vendor row after the wide one starts a tracer of its own (the binary packing
    // again), which builds them with its first frame; they were once read before it.
    let ours: Vec<u64> = rows
        .iter()
        .filter(|r| r["accel"] == "bvh")
        .map(|r| r["scene_bytes"].as_u64().unwrap())
        .collect();
    for r in &vendor {
        let bytes = r["scene_bytes"].as_u64().unwrap();
        assert!(
            bytes > 0 && !ours.contains(&bytes),
            "the vendor's bytes {bytes} are one of ours {ours:?}: {r}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
