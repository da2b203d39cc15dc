//! The `LineFeeder` through which tobj reads an OBJ (or MTL) text one line at a time, so
//! that every error can be pinned to its line; in OBJ mode it also counts `v`/`vt`/`vn`,
//! validates each face's indices before tobj parses them (a fast byte scan, with a slower
//! path that says what is wrong), hands tobj a face without the texture coordinates or
//! normals it names out of range, records smoothing groups (which tobj ignores), collects
//! `usemtl` names and hides polylines from tobj.
//!
//! OBJ files are now parsed by our own parallel parser (`parallel.rs`); the OBJ mode here
//! is the serial loader it replaced (`oracle.rs`), kept as the oracle the tests and the
//! fuzzer compare it with. MTL files still go through tobj and this feeder.

use std::borrow::Cow;
use std::collections::HashSet;
use std::io::{self, BufRead, Read};

use super::chunks::is_ascii_space;
#[cfg(any(test, feature = "dev"))]
use super::convert::locate_colour_mismatch;
use super::fast_lines::fast_face;
use super::{quote, ObjError};

/// An out-of-range index of a face corner: the index as written, and how many of its kind
/// the file had defined by then.
type BadIndex = (String, usize);

/// The `BufRead` that tobj reads the text through. tobj reads with `BufRead::lines`, so
/// every `consume` takes exactly one line: the feeder always knows which line tobj is on.
/// In OBJ mode it checks each line before tobj parses it: faces (and polylines) when
/// `fill_buf` is about to hand them out, so that a face can be handed out changed or not
/// at all; the other lines as they are consumed (counting `v`/`vt`/`vn`, reading `s`).
/// After a bad line the next `fill_buf` fails, so tobj stops before it can use it.
pub(super) struct LineFeeder<'a> {
    name: &'a str,
    /// The whole text (for the oracle's errors).
    #[cfg(any(test, feature = "dev"))]
    text: &'a str,
    /// Text not consumed yet.
    rest: &'a str,
    /// The line consumed last: the one tobj is working on.
    pub(super) current_line: &'a str,
    /// 1-based number of `current_line`; 0 before the first.
    pub(super) line: usize,
    /// The line `fill_buf` hands out in place of `rest` (OBJ mode): a face already checked,
    /// as written or without its out-of-range attributes, or an empty line for a hidden
    /// polyline. It has already moved from `rest` to `current_line`.
    pending: Option<Cow<'a, str>>,
    /// Bytes of `pending` consumed so far.
    pending_at: usize,
    /// Check faces and count elements (OBJ), or only count lines (MTL).
    check_obj: bool,
    vertices: usize,
    texcoords: usize,
    normals: usize,
    /// Faces so far (each `f` line is one face for tobj).
    pub(super) faces: usize,
    /// Where the smoothing group changes: (index of the first face in it, group), group
    /// 0 for `s off`/`s 0`. Empty when the file has no `s` statement.
    pub(super) smoothing: Vec<(usize, u32)>,
    /// Faces whose texture coordinate indices were out of range and left out.
    pub(super) dropped_texcoords: Dropped,
    /// Faces whose normal indices were out of range and left out.
    pub(super) dropped_normals: Dropped,
    /// Distinct `usemtl` names, in order of first use.
    pub(super) usemtl_names: Vec<&'a str>,
    usemtl_seen: HashSet<&'a str>,
    /// The error that made the feeder stop, reported instead of tobj's `ReadError`.
    error: Option<ObjError>,
    /// The corners the fast face check reads (kept to spare an allocation a face).
    face_corners: Vec<[u32; 3]>,
}

