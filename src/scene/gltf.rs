//! glTF 2.0 (`.gltf` with its buffers, `.glb`): each mesh the default scene's nodes use,
//! stored once (its triangle primitives merged), and one part per node that places it, with
//! the node's world transform: a [`Model`].
//!
//! The document is read as plain JSON (`serde_json::Value`) and only what we use is checked,
//! as the spec and the Khronos validator have it: the `gltf` crate's own validation refused
//! valid files (accessors without a buffer view, textures without `source`, `1.0` for an
//! integer, animation targets without `node`). The bytes are ours to check too: the GLB
//! container, the buffers (read through the same regular-file check as the other models, and
//! held to their declared length) and every accessor's range inside its buffer view and
//! buffer, before a value is read. So a broken file is one line naming it, never a panic or
//! an allocation the file cannot back, and a file is refused only for what breaks its
//! geometry (or a required extension we do not read, named). Compressed geometry (Draco
//! primitives, meshopt buffer views) is decoded where it is read (`draco`, `meshopt`).

use std::path::Path;

use serde_json::Value as Json;

use super::obj::ObjError;
use super::Model;
use crate::files::{io_reason, read_regular_prefix};
use doc::Doc;

mod doc;
mod draco;
mod material;
mod mesh;
mod meshopt;

/// The extensions a file may require that we read; any other required one refuses the file,
/// naming it.
const SUPPORTED_REQUIRED: [&str; 5] = [
    "KHR_mesh_quantization",
    "KHR_texture_transform",
    "KHR_draco_mesh_compression",
    "EXT_meshopt_compression",
    "KHR_meshopt_compression",
];

/// A glTF file as loaded: its model (meshes stored once, a part per node) and the loader's
/// warnings (skipped primitives, textures that cannot be read...).
#[derive(Clone, Debug)]
pub struct LoadedGltf {
    pub model: Model,
    /// One sentence per problem worked around.
    pub warnings: Vec<String>,
}

/// Load a `.gltf` or `.glb` from bytes in memory (a file's are read by
/// `formats::load_model`; `name` for messages; `base_dir` resolves external buffers and
/// images, and without it only what the file holds can be read).
pub fn load_gltf_from_bytes(
    bytes: &[u8],
    name: &str,
    base_dir: Option<&Path>,
) -> Result<LoadedGltf, ObjError> {
    let invalid = |reason: String| ObjError::Invalid { name: name.to_owned(), reason };
    let (json, blob) =
        if bytes.starts_with(b"glTF") { split_glb(bytes).map_err(invalid)? } else { (bytes, None) };
    let root: Json = serde_json::from_slice(json)
        .map_err(|e| invalid(format!("not a valid glTF 2.0 file: {}", one_line(&e.to_string()))))?;
    check_document(&root).map_err(invalid)?;
    let buffers = read_buffers(&root, blob, base_dir);
    let doc = Doc::new(&root, &buffers);
    let mut warnings = Vec::new();
    let model = mesh::build_model(&doc, name, base_dir, &mut warnings).map_err(invalid)?;
    Ok(LoadedGltf { model, warnings })
}

