//! The paper's brute force gives the right image on every lavapipe (#30): on a mesh big
//! enough that a pixel needs more than 65,535 triangle tests (30k triangles, 2 bounces),
//! brute force equals the BVH and the CPU reference. Mesa 22's lavapipe (Debian 12's own)
//! used to end the brute-force loop there and drew wrong images.
//!
//! Runs on the default driver always, and also on Mesa 22's lavapipe when
//! `MESHTRACER_MESA22_ICD` names its ICD file (`.ci/run` unpacks one and sets it); in CI
//! the Mesa 22 test fails without it (`common::require`).

mod common;

use std::path::Path;
use std::process::Command;

use common::Scratch;

const SCENE: [&str; 8] =
    ["--model", "torusknot:30k", "--width", "32", "--height", "32", "--bounces", "2"];

/// `meshtracer render SCENE EXTRA -o NAME` under the validation layer, on `icd` if given.
fn render(dir: &Path, icd: Option<&str>, extra: &[&str], name: &str) -> image::RgbImage {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_meshtracer"));
    cmd.current_dir(dir)
        .env("MESHTRACER_VALIDATION", "1")
        .arg("render")
        .args(SCENE)
        .args(extra)
        .args(["-o", name]);
    if let Some(icd) = icd {
        cmd.env("VK_DRIVER_FILES", icd).env("VK_ICD_FILENAMES", icd);
    }
    let out = cmd.output().unwrap();
    assert!(
        out.status.success(),
        "render {extra:?} on {icd:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    image::open(dir.join(name)).unwrap().to_rgb8()
}

/// Pixels whose largest channel difference exceeds 2/255.
fn pixels_off(a: &image::RgbImage, b: &image::RgbImage) -> usize {
    a.pixels()
        .zip(b.pixels())
        .filter(|(p, q)| p.0.iter().zip(q.0).any(|(x, y)| x.abs_diff(y) > 2))
        .count()
}

fn brute_equals_bvh_and_cpu(icd: Option<&str>, tag: &str) {
    let dir = Scratch::new(tag);
    let cpu = render(&dir.0, None, &["--cpu"], "cpu.png");
    let bvh = render(&dir.0, icd, &["--accel", "bvh"], "bvh.png");
    let brute = render(&dir.0, icd, &["--accel", "brute"], "brute.png");
    // Ties between triangles at shared edges may go either way: at most 1% of pixels.
    let tolerance = cpu.len() / 3 / 100;
    assert!(
        pixels_off(&bvh, &cpu) <= tolerance,
        "{tag}: BVH vs CPU: {} pixels off",
        pixels_off(&bvh, &cpu)
    );
    assert!(
        pixels_off(&brute, &cpu) <= tolerance,
        "{tag}: brute force vs CPU: {} pixels off",
        pixels_off(&brute, &cpu)
    );
    assert!(
        pixels_off(&brute, &bvh) <= tolerance,
        "{tag}: brute force vs BVH: {} pixels off",
        pixels_off(&brute, &bvh)
    );
}

#[test]
fn brute_force_equals_the_bvh_and_the_cpu_on_a_30k_mesh() {
    brute_equals_bvh_and_cpu(None, "default");
}

#[test]
fn brute_force_equals_the_bvh_and_the_cpu_on_mesa_22s_lavapipe() {
    let icd = std::env::var("MESHTRACER_MESA22_ICD");
    let why =
        "MESHTRACER_MESA22_ICD is not set, so Mesa 22's lavapipe is not tried (.ci/run sets it)";
    if !common::require(icd.is_ok(), why) {
        return;
    }
    let icd = icd.unwrap();
    assert!(Path::new(&icd).is_file(), "MESHTRACER_MESA22_ICD={icd} is no file");
    brute_equals_bvh_and_cpu(Some(&icd), "mesa22");
}
