//! Files in, files out (#29), as a user or an attacker meets them on the command line:
//! nothing a file can do crashes the tool or eats the machine (a compressed PNG text bomb,
//! a link to /dev/zero, a FIFO), a failed write costs the user no file and leaves no
//! half-written one, warnings are printed once, and text from a file cannot drive the
//! terminal.

mod common;

use std::path::Path;
use std::process::{Command, Output};

use common::Scratch;

/// `meshtracer ARGS` in `dir` under the validation layer, with a clean log setting.
fn run_in(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_meshtracer"))
        .current_dir(dir)
        .env("MESHTRACER_VALIDATION", "1")
        .env_remove("RUST_LOG")
        .args(args)
        .output()
        .unwrap()
}

/// The same through `sh`, with the file-size limit at `blocks` KiB and SIGXFSZ ignored, so
/// a write past it fails as a full disk does instead of killing the process.
fn run_size_limited(dir: &Path, blocks: u32, args: &[&str]) -> Output {
    let script = format!("trap '' XFSZ; ulimit -f {blocks}; exec \"$0\" \"$@\"");
    Command::new("sh")
        .current_dir(dir)
        .env("MESHTRACER_VALIDATION", "1")
        .arg("-c")
        .arg(script)
        .arg(env!("CARGO_BIN_EXE_meshtracer"))
        .args(args)
        .output()
        .unwrap()
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// A 1x1 PNG whose `meshtracer` text chunk is zlib-compressed from `text_bytes` spaces.
fn png_with_compressed_settings(text_bytes: usize) -> Vec<u8> {
    let mut bytes = Vec::new();
    let mut encoder = png::Encoder::new(&mut bytes, 1, 1);
    encoder.set_color(png::ColorType::Rgba);
    encoder.add_ztxt_chunk("meshtracer".into(), " ".repeat(text_bytes)).unwrap();
    let mut writer = encoder.write_header().unwrap();
    writer.write_image_data(&[0, 0, 0, 255]).unwrap();
    writer.finish().unwrap();
    bytes
}

#[test]
fn a_png_text_bomb_as_preset_is_refused_without_inflating_it() {
    let dir = Scratch::new("bomb");
    // 64 MiB of text in ~64 KiB of file: over the 1 MiB bound on a preset's text (the old
    // reader inflated whatever a chunk claimed; from 4 GiB it aborted the process).
    let png = png_with_compressed_settings(64 << 20);
    assert!(png.len() < 1 << 20, "the bomb is small: {} bytes", png.len());
    std::fs::write(dir.join("bomb.png"), png).unwrap();
    // A text just over the bound says the same (it said "Out of decompression space. Try
    // with a larger limit."), and so does one stored uncompressed.
    std::fs::write(dir.join("over.png"), png_with_compressed_settings((1 << 20) + 1)).unwrap();
    let mut plain = Vec::new();
    let mut encoder = png::Encoder::new(&mut plain, 1, 1);
    encoder.set_color(png::ColorType::Rgba);
    encoder.add_text_chunk("meshtracer".into(), " ".repeat((1 << 20) + 1)).unwrap();
    let mut writer = encoder.write_header().unwrap();
    writer.write_image_data(&[0, 0, 0, 255]).unwrap();
    writer.finish().unwrap();
    std::fs::write(dir.join("plain.png"), plain).unwrap();
    for name in ["bomb.png", "over.png", "plain.png"] {
        let out = run_in(&dir.0, &["render", "--preset", name, "-o", "x.png"]);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{err}");
        assert_eq!(
            err.trim(),
            format!("error: preset {name}: the preset text in the PNG is over the limit of 1048576 bytes (a preset is a page of text)")
        );
        assert!(!dir.join("x.png").exists());
    }
}

#[test]
fn a_preset_must_be_a_regular_file_of_sensible_size() {
    let dir = Scratch::new("preset-size");
    std::os::unix::fs::symlink("/dev/zero", dir.join("zero.toml")).unwrap();
    let fifo = dir.join("fifo.toml");
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    std::fs::write(dir.join("big.toml"), format!("version = 1\n#{}\n", "x".repeat(2 << 20)))
        .unwrap();
    for (name, why) in [
        ("zero.toml", "not a regular file"),
        ("fifo.toml", "not a regular file"),
        ("big.toml", "larger than 1 MiB"),
    ] {
        let out = run_in(&dir.0, &["render", "--preset", name, "-o", "x.png"]);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{name}: {err}");
        assert!(
            err.starts_with(&format!("error: cannot read the preset {name}: "))
                && err.contains(why),
            "{name}: {err}"
        );
    }
}

#[test]
fn a_fifo_as_model_is_refused_at_once() {
    let dir = Scratch::new("fifo-model");
    assert!(Command::new("mkfifo").arg(dir.join("m.obj")).status().unwrap().success());
    // The old loader opened the file before checking it and waited for a writer forever.
    let out = run_in(
        &dir.0,
        &["render", "--model", "m.obj", "--width", "8", "--height", "8", "-o", "x.png"],
    );
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("m.obj") && err.contains("not a regular file"), "{err}");
}

