//! The `LineFeeder` through which tobj reads an OBJ (or MTL) text one line at a time, so
//! that every error can be pinned to its line; in OBJ mode it also counts `v`/`vt`/`vn`,
//! validates each face's indices before tobj parses them (a fast byte scan, with a slower
//! path that says what is wrong), collects `usemtl` names and hides polylines from tobj.

use std::collections::HashSet;
use std::io::{self, BufRead, Read};

use super::convert::locate_colour_mismatch;
use super::{quote, ObjError};

/// The `BufRead` that tobj reads the text through. tobj reads with `BufRead::lines`, so
/// every `consume` takes exactly one line: the feeder always knows which line tobj is on.
/// In OBJ mode it checks each line as it is consumed, before tobj parses it (counting
/// `v`/`vt`/`vn`, checking faces); after a bad line the next `fill_buf` fails, so tobj
/// stops before it can use the face. It also hides polylines from tobj.
pub(super) struct LineFeeder<'a> {
    name: &'a str,
    /// The whole text.
    text: &'a str,
    /// Text not consumed yet.
    rest: &'a str,
    /// The line consumed last: the one tobj is working on.
    pub(super) current_line: &'a str,
    /// 1-based number of `current_line`; 0 before the first.
    pub(super) line: usize,
    /// `fill_buf` is handing out an empty line in place of a hidden one.
    hiding: bool,
    /// Check faces and count elements (OBJ), or only count lines (MTL).
    check_obj: bool,
    vertices: usize,
    texcoords: usize,
    normals: usize,
    /// Distinct `usemtl` names, in order of first use.
    pub(super) usemtl_names: Vec<&'a str>,
    usemtl_seen: HashSet<&'a str>,
    /// The error that made the feeder stop, reported instead of tobj's `ReadError`.
    error: Option<ObjError>,
}

impl<'a> LineFeeder<'a> {
    pub(super) fn new(text: &'a str, name: &'a str, check_obj: bool) -> Self {
        Self {
            name,
            text,
            rest: text,
            current_line: "",
            line: 0,
            hiding: false,
            check_obj,
            vertices: 0,
            texcoords: 0,
            normals: 0,
            usemtl_names: Vec::new(),
            usemtl_seen: HashSet::new(),
            error: None,
        }
    }

    /// True when nothing but whitespace follows the current line.
    fn at_last_line(&self) -> bool {
        self.rest.trim().is_empty()
    }

    /// A parse error on the current line; on the last line it reads as a truncated file.
    fn parse_error(&self, reason: String) -> ObjError {
        let (name, line) = (self.name.to_owned(), self.line);
        if self.at_last_line() {
            ObjError::Truncated { name, line, reason }
        } else {
            ObjError::Parse { name, line, reason }
        }
    }

    /// What tobj's error means, located on the line tobj was reading when it gave up.
    pub(super) fn into_error(self, e: tobj::LoadError) -> ObjError {
        use tobj::LoadError as E;
        if let Some(own) = self.error {
            return own;
        }
        let quoted = quote(self.current_line);
        let reason = match e {
            E::PositionParseError => format!("a vertex position needs three numbers, but the line reads {quoted}"),
            E::NormalParseError => format!("a normal needs three numbers, but the line reads {quoted}"),
            E::TexcoordParseError => format!("a texture coordinate needs two numbers, but the line reads {quoted}"),
            E::ScalingByZeroError => format!("the vertex weight w is zero in {quoted}"),
            E::ColorParseError => format!("a vertex colour needs three numbers, but the line reads {quoted}"),
            E::MaterialParseError => format!("cannot read the material name from {quoted}"),
            // Raised when an object is closed, after its faces, far from the culprit.
            E::FaceColorOutOfBounds => return locate_colour_mismatch(self.text, self.name),
            other => format!("{other} in {quoted}"),
        };
        self.parse_error(reason)
    }

    /// Check one line before tobj parses it.
    fn check_line(&mut self, line: &'a str) -> Result<(), ObjError> {
        // Fast paths for the statements that make up nearly all of a file.
        match line.as_bytes() {
            [b'v', s, ..] if is_ascii_space(*s) => self.vertices += 1,
            [b'v', b't', s, ..] if is_ascii_space(*s) => self.texcoords += 1,
            [b'v', b'n', s, ..] if is_ascii_space(*s) => self.normals += 1,
            [b'f', s, corners @ ..] if is_ascii_space(*s) && line.is_ascii() && face_is_valid(corners, self.counts()) => {}
            _ => return self.check_any_line(line),
        }
        Ok(())
    }

