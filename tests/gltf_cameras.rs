//! A glTF file's cameras as viewpoints (issue #45): the default scene's perspective cameras
//! are read with their nodes' world transforms, fitted with the model, and `--file-camera N`
//! looks through one (what `render` traces and what its image's preset records); the
//! opening view stays the scene's own unless one is asked for.

mod common;

use std::process::Command;

use common::Scratch;
use glam::Vec3;
use meshtracer::scene::formats::load_model;
use meshtracer::scene::obj::LoadOptions;
use meshtracer::scene::paper::ModelSource;
use meshtracer::scene::spec::SceneSpec;

/// A 4 x 2 quad at z = 0 from (0, 0) and three cameras: a perspective one at (2, 1, 6) in
/// the world (a child of a node moved along x) looking down -z, an orthographic one, and
/// one no node of the scene uses.
const DOC: &str = r#"{"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0, 1, 3]}],
  "nodes": [{"mesh": 0}, {"translation": [1, 0, 0], "children": [2]},
            {"camera": 0, "translation": [1, 1, 6]}, {"camera": 1}, {"camera": 2}],
  "cameras": [{"type": "perspective", "perspective": {"yfov": 0.5, "znear": 0.1}},
              {"type": "orthographic", "orthographic": {"xmag": 1, "ymag": 1, "znear": 0, "zfar": 10}},
              {"type": "perspective", "perspective": {"yfov": 1.0, "znear": 0.1}}],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
  "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3"},
                {"bufferView": 1, "componentType": 5121, "count": 6, "type": "SCALAR"}],
  "bufferViews": [{"buffer": 0, "byteLength": 48}, {"buffer": 0, "byteOffset": 48, "byteLength": 6}],
  "buffers": [{"uri": "quad.bin", "byteLength": 54}]}"#;

fn write_quad(dir: &Scratch) -> std::path::PathBuf {
    let mut bin: Vec<u8> = [0f32, 0., 0., 4., 0., 0., 4., 2., 0., 0., 2., 0.]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    bin.extend([0u8, 1, 2, 0, 2, 3]);
    std::fs::write(dir.join("quad.bin"), bin).unwrap();
    std::fs::write(dir.join("cams.gltf"), DOC).unwrap();
    dir.join("cams.gltf")
}

/// Camera 0 fitted with the quad: the box's centre (2, 1, 0) to the origin and its
/// half-extent 2 to 1 (a scale of 1/2), so the eye is at (0, 0, 3), looking at the origin.
fn expected() -> (Vec3, Vec3, f32) {
    (Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, 0.5f32.to_degrees())
}

#[test]
fn perspective_cameras_are_read_placed_and_fitted_with_the_model() {
    let dir = Scratch::new("gltf-cameras");
    let path = write_quad(&dir);
    let source = ModelSource::File(path.clone());
    let loaded = load_model(&source, &LoadOptions::default(), None).unwrap();
    assert!(
        loaded.warnings.len() == 1
            && loaded.warnings[0].contains("camera 1 is not a perspective camera"),
        "{:?}",
        loaded.warnings
    );
    let cameras = &loaded.model.cameras;
    assert_eq!(cameras.len(), 1, "camera 2 is on no node of the scene");
    let (eye, target, fov) = expected();
    assert!(cameras[0].position.abs_diff_eq(eye, 1e-5), "{:?}", cameras[0]);
    assert!(cameras[0].target.abs_diff_eq(target, 1e-5), "{:?}", cameras[0]);
    assert!(cameras[0].up.abs_diff_eq(Vec3::Y, 1e-6));
    assert!((cameras[0].vfov_deg - fov).abs() < 1e-4);

    // The opening view is the scene's own; the spec picks the file's camera by number,
    // its overrides applied over it.
    let spec = SceneSpec { model: source, ..SceneSpec::default() };
    assert_eq!(spec.scene_with(loaded.model.clone()).camera, spec.camera());
    let picked = SceneSpec { file_camera: Some(1), ..spec.clone() };
    assert_eq!(picked.scene_with(loaded.model.clone()).camera, cameras[0]);
    let mut narrowed = picked.clone();
    narrowed.camera.fov = Some(20.0);
    let camera = narrowed.scene_with(loaded.model.clone()).camera;
    assert_eq!((camera.position, camera.vfov_deg), (cameras[0].position, 20.0));
}

#[test]
fn render_looks_through_a_file_camera_and_records_it_in_the_preset() {
    let dir = Scratch::new("gltf-cameras-cli");
    let path = write_quad(&dir);
    let out = dir.join("through.png");
    let run = |camera: &str, out: &std::path::Path| {
        Command::new(env!("CARGO_BIN_EXE_meshtracer"))
            .args(["render", "--cpu", "--width", "24", "--height", "16", "--file-camera", camera])
            .arg("--model")
            .arg(&path)
            .arg("-o")
            .arg(out)
            .env_remove("MESHTRACER_VALIDATION")
            .output()
            .unwrap()
    };
    let done = run("1", &out);
    assert!(done.status.success(), "{}", String::from_utf8_lossy(&done.stderr));
    let preset = meshtracer::scene::preset::read(&out).unwrap().spec;
    let (eye, target, fov) = expected();
    assert_eq!(preset.file_camera, None, "the preset holds the camera as numbers");
    assert!(preset.camera.eye.unwrap().abs_diff_eq(eye, 1e-4), "{:?}", preset.camera);
    assert!(preset.camera.target.unwrap().abs_diff_eq(target, 1e-4), "{:?}", preset.camera);
    assert!((preset.camera.fov.unwrap() - fov).abs() < 1e-3, "{:?}", preset.camera);

    let missing = run("2", &dir.join("missing.png"));
    let stderr = String::from_utf8_lossy(&missing.stderr);
    let errors: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error: ")).collect();
    assert!(!missing.status.success() && errors.len() == 1, "{stderr}");
    assert!(
        errors[0].contains("file camera 2:") && errors[0].contains("has 1 cameras"),
        "{stderr}"
    );
}