#[test]
fn a_file_size_limit_is_named_before_the_vulkan_driver_meets_it() {
    // Lavapipe backs GPU memory with files, which a 1 KiB limit stops: the system then ends
    // the process (SIGXFSZ; a bus error where the signal is ignored), and the program has said
    // first what the limit is.
    let dir = Scratch::new("size-limit-gpu");
    let script = "ulimit -f 1; exec \"$0\" \"$@\"";
    let out = Command::new("sh")
        .current_dir(&dir.0)
        .env("MESHTRACER_VALIDATION", "1")
        .arg("-c")
        .arg(script)
        .arg(env!("CARGO_BIN_EXE_meshtracer"))
        .args(["render", "--width", "64", "--height", "64", "-o", "x.png"])
        .output()
        .unwrap();
    let err = stderr(&out);
    // (512 or 1024 bytes: a block of `ulimit -f` is either, shell by shell.)
    let first = err.lines().next().unwrap_or_default();
    assert!(
        first.starts_with("warning: the file-size limit (ulimit -f) is ")
            && (first.contains("1024 bytes;") || first.contains("512 bytes;")),
        "{err}"
    );
}

#[test]
fn a_failed_write_keeps_the_users_file_and_leaves_nothing_half_written() {
    let dir = Scratch::new("failed-write");
    let old = b"the user's own file, not to be lost".to_vec();
    for (out_name, aov) in [
        ("shot.png", "color"),
        ("shot.jpg", "color"),
        ("depth.exr", "depth"),
        ("normal.exr", "normal"),
    ] {
        std::fs::write(dir.join(out_name), &old).unwrap();
        // 1 KiB: the 64x64 image's file does not fit. The CPU tracer traces it: lavapipe's
        // own memory files would meet the limit first.
        let out = run_size_limited(
            &dir.0,
            1,
            &["render", "--cpu", "--width", "64", "--height", "64", "--aov", aov, "-o", out_name],
        );
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{out_name}: {err}");
        assert!(err.starts_with(&format!("error: cannot write {out_name}: ")), "{out_name}: {err}");
        assert!(!err.contains("decoding"), "a write is no decoding: {err}");
        assert_eq!(
            std::fs::read(dir.join(out_name)).unwrap(),
            old,
            "{out_name} was changed by a failed write"
        );
        assert_eq!(dir.names(), [out_name.to_string()], "a temporary was left behind");
        std::fs::remove_file(dir.join(out_name)).unwrap();
    }
    // A link to a device is refused and kept (the old EXR writer unlinked it).
    std::os::unix::fs::symlink("/dev/full", dir.join("full.exr")).unwrap();
    let out = run_in(
        &dir.0,
        &["render", "--width", "8", "--height", "8", "--aov", "depth", "-o", "full.exr"],
    );
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert!(std::fs::symlink_metadata(dir.join("full.exr")).unwrap().file_type().is_symlink());
}

#[test]
fn the_output_path_is_checked_before_tracing() {
    let dir = Scratch::new("output-first");
    // A big brute-force frame that would take minutes on lavapipe: the error comes first.
    let out = run_in(
        &dir.0,
        &[
            "render",
            "--width",
            "4096",
            "--height",
            "4096",
            "--accel",
            "brute",
            "--spp",
            "64",
            "-o",
            "no/such/folder/x.png",
        ],
    );
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.starts_with("error: cannot write no/such/folder/x.png: no such file or directory"),
        "{err}"
    );
    assert!(dir.names().is_empty());
}

