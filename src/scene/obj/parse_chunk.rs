//! The parse of one chunk of an OBJ (chunks run in parallel), with the rules the loader
//! has always had (tobj's reading of each statement, and the face checks that used to run
//! in front of it): positions, texture coordinates and normals go into the chunk's own
//! arrays; faces become corner indices resolved in the whole file; what changes between
//! faces (`o`/`g`, `usemtl`, `mtllib`, `s`) is noted as events for the join; the chunk
//! stops at its first error.
//!
//! A chunk is first read on its own ([`parse_alone`]), before the counts of the chunks
//! before it are known: one pass over its text, which is all nearly every chunk needs (a
//! face's absolute index is the same wherever the chunk lies; whether it is in range is
//! settled in the join, from the largest index each face used). A chunk with a line that
//! needs those counts (a relative index, an index out of range, an error to locate) gives
//! up and is read again, exactly, once they are known ([`parse_exact`]).

use glam::{Vec2, Vec3};

use super::chunks::{find_newline, is_ascii_space, keyword, parse_f32, Chunk, Counts};
use super::corners::Corners;
use super::fast_lines::{blank_to_line_end, fast_face, plain_face, rest_of_line, short_numbers};
use super::quote;

pub(super) use super::chunks::NONE;

/// What happens between faces, in line order. `face` is the number of faces of the
/// chunk before the line; `colours` the number of vertex colour values before it.
#[derive(Clone, Debug)]
pub(super) enum Event<'a> {
    /// `o` or `g`: a new model once the current one has faces.
    Group { face: usize, colours: usize },
    /// `usemtl name` (the name non-empty).
    Usemtl { face: usize, colours: usize, name: &'a str },
    /// `mtllib ...`: everything after the first space, trimmed.
    Mtllib { spelled: &'a str },
    /// `s ...`: the smoothing group from here on (0 for none).
    Smooth { face: usize, group: u32 },
}

/// Faces that named a texture coordinate or normal out of range and lost it.
#[derive(Debug, Default)]
pub(super) struct ChunkDropped {
    /// The faces, numbered within the chunk.
    pub(super) faces: Vec<usize>,
    /// The first: (line, index as written, count of that kind before the line).
    pub(super) first: Option<(usize, String, usize)>,
}

/// Why a chunk stopped, with where (the message's sentence is completed in the join).
#[derive(Debug)]
pub(super) struct ChunkError {
    /// 1-based line in the whole file.
    pub(super) line: usize,
    /// Byte offset just past the line (its `\n` included) in the whole text.
    pub(super) line_end: usize,
    pub(super) kind: ErrorKind,
}

/// The two shapes of a line's error.
#[derive(Debug)]
pub(super) enum ErrorKind {
    /// A statement that cannot be read: the reason, quoting the line.
    Parse(String),
    /// A face's vertex index names no vertex defined before it.
    VertexOutOfRange { index: String, count: usize },
}

/// One chunk parsed.
#[derive(Debug, Default)]
pub(super) struct ChunkFaces<'a> {
    /// The chunk's `v`, `vt` and `vn` values, in order.
    pub(super) positions: Vec<Vec3>,
    pub(super) texcoords: Vec<Vec2>,
    pub(super) normals: Vec<Vec3>,
    /// The chunk's lines and elements (up to its error, if it has one).
    pub(super) counts: Counts,
    /// Per kind (v, vt, vn): how many elements the chunks before this one must hold for
    /// every face index to be in range (the largest excess of an index over the chunk's own
    /// count before its line). Zero from [`parse_exact`], which checks each face itself.
    pub(super) need: [usize; 3],
    /// Every face's corners in order: (v, vt, vn), 0-based in the whole file, [`NONE`] when
    /// absent; position indices alone while no corner has more.
    pub(super) corners: Corners,
    /// Corners per face (at least three).
    pub(super) arities: Vec<u32>,
    pub(super) events: Vec<Event<'a>>,
    /// Vertex colour values read (tobj keeps them, and fails if faces use vertices beyond them).
    pub(super) colours: usize,
    /// The colour values of the `v x y z r g b` lines, in order, as tobj keeps them: each
    /// line's leading numbers, so a line with an unreadable one shifts the rest.
    pub(super) colour_values: Vec<f32>,
    /// Some corner has a texture coordinate / a normal; every corner has a normal.
    pub(super) any_texcoord: bool,
    pub(super) any_normal: bool,
    pub(super) all_normals: bool,
    pub(super) dropped_texcoords: ChunkDropped,
    pub(super) dropped_normals: ChunkDropped,
    /// First line with a coordinate that is not finite, per kind (position, normal,
    /// texture coordinate), read as the message for such a value has always located it.
    pub(super) non_finite: [Option<usize>; 3],
    pub(super) error: Option<ChunkError>,
}

