//! Vertex colours from the readers: PLY `red green blue [alpha]` in every encoding and
//! through both binary readers, glTF `COLOR_0`, and the errors for colours that are wrong.

mod common;

use std::fs;

use common::Scratch;

use glam::Vec3;
use meshtracer::scene::formats::{load_model, LoadError};
use meshtracer::scene::obj::{LoadOptions, LoadedObj};
use meshtracer::scene::paper::ModelSource;
use meshtracer::scene::ply::load_ply_from_bytes;
use meshtracer::scene::Mesh;

/// Four vertices of a quad (two triangles) and their colours.
const QUAD: [[f32; 3]; 4] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
const COLOURS: [[u8; 4]; 4] =
    [[255, 0, 0, 255], [0, 255, 0, 128], [0, 0, 255, 0], [12, 34, 56, 78]];

#[derive(Clone, Copy, PartialEq)]
enum Encoding {
    Ascii,
    Little,
    Big,
}

/// A PLY quad whose vertices carry `colour_props` (header lines) with values `colour(i)`,
/// each written by `write` in its type; `extra_face_flag` adds a face property, which the
/// parallel binary reader does not take (so the general reader reads the file).
fn ply(
    enc: Encoding,
    colour_props: &str,
    colour: impl Fn(usize) -> Vec<Value>,
    extra_face_flag: bool,
) -> Vec<u8> {
    let format = match enc {
        Encoding::Ascii => "ascii",
        Encoding::Little => "binary_little_endian",
        Encoding::Big => "binary_big_endian",
    };
    let flag = if extra_face_flag { "property uchar flags\n" } else { "" };
    let mut out = format!(
        "ply\nformat {format} 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n{colour_props}element face 1\nproperty list uchar int vertex_indices\n{flag}end_header\n"
    )
    .into_bytes();
    let mut put = |v: Value| match (enc, v) {
        (Encoding::Ascii, v) => out.extend(format!("{} ", v.text()).bytes()),
        (_, Value::U8(b)) => out.push(b),
        (Encoding::Little, Value::F32(f)) => out.extend(f.to_le_bytes()),
        (Encoding::Big, Value::F32(f)) => out.extend(f.to_be_bytes()),
        (Encoding::Little, Value::I32(i)) => out.extend(i.to_le_bytes()),
        (Encoding::Big, Value::I32(i)) => out.extend(i.to_be_bytes()),
    };
    for (i, p) in QUAD.iter().enumerate() {
        p.iter().for_each(|&c| put(Value::F32(c)));
        colour(i).into_iter().for_each(&mut put);
    }
    put(Value::U8(4));
    (0..4).for_each(|k| put(Value::I32(k)));
    if extra_face_flag {
        put(Value::U8(7));
    }
    out
}

#[derive(Clone, Copy)]
enum Value {
    U8(u8),
    F32(f32),
    I32(i32),
}

impl Value {
    fn text(self) -> String {
        match self {
            Value::U8(b) => b.to_string(),
            Value::F32(f) => f.to_string(),
            Value::I32(i) => i.to_string(),
        }
    }
}

const UCHAR_RGBA: &str =
    "property uchar red\nproperty uchar green\nproperty uchar blue\nproperty uchar alpha\n";

fn uchar_rgba(i: usize) -> Vec<Value> {
    COLOURS[i].iter().map(|&b| Value::U8(b)).collect()
}

fn load(bytes: &[u8], name: &str) -> Mesh {
    load_ply_from_bytes(bytes, name).unwrap_or_else(|e| panic!("{name}: {e}")).mesh
}

#[test]
fn uchar_colours_read_the_same_in_every_encoding_and_reader() {
    for enc in [Encoding::Ascii, Encoding::Little, Encoding::Big] {
        for general in [false, true] {
            let mesh = load(&ply(enc, UCHAR_RGBA, uchar_rgba, general), "c.ply");
            assert_eq!(mesh.colors, COLOURS, "encoding {} general reader {general}", enc as u8);
            assert_eq!(mesh.triangles.len(), 2);
            // White, so that the vertex colours are what is seen; the rest stays the default.
            assert_eq!(mesh.materials[0].diffuse, Vec3::ONE);
            assert_eq!(mesh.materials[0].specular, meshtracer::scene::Material::default().specular);
        }
    }
}

