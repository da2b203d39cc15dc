//! Wavefront OBJ loading (paper 3.1), on top of `tobj`, hardened for real-world files.
//!
//! `tobj` does the parsing, the vertex de-duplication (`single_index`) and the .mtl
//! parsing. Around it this module adds what a viewer needs from a loader:
//!
//! - Triangulation done here, so that a quad `1 2 3 4` splits into (1,2,4) and (2,3,4)
//!   exactly as the paper says; larger polygons become fans.
//! - Errors that name the file and the line. `tobj` reads through a `LineFeeder`, which
//!   sees it take one line at a time, so when `tobj` stops with an error the feeder knows
//!   the line. The feeder also checks every face index against the counts seen so far
//!   before `tobj` parses it: out-of-range indices get a line number, and `tobj` never
//!   meets the zero, huge or far-negative indices whose arithmetic can overflow inside it.
//!   All of this costs about a tenth of `tobj`'s own time; the text is only scanned
//!   again to find the line of a NaN.
//! - Warnings instead of failures for what a model can live without: a missing .mtl,
//!   a missing texture, an unknown `usemtl` name.

use std::cell::RefCell;
use std::collections::HashSet;
use std::io::{self, BufRead, Read};
use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};

use super::{Material, Mesh};

/// A loaded OBJ: the mesh plus the non-fatal problems met on the way (missing .mtl, missing texture...).
#[derive(Clone, Debug)]
pub struct LoadedObj {
    /// All objects and groups of the file merged into one mesh, triangles in file order.
    pub mesh: Mesh,
    /// One sentence per problem that was worked around (each also went to `log::warn!`).
    pub warnings: Vec<String>,
}

/// Why an OBJ could not be loaded; Display is one clear sentence naming the file and, where known, the line.
#[derive(Debug, thiserror::Error)]
pub enum ObjError {
    /// The file could not be opened or read (missing, a directory, no permission...).
    #[error("cannot read {}: {source}", path.display())]
    Io {
        /// The path as given.
        path: PathBuf,
        /// What the operating system said.
        #[source]
        source: io::Error,
    },
    /// The bytes are not UTF-8 text: a binary file, or text in another encoding.
    #[error("{name} is not an OBJ text file (invalid UTF-8 on line {line})")]
    NotText {
        /// The file, as named in messages.
        name: String,
        /// The line holding the first invalid byte.
        line: usize,
    },
    /// A line could not be read: a malformed number, too few values, a bad face corner.
    #[error("{name} line {line}: {reason}")]
    Parse {
        /// The file, as named in messages.
        name: String,
        /// 1-based line number.
        line: usize,
        /// What is wrong with the line, quoting it.
        reason: String,
    },
    /// The last statement of the file is incomplete (`f 1 2`, `v 1.0 2.`): the file was cut short.
    #[error("{name} line {line}: {reason}; this is the last line, so the file seems to be cut short")]
    Truncated {
        /// The file, as named in messages.
        name: String,
        /// 1-based line number of the incomplete last line.
        line: usize,
        /// What is wrong with the line, quoting it.
        reason: String,
    },
    /// A face refers to a vertex, texture coordinate or normal not defined before it.
    #[error("{name} line {line}: face {kind} index {index} is out of range (the file has {count} {} so far)", if *.count == 1 { .kind } else { .kind_plural })]
    IndexOutOfRange {
        /// The file, as named in messages.
        name: String,
        /// 1-based line number of the face.
        line: usize,
        /// "vertex", "texture coordinate" or "normal".
        kind: &'static str,
        /// The plural of `kind`, for the message.
        kind_plural: &'static str,
        /// The index as written in the file (it may not even fit an integer).
        index: String,
        /// How many elements of that kind precede the face.
        count: usize,
    },
    /// A vertex, normal or texture coordinate is NaN or infinite.
    #[error("{name} line {line}: {what} has a coordinate that is not a finite number (NaN or infinity)")]
    NonFinite {
        /// The file, as named in messages.
        name: String,
        /// 1-based line number of the first such `v`/`vn`/`vt` line.
        line: usize,
        /// "a vertex position", "a normal" or "a texture coordinate".
        what: &'static str,
    },
    /// The file has no faces (only points, lines, or nothing at all): nothing to trace.
    #[error("{name} contains no faces, so there is nothing to trace")]
    NoFaces {
        /// The file, as named in messages.
        name: String,
    },
    /// A problem that cannot be pinned to one line (too many vertices, inconsistent colours).
    #[error("{name}: {reason}")]
    Invalid {
        /// The file, as named in messages.
        name: String,
        /// What is wrong, one sentence.
        reason: String,
    },
}

