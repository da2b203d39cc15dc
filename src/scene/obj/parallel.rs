//! The parallel OBJ parse: the text cut into chunks at line starts, each parsed on its own
//! with rayon (the few that need the counts of the chunks before them parsed again once
//! those are known), the element arrays joined into the whole file's, then the rest
//! joined in order: `mtllib`/`usemtl`/`o`/`g` walked as tobj walked
//! them (which decides the models, each a run of faces with one material), smoothing
//! groups and dropped attributes numbered in the whole file, and the first error in file
//! order reported, whichever chunk finished first.
//!
//! What comes out no longer borrows the text, so the caller can free it before the mesh
//! is built.

use std::collections::{HashMap, HashSet};
use std::ops::Range;
use std::path::Path;

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::chunks::{self, Chunk, Counts};
use super::convert::{colour, locate_colour_mismatch};
use super::corners::{Corner, Corners};
use super::line_feeder::{Dropped, DroppedFirst};
use super::mtl::MaterialLibraries;
use super::parse_chunk::{
    parse_alone, parse_exact, ChunkDropped, ChunkError, ChunkFaces, ErrorKind, Event,
};
use super::ObjError;

/// A run of faces (numbered in file order) that tobj made one model of.
#[derive(Clone, Debug)]
pub(super) struct ModelRun {
    pub(super) faces: Range<usize>,
    /// Index into the merged material libraries, when `usemtl` named a known material.
    pub(super) material: Option<usize>,
    /// Some `v` line before the model's end carried a colour: tobj gives its vertices
    /// their colours then, and none (white, in a mesh with colours) otherwise.
    pub(super) coloured: bool,
}

/// The faces of one chunk.
#[derive(Debug, Default)]
pub(super) struct FaceBlock<C> {
    /// Per corner its position index (`u32`) or (v, vt, vn), 0-based, `NONE` when absent.
    pub(super) corners: Vec<C>,
    /// Corners per face.
    pub(super) arities: Vec<u32>,
}

/// The chunks' faces in file order, all stored alike: position indices alone when no
/// corner of the file names more.
#[derive(Debug)]
pub(super) enum Blocks {
    Plain(Vec<FaceBlock<u32>>),
    Full(Vec<FaceBlock<[u32; 3]>>),
}

impl Default for Blocks {
    fn default() -> Self {
        Blocks::Plain(Vec::new())
    }
}

impl Blocks {
    /// The chunks' corners and arities, as triples if any chunk has them.
    fn new(chunks: Vec<(Corners, Vec<u32>)>) -> Blocks {
        let mut plain = Vec::with_capacity(chunks.len());
        let mut rest = chunks.into_iter();
        while let Some((corners, arities)) = rest.next() {
            match corners {
                Corners::Plain(corners) => plain.push(FaceBlock { corners, arities }),
                Corners::Full(full) => {
                    let before = plain.into_iter().map(|b| (Corners::Plain(b.corners), b.arities));
                    let all: Vec<_> =
                        before.chain([(Corners::Full(full), arities)]).chain(rest).collect();
                    return Blocks::Full(
                        all.into_par_iter()
                            .map(|(c, arities)| FaceBlock { corners: c.into_full(), arities })
                            .collect(),
                    );
                }
            }
        }
        Blocks::Plain(plain)
    }
}

/// The parsed file, joined, without references into the text.
#[derive(Debug, Default)]
pub(super) struct Parsed {
    pub(super) positions: Vec<Vec3>,
    pub(super) texcoords: Vec<Vec2>,
    pub(super) normals: Vec<Vec3>,
    /// Colours of the `v` lines that have one, in order (empty without): a vertex made
    /// from position `v` takes `colors[v]`, as tobj gives it.
    pub(super) colors: Vec<[u8; 4]>,
    /// The faces, chunk by chunk, in file order.
    pub(super) blocks: Blocks,
    pub(super) models: Vec<ModelRun>,
    /// Where the smoothing group changes: (first face, group); empty without `s` lines.
    pub(super) smoothing: Vec<(usize, u32)>,
    pub(super) dropped_texcoords: Dropped,
    pub(super) dropped_normals: Dropped,
    /// Some corner names a texture coordinate / a normal; every corner names a normal.
    pub(super) any_texcoord: bool,
    pub(super) any_normal: bool,
    pub(super) all_normals: bool,
    /// First line per kind (position, normal, texture coordinate) holding a non-finite value.
    pub(super) non_finite: [Option<usize>; 3],
    /// Distinct `usemtl` names, in order of first use.
    pub(super) usemtl_names: Vec<String>,
    /// The merged materials of all `mtllib` libraries, as tobj merges them.
    pub(super) materials: Vec<tobj::Material>,
}

