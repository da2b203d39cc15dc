//! The parts of a glTF document we read, straight from its JSON, checked as the spec has
//! them and no stricter: integers may be written `1.0`, unknown properties are ignored, and
//! accessors are read with all the spec allows (no buffer view: zeros; sparse substitutions;
//! normalized and, for `KHR_mesh_quantization`, plain integer components).

use std::cell::OnceCell;

use serde_json::Value as Json;

use super::meshopt;

/// The most elements an accessor without a buffer view may have: its zeros are allocated
/// with nothing in the file to back them, so a few bytes of JSON could ask for gigabytes.
/// 16M (vertices of a mesh whose positions are all sparse substitutions) is far beyond
/// what such files hold.
const MAX_ZERO_ELEMENTS: usize = 1 << 24;

/// A primitive's vertices as read (from accessors or Draco), before they join its mesh.
pub(super) struct Vertices {
    /// x, y, z per vertex.
    pub positions: Vec<f32>,
    /// x, y, z per vertex, if the primitive has them.
    pub normals: Option<Vec<f32>>,
    /// u, v per vertex in glTF's texture space (origin top-left).
    pub texcoords: Option<Vec<f32>>,
    /// RGB or RGBA in [0, 1] per vertex, and which (3 or 4).
    pub colors: Option<(Vec<f32>, usize)>,
    /// The vertex indices in the primitive's mode's order.
    pub indices: Vec<u32>,
}

/// The document and its buffers' bytes (or why each cannot be read).
pub(super) struct Doc<'a> {
    pub root: &'a Json,
    buffers: &'a [Result<Vec<u8>, String>],
    /// Each buffer view's bytes as decompressed (`EXT_meshopt_compression`), decoded when
    /// first read, so views nothing reads (animations, other scenes) cost nothing.
    decoded: Vec<OnceCell<Result<meshopt::Decoded, String>>>,
}

/// A JSON number as a non-negative integer: `1.0` is 1, as JSON does not tell them apart.
pub(super) fn index_of(v: &Json) -> Option<usize> {
    let whole = |f: &f64| f.fract() == 0.0 && *f >= 0.0 && *f < 9e15;
    let n = v.as_u64().or_else(|| v.as_f64().filter(whole).map(|f| f as u64))?;
    Some(usize::try_from(n).unwrap_or(usize::MAX))
}

/// Entry `key` of `v` as a non-negative integer ([`index_of`]); None when absent, an
/// error naming `what` when it is anything else.
pub(super) fn uint(v: &Json, key: &str, what: &str) -> Result<Option<usize>, String> {
    match v.get(key) {
        None => Ok(None),
        Some(x) => index_of(x)
            .map(Some)
            .ok_or_else(|| format!("{what}: `{key}` is not a non-negative integer")),
    }
}

/// Entry `key` of `v` as a number, if it is one.
pub(super) fn number(v: &Json, key: &str) -> Option<f64> {
    v.get(key).and_then(Json::as_f64)
}

/// Entry `key` of `v` as `N` numbers, if it is an array of exactly that.
pub(super) fn numbers<const N: usize>(v: &Json, key: &str) -> Option<[f32; N]> {
    let a = v.get(key)?.as_array()?;
    if a.len() != N {
        return None;
    }
    let mut out = [0.0; N];
    for (o, x) in out.iter_mut().zip(a) {
        *o = x.as_f64()? as f32;
    }
    Some(out)
}

/// Array `key` of `v` (empty when absent or not an array).
pub(super) fn array<'a>(v: &'a Json, key: &str) -> &'a [Json] {
    v.get(key).and_then(Json::as_array).map_or(&[], Vec::as_slice)
}

/// An accessor's component type (`componentType`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Component {
    I8,
    U8,
    I16,
    U16,
    U32,
    F32,
}

impl Component {
    /// The type for a `componentType` code.
    fn from_code(code: usize) -> Option<Self> {
        Some(match code {
            5120 => Component::I8,
            5121 => Component::U8,
            5122 => Component::I16,
            5123 => Component::U16,
            5125 => Component::U32,
            5126 => Component::F32,
            _ => return None,
        })
    }

    /// Bytes per component.
    pub fn size(self) -> usize {
        match self {
            Component::I8 | Component::U8 => 1,
            Component::I16 | Component::U16 => 2,
            Component::U32 | Component::F32 => 4,
        }
    }

    /// Whether it is an unsigned integer (what indices must be).
    pub fn is_unsigned_integer(self) -> bool {
        matches!(self, Component::U8 | Component::U16 | Component::U32)
    }

    /// The divisor of a normalized integer (1 for floats), and whether it is signed: signed
    /// values are clamped at -1 (the spec's `max(c / 127, -1)`).
    fn normalizer(self) -> (f64, bool) {
        match self {
            Component::I8 => (127.0, true),
            Component::U8 => (255.0, false),
            Component::I16 => (32767.0, true),
            Component::U16 => (65535.0, false),
            Component::U32 => (u32::MAX as f64, false),
            Component::F32 => (1.0, false),
        }
    }