/// Load an OBJ file (and the .mtl libraries it names, from its folder).
///
/// The whole file is read into memory first: it is needed again to locate the line of
/// an error, and one read is the fastest way to get at it anyway.
pub fn load_obj(path: &Path) -> Result<LoadedObj, ObjError> {
    let bytes = read_regular_file(path).map_err(|source| ObjError::Io { path: path.to_owned(), source })?;
    let name = path.display().to_string();
    let text = String::from_utf8(bytes).map_err(|e| {
        let valid = &e.as_bytes()[..e.utf8_error().valid_up_to()];
        let line = 1 + valid.iter().filter(|&&b| b == b'\n').count();
        ObjError::NotText { line, name: name.clone() }
    })?;
    // `parent()` of a bare file name is "", which joins to paths relative to the working
    // directory: exactly where the file itself was found.
    load_obj_from_str(&text, &name, path.parent())
}

/// Same, from text already in memory (`name` is used in messages, `base_dir` resolves mtllib). Used by tests and the fuzzer.
///
/// With `base_dir` `None`, `mtllib` statements are skipped with a warning.
pub fn load_obj_from_str(text: &str, name: &str, base_dir: Option<&Path>) -> Result<LoadedObj, ObjError> {
    // A UTF-8 byte-order mark would glue itself to the first keyword.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let libs = MaterialLibraries { base_dir, obj_name: name, loaded: RefCell::default(), warnings: RefCell::default() };
    let mut feeder = LineFeeder::new(text, name, true);

    let options = tobj::LoadOptions { single_index: true, triangulate: false, ignore_points: true, ignore_lines: true };
    let parsed = tobj::load_obj_buf(&mut feeder, &options, |mtl| libs.load(mtl));
    let (models, materials) = match parsed {
        Ok(ok) => ok,
        Err(e) => return Err(feeder.into_error(e)),
    };
    let usemtl_names = feeder.usemtl_names;
    let mut warnings = libs.warnings.into_inner();
    // Errors of the libraries were already turned into warnings, one per library.
    let materials = materials.unwrap_or_default();
    let materials = convert_materials(&materials, &libs.loaded.into_inner(), &mut warnings);

    let known: HashSet<&str> = materials.iter().map(|m| m.name.as_str()).collect();
    for missing in usemtl_names.iter().filter(|n| !known.contains(*n)) {
        warn(
            &mut warnings,
            format!("{name}: `usemtl {missing}` names no material of the loaded libraries; its faces use the default material"),
        );
    }

    let mesh = build_mesh(text, name, &models, materials)?;
    Ok(LoadedObj { mesh, warnings })
}

/// The bytes of a regular file. Devices and pipes are refused: `/dev/zero` would never end.
fn read_regular_file(path: &Path) -> io::Result<Vec<u8>> {
    let mut file = std::fs::File::open(path)?;
    let meta = file.metadata()?;
    if !meta.is_file() {
        let what = if meta.is_dir() { "a directory" } else { "not a regular file" };
        return Err(io::Error::new(io::ErrorKind::InvalidInput, format!("it is {what}")));
    }
    let mut bytes = Vec::with_capacity(usize::try_from(meta.len()).unwrap_or(0).saturating_add(1));
    file.read_to_end(&mut bytes)?;
    Ok(bytes)
}

