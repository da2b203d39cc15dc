//! The parallel reader of ASCII bodies (see [`read_ascii_in_parallel`]).

use std::ops::Range;

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::binary::Columns;
use super::body::{corner_list, push_face, VertexColumns};
use super::number::value;
use super::{Attributes, Element, Header, Property};

/// The bytes of body text each thread's piece is cut at (at the next line's start): small
/// enough that a 7 MB scan is shared by 16 threads several times over, large enough that a
/// piece's setup is lost in its parsing.
pub(super) const CHUNK_BYTES: usize = 256 << 10;

/// What each element's records become.
#[derive(Clone, Copy, PartialEq)]
enum Role {
    Vertex,
    Face,
    Skipped,
}

/// The common ASCII file, one record a line (as every exporter writes them), read with its
/// lines split between threads: each piece's first line is found by counting the line ends
/// before it, and the header's counts say which element a line belongs to, and so where
/// its vertex or triangle goes in the whole mesh's arrays (a face that is not a triangle
/// sends its piece's triangles to a list of their own, joined after). None when the file
/// is anything else (a record over two lines, two on one, several vertex or face elements)
/// or anything in it is wrong: `read_body` then reads it, and says what and on which line.
/// Since both readers parse a value with [`value`] and end a record with the same
/// functions, what this one reads is what `read_body` would have read.
pub(super) fn read_ascii_in_parallel(
    header: &Header,
    body: &[u8],
    chunk_bytes: usize,
) -> Option<Columns> {
    let elements = &header.elements;
    let count = |name: &str| elements.iter().filter(|e| e.name == name).count();
    // `read_body` reads a second vertex or face element by rules of its own: it alone reads those.
    if count("vertex") != 1 || count("face") != 1 {
        return None;
    }
    // A record of no values takes no line: such an element is `read_body`'s too.
    if elements.iter().any(|e| e.count > 0 && e.properties.is_empty()) {
        return None;
    }
    let vertex = elements.iter().find(|e| e.name == "vertex")?;
    let face = elements.iter().find(|e| e.name == "face")?;
    let records = elements.iter().try_fold(0u64, |n, e| n.checked_add(e.count))?;
    let first_of =
        |name: &str| elements.iter().take_while(|e| e.name != name).map(|e| e.count).sum::<u64>();
    let plan = Plan {
        elements,
        columns: VertexColumns::of(vertex).ok()?,
        corners: corner_list(face).ok()?,
        vertex_count: vertex.count,
        vertices: first_of("vertex")..first_of("vertex") + vertex.count,
        faces: first_of("face")..first_of("face") + face.count,
    };
    let pieces = split_at_lines(body, chunk_bytes.max(1));
    let line_ends: Vec<u64> = pieces.par_iter().map(|piece| line_ends_in(piece)).collect();
    // Each piece's records: one a line, up to the body's last.
    let mut jobs = Vec::with_capacity(pieces.len());
    let mut first = 0u64;
    for (piece, ends) in pieces.into_iter().zip(line_ends) {
        if first >= records {
            break;
        }
        let lines = ends + u64::from(!piece.ends_with(b"\n"));
        jobs.push((first..(first + lines).min(records), piece));
        first += lines;
    }
    // Fewer lines than records: the file is cut short, or its records span lines.
    if first < records {
        return None;
    }
    // The body is at least 2 bytes a value (checked against the header's counts), so the
    // vertex arrays are at most a few times the file's size; the triangles are made room for
    // one a face only where the body could hold that many triangles (`3 0 1 2`, 7 bytes), so
    // that a file of empty lines cannot ask for twelve times its size.
    if face.count.saturating_mul(7) > body.len() as u64 {
        return None;
    }
    let (has_normals, has_texcoords, has_colours) = plan.columns.has();
    let vertices = usize::try_from(vertex.count).ok()?;
    let mut out = Output {
        positions: filled(vertices, true),
        normals: filled(vertices, has_normals),
        texcoords: filled(vertices, has_texcoords),
        colors: filled(vertices, has_colours),
        triangles: filled(usize::try_from(face.count).ok()?, true),
    };
    let slots = out.slots(&plan, &jobs);
    let faces: Vec<usize> = jobs.iter().map(|(lines, _)| overlap(lines, &plan.faces)).collect();
    let overflows: Vec<Option<Vec<[u32; 3]>>> = jobs
        .into_par_iter()
        .zip(slots)
        .map(|((lines, piece), slots)| plan.read(lines, piece, slots))
        .collect::<Option<_>>()?;
    let Output { positions, normals, texcoords, colors, mut triangles } = out;
    if overflows.iter().any(Option::is_some) {
        triangles = join_triangles(&triangles, &faces, overflows);
    }
    Some((positions, Attributes { normals, texcoords, colors }, triangles))
}