impl ChunkFaces<'_> {
    /// Whether the faces read by [`parse_alone`] are all in range after `before`.
    pub(super) fn fits_after(&self, before: &Counts) -> bool {
        let [v, vt, vn] = self.need;
        v <= before.positions && vt <= before.texcoords && vn <= before.normals
    }
}

/// Read one chunk without the counts of the chunks before it; None when a line needs them
/// (a relative index, an error, a face to diagnose...): then [`parse_exact`] reads it.
pub(super) fn parse_alone(chunk: Chunk<'_>) -> Option<ChunkFaces<'_>> {
    let out = parse(chunk, Counts::default(), false)?;
    // Such values are located by their line in the whole file: rare, read again.
    out.non_finite.iter().all(Option::is_none).then_some(out)
}

/// Read one chunk exactly; `before` holds the lines and elements of the chunks before it.
pub(super) fn parse_exact(chunk: Chunk<'_>, before: Counts) -> ChunkFaces<'_> {
    // With the counts known no line gives up.
    parse(chunk, before, true).unwrap_or_default()
}

/// The line loop of both reads: the usual `v` and `f` lines in one pass each up to their
/// `\n` ([`Parser::fast_line`]), any other line found first and read by [`Parser::line`].
fn parse(chunk: Chunk<'_>, before: Counts, exact: bool) -> Option<ChunkFaces<'_>> {
    let mut parser = Parser {
        out: ChunkFaces { all_normals: true, ..Default::default() },
        counts: before,
        exact,
        gave_up: false,
        scratch: Vec::new(),
    };
    let (text, bytes) = (chunk.text, chunk.text.as_bytes());
    let mut at = 0;
    while at < bytes.len() {
        parser.counts.lines += 1;
        if let Some(len) = parser.fast_line(&bytes[at..]) {
            at += len;
            continue;
        }
        let end = find_newline(&bytes[at..]).map_or(bytes.len(), |i| at + i);
        let line = &text[at..end];
        at = (end + 1).min(bytes.len());
        let result = parser.line(line);
        if parser.gave_up {
            return None;
        }
        if let Err(kind) = result {
            if !exact {
                return None;
            }
            let (line, line_end) = (parser.counts.lines, chunk.offset + at);
            parser.out.error = Some(ChunkError { line, line_end, kind });
            break;
        }
    }
    parser.out.counts = parser.counts.minus(before);
    Some(parser.out)
}

struct Parser<'a> {
    out: ChunkFaces<'a>,
    /// Lines and elements up to the current line (the line itself counted), from the start
    /// of the file when exact, of the chunk otherwise.
    counts: Counts,
    /// The counts before the chunk are known: relative indices resolve, every face is
    /// checked and every error located.
    exact: bool,
    /// Not exact, and a line needs the counts.
    gave_up: bool,
    /// One face's corners, read before they are stored.
    scratch: Vec<[u32; 3]>,
}

/// A line's words as `split_whitespace` splits them, faster for ASCII.
pub(super) enum Words<'a> {
    Ascii(&'a [u8], &'a str),
    Unicode(std::str::SplitWhitespace<'a>),
}

/// The words of `text`.
pub(super) fn words(text: &str) -> Words<'_> {
    if text.is_ascii() {
        Words::Ascii(text.as_bytes(), text)
    } else {
        Words::Unicode(text.split_whitespace())
    }
}

impl<'a> Iterator for Words<'a> {
    type Item = &'a str;

    fn next(&mut self) -> Option<&'a str> {
        match self {
            Words::Unicode(split) => split.next(),
            Words::Ascii(bytes, text) => {
                let start = bytes.iter().position(|&b| !is_ascii_space(b))?;
                let len = bytes[start..]
                    .iter()
                    .position(|&b| is_ascii_space(b))
                    .unwrap_or(bytes.len() - start);
                let word = &text[start..start + len];
                (*bytes, *text) = (&bytes[start + len..], &text[start + len..]);
                Some(word)
            }
        }
    }
}

