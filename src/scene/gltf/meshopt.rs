//! `EXT_meshopt_compression` / `KHR_meshopt_compression` buffer views, decoded by
//! meshoptimizer's own C++ (the `meshopt` crate). Every size it is given is checked first:
//! meshoptimizer asserts (aborts) on a stride it does not take, and a declared size is
//! allocated only when the compressed bytes could describe it.

use serde_json::Value as Json;

/// The most bytes a meshopt view may decode to per compressed byte: the codecs' densest
/// case, a constant attribute in version 1 of the vertex codec, measured 1,022 (a million
/// vertices; version 0: 63, indices: 5), so a valid file is never refused, and a few bytes
/// cannot ask for gigabytes.
const MESHOPT_MAX_RATIO: usize = 4096;
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
pub(super) fn extension(view: &Json) -> Option<&Json> {
    let ext = view.get("extensions")?;
    ext.get("KHR_meshopt_compression").or_else(|| ext.get("EXT_meshopt_compression"))
}

/// What a meshopt extension object declares, as `doc.rs` reads it.
pub(super) struct View<'a> {
    /// The compressed bytes.
    pub source: &'a [u8],
    /// Bytes per element (`byteStride`).
    pub stride: usize,
    /// Elements (`count`).
    pub count: usize,
    /// `ATTRIBUTES`, `TRIANGLES` or `INDICES`.
    pub mode: &'a str,
    /// `NONE`, `OCTAHEDRAL`, `QUATERNION`, `EXPONENTIAL` or `COLOR`.
    pub filter: &'a str,
}

/// The decompressed bytes of a view (`what` names it), its filter applied.
pub(super) fn decode(view: View, what: &str) -> Result<Decoded, String> {
    let View { source, stride, count, mode, filter } = view;
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
        use ::meshopt::ffi;
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
        use ::meshopt::ffi;
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