/// `bytes` cut into pieces of about `size` bytes, each but the first starting a line.
fn split_at_lines(bytes: &[u8], size: usize) -> Vec<&[u8]> {
    let mut pieces = Vec::with_capacity(bytes.len() / size + 1);
    let mut start = 0;
    while start < bytes.len() {
        let cut = start.saturating_add(size).min(bytes.len());
        let end =
            bytes[cut..].iter().position(|&b| b == b'\n').map_or(bytes.len(), |i| cut + i + 1);
        pieces.push(&bytes[start..end]);
        start = end;
    }
    pieces
}

/// The `\n` bytes in `bytes`, counted 255 at a time in bytes: 32 bytes an instruction,
/// where counting into a `usize` widened each byte (a 20th of a 2M-triangle file's parse).
fn line_ends_in(bytes: &[u8]) -> u64 {
    bytes
        .chunks(255)
        .map(|c| c.iter().map(|&b| u8::from(b == b'\n')).fold(0u8, u8::wrapping_add) as u64)
        .sum()
}

/// `n` default values (none when not `wanted`), written on every core: `resize` would fault
/// the pages in on one thread.
fn filled<T: Copy + Send + Sync + Default>(n: usize, wanted: bool) -> Vec<T> {
    let n = if wanted { n } else { 0 };
    let mut v = crate::memory::with_huge_pages(n);
    v.par_extend(rayon::iter::repeat_n(T::default(), n));
    v
}

/// The whole mesh's arrays, which the pieces write their parts of.
struct Output {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    texcoords: Vec<Vec2>,
    colors: Vec<[u8; 4]>,
    /// One triangle a face, while every face is one.
    triangles: Vec<[u32; 3]>,
}

/// One piece's parts of the [`Output`].
#[derive(Default)]
struct Slots<'a> {
    positions: &'a mut [Vec3],
    normals: &'a mut [Vec3],
    texcoords: &'a mut [Vec2],
    colors: &'a mut [[u8; 4]],
    triangles: &'a mut [[u32; 3]],
}

impl Output {
    /// Each job's parts: the vertices and faces among its records.
    fn slots<'a>(&'a mut self, plan: &Plan, jobs: &[(Range<u64>, &[u8])]) -> Vec<Slots<'a>> {
        let mut rest = Slots {
            positions: &mut self.positions,
            normals: &mut self.normals,
            texcoords: &mut self.texcoords,
            colors: &mut self.colors,
            triangles: &mut self.triangles,
        };
        jobs.iter()
            .map(|(lines, _)| {
                let v = overlap(lines, &plan.vertices);
                let f = overlap(lines, &plan.faces);
                Slots {
                    positions: take_front(&mut rest.positions, v),
                    normals: take_front(&mut rest.normals, v),
                    texcoords: take_front(&mut rest.texcoords, v),
                    colors: take_front(&mut rest.colors, v),
                    triangles: take_front(&mut rest.triangles, f),
                }
            })
            .collect()
    }
}

/// How many of `a` are in `b`.
fn overlap(a: &Range<u64>, b: &Range<u64>) -> usize {
    (a.end.min(b.end).saturating_sub(a.start.max(b.start))) as usize
}

