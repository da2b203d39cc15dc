//! Compressed glTF geometry: `KHR_draco_mesh_compression` primitives, decoded by the pure
//! Rust `draco-core`, and `EXT_meshopt_compression` / `KHR_meshopt_compression` buffer views,
//! decoded by meshoptimizer's own C++ (the `meshopt` crate). Every size the decoders are given
//! is checked first: meshoptimizer asserts (aborts) on a stride it does not take, and a
//! declared size is allocated only when the compressed bytes could describe it.

use serde_json::Value as Json;

use super::doc::{uint, Doc};
use super::mesh::Vertices;

/// The most bytes a meshopt view may decode to per compressed byte: the codecs' densest
/// case (a block of zeros in version 1 of the vertex codec) is below this, so a valid file
/// is never refused, and a few bytes cannot ask for gigabytes.
const MESHOPT_MAX_RATIO: usize = 1024;
/// Views smaller than this are decoded whatever their compressed size.
const MESHOPT_SMALL: usize = 1 << 16;

/// A decompressed buffer view: 4-byte words (meshoptimizer's filters read 16- and 32-bit
/// values in place, so the memory is aligned for them) and its length in bytes.
#[derive(Debug)]
pub(super) struct Decoded {
    words: Vec<u32>,
    len: usize,
}

impl Decoded {
    /// The view's bytes.
    pub fn bytes(&self) -> &[u8] {
        &bytemuck::cast_slice(&self.words)[..self.len]
    }
}

/// A buffer view's meshopt extension (`EXT_` or the ratified `KHR_`), if it has one.
pub(super) fn meshopt_extension(view: &Json) -> Option<&Json> {
    let ext = view.get("extensions")?;
    ext.get("KHR_meshopt_compression").or_else(|| ext.get("EXT_meshopt_compression"))
}

/// The bytes of a meshopt-compressed buffer view (`ext` its extension object, `what` names
/// the view), its filter applied.
pub(super) fn meshopt_view(doc: &Doc, ext: &Json, what: &str) -> Result<Decoded, String> {
    let need = |key: &str| uint(ext, key, what)?.ok_or(format!("{what}: meshopt `{key}` missing"));
    let (buffer, length) = (need("buffer")?, need("byteLength")?);
    let offset = uint(ext, "byteOffset", what)?.unwrap_or(0);
    let (stride, count) = (need("byteStride")?, need("count")?);
    let mode = ext.get("mode").and_then(Json::as_str).unwrap_or("");
    let filter = ext.get("filter").and_then(Json::as_str).unwrap_or("NONE");
    let source = doc.buffer_range(buffer, offset, length, what)?;
    let stride_ok = match (mode, filter) {
        ("ATTRIBUTES", "NONE" | "EXPONENTIAL") => stride % 4 == 0 && (4..=256).contains(&stride),
        ("ATTRIBUTES", "OCTAHEDRAL" | "COLOR") => stride == 4 || stride == 8,
        ("ATTRIBUTES", "QUATERNION") => stride == 8,
        ("TRIANGLES", "NONE") => (stride == 2 || stride == 4) && count % 3 == 0,
        ("INDICES", "NONE") => stride == 2 || stride == 4,
        _ => {
            return Err(format!(
                "{what}: meshopt mode `{}` with filter `{}` is not one the extension defines",
                crate::files::shown(mode, 20),
                crate::files::shown(filter, 20)
            ))
        }
    };
    if !stride_ok {
        return Err(format!(
            "{what}: a meshopt byteStride of {stride} (and count {count}) is not allowed for {mode} with filter {filter}"
        ));
    }
    let len = count
        .checked_mul(stride)
        .filter(|&n| n <= MESHOPT_SMALL.max(source.len().saturating_mul(MESHOPT_MAX_RATIO)))
        .ok_or(format!(
            "{what}: {count} meshopt elements of {stride} bytes are more than its {} compressed bytes can hold",
            source.len()
        ))?;
    let mut words = vec![0u32; len.div_ceil(4)];
    let out = words.as_mut_ptr().cast();
    // SAFETY: `words` holds `count * stride` bytes, `source` is a live slice of its length,
    // and the strides and counts are the ones each function asserts (checked above); the
    // decoders read only `source.len()` bytes of it.
    let rc = unsafe {
        use meshopt::ffi;
        match mode {
            "ATTRIBUTES" => {
                ffi::meshopt_decodeVertexBuffer(out, count, stride, source.as_ptr(), source.len())
            }
            "TRIANGLES" => {
                ffi::meshopt_decodeIndexBuffer(out, count, stride, source.as_ptr(), source.len())
            }
            _ => {
                ffi::meshopt_decodeIndexSequence(out, count, stride, source.as_ptr(), source.len())
            }
        }
    };
    if rc != 0 {
        return Err(format!("{what}: its meshopt data cannot be decoded (it is corrupt, or of a codec version this meshoptimizer does not read)"));
    }
    // SAFETY: as above: the filter rewrites `count` elements of `stride` bytes in place, with
    // the stride it asserts.
    unsafe {
        use meshopt::ffi;
        match filter {
            "OCTAHEDRAL" => ffi::meshopt_decodeFilterOct(out, count, stride),
            "QUATERNION" => ffi::meshopt_decodeFilterQuat(out, count, stride),
            "EXPONENTIAL" => ffi::meshopt_decodeFilterExp(out, count, stride),
            "COLOR" => ffi::meshopt_decodeFilterColor(out, count, stride),
            _ => {}
        }
    }
    Ok(Decoded { words, len })
}

