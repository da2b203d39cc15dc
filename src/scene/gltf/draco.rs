//! `KHR_draco_mesh_compression` primitives, decoded by the pure Rust `draco-core`: its
//! decoder bounds what it allocates by what the stream could describe.

use serde_json::Value as Json;

use super::doc::{uint, Doc, Vertices};

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