/// `n` numbers from `words`, or None when fewer are there or one is not a number.
fn numbers<'w, const N: usize>(words: &mut impl Iterator<Item = &'w str>) -> Option<[f32; N]> {
    let mut out = [0.0; N];
    for slot in &mut out {
        *slot = parse_f32(words.next()?)?;
    }
    Some(out)
}

impl<'a> Parser<'a> {
    /// The usual lines, read in one pass up to their `\n` as [`Parser::line`] would read
    /// them: `v x y z`, `vt` and `vn` of short decimals, and the faces that [`fast_face`]
    /// takes. The line's length with its `\n`, or None (nothing read) for `line` to read it.
    #[inline(always)]
    fn fast_line(&mut self, text: &[u8]) -> Option<usize> {
        match text {
            [b'v', b' ' | b'\t', rest @ ..] => {
                // Three numbers and nothing after them: finite, no weight, no colour.
                let (p, end) = short_numbers::<3>(rest)?;
                let len = blank_to_line_end(rest, end)?;
                self.out.positions.push(Vec3::from(p));
                self.counts.positions += 1;
                Some(2 + len)
            }
            [b'f', b' ' | b'\t', rest @ ..] => self.fast_face(rest).map(|len| 2 + len),
            // What follows a texture coordinate's or normal's numbers is not read (tobj's reading).
            [b'v', b't', b' ' | b'\t', rest @ ..] => {
                let (t, end) = short_numbers::<2>(rest)?;
                self.out.texcoords.push(Vec2::from(t));
                self.counts.texcoords += 1;
                Some(3 + rest_of_line(rest, end))
            }
            [b'v', b'n', b' ' | b'\t', rest @ ..] => {
                let (n, end) = short_numbers::<3>(rest)?;
                self.out.normals.push(Vec3::from(n));
                self.counts.normals += 1;
                Some(3 + rest_of_line(rest, end))
            }
            _ => None,
        }
    }

    /// A face that [`plain_face`] or [`fast_face`] takes, stored; its length up to and with
    /// its `\n`, or None (nothing stored).
    #[inline(always)]
    fn fast_face(&mut self, text: &[u8]) -> Option<usize> {
        let counts = [self.counts.positions, self.counts.texcoords, self.counts.normals];
        // Read alone, any positive index is taken: the join checks `need` against the
        // counts before the chunk.
        let available = if self.exact { counts.map(|n| n as u64) } else { [u64::MAX; 3] };
        let before = self.out.corners.len();
        if let Corners::Plain(plain) = &mut self.out.corners {
            let mut largest = 0;
            if let Some((arity, len)) = plain_face(text, available[0], &mut largest, plain) {
                self.out.arities.push(arity);
                self.out.all_normals = false;
                self.out.need[0] = self.out.need[0].max(excess(largest, counts[0]));
                return Some(len);
            }
            plain.truncate(before);
        }
        let mut largest = [0; 3];
        let read = match &mut self.out.corners {
            Corners::Full(full) => fast_face(text, available, self.exact, &mut largest, full),
            Corners::Plain(_) => {
                self.scratch.clear();
                let read = fast_face(text, available, self.exact, &mut largest, &mut self.scratch);
                if read.is_some() {
                    self.out.corners.extend(&self.scratch);
                }
                read
            }
        };
        let Some((arity, len)) = read else {
            self.out.corners.truncate(before);
            return None;
        };
        match &self.out.corners {
            Corners::Full(full) => {
                for &[_, vt, vn] in &full[before..] {
                    self.out.any_texcoord |= vt != NONE;
                    self.out.any_normal |= vn != NONE;
                    self.out.all_normals &= vn != NONE;
                }
            }
            Corners::Plain(_) => self.out.all_normals = false,
        }
        self.out.arities.push(arity);
        for ((need, largest), count) in self.out.need.iter_mut().zip(largest).zip(counts) {
            *need = (*need).max(excess(largest, count));
        }
        Some(len)
    }