/// Record a warning and pass it on to the log.
fn warn(warnings: &mut Vec<String>, message: String) {
    log::warn!("{message}");
    warnings.push(message);
}

/// A line for quoting in a message: trimmed, and shortened if long.
fn quote(line: &str) -> String {
    const MAX: usize = 60;
    let line = line.trim();
    match line.char_indices().nth(MAX) {
        Some((cut, _)) => format!("`{}...`", &line[..cut]),
        None => format!("`{line}`"),
    }
}

// ---------------------------------------------------------------------------------------
// Feeding tobj one checked line at a time
// ---------------------------------------------------------------------------------------

/// The `BufRead` that tobj reads the text through. tobj reads with `BufRead::lines`, so
/// every `consume` takes exactly one line: the feeder always knows which line tobj is on.
/// In OBJ mode it checks each line as it is consumed, before tobj parses it (counting
/// `v`/`vt`/`vn`, checking faces); after a bad line the next `fill_buf` fails, so tobj
/// stops before it can use the face. It also hides polylines from tobj.
struct LineFeeder<'a> {
    name: &'a str,
    /// The whole text.
    text: &'a str,
    /// Text not consumed yet.
    rest: &'a str,
    /// The line consumed last: the one tobj is working on.
    current_line: &'a str,
    /// 1-based number of `current_line`; 0 before the first.
    line: usize,
    /// `fill_buf` is handing out an empty line in place of a hidden one.
    hiding: bool,
    /// Check faces and count elements (OBJ), or only count lines (MTL).
    check_obj: bool,
    vertices: usize,
    texcoords: usize,
    normals: usize,
    /// Distinct `usemtl` names, in order of first use.
    usemtl_names: Vec<&'a str>,
    usemtl_seen: HashSet<&'a str>,
    /// The error that made the feeder stop, reported instead of tobj's `ReadError`.
    error: Option<ObjError>,
}