/// The first `n` items of `s` (which keeps the rest); all there are of an empty array.
fn take_front<'a, T>(s: &mut &'a mut [T], n: usize) -> &'a mut [T] {
    let all = std::mem::take(s);
    let (front, rest) = all.split_at_mut(n.min(all.len()));
    *s = rest;
    front
}

/// The triangles of every piece in order: its own list where it made one, else its
/// `faces` triangles of `in_place`, copied on every core.
fn join_triangles(
    in_place: &[[u32; 3]],
    faces: &[usize],
    own: Vec<Option<Vec<[u32; 3]>>>,
) -> Vec<[u32; 3]> {
    let mut rest = in_place;
    let parts: Vec<&[[u32; 3]]> = faces
        .iter()
        .zip(&own)
        .map(|(&n, list)| {
            let (front, back) = rest.split_at(n);
            rest = back;
            list.as_deref().unwrap_or(front)
        })
        .collect();
    let mut all = filled(parts.iter().map(|p| p.len()).sum(), true);
    let mut to = all.as_mut_slice();
    let pairs: Vec<_> = parts.iter().map(|p| (take_front(&mut to, p.len()), *p)).collect();
    pairs.into_par_iter().for_each(|(to, from)| to.copy_from_slice(from));
    all
}

/// What the header says about the body, for every piece.
struct Plan<'a> {
    elements: &'a [Element],
    columns: VertexColumns,
    /// The face element's list of corners.
    corners: usize,
    vertex_count: u64,
    /// The records of the vertex and the face element.
    vertices: Range<u64>,
    faces: Range<u64>,
}

impl Plan<'_> {
    /// Read records `lines` from `piece`, one a line, into `slots`. Its triangles, when a
    /// face is not one: the piece's own list of them.
    fn read(&self, lines: Range<u64>, piece: &[u8], slots: Slots) -> Option<Option<Vec<[u32; 3]>>> {
        let mut values = vec![0.0f64; self.elements.iter().map(|e| e.properties.len()).max()?];
        let mut corners: Vec<f64> = Vec::new();
        let mut face: Vec<[u32; 3]> = Vec::with_capacity(4);
        let mut own: Option<Vec<[u32; 3]>> = None;
        let mut line = Line { text: piece, pos: 0 };
        let (mut record, mut vertex, mut triangle) = (lines.start, 0, 0);
        // The elements' records follow each other: element `e` holds records start..end.
        let mut start = 0u64;
        for e in self.elements {
            let end = (start + e.count).min(lines.end);
            let role = match e.name.as_str() {
                "vertex" => Role::Vertex,
                "face" => Role::Face,
                _ => Role::Skipped,
            };
            let values = &mut values[..e.properties.len()];
            while record < end {
                self.record(e, role, &mut line, values, &mut corners)?;
                match role {
                    Role::Vertex => {
                        let (p, n, uv, c) = self.columns.vertex(values)?;
                        slots.positions[vertex] = p;
                        if let Some(slot) = slots.normals.get_mut(vertex) {
                            *slot = n;
                        }
                        if let Some(slot) = slots.texcoords.get_mut(vertex) {
                            *slot = uv;
                        }
                        if let Some(slot) = slots.colors.get_mut(vertex) {
                            *slot = c;
                        }
                        vertex += 1;
                    }
                    Role::Face => {
                        face.clear();
                        push_face(&corners, self.vertex_count, &mut face).ok()?;
                        match (&mut own, face.as_slice()) {
                            (None, [t]) => slots.triangles[triangle] = *t,
                            (None, _) => {
                                let mut list = slots.triangles[..triangle].to_vec();
                                list.extend_from_slice(&face);
                                own = Some(list);
                            }
                            (Some(list), _) => list.extend_from_slice(&face),
                        }
                        triangle += 1;
                    }
                    Role::Skipped => {}
                }
                record += 1;
            }
            start += e.count;
        }
        Some(own)
    }

    /// Read one record's values from the line (lists as 0, and the face's corners into
    /// `corners`) and the line's end: None when a value is wrong or missing, or more follow.
    #[inline]
    fn record(
        &self,
        e: &Element,
        role: Role,
        line: &mut Line,
        values: &mut [f64],
        corners: &mut Vec<f64>,
    ) -> Option<()> {
        for (k, (_, p)) in e.properties.iter().enumerate() {
            values[k] = match *p {
                Property::Scalar(kind) => value(line.word()?, kind)?,
                Property::List { count, item } => {
                    let keep = role == Role::Face && k == self.corners;
                    if keep {
                        corners.clear();
                    }
                    let n = value(line.word()?, count)?;
                    if n < 0.0 {
                        return None;
                    }
                    // A count beyond the line's values fails at its end, after at most a line's worth.
                    for _ in 0..n as u64 {
                        let v = value(line.word()?, item)?;
                        if keep {
                            corners.push(v);
                        }
                    }
                    0.0
                }
            };
        }
        line.end()
    }
}