    /// Any line, and the diagnosis of a bad face.
    fn check_any_line(&mut self, line: &'a str) -> Result<(), ObjError> {
        // tobj splits words at Unicode whitespace; for an ASCII line splitting bytes gives
        // the same words.
        if line.is_ascii() {
            let words = line.as_bytes().split(|&b| is_ascii_space(b)).filter(|w| !w.is_empty());
            self.check_statement(words, line)
        } else {
            self.check_statement(line.split_whitespace().map(str::as_bytes), line)
        }
    }

    /// How many `v`, `vt` and `vn` came before the current line.
    fn counts(&self) -> [u64; 3] {
        [self.vertices, self.texcoords, self.normals].map(|n| n as u64)
    }

    fn check_statement<'w>(&mut self, mut words: impl Iterator<Item = &'w [u8]>, line: &'a str) -> Result<(), ObjError> {
        match words.next() {
            Some(b"v") => self.vertices += 1,
            Some(b"vt") => self.texcoords += 1,
            Some(b"vn") => self.normals += 1,
            Some(b"f") => self.check_face(words)?,
            Some(b"usemtl") => {
                // tobj takes the name the same way: everything after the first space.
                let name = line.split_once(' ').map_or("", |(_, n)| n.trim());
                if !name.is_empty() && self.usemtl_seen.insert(name) {
                    self.usemtl_names.push(name);
                }
            }
            _ => {}
        }
        Ok(())
    }

    /// Every corner must be `v`, `v/vt`, `v//vn` or `v/vt/vn` with indices (absolute or
    /// negative/relative) of elements defined earlier in the file, and there must be at
    /// least three corners.
    fn check_face<'w>(&self, corners: impl Iterator<Item = &'w [u8]>) -> Result<(), ObjError> {
        let kinds = [
            ("vertex", "vertices", self.vertices),
            ("texture coordinate", "texture coordinates", self.texcoords),
            ("normal", "normals", self.normals),
        ];
        let mut count = 0;
        for corner in corners {
            count += 1;
            let mut parts = corner.split(|&b| b == b'/');
            for (slot, &(kind, kind_plural, available)) in kinds.iter().enumerate() {
                let Some(text) = parts.next() else { break };
                if text.is_empty() && slot > 0 {
                    continue; // `v//vn` and `v/vt/`: the element is simply absent
                }
                let Some(index) = parse_index(text) else {
                    return Err(self.parse_error(format!(
                        "`{}` is not a face corner (expected v, v/vt, v//vn or v/vt/vn) in {}",
                        String::from_utf8_lossy(corner),
                        quote(self.current_line)
                    )));
                };
                // Negative indices count back from the last element defined so far.
                let in_range = match index {
                    1.. => index as u64 <= available as u64,
                    0 => false,
                    _ => index.unsigned_abs() <= available as u64,
                };
                if !in_range {
                    return Err(ObjError::IndexOutOfRange {
                        name: self.name.to_owned(),
                        line: self.line,
                        kind,
                        kind_plural,
                        index: String::from_utf8_lossy(text).into_owned(),
                        count: available,
                    });
                }
            }
            if parts.next().is_some() {
                return Err(self.parse_error(format!(
                    "`{}` has more than three indices in {}",
                    String::from_utf8_lossy(corner),
                    quote(self.current_line)
                )));
            }
        }
        if count < 3 {
            return Err(self.parse_error(format!("a face needs at least three corners, but {} has {count}", quote(self.current_line))));
        }
        Ok(())
    }
}

/// The fast check of an ASCII face's corners (the text after `f`) against the element
/// counts so far: true when [`LineFeeder::check_face`] would accept them.
fn face_is_valid(corners: &[u8], counts: [u64; 3]) -> bool {
    let (n, mut i, mut corner_count) = (corners.len(), 0, 0);
    loop {
        while i < n && is_ascii_space(corners[i]) {
            i += 1;
        }
        if i == n {
            return corner_count >= 3;
        }
        corner_count += 1;
        // One corner: up to three slash-separated indices, v required.
        for (slot, &available) in counts.iter().enumerate() {
            let signed = matches!(corners.get(i), Some(b'-' | b'+'));
            i += usize::from(signed);
            let (start, mut value) = (i, 0u64);
            while i < n && corners[i].is_ascii_digit() {
                value = value.saturating_mul(10).saturating_add(u64::from(corners[i] - b'0'));
                i += 1;
            }
            // Absolute or relative, the magnitude must lie in 1..=available.
            let ok = if i == start { slot > 0 && !signed } else { (1..=available).contains(&value) };
            if !ok {
                return false;
            }
            match corners.get(i) {
                Some(b'/') if slot < 2 => i += 1,
                None => break,
                Some(&b) if is_ascii_space(b) => break,
                Some(_) => return false,
            }
        }
    }
}

