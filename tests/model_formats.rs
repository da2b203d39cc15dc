//! The model formats beside OBJ: PLY (ASCII, binary little- and big-endian) and glTF 2.0
//! (.gltf with its .bin, and .glb). Every file is written here: the same mesh in each
//! format loads as its OBJ twin does, and broken files are one line naming the file.

mod common;

use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

use common::gltf::glb;
use glam::{Mat4, Quat, Vec3};
use meshtracer::scene::formats::{load_model, LoadError};
use meshtracer::scene::obj::{load_obj, LoadOptions, LoadedObj};
use meshtracer::scene::paper::{prepare_mesh, ModelSource};
use meshtracer::scene::Mesh;

struct TempDir(PathBuf);

impl TempDir {
    fn new(tag: &str) -> Self {
        let dir =
            std::env::temp_dir().join(format!("meshtracer-formats-{tag}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).unwrap();
        TempDir(dir)
    }

    fn write(&self, name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
        let path = self.0.join(name);
        fs::write(&path, bytes).unwrap();
        path
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = fs::remove_dir_all(&self.0);
    }
}

/// A small closed-ish shape with a triangle, a quad and a pentagon, and normals.
fn shape() -> (Vec<[f32; 6]>, Vec<Vec<u32>>) {
    let v = |p: [f32; 3], n: [f32; 3]| [p[0], p[1], p[2], n[0], n[1], n[2]];
    let verts = vec![
        v([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
        v([1.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
        v([1.0, 1.0, 0.0], [0.0, 0.6, 0.8]),
        v([0.0, 1.0, 0.0], [0.0, 0.6, 0.8]),
        v([0.5, 1.5, -0.5], [0.0, 1.0, 0.0]),
        v([1.5, 0.5, -0.5], [1.0, 0.0, 0.0]),
        v([-0.5, 0.5, -1.0], [-1.0, 0.0, 0.0]),
    ];
    let faces = vec![vec![0, 1, 2, 3], vec![3, 2, 4], vec![1, 5, 4, 2, 0], vec![6, 0, 3]];
    (verts, faces)
}

fn obj_text(verts: &[[f32; 6]], faces: &[Vec<u32>]) -> String {
    let mut s = String::from("# the OBJ twin\n");
    for v in verts {
        s += &format!("v {} {} {}\nvn {} {} {}\n", v[0], v[1], v[2], v[3], v[4], v[5]);
    }
    for f in faces {
        s += "f";
        for i in f {
            s += &format!(" {0}//{0}", i + 1);
        }
        s += "\n";
    }
    s
}

#[derive(Clone, Copy, PartialEq)]
enum Encoding {
    Ascii,
    Little,
    Big,
}

/// The shape as PLY, with a colour, an extra element and comments to skip; the binary
/// encodings use different position, count and index types.
fn ply_bytes(enc: Encoding, verts: &[[f32; 6]], faces: &[Vec<u32>]) -> Vec<u8> {
    let (format, pos_type, list) = match enc {
        Encoding::Ascii => ("ascii", "float", "list uchar int vertex_indices"),
        Encoding::Little => ("binary_little_endian", "double", "list uchar uint vertex_indices"),
        Encoding::Big => ("binary_big_endian", "float", "list ushort int vertex_index"),
    };
    let mut out = format!(
        "ply\nformat {format} 1.0\ncomment made by the test\nobj_info nothing\nelement vertex {}\n\
         property {pos_type} x\nproperty {pos_type} y\nproperty {pos_type} z\nproperty uchar red\nproperty float nx\nproperty float ny\nproperty float nz\n\
         element face {}\nproperty uchar flags\nproperty {list}\nelement edge 2\nproperty int vertex1\nproperty int vertex2\nend_header\n",
        verts.len(),
        faces.len()
    )
    .into_bytes();
    let put = |out: &mut Vec<u8>, le: Vec<u8>| {
        let mut b = le;
        if enc == Encoding::Big {
            b.reverse();
        }
        out.extend(b);
    };
    for v in verts {
        if enc == Encoding::Ascii {
            out.extend(
                format!("{} {} {} 200 {} {} {}\n", v[0], v[1], v[2], v[3], v[4], v[5]).bytes(),
            );
            continue;
        }
        for c in &v[..3] {
            if pos_type == "double" {
                put(&mut out, (*c as f64).to_le_bytes().to_vec())
            } else {
                put(&mut out, c.to_le_bytes().to_vec())
            }
        }
        out.push(200);
        for c in &v[3..] {
            put(&mut out, c.to_le_bytes().to_vec());
        }
    }
    for f in faces {
        if enc == Encoding::Ascii {
            let idx: Vec<String> = f.iter().map(u32::to_string).collect();
            out.extend(format!("7 {} {}\n", f.len(), idx.join(" ")).bytes());
            continue;
        }
        out.push(7);
        if enc == Encoding::Big {
            put(&mut out, (f.len() as u16).to_le_bytes().to_vec())
        } else {
            out.push(f.len() as u8)
        }
        for i in f {
            put(&mut out, i.to_le_bytes().to_vec());
        }
    }
    for e in [[0i32, 1], [1, 2]] {
        if enc == Encoding::Ascii {
            out.extend(format!("{} {}\n", e[0], e[1]).bytes());
        } else {
            put(&mut out, e[0].to_le_bytes().to_vec());
            put(&mut out, e[1].to_le_bytes().to_vec());
        }
    }
    out
}

fn corners(mesh: &Mesh) -> Vec<[Vec3; 3]> {
    (0..mesh.triangle_count()).map(|i| mesh.corners(i)).collect()
}

fn assert_same_geometry(a: &Mesh, b: &Mesh, what: &str) {
    let (ca, cb) = (corners(a), corners(b));
    assert_eq!(ca.len(), cb.len(), "{what}: triangle count");
    for (i, (x, y)) in ca.iter().zip(&cb).enumerate() {
        for k in 0..3 {
            assert!(
                (x[k] - y[k]).length() < 1e-5,
                "{what}: triangle {i} corner {k}: {} vs {}",
                x[k],
                y[k]
            );
        }
    }
}

/// `path` loaded as every command loads a model: fitted to the scene's size.
fn load_file(path: &Path) -> Result<LoadedObj, LoadError> {
    load_model(&ModelSource::File(path.to_owned()), &LoadOptions::default(), None)
        .map(LoadedObj::from)
}

/// The OBJ twin at `path`, read by the OBJ reader alone and fitted as a loaded model is.
fn twin(path: &Path) -> Mesh {
    let mut mesh = load_obj(path).unwrap().mesh;
    prepare_mesh(&mut mesh);
    mesh
}

fn load(path: &Path) -> Mesh {
    load_file(path).unwrap_or_else(|e| panic!("{e}")).mesh
}

#[test]
fn ply_in_every_encoding_loads_as_its_obj_twin() {
    let dir = TempDir::new("ply");
    let (verts, faces) = shape();
    let obj = twin(&dir.write("twin.obj", obj_text(&verts, &faces)));
    for (enc, name) in [
        (Encoding::Ascii, "ascii.ply"),
        (Encoding::Little, "little.ply"),
        (Encoding::Big, "BIG.PLY"),
    ] {
        let path = dir.write(name, ply_bytes(enc, &verts, &faces));
        let loaded = load_file(&path).unwrap();
        assert_same_geometry(&obj, &loaded.mesh, name);
        assert_eq!(
            loaded.mesh.triangles.len(),
            2 + 1 + 3 + 1,
            "quads split in two, pentagons in three"
        );
        assert!(loaded.mesh.has_file_normals, "{name}: nx/ny/nz are kept");
        assert!(loaded.warnings.iter().all(|w| !w.contains('\n')), "{:?}", loaded.warnings);
    }
}

#[test]
fn ply_and_obj_render_the_same_image() {
    let dir = TempDir::new("render");
    let (verts, faces) = shape();
    dir.write("twin.obj", obj_text(&verts, &faces));
    dir.write("twin.ply", ply_bytes(Encoding::Little, &verts, &faces));
    let render = |model: &str, out: &str| {
        let run = Command::new(env!("CARGO_BIN_EXE_meshtracer"))
            .current_dir(&dir.0)
            .args([
                "render", "--cpu", "--width", "32", "--height", "32", "--smooth", "--model", model,
                "-o", out,
            ])
            .output()
            .unwrap();
        assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
        image::open(dir.0.join(out)).unwrap().to_rgb8()
    };
    let (a, b) = (render("twin.obj", "obj.png"), render("twin.ply", "ply.png"));
    let worst = a.as_raw().iter().zip(b.as_raw()).map(|(x, y)| x.abs_diff(*y)).max().unwrap();
    assert!(worst <= 1, "the PLY renders unlike its OBJ twin (largest channel difference {worst})");
}

/// A quad (four vertices, two triangles by u16 indices) and a triangle without indices.
fn gltf_bin() -> (Vec<u8>, [Vec3; 4]) {
    let quad = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ];
    let mut bin = Vec::new();
    for p in quad {
        bin.extend(p.to_array().iter().flat_map(|c| c.to_le_bytes()));
    }
    for i in [0u16, 1, 2, 0, 2, 3] {
        bin.extend(i.to_le_bytes());
    }
    (bin, quad)
}

/// Node 0 moves the quad; node 1 scales and rotates it and has a child that moves it again.
fn gltf_json(bin_uri: &str, position_type: &str) -> String {
    format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "scene": 0,
  "scenes": [{{"nodes": [0, 1]}}],
  "nodes": [
    {{"mesh": 0, "translation": [2, 0, 0]}},
    {{"mesh": 0, "scale": [2, 2, 2], "rotation": [0, 0.7071068, 0, 0.7071068], "children": [2]}},
    {{"mesh": 0, "translation": [0, 0, 3]}}
  ],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1, "material": 0}}]}}],
  "materials": [{{"name": "red", "pbrMetallicRoughness": {{"baseColorFactor": [0.8, 0.1, 0.1, 1]}}}}],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 4, "type": "{position_type}", "min": [0, 0, 0], "max": [1, 1, 0]}},
    {{"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}}
  ],
  "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 48}}, {{"buffer": 0, "byteOffset": 48, "byteLength": 12}}],
  "buffers": [{{"uri": "{bin_uri}", "byteLength": 60}}]
}}"#
    )
}