    fn line(&mut self, line: &'a str) -> Result<(), ErrorKind> {
        let word = keyword(line);
        if word.is_empty() {
            return Ok(());
        }
        // `word` is a subslice of `line`: what follows it.
        let rest = &line[word.as_ptr() as usize - line.as_ptr() as usize + word.len()..];
        let quoted = || quote(line);
        // Byte patterns: a plain comparison each, where string patterns call memcmp.
        match word.as_bytes() {
            [b'v'] => self.position(line, rest)?,
            [b'v', b't'] => {
                let fast = short_numbers::<2>(rest.as_bytes()).map(|(t, _)| t);
                let Some(t) = fast.or_else(|| numbers::<2>(&mut words(rest))) else {
                    return Err(ErrorKind::Parse(format!(
                        "a texture coordinate needs two numbers, but the line reads {}",
                        quoted()
                    )));
                };
                self.note_non_finite(2, t.iter().all(|c| c.is_finite()));
                self.out.texcoords.push(Vec2::from(t));
                self.counts.texcoords += 1;
            }
            [b'v', b'n'] => {
                let fast = short_numbers::<3>(rest.as_bytes()).map(|(n, _)| n);
                let Some(n) = fast.or_else(|| numbers::<3>(&mut words(rest))) else {
                    return Err(ErrorKind::Parse(format!(
                        "a normal needs three numbers, but the line reads {}",
                        quoted()
                    )));
                };
                self.note_non_finite(1, n.iter().all(|c| c.is_finite()));
                self.out.normals.push(Vec3::from(n));
                self.counts.normals += 1;
            }
            [b'f'] => self.face(line, rest)?,
            [b'o'] | [b'g'] => self
                .out
                .events
                .push(Event::Group { face: self.out.arities.len(), colours: self.out.colours }),
            [b'u', b's', b'e', b'm', b't', b'l'] => {
                let name = line.split_once(' ').map_or("", |(_, n)| n.trim());
                if name.is_empty() {
                    return Err(ErrorKind::Parse(format!(
                        "cannot read the material name from {}",
                        quoted()
                    )));
                }
                let (face, colours) = (self.out.arities.len(), self.out.colours);
                self.out.events.push(Event::Usemtl { face, colours, name });
            }
            [b'm', b't', b'l', b'l', b'i', b'b'] => self.out.events.push(Event::Mtllib {
                spelled: line.split_once(' ').map_or("", |(_, n)| n.trim()),
            }),
            [b's'] => {
                let value = words(rest).next().map(str::as_bytes);
                let group = match value {
                    Some(v) if v.eq_ignore_ascii_case(b"off") => 0,
                    // A number too large for u32 is still a group: all of them the same one.
                    Some(v) if !v.is_empty() && v.iter().all(u8::is_ascii_digit) => {
                        std::str::from_utf8(v).ok().and_then(|t| t.parse().ok()).unwrap_or(u32::MAX)
                    }
                    _ => 0,
                };
                self.out.events.push(Event::Smooth { face: self.out.arities.len(), group });
            }
            _ => {} // comments, `l` polylines, and what a mesh does not need
        }
        Ok(())
    }

