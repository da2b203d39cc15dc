//! The serial reader: the body's values one at a time ([`Body`], ASCII or binary) and every
//! element in order (`read_body`): vertices and faces into the mesh, the rest skipped. It
//! reads every file the parallel binary reader does not, and says what is wrong with one.

use glam::{Vec2, Vec3};

use super::number::value;
use super::{
    finish_mesh, quote, Attributes, ColourColumns, Element, Failure, Header, Location, Property,
    Scalar, MAX_INITIAL_CAPACITY,
};
use crate::scene::{Material, Mesh};

/// The body: numbers in text, or packed binary values.
pub(super) enum Body<'a> {
    Ascii { text: &'a [u8], pos: usize, line: usize },
    Binary { data: &'a [u8], pos: usize, big_endian: bool },
}

impl Body<'_> {
    /// The next value as `kind`, widened to f64 (every PLY type fits it exactly).
    #[inline]
    pub(super) fn next(&mut self, kind: Scalar) -> Result<f64, String> {
        match self {
            Body::Ascii { text, pos, line } => {
                // The line moves on only when a value follows: a cut file is named by its last line.
                let mut newlines = 0;
                while let Some(&b) = text.get(*pos) {
                    if !b.is_ascii_whitespace() {
                        break;
                    }
                    newlines += usize::from(b == b'\n');
                    *pos += 1;
                }
                let start = *pos;
                while text.get(*pos).is_some_and(|b| !b.is_ascii_whitespace()) {
                    *pos += 1;
                }
                if start == *pos {
                    return Err("the file ends here: it seems to be cut short".to_owned());
                }
                *line += newlines;
                let word = &text[start..*pos];
                value(word, kind).ok_or_else(|| {
                    let word = std::str::from_utf8(word).unwrap_or("?");
                    format!("{} is not a valid {} value", quote(word), kind.name())
                })
            }
            Body::Binary { data, pos, big_endian } => {
                let size = kind.size();
                let Some(raw) = data.get(*pos..*pos + size) else {
                    return Err("the file ends here: it seems to be cut short".to_owned());
                };
                *pos += size;
                let mut b = [0u8; 8];
                b[..size].copy_from_slice(raw);
                if *big_endian {
                    b[..size].reverse();
                }
                Ok(match kind {
                    Scalar::I8 => b[0] as i8 as f64,
                    Scalar::U8 => b[0] as f64,
                    Scalar::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
                    Scalar::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
                    Scalar::I32 => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    Scalar::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    Scalar::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    Scalar::F64 => f64::from_le_bytes(b),
                })
            }
        }
    }

    /// In ASCII, the values left on the line the last value was read from (None when there
    /// are none, and always in binary). Each element is a line: values left over mean its
    /// list's count is wrong, and reading on would take them for the next element's.
    fn rest_of_line(&self) -> Option<&str> {
        let Body::Ascii { text, pos, .. } = self else { return None };
        let rest = &text[*pos..];
        let rest = &rest[..rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len())];
        let rest = std::str::from_utf8(rest).unwrap_or("?").trim();
        (!rest.is_empty()).then_some(rest)
    }

    /// Where the reader is, for a message about element `index` of `element`.
    pub(super) fn location(&self, element: &str, index: u64) -> Location {
        match self {
            Body::Ascii { line, .. } => Location::Line(*line),
            Body::Binary { .. } => Location::Element(format!("{element} {index}")),
        }
    }

    /// Read one property, calling `item` with each value of a list (none for a scalar).
    #[inline]
    pub(super) fn property(
        &mut self,
        p: &Property,
        mut item: impl FnMut(f64),
    ) -> Result<Option<f64>, String> {
        match *p {
            Property::Scalar(s) => self.next(s).map(Some),
            Property::List { count, item: kind } => {
                let n = self.next(count)?;
                if n < 0.0 {
                    return Err(format!("a list has a negative length ({n})"));
                }
                for _ in 0..n as u64 {
                    item(self.next(kind)?);
                }
                Ok(None)
            }
        }
    }
}