impl<'a> LineFeeder<'a> {
    pub(super) fn new(text: &'a str, name: &'a str, check_obj: bool) -> Self {
        Self {
            name,
            #[cfg(any(test, feature = "dev"))]
            text,
            rest: text,
            current_line: "",
            line: 0,
            pending: None,
            pending_at: 0,
            check_obj,
            vertices: 0,
            texcoords: 0,
            normals: 0,
            faces: 0,
            smoothing: Vec::new(),
            dropped_texcoords: Dropped::default(),
            dropped_normals: Dropped::default(),
            usemtl_names: Vec::new(),
            usemtl_seen: HashSet::new(),
            error: None,
            face_corners: Vec::new(),
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
    #[cfg(any(test, feature = "dev"))]
    pub(super) fn into_error(self, e: tobj::LoadError) -> ObjError {
        use tobj::LoadError as E;
        if let Some(own) = self.error {
            return own;
        }
        let quoted = quote(self.current_line);
        let reason = match e {
            E::PositionParseError => {
                format!("a vertex position needs three numbers, but the line reads {quoted}")
            }
            E::NormalParseError => {
                format!("a normal needs three numbers, but the line reads {quoted}")
            }
            E::TexcoordParseError => {
                format!("a texture coordinate needs two numbers, but the line reads {quoted}")
            }
            E::ScalingByZeroError => format!("the vertex weight w is zero in {quoted}"),
            E::ColorParseError => {
                format!("a vertex colour needs three numbers, but the line reads {quoted}")
            }
            E::MaterialParseError => format!("cannot read the material name from {quoted}"),
            // Raised when an object is closed, after its faces, far from the culprit.
            E::FaceColorOutOfBounds => return locate_colour_mismatch(self.text, self.name),
            other => format!("{other} in {quoted}"),
        };
        self.parse_error(reason)
    }

    /// Check one line other than a face or polyline as tobj consumes it.
    fn check_line(&mut self, line: &'a str) -> Result<(), ObjError> {
        // Fast paths for the statements that make up nearly all of a file.
        match line.as_bytes() {
            [b'v', s, ..] if is_ascii_space(*s) => self.vertices += 1,
            [b'v', b't', s, ..] if is_ascii_space(*s) => self.texcoords += 1,
            [b'v', b'n', s, ..] if is_ascii_space(*s) => self.normals += 1,
            _ => return self.check_statement(words_of(line), line),
        }
        Ok(())
    }

    /// Check the face on the current line (already taken from `rest`) and decide what tobj
    /// gets: the line as written, the line without the texture coordinates or normals that
    /// it names out of range (recorded in `dropped_*`), or nothing (an error).
    fn prepare_face(&mut self) {
        let line = self.current_line;
        let face = self.faces;
        self.faces += 1;
        // The fast path: an ASCII face whose indices are all in range.
        if let [b'f', s, corners @ ..] = line.as_bytes() {
            if is_ascii_space(*s)
                && line.is_ascii()
                && face_is_valid(corners, self.counts(), &mut self.face_corners)
            {
                self.pending = Some(Cow::Borrowed(line));
                return;
            }
        }
        let (texcoord, normal) = match self.check_face(words_of(line).skip(1)) {
            Ok(bad) => bad,
            Err(e) => {
                self.error = Some(e);
                return;
            }
        };
        let (drop_vt, drop_vn) = (texcoord.is_some(), normal.is_some());
        for (dropped, bad) in
            [(&mut self.dropped_texcoords, texcoord), (&mut self.dropped_normals, normal)]
        {
            if let Some((index, count)) = bad {
                dropped.faces.push(face);
                dropped.first.get_or_insert(DroppedFirst { line: self.line, index, count });
            }
        }
        self.pending = Some(if drop_vt || drop_vn {
            Cow::Owned(without_attributes(line, drop_vt, drop_vn))
        } else {
            Cow::Borrowed(line)
        });
    }

    /// `s 1`, `s off`...: faces from here on are in that smoothing group (0 = none).
    fn set_smoothing_group(&mut self, value: Option<&[u8]>) {
        let group = match value {
            Some(v) if v.eq_ignore_ascii_case(b"off") => 0,
            // A number too large for u32 is still a group: all of them the same one.
            Some(v) if !v.is_empty() && v.iter().all(u8::is_ascii_digit) => {
                std::str::from_utf8(v).ok().and_then(|t| t.parse().ok()).unwrap_or(u32::MAX)
            }
            _ => 0,
        };
        match self.smoothing.last_mut() {
            Some(last) if last.0 == self.faces => last.1 = group,
            Some(last) if last.1 == group => {}
            _ => self.smoothing.push((self.faces, group)),
        }
    }

    /// How many `v`, `vt` and `vn` came before the current line.
    fn counts(&self) -> [u64; 3] {
        [self.vertices, self.texcoords, self.normals].map(|n| n as u64)
    }

    fn check_statement<'w>(
        &mut self,
        mut words: impl Iterator<Item = &'w [u8]>,
        line: &'a str,
    ) -> Result<(), ObjError> {
        match words.next() {
            Some(b"v") => self.vertices += 1,
            Some(b"vt") => self.texcoords += 1,
            Some(b"vn") => self.normals += 1,
            Some(b"s") => self.set_smoothing_group(words.next()),
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
    /// negative/relative), and there must be at least three corners. A vertex index must
    /// name a vertex defined earlier in the file; a texture coordinate or normal index
    /// that names none is returned (the first of each kind, with the count so far), for
    /// the face to go on without them.
    fn check_face<'w>(
        &self,
        corners: impl Iterator<Item = &'w [u8]>,
    ) -> Result<(Option<BadIndex>, Option<BadIndex>), ObjError> {
        let kinds = [
            ("vertex", "vertices", self.vertices),
            ("texture coordinate", "texture coordinates", self.texcoords),
            ("normal", "normals", self.normals),
        ];
        let mut bad: [Option<BadIndex>; 3] = Default::default();
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
                        "{} is not a face corner (expected v, v/vt, v//vn or v/vt/vn) in {}",
                        quote(&String::from_utf8_lossy(corner)),
                        quote(self.current_line)
                    )));
                };
                // Negative indices count back from the last element defined so far.
                let in_range = match index {
                    1.. => index as u64 <= available as u64,
                    0 => false,
                    _ => index.unsigned_abs() <= available as u64,
                };
                if !in_range && slot == 0 {
                    return Err(ObjError::IndexOutOfRange {
                        name: self.name.to_owned(),
                        line: self.line,
                        kind,
                        kind_plural,
                        index: shown_index(text),
                        count: available,
                    });
                }
                if !in_range && bad[slot].is_none() {
                    bad[slot] = Some((shown_index(text), available));
                }
            }
            if parts.next().is_some() {
                return Err(self.parse_error(format!(
                    "{} has more than three indices in {}",
                    quote(&String::from_utf8_lossy(corner)),
                    quote(self.current_line)
                )));
            }
        }
        if count < 3 {
            return Err(self.parse_error(format!(
                "a face needs at least three corners, but {} has {count}",
                quote(self.current_line)
            )));
        }
        let [_, texcoord, normal] = bad;
        Ok((texcoord, normal))
    }
}

