//! Compressed glTF geometry (issue #45): `KHR_draco_mesh_compression` primitives and
//! `EXT_meshopt_compression` / `KHR_meshopt_compression` buffer views read as their
//! uncompressed twins, made here with the codecs' own encoders (draco-core's, at the
//! settings Blender and `draco_encoder` use; meshoptimizer's, with each filter), and broken
//! compressed data refused in one line, never a panic.

mod common;

use common::gltf::glb;
use common::random::mutations;
use glam::Vec3;
use meshtracer::scene::gltf::load_gltf_from_bytes;
use meshtracer::scene::Mesh;

// ---------------------------------------------------------------------------------------
// The mesh and its plain twin

/// A wavy 12 x 12 grid (no two vertices alike, no symmetry): positions, unit normals,
/// texture coordinates, RGBA8 colours and triangles.
struct Grid {
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    uvs: Vec<[f32; 2]>,
    colors: Vec<[u8; 4]>,
    indices: Vec<u32>,
}

const SIDE: usize = 12;

fn grid() -> Grid {
    let mut g =
        Grid { positions: vec![], normals: vec![], uvs: vec![], colors: vec![], indices: vec![] };
    for j in 0..SIDE {
        for i in 0..SIDE {
            let (u, v) = (i as f32 / (SIDE - 1) as f32, j as f32 / (SIDE - 1) as f32);
            let (x, y) = (2.0 * u - 1.0, 2.0 * v - 1.0);
            let z = 0.15 * (2.0 * x).sin() * (3.0 * y).cos();
            let (dx, dy) = (
                0.3 * (2.0 * x).cos() * (3.0 * y).cos(),
                -0.45 * (2.0 * x).sin() * (3.0 * y).sin(),
            );
            let n = Vec3::new(-dx, -dy, 1.0).normalize();
            g.positions.push([x, y, z]);
            g.normals.push(n.to_array());
            g.uvs.push([u, v]);
            g.colors.push([(u * 255.0) as u8, (v * 255.0) as u8, 128, 200]);
        }
    }
    for j in 0..SIDE - 1 {
        for i in 0..SIDE - 1 {
            let a = (j * SIDE + i) as u32;
            let (b, c, d) = (a + 1, a + SIDE as u32 + 1, a + SIDE as u32);
            g.indices.extend([a, b, c, a, c, d]);
        }
    }
    g
}

fn bytes_of<T: bytemuck::Pod>(values: &[T]) -> Vec<u8> {
    bytemuck::cast_slice(values).to_vec()
}

/// The document around one primitive: `accessors`, `views`, `buffers` and the primitive's
/// `extensions` as JSON, and the extensions the file requires.
fn document(accessors: &str, views: &str, buffers: &str, prim_ext: &str, required: &str) -> String {
    format!(
        r#"{{"asset": {{"version": "2.0"}}, "extensionsUsed": [{required}], "extensionsRequired": [{required}],
  "scenes": [{{"nodes": [0]}}], "nodes": [{{"mesh": 0}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2, "COLOR_0": 3}}, "indices": 4{prim_ext}}}]}}],
  "accessors": [{accessors}], "bufferViews": [{views}], "buffers": [{buffers}]}}"#
    )
}

