//! The loader-to-GPU-scene pipeline that the `obj_to_scene` fuzz target drives, shared
//! word for word with `tests/hardening.rs` (which includes this file with `#[path]`), so
//! that every crash input kept under `tests/data/fuzz_regressions/` is replayed through
//! exactly what the fuzzer ran.
//!
//! Input layout: the bytes up to the first NUL are the OBJ; whatever follows the NUL is
//! an MTL library, written to `dir/m.mtl` and named by an `mtllib m.mtl` line put in
//! front of the OBJ (so the OBJ's line numbers in messages are one higher). Without a
//! NUL there is no folder: `mtllib` lines are skipped with a warning.
//!
//! Every step either succeeds or returns an error; a panic, an abort (an allocation that
//! is too large), a hang or a broken invariant below is a finding.

use std::path::Path;

use glam::Vec3;
use meshtracer::render_settings::RenderSettings;
use meshtracer::scene::obj::{
    load_obj_from_str, load_obj_from_str_chunked, load_obj_from_str_tobj, LoadOptions, LoadedObj,
    ObjError,
};
use meshtracer::scene::paper::{paper_scene, prepare_mesh, LightOrbit, MAX_MODELS, MODEL_RADIUS};
use meshtracer::tracer::{cpu, FrameParams, PackedScene};

/// Inputs longer than this are ignored, so that every run stays fast.
pub const MAX_INPUT: usize = 64 * 1024;

/// How far an input got.
#[derive(Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Longer than [`MAX_INPUT`].
    TooLong,
    /// The OBJ part is not UTF-8 (the file loader's `NotText` error; not fed further).
    NotUtf8,
    /// The loader refused it with this message.
    Refused(String),
    /// Loaded, packed, BVHs validated, a small frame traced: this many triangles.
    Traced(usize),
}

/// Run `data` through loader, scene builder, packer (BVH build), BVH validation and a
/// tiny CPU frame; `dir` is a private scratch folder for the MTL part. Panics when an
/// invariant breaks.
pub fn run(data: &[u8], dir: &Path) -> Outcome {
    if data.len() > MAX_INPUT {
        return Outcome::TooLong;
    }
    let (obj, mtl) = match data.iter().position(|&b| b == 0) {
        Some(i) => (&data[..i], Some(&data[i + 1..])),
        None => (data, None),
    };
    let Ok(obj) = std::str::from_utf8(obj) else { return Outcome::NotUtf8 };
    let loaded = match mtl {
        Some(mtl) => {
            std::fs::write(dir.join("m.mtl"), mtl).expect("the scratch folder is writable");
            let text = format!("mtllib m.mtl\n{obj}");
            check_against_tobj(&text, Some(dir));
            load_obj_from_str(&text, "fuzz.obj", Some(dir))
        }
        None => {
            check_against_tobj(obj, None);
            load_obj_from_str(obj, "fuzz.obj", None)
        }
    };
    let mut mesh = match loaded {
        Ok(l) => l.mesh,
        Err(e) => {
            check_message(&e);
            return Outcome::Refused(e.to_string());
        }
    };
    check_mesh(&mesh);

    let before = mesh.bounds();
    prepare_mesh(&mut mesh);
    for (i, p) in mesh.positions.iter().enumerate() {
        assert!(p.is_finite(), "vertex {i} is {p} after normalisation");
    }
    if before.extent().max_element() > 0.0 {
        // Normalised to MODEL_RADIUS: neither collapsed to a point nor blown up.
        let half = mesh.bounds().extent().max_element() * 0.5;
        assert!(
            half > 0.0 && half <= 2.0 * MODEL_RADIUS,
            "a model over {before:?} has half-extent {half} after normalisation"
        );
    }
    let models = 1 + (data.len() as u32 % MAX_MODELS);
    let scene = paper_scene(mesh, models, LightOrbit::default());
    let packed = PackedScene::new(&scene);

    let mut total = 0;
    for (mesh, pm) in scene.meshes.iter().zip(&packed.meshes) {
        let corners: Vec<[Vec3; 3]> = (0..mesh.triangle_count()).map(|i| mesh.corners(i)).collect();
        if let Err(e) = pm.bvh(&packed).validate(&corners) {
            panic!("invalid BVH for {} ({} triangles): {e}", mesh.name, corners.len());
        }
        // Every triangle packed exactly once, its prim id its file-order index.
        let range = pm.triangle_base as usize..(pm.triangle_base + pm.triangle_count) as usize;
        let mut prims: Vec<u32> = packed.triangles[range].iter().map(|t| t.prim).collect();
        prims.sort_unstable();
        assert!(
            prims.iter().copied().eq(0..mesh.triangle_count() as u32),
            "prim ids of {} are not 0..{}",
            mesh.name,
            mesh.triangle_count()
        );
        total += mesh.triangle_count();
    }
    assert_eq!(packed.triangles.len(), total);
    assert_eq!(packed.shading.len(), total);
    let vertices = packed.vertices.normals.len() as u32;
    assert!(
        packed.shading.iter().flat_map(|s| s.corners).all(|k| k < vertices),
        "a corner names a vertex past the end"
    );
    assert_eq!(packed.top_level.instances.len(), scene.instances.len());
    let material_count = packed.materials.len() as u32;
    assert!(
        packed.shading.iter().all(|s| s.material < material_count),
        "a triangle names a material past the end"
    );

    // A few rays through the fresh BVH: primary and one bounce.
    let settings = RenderSettings { width: 4, height: 4, bounces: 1, ..Default::default() };
    let image = cpu::render(&packed, &FrameParams::new(&scene, settings));
    for p in &image.pixels {
        assert!(p.iter().all(|c| c.is_finite()), "a traced pixel is {p:?}");
    }
    Outcome::Traced(scene.meshes[0].triangle_count())
}

