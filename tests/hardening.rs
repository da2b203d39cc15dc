//! Hardening: every fault class provoked on purpose, and its message checked.
//!
//! - The validation checker itself can fail: a planted invalid call is reported by VUID.
//! - Out-of-range command-line values are refused with the allowed range.
//! - Bad model files: one line naming the file (and the line, where there is one).
//! - Scenes larger than the device allows: `SceneTooLarge` before anything is uploaded.
//! - Device loss and out-of-memory map to their own one-sentence errors (unit level only:
//!   lavapipe cannot be made to lose its device on purpose).
//! - An unwritable output path, and no Vulkan driver at all, end in one line.
//! - Every input the fuzzer ever crashed on (`tests/data/fuzz_regressions/`), and a few
//!   handcrafted nasty ones, run through the fuzz target's own pipeline.

mod common;

#[path = "../fuzz/pipeline.rs"]
mod pipeline;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::atomic::{AtomicUsize, Ordering};

use ash::vk;
use meshtracer::gpu::scene_buffers::{check_fits, SceneBuffers};
use meshtracer::gpu::{ComputeTracer, ContextOptions, GpuContext, GpuError};
use meshtracer::render_settings::RenderSettings;
use meshtracer::render_settings::MAX_RESOLUTION;
use meshtracer::scene::primitives::PaperModel;
use meshtracer::tracer::packed::{GpuTriangle, GpuTriangleShading};
use meshtracer::tracer::{FrameParams, PackedScene};

// --- helpers ---------------------------------------------------------------------------

/// A fresh, empty scratch folder, removed again when dropped.
struct Scratch(PathBuf);