impl Parsed {
    /// Frees the parse's arrays now, on every core (see [`crate::memory::free_on_every_core`]).
    pub(super) fn free(self) {
        let Parsed { positions, texcoords, normals, blocks, .. } = self;
        crate::memory::free_on_every_core(positions);
        crate::memory::free_on_every_core(texcoords);
        crate::memory::free_on_every_core(normals);
        match blocks {
            Blocks::Plain(blocks) => blocks.into_par_iter().for_each(drop),
            Blocks::Full(blocks) => blocks.into_par_iter().for_each(drop),
        }
    }
}

/// Parse `bytes` (checked to be UTF-8 on the way) in chunks of about `chunk_bytes`;
/// `libs` loads the `mtllib` libraries.
pub(super) fn parse(
    bytes: &[u8],
    name: &str,
    libs: &MaterialLibraries,
    chunk_bytes: usize,
) -> Result<Parsed, ObjError> {
    let mut laps = crate::progress::Laps::start("obj parse");
    let pieces = chunks::split(bytes, chunk_bytes);
    let alone: Vec<Alone> = pieces
        .par_iter()
        .map(|&(offset, bytes)| match chunks::text_of(offset, bytes) {
            Err(lines) => Alone::NotText(lines),
            Ok(chunk) => match parse_alone(chunk) {
                Some(faces) => Alone::Parsed(chunk, Box::new(faces)),
                None => Alone::Counted(chunk, chunks::count(chunk.text)),
            },
        })
        .collect();
    drop(pieces);
    laps.lap("chunks alone");
    // The counts before each chunk, and the first bytes that are not text, in file order.
    let mut before = Vec::with_capacity(alone.len());
    let mut sum = Counts::default();
    for piece in &alone {
        before.push(sum);
        sum = sum.add(match piece {
            Alone::NotText(lines) => {
                return Err(ObjError::NotText {
                    name: name.to_owned(),
                    line: sum.lines + lines + 1,
                })
            }
            Alone::Parsed(_, faces) => faces.counts,
            Alone::Counted(_, counts) => *counts,
        });
    }
    let results: Vec<ChunkFaces> = alone
        .into_par_iter()
        .zip(&before)
        .map(|(piece, before)| match piece {
            Alone::Parsed(_, faces) if faces.fits_after(before) => *faces,
            Alone::Parsed(chunk, _) | Alone::Counted(chunk, _) => parse_exact(chunk, *before),
            Alone::NotText(_) => ChunkFaces::default(), // returned above
        })
        .collect();
    laps.lap("chunks again");
    let mut parsed = Parsed {
        positions: concat(&results, |r| &r.positions),
        texcoords: concat(&results, |r| &r.texcoords),
        normals: concat(&results, |r| &r.normals),
        all_normals: true,
        ..Default::default()
    };
    laps.lap("arrays joined");
    join(results, &mut parsed, bytes, name, libs)?;
    laps.lap("rest joined");
    Ok(parsed)
}

/// A chunk after its parse on its own.
enum Alone<'a> {
    /// Parsed, and right if its faces' indices prove in range (boxed: the other two are small).
    Parsed(Chunk<'a>, Box<ChunkFaces<'a>>),
    /// Needs the counts before it: only counted so far.
    Counted(Chunk<'a>, Counts),
    /// Not UTF-8: the number of whole lines before its first invalid byte.
    NotText(usize),
}