/// Read every element in order: vertices and faces into the mesh, the rest skipped.
pub(super) fn read_body(
    header: &Header,
    body: &mut Body,
    name: &str,
    warnings: &mut Vec<String>,
) -> Result<Mesh, Failure> {
    let vertex_count = header.elements.iter().find(|e| e.name == "vertex").map_or(0, |e| e.count);
    let mut mesh =
        Mesh { name: name.to_owned(), materials: vec![Material::default()], ..Default::default() };
    let mut attributes = Attributes::default();
    let mut saw_vertices = false;
    for e in &header.elements {
        match e.name.as_str() {
            "vertex" if !saw_vertices => {
                saw_vertices = true;
                read_vertices(e, body, &mut mesh.positions, &mut attributes)?;
            }
            "face" if mesh.triangles.is_empty() => {
                read_faces(e, body, vertex_count, &mut mesh.triangles)?;
            }
            // Another element (or a second vertex/face one): skipped by its layout.
            _ => skip_element(e, body)?,
        }
    }
    finish_mesh(mesh, attributes, header, name, warnings)
}

/// Vectors start at most this big, whatever the header's count says.
fn capacity(n: u64) -> usize {
    (n as usize).min(MAX_INITIAL_CAPACITY)
}

/// Which of a vertex's properties hold what we keep.
pub(super) struct VertexColumns {
    xyz: [usize; 3],
    normal: Option<[usize; 3]>,
    uv: Option<[usize; 2]>,
    colours: Option<ColourColumns>,
}

impl VertexColumns {
    /// The columns of `element vertex`; an error when x, y or z is missing.
    pub(super) fn of(e: &Element) -> Result<Self, Failure> {
        let missing = |axis: &str| {
            (Location::File, format!("`element vertex` has no scalar property {axis}"))
        };
        let xyz = [
            e.find(&["x"]).ok_or_else(|| missing("x"))?,
            e.find(&["y"]).ok_or_else(|| missing("y"))?,
            e.find(&["z"]).ok_or_else(|| missing("z"))?,
        ];
        let n = [e.find(&["nx"]), e.find(&["ny"]), e.find(&["nz"])];
        let normal = if let [Some(a), Some(b), Some(c)] = n { Some([a, b, c]) } else { None };
        let uv = match (
            e.find(&["u", "s", "texture_u", "texture_s"]),
            e.find(&["v", "t", "texture_v", "texture_t"]),
        ) {
            (Some(a), Some(b)) => Some([a, b]),
            _ => None,
        };
        let colours = ColourColumns::of(e).map_err(|r| (Location::File, r))?;
        Ok(VertexColumns { xyz, normal, uv, colours })
    }

    /// A record's vertex from its `values` (one per property, widened to f64): its
    /// position, normal, texture coordinate and colour (zeros for those the file lacks), or
    /// None when the position is not finite. Both readers of ASCII bodies make each vertex
    /// here, so they make the same vertices.
    #[inline]
    pub(super) fn vertex(&self, values: &[f64]) -> Option<(Vec3, Vec3, Vec2, [u8; 4])> {
        let p = Vec3::from(self.xyz.map(|k| values[k] as f32));
        if !p.is_finite() {
            return None;
        }
        let n = self.normal.map_or(Vec3::ZERO, |n| Vec3::from(n.map(|k| values[k] as f32)));
        let uv = self.uv.map_or(Vec2::ZERO, |uv| Vec2::from(uv.map(|k| values[k] as f32)));
        let c = self.colours.as_ref().map_or([0; 4], |c| c.rgba(|k| values[k]));
        Some((p, n, uv, c))
    }

    /// Whether the file has normals, texture coordinates and colours.
    pub(super) fn has(&self) -> (bool, bool, bool) {
        (self.normal.is_some(), self.uv.is_some(), self.colours.is_some())
    }
}