/// A `KHR_draco_mesh_compression` primitive's vertices (`ext` its extension object, `prim`
/// the primitive, whose accessors give each attribute's type) and its triangles. `texcoord`
/// is the `TEXCOORD_n` its material reads.
pub(super) fn draco_primitive(
    doc: &Doc,
    ext: &Json,
    prim: &Json,
    texcoord: &str,
    at: &str,
) -> Result<Vertices, String> {
    let what = format!("{at} (Draco)");
    let view = uint(ext, "bufferView", &what)?.ok_or(format!("{what} has no bufferView"))?;
    let bytes = doc.buffer_view(view, &what)?;
    let mut mesh = draco_core::Mesh::new();
    let mut input = draco_core::DecoderBuffer::new(bytes);
    draco_core::MeshDecoder::new().decode(&mut input, &mut mesh).map_err(|e| {
        format!(
            "{what}: its Draco data cannot be decoded ({})",
            crate::files::shown(&e.to_string(), 200)
        )
    })?;
    let points = mesh.num_points();
    let attribute = |key: &str, widths: &[usize]| -> Result<Option<(Vec<f32>, usize)>, String> {
        let Some(id) = ext.get("attributes").map(|a| uint(a, key, &what)).transpose()?.flatten()
        else {
            return Ok(None);
        };
        let att = (0..mesh.num_attributes())
            .map(|i| mesh.attribute(i))
            .find(|a| a.unique_id() as usize == id)
            .ok_or(format!(
                "{what}: {key} is Draco attribute {id}, which the data does not have"
            ))?;
        // The glTF accessor's type and normalization, where the primitive has it.
        let accessor = prim
            .get("attributes")
            .and_then(|a| uint(a, key, &what).ok().flatten())
            .and_then(|i| doc.accessor(i, key).ok());
        let width = accessor.as_ref().map_or(att.num_components() as usize, |a| a.width);
        if !widths.contains(&width) {
            return Err(format!("{what}: {key} has {width} components"));
        }
        let mut values = att.read_f32s(points, width);
        let normalized = att.normalized() || accessor.is_some_and(|a| a.normalized);
        if let (true, Some(scale)) = (normalized, integer_scale(att.data_type())) {
            values.iter_mut().for_each(|v| *v = (*v / scale).max(-1.0));
        }
        Ok(Some((values, width)))
    };
    let positions = attribute("POSITION", &[3])?.ok_or(format!("{what} has no POSITION"))?.0;
    let normals = attribute("NORMAL", &[3])?.map(|(v, _)| v);
    let texcoords = attribute(texcoord, &[2])?.map(|(v, _)| v);
    let colors = attribute("COLOR_0", &[3, 4])?;
    let indices = mesh.faces().as_flattened().iter().map(|p| p.0).collect();
    Ok(Vertices { positions, normals, texcoords, colors, indices })
}

/// The divisor that normalizes an integer component type (None for floats).
fn integer_scale(kind: draco_core::DataType) -> Option<f32> {
    use draco_core::DataType as D;
    Some(match kind {
        D::Int8 => 127.0,
        D::Uint8 => 255.0,
        D::Int16 => 32767.0,
        D::Uint16 => 65535.0,
        D::Int32 => i32::MAX as f32,
        D::Uint32 => u32::MAX as f32,
        _ => return None,
    })
}