/// Faces that lost an attribute because they named it out of range.
#[derive(Debug, Default)]
pub(super) struct Dropped {
    /// The faces, by index in file order (from 0), ascending.
    pub(super) faces: Vec<usize>,
    /// The first of them, for the warning.
    pub(super) first: Option<DroppedFirst>,
}

/// Where and how the first face that lost an attribute named it.
#[derive(Debug)]
pub(super) struct DroppedFirst {
    /// 1-based line number.
    pub(super) line: usize,
    /// The first out-of-range index, as written.
    pub(super) index: String,
    /// How many elements of the kind the file had defined at that line.
    pub(super) count: usize,
}

/// The words of a line as tobj splits them (at Unicode whitespace), as bytes. For an
/// ASCII line splitting bytes gives the same words, faster.
fn words_of(line: &str) -> impl Iterator<Item = &[u8]> {
    let ascii = line.is_ascii();
    let bytes =
        ascii.then(|| line.as_bytes().split(|&b| is_ascii_space(b)).filter(|w| !w.is_empty()));
    let unicode = (!ascii).then(|| line.split_whitespace().map(str::as_bytes));
    bytes.into_iter().flatten().chain(unicode.into_iter().flatten())
}

/// A face line without its texture coordinate (`drop_vt`) and/or normal (`drop_vn`)
/// indices: `f 1/2/3 ...` becomes `f 1/2 ...`, `f 1//3 ...` or `f 1 ...`.
fn without_attributes(line: &str, drop_vt: bool, drop_vn: bool) -> String {
    let mut out = String::from("f");
    for corner in line.split_whitespace().skip(1) {
        let mut parts = corner.split('/');
        let v = parts.next().unwrap_or("");
        let vt = parts.next().filter(|_| !drop_vt).unwrap_or("");
        let vn = parts.next().filter(|_| !drop_vn).unwrap_or("");
        out.push(' ');
        out.push_str(v);
        match (vt.is_empty(), vn.is_empty()) {
            (true, true) => {}
            (false, true) => out.extend(["/", vt]),
            (true, false) => out.extend(["//", vn]),
            (false, false) => out.extend(["/", vt, "/", vn]),
        }
    }
    out.push('\n');
    out
}

