//! glTF 2.0 loading (`.gltf` with its `.bin` buffers and images, or `.glb`): every
//! triangle primitive of every node of the default scene, in world space, merged into one
//! mesh.
//!
//! The `gltf` crate parses and validates the document (references, enums, required
//! fields). The bytes are ours to check: the GLB container, the buffers (read through the
//! same regular-file check as the other models, and held to their declared length) and
//! every accessor's range inside its buffer view and buffer, before a value is read. So a
//! broken file is one line naming it, never a panic or an allocation the file cannot back.

use std::path::{Path, PathBuf};

use ::gltf::accessor::{DataType, Dimensions};
use ::gltf::{buffer, image, Accessor, Document, Semantic};
use glam::Vec3;

use super::obj::{LoadedObj, ObjError};
use super::Material;
use crate::files::{io_reason, read_regular_file};
use mesh::build_mesh;

mod mesh;

/// Load a `.gltf` or `.glb` from bytes in memory (a file's are read by
/// `formats::load_model`; `name` for messages; `base_dir` resolves external buffers and
/// images, and without it only embedded buffers can be read).
pub fn load_gltf_from_bytes(
    bytes: &[u8],
    name: &str,
    base_dir: Option<&Path>,
) -> Result<LoadedObj, ObjError> {
    let invalid = |reason: String| ObjError::Invalid { name: name.to_owned(), reason };
    let (json, blob) =
        if bytes.starts_with(b"glTF") { split_glb(bytes).map_err(invalid)? } else { (bytes, None) };
    let not_gltf = |e: &dyn std::fmt::Display| {
        invalid(format!("not a valid glTF 2.0 file: {}", one_line(&e.to_string())))
    };
    let root = ::gltf::json::Root::from_slice(json).map_err(|e| not_gltf(&e))?;
    check_position_indices(&root).map_err(invalid)?;
    let document = Document::from_json(root).map_err(|e| not_gltf(&e))?;
    let buffers = read_buffers(&document, blob, base_dir).map_err(invalid)?;
    let mut warnings = Vec::new();
    let mesh = build_mesh(&document, &buffers, name, base_dir, &mut warnings).map_err(invalid)?;
    Ok(LoadedObj { mesh, warnings })
}

/// gltf-json 1.4's validation looks up each primitive's POSITION accessor before it checks
/// that the index exists (and panics where it does not): that one is checked first here.
fn check_position_indices(root: &::gltf::json::Root) -> Result<(), String> {
    use ::gltf::json::validation::Checked;
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let position = prim.attributes.get(&Checked::Valid(Semantic::Positions));
            if let Some(index) = position.filter(|i| i.value() >= root.accessors.len()) {
                let count = root.accessors.len();
                return Err(format!("mesh {m} primitive {p}: POSITION is accessor {}, but the file has {count} accessors", index.value()));
            }
        }
    }
    Ok(())
}

