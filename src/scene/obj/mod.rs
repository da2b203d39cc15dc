//! Wavefront OBJ loading (paper 3.1): our own parallel parser, hardened for real-world
//! files; `tobj` reads the .mtl libraries.
//!
//! The file is read once, cut into chunks at line starts and parsed chunk by chunk on all
//! cores (`chunks.rs`, `parse_chunk.rs`), joined in file order (`parallel.rs`) and built
//! into one mesh (`assemble.rs`, with `par_dedup.rs` for models spread over several
//! chunks, `plain_dedup.rs` for those whose corners name positions alone, and `convert.rs`
//! for the normals); the text is freed before the mesh is built. Corners are kept as
//! compactly as the file allows (`corners.rs`: one `u32` each for `f 1 2 3`).
//!
//! The loader used to be tobj fed line by line (`line_feeder.rs`); that path is kept as
//! the oracle the tests, benches and the fuzzer compare with (`oracle.rs`, built only for
//! them: `cfg(test)` or the `dev` feature), and every rule below is the one it had:
//!
//! - Statements read as tobj read them: words split at whitespace, `v x y z` with an
//!   optional weight w (dropped: a mesh keeps x, y, z) or colour r g b (0..1, kept as
//!   RGBA8 in `Mesh::colors`, following its vertex through de-duplication and splits), `vt u v`,
//!   `vn x y z`, faces of three or more corners `v`, `v/vt`, `v//vn`, `v/vt/vn` with
//!   absolute or relative (negative) indices; every line on its own (a `\` at the end of a
//!   line does not continue it); `l` polylines and unknown statements ignored.
//! - Vertices as tobj made them: per model (a new one at `o`/`g` and at a `usemtl` that
//!   changes the material, once the current one has faces) each distinct corner becomes
//!   a vertex, in order of first use.
//! - Triangulation: a quad `1 2 3 4` splits into (1,2,4) and (2,3,4) exactly as the paper
//!   says; larger polygons become fans.
//! - Errors that name the file and the line, the first in file order: a number that is
//!   not one, too few values, a bad face corner, a face vertex index out of range (checked
//!   against the counts before its line, so zero, huge or far-negative indices are refused
//!   with their line), a statement cut short on the last line, a NaN or infinity.
//! - Warnings instead of failures for what a model can live without: a missing .mtl,
//!   a missing texture, an unknown `usemtl` name, texture options it does not apply,
//!   faces naming texture coordinates or normals that the file never defines (the face
//!   goes on without them).
//! - Computed normals (for vertices that the file gives none) that honour smoothing
//!   groups (`s 1`, `s off`) or, without groups, an optional crease angle
//!   ([`LoadOptions::crease_angle`]).
//! - Texture options of `map_Kd` (`-o`, `-s`, `-clamp` applied, the others ignored) and
//!   `mtllib` with several names and `\ ` escapes.

mod assemble;
mod chunks;
mod convert;
mod corners;
mod fast_lines;
mod line_feeder;
mod mtl;
#[cfg(any(test, feature = "dev"))]
mod oracle;
mod par_dedup;
mod parallel;
mod parse_chunk;
mod plain_dedup;

use std::cell::RefCell;
use std::collections::HashSet;
use std::io;
use std::path::{Path, PathBuf};

use super::Mesh;
use line_feeder::Dropped;
use mtl::{convert_materials, MaterialLibraries};
#[cfg(any(test, feature = "dev"))]
pub use oracle::load_obj_from_str_tobj;

/// How to load: what the file leaves to the loader.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LoadOptions {
    /// For files with neither normals nor smoothing groups: faces that share a position
    /// share a computed normal only where their face normals are less than this many
    /// degrees apart (`--crease-angle`). None smooths across every edge.
    pub crease_angle: Option<f32>,
}

/// A loaded OBJ: the mesh plus the non-fatal problems met on the way (missing .mtl, missing texture...).
#[derive(Clone, Debug)]
pub struct LoadedObj {
    /// All objects and groups of the file merged into one mesh, triangles in file order.
    pub mesh: Mesh,
    /// One sentence per problem that was worked around (not logged here: the caller shows them).
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
    /// The bytes are not UTF-8 text where it matters (a binary file, or statements in
    /// another encoding; comments and names may be in any).
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
    #[error(
        "{name} line {line}: {reason}; this is the last line, so the file seems to be cut short"
    )]
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
    #[error(
        "{name} line {line}: {what} has a coordinate that is not a finite number (NaN or infinity)"
    )]
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
/// The whole file is read into memory first (one read is the fastest way to get at it),
/// parsed in parallel, and freed before the mesh is built.
pub fn load_obj(path: &Path) -> Result<LoadedObj, ObjError> {
    load_obj_with(path, &LoadOptions::default())
}

/// [`load_obj`] with options.
pub fn load_obj_with(path: &Path, options: &LoadOptions) -> Result<LoadedObj, ObjError> {
    let mut laps = crate::progress::Laps::start("obj load");
    let bytes = crate::files::read_regular_file_parallel(path)
        .map_err(|source| ObjError::Io { path: path.to_owned(), source })?;
    laps.lap("read");
    // `parent()` of a bare file name is "", which joins to paths relative to the working
    // directory: exactly where the file itself was found.
    load_obj_from_bytes(bytes, &path.display().to_string(), path.parent(), options)
}