impl std::ops::Deref for Scratch {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn scratch(tag: &str) -> Scratch {
    static N: AtomicUsize = AtomicUsize::new(0);
    let dir = std::env::temp_dir().join(format!(
        "meshtracer-hardening-{}-{tag}-{}",
        std::process::id(),
        N.fetch_add(1, Ordering::Relaxed)
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    Scratch(dir)
}

/// Run the real binary with `args` (and extra environment).
fn meshtracer(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_meshtracer"));
    cmd.args(args).env("RUST_BACKTRACE", "1").env_remove("MESHTRACER_VALIDATION");
    for (k, v) in env {
        cmd.env(k, v);
    }
    cmd.output().expect("the binary runs")
}

/// The error line of a failed run. Fails the test unless the run failed with exactly one
/// line of error on stderr (clap's standard `For more information, try '--help'.` hint
/// after a usage error is tolerated), without a backtrace or panic.
fn one_line_error(out: &Output, what: &str) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{what}: exited successfully; stderr: {stderr}");
    assert!(
        out.status.code().is_some_and(|c| c != 0 && c != 101),
        "{what}: exit status {:?} (101 = panic); stderr: {stderr}",
        out.status
    );
    for bad in ["panicked", "backtrace", "RUST_BACKTRACE", "internal error"] {
        assert!(!stderr.contains(bad), "{what}: stderr mentions {bad:?}: {stderr}");
    }
    let lines: Vec<&str> = stderr
        .lines()
        .filter(|l| !l.trim().is_empty() && !l.starts_with("For more information, try"))
        .collect();
    assert_eq!(lines.len(), 1, "{what}: expected one line of error, got:\n{stderr}");
    assert!(lines[0].starts_with("error: "), "{what}: {}", lines[0]);
    lines[0].to_string()
}

fn assert_mentions(line: &str, needles: &[&str], what: &str) {
    for n in needles {
        assert!(line.contains(n), "{what}: the message does not mention {n:?}: {line}");
    }
}

// --- 1. the validation checker can fail --------------------------------------------------

#[test]
fn a_planted_validation_error_is_caught_by_vuid() {
    // Its own context: the planted error must not leak into the other tests' shared one.
    let ctx = GpuContext::new(&ContextOptions::validated()).expect("a validated context");
    assert!(ctx.validation_enabled());
    assert!(
        ctx.validation_messages().is_empty(),
        "a fresh context is clean: {:?}",
        ctx.validation_messages()
    );
    // Invalid but harmless to the driver: a concurrently shared buffer that names no queue
    // family (sharingMode CONCURRENT needs queueFamilyIndexCount > 1). lavapipe ignores
    // the sharing mode, so the call itself works and the buffer is destroyed normally.
    let info = vk::BufferCreateInfo::default()
        .size(64)
        .usage(vk::BufferUsageFlags::STORAGE_BUFFER)
        .sharing_mode(vk::SharingMode::CONCURRENT);
    let buffer = unsafe { ctx.device.create_buffer(&info, None) }
        .expect("lavapipe creates the buffer anyway");
    unsafe { ctx.device.destroy_buffer(buffer, None) };
    let messages = ctx.validation_messages();
    assert!(
        !messages.is_empty(),
        "the validation layer reported nothing for an invalid VkBufferCreateInfo"
    );
    let caught = messages.iter().find(|m| m.contains("VUID-VkBufferCreateInfo-sharingMode-"));
    let caught = caught
        .unwrap_or_else(|| panic!("no message names the VUID of the planted error: {messages:#?}"));
    eprintln!("the planted error was reported as: {caught}");
}

// --- 2. out-of-range command-line values ---------------------------------------------------

#[test]
fn out_of_range_flags_are_refused_with_the_allowed_range() {
    let cases: &[(&[&str], &[&str])] = &[
        (&["--width", "0"], &["--width", "1..=8192"]),
        (&["--width", "100000"], &["--width", "1..=8192"]),
        (&["--height", "0"], &["--height", "1..=8192"]),
        (&["--bounces", "1000"], &["--bounces", "0..=8"]),
        (&["--blend", "7"], &["--blend", "0..=1"]),
        (&["--blend", "NaN"], &["--blend", "0..=1"]),
        (&["--blend=-0.5"], &["--blend", "0..=1"]),
        (&["--models", "0"], &["--models", "1..=10000"]),
        (&["--models", "10001"], &["--models", "1..=10000"]),
        (&["--spp", "0"], &["--spp", "1..=64"]),
        (&["--spp", "65"], &["--spp", "1..=64"]),
        (&["--light-angle", "inf"], &["--light-angle", "finite"]),
        (&["--light-angle", "NaN"], &["--light-angle", "finite"]),
        (&["--fov", "180"], &["--fov", "1..179"]),
        (&["--eye", "1,2,nan"], &["--eye", "finite"]),
        (&["--crease-angle", "200"], &["--crease-angle", "0..=180"]),
        (&["--crease-angle", "-5"], &["--crease-angle", "0..=180"]),
    ];
    let dir = scratch("flags");
    let out_path = dir.join("never.png");
    for (flags, needles) in cases {
        let mut args = vec!["render", "--cpu", "-o", out_path.to_str().unwrap()];
        args.extend_from_slice(flags);
        let what = flags.join(" ");
        let line = one_line_error(&meshtracer(&args, &[]), &what);
        assert_mentions(&line, needles, &what);
    }
    assert!(!out_path.exists(), "a refused command wrote its output");
}

// --- 3. bad model files through the binary ---------------------------------------------------

#[test]
fn bad_model_files_end_in_one_line_naming_the_file_and_line() {
    let dir = scratch("files");
    let garbage: Vec<u8> =
        (0..512u32).map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8 | 0x80).collect();
    std::fs::write(dir.join("garbage.obj"), garbage).unwrap();
    std::fs::write(dir.join("index.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n\nf 1 2 9\n")
        .unwrap();
    std::fs::write(dir.join("truncated.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nv 1 2").unwrap();
    std::fs::write(dir.join("cut.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2").unwrap();
    std::fs::write(dir.join("nan.obj"), "v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    std::fs::write(dir.join("empty.obj"), "").unwrap();
    std::fs::create_dir(dir.join("folder.obj")).unwrap();
    let path = |n: &str| dir.join(n).to_str().unwrap().to_owned();
    let cases: Vec<(String, Vec<String>)> = vec![
        (path("missing.obj"), vec![path("missing.obj"), "No such file".into()]),
        (path("folder.obj"), vec![path("folder.obj"), "directory".into()]),
        (
            path("garbage.obj"),
            vec![path("garbage.obj"), "not an OBJ text file".into(), "line 1".into()],
        ),
        (
            path("index.obj"),
            vec![path("index.obj"), "line 6".into(), "index 9 is out of range".into()],
        ),
        (path("truncated.obj"), vec![path("truncated.obj"), "line 5".into(), "cut short".into()]),
        (path("cut.obj"), vec![path("cut.obj"), "line 4".into(), "cut short".into()]),
        (path("nan.obj"), vec![path("nan.obj"), "line 2".into(), "not a finite number".into()]),
        (path("empty.obj"), vec![path("empty.obj"), "no faces".into()]),
    ];
    let out_path = dir.join("out.png");
    for (model, needles) in &cases {
        let out = meshtracer(
            &[
                "render",
                "--cpu",
                "--width",
                "8",
                "--height",
                "8",
                "--model",
                model,
                "-o",
                out_path.to_str().unwrap(),
            ],
            &[],
        );
        let line = one_line_error(&out, model);
        let needles: Vec<&str> = needles.iter().map(String::as_str).collect();
        assert_mentions(&line, &needles, model);
    }
    assert!(!out_path.exists());
}

// --- 4. scenes too large for the device ------------------------------------------------------

/// Bytes the triangle buffer holds beyond its triangles (the shaders' read-ahead).
const READ_AHEAD: u64 = meshtracer::contract::TRIANGLE_READ_AHEAD as u64;

/// A packed scene whose triangle buffer (its triangles and the read-ahead) is one triangle
/// over `limit` bytes (no BVH: the check comes before anything reads it).
fn oversized_triangles(limit: u64) -> PackedScene {
    let n = ((limit - READ_AHEAD) / std::mem::size_of::<GpuTriangle>() as u64 + 1) as usize;
    let mut packed = PackedScene::default();
    packed.triangles = vec![GpuTriangle::default(); n];
    packed
}

#[test]
fn a_scene_over_the_storage_buffer_range_is_refused_before_upload() {
    let ctx = common::ctx();
    let limit = ctx.info.max_storage_buffer_range;
    assert!(limit >= 1 << 20, "implausible maxStorageBufferRange {limit}");
    // Keep the test cheap: a device with a huge range would need a huge array.
    assert!(limit <= 1 << 31, "maxStorageBufferRange {limit} is too large to provoke cheaply");

    let packed = oversized_triangles(limit);
    let bytes = std::mem::size_of_val(packed.triangles.as_slice()) as u64 + READ_AHEAD;
    let check = |r: Result<(), GpuError>, what: &str| match r {
        Err(GpuError::SceneTooLarge { buffer, bytes: b, limit: l }) => {
            assert_eq!((buffer, b, l), ("triangle", bytes, limit), "{what}");
        }
        Err(e) => panic!("{what}: expected SceneTooLarge, got: {e}"),
        Ok(()) => {
            panic!("{what}: a {bytes}-byte triangle buffer was accepted with a {limit}-byte limit")
        }
    };
    check(check_fits(&ctx, &packed), "check_fits");
    check(SceneBuffers::upload(&ctx, &packed).map(drop), "SceneBuffers::upload");
    let err = ComputeTracer::with_scene(&ctx, &packed)
        .err()
        .expect("ComputeTracer::new refuses the scene");
    check(Err(err), "ComputeTracer::with_scene");
    let msg = ComputeTracer::with_scene(&ctx, &packed).err().unwrap().to_string();
    assert_mentions(&msg, &["triangle buffer", &bytes.to_string(), &limit.to_string()], "message");
    assert!(!msg.contains('\n'), "{msg}");

    // The shading array is checked too (16 bytes a triangle: over the limit first).
    let mut packed = PackedScene::default();
    packed.triangles = vec![GpuTriangle::default(); 1];
    packed.shading = vec![GpuTriangleShading::default(); (limit / 16 + 1) as usize];
    match check_fits(&ctx, &packed) {
        Err(GpuError::SceneTooLarge { buffer, .. }) => assert_eq!(buffer, "shading"),
        other => panic!("oversized shading array: {other:?}"),
    }
    common::assert_validation_clean(&ctx);
}

#[test]
fn a_scene_at_the_storage_buffer_range_is_accepted_by_the_check() {
    let ctx = common::ctx();
    let limit = ctx.info.max_storage_buffer_range;
    let mut packed = PackedScene::default();
    packed.triangles = vec![
        GpuTriangle::default();
        ((limit - READ_AHEAD) / std::mem::size_of::<GpuTriangle>() as u64)
            as usize
    ];
    check_fits(&ctx, &packed).expect("a triangle buffer within the limit fits");
}

#[test]
fn an_output_image_over_the_storage_buffer_range_is_refused() {
    // The float output holds 16 bytes a pixel: at the largest resolution the flags allow
    // (8192 x 8192, 1 GiB) it exceeds lavapipe's 128 MiB storage-buffer range. Binding it
    // anyway is invalid Vulkan; it must be refused with a message instead. Its own
    // context, so that a failure here does not leak messages into the other tests.
    let ctx = GpuContext::new(&ContextOptions::validated()).expect("a validated context");
    let limit = ctx.info.max_storage_buffer_range;
    let width = 4096u32;
    let height =
        u32::try_from(limit / 16 / width as u64 + 8).unwrap_or(u32::MAX).min(MAX_RESOLUTION);
    let bytes = width as u64 * height as u64 * 16;
    let why = format!("this device's storage-buffer range ({limit} bytes) holds any allowed image: nothing to provoke");
    if !common::require(bytes > limit, &why) {
        return;
    }
    let scene = common::paper(PaperModel::Geosphere, 1);
    let packed = PackedScene::new(&scene);
    let mut tracer = ComputeTracer::with_scene(&ctx, &packed).expect("upload");
    let mut params = FrameParams::new(
        &scene,
        RenderSettings { width, height, bounces: 0, ..RenderSettings::default() },
    );
    params.instance_count = 0; // if it does trace, every ray misses at once
    let result = tracer.trace(&params);
    let messages = ctx.validation_messages();
    drop(tracer);
    match result {
        Err(e) => {
            let msg = e.to_string();
            assert_mentions(&msg, &[&limit.to_string()], "output too large");
            assert!(!msg.contains('\n'), "{msg}");
        }
        Ok(_) => panic!(
            "a {width}x{height} frame ({bytes}-byte float output, device limit {limit}) was traced; validation said: {:?}",
            messages.first()
        ),
    }
    assert!(messages.is_empty(), "the refusal came after invalid Vulkan use: {}", messages[0]);
}

// --- 5. device loss and out-of-memory (unit level) ---------------------------------------------

#[test]
fn device_lost_and_out_of_memory_have_their_own_one_sentence_errors() {
    // The real faults are not provoked (lavapipe cannot lose its device on demand): this
    // checks the mapping every Vulkan call's error goes through.
    let lost = GpuError::vk("tracing a frame", vk::Result::ERROR_DEVICE_LOST);
    assert!(matches!(lost, GpuError::DeviceLost("tracing a frame")), "{lost:?}");
    for result in [vk::Result::ERROR_OUT_OF_DEVICE_MEMORY, vk::Result::ERROR_OUT_OF_HOST_MEMORY] {
        let oom = GpuError::vk("creating a buffer", result);
        assert!(matches!(oom, GpuError::OutOfMemory("creating a buffer")), "{result:?}: {oom:?}");
    }
    let other = GpuError::vk("creating a fence", vk::Result::ERROR_UNKNOWN);
    assert!(matches!(other, GpuError::Vulkan { what: "creating a fence", .. }), "{other:?}");
    // Through the `?`-helper as every call site uses it.
    use meshtracer::gpu::error::VkContext;
    let via: Result<(), GpuError> =
        Err(vk::Result::ERROR_DEVICE_LOST).during("waiting for the GPU");
    assert!(matches!(via, Err(GpuError::DeviceLost("waiting for the GPU"))));

    let messages = [
        (lost.to_string(), vec!["VK_ERROR_DEVICE_LOST", "tracing a frame"]),
        (
            GpuError::vk("creating a buffer", vk::Result::ERROR_OUT_OF_DEVICE_MEMORY).to_string(),
            vec!["out of memory", "creating a buffer"],
        ),
    ];
    for (msg, needles) in &messages {
        assert_mentions(msg, needles, "GpuError");
        assert!(!msg.contains('\n'), "not one line: {msg}");
        // One sentence: no full stop followed by another sentence.
        assert!(!msg.trim_end_matches('.').contains(". "), "more than one sentence: {msg}");
    }
}

// --- 6. unwritable output -------------------------------------------------------------------

#[test]
fn an_unwritable_output_path_is_one_line_naming_it() {
    // Tests run as root, so permissions do not stop a write: a path under a regular file does.
    let dir = scratch("output");
    let file = dir.join("a-file");
    std::fs::write(&file, "not a folder").unwrap();
    for name in ["x.png", "x.exr"] {
        let target = file.join(name);
        let target = target.to_str().unwrap();
        let mut args = vec!["render", "--cpu", "--width", "8", "--height", "8", "-o", target];
        if name.ends_with(".exr") {
            args.extend(["--aov", "depth"]);
        }
        let line = one_line_error(&meshtracer(&args, &[]), target);
        assert_mentions(&line, &[target, "cannot write"], target);
    }
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "not a folder");
}

// --- 7. no Vulkan driver ----------------------------------------------------------------------

#[test]
fn no_vulkan_driver_gives_the_one_line_install_hint() {
    let dir = scratch("nodriver");
    let out_path = dir.join("x.png");
    let env = [
        ("VK_ICD_FILENAMES", "/nonexistent.json"),
        ("VK_DRIVER_FILES", "/nonexistent.json"),
        ("VK_ADD_DRIVER_FILES", ""),
    ];
    for cmd in [
        &["render", "--width", "8", "--height", "8", "-o", out_path.to_str().unwrap()][..],
        &["devices"][..],
    ] {
        let what = cmd.join(" ");
        let line = one_line_error(&meshtracer(cmd, &env), &what);
        assert_mentions(&line, &["install a Vulkan driver", "lavapipe"], &what);
    }
    assert!(!out_path.exists());
}

// --- fuzz regressions and handcrafted nasty inputs --------------------------------------------

fn regressions_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/fuzz_regressions")
}

/// Run `data` through the fuzz pipeline, turning a panic into a message naming `what`.
fn replay(data: &[u8], what: &str) -> Result<pipeline::Outcome, String> {
    let dir = scratch("replay");
    let result = std::panic::catch_unwind(|| pipeline::run(data, &dir));
    result.map_err(|p| {
        let msg = p
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_default();
        format!("{what}: {msg}")
    })
}

#[test]
fn every_fuzz_regression_input_runs_through_the_pipeline() {
    let mut failures = Vec::new();
    let mut count = 0;
    let mut entries: Vec<PathBuf> = std::fs::read_dir(regressions_dir())
        .expect("tests/data/fuzz_regressions exists")
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file() && p.file_name().is_some_and(|n| n != "README.md"))
        .collect();
    entries.sort();
    for path in entries {
        count += 1;
        let data = std::fs::read(&path).unwrap();
        if let Err(e) = replay(&data, &path.display().to_string()) {
            failures.push(e);
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {count} regression inputs fail:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

/// An n-gon face over `n` vertices on a circle.
fn ngon(n: usize) -> String {
    let mut s = String::new();
    for i in 0..n {
        let a = i as f32 / n as f32 * std::f32::consts::TAU;
        s += &format!("v {} {} 0\n", a.cos(), a.sin());
    }
    s += "f";
    for i in 1..=n {
        s += &format!(" {i}");
    }
    s + "\n"
}

#[test]
fn handcrafted_nasty_inputs_are_traced_or_refused_with_a_line() {
    use pipeline::Outcome::{Refused, TooLong, Traced};
    let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    let big_polygon = ngon(1000);
    let many_identical = tri.to_string() + &"f 1 2 3\n".repeat(3000);
    let many_points = (0..2000).map(|i| format!("v {i} {i} {i}\n")).collect::<String>()
        + &"f 1 1 1\n".repeat(500);
    type Expect<'a> = &'a dyn Fn(&pipeline::Outcome) -> bool;
    let cases: Vec<(&str, Vec<u8>, Expect)> = vec![
        // Coordinates whose extent or centre overflows f32 when the model is normalised.
        ("extent overflows", b"v -3e38 -3e38 -3e38\nv 3e38 3e38 3e38\nv 3e38 -3e38 0\nf 1 2 3\n".to_vec(), &|o| matches!(o, Traced(1))),
        ("centre overflows", b"v 3e38 3e38 3e38\nv 3.4e38 3.4e38 3.4e38\nv 3.4e38 3e38 3e38\nf 1 2 3\n".to_vec(), &|o| matches!(o, Traced(1))),
        ("denormal mesh", b"v 0 0 0\nv 1e-45 0 0\nv 0 1e-45 0\nf 1 2 3\n".to_vec(), &|o| matches!(o, Traced(1))),
        ("all at one point", b"v 1 1 1\nv 1 1 1\nv 1 1 1\nf 1 2 3\nf 3 2 1\n".to_vec(), &|o| matches!(o, Traced(2))),
        // A vertex's w is a curve weight, not a divisor (#29): tiny or zero, it is ignored.
        ("w tiny", b"v 1 1 1 1e-45\nv 0 0 0\nv 1 0 0\nf 1 2 3\n".to_vec(), &|o| matches!(o, Traced(1))),
        ("w is zero", b"v 1 1 1 0\nv 0 0 0\nv 1 0 0\nf 1 2 3\n".to_vec(), &|o| matches!(o, Traced(1))),
        ("huge index", format!("{tri}f 1 2 99999999999999999999999\n").into_bytes(), &|o| matches!(o, Refused(m) if m.contains("line 4"))),
        ("far negative index", format!("{tri}f -1 -2 -9223372036854775808\n").into_bytes(), &|o| matches!(o, Refused(m) if m.contains("line 4"))),
        ("zero index", format!("{tri}f 0 1 2\n").into_bytes(), &|o| matches!(o, Refused(m) if m.contains("line 4"))),
        // Out-of-range texture coordinates and normals are left out, with a warning (#13).
        ("zero texcoord index", format!("{tri}vt 0 0\nf 1/0 2/1 3/1\n").into_bytes(), &|o| matches!(o, Traced(1))),
        ("far negative normal index", format!("{tri}vn 0 0 1\nf 1//1 2//-9223372036854775808 3//1\n").into_bytes(), &|o| matches!(o, Traced(1))),
        ("usemtl without a name", format!("{tri}f 1 2 3\nusemtl \nf 3 2 1\n").into_bytes(), &|o| matches!(o, Refused(m) if m.contains("line 5"))),
        ("only lines and points", format!("{tri}l 1 2 3\np 1\n").into_bytes(), &|o| matches!(o, Refused(m) if m.contains("no faces"))),
        ("mixed colours", b"v 0 0 0 1 0 0\nv 1 0 0\nv 0 1 0 0 0 1\nf 1 2 3\n".to_vec(), &|o| matches!(o, Refused(_) | Traced(1))),
        ("cr-only line ends", b"v 0 0 0\rv 1 0 0\rv 0 1 0\rf 1 2 3\r".to_vec(), &|o| matches!(o, Refused(_) | Traced(_))),
        ("vertical tabs and bom", "\u{feff}v\x0b0 0 0\nv 1\x0c0 0\nv 0 1 0\nf\x0b1 2 3\n".as_bytes().to_vec(), &|o| matches!(o, Traced(1))),
        ("1000-gon", big_polygon.into_bytes(), &|o| matches!(o, Traced(998))),
        ("3000 identical triangles", many_identical.into_bytes(), &|o| matches!(o, Traced(3000))),
        ("degenerate fans", many_points.into_bytes(), &|o| matches!(o, Traced(500))),
        ("not utf-8", b"v 0 0 0\xff\n".to_vec(), &|o| matches!(o, pipeline::Outcome::NotUtf8)),
        ("over the size cap", vec![b'#'; pipeline::MAX_INPUT + 1], &|o| matches!(o, TooLong)),
        // MTL part after the NUL: malformed colours, a texture that is the MTL itself,
        // a texture naming a folder and an absolute path, a nameless material.
        (
            "nasty mtl",
            format!("{tri}usemtl a\nf 1 2 3\nusemtl c\nf 3 2 1\nusemtl b\nf 1 3 2\n\0newmtl a\nKd\nKs 1\nKa nan nan nan\nNs inf\nmap_Kd m.mtl\nnewmtl\nnewmtl b\nmap_Kd -s 1 1 1 .\nmap_Kd /\nKd 1e39 0 0\n").into_bytes(),
            &|o| matches!(o, Traced(3)),
        ),
        ("mtl not utf-8", [format!("{tri}usemtl a\nf 1 2 3\n\0newmtl a\nKd 0.5 ").as_bytes(), b"\x00\xff\xfe 1\nNs 4\n"].concat(), &|o| matches!(o, Traced(1))),
        ("mtllib naming a folder", format!("mtllib .\nmtllib /\nmtllib\n{tri}f 1 2 3\n\0").into_bytes(), &|o| matches!(o, Traced(1))),
    ];
    let mut failures = Vec::new();
    for (what, data, expect) in &cases {
        match replay(data, what) {
            Ok(outcome) if expect(&outcome) => {}
            Ok(outcome) => failures.push(format!("{what}: unexpected outcome {outcome:?}")),
            Err(e) => failures.push(e),
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} nasty inputs fail:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
}