    /// Component `c` of element `i` of `bytes` with `stride` (exact in f64 for every type).
    fn read(self, bytes: &[u8], stride: usize, i: usize, c: usize) -> f64 {
        let b = &bytes[i * stride + c * self.size()..];
        match self {
            Component::I8 => b[0] as i8 as f64,
            Component::U8 => b[0] as f64,
            Component::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
            Component::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
            Component::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Component::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
        }
    }
}

/// An accessor, as far as we read it.
#[derive(Clone, Debug)]
pub(super) struct Accessor {
    pub index: usize,
    view: Option<usize>,
    offset: usize,
    pub component: Component,
    pub normalized: bool,
    pub count: usize,
    /// Components per element: 1 (SCALAR) to 4 (VEC4); matrices are not read.
    pub width: usize,
    sparse: Option<Sparse>,
}

/// A sparse accessor's substitutions: `count` indices, and as many values.
#[derive(Clone, Debug)]
struct Sparse {
    count: usize,
    indices_view: usize,
    indices_offset: usize,
    indices_component: Component,
    values_view: usize,
    values_offset: usize,
}

impl<'a> Doc<'a> {
    /// The document `root` over its buffers.
    pub fn new(root: &'a Json, buffers: &'a [Result<Vec<u8>, String>]) -> Self {
        let decoded = array(root, "bufferViews").iter().map(|_| OnceCell::new()).collect();
        Doc { root, buffers, decoded }
    }

    /// Accessor `index`, its properties checked (not yet its bytes).
    pub fn accessor(&self, index: usize, what: &str) -> Result<Accessor, String> {
        let at = format!("accessor {index} ({what})");
        let acc = array(self.root, "accessors").get(index).ok_or_else(|| {
            format!(
                "{what} is accessor {index}, but the file has {} accessors",
                array(self.root, "accessors").len()
            )
        })?;
        let code = uint(acc, "componentType", &at)?.unwrap_or(0);
        let component = Component::from_code(code)
            .ok_or_else(|| format!("{at} has an unknown componentType {code}"))?;
        let kind = acc.get("type").and_then(Json::as_str).unwrap_or("");
        let width = match kind {
            "SCALAR" => 1,
            "VEC2" => 2,
            "VEC3" => 3,
            "VEC4" => 4,
            _ => {
                return Err(format!(
                    "{at} is of type `{}`, which is not read for {what}",
                    crate::files::shown(kind, 20)
                ))
            }
        };
        let count = uint(acc, "count", &at)?.ok_or(format!("{at} has no count"))?;
        let sparse = match acc.get("sparse") {
            None => None,
            Some(s) => {
                let indices = s.get("indices").ok_or(format!("{at}: sparse without indices"))?;
                let values = s.get("values").ok_or(format!("{at}: sparse without values"))?;
                let need = |v: &Json, key: &str| {
                    uint(v, key, &at)?.ok_or(format!("{at}: sparse {key} missing"))
                };
                let code = need(indices, "componentType")?;
                let indices_component = Component::from_code(code)
                    .filter(|c| c.is_unsigned_integer())
                    .ok_or(format!("{at}: sparse indices of componentType {code}"))?;
                Some(Sparse {
                    count: need(s, "count")?,
                    indices_view: need(indices, "bufferView")?,
                    indices_offset: uint(indices, "byteOffset", &at)?.unwrap_or(0),
                    indices_component,
                    values_view: need(values, "bufferView")?,
                    values_offset: uint(values, "byteOffset", &at)?.unwrap_or(0),
                })
            }
        };
        Ok(Accessor {
            index,
            view: uint(acc, "bufferView", &at)?,
            offset: uint(acc, "byteOffset", &at)?.unwrap_or(0),
            component,
            normalized: acc.get("normalized").and_then(Json::as_bool).unwrap_or(false),
            count,
            width,
            sparse,
        })
    }

    /// The bytes of buffer view `view` (decompressed if it is) and its byte stride, checked
    /// to lie in its buffer.
    fn view_bytes(&self, view: usize, at: &str) -> Result<(&[u8], Option<usize>), String> {
        let v = array(self.root, "bufferViews").get(view).ok_or_else(|| {
            format!(
                "{at} uses buffer view {view}, but the file has {}",
                array(self.root, "bufferViews").len()
            )
        })?;
        let what = format!("buffer view {view}");
        let stride = uint(v, "byteStride", &what)?;
        if let Some(ext) = meshopt::extension(v) {
            let decoded = self.decoded[view]
                .get_or_init(|| self.meshopt_view(ext, &what))
                .as_ref()
                .map_err(Clone::clone)?;
            return Ok((decoded.bytes(), stride));
        }
        let buffer = uint(v, "buffer", &what)?.ok_or(format!("{what} has no buffer"))?;
        let offset = uint(v, "byteOffset", &what)?.unwrap_or(0);
        let length = uint(v, "byteLength", &what)?.unwrap_or(0);
        Ok((self.buffer_range(buffer, offset, length, &what)?, stride))
    }