#[test]
fn float_colours_scale_round_and_clamp_and_alpha_defaults_to_opaque() {
    let props = "property float red\nproperty float green\nproperty float blue\n";
    let values = [[0.0, 0.5, 1.0], [1.5, -0.5, 0.25], [0.2, 0.4, 0.6], [1.0, 1.0, 1.0]];
    let expected =
        [[0, 128, 255, 255], [255, 0, 64, 255], [51, 102, 153, 255], [255, 255, 255, 255]];
    for enc in [Encoding::Ascii, Encoding::Little, Encoding::Big] {
        for general in [false, true] {
            let mesh = load(
                &ply(enc, props, |i| values[i].iter().map(|&f| Value::F32(f)).collect(), general),
                "f.ply",
            );
            assert_eq!(mesh.colors, expected);
        }
    }
    // The short spellings read the same.
    let short = "property uchar r\nproperty uchar g\nproperty uchar b\n";
    let mesh = load(
        &ply(
            Encoding::Little,
            short,
            |i| COLOURS[i][..3].iter().map(|&b| Value::U8(b)).collect(),
            false,
        ),
        "s.ply",
    );
    assert_eq!(mesh.colors, COLOURS.map(|[r, g, b, _]| [r, g, b, 255]));
}

#[test]
fn files_without_colours_keep_colors_empty_and_the_default_material() {
    for enc in [Encoding::Ascii, Encoding::Little] {
        // Red alone is not a colour: it is skipped like any other property.
        for (props, values) in [("", 0), ("property uchar red\n", 1)] {
            let mesh = load(&ply(enc, props, |_| vec![Value::U8(9); values], false), "n.ply");
            assert!(mesh.colors.is_empty());
            assert_eq!(mesh.materials[0], meshtracer::scene::Material::default());
        }
    }
}

#[test]
fn a_colour_that_is_a_list_is_one_line_naming_the_file() {
    let props = "property list uchar uchar red\nproperty uchar green\nproperty uchar blue\n";
    for enc in [Encoding::Ascii, Encoding::Little, Encoding::Big] {
        let bytes = ply(
            enc,
            props,
            |_| vec![Value::U8(1), Value::U8(5), Value::U8(6), Value::U8(7)],
            false,
        );
        let e = load_ply_from_bytes(&bytes, "list.ply").unwrap_err().to_string();
        assert!(e.starts_with("list.ply"), "{e}");
        assert!(e.contains("`red` is a list"), "{e}");
        assert!(!e.contains('\n'), "{e}");
    }
}

/// The quad's positions, u16 indices, RGBA ubyte colours and RGB float colours, in one buffer.
fn gltf_bin() -> Vec<u8> {
    let mut bin: Vec<u8> = QUAD.iter().flatten().flat_map(|c| c.to_le_bytes()).collect();
    bin.extend([0u16, 1, 2, 0, 2, 3].iter().flat_map(|i| i.to_le_bytes()));
    bin.extend(COLOURS.iter().flatten());
    bin.extend(
        [[1.0f32, 0.5, 0.0], [0.0, 0.25, 1.0], [2.0, -1.0, 0.2], [0.4, 0.6, 0.8]]
            .iter()
            .flatten()
            .flat_map(|c| c.to_le_bytes()),
    );
    bin
}

/// Mesh 0: the quad with ubyte colours (`rgba_accessor` spells that accessor's extra
/// fields) and again without colours; mesh 1: the quad with float RGB colours.
fn gltf_json(rgba_accessor: &str) -> String {
    format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "scene": 0,
  "scenes": [{{"nodes": [0, 1]}}],
  "nodes": [{{"mesh": 0}}, {{"mesh": 1, "translation": [0, 0, 2]}}],
  "meshes": [
    {{"primitives": [{{"attributes": {{"POSITION": 0, "COLOR_0": 2}}, "indices": 1}}, {{"attributes": {{"POSITION": 0}}, "indices": 1}}]}},
    {{"primitives": [{{"attributes": {{"POSITION": 0, "COLOR_0": 3}}, "indices": 1}}]}}
  ],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}},
    {{"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}},
    {{"bufferView": 2, "componentType": 5121, "count": 4, "type": "VEC4"{rgba_accessor}}},
    {{"bufferView": 3, "componentType": 5126, "count": 4, "type": "VEC3"}}
  ],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 48}},
    {{"buffer": 0, "byteOffset": 48, "byteLength": 12}},
    {{"buffer": 0, "byteOffset": 60, "byteLength": 16}},
    {{"buffer": 0, "byteOffset": 76, "byteLength": 48}}
  ],
  "buffers": [{{"uri": "quad.bin", "byteLength": 124}}]
}}"#
    )
}