    /// `v x y z`, `v x y z w` (w dropped: a mesh keeps x, y, z) or `v x y z r g b`.
    fn position(&mut self, line: &str, rest: &str) -> Result<(), ErrorKind> {
        // (`fast_line` took the lines of three short decimals.)
        let position_error = || {
            ErrorKind::Parse(format!(
                "a vertex position needs three numbers, but the line reads {}",
                quote(line)
            ))
        };
        let colour_error = || {
            ErrorKind::Parse(format!(
                "a vertex colour needs three numbers, but the line reads {}",
                quote(line)
            ))
        };
        let mut words = words(rest);
        let p = numbers::<3>(&mut words).ok_or_else(position_error)?;
        // The message for a non-finite value reads the line's leading numbers, and divides
        // by a fourth one (the weight w) when there are exactly four.
        let mut weight = None;
        if let Some(first) = words.next() {
            let extra: Vec<&str> = std::iter::once(first).chain(words).collect();
            match extra.len() {
                1 => {
                    first.parse::<f32>().map_err(|_| position_error())?;
                }
                3 => {
                    let before = self.out.colour_values.len();
                    self.out
                        .colour_values
                        .extend(extra.iter().map_while(|w| w.parse::<f32>().ok()));
                    self.out.colours += self.out.colour_values.len() - before;
                }
                _ => return Err(colour_error()),
            }
            let leading: Vec<f32> = extra.iter().map_while(|w| w.parse().ok()).collect();
            if let [w] = leading[..] {
                weight = Some(w);
            }
        }
        let located = weight.map_or(p, |w| p.map(|c| c / w));
        self.note_non_finite(0, located.iter().all(|c| c.is_finite()));
        self.out.positions.push(Vec3::from(p));
        self.counts.positions += 1;
        Ok(())
    }

    /// Remember the first line whose `kind` coordinates are not all finite.
    fn note_non_finite(&mut self, kind: usize, finite: bool) {
        if !finite && self.out.non_finite[kind].is_none() {
            self.out.non_finite[kind] = Some(self.counts.lines);
        }
    }

    /// A face: checked, corners resolved and stored; a texture coordinate or normal
    /// index out of range drops that attribute from the whole face (with a warning).
    fn face(&mut self, line: &str, rest: &str) -> Result<(), ErrorKind> {
        if self.fast_face(rest.as_bytes()).is_some() {
            return Ok(());
        }
        if !self.exact {
            self.gave_up = true;
            return Ok(());
        }
        let available = [self.counts.positions, self.counts.texcoords, self.counts.normals];
        let face = self.out.arities.len();
        // Something to say about the face: the slow path finds what.
        let (drop_texcoords, drop_normals) = match check_face(words(rest), available, line)? {
            (None, None) => (false, false),
            (texcoord, normal) => {
                let line_no = self.counts.lines;
                let (vt, vn) = (texcoord.is_some(), normal.is_some());
                for (dropped, bad) in [
                    (&mut self.out.dropped_texcoords, texcoord),
                    (&mut self.out.dropped_normals, normal),
                ] {
                    if let Some((index, count)) = bad {
                        dropped.faces.push(face);
                        dropped.first.get_or_insert((line_no, index, count));
                    }
                }
                (vt, vn)
            }
        };
        let mut corners = std::mem::take(&mut self.scratch);
        corners.clear();
        for corner in words(rest) {
            let mut parts = corner.split('/');
            let mut index = |slot: usize, drop: bool| match parts
                .next()
                .and_then(|t| parse_index(t.as_bytes()))
            {
                Some(i) if !drop => resolve(i, available[slot]),
                _ => NONE,
            };
            let (v, vt, vn) = (index(0, false), index(1, drop_texcoords), index(2, drop_normals));
            self.out.any_texcoord |= vt != NONE;
            self.out.any_normal |= vn != NONE;
            self.out.all_normals &= vn != NONE;
            corners.push([v, vt, vn]);
        }
        self.out.corners.extend(&corners);
        self.out.arities.push(corners.len() as u32);
        self.scratch = corners;
        Ok(())
    }
}