/// The chunks' parts of one element array, joined in order on every core.
fn concat<T: Copy + Default + Send + Sync>(
    results: &[ChunkFaces],
    part: impl for<'r> Fn(&'r ChunkFaces<'_>) -> &'r [T] + Sync,
) -> Vec<T> {
    let mut all = crate::memory::filled(results.iter().map(|r| part(r).len()).sum(), T::default());
    let mut rest = all.as_mut_slice();
    let mut jobs = Vec::with_capacity(results.len());
    for r in results {
        let (mine, after) = std::mem::take(&mut rest).split_at_mut(part(r).len());
        rest = after;
        jobs.push((mine, part(r)));
    }
    jobs.into_par_iter().for_each(|(mine, from)| mine.copy_from_slice(from));
    all
}

/// The chunks in file order, as tobj would have read them: models, materials, smoothing
/// groups, dropped attributes; the first error in file order, or the vertex colour error
/// that tobj raises when it closes a model before that line.
fn join(
    results: Vec<ChunkFaces>,
    parsed: &mut Parsed,
    bytes: &[u8],
    name: &str,
    libs: &MaterialLibraries,
) -> Result<(), ObjError> {
    // Every chunk was valid UTF-8, so the whole is: the messages that read the text again
    // (rare) check it once more rather than assume it.
    let text = || std::str::from_utf8(bytes).unwrap_or_default();
    let mut walk = Walk::default();
    let mut error: Option<ChunkError> = None;
    let (mut face_base, mut colour_base) = (0, 0);
    let mut colour_values = Vec::new();
    let mut blocks = Vec::with_capacity(results.len());
    for mut chunk in results {
        for event in std::mem::take(&mut chunk.events) {
            walk.event(event, face_base, colour_base, libs);
        }
        join_dropped(&mut parsed.dropped_texcoords, &chunk.dropped_texcoords, face_base);
        join_dropped(&mut parsed.dropped_normals, &chunk.dropped_normals, face_base);
        parsed.any_texcoord |= chunk.any_texcoord;
        parsed.any_normal |= chunk.any_normal;
        parsed.all_normals &= chunk.all_normals;
        for (first, here) in parsed.non_finite.iter_mut().zip(chunk.non_finite) {
            *first = first.or(here);
        }
        face_base += chunk.arities.len();
        colour_base += chunk.colours;
        colour_values.append(&mut chunk.colour_values);
        error = chunk.error.take();
        blocks.push((chunk.corners, chunk.arities));
        if error.is_some() {
            break;
        }
    }
    if error.is_none() {
        // The last model is closed at the end of the file, even without faces.
        walk.pop(face_base, colour_base);
    }
    parsed.blocks = Blocks::new(blocks);
    if walk.pops.iter().any(|(faces, colours)| {
        *colours > 0
            && match &parsed.blocks {
                Blocks::Plain(blocks) => uses_vertex_beyond(&blocks[..], faces.clone(), *colours),
                Blocks::Full(blocks) => uses_vertex_beyond(&blocks[..], faces.clone(), *colours),
            }
    }) {
        return Err(locate_colour_mismatch(text(), name));
    }
    if let Some(e) = error {
        return Err(located_error(e, text(), name));
    }
    // Position `v` has values 3v..3v+3, as tobj reads them.
    parsed.colors = colour_values.chunks_exact(3).map(|c| colour([c[0], c[1], c[2]])).collect();
    parsed.models = walk.models;
    parsed.smoothing = walk.smoothing;
    parsed.usemtl_names = walk.usemtl_names;
    parsed.materials = walk.materials;
    Ok(())
}

/// The chunk's dropped faces, numbered in the whole file.
fn join_dropped(all: &mut Dropped, chunk: &ChunkDropped, face_base: usize) {
    all.faces.extend(chunk.faces.iter().map(|f| f + face_base));
    if all.first.is_none() {
        all.first = chunk.first.as_ref().map(|(line, index, count)| DroppedFirst {
            line: *line,
            index: index.clone(),
            count: *count,
        });
    }
}