/// The accessors of the grid: `views[k]` is accessor k's buffer view (None: none), and
/// normals are `normal` (a component type and whether normalized).
fn accessors(views: [Option<usize>; 5], normal: (u32, bool)) -> String {
    let n = SIDE * SIDE;
    let t = (SIDE - 1) * (SIDE - 1) * 6;
    let view = |k: usize| views[k].map_or(String::new(), |v| format!(r#""bufferView": {v}, "#));
    format!(
        r#"{{{}"componentType": 5126, "count": {n}, "type": "VEC3", "min": [-1, -1, -0.2], "max": [1, 1, 0.2]}},
  {{{}"componentType": {}, "normalized": {}, "count": {n}, "type": "VEC3"}},
  {{{}"componentType": 5126, "count": {n}, "type": "VEC2"}},
  {{{}"componentType": 5121, "normalized": true, "count": {n}, "type": "VEC4"}},
  {{{}"componentType": 5123, "count": {t}, "type": "SCALAR"}}"#,
        view(0),
        view(1),
        normal.0,
        normal.1,
        view(2),
        view(3),
        view(4)
    )
}

/// The grid as a plain GLB: every attribute in its own buffer view.
fn plain_glb(g: &Grid) -> Vec<u8> {
    let indices: Vec<u16> = g.indices.iter().map(|&i| i as u16).collect();
    let parts = [
        bytes_of(&g.positions),
        bytes_of(&g.normals),
        bytes_of(&g.uvs),
        bytes_of(&g.colors),
        bytes_of(&indices),
    ];
    let mut bin = Vec::new();
    let mut views = Vec::new();
    for p in &parts {
        views.push(format!(
            r#"{{"buffer": 0, "byteOffset": {}, "byteLength": {}}}"#,
            bin.len(),
            p.len()
        ));
        bin.extend(p);
        bin.resize(bin.len().div_ceil(4) * 4, 0);
    }
    let accessors = accessors([Some(0), Some(1), Some(2), Some(3), Some(4)], (5126, false));
    let buffers = format!(r#"{{"byteLength": {}}}"#, bin.len());
    glb(&document(&accessors, &views.join(", "), &buffers, "", ""), &bin)
}

fn load(bytes: &[u8], name: &str) -> Mesh {
    let loaded = load_gltf_from_bytes(bytes, name, None).unwrap_or_else(|e| panic!("{e}"));
    assert!(loaded.warnings.is_empty(), "{name}: {:?}", loaded.warnings);
    assert_eq!(loaded.model.meshes.len(), 1);
    loaded.model.meshes[0].clone()
}

/// Tolerances of a lossy codec, per attribute.
struct Tolerances {
    position: f32,
    normal: f32,
    uv: f32,
    color: u8,
}

/// `got` is `want` up to the tolerances and the vertices' and triangles' order: each vertex
/// is matched to the nearest of `want`, and the triangles, in those terms, are the same set
/// with the same winding.
fn assert_same_mesh(got: &Mesh, want: &Mesh, tol: &Tolerances, what: &str) {
    assert_eq!(got.triangle_count(), want.triangle_count(), "{what}: triangles");
    assert!(got.has_file_normals, "{what}: the file's normals are kept");
    let matched: Vec<usize> = got
        .positions
        .iter()
        .map(|p| {
            let nearest = (0..want.positions.len())
                .min_by(|&a, &b| {
                    let (da, db) = (want.positions[a].distance(*p), want.positions[b].distance(*p));
                    da.total_cmp(&db)
                })
                .unwrap();
            let d = want.positions[nearest].distance(*p);
            assert!(d <= tol.position, "{what}: a vertex {d} from the nearest");
            nearest
        })
        .collect();
    for (g, &w) in matched.iter().enumerate() {
        let dn = got.normals[g].distance(want.normals[w]);
        let duv = (got.texcoords[g] - want.texcoords[w]).abs().max_element();
        let dc = (0..4).map(|c| got.colors[g][c].abs_diff(want.colors[w][c])).max().unwrap();
        assert!(dn <= tol.normal, "{what}: a normal {dn} off");
        assert!(duv <= tol.uv, "{what}: a texture coordinate {duv} off");
        assert!(dc <= tol.color, "{what}: a colour {dc} off");
    }
    let canonical = |tris: Vec<[u32; 3]>| {
        let mut out: Vec<[u32; 3]> = tris
            .into_iter()
            .map(|t| {
                let first = (0..3).min_by_key(|&k| t[k]).unwrap();
                [t[first], t[(first + 1) % 3], t[(first + 2) % 3]]
            })
            .collect();
        out.sort();
        out
    };
    let got_tris = got.triangles.iter().map(|t| t.map(|i| matched[i as usize] as u32)).collect();
    assert_eq!(canonical(got_tris), canonical(want.triangles.clone()), "{what}: triangles");
}

// ---------------------------------------------------------------------------------------
// Draco

/// The grid Draco-encoded by draco-core at `level` (draco_encoder's `-cl`; 10 is speed 0),
/// or with sequential connectivity, quantized as Blender exports (positions 14 bits,
/// normals 10, texture coordinates 12; colours stay bytes); and the attributes' Draco ids.
fn draco_encode(g: &Grid, level: Option<i32>) -> (Vec<u8>, Vec<u32>) {
    use draco_core::{DataType, GeometryAttributeType as T, PointAttribute};
    let n = g.positions.len();
    let mut mesh = draco_core::Mesh::new();
    let mut add = |kind, width, data_type, normalized, bytes: Vec<u8>| {
        let mut att = PointAttribute::new();
        att.init(kind, width, data_type, normalized, n);
        att.buffer_mut().write(0, &bytes);
        mesh.add_attribute(att)
    };
    let ids = [
        add(T::Position, 3, DataType::Float32, false, bytes_of(&g.positions)),
        add(T::Normal, 3, DataType::Float32, false, bytes_of(&g.normals)),
        add(T::TexCoord, 2, DataType::Float32, false, bytes_of(&g.uvs)),
        add(T::Color, 4, DataType::Uint8, true, bytes_of(&g.colors)),
    ];
    mesh.set_num_faces(g.indices.len() / 3);
    mesh.set_faces_from_flat_indices(&g.indices);
    let mut options = draco_core::EncoderOptions::new();
    match level {
        Some(level) => options.set_compression_level(level),
        None => {
            options.set_global_int("encoding_speed", 10);
            options.set_global_int("decoding_speed", 10);
        }
    }
    for (id, bits) in ids.iter().zip([14, 10, 12]) {
        options.set_attribute_quantization(*id, bits);
    }
    let mut encoder = draco_core::MeshEncoder::new();
    encoder.set_mesh(mesh);
    let mut out = draco_core::EncoderBuffer::new();
    let info = encoder.encode_with_info(&options, &mut out).expect("draco encodes");
    let unique = ids
        .iter()
        .map(|&id| info.attributes.iter().find(|a| a.source_attribute_id == id).unwrap().unique_id)
        .collect();
    (out.data().to_vec(), unique)
}

/// The grid as a GLB whose primitive is `draco` (its bytes and attribute ids).
fn draco_glb(draco: &(Vec<u8>, Vec<u32>)) -> Vec<u8> {
    let (bytes, ids) = draco;
    let ext = format!(
        r#", "extensions": {{"KHR_draco_mesh_compression": {{"bufferView": 0, "attributes": {{"POSITION": {}, "NORMAL": {}, "TEXCOORD_0": {}, "COLOR_0": {}}}}}}}"#,
        ids[0], ids[1], ids[2], ids[3]
    );
    let json = document(
        &accessors([None; 5], (5126, false)),
        &format!(r#"{{"buffer": 0, "byteLength": {}}}"#, bytes.len()),
        &format!(r#"{{"byteLength": {}}}"#, bytes.len()),
        &ext,
        r#""KHR_draco_mesh_compression""#,
    );
    glb(&json, bytes)
}

#[test]
fn draco_primitives_read_as_their_uncompressed_twin() {
    let g = grid();
    let plain = load(&plain_glb(&g), "plain.glb");
    // Quantization steps: positions 2 / 2^14, texture coordinates 1 / 2^12, normals 10 bits.
    let tol = Tolerances { position: 2e-4, normal: 5e-3, uv: 5e-4, color: 0 };
    // Blender's default (6), draco_encoder's (7), the smallest (10) and sequential.
    for level in [Some(6), Some(7), Some(10), None] {
        let what = format!("Draco at level {level:?}");
        let draco = draco_encode(&g, level);
        let mesh = load(&draco_glb(&draco), &what);
        assert_same_mesh(&mesh, &plain, &tol, &what);
    }
}

#[test]
fn broken_draco_data_is_one_line_never_a_panic() {
    let g = grid();
    let (bytes, ids) = draco_encode(&g, Some(7));
    let mut cut = bytes.clone();
    cut.truncate(bytes.len() / 2);
    let e = load_gltf_from_bytes(&draco_glb(&(cut, ids.clone())), "cut.glb", None)
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("cut.glb") && e.contains("its Draco data cannot be decoded"), "{e}");
    assert!(!e.contains('\n'), "{e}");
    // An attribute id the data lacks.
    let mut wrong = ids.clone();
    wrong[1] = 99;
    let e = load_gltf_from_bytes(&draco_glb(&(bytes.clone(), wrong)), "id.glb", None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("NORMAL is Draco attribute 99, which the data does not have"), "{e}");
    // Bytes changed at random: read or refused, each refusal one line.
    for mutated in mutations(&bytes, 0x2545_F491_4F6C_DD1D, 300) {
        if let Err(e) = load_gltf_from_bytes(&draco_glb(&(mutated, ids.clone())), "x.glb", None) {
            assert!(!e.to_string().contains('\n'), "{e}");
        }
    }
}

// ---------------------------------------------------------------------------------------
// meshopt

/// `vertices` through version 0 of meshoptimizer's vertex codec: the one
/// EXT_meshopt_compression defines.
fn v0<T>(vertices: &[T]) -> Vec<u8> {
    meshopt::encode_vertex_buffer_level(vertices, 2, Some(0)).unwrap()
}

/// One meshopt-compressed view: its compressed bytes, element size and count, mode, filter
/// and extension name.
struct Stream {
    bytes: Vec<u8>,
    stride: usize,
    count: usize,
    mode: &'static str,
    filter: &'static str,
    ext: &'static str,
}

/// The grid's attributes and indices as meshopt streams: positions plain, normals through
/// the octahedral filter (8-bit, as KHR_mesh_quantization allows), texture coordinates
/// through the exponential filter, colours through the colour filter (KHR_ only) and
/// indices as a triangle list, or a plain sequence when `sequence`.
fn meshopt_streams(g: &Grid, sequence: bool) -> Vec<Stream> {
    use meshopt::{encode_filter_color, encode_filter_exp, encode_filter_oct, EncodeExpMode};
    let n = g.positions.len();
    let normals: Vec<[f32; 4]> = g.normals.iter().map(|n| [n[0], n[1], n[2], 0.0]).collect();
    let oct = encode_filter_oct::<i8>(&normals, 8);
    let exp = encode_filter_exp::<2>(&g.uvs, 20, EncodeExpMode::Separate);
    let rgba: Vec<[f32; 4]> = g.colors.iter().map(|c| c.map(|v| v as f32 / 255.0)).collect();
    let color = encode_filter_color::<u8>(&rgba, 8);
    let stream = |bytes, stride, count, mode, filter, ext| Stream {
        bytes,
        stride,
        count,
        mode,
        filter,
        ext,
    };
    let ext = "EXT_meshopt_compression";
    let (encoded, mode) = if sequence {
        (meshopt::encode_index_sequence(&g.indices, n).unwrap(), "INDICES")
    } else {
        (meshopt::encode_index_buffer(&g.indices, n).unwrap(), "TRIANGLES")
    };
    let indices = stream(encoded, 2, g.indices.len(), mode, "NONE", ext);
    vec![
        stream(v0(&g.positions), 12, n, "ATTRIBUTES", "NONE", ext),
        stream(v0(&oct), 4, n, "ATTRIBUTES", "OCTAHEDRAL", ext),
        stream(v0(&exp), 8, n, "ATTRIBUTES", "EXPONENTIAL", ext),
        // The ratified extension's codec version 1 (meshoptimizer's default) and filter.
        stream(
            meshopt::encode_vertex_buffer(&color).unwrap(),
            4,
            n,
            "ATTRIBUTES",
            "COLOR",
            "KHR_meshopt_compression",
        ),
        indices,
    ]
}

/// The grid as a GLB of meshopt views over a fallback buffer with no data.
fn meshopt_glb(streams: &[Stream]) -> Vec<u8> {
    let (mut bin, mut views, mut fallback) = (Vec::new(), Vec::new(), 0);
    for (k, s) in streams.iter().enumerate() {
        let length = s.stride * s.count;
        let stride = if k < 4 { format!(r#""byteStride": {}, "#, s.stride) } else { String::new() };
        views.push(format!(
            r#"{{"buffer": 1, "byteOffset": {fallback}, "byteLength": {length}, {stride}"extensions": {{"{}": {{"buffer": 0, "byteOffset": {}, "byteLength": {}, "byteStride": {}, "count": {}, "mode": "{}", "filter": "{}"}}}}}}"#,
            s.ext, bin.len(), s.bytes.len(), s.stride, s.count, s.mode, s.filter
        ));
        fallback += length.div_ceil(4) * 4;
        bin.extend(&s.bytes);
        bin.resize(bin.len().div_ceil(4) * 4, 0);
    }
    let buffers = format!(
        r#"{{"byteLength": {}}}, {{"byteLength": {fallback}, "extensions": {{"EXT_meshopt_compression": {{"fallback": true}}}}}}"#,
        bin.len()
    );
    let json = document(
        &accessors([Some(0), Some(1), Some(2), Some(3), Some(4)], (5120, true)),
        &views.join(",\n"),
        &buffers,
        "",
        r#""EXT_meshopt_compression", "KHR_meshopt_compression", "KHR_mesh_quantization""#,
    );
    glb(&json, &bin)
}

#[test]
fn meshopt_views_read_as_their_uncompressed_twin() {
    let g = grid();
    let plain = load(&plain_glb(&g), "plain.glb");
    // Positions and indices are lossless; normals are 8 bits, the colour filter 8.
    let tol = Tolerances { position: 0.0, normal: 0.02, uv: 1e-5, color: 2 };
    for sequence in [false, true] {
        let what = format!("meshopt (indices as a sequence: {sequence})");
        let mesh = load(&meshopt_glb(&meshopt_streams(&g, sequence)), &what);
        assert_same_mesh(&mesh, &plain, &tol, &what);
        assert_eq!(mesh.positions, plain.positions, "{what}: lossless, in order");
    }
}

#[test]
fn broken_meshopt_views_are_one_line_never_a_panic_or_a_large_allocation() {
    let g = grid();
    let streams = meshopt_streams(&g, false);
    let refusal = |bytes: Vec<u8>| {
        let e = load_gltf_from_bytes(&bytes, "m.glb", None).unwrap_err().to_string();
        assert!(e.starts_with("m.glb") && !e.contains('\n'), "{e}");
        e
    };
    let json_of = |glb: &[u8]| {
        let len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
        (String::from_utf8(glb[20..20 + len].to_vec()).unwrap(), glb[28 + len..].to_vec())
    };
    let (json, bin) = json_of(&meshopt_glb(&streams));
    // A stride meshoptimizer would assert on (and abort the process).
    let bad = json.replacen(r#""byteStride": 12, "count""#, r#""byteStride": 6, "count""#, 1);
    let e = refusal(glb(&bad, &bin));
    assert!(e.contains("a meshopt byteStride of 6"), "{e}");
    // A count the compressed bytes cannot describe: refused before anything is allocated.
    let big = json.replacen(
        r#""count": 144, "mode": "ATTRIBUTES", "filter": "NONE""#,
        r#""count": 4000000000, "mode": "ATTRIBUTES", "filter": "NONE""#,
        1,
    );
    let e = refusal(glb(&big, &bin));
    assert!(e.contains("4000000000 meshopt elements of 12 bytes are more than"), "{e}");
    let mode = json.replacen(r#""mode": "TRIANGLES""#, r#""mode": "STRIPS""#, 1);
    let e = refusal(glb(&mode, &bin));
    assert!(e.contains("meshopt mode `STRIPS` with filter `NONE`"), "{e}");
    // Corrupt data: the positions' header byte.
    let mut corrupt = bin.clone();
    corrupt[0] = 0x7f;
    let e = refusal(glb(&json, &corrupt));
    assert!(e.contains("buffer view 0: its meshopt data cannot be decoded"), "{e}");
    // Bytes changed at random: read or refused in one line.
    for mutated in mutations(&bin, 0x9E37_79B9_7F4A_7C15, 300) {
        if let Err(e) = load_gltf_from_bytes(&glb(&json, &mutated), "x.glb", None) {
            assert!(!e.to_string().contains('\n'), "{e}");
        }
    }
}