    /// The bytes of a meshopt-compressed buffer view (`ext` its extension object, `what`
    /// names the view), decoded.
    fn meshopt_view(&self, ext: &Json, what: &str) -> Result<meshopt::Decoded, String> {
        let need =
            |key: &str| uint(ext, key, what)?.ok_or(format!("{what}: meshopt `{key}` missing"));
        let (buffer, length) = (need("buffer")?, need("byteLength")?);
        let offset = uint(ext, "byteOffset", what)?.unwrap_or(0);
        let view = meshopt::View {
            source: self.buffer_range(buffer, offset, length, what)?,
            stride: need("byteStride")?,
            count: need("count")?,
            mode: ext.get("mode").and_then(Json::as_str).unwrap_or(""),
            filter: ext.get("filter").and_then(Json::as_str).unwrap_or("NONE"),
        };
        meshopt::decode(view, what)
    }

    /// `length` bytes from `offset` of buffer `buffer`, checked to lie in it; `what` (a buffer
    /// view) names the range in messages.
    pub fn buffer_range(
        &self,
        buffer: usize,
        offset: usize,
        length: usize,
        what: &str,
    ) -> Result<&'a [u8], String> {
        let data = match self.buffers.get(buffer) {
            Some(Ok(data)) => data,
            Some(Err(e)) => return Err(e.clone()),
            None => {
                return Err(format!(
                    "{what} uses buffer {buffer}, but the file has {}",
                    self.buffers.len()
                ))
            }
        };
        offset
            .checked_add(length)
            .filter(|&e| e <= data.len())
            .map(|e| &data[offset..e])
            .ok_or(format!("{what} runs past the end of buffer {buffer}"))
    }

    /// The bytes of buffer view `view` (an image's or Draco's), checked to lie in its buffer.
    pub fn buffer_view(&self, view: usize, at: &str) -> Result<&[u8], String> {
        self.view_bytes(view, at).map(|(bytes, _)| bytes)
    }

    /// `count` elements of `elem` bytes from `offset` in a view (its stride, or packed when
    /// `packed` or it has none), checked to lie inside it; returns the bytes and stride.
    fn element_bytes(
        &self,
        view: usize,
        offset: usize,
        count: usize,
        elem: usize,
        packed: bool,
        at: &str,
    ) -> Result<(&[u8], usize), String> {
        let (bytes, stride) = self.view_bytes(view, at)?;
        let stride = if packed { elem } else { stride.unwrap_or(elem) };
        if stride < elem {
            return Err(format!(
                "buffer view {view} has a stride of {stride} bytes, less than an element of {at}"
            ));
        }
        let needed = match count {
            0 => Some(0),
            n => (n - 1).checked_mul(stride).and_then(|n| n.checked_add(elem)),
        };
        match needed.and_then(|n| n.checked_add(offset)) {
            Some(end) if end <= bytes.len() => Ok((&bytes[offset..], stride)),
            _ => Err(format!(
                "{at} runs past the end of its buffer view {view} ({count} elements from byte {offset})"
            )),
        }
    }

    /// An accessor's values, `width` per element, each through `map` (from the exact value as
    /// f64, normalized integers already scaled to [0, 1] or [-1, 1]): zeros without a buffer
    /// view, then the sparse substitutions.
    pub fn read<T: Copy + Default>(
        &self,
        acc: &Accessor,
        what: &str,
        map: impl Fn(f64) -> T,
    ) -> Result<Vec<T>, String> {
        let at = format!("accessor {} ({what})", acc.index);
        let (width, kind) = (acc.width, acc.component);
        let elem = kind.size() * width;
        let (scale, signed) = if acc.normalized { kind.normalizer() } else { (1.0, false) };
        let value = |v: f64| map(if signed { (v / scale).max(-1.0) } else { v / scale });
        let mut out = match acc.view {
            Some(view) => {
                let (bytes, stride) =
                    self.element_bytes(view, acc.offset, acc.count, elem, false, &at)?;
                let mut out = Vec::with_capacity(acc.count * width);
                for i in 0..acc.count {
                    out.extend((0..width).map(|c| value(kind.read(bytes, stride, i, c))));
                }
                out
            }
            None if acc.count > MAX_ZERO_ELEMENTS => {
                return Err(format!(
                    "{at} has {} elements and no buffer view (more than {MAX_ZERO_ELEMENTS} zeros)",
                    acc.count
                ))
            }
            None => vec![value(0.0); acc.count * width],
        };
        if let Some(s) = &acc.sparse {
            let (indices, istride) = self.element_bytes(
                s.indices_view,
                s.indices_offset,
                s.count,
                s.indices_component.size(),
                true,
                &format!("{at} sparse indices"),
            )?;
            let (values, vstride) = self.element_bytes(
                s.values_view,
                s.values_offset,
                s.count,
                elem,
                true,
                &format!("{at} sparse values"),
            )?;
            for k in 0..s.count {
                let i = s.indices_component.read(indices, istride, k, 0) as usize;
                if i >= acc.count {
                    return Err(format!(
                        "{at}: sparse index {i} is out of range (the accessor has {} elements)",
                        acc.count
                    ));
                }
                for c in 0..width {
                    out[i * width + c] = value(kind.read(values, vstride, k, c));
                }
            }
        }
        Ok(out)
    }
}