/// The JSON chunk and the optional BIN chunk of a binary glTF, every length checked.
fn split_glb(bytes: &[u8]) -> Result<(&[u8], Option<&[u8]>), String> {
    let word = |at: usize| {
        bytes.get(at..at + 4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
    };
    let (version, length) = (word(4), word(8));
    if version != Some(2) {
        return Err(format!(
            "a .glb of version {} (only 2 is read)",
            version.map_or("?".into(), |v| v.to_string())
        ));
    }
    let length = length.unwrap_or(0);
    if length < 12 || length > bytes.len() {
        return Err(format!("the .glb header gives a length of {length} bytes, but the file holds {}: it is cut short or corrupt", bytes.len()));
    }
    let mut chunks = Vec::new();
    let mut at = 12;
    while at < length {
        let (Some(size), Some(kind)) = (word(at), word(at + 4)) else {
            return Err(format!("a .glb chunk header at byte {at} is cut short"));
        };
        let start = at + 8;
        let end = start.checked_add(size).filter(|&e| e <= length).ok_or(format!(
            "a .glb chunk at byte {at} claims {size} bytes, past the end of the file"
        ))?;
        chunks.push((kind, &bytes[start..end]));
        // Chunks are padded to four bytes.
        at = end.div_ceil(4) * 4;
    }
    const JSON: usize = 0x4E4F_534A;
    const BIN: usize = 0x004E_4942;
    match chunks.as_slice() {
        [(JSON, json), rest @ ..] => {
            Ok((json, rest.iter().find(|(k, _)| *k == BIN).map(|(_, b)| *b)))
        }
        _ => Err("the .glb's first chunk is not its JSON chunk".to_owned()),
    }
}

/// Every buffer's bytes, each at least its declared `byteLength`.
fn read_buffers(
    document: &Document,
    blob: Option<&[u8]>,
    base_dir: Option<&Path>,
) -> Result<Vec<Vec<u8>>, String> {
    let mut out = Vec::new();
    for b in document.buffers() {
        let data = match b.source() {
            buffer::Source::Bin => blob
                .ok_or(format!(
                    "buffer {} refers to the .glb's binary chunk, which the file does not have",
                    b.index()
                ))?
                .to_vec(),
            buffer::Source::Uri(uri) if uri.starts_with("data:") => decode_data_uri(uri)
                .ok_or(format!("buffer {} has a data URI that is not base64", b.index()))?,
            buffer::Source::Uri(uri) => {
                let dir = base_dir.ok_or(format!(
                    "buffer {} is an external file, which cannot be read here",
                    b.index()
                ))?;
                let path = dir.join(percent_decode(uri));
                let shown =
                    crate::files::shown(&path.display().to_string(), crate::files::MAX_QUOTED_NAME);
                let mut data = read_regular_file(&path)
                    .map_err(|e| format!("cannot read its buffer {shown}: {}", io_reason(&e)))?;
                data.truncate(b.length());
                data
            }
        };
        if data.len() < b.length() {
            return Err(format!(
                "buffer {} holds {} bytes, but its byteLength is {}",
                b.index(),
                data.len(),
                b.length()
            ));
        }
        out.push(data);
    }
    Ok(out)
}

/// The bytes of an accessor, from its first element on, and its stride, after checking
/// its type and that all of it lies inside its view and buffer.
fn accessor_bytes<'b>(
    acc: &Accessor,
    buffers: &'b [Vec<u8>],
    what: &str,
    dims: Dimensions,
) -> Result<(&'b [u8], usize), String> {
    let at = || format!("accessor {} ({what})", acc.index());
    if acc.dimensions() != dims {
        return Err(format!("{} is of type {:?}, expected {dims:?}", at(), acc.dimensions()));
    }
    if acc.sparse().is_some() {
        return Err(format!("{} is sparse, which is not supported", at()));
    }
    let view = acc.view().ok_or_else(|| format!("{} has no buffer view", at()))?;
    let data = &buffers[view.buffer().index()];
    let view_end = view.offset().checked_add(view.length()).filter(|&e| e <= data.len());
    let view_bytes = view_end.map(|e| &data[view.offset()..e]).ok_or_else(|| {
        format!(
            "buffer view {} runs past the end of buffer {}",
            view.index(),
            view.buffer().index()
        )
    })?;
    let elem = acc.data_type().size() * dims.multiplicity();
    let stride = view.stride().unwrap_or(elem);
    if stride < elem {
        return Err(format!(
            "buffer view {} has a stride of {stride} bytes, less than an element of {}",
            view.index(),
            at()
        ));
    }
    let count = acc.count();
    let needed = if count == 0 {
        Some(0)
    } else {
        (count - 1)
            .checked_mul(stride)
            .and_then(|n| n.checked_add(elem))
            .and_then(|n| n.checked_add(acc.offset()))
    };
    if needed.is_none_or(|n| n > view_bytes.len()) {
        return Err(format!(
            "{} runs past the end of its buffer view {} ({count} elements from byte {})",
            at(),
            view.index(),
            acc.offset()
        ));
    }
    Ok((&view_bytes[acc.offset()..], stride))
}

/// Component `c` of element `i` as f64 (exact for every glTF component type).
fn component(bytes: &[u8], stride: usize, kind: DataType, i: usize, c: usize) -> f64 {
    let b = &bytes[i * stride + c * kind.size()..];
    match kind {
        DataType::I8 => b[0] as i8 as f64,
        DataType::U8 => b[0] as f64,
        DataType::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
        DataType::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
        DataType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
        DataType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
    }
}

/// An accessor's values as f32, normalized integers scaled to [0, 1] or [-1, 1].
fn read_accessor(
    acc: &Accessor,
    buffers: &[Vec<u8>],
    what: &str,
    dims: Dimensions,
) -> Result<Vec<f32>, String> {
    let (bytes, stride) = accessor_bytes(acc, buffers, what, dims)?;
    let (kind, width) = (acc.data_type(), dims.multiplicity());
    let scale = match kind {
        _ if !acc.normalized() => 1.0,
        DataType::I8 => 127.0,
        DataType::U8 => 255.0,
        DataType::I16 => 32767.0,
        DataType::U16 => 65535.0,
        DataType::U32 => u32::MAX as f64,
        DataType::F32 => 1.0,
    };
    let mut out = Vec::with_capacity(acc.count() * width);
    for i in 0..acc.count() {
        out.extend(
            (0..width)
                .map(|c| component(bytes, stride, kind, i, c) / scale)
                .map(|v| if acc.normalized() { v.max(-1.0) } else { v } as f32),
        );
    }
    Ok(out)
}

