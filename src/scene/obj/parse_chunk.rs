//! The second pass: one chunk of an OBJ parsed on its own (chunks run in parallel), with
//! the rules the loader has always had (tobj's reading of each statement, and the face
//! checks that used to run in front of it): positions, texture coordinates and normals go
//! straight into their places in the whole file's arrays; faces become corner indices
//! resolved against the counts before their line in the whole file; what changes between
//! faces (`o`/`g`, `usemtl`, `mtllib`, `s`) is noted as events for the join; the chunk
//! stops at its first error.

use glam::{Vec2, Vec3};

use super::chunks::{is_ascii_space, keyword, lines, parse_f32, Chunk, Counts};
use super::quote;
use crate::scene::decimal::short_f32;

/// A corner index that is absent (`v//vn` has no texture coordinate).
pub(super) const NONE: u32 = u32::MAX;

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
    /// Every face's corners in order: (v, vt, vn), 0-based in the whole file, [`NONE`] when absent.
    pub(super) corners: Vec<[u32; 3]>,
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

/// Where a chunk writes its elements: its own parts of the whole file's arrays.
pub(super) struct Targets<'t> {
    pub(super) positions: &'t mut [Vec3],
    pub(super) texcoords: &'t mut [Vec2],
    pub(super) normals: &'t mut [Vec3],
}

/// Parse one chunk; `before` holds the lines and elements of the chunks before it.
pub(super) fn parse_chunk<'a>(
    chunk: Chunk<'a>,
    before: Counts,
    targets: Targets<'_>,
) -> ChunkFaces<'a> {
    let mut parser = Parser {
        out: ChunkFaces { all_normals: true, ..Default::default() },
        counts: before,
        first: before,
        targets,
    };
    let mut offset = chunk.offset;
    for line in lines(chunk.text) {
        parser.counts.lines += 1;
        let end = (offset + line.len() + 1).min(chunk.offset + chunk.text.len());
        offset = end;
        if let Err(kind) = parser.line(line) {
            parser.out.error = Some(ChunkError { line: parser.counts.lines, line_end: end, kind });
            break;
        }
    }
    parser.out
}

struct Parser<'a, 't> {
    out: ChunkFaces<'a>,
    /// Lines and elements up to the current line (the line itself counted).
    counts: Counts,
    /// The counts before the chunk: where its elements go in the targets.
    first: Counts,
    targets: Targets<'t>,
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

/// The fast path for a line's first `N` numbers when each is a short decimal
/// (`scene/decimal.rs`; nearly every `v`, `vt` and `vn` line): the numbers and where the
/// text after them begins, or None for [`numbers`] to read them (and word what is wrong).
/// One pass over the bytes, where `words` and `str::parse` would take several.
#[inline(always)]
fn short_numbers<const N: usize>(text: &[u8]) -> Option<([f32; N], usize)> {
    let (mut out, mut i) = ([0.0; N], 0);
    for slot in &mut out {
        while i < text.len() && is_ascii_space(text[i]) {
            i += 1;
        }
        let start = i;
        while i < text.len() && !is_ascii_space(text[i]) {
            i += 1;
        }
        *slot = short_f32(&text[start..i])?;
    }
    Some((out, i))
}

/// `n` numbers from `words`, or None when fewer are there or one is not a number.
fn numbers<'w, const N: usize>(words: &mut impl Iterator<Item = &'w str>) -> Option<[f32; N]> {
    let mut out = [0.0; N];
    for slot in &mut out {
        *slot = parse_f32(words.next()?)?;
    }
    Some(out)
}