#[test]
fn gltf_color_0_is_read_and_primitives_without_it_are_white() {
    let dir = Scratch::new("gltf");
    fs::write(dir.join("quad.bin"), gltf_bin()).unwrap();
    let path = dir.join("c.gltf");
    fs::write(&path, gltf_json(r#", "normalized": true"#)).unwrap();
    let load = |path: &std::path::Path| -> Result<LoadedObj, LoadError> {
        load_model(&ModelSource::File(path.to_owned()), &LoadOptions::default(), None)
            .map(LoadedObj::from)
    };
    let mesh = load(&path).unwrap().mesh;
    let floats = [[255, 128, 0, 255], [0, 64, 255, 255], [255, 0, 51, 255], [102, 153, 204, 255]];
    let expected: Vec<[u8; 4]> =
        COLOURS.iter().chain(&[[255; 4]; 4]).chain(&floats).copied().collect();
    assert_eq!(mesh.colors, expected);
    assert_eq!(mesh.colors.len(), mesh.positions.len());

    // glTF allows integer colours only normalized.
    fs::write(&path, gltf_json("")).unwrap();
    let e = load(&path).unwrap_err().to_string();
    assert!(e.starts_with(&path.display().to_string()), "{e}");
    assert!(e.contains("accessor 2 (COLOR_0) has component type U8"), "{e}");
    assert!(!e.contains('\n'), "{e}");
}

/// Each triangle corner's colour: the same on meshes whose vertices were numbered or
/// split differently.
fn corner_colours(mesh: &Mesh) -> Vec<[u8; 4]> {
    assert_eq!(mesh.colors.len(), mesh.positions.len(), "{}", mesh.name);
    mesh.triangles.iter().flatten().map(|&v| mesh.colors[v as usize]).collect()
}

#[test]
fn obj_colours_written_by_write_obj_read_back_through_both_parsers() {
    use meshtracer::scene::obj::{load_obj_from_str_chunked, load_obj_from_str_tobj, LoadOptions};
    use meshtracer::scene::primitives::{uv_sphere, write_obj};
    let dir = Scratch::new("obj");
    let mut sphere = uv_sphere(16, 8);
    sphere.colors = (0..sphere.positions.len())
        .map(|i| [(i * 37 % 256) as u8, (i * 101 % 256) as u8, (255 - i % 256) as u8, 255])
        .collect();
    let expected = corner_colours(&sphere);
    let path = dir.join("sphere.obj");
    // With file normals, and without them smoothed within a crease angle (vertices split).
    for (normals, options) in
        [(true, LoadOptions::default()), (false, LoadOptions { crease_angle: Some(20.0) })]
    {
        let mut mesh = sphere.clone();
        if !normals {
            mesh.normals.clear();
        }
        write_obj(&mesh, &path).unwrap();
        let text = fs::read_to_string(&path).unwrap();
        let oracle = load_obj_from_str_tobj(&text, "sphere.obj", None, &options).unwrap().mesh;
        assert_eq!(corner_colours(&oracle), expected, "tobj, normals {normals}");
        // One chunk, and many (a model over several chunks is de-duplicated in parallel).
        for chunk_bytes in [usize::MAX, 256] {
            let parallel =
                load_obj_from_str_chunked(&text, "sphere.obj", None, &options, chunk_bytes)
                    .unwrap()
                    .mesh;
            assert_eq!(
                corner_colours(&parallel),
                expected,
                "chunks of {chunk_bytes} bytes, normals {normals}"
            );
            assert_eq!(parallel.colors, oracle.colors);
        }
    }
    // A file without colours reads none.
    sphere.colors.clear();
    write_obj(&sphere, &path).unwrap();
    let text = fs::read_to_string(&path).unwrap();
    assert!(load_obj_from_str_chunked(&text, "plain.obj", None, &LoadOptions::default(), 256)
        .unwrap()
        .mesh
        .colors
        .is_empty());
}

#[test]
fn obj_colour_lines_with_an_unreadable_value_shift_the_rest_as_tobj_does() {
    use meshtracer::scene::obj::{load_obj_from_str_chunked, load_obj_from_str_tobj, LoadOptions};
    // tobj keeps the first line's leading 0.5 alone, so every later colour is shifted by one value.
    let text = "v 0 0 0 0.5 x 0.2\nv 1 0 0 1 0 0\nv 0 1 0 0 1 0\nv 0 0 1 0 0 1\nf 1 2 3\n";
    let options = LoadOptions::default();
    let oracle = load_obj_from_str_tobj(text, "shift.obj", None, &options).unwrap().mesh;
    assert_eq!(oracle.colors, [[128, 255, 0, 255], [0, 0, 255, 255], [0, 0, 0, 255]]);
    for chunk_bytes in [usize::MAX, 1] {
        let parallel =
            load_obj_from_str_chunked(text, "shift.obj", None, &options, chunk_bytes).unwrap().mesh;
        assert_eq!(parallel.colors, oracle.colors, "chunks of {chunk_bytes} bytes");
    }
}