#[test]
fn gltf_nodes_are_placed_by_their_world_transforms() {
    let dir = TempDir::new("gltf");
    let (bin, quad) = gltf_bin();
    dir.write("quad data.bin", &bin);
    let path = dir.write("two.gltf", gltf_json("quad%20data.bin", "VEC3"));
    let loaded = load_file(&path).unwrap();
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    assert_eq!(loaded.mesh.materials[0].name, "red");
    assert!((loaded.mesh.materials[0].diffuse - Vec3::new(0.8, 0.1, 0.1)).length() < 1e-6);

    // The OBJ twin: the quad placed by hand by each node's world matrix, in scene order.
    let node1 = Mat4::from_scale_rotation_translation(
        Vec3::splat(2.0),
        Quat::from_xyzw(0.0, std::f32::consts::FRAC_1_SQRT_2, 0.0, std::f32::consts::FRAC_1_SQRT_2),
        Vec3::ZERO,
    );
    let worlds = [
        Mat4::from_translation(Vec3::new(2.0, 0.0, 0.0)),
        node1,
        node1 * Mat4::from_translation(Vec3::new(0.0, 0.0, 3.0)),
    ];
    let mut obj = String::new();
    for (k, w) in worlds.iter().enumerate() {
        for p in quad {
            let q = w.transform_point3(p);
            obj += &format!("v {} {} {}\n", q.x, q.y, q.z);
        }
        let b = 4 * k + 1;
        obj += &format!("f {} {} {}\nf {} {} {}\n", b, b + 1, b + 2, b, b + 2, b + 3);
    }
    let twin = twin(&dir.write("twin.obj", obj));
    assert_same_geometry(&twin, &loaded.mesh, "two.gltf");

    // The same document as a .glb, the buffer in its binary chunk.
    let glb = glb(&gltf_json("", "VEC3").replace(r#""uri": "", "#, ""), &bin);
    let from_glb = load(&dir.write("two.GLB", glb));
    assert_same_geometry(&twin, &from_glb, "two.glb");
}

#[test]
fn gltf_base_colour_textures_are_paths_beside_the_file() {
    let dir = TempDir::new("gltf-tex");
    let (bin, _) = gltf_bin();
    dir.write("quad.bin", &bin);
    dir.write("wood grain.png", b"not decoded by the loader");
    let textured = |uri: &str| {
        gltf_json("quad.bin", "VEC3").replace(
            r#""materials": [{"name": "red", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.1, 0.1, 1]}}],"#,
            &format!(r#""materials": [{{"pbrMetallicRoughness": {{"baseColorTexture": {{"index": 0}}}}}}], "textures": [{{"source": 0}}], "images": [{{"uri": "{uri}"}}],"#),
        )
    };
    let loaded = load_file(&dir.write("tex.gltf", textured("wood%20grain.png"))).unwrap();
    let material = &loaded.mesh.materials[0];
    assert_eq!(
        material.diffuse_texture.as_ref().and_then(|t| t.path()),
        Some(dir.0.join("wood grain.png").as_path())
    );
    assert_eq!((material.name.as_str(), material.diffuse), ("material 0", Vec3::ONE));
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);

    for (name, uri, warning) in [
        ("missing.gltf", "nowhere.png", "the file `nowhere.png`, which is not found"),
        ("embedded.gltf", "data:image/png;base64,A@A", "a data URI that cannot be decoded"),
    ] {
        let loaded = load_file(&dir.write(name, textured(uri))).unwrap();
        assert_eq!(loaded.mesh.materials[0].diffuse_texture, None);
        assert!(
            loaded.warnings.len() == 1
                && loaded.warnings[0].contains(name)
                && loaded.warnings[0].contains(warning),
            "{:?}",
            loaded.warnings
        );
    }
}

/// The one-line error of loading `path`, which must name it and say `expected`.
fn assert_one_line_error(path: &Path, expected: &str) {
    let e = match load_file(path) {
        Ok(_) => panic!("{} loaded", path.display()),
        Err(e) => e.to_string(),
    };
    assert!(e.contains(&path.display().to_string()), "the error names the file: {e}");
    assert!(e.contains(expected), "expected `{expected}` in: {e}");
    assert!(!e.contains('\n'), "one line: {e}");
}

/// `bytes` with the first `from` replaced by `to` (binary bodies stay as they are).
fn replace_bytes(bytes: &[u8], from: &str, to: &str) -> Vec<u8> {
    let at = bytes.windows(from.len()).position(|w| w == from.as_bytes()).unwrap();
    [&bytes[..at], to.as_bytes(), &bytes[at + from.len()..]].concat()
}

#[test]
fn broken_ply_files_are_one_line_naming_the_file() {
    let dir = TempDir::new("bad-ply");
    let (verts, faces) = shape();
    let ascii = String::from_utf8(ply_bytes(Encoding::Ascii, &verts, &faces)).unwrap();
    let little = ply_bytes(Encoding::Little, &verts, &faces);
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        (
            "more.ply",
            replace_bytes(&little, "element vertex 7", "element vertex 4000000000"),
            "the header claims 4000000000 `vertex`",
        ),
        (
            "format.ply",
            ascii.replace("format ascii", "format ebcdic").into_bytes(),
            "line 2: unknown format `ebcdic`",
        ),
        (
            "type.ply",
            ascii.replace("property uchar red", "property half red").into_bytes(),
            "line 9: unknown property type `half`",
        ),
        (
            "range.ply",
            ascii.replace("7 3 3 2 4", "7 3 3 2 99").into_bytes(),
            ": vertex index 99 is out of range (the file has 7 vertices)",
        ),
        (
            "corners.ply",
            ascii.replace("7 3 3 2 4", "7 2 3 2").into_bytes(),
            ": it has 2 corners; at least 3 are needed",
        ),
        // Values past the face's list (it said "a face has 0 corners" of a later line):
        // the line of the face whose count is wrong, and what is left on it.
        (
            "extra.ply",
            ascii.replace("7 3 3 2 4", "7 3 3 2 4 7 7 7").into_bytes(),
            ": its vertex count says 3 but the line holds more values (`7 7 7`)",
        ),
        ("cut.ply", little[..little.len() - 9].to_vec(), "cut short"),
        ("notply.ply", b"solid cube\nfacet normal 0 0 1\n".to_vec(), "not a PLY file"),
    ];
    for (name, bytes, expected) in cases {
        assert_one_line_error(&dir.write(name, bytes), expected);
    }
    // A binary face names its element index; an ASCII one its line.
    let mut bad_index = little.clone();
    let at = bad_index.len() - 16 - 4; // the last face's last index (before two edges)
    bad_index[at..at + 4].copy_from_slice(&1000u32.to_le_bytes());
    assert_one_line_error(
        &dir.write("index.ply", bad_index),
        "face 3: vertex index 1000 is out of range",
    );
}

#[test]
fn broken_gltf_files_are_one_line_naming_the_file() {
    let dir = TempDir::new("bad-gltf");
    let (bin, _) = gltf_bin();
    dir.write("quad.bin", &bin);
    assert_one_line_error(
        &dir.write("missing.gltf", gltf_json("nowhere.bin", "VEC3")),
        "cannot read its buffer",
    );
    assert_one_line_error(
        &dir.write("type.gltf", gltf_json("quad.bin", "VEC2")),
        "accessor 0 (POSITION) is of type VEC2, expected VEC3",
    );
    let past = gltf_json("quad.bin", "VEC3").replace(r#""count": 6"#, r#""count": 60"#);
    assert_one_line_error(
        &dir.write("past.gltf", past),
        "accessor 1 (indices) runs past the end of its buffer view 1",
    );
    let short =
        gltf_json("quad.bin", "VEC3").replace(r#""byteLength": 60"#, r#""byteLength": 600"#);
    assert_one_line_error(
        &dir.write("short.gltf", short),
        "buffer 0 holds 60 bytes, but its byteLength is 600",
    );
    assert_one_line_error(&dir.write("json.gltf", "{\"asset\": "), "not a valid glTF 2.0 file");
    let no_accessor = r#"{"asset": {"version": "2.0"}, "nodes": [{"mesh": 0}], "meshes": [{"primitives": [{"attributes": {"POSITION": 7}}]}]}"#;
    assert_one_line_error(
        &dir.write("accessor.gltf", no_accessor),
        "POSITION is accessor 7, but the file has 0 accessors",
    );
    let dangling = gltf_json("quad.bin", "VEC3").replace(r#""indices": 1"#, r#""indices": 9"#);
    assert_one_line_error(
        &dir.write("dangling.gltf", dangling),
        "indices is accessor 9, but the file has 2 accessors",
    );
    let mut glb = glb(&gltf_json("", "VEC3").replace(r#""uri": "", "#, ""), &bin);
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    glb[20 + json_len..24 + json_len].copy_from_slice(&100_000u32.to_le_bytes());
    assert_one_line_error(
        &dir.write("chunk.glb", &glb),
        "claims 100000 bytes, past the end of the file",
    );
    glb[8..12].copy_from_slice(&5u32.to_le_bytes());
    assert_one_line_error(
        &dir.write("header.glb", &glb),
        "the .glb header gives a length of 5 bytes",
    );
}

#[test]
fn unknown_extensions_list_the_formats() {
    let dir = TempDir::new("ext");
    assert_one_line_error(
        &dir.write("cube.stl", "solid"),
        "expected an OBJ (.obj), PLY (.ply) or glTF 2.0 (.gltf, .glb) file",
    );
}

#[test]
fn a_fifo_named_ply_is_refused_at_once() {
    let dir = TempDir::new("fifo");
    let path = dir.0.join("pipe.ply");
    assert!(Command::new("mkfifo").arg(&path).status().unwrap().success());
    // Opening a FIFO for reading waits for a writer: the check must come before.
    let (tx, rx) = std::sync::mpsc::channel();
    let p = path.clone();
    std::thread::spawn(move || tx.send(load_file(&p).map(|_| ()).map_err(|e| e.to_string())));
    let result =
        rx.recv_timeout(std::time::Duration::from_secs(10)).expect("loading a FIFO blocked");
    let e = result.unwrap_err();
    assert!(e.contains("pipe.ply") && e.contains("not a regular file"), "{e}");
}

#[test]
fn mutated_files_never_panic() {
    // A cheap stand-in for the fuzzer on stable Rust: flipped, cut and repeated bytes of
    // valid files of each encoding are errors or meshes, never panics.
    let (verts, faces) = shape();
    let (bin, _) = gltf_bin();
    let seeds = [
        ply_bytes(Encoding::Ascii, &verts, &faces),
        ply_bytes(Encoding::Little, &verts, &faces),
        ply_bytes(Encoding::Big, &verts, &faces),
        glb(&gltf_json("", "VEC3").replace(r#""uri": "", "#, ""), &bin),
    ];
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    for round in 0..4000 {
        let seed = &seeds[round % seeds.len()];
        let mut bytes = seed.clone();
        for _ in 0..1 + next() % 4 {
            let at = (next() as usize) % bytes.len().max(1);
            match next() % 4 {
                0 => bytes[at] = next() as u8,
                1 => bytes[at] ^= 1 << (next() % 8),
                2 => bytes.truncate(at),
                _ => bytes.insert(at, b"0123456789 -\n"[(next() % 13) as usize]),
            }
            if bytes.is_empty() {
                break;
            }
        }
        if round % seeds.len() == 3 {
            let _ = meshtracer::scene::gltf::load_gltf_from_bytes(&bytes, "m.glb", None);
        } else {
            let _ = meshtracer::scene::ply::load_ply_from_bytes(&bytes, "m.ply");
        }
    }
}

/// A plain PLY (vertex x y z nx ny nz u v, then triangles alone): the shape the common
/// writers emit, which a binary file reads on every core.
fn plain_ply(format: &str, verts: &[[f32; 8]], tris: &[[i32; 3]]) -> Vec<u8> {
    let big = format == "binary_big_endian";
    let mut out = format!(
        "ply\nformat {format} 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\nproperty float u\nproperty float v\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        verts.len(),
        tris.len()
    )
    .into_bytes();
    let word =
        |out: &mut Vec<u8>, b: [u8; 4]| out.extend(if big { [b[3], b[2], b[1], b[0]] } else { b });
    for v in verts {
        if format == "ascii" {
            out.extend(format!("{}\n", v.map(|c| c.to_string()).join(" ")).bytes());
        } else {
            v.iter().for_each(|c| word(&mut out, c.to_le_bytes()));
        }
    }
    for t in tris {
        if format == "ascii" {
            out.extend(format!("3 {} {} {}\n", t[0], t[1], t[2]).bytes());
        } else {
            out.push(3);
            t.iter().for_each(|i| word(&mut out, i.to_le_bytes()));
        }
    }
    out
}

#[test]
fn a_plain_binary_ply_read_on_every_core_equals_its_ascii_twin() {
    let dir = TempDir::new("plain-ply");
    // A grid of 40x30 quads, with normals and texture coordinates that are not round numbers.
    let (nx, ny) = (41usize, 31usize);
    let verts: Vec<[f32; 8]> = (0..nx * ny)
        .map(|k| {
            let (x, y) = ((k % nx) as f32 / 7.0, (k / nx) as f32 / 3.0);
            let n = Vec3::new(0.1 * x.sin(), 0.2, 1.0).normalize();
            [x, y, (x * y).sin() / 9.0, n.x, n.y, n.z, x / 5.0, y / 11.0]
        })
        .collect();
    let tris: Vec<[i32; 3]> = (0..(nx - 1) * (ny - 1))
        .flat_map(|q| {
            let (i, j) = ((q % (nx - 1)) as i32, (q / (nx - 1)) as i32);
            let at = |di: i32, dj: i32| (j + dj) * nx as i32 + i + di;
            [[at(0, 0), at(1, 0), at(1, 1)], [at(0, 0), at(1, 1), at(0, 1)]]
        })
        .collect();
    let ascii = load_file(&dir.write("grid.ply", plain_ply("ascii", &verts, &tris))).unwrap().mesh;
    for format in ["binary_little_endian", "binary_big_endian"] {
        let binary =
            load_file(&dir.write(&format!("{format}.ply"), plain_ply(format, &verts, &tris)))
                .unwrap()
                .mesh;
        assert_eq!(binary.positions, ascii.positions, "{format}");
        assert_eq!(binary.normals, ascii.normals, "{format}");
        assert_eq!(binary.texcoords, ascii.texcoords, "{format}");
        assert_eq!(binary.triangles, ascii.triangles, "{format}");
        assert!(binary.has_file_normals);
    }
    // Anything wrong in it is still found and named by the reader that says what.
    let mut bad = tris.clone();
    bad[1000][2] = 99_999;
    let err = load_file(&dir.write("bad.ply", plain_ply("binary_little_endian", &verts, &bad)))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("face 1000") && err.contains("99999") && err.contains("out of range"),
        "{err}"
    );
}

/// A header comment in Latin-1 (old exporters write one) is skipped like any other; the
/// header was refused as "not text" for its one byte that is not UTF-8.
#[test]
fn a_ply_header_comment_in_latin1_loads() {
    let dir = TempDir::new("latin1-ply");
    let (verts, faces) = shape();
    let swap = |bytes: &[u8], from: &str, to: &[u8]| {
        let at = bytes.windows(from.len()).position(|w| w == from.as_bytes()).unwrap();
        [&bytes[..at], to, &bytes[at + from.len()..]].concat()
    };
    for enc in [Encoding::Ascii, Encoding::Little] {
        let plain = ply_bytes(enc, &verts, &faces);
        // "créé" in Latin-1.
        let latin1 = swap(&plain, "comment made by the test", b"comment cr\xe9\xe9 par le test");
        let a = load_file(&dir.write("plain.ply", &plain)).unwrap().mesh;
        let b = load_file(&dir.write("latin1.ply", &latin1)).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!((a.positions, a.triangles), (b.mesh.positions, b.mesh.triangles));
    }
    // Anywhere else in the header such a byte is still refused.
    let plain = ply_bytes(Encoding::Ascii, &verts, &faces);
    let bad = swap(&plain, "property uchar red", b"property uchar r\xe9d");
    assert_one_line_error(&dir.write("bad.ply", bad), "line 9: the header is not text");
}