/// The vertices: positions (which must be finite) and the attributes the file has.
fn read_vertices(
    e: &Element,
    body: &mut Body,
    positions: &mut Vec<Vec3>,
    attributes: &mut Attributes,
) -> Result<(), Failure> {
    let columns = VertexColumns::of(e)?;
    let (normals, texcoords, colours) = columns.has();
    positions.reserve(capacity(e.count));
    let mut values = vec![0.0f64; e.properties.len()];
    for i in 0..e.count {
        for (k, (_, p)) in e.properties.iter().enumerate() {
            values[k] = body
                .property(p, |_| {})
                .map_err(|r| (body.location("vertex", i), r))?
                .unwrap_or(0.0);
        }
        let Some((p, n, uv, c)) = columns.vertex(&values) else {
            return Err((body.location("vertex", i), "a vertex position has a coordinate that is not a finite number (NaN, infinity or beyond f32)".to_owned()));
        };
        positions.push(p);
        if normals {
            attributes.normals.push(n);
        }
        if texcoords {
            attributes.texcoords.push(uv);
        }
        if colours {
            attributes.colors.push(c);
        }
    }
    Ok(())
}

/// The faces, each split into triangles by [`push_face`].
fn read_faces(
    e: &Element,
    body: &mut Body,
    vertex_count: u64,
    triangles: &mut Vec<[u32; 3]>,
) -> Result<(), Failure> {
    let list = corner_list(e)?;
    triangles.reserve(capacity(e.count));
    let mut corners: Vec<f64> = Vec::new();
    for i in 0..e.count {
        for (k, (_, p)) in e.properties.iter().enumerate() {
            let keep = k == list;
            if keep {
                corners.clear();
            }
            body.property(p, |v| {
                if keep {
                    corners.push(v)
                }
            })
            .map_err(|r| (body.location("face", i), r))?;
        }
        // A binary file's location names the face already; an ASCII line is given it.
        let fail = |reason: String| match body.location("face", i) {
            Location::Line(line) => (Location::Line(line), format!("face {i}: {reason}")),
            other => (other, reason),
        };
        if let Some(rest) = body.rest_of_line() {
            return Err(fail(format!("its vertex count says {} but the line holds more values ({}); a face is one line: its count, its indices and its other properties", corners.len(), quote(rest))));
        }
        push_face(&corners, vertex_count, triangles).map_err(fail)?;
    }
    Ok(())
}

/// The index of `element face`'s list of corners.
pub(super) fn corner_list(e: &Element) -> Result<usize, Failure> {
    e.properties
        .iter()
        .position(|(n, p)| {
            (n == "vertex_indices" || n == "vertex_index") && matches!(p, Property::List { .. })
        })
        .ok_or((Location::File, "`element face` has no list property vertex_indices".to_owned()))
}

/// Split a face into triangles (quads as the paper does, larger ones into fans); its
/// corners must name one of the `vertex_count` vertices. Both readers of ASCII bodies end
/// each face here, so they make the same triangles.
#[inline]
pub(super) fn push_face(
    corners: &[f64],
    vertex_count: u64,
    triangles: &mut Vec<[u32; 3]>,
) -> Result<(), String> {
    if corners.len() < 3 {
        return Err(format!("it has {} corners; at least 3 are needed", corners.len()));
    }
    if let Some(&bad) = corners.iter().find(|&&c| c < 0.0 || c >= vertex_count as f64) {
        return Err(format!(
            "vertex index {bad} is out of range (the file has {vertex_count} vertices)"
        ));
    }
    let c = |k: usize| corners[k] as u32;
    match corners.len() {
        3 => triangles.push([c(0), c(1), c(2)]),
        4 => triangles.extend([[c(0), c(1), c(3)], [c(1), c(2), c(3)]]),
        n => triangles.extend((1..n - 1).map(|k| [c(0), c(k), c(k + 1)])),
    }
    Ok(())
}

/// Read past an element we do not keep, value by value.
fn skip_element(e: &Element, body: &mut Body) -> Result<(), Failure> {
    if e.properties.is_empty() {
        return Ok(());
    }
    for i in 0..e.count {
        for (_, p) in &e.properties {
            body.property(p, |_| {}).map_err(|r| (body.location(&e.name, i), r))?;
        }
    }
    Ok(())
}