/// What the whole file must be: a JSON object of glTF 2.x, and no required extension we do
/// not read.
fn check_document(root: &Json) -> Result<(), String> {
    if !root.is_object() {
        return Err("not a valid glTF 2.0 file: the document is not a JSON object".to_owned());
    }
    let version = root.pointer("/asset/version").and_then(Json::as_str);
    match version {
        Some(v) if v == "2" || v.starts_with("2.") => {}
        Some(v) => {
            return Err(format!(
                "a glTF of version {} (only 2.x is read)",
                crate::files::shown(v, 20)
            ))
        }
        None => return Err("not a valid glTF 2.0 file: it has no asset.version".to_owned()),
    }
    let required = root.get("extensionsRequired").and_then(Json::as_array);
    for ext in required.into_iter().flatten().filter_map(Json::as_str) {
        if !SUPPORTED_REQUIRED.contains(&ext) {
            return Err(format!(
                "needs `{}`, which meshtracer does not read",
                crate::files::shown(ext, 80)
            ));
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

/// Every buffer's bytes (each at least its declared `byteLength`), or why it cannot be
/// read: the error is given only when a buffer view of the geometry uses it.
fn read_buffers(
    root: &Json,
    blob: Option<&[u8]>,
    base_dir: Option<&Path>,
) -> Vec<Result<Vec<u8>, String>> {
    let buffers = root.get("buffers").and_then(Json::as_array);
    buffers
        .into_iter()
        .flatten()
        .enumerate()
        .map(|(i, b)| read_buffer(i, b, blob, base_dir))
        .collect()
}

/// Buffer `i`'s bytes, from the GLB's binary chunk, a `data:` URI or a file beside the model.
fn read_buffer(
    i: usize,
    b: &Json,
    blob: Option<&[u8]>,
    base_dir: Option<&Path>,
) -> Result<Vec<u8>, String> {
    let length = doc::uint(b, "byteLength", &format!("buffer {i}"))?.unwrap_or(0);
    let mut data = match b.get("uri").and_then(Json::as_str) {
        // Only the first buffer may be the GLB's binary chunk.
        None if i == 0 => blob
            .ok_or(format!(
                "buffer {i} refers to the .glb's binary chunk, which the file does not have"
            ))?
            .to_vec(),
        None => return Err(format!("buffer {i} has no uri and is not the .glb's binary chunk")),
        Some(uri) if uri.starts_with("data:") => decode_data_uri(uri)
            .ok_or(format!("buffer {i} has a data URI that cannot be decoded"))?,
        Some(uri) => {
            let dir = base_dir
                .ok_or(format!("buffer {i} is an external file, which cannot be read here"))?;
            let path = dir.join(percent_decode(uri));
            let shown =
                crate::files::shown(&path.display().to_string(), crate::files::MAX_QUOTED_NAME);
            // Only the declared length is read: a larger file (or a link to one) costs no
            // more, and a FIFO or device is refused before it is opened.
            read_regular_prefix(&path, length as u64)
                .map_err(|e| format!("cannot read its buffer {shown}: {}", io_reason(&e)))?
        }
    };
    if data.len() < length {
        return Err(format!(
            "buffer {i} holds {} bytes, but its byteLength is {length}",
            data.len()
        ));
    }
    data.truncate(length);
    Ok(data)
}

/// The bytes of a `data:` URI: base64 after `;base64,`, else the percent-encoded text
/// after the comma (RFC 2397); None when it is malformed.
fn decode_data_uri(uri: &str) -> Option<Vec<u8>> {
    let (header, data) = uri.strip_prefix("data:")?.split_once(',')?;
    if header.ends_with(";base64") {
        decode_base64(data)
    } else {
        Some(percent_decode_bytes(data.as_bytes()))
    }
}

/// Base64 (standard or URL-safe alphabet, padding optional); None on any other character.
fn decode_base64(data: &str) -> Option<Vec<u8>> {
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

/// `%XX` escapes decoded to the bytes they stand for (other bytes kept as they are).
fn percent_decode_bytes(b: &[u8]) -> Vec<u8> {
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
    out
}

/// A URI's `%XX` escapes decoded (file names with spaces are written `%20`).
fn percent_decode(uri: &str) -> String {
    String::from_utf8_lossy(&percent_decode_bytes(uri.as_bytes())).into_owned()
}

/// Several lines of a parser's report as one.
fn one_line(text: &str) -> String {
    crate::files::shown(&text.lines().collect::<Vec<_>>().join("; "), 400)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn data_uris_decode_in_base64_and_percent_encoding() {
        let bytes = b"\x89PNG \x00\xff";
        assert_eq!(decode_data_uri("data:image/png;base64,iVBORyAA/w==").unwrap(), bytes);
        assert_eq!(decode_data_uri("data:image/png,%89PNG%20%00%FF").unwrap(), bytes);
        assert_eq!(decode_data_uri("data:,plain").unwrap(), b"plain");
        assert_eq!(decode_data_uri("data:application/octet-stream;base64,@@"), None);
        assert_eq!(decode_data_uri("data:no comma"), None);
    }
}