/// A primitive's `COLOR_0` (RGB or RGBA; float, or normalized unsigned byte or short, as
/// glTF allows) as RGBA8, alpha 255 where absent; `count` is the primitive's vertex count.
fn read_colors(
    acc: &Accessor,
    buffers: &[Vec<u8>],
    count: usize,
    at: &str,
) -> Result<Vec<[u8; 4]>, String> {
    let dims = acc.dimensions();
    if !matches!(dims, Dimensions::Vec3 | Dimensions::Vec4) {
        return Err(format!(
            "accessor {} (COLOR_0) is of type {dims:?}, expected Vec3 or Vec4",
            acc.index()
        ));
    }
    let kind = acc.data_type();
    if !(kind == DataType::F32
        || (acc.normalized() && matches!(kind, DataType::U8 | DataType::U16)))
    {
        return Err(format!("accessor {} (COLOR_0) has component type {kind:?}; glTF allows float or normalized unsigned byte or short", acc.index()));
    }
    let values = read_accessor(acc, buffers, "COLOR_0", dims)?;
    let width = dims.multiplicity();
    if values.len() / width != count {
        return Err(format!(
            "{at}: COLOR_0 has {} elements, POSITION {count}",
            values.len() / width
        ));
    }
    let byte = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
    Ok(values
        .chunks_exact(width)
        .map(|c| [byte(c[0]), byte(c[1]), byte(c[2]), c.get(3).map_or(255, |&a| byte(a))])
        .collect())
}

/// Triangle indices of a primitive (unsigned integer scalars).
fn read_indices(acc: &Accessor, buffers: &[Vec<u8>]) -> Result<Vec<u32>, String> {
    let kind = acc.data_type();
    if !matches!(kind, DataType::U8 | DataType::U16 | DataType::U32) {
        return Err(format!(
            "accessor {} (indices) has component type {kind:?}, not an unsigned integer",
            acc.index()
        ));
    }
    let (bytes, stride) = accessor_bytes(acc, buffers, "indices", Dimensions::Scalar)?;
    Ok((0..acc.count()).map(|i| component(bytes, stride, kind, i, 0) as u32).collect())
}

/// Our Blinn–Phong material for a glTF metallic-roughness one: the base colour is the
/// diffuse colour (and texture), metals tint the highlight, roughness widens it.
fn convert_material(
    m: &::gltf::Material,
    base_dir: Option<&Path>,
    name: &str,
    warnings: &mut Vec<String>,
) -> Material {
    let Some(index) = m.index() else { return Material::default() };
    let pbr = m.pbr_metallic_roughness();
    let base = Vec3::from_slice(&pbr.base_color_factor()[..3]);
    let metal = pbr.metallic_factor().clamp(0.0, 1.0);
    let alpha = pbr.roughness_factor().clamp(0.01, 1.0).powi(2);
    let label = m.name().map_or_else(
        || format!("material {index}"),
        |n| crate::files::shown(n, crate::files::MAX_QUOTED_NAME),
    );
    let mut out = Material {
        name: label.clone(),
        diffuse: if base.is_finite() { base } else { Material::default().diffuse },
        specular: Vec3::splat(0.04).lerp(base, metal),
        shininess: (2.0 / (alpha * alpha) - 2.0).clamp(1.0, 1024.0),
        ..Material::default()
    };
    if let Some(info) = pbr.base_color_texture() {
        match (info.texture().source().source(), base_dir) {
            (image::Source::Uri { uri, .. }, Some(dir)) if !uri.starts_with("data:") => {
                let path: PathBuf = dir.join(percent_decode(uri));
                if path.is_file() {
                    out.diffuse_texture = Some(path);
                } else {
                    warnings.push(format!("{name}: texture `{}` of {label} not found; the material keeps its plain colour", crate::files::shown(uri, 200)));
                }
            }
            _ => warnings.push(format!("{name}: the embedded texture of {label} is not supported; the material keeps its plain colour")),
        }
    }
    out
}

/// The bytes of a `data:...;base64,` URI.
fn decode_data_uri(uri: &str) -> Option<Vec<u8>> {
    let (_, data) = uri.split_once(";base64,")?;
    let value = |c: u8| match c {
        b'A'..=b'Z' => Some(c - b'A'),
        b'a'..=b'z' => Some(c - b'a' + 26),
        b'0'..=b'9' => Some(c - b'0' + 52),
        b'+' | b'-' => Some(62),
        b'/' | b'_' => Some(63),
        _ => None,
    };
    let mut out = Vec::with_capacity(data.len() / 4 * 3);
    let (mut acc, mut bits) = (0u32, 0);
    for c in data.bytes().filter(|&c| c != b'=') {
        acc = (acc << 6) | value(c)? as u32;
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
        }
    }
    Some(out)
}

/// A URI's `%XX` escapes decoded (file names with spaces are written `%20`).
fn percent_decode(uri: &str) -> String {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = b
            .get(i + 1..i + 3)
            .and_then(|h| std::str::from_utf8(h).ok())
            .and_then(|h| u8::from_str_radix(h, 16).ok());
        match (b[i], hex) {
            (b'%', Some(v)) => {
                out.push(v);
                i += 3;
            }
            (c, _) => {
                out.push(c);
                i += 1;
            }
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Several lines of a validation report as one.
fn one_line(text: &str) -> String {
    crate::files::shown(&text.lines().collect::<Vec<_>>().join("; "), 400)
}
