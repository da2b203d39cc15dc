//! Hostile glTF files (issue #45): what a file names outside itself (external buffers and
//! images as a FIFO, `/dev/zero`, a link to it, a folder), declared sizes its bytes cannot
//! back (buffers, accessors, compressed views, chunk lengths, an image's pixel count), each
//! refused in one sentence naming what, never a hang or an allocation the file asked for.
//! The last test loads them all in the real binary under a 2 GiB address-space limit.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::Scratch;
use meshtracer::scene::formats::load_model;
use meshtracer::scene::obj::LoadOptions;
use meshtracer::scene::paper::ModelSource;

/// A triangle (36 bytes of positions) whose buffer is `buffer` (JSON), with `extra` JSON
/// after the asset (a material, textures, images).
fn triangle_doc(buffer: &str, extra: &str) -> String {
    let material = if extra.is_empty() { "" } else { r#", "material": 0"# };
    format!(
        r#"{{"asset": {{"version": "2.0"}}{extra},
  "nodes": [{{"mesh": 0}}], "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}{material}}}]}}],
  "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"}}],
  "bufferViews": [{{"buffer": 0, "byteLength": 36}}],
  "buffers": [{buffer}]}}"#
    )
}

fn triangle_bin() -> Vec<u8> {
    [0f32, 0., 0., 1., 0., 0., 0., 1., 0.].iter().flat_map(|v| v.to_le_bytes()).collect()
}

/// A textured triangle whose image is `uri`, its buffer `tri.bin` beside it.
fn textured(uri: &str) -> String {
    triangle_doc(
        r#"{"uri": "tri.bin", "byteLength": 36}"#,
        &format!(
            r#", "materials": [{{"pbrMetallicRoughness": {{"baseColorTexture": {{"index": 0}}}}}}],
  "textures": [{{"source": 0}}], "images": [{{"uri": "{uri}"}}]"#
        ),
    )
}

/// Loading `path` on another thread, failing the test if it takes more than 20 s.
fn load_within_time(path: &Path) -> Result<meshtracer::scene::formats::LoadedModel, String> {
    let path = path.to_owned();
    let (send, receive) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let loaded = load_model(&ModelSource::File(path), &LoadOptions::default(), None);
        let _ = send.send(loaded.map_err(|e| e.to_string()));
    });
    receive.recv_timeout(Duration::from_secs(20)).expect("the load ends within 20 s")
}