impl<'a> LineFeeder<'a> {
    fn new(text: &'a str, name: &'a str, check_obj: bool) -> Self {
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
    fn into_error(self, e: tobj::LoadError) -> ObjError {
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

// ---------------------------------------------------------------------------------------
// Material libraries
// ---------------------------------------------------------------------------------------

/// The `mtllib` loader handed to tobj: reads libraries relative to the OBJ's folder and
/// turns every failure into a warning.
struct MaterialLibraries<'a> {
    base_dir: Option<&'a Path>,
    obj_name: &'a str,
    /// For each library that loaded: its path and how many materials it added. tobj
    /// appends libraries in call order, so this maps a material back to its folder.
    loaded: RefCell<Vec<(PathBuf, usize)>>,
    warnings: RefCell<Vec<String>>,
}

impl MaterialLibraries<'_> {
    fn warn(&self, message: String) {
        warn(&mut self.warnings.borrow_mut(), message);
    }

    /// tobj's callback for `mtllib`: the library's materials, or an error once warned about.
    fn load(&self, mtllib: &Path) -> tobj::MTLLoadResult {
        let Some(base) = self.base_dir else {
            self.warn(format!(
                "{}: `mtllib {}` ignored (the OBJ was not loaded from a folder); using the default material",
                self.obj_name,
                mtllib.display()
            ));
            return Err(tobj::LoadError::OpenFileFailed);
        };
        // tobj passes the whole rest of the line, which may name several libraries
        // (`mtllib a.mtl b.mtl`) or one with spaces in its name.
        let spelled = mtllib.to_string_lossy();
        if spelled.trim().is_empty() {
            self.warn(format!("{}: `mtllib` names no file; using the default material", self.obj_name));
            return Err(tobj::LoadError::OpenFileFailed);
        }
        let parts: Vec<&str> = if find_file(base, &spelled).is_some() || !spelled.contains(char::is_whitespace) {
            vec![spelled.as_ref()]
        } else {
            spelled.split_whitespace().collect()
        };
        let mut merged: Option<(Vec<tobj::Material>, _)> = None;
        for part in parts {
            let Ok((mats, map)) = self.load_one(base, part) else { continue };
            match &mut merged {
                None => merged = Some((mats, map)),
                Some((all, all_map)) => {
                    let offset = all.len();
                    all_map.extend(map.into_iter().map(|(name, i)| (name, i + offset)));
                    all.extend(mats);
                }
            }
        }
        merged.ok_or(tobj::LoadError::OpenFileFailed)
    }

    fn load_one(&self, base: &Path, spelled: &str) -> tobj::MTLLoadResult {
        let path = find_file(base, spelled).unwrap_or_else(|| base.join(spelled));
        let bytes = match read_regular_file(&path) {
            Ok(b) => b,
            Err(e) => {
                self.warn(format!(
                    "{}: material library {} cannot be read ({e}); using the default material",
                    self.obj_name,
                    path.display()
                ));
                return Err(tobj::LoadError::OpenFileFailed);
            }
        };
        // Material names and texture paths are often Latin-1: keep going rather than fail.
        let text = String::from_utf8_lossy(&bytes);
        let mtl_name = path.display().to_string();
        let text = sanitize_mtl(&text, &mtl_name, &mut self.warnings.borrow_mut());
        let mut feeder = LineFeeder::new(&text, &mtl_name, false);
        match tobj::load_mtl_buf(&mut feeder) {
            Ok((mats, map)) => {
                self.loaded.borrow_mut().push((path, mats.len()));
                Ok((mats, map))
            }
            Err(e) => {
                self.warn(format!(
                    "{mtl_name} line {}: {e} in {}; the library's materials are ignored",
                    feeder.line,
                    quote(feeder.current_line)
                ));
                Err(e)
            }
        }
    }
}

/// `dir/spelled` if it is a file, also reading `\` as a path separator (files exported on Windows).
fn find_file(dir: &Path, spelled: &str) -> Option<PathBuf> {
    let direct = dir.join(spelled);
    if direct.is_file() {
        return Some(direct);
    }
    let slashed = dir.join(spelled.replace('\\', "/"));
    slashed.is_file().then_some(slashed)
}

/// Make colour lines safe for tobj, which panics on a `Kd` with fewer than three values
/// and rejects the whole library for `Kd spectral ...`. `Kd r` means grey (the MTL spec
/// repeats r); other malformed colour lines are blanked with a warning. Line numbers stay.
fn sanitize_mtl(text: &str, mtl_name: &str, warnings: &mut Vec<String>) -> String {
    let mut out = String::with_capacity(text.len() + 64);
    for (i, line) in text.split_inclusive('\n').enumerate() {
        let mut words = line.split_whitespace();
        let keyword = words.next().unwrap_or("");
        if matches!(keyword, "Ka" | "Kd" | "Ks" | "Ke") {
            let values: Vec<&str> = words.collect();
            let numeric = |n: usize| values.len() >= n && values[..n].iter().all(|v| v.parse::<f32>().is_ok());
            if numeric(3) {
                out.push_str(line);
            } else if values.len() == 1 && numeric(1) {
                let r = values[0];
                out.push_str(&format!("{keyword} {r} {r} {r}\n"));
            } else {
                warn(warnings, format!("{mtl_name} line {}: {} is not an RGB colour; ignored", i + 1, quote(line)));
                out.push('\n');
            }
        } else {
            out.push_str(line);
        }
    }
    out
}

/// Our materials from tobj's, with `map_Kd` resolved next to the library that named it.
fn convert_materials(mats: &[tobj::Material], loaded: &[(PathBuf, usize)], warnings: &mut Vec<String>) -> Vec<Material> {
    let mut libraries = loaded.iter().flat_map(|(path, count)| std::iter::repeat_n(path.as_path(), *count));
    mats.iter().map(|m| convert_material(m, libraries.next(), warnings)).collect()
}

fn convert_material(m: &tobj::Material, library: Option<&Path>, warnings: &mut Vec<String>) -> Material {
    let default = Material::default();
    let color = |c: Option<[f32; 3]>, fallback: Vec3| c.map(Vec3::from).filter(|v| v.is_finite()).unwrap_or(fallback);
    let mut out = Material {
        name: m.name.clone(),
        diffuse: color(m.diffuse, default.diffuse),
        specular: color(m.specular, default.specular),
        shininess: m.shininess.filter(|s| s.is_finite() && *s >= 0.0).unwrap_or(default.shininess),
        ..default
    };
    if let Some(raw) = &m.diffuse_texture {
        let dir = library.and_then(Path::parent).unwrap_or(Path::new(""));
        out.diffuse_texture = texture_path(dir, raw);
        if out.diffuse_texture.is_none() {
            let library = library.map_or_else(|| "a material library".to_owned(), |p| p.display().to_string());
            warn(warnings, format!("{library}: texture `{raw}` of material {} not found; the material keeps its plain colour", m.name));
        }
        // Exporters write `Kd 0 0 0` when the map supplies the colour (all of Sponza does).
        // Taken literally that is black whatever the renderer does with textures: white
        // lets `texture * diffuse` show the texture, and grey stands in for a missing one.
        if out.diffuse == Vec3::ZERO {
            out.diffuse = if out.diffuse_texture.is_some() { Vec3::ONE } else { Material::default().diffuse };
        }
    }
    out
}

/// The file a `map_Kd` value names. Options come before the name
/// (`map_Kd -s 1 1 1 -bm 0.5 wall.png`), but a name may also contain spaces.
fn texture_path(dir: &Path, raw: &str) -> Option<PathBuf> {
    let raw = raw.trim();
    find_file(dir, raw).or_else(|| raw.split_whitespace().last().and_then(|file| find_file(dir, file)))
}

// ---------------------------------------------------------------------------------------
// From tobj's models to one Mesh
// ---------------------------------------------------------------------------------------

/// Number of triangles a tobj mesh makes once triangulated.
fn triangles_in(m: &tobj::Mesh) -> usize {
    if m.face_arities.is_empty() {
        m.indices.len() / 3
    } else {
        m.face_arities.iter().map(|&n| (n as usize).saturating_sub(2)).sum()
    }
}

/// Append the triangles of one tobj mesh, offset by `base`. Quads split as the paper
/// says, (1,2,4) and (2,3,4); larger polygons become fans around their first corner.
fn triangulate(indices: &[u32], arities: &[u32], base: u32, out: &mut Vec<[u32; 3]>) {
    if arities.is_empty() {
        // tobj drops the arities when every face is a triangle.
        out.extend(indices.chunks_exact(3).map(|c| [c[0] + base, c[1] + base, c[2] + base]));
        return;
    }
    let mut start = 0;
    for &n in arities {
        let n = n as usize;
        let Some(c) = indices.get(start..start + n) else { break };
        start += n;
        let at = |i: usize| c[i] + base;
        match n {
            0..=2 => {} // points and lines: not surfaces
            3 => out.push([at(0), at(1), at(2)]),
            4 => out.extend([[at(0), at(1), at(3)], [at(1), at(2), at(3)]]),
            _ => out.extend((1..n - 1).map(|i| [at(0), at(i), at(i + 1)])),
        }
    }
}

fn build_mesh(text: &str, name: &str, models: &[tobj::Model], mut materials: Vec<Material>) -> Result<Mesh, ObjError> {
    let vertex_total: usize = models.iter().map(|m| m.mesh.positions.len() / 3).sum();
    let triangle_total: usize = models.iter().map(|m| triangles_in(&m.mesh)).sum();
    if triangle_total == 0 {
        return Err(ObjError::NoFaces { name: name.to_owned() });
    }
    if u32::try_from(vertex_total).is_err() {
        let reason = format!("{vertex_total} vertices are more than 32-bit indices can address");
        return Err(ObjError::Invalid { name: name.to_owned(), reason });
    }
    // tobj gives a vertex a normal (texcoord) only when its face corner names one, so a
    // model has them for every vertex exactly when the counts agree.
    let has = |attr: &[f32], width: usize, m: &tobj::Mesh| !m.positions.is_empty() && attr.len() / width == m.positions.len() / 3;
    let with_normals = models.iter().filter(|m| !m.mesh.positions.is_empty()).all(|m| has(&m.mesh.normals, 3, &m.mesh));
    let with_texcoords = models.iter().any(|m| has(&m.mesh.texcoords, 2, &m.mesh));

    let mut mesh = Mesh {
        name: name.to_owned(),
        positions: Vec::with_capacity(vertex_total),
        normals: Vec::with_capacity(if with_normals { vertex_total } else { 0 }),
        texcoords: Vec::with_capacity(if with_texcoords { vertex_total } else { 0 }),
        triangles: Vec::with_capacity(triangle_total),
        triangle_materials: Vec::with_capacity(triangle_total),
        ..Default::default()
    };
    let mut default_material = None;
    for model in models {
        let m = &model.mesh;
        let base = mesh.positions.len() as u32; // fits: checked against u32 above
        mesh.positions.extend(m.positions.chunks_exact(3).map(Vec3::from_slice));
        if with_normals {
            mesh.normals.extend(m.normals.chunks_exact(3).map(Vec3::from_slice));
        }
        if with_texcoords {
            if has(&m.texcoords, 2, m) {
                mesh.texcoords.extend(m.texcoords.chunks_exact(2).map(Vec2::from_slice));
            } else {
                mesh.texcoords.resize(mesh.positions.len(), Vec2::ZERO);
            }
        }
        let material = match m.material_id {
            Some(i) if i < materials.len() => i as u32,
            _ => *default_material.get_or_insert_with(|| {
                materials.push(Material::default());
                (materials.len() - 1) as u32
            }),
        };
        triangulate(&m.indices, &m.face_arities, base, &mut mesh.triangles);
        mesh.triangle_materials.resize(mesh.triangles.len(), material);
    }
    mesh.materials = materials;

    let bad = [
        !mesh.positions.iter().all(|p| p.is_finite()),
        !mesh.normals.iter().all(|n| n.is_finite()),
        !mesh.texcoords.iter().all(|t| t.is_finite()),
    ];
    if bad.contains(&true) {
        return Err(locate_non_finite(text, name, bad));
    }

    let models_with_faces = models.iter().filter(|m| !m.mesh.indices.is_empty()).count();
    if with_normals {
        // File normals need not be unit length; a zero one takes the computed normal.
        let file_normals = std::mem::take(&mut mesh.normals);
        let computed = if file_normals.iter().any(|n| n.try_normalize().is_none()) {
            mesh.compute_vertex_normals();
            std::mem::take(&mut mesh.normals)
        } else {
            Vec::new()
        };
        mesh.normals = file_normals.iter().enumerate().map(|(i, n)| n.try_normalize().unwrap_or_else(|| computed[i])).collect();
        mesh.has_file_normals = true;
    } else if models_with_faces > 1 || with_texcoords {
        // tobj splits vertices at every `usemtl`/`o`/`g` and at texture seams: averaging
        // per vertex would leave shading seams there, so average per position instead.
        smooth_normals_by_position(&mut mesh);
    } else {
        mesh.compute_vertex_normals();
    }
    Ok(mesh)
}

/// Area-weighted normals like [`Mesh::compute_vertex_normals`], but shared by all
/// vertices at the same position.
fn smooth_normals_by_position(mesh: &mut Mesh) {
    let mut slots = std::collections::HashMap::with_capacity(mesh.positions.len());
    // `+ 0.0` turns -0.0 into 0.0, so that the two zeros share a slot.
    let slot_of: Vec<u32> = mesh
        .positions
        .iter()
        .map(|p| {
            let next = slots.len() as u32;
            *slots.entry((*p + 0.0).to_array().map(f32::to_bits)).or_insert(next)
        })
        .collect();
    let mut sums = vec![Vec3::ZERO; slots.len()];
    for tri in &mesh.triangles {
        let [a, b, c] = tri.map(|k| mesh.positions[k as usize]);
        let face = (b - a).cross(c - a); // length = twice the area: the weight
        for &k in tri {
            sums[slot_of[k as usize] as usize] += face;
        }
    }
    mesh.normals = slot_of.iter().map(|&s| sums[s as usize].normalize_or(Vec3::Y)).collect();
    mesh.has_file_normals = false;
}

/// The error for the first `v`, `vn` or `vt` line (of the kinds flagged in `bad`) that
/// holds a NaN or infinity. Only runs once the loaded data was found to contain one.
fn locate_non_finite(text: &str, name: &str, bad: [bool; 3]) -> ObjError {
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let (what, width) = match words.next() {
            Some("v") if bad[0] => ("a vertex position", 3),
            Some("vn") if bad[1] => ("a normal", 3),
            Some("vt") if bad[2] => ("a texture coordinate", 2),
            _ => continue,
        };
        let values: Vec<f32> = words.map_while(|w| w.parse().ok()).collect();
        let mut coords: Vec<f32> = values.iter().copied().take(width).collect();
        if width == 3 && values.len() == 4 && what == "a vertex position" {
            // `v x y z w`: tobj divides by w, which can overflow to infinity.
            coords.iter_mut().for_each(|c| *c /= values[3]);
        }
        if coords.iter().any(|c| !c.is_finite()) {
            return ObjError::NonFinite { name: name.to_owned(), line: i + 1, what };
        }
    }
    let reason = "it contains a coordinate that is not a finite number".to_owned();
    ObjError::Invalid { name: name.to_owned(), reason }
}