#[test]
fn a_fifo_as_output_is_refused_before_loading_and_never_opened() {
    let dir = Scratch::new("fifo-output");
    assert!(Command::new("mkfifo").arg(dir.join("fifo.png")).status().unwrap().success());
    // The model is missing too: an error about the output shows that it was checked before
    // anything was loaded or traced (it used to be refused by the write, after the trace).
    // Opening the FIFO would wait for a reader forever.
    let out = run_in(
        &dir.0,
        &["render", "--model", "missing.obj", "--width", "8", "--height", "8", "-o", "fifo.png"],
    );
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert_eq!(err.trim(), "error: cannot write fifo.png: it is not a regular file");
    assert_eq!(dir.names(), ["fifo.png"], "nothing is left beside it");
}

#[test]
fn a_fifo_as_texture_is_named_as_not_a_regular_file() {
    let dir = Scratch::new("fifo-texture");
    let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl a\nf 1/1 2/2 3/3\n";
    std::fs::write(dir.join("m.obj"), obj).unwrap();
    std::fs::write(dir.join("m.mtl"), "newmtl a\nKd 1 1 1\nmap_Kd tex.png\n").unwrap();
    assert!(Command::new("mkfifo").arg(dir.join("tex.png")).status().unwrap().success());
    // It was "not found", as if the name were wrong; it is never opened.
    let out = run_in(
        &dir.0,
        &["render", "--cpu", "--model", "m.obj", "--width", "8", "--height", "8", "-o", "x.png"],
    );
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    assert_eq!(
        err.trim(),
        "warning: cannot read texture tex.png: not a regular file; using the material's Kd instead"
    );
}

#[test]
fn loader_warnings_are_printed_once_and_file_text_cannot_drive_the_terminal() {
    let dir = Scratch::new("warnings");
    // A usemtl name with an escape sequence (set the window title, ring the bell) and a
    // very long one: quoted escaped and cut, each warning on one line, once.
    let long = "m".repeat(50_000);
    let obj = format!("v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl evil\x1b]0;pwned\x07name\nf 1 2 3\nusemtl {long}\nf 3 2 1\n");
    std::fs::write(dir.join("m.obj"), obj).unwrap();
    let out = run_in(
        &dir.0,
        &["render", "--model", "m.obj", "--width", "8", "--height", "8", "-o", "x.png"],
    );
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    let warnings: Vec<&str> = err.lines().filter(|l| l.contains("usemtl")).collect();
    assert_eq!(warnings.len(), 2, "each warning once:\n{err}");
    assert!(warnings.iter().all(|w| w.starts_with("warning: m.obj: `usemtl ")), "{err}");
    assert!(
        !err.contains('\x1b') && !err.contains('\x07'),
        "control characters reached the terminal: {err:?}"
    );
    assert!(warnings[0].contains("evil\\u{1b}]0;pwned\\u{7}name"), "{}", warnings[0]);
    assert!(
        warnings[1].len() < 1000,
        "a 50,000-character name is cut: {} characters",
        warnings[1].len()
    );
}

#[test]
fn bad_numbers_in_a_preset_say_what_is_wrong() {
    let dir = Scratch::new("numbers");
    for (text, expect) in [
        ("version = 1\n[camera]\nfov = 1e308\n", "1e308 is out of range (1..179 degrees)"),
        ("version = 1\n[light]\nradius = -1e30\n", "-1e30 is out of range (0..=100)"),
        ("version = 1\n[light]\nangle = 1e300\n", "1e300 is too large"),
    ] {
        std::fs::write(dir.join("p.toml"), text).unwrap();
        let out = run_in(&dir.0, &["render", "--preset", "p.toml", "-o", "x.png"]);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{text}: {err}");
        assert!(err.contains(expect), "{text}: {err}");
    }
    // "1 bounce", not "1 bounces".
    let out = run_in(
        &dir.0,
        &["render", "--width", "8", "--height", "8", "--bounces", "1", "-o", "x.png"],
    );
    assert!(
        String::from_utf8_lossy(&out.stdout).contains(" 1 bounce,"),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
}