impl<'a> Parser<'a, '_> {
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
                put(
                    self.targets.texcoords,
                    self.counts.texcoords - self.first.texcoords,
                    Vec2::from(t),
                );
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
                put(self.targets.normals, self.counts.normals - self.first.normals, Vec3::from(n));
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
        // Three short decimals and nothing after them: finite, no weight, no colour.
        if let Some((p, end)) = short_numbers::<3>(rest.as_bytes()) {
            if rest.as_bytes()[end..].iter().all(|&b| is_ascii_space(b)) {
                let at = self.counts.positions - self.first.positions;
                put(self.targets.positions, at, Vec3::from(p));
                self.counts.positions += 1;
                return Ok(());
            }
        }
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
        put(self.targets.positions, self.counts.positions - self.first.positions, Vec3::from(p));
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
        let available = [self.counts.positions, self.counts.texcoords, self.counts.normals];
        let face = self.out.arities.len();
        let before = self.out.corners.len();
        if let Some(arity) =
            fast_face(rest.as_bytes(), available.map(|n| n as u64), &mut self.out.corners)
        {
            for &[_, vt, vn] in &self.out.corners[before..] {
                self.out.any_texcoord |= vt != NONE;
                self.out.any_normal |= vn != NONE;
                self.out.all_normals &= vn != NONE;
            }
            self.out.arities.push(arity);
            return Ok(());
        }
        // Something to say about the face: the slow path finds what.
        self.out.corners.truncate(before);
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
        let mut arity = 0;
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
            self.out.corners.push([v, vt, vn]);
            arity += 1;
        }
        self.out.arities.push(arity);
        Ok(())
    }
}

/// The fast path for a face whose corners are all well-formed ASCII with indices in range
/// (nearly every face): the corners resolved into `out` and their number, or None (with
/// `out` perhaps grown) when [`check_face`] has something to say.
fn fast_face(corners: &[u8], available: [u64; 3], out: &mut Vec<[u32; 3]>) -> Option<u32> {
    let (n, mut i, mut count) = (corners.len(), 0, 0u32);
    loop {
        while i < n && is_ascii_space(corners[i]) {
            i += 1;
        }
        if i == n {
            return (count >= 3).then_some(count);
        }
        count += 1;
        let mut corner = [NONE; 3];
        // One corner: up to three slash-separated indices, v required.
        for (slot, &available) in available.iter().enumerate() {
            let negative = corners.get(i) == Some(&b'-');
            let signed = negative || corners.get(i) == Some(&b'+');
            i += usize::from(signed);
            let (start, mut value) = (i, 0u64);
            while i < n && corners[i].is_ascii_digit() {
                value = value.saturating_mul(10).saturating_add(u64::from(corners[i] - b'0'));
                i += 1;
            }
            if i == start {
                // Only texture coordinates and normals may be left out, and without a sign.
                if slot == 0 || signed {
                    return None;
                }
            } else if (1..=available).contains(&value) {
                corner[slot] = if negative { available - value } else { value - 1 } as u32;
            } else {
                return None;
            }
            match corners.get(i) {
                Some(b'/') if slot < 2 => i += 1,
                None => break,
                Some(&b) if is_ascii_space(b) => break,
                Some(_) => return None,
            }
        }
        out.push(corner);
    }
}

/// Store `value` at `i` (the first pass counted the same lines, so `i` is in range).
fn put<T>(target: &mut [T], i: usize, value: T) {
    if let Some(slot) = target.get_mut(i) {
        *slot = value;
    }
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
mod tests {
    use super::*;

    #[test]
    fn fast_face_path_agrees_with_the_diagnosing_one() {
        // Every corner list up to 5 characters over a troublesome alphabet, after two
        // good corners, against 2 vertices, 1 texture coordinate and no normals.
        let alphabet = b"12-/ 0x+";
        let mut tail = Vec::new();
        for len in 0..=5u32 {
            for mut code in 0..alphabet.len().pow(len) {
                tail.clear();
                for _ in 0..len {
                    tail.push(alphabet[code % alphabet.len()]);
                    code /= alphabet.len();
                }
                let corners = String::from_utf8([b"1/1 -2 ".as_slice(), &tail].concat()).unwrap();
                let slow = matches!(check_face(words(&corners), [2, 1, 0], "f"), Ok((None, None)));
                let mut out = Vec::new();
                let fast = fast_face(corners.as_bytes(), [2, 1, 0], &mut out);
                assert_eq!(fast.is_some(), slow, "f {corners}");
                if let Some(n) = fast {
                    assert_eq!(
                        (out.len(), out[0], out[1]),
                        (n as usize, [0, 0, NONE], [0, NONE, NONE]),
                        "f {corners}"
                    );
                }
            }
        }
    }

    #[test]
    fn words_split_as_split_whitespace_splits() {
        for text in [" a  b\tc\r", "", "  ", "x\u{3000}y z", "\u{85}q"] {
            assert_eq!(
                words(text).collect::<Vec<_>>(),
                text.split_whitespace().collect::<Vec<_>>(),
                "{text:?}"
            );
        }
    }
}