/// A `v` line of exactly four numbers without its fourth (the weight w), or None for
/// any other line (three numbers, or six with a colour, go to tobj as written).
fn without_weight(line: &str) -> Option<String> {
    let mut words = line.split_whitespace();
    let (v, x, y, z, w) =
        (words.next()?, words.next()?, words.next()?, words.next()?, words.next()?);
    // A w that is no number stays for tobj to refuse, with its line.
    if v != "v" || words.next().is_some() || w.parse::<f32>().is_err() {
        return None;
    }
    Some(format!("v {x} {y} {z}\n"))
}

/// The fast check of an ASCII face's corners (the text after `f`) against the element
/// counts so far: true when [`LineFeeder::check_face`] would accept them. The parallel
/// reader's one-pass face reader decides it (`scratch` takes its corners, unused here).
fn face_is_valid(corners: &[u8], counts: [u64; 3], scratch: &mut Vec<[u32; 3]>) -> bool {
    scratch.clear();
    fast_face(corners, counts, true, &mut [0; 3], scratch).is_some()
}

/// An index as written, for a message: a file may write a million digits.
fn shown_index(text: &[u8]) -> String {
    crate::files::shown(&String::from_utf8_lossy(text), 60)
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
        if self.check_obj && self.pending.is_none() && self.error.is_none() {
            match first_word(self.rest) {
                "l" => {
                    // tobj would turn `l 1 2 3` into a triangle: it gets an empty line instead.
                    self.advance(line_end(self.rest));
                    self.pending = Some(Cow::Borrowed("\n"));
                }
                "f" => {
                    self.advance(line_end(self.rest));
                    self.prepare_face();
                }
                "v" => {
                    // `v x y z w`: w is a rational curve's weight, which tobj would divide
                    // the position by; a mesh keeps x, y, z (as other loaders do).
                    let end = line_end(self.rest);
                    if let Some(without_w) = without_weight(&self.rest[..end]) {
                        self.advance(end);
                        self.vertices += 1;
                        self.pending = Some(Cow::Owned(without_w));
                    }
                }
                _ => {}
            }
        }
        if self.error.is_some() {
            // tobj turns this into `ReadError`; `into_error` swaps ours back in.
            return Err(io::Error::other("stopped at a bad line"));
        }
        Ok(match &self.pending {
            Some(line) => &line.as_bytes()[self.pending_at.min(line.len())..],
            None => self.rest.as_bytes(),
        })
    }

    fn consume(&mut self, amount: usize) {
        if let Some(line) = &self.pending {
            // Already taken from `rest` and checked.
            self.pending_at += amount;
            if self.pending_at >= line.len() {
                (self.pending, self.pending_at) = (None, 0);
            }
            return;
        }
        // `read_until` consumes 0 bytes at the end of the text: that is no line.
        if amount == 0 {
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

/// The length of the first line of `text`, its `\n` included.
fn line_end(text: &str) -> usize {
    text.find('\n').map_or(text.len(), |i| i + 1)
}

/// The keyword of the first line of `text`, as tobj would see it (`l` for a polyline,
/// `f` for a face); "" for a blank line.
fn first_word(text: &str) -> &str {
    let line = text.trim_start_matches(|c: char| c.is_whitespace() && c != '\n');
    &line[..line.find(char::is_whitespace).unwrap_or(line.len())]
}

/// True when the first line of `text` is an `l` (polyline) statement, as tobj would see it.
#[cfg(test)]
fn starts_polyline(text: &str) -> bool {
    first_word(text) == "l"
}

#[cfg(test)]
#[path = "line_feeder_tests.rs"]
mod tests;