/// How many elements the chunks before must hold for index `largest` (1-based) to be in
/// range after `count` of the chunk's own.
fn excess(largest: u64, count: usize) -> usize {
    largest.saturating_sub(count as u64).try_into().unwrap_or(usize::MAX)
}

/// A checked OBJ index (1-based, or negative counting back from the last of `available`)
/// as a 0-based index.
fn resolve(index: i64, available: usize) -> u32 {
    let zero_based =
        if index > 0 { index as usize - 1 } else { available - index.unsigned_abs() as usize };
    zero_based as u32
}

/// An out-of-range texture coordinate or normal index: as written, and the count so far.
type BadIndex = (String, usize);

/// Every corner must be `v`, `v/vt`, `v//vn` or `v/vt/vn` with indices (absolute or
/// negative/relative), and there must be at least three corners. A vertex index must
/// name a vertex defined earlier in the file; a texture coordinate or normal index that
/// names none is returned (the first of each kind, with the count so far), for the face
/// to go on without them.
fn check_face<'w>(
    corners: impl Iterator<Item = &'w str>,
    available: [usize; 3],
    line: &str,
) -> Result<(Option<BadIndex>, Option<BadIndex>), ErrorKind> {
    let mut bad: [Option<BadIndex>; 3] = Default::default();
    let mut count = 0;
    for corner in corners {
        count += 1;
        let mut parts = corner.split('/');
        for (slot, &available) in available.iter().enumerate() {
            let Some(text) = parts.next() else { break };
            if text.is_empty() && slot > 0 {
                continue; // `v//vn` and `v/vt/`: the element is simply absent
            }
            let Some(index) = parse_index(text.as_bytes()) else {
                return Err(ErrorKind::Parse(format!(
                    "{} is not a face corner (expected v, v/vt, v//vn or v/vt/vn) in {}",
                    quote(corner),
                    quote(line)
                )));
            };
            // Negative indices count back from the last element defined so far.
            let in_range = match index {
                1.. => index as u64 <= available as u64,
                0 => false,
                _ => index.unsigned_abs() <= available as u64,
            };
            if !in_range && slot == 0 {
                return Err(ErrorKind::VertexOutOfRange {
                    index: shown_index(text),
                    count: available,
                });
            }
            if !in_range && bad[slot].is_none() {
                bad[slot] = Some((shown_index(text), available));
            }
        }
        if parts.next().is_some() {
            return Err(ErrorKind::Parse(format!(
                "{} has more than three indices in {}",
                quote(corner),
                quote(line)
            )));
        }
    }
    if count < 3 {
        return Err(ErrorKind::Parse(format!(
            "a face needs at least three corners, but {} has {count}",
            quote(line)
        )));
    }
    let [_, texcoord, normal] = bad;
    Ok((texcoord, normal))
}

/// An index as written, for a message: a file may write a million digits.
fn shown_index(text: &str) -> String {
    crate::files::shown(text, 60)
}

/// An OBJ index: optional sign, decimal digits. Saturates instead of overflowing, since
/// anything that large is out of range anyway.
fn parse_index(text: &[u8]) -> Option<i64> {
    let (negative, digits) = match text.split_first()? {
        (b'-', rest) => (true, rest),
        (b'+', rest) => (false, rest),
        _ => (false, text),
    };
    if digits.is_empty() {
        return None;
    }
    let mut value: i64 = 0;
    for &b in digits {
        if !b.is_ascii_digit() {
            return None;
        }
        value = value.saturating_mul(10).saturating_add(i64::from(b - b'0'));
    }
    Some(if negative { -value } else { value })
}

#[cfg(test)]
#[path = "parse_chunk_tests.rs"]
mod tests;