/// [`load_obj_with`] on a file already read (`name` for messages, `base_dir` for its .mtl
/// and textures); the text is freed as soon as it is parsed. The bytes are checked to be
/// UTF-8 chunk by chunk, in parallel, as they are parsed.
pub fn load_obj_from_bytes(
    bytes: Vec<u8>,
    name: &str,
    base_dir: Option<&Path>,
    options: &LoadOptions,
) -> Result<LoadedObj, ObjError> {
    let parsed = parse_text(&bytes, name, base_dir, chunks::default_chunk_bytes(bytes.len()))?;
    crate::memory::free_on_every_core(bytes);
    finish(parsed, name, options)
}

/// Same, from text already in memory (`name` is used in messages, `base_dir` resolves mtllib). Used by tests and the fuzzer.
///
/// With `base_dir` `None`, `mtllib` statements are skipped with a warning.
pub fn load_obj_from_str(
    text: &str,
    name: &str,
    base_dir: Option<&Path>,
) -> Result<LoadedObj, ObjError> {
    load_obj_from_str_with(text, name, base_dir, &LoadOptions::default())
}

/// [`load_obj_from_str`] with options.
pub fn load_obj_from_str_with(
    text: &str,
    name: &str,
    base_dir: Option<&Path>,
    options: &LoadOptions,
) -> Result<LoadedObj, ObjError> {
    load_obj_from_str_chunked(
        text,
        name,
        base_dir,
        options,
        chunks::default_chunk_bytes(text.len()),
    )
}

/// [`load_obj_from_str_with`] with the text cut into chunks of about `chunk_bytes` (1 cuts
/// at every line): for tests, which check that every cut gives the same result.
#[doc(hidden)]
pub fn load_obj_from_str_chunked(
    text: &str,
    name: &str,
    base_dir: Option<&Path>,
    options: &LoadOptions,
    chunk_bytes: usize,
) -> Result<LoadedObj, ObjError> {
    let parsed = parse_text(text.as_bytes(), name, base_dir, chunk_bytes)?;
    finish(parsed, name, options)
}

/// The parse and everything that needs the text: the joined parse, the converted
/// materials and the warnings so far.
struct ParsedObj {
    parsed: parallel::Parsed,
    materials: Vec<crate::scene::Material>,
    warnings: Vec<String>,
}

fn parse_text(
    bytes: &[u8],
    name: &str,
    base_dir: Option<&Path>,
    chunk_bytes: usize,
) -> Result<ParsedObj, ObjError> {
    // A UTF-8 byte-order mark would glue itself to the first keyword.
    let bytes = bytes.strip_prefix("\u{feff}".as_bytes()).unwrap_or(bytes);
    let libs = MaterialLibraries {
        base_dir,
        obj_name: name,
        loaded: RefCell::default(),
        warnings: RefCell::default(),
    };
    let mut parsed = match parallel::parse(bytes, name, &libs, chunk_bytes) {
        // Bytes that are not UTF-8 stop the parse before any line is read: where they sit
        // in comments and names only, the text is read again with them replaced.
        Err(ObjError::NotText { .. }) => {
            let text = chunks::lossy_text(bytes)
                .map_err(|line| ObjError::NotText { name: name.to_owned(), line })?;
            parallel::parse(text.as_bytes(), name, &libs, chunk_bytes)?
        }
        other => other?,
    };
    let mut warnings = libs.warnings.into_inner();
    warn_dropped(
        &mut warnings,
        name,
        &parsed.dropped_texcoords,
        "texture coordinate",
        "texture coordinates",
        "drawn without texture coordinates",
    );
    warn_dropped(
        &mut warnings,
        name,
        &parsed.dropped_normals,
        "normal",
        "normals",
        "drawn with computed normals",
    );
    let materials = convert_materials(
        &std::mem::take(&mut parsed.materials),
        &libs.loaded.into_inner(),
        &mut warnings,
    );
    let known: HashSet<&str> = materials.iter().map(|m| m.name.as_str()).collect();
    for missing in parsed.usemtl_names.iter().filter(|n| !known.contains(n.as_str())) {
        warn(
            &mut warnings,
            format!("{name}: `usemtl {}` names no material of the loaded libraries; its faces use the default material", quote_name(missing)),
        );
    }
    Ok(ParsedObj { parsed, materials, warnings })
}

fn finish(parsed: ParsedObj, name: &str, options: &LoadOptions) -> Result<LoadedObj, ObjError> {
    let mesh = assemble::assemble(parsed.parsed, parsed.materials, name, options)?;
    Ok(LoadedObj { mesh, warnings: parsed.warnings })
}

/// One warning for all the faces that named a texture coordinate or normal out of range,
/// naming the first one's line.
fn warn_dropped(
    warnings: &mut Vec<String>,
    name: &str,
    dropped: &Dropped,
    kind: &str,
    kind_plural: &str,
    outcome: &str,
) {
    let Some(first) = &dropped.first else { return };
    let had = if first.count == 1 { kind } else { kind_plural };
    let these = match dropped.faces.len() - 1 {
        0 => "the face is".to_owned(),
        n => format!("the face and {n} more like it are"),
    };
    warn(
        warnings,
        format!("{name} line {}: face {kind} index {} is out of range (the file has {} {had} so far); {these} {outcome}", first.line, first.index, first.count),
    );
}

/// Record a warning for the caller, who shows it once (the log on the command line, the
/// panel in the window).
fn warn(warnings: &mut Vec<String>, message: String) {
    warnings.push(message);
}

/// A line for quoting in a message: trimmed, shortened if long, control characters
/// escaped (a file's text must not drive the user's terminal).
fn quote(line: &str) -> String {
    format!("`{}`", crate::files::shown(line.trim(), 60))
}

/// A name read from a file (a material, a library) for a message: see [`quote`].
fn quote_name(name: &str) -> String {
    crate::files::shown(name, crate::files::MAX_QUOTED_NAME)
}