/// The parallel parse, in one chunk and cut at every line, gives exactly what the serial
/// tobj loader it replaced gives: the same mesh and warnings, or the same message.
fn check_against_tobj(text: &str, dir: Option<&Path>) {
    let outcome = |r: Result<LoadedObj, ObjError>| match r {
        Ok(l) => format!("{:?}\n{:?}", l.mesh, l.warnings),
        Err(e) => format!("error: {e}"),
    };
    let options = LoadOptions::default();
    let expected = outcome(load_obj_from_str_tobj(text, "fuzz.obj", dir, &options));
    let whole = outcome(load_obj_from_str_chunked(text, "fuzz.obj", dir, &options, usize::MAX));
    assert_eq!(whole, expected, "the parallel parse in one chunk differs from tobj");
    let chunked = outcome(load_obj_from_str_chunked(text, "fuzz.obj", dir, &options, 1));
    assert_eq!(chunked, expected, "the parallel parse cut at every line differs from tobj");
}

/// The loader's message is one line naming the file.
fn check_message(e: &ObjError) {
    let msg = e.to_string();
    assert!(!msg.contains('\n'), "the message is more than one line: {msg:?}");
    assert!(msg.contains("fuzz.obj") || msg.contains("m.mtl"), "the message names no file: {msg}");
}

/// What the loader promises about a mesh it returns.
fn check_mesh(mesh: &meshtracer::scene::Mesh) {
    let n = mesh.positions.len();
    assert!(mesh.triangle_count() > 0, "a loaded mesh has no triangles");
    assert!(!mesh.materials.is_empty(), "a loaded mesh has no material");
    assert_eq!(mesh.triangle_materials.len(), mesh.triangle_count());
    assert_eq!(mesh.normals.len(), n, "one normal per vertex");
    assert!(
        mesh.texcoords.is_empty() || mesh.texcoords.len() == n,
        "texcoords for some vertices only"
    );
    for (i, t) in mesh.triangles.iter().enumerate() {
        assert!(
            t.iter().all(|&k| (k as usize) < n),
            "triangle {i} {t:?} indexes past {n} vertices"
        );
    }
    let materials = mesh.materials.len() as u32;
    assert!(
        mesh.triangle_materials.iter().all(|&m| m < materials),
        "a triangle's material is out of range"
    );
    assert!(mesh.positions.iter().all(|p| p.is_finite()), "a loaded vertex is not finite");
    assert!(mesh.normals.iter().all(|v| v.is_finite()), "a loaded normal is not finite");
}