/// The ASCII characters that `char::is_whitespace` accepts (vertical tab and form feed
/// included, unlike `u8::is_ascii_whitespace`).
fn is_ascii_space(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\n' | b'\r' | 0x0b | 0x0c)
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

impl Read for LineFeeder<'_> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        // tobj only reads lines. A raw read works too, but counts each piece as a line.
        let available = self.fill_buf()?;
        let n = available.len().min(buf.len());
        buf[..n].copy_from_slice(&available[..n]);
        self.consume(n);
        Ok(n)
    }
}

impl BufRead for LineFeeder<'_> {
    fn fill_buf(&mut self) -> io::Result<&[u8]> {
        if self.error.is_some() {
            // tobj turns this into `ReadError`; `into_error` swaps ours back in.
            return Err(io::Error::other("stopped at a bad line"));
        }
        if self.check_obj && !self.hiding && starts_polyline(self.rest) {
            // tobj would turn `l 1 2 3` into a triangle: it gets an empty line instead.
            let end = self.rest.find('\n').map_or(self.rest.len(), |i| i + 1);
            self.advance(end);
            self.hiding = true;
        }
        Ok(if self.hiding { b"\n" } else { self.rest.as_bytes() })
    }

    fn consume(&mut self, amount: usize) {
        // `read_until` consumes 0 bytes at the end of the text: that is no line.
        if std::mem::take(&mut self.hiding) || amount == 0 {
            return;
        }
        self.advance(amount);
        if self.check_obj {
            if let Err(e) = self.check_line(self.current_line) {
                self.error = Some(e);
            }
        }
    }
}

impl LineFeeder<'_> {
    /// Move the next `amount` bytes (one line) from `rest` to `current_line`.
    fn advance(&mut self, amount: usize) {
        // `lines()` consumes whole lines, so `amount` ends on a char boundary; a stray
        // count takes the rest rather than panic.
        let (line, rest) = self.rest.split_at_checked(amount).unwrap_or((self.rest, ""));
        self.current_line = line;
        self.rest = rest;
        self.line += 1;
    }
}

/// True when the first line of `text` is an `l` (polyline) statement, as tobj would see it.
fn starts_polyline(text: &str) -> bool {
    let mut chars = text.trim_start_matches(|c: char| c.is_whitespace() && c != '\n').chars();
    chars.next() == Some('l') && chars.next().is_none_or(char::is_whitespace)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_parsing_accepts_signs_and_saturates() {
        assert_eq!(parse_index(b"12"), Some(12));
        assert_eq!(parse_index(b"-3"), Some(-3));
        assert_eq!(parse_index(b"+7"), Some(7));
        assert_eq!(parse_index(b"99999999999999999999999"), Some(i64::MAX));
        for bad in ["", "-", "1a", "1.0", " 1", "+-1"] {
            assert_eq!(parse_index(bad.as_bytes()), None, "{bad:?}");
        }
    }

    #[test]
    fn fast_face_check_agrees_with_the_diagnosing_one() {
        // Every corner list up to 5 characters over a troublesome alphabet, after two
        // good corners, against 2 vertices, 1 texture coordinate and no normals.
        let alphabet = b"12-/ 0x+";
        let mut feeder = LineFeeder::new("", "t.obj", true);
        (feeder.vertices, feeder.texcoords, feeder.normals) = (2, 1, 0);
        let mut tail = Vec::new();
        for len in 0..=5u32 {
            for mut code in 0..alphabet.len().pow(len) {
                tail.clear();
                for _ in 0..len {
                    tail.push(alphabet[code % alphabet.len()]);
                    code /= alphabet.len();
                }
                let corners = [b"1/1 -2 ".as_slice(), &tail].concat();
                let words = corners.split(|&b| is_ascii_space(b)).filter(|w| !w.is_empty());
                let slow = feeder.check_face(words).is_ok();
                let text = String::from_utf8_lossy(&corners);
                assert_eq!(face_is_valid(&corners, [2, 1, 0]), slow, "f {text}");
            }
        }
    }

    #[test]
    fn polylines_are_recognised_as_tobj_reads_them() {
        for yes in ["l 1 2", "  l 1 2 3\n", "\u{3000}l\t1 2", "l", "l\n"] {
            assert!(starts_polyline(yes), "{yes:?}");
        }
        for no in ["", "\nl 1 2", "ln 1 2", "f 1 2 3", "# l 1 2", "lod 1"] {
            assert!(!starts_polyline(no), "{no:?}");
        }
    }

    #[test]
    fn feeder_hands_out_one_line_at_a_time_and_counts_them() {
        let mut feeder = LineFeeder::new("a\nbb\r\n\nccc", "x", false);
        let mut lines = Vec::new();
        let mut buf = String::new();
        while feeder.read_line(&mut buf).unwrap() > 0 {
            lines.push((feeder.line, std::mem::take(&mut buf)));
        }
        assert_eq!(lines, [(1, "a\n".into()), (2, "bb\r\n".into()), (3, "\n".into()), (4, "ccc".into())]);
    }
}