/// The error for `v` lines that mix colours: tobj only notices when a face uses a vertex
/// past the last colour, so find the first vertex that differs from the first one.
fn locate_colour_mismatch(text: &str, name: &str) -> ObjError {
    let mut first = None;
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        if words.next() != Some("v") {
            continue;
        }
        // x y z [w] or x y z r g b
        let coloured = words.count() >= 6;
        match first {
            None => first = Some((i + 1, coloured)),
            Some((first_line, first_coloured)) if coloured != first_coloured => {
                let (has, lacks) = if first_coloured { (first_line, i + 1) } else { (i + 1, first_line) };
                let reason =
                    format!("the vertex on line {lacks} has no colour while the one on line {has} has; give every vertex a colour or none");
                return ObjError::Parse { name: name.to_owned(), line: i + 1, reason };
            }
            Some(_) => {}
        }
    }
    let reason = "some `v` lines carry a vertex colour and others do not".to_owned();
    ObjError::Invalid { name: name.to_owned(), reason }
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
    fn quads_follow_the_paper_and_polygons_fan() {
        let mut out = Vec::new();
        // A triangle, a quad and a pentagon, offset by 10.
        triangulate(&[0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11], &[3, 4, 5], 10, &mut out);
        assert_eq!(out, [[10, 11, 12], [13, 14, 16], [14, 15, 16], [17, 18, 19], [17, 19, 20], [17, 20, 21]]);
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

    #[test]
    fn mtl_colours_are_made_safe_for_tobj() {
        let mut warnings = Vec::new();
        let text = sanitize_mtl("newmtl a\nKd 0.5\nKs 1 2\nKa spectral x.rfl\nKe 1 2 3\n", "m.mtl", &mut warnings);
        assert_eq!(text, "newmtl a\nKd 0.5 0.5 0.5\n\n\nKe 1 2 3\n");
        assert_eq!(warnings.len(), 2);
        assert!(warnings[0].contains("m.mtl line 3"), "{}", warnings[0]);
    }

    #[test]
    fn non_finite_values_are_found_on_their_line() {
        let text = "v 0 0 0\nvn 0 0 1\nv 1 0 0 1e-45\nv nan 0 0\n";
        match locate_non_finite(text, "t.obj", [true, false, false]) {
            ObjError::NonFinite { line, what, .. } => assert_eq!((line, what), (3, "a vertex position")),
            other => panic!("{other}"),
        }
    }
}