/// A scratch folder holding the hostile files, and what each must say (None: it loads,
/// with a warning containing the text that follows instead).
fn hostile_files(dir: &Scratch) -> Vec<(PathBuf, Result<&'static str, &'static str>)> {
    std::fs::write(dir.join("tri.bin"), triangle_bin()).unwrap();
    // A buffer file far larger than its byteLength: only the declared bytes are read.
    let mut big = triangle_bin();
    big.resize(64 << 20, 0);
    std::fs::write(dir.join("big.bin"), big).unwrap();
    assert!(Command::new("mkfifo").arg(dir.join("fifo.bin")).status().unwrap().success());
    assert!(Command::new("mkfifo").arg(dir.join("fifo.png")).status().unwrap().success());
    std::os::unix::fs::symlink("/dev/zero", dir.join("zero.bin")).unwrap();
    std::os::unix::fs::symlink("/dev/zero", dir.join("zero.png")).unwrap();
    std::fs::create_dir(dir.join("folder.bin")).unwrap();
    std::fs::write(dir.join("huge.png"), png_claiming(60_000, 60_000)).unwrap();
    let external = |uri: &str, length: u64| {
        triangle_doc(&format!(r#"{{"uri": "{uri}", "byteLength": {length}}}"#), "")
    };
    let cases: Vec<(&str, String, Result<&str, &str>)> = vec![
        ("fifo.gltf", external("fifo.bin", 36), Err("it is not a regular file")),
        ("zero.gltf", external("zero.bin", 36), Err("it is not a regular file")),
        ("devzero.gltf", external("/dev/zero", 36), Err("it is not a regular file")),
        ("folder.gltf", external("folder.bin", 36), Err("it is a directory")),
        (
            "length.gltf",
            external("tri.bin", 1_000_000_000_000_000),
            Err("buffer 0 holds 36 bytes, but its byteLength is 1000000000000000"),
        ),
        ("big.gltf", external("big.bin", 36), Ok("")),
        (
            "data length.gltf",
            triangle_doc(
                r#"{"uri": "data:application/octet-stream;base64,AAAA", "byteLength": 1000000000000}"#,
                "",
            ),
            Err("buffer 0 holds 3 bytes, but its byteLength is 1000000000000"),
        ),
        ("fifo image.gltf", textured("fifo.png"), Ok("which cannot be read (not a regular file)")),
        ("zero image.gltf", textured("zero.png"), Ok("which cannot be read (not a regular file)")),
    ];
    let mut out = Vec::new();
    for (name, text, expected) in cases {
        std::fs::write(dir.join(name), text).unwrap();
        out.push((dir.join(name), expected));
    }
    // A GLB whose header claims 4 GB, and one whose chunk does.
    let mut glb = b"glTF".to_vec();
    glb.extend([2u32, u32::MAX].iter().flat_map(|w| w.to_le_bytes()));
    std::fs::write(dir.join("header.glb"), &glb).unwrap();
    out.push((dir.join("header.glb"), Err("the .glb header gives a length of 4294967295 bytes")));
    let mut chunk = b"glTF".to_vec();
    chunk.extend([2u32, 24, u32::MAX - 8, 0x4E4F_534A, 0].iter().flat_map(|w| w.to_le_bytes()));
    std::fs::write(dir.join("chunk.glb"), &chunk).unwrap();
    out.push((dir.join("chunk.glb"), Err("claims 4294967287 bytes, past the end of the file")));
    out
}

/// A PNG of one IHDR chunk claiming `width` x `height` RGBA8 pixels (and no pixels): a
/// decompression bomb's header.
fn png_claiming(width: u32, height: u32) -> Vec<u8> {
    fn crc32(bytes: &[u8]) -> u32 {
        let mut crc = !0u32;
        for &b in bytes {
            crc ^= b as u32;
            for _ in 0..8 {
                crc = if crc & 1 == 1 { (crc >> 1) ^ 0xEDB8_8320 } else { crc >> 1 };
            }
        }
        !crc
    }
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = b"IHDR".to_vec();
    ihdr.extend(width.to_be_bytes());
    ihdr.extend(height.to_be_bytes());
    ihdr.extend([8, 6, 0, 0, 0]);
    out.extend(13u32.to_be_bytes());
    out.extend(&ihdr);
    out.extend(crc32(&ihdr).to_be_bytes());
    out.extend([0, 0, 0, 0]);
    out.extend(b"IEND");
    out.extend(crc32(b"IEND").to_be_bytes());
    out
}

#[test]
fn files_outside_the_model_and_sizes_it_cannot_back_are_one_sentence() {
    let dir = Scratch::new("gltf-hostile");
    for (path, expected) in hostile_files(&dir) {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let started = Instant::now();
        let result = load_within_time(&path);
        assert!(started.elapsed() < Duration::from_secs(5), "{name} took {:?}", started.elapsed());
        match (result, expected) {
            (Err(e), Err(want)) => {
                assert!(e.starts_with(&path.display().to_string()), "{name}: {e}");
                assert!(e.contains(want), "{name}: {e}");
                assert!(!e.contains('\n'), "{name}: {e}");
            }
            (Ok(loaded), Ok(warning)) => {
                if warning.is_empty() {
                    assert!(loaded.warnings.is_empty(), "{name}: {:?}", loaded.warnings);
                } else {
                    assert!(
                        loaded.warnings.len() == 1 && loaded.warnings[0].contains(warning),
                        "{name}: {:?}",
                        loaded.warnings
                    );
                    assert_eq!(loaded.model.meshes[0].materials[0].diffuse_texture, None);
                }
            }
            (got, want) => panic!("{name}: got {:?}, expected {want:?}", got.map(|l| l.warnings)),
        }
    }
}

#[test]
fn hostile_files_are_refused_by_the_binary_under_an_address_space_limit() {
    let dir = Scratch::new("gltf-hostile-bin");
    let mut files: Vec<(PathBuf, bool)> =
        hostile_files(&dir).into_iter().map(|(p, e)| (p, e.is_err())).collect();
    // The decompression bomb as a texture: the image reader's limits refuse it, a warning.
    std::fs::write(dir.join("bomb.gltf"), textured("huge.png")).unwrap();
    files.push((dir.join("bomb.gltf"), false));
    for (path, refused) in files {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let out = dir.join("out.png");
        // 2 GiB of address space: any of the sizes these files claim would fail to allocate
        // (and abort) under it.
        let script = "ulimit -v 2097152; exec \"$0\" render --cpu --width 16 --height 16 --model \"$1\" -o \"$2\"";
        let mut child = Command::new("sh")
            .args(["-c", script, env!("CARGO_BIN_EXE_meshtracer")])
            .arg(&path)
            .arg(&out)
            .env_remove("MESHTRACER_VALIDATION")
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let started = Instant::now();
        while child.try_wait().unwrap().is_none() {
            if started.elapsed() > Duration::from_secs(60) {
                let _ = child.kill();
                panic!("{name}: still running after 60 s");
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let output = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        let code = output.status.code();
        assert!(code.is_some(), "{name}: killed by a signal: {stderr}");
        assert!(
            !stderr.contains("panicked") && !stderr.contains("memory allocation"),
            "{name}: {stderr}"
        );
        if refused {
            let errors: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error: ")).collect();
            assert!(code != Some(0) && code != Some(101), "{name}: exit {code:?}: {stderr}");
            assert_eq!(errors.len(), 1, "{name}: one error line: {stderr}");
        } else {
            assert_eq!(code, Some(0), "{name}: {stderr}");
        }
    }
}