/// A piece of text read a line at a time, a word at a time.
struct Line<'a> {
    text: &'a [u8],
    pos: usize,
}

impl<'a> Line<'a> {
    /// The next word on this line; None at its end. Words are parted by ASCII white space,
    /// as `Body::next` parts them.
    #[inline]
    fn word(&mut self) -> Option<&'a [u8]> {
        while let Some(&b) = self.text.get(self.pos) {
            if b == b'\n' || !b.is_ascii_whitespace() {
                break;
            }
            self.pos += 1;
        }
        let start = self.pos;
        while self.text.get(self.pos).is_some_and(|b| !b.is_ascii_whitespace()) {
            self.pos += 1;
        }
        (self.pos > start).then(|| &self.text[start..self.pos])
    }

    /// Past the end of this line: None when a word is left on it.
    #[inline]
    fn end(&mut self) -> Option<()> {
        if self.word().is_some() {
            return None;
        }
        if self.text.get(self.pos) == Some(&b'\n') {
            self.pos += 1;
        }
        Some(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_record_a_line_is_read_here_and_anything_else_left_to_the_serial_reader() {
        let head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
        let read = |body: &str, size: usize| {
            let text = format!("{head}{body}");
            let header = super::super::parse_header(text.as_bytes()).ok().unwrap();
            read_ascii_in_parallel(&header, &text.as_bytes()[header.body_start..], size)
        };
        for size in [1, 5, 1000] {
            let (positions, _, triangles) =
                read("0 0 0\n1 0 0\r\n 0 1 0 \n4 0 1 2 1\n", size).unwrap();
            assert_eq!(positions, [Vec3::ZERO, Vec3::X, Vec3::Y], "size {size}");
            assert_eq!(triangles, [[0, 1, 1], [1, 2, 1]], "size {size}");
            assert!(read("0 0 0\n1 0 0 0 1\n0\n3 0 1 2\n", size).is_none(), "size {size}");
            assert!(read("0 0 0\n1 0 0\n0 1 0\n3 0 1 2 3\n", size).is_none(), "size {size}");
            assert!(read("0 0 0\n1 0 0\n0 1 0\n", size).is_none(), "size {size}");
            assert!(read("0 0 0\n1 0 0\n0 1 0\n3 0 1\n", size).is_none(), "size {size}");
        }
    }

    #[test]
    fn pieces_start_lines_and_cover_the_text() {
        let text = b"a b\nc\n\nd e f\ng";
        for size in 1..=text.len() + 1 {
            let pieces = split_at_lines(text, size);
            assert_eq!(pieces.concat(), text, "size {size}");
            assert!(pieces.iter().all(|p| !p.is_empty()), "size {size}");
            assert!(pieces.iter().rev().skip(1).all(|p| p.ends_with(b"\n")), "size {size}");
            let ends: u64 = pieces.iter().map(|p| line_ends_in(p)).sum();
            assert_eq!(ends, 4, "size {size}");
        }
    }
}