/// True when a face among `faces` uses a vertex without a colour value (tobj's check when
/// it closes a model while some `v` lines carried colours: `colours` values so far).
fn uses_vertex_beyond<C: Corner>(
    blocks: &[FaceBlock<C>],
    faces: Range<usize>,
    colours: usize,
) -> bool {
    let mut first_face = 0;
    for block in blocks {
        let here = first_face..first_face + block.arities.len();
        first_face = here.end;
        if here.end <= faces.start || here.start >= faces.end {
            continue;
        }
        let mut corner = 0;
        for (f, &n) in block.arities.iter().enumerate() {
            let n = n as usize;
            if faces.contains(&(here.start + f))
                && block.corners[corner..corner + n]
                    .iter()
                    .any(|c| 3 * c.position() as usize + 2 >= colours)
            {
                return true;
            }
            corner += n;
        }
    }
    false
}

/// A chunk's error as the message the loader gives: a parse error on the file's last
/// line reads as a truncated file.
fn located_error(e: ChunkError, text: &str, name: &str) -> ObjError {
    let (name, line) = (name.to_owned(), e.line);
    match e.kind {
        ErrorKind::VertexOutOfRange { index, count } => ObjError::IndexOutOfRange {
            name,
            line,
            kind: "vertex",
            kind_plural: "vertices",
            index,
            count,
        },
        ErrorKind::Parse(reason) if text.get(e.line_end..).unwrap_or("").trim().is_empty() => {
            ObjError::Truncated { name, line, reason }
        }
        ErrorKind::Parse(reason) => ObjError::Parse { name, line, reason },
    }
}

/// tobj's state between faces, walked event by event in file order.
#[derive(Default)]
struct Walk {
    /// First face of the model being gathered.
    start: usize,
    material: Option<usize>,
    materials: Vec<tobj::Material>,
    material_map: HashMap<String, usize>,
    models: Vec<ModelRun>,
    /// Every closed model's faces and the vertex colour values read by then.
    pops: Vec<(Range<usize>, usize)>,
    smoothing: Vec<(usize, u32)>,
    usemtl_names: Vec<String>,
    usemtl_seen: HashSet<String>,
}

impl Walk {
    fn event(
        &mut self,
        event: Event,
        face_base: usize,
        colour_base: usize,
        libs: &MaterialLibraries,
    ) {
        match event {
            Event::Group { face, colours } => {
                if face_base + face > self.start {
                    self.pop(face_base + face, colour_base + colours);
                }
            }
            Event::Usemtl { face, colours, name } => {
                if !self.usemtl_seen.contains(name) {
                    self.usemtl_seen.insert(name.to_owned());
                    self.usemtl_names.push(name.to_owned());
                }
                let material = self.material_map.get(name).copied();
                if material != self.material && face_base + face > self.start {
                    self.pop(face_base + face, colour_base + colours);
                }
                self.material = material;
            }
            Event::Mtllib { spelled } => {
                // A library that fails was already turned into a warning.
                if let Ok((mut materials, map)) = libs.load(Path::new(spelled)) {
                    let offset = self.materials.len();
                    self.materials.append(&mut materials);
                    self.material_map.extend(map.into_iter().map(|(name, i)| (name, i + offset)));
                }
            }
            Event::Smooth { face, group } => {
                let face = face_base + face;
                match self.smoothing.last_mut() {
                    Some(last) if last.0 == face => last.1 = group,
                    Some(last) if last.1 == group => {}
                    _ => self.smoothing.push((face, group)),
                }
            }
        }
    }

    /// Close the model gathered so far at face `end`.
    fn pop(&mut self, end: usize, colours: usize) {
        let faces = self.start..end;
        let coloured = colours > 0;
        self.models.push(ModelRun { faces: faces.clone(), material: self.material, coloured });
        self.pops.push((faces, colours));
        self.start = end;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn invalid_utf8_is_found_on_its_line_whatever_the_chunks() {
        // Chunks read alone, chunks counted (the relative index) and chunks read exactly.
        let bytes = b"v 1 2 3\nv 1 2 3\nv 1 2 3\nf -1 -2 -3\nf 1 2 3\nv \xff 2 3\nv\n";
        let libs = MaterialLibraries {
            base_dir: None,
            obj_name: "t.obj",
            loaded: Default::default(),
            warnings: Default::default(),
        };
        for size in 1..bytes.len() + 2 {
            let e = parse(bytes, "t.obj", &libs, size).err();
            assert!(matches!(e, Some(ObjError::NotText { line: 6, .. })), "size {size}: {e:?}");
        }
    }
}
