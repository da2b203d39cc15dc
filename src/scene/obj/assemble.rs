//! From the joined parse to one `Mesh`, as the loader has always built it from tobj's
//! models: per model (a run of faces with one material) every distinct corner (v, vt, vn)
//! becomes a vertex, numbered in order of first use; faces are triangulated (quads as the
//! paper splits them, fans beyond); then the checks on the whole mesh (no faces, too many
//! vertices, non-finite values) and the normals.

use std::collections::HashMap;

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::convert::{finish_normals, triangulate, NormalSources};
use super::corners::Corner;
use super::par_dedup::{add_model, grow, Output, Piece, Shared, Sources};
use super::parallel::{Blocks, FaceBlock, ModelRun, Parsed};
use super::parse_chunk::NONE;
use super::plain_dedup::{add_plain_model, PlainShared};
use super::{LoadOptions, ObjError};
use crate::scene::{Material, Mesh};

/// Build the mesh; `materials` are the merged libraries' materials, converted.
pub(super) fn assemble(
    mut parsed: Parsed,
    materials: Vec<Material>,
    name: &str,
    options: &LoadOptions,
) -> Result<Mesh, ObjError> {
    let mut laps = crate::progress::Laps::start("obj assemble");
    let blocks = std::mem::take(&mut parsed.blocks);
    let (mut mesh, groups) = match &blocks {
        Blocks::Plain(blocks) => build(blocks, &parsed, materials, name)?,
        Blocks::Full(blocks) => build(blocks, &parsed, materials, name)?,
    };
    let sources = NormalSources {
        with_normals: parsed.any_normal,
        all_normals: parsed.all_normals,
        with_texcoords: parsed.any_texcoord,
        models_with_faces: parsed.models.iter().filter(|m| !m.faces.is_empty()).count(),
    };
    let non_finite = parsed.non_finite;
    laps.lap("de-duplicated");
    parsed.blocks = blocks;
    parsed.free();
    laps.lap("parse freed");
    check_finite(&mesh, non_finite, name)?;
    laps.lap("checked finite");
    finish_normals(&mut mesh, groups.as_deref(), sources, options);
    laps.lap("normals");
    Ok(mesh)
}

/// The mesh from `blocks` (the faces of `parsed`) before its normals, and the smoothing
/// group of each triangle (None without `s` lines).
fn build<C: Corner>(
    blocks: &[FaceBlock<C>],
    parsed: &Parsed,
    mut materials: Vec<Material>,
    name: &str,
) -> Result<(Mesh, Option<Vec<u32>>), ObjError> {
    let triangle_total: usize = blocks
        .par_iter()
        .map(|b| b.arities.iter().map(|&n| (n as usize).saturating_sub(2)).sum::<usize>())
        .sum();
    if triangle_total == 0 {
        return Err(ObjError::NoFaces { name: name.to_owned() });
    }
    let channels = Channels {
        normals: parsed.any_normal,
        texcoords: parsed.any_texcoord,
        colours: parsed.models.iter().any(|m| m.coloured && !m.faces.is_empty()),
    };
    let mut mesh = empty_mesh(name, parsed.positions.len(), triangle_total, channels);
    // Made on the first model that needs it: its table is a serial fill of 4 bytes a position.
    let mut dedup: Option<Dedup> = None;
    let mut tables = Tables::default();
    let mut cursor = Cursor { blocks, block: 0, face: 0, corner: 0 };
    let mut corners = Vec::new();
    let mut default_material = None;
    for (m, model) in parsed.models.iter().enumerate() {
        let pieces = cursor.take(model.faces.len());
        // A model closed before any colour was read has none of its own.
        let model_channels = Channels { colours: channels.colours && model.coloured, ..channels };
        // A model over several chunks is de-duplicated in parallel, a chunk at a time; one
        // too big for that goes the serial way, which reports it.
        let parallel = pieces.len() > 1 && {
            let last = m + 1 == parsed.models.len();
            add_model_in_parallel(&pieces, &mut tables, parsed, model_channels, &mut mesh, last)
        };
        if !parallel {
            let dedup = dedup.get_or_insert_with(|| Dedup::new(parsed.positions.len()));
            dedup.start_model(m as u32);
            add_model_serially(
                &pieces,
                dedup,
                parsed,
                model_channels,
                &mut corners,
                &mut mesh,
                name,
            )?;
        }
        if channels.colours {
            // Its vertices are white in a mesh with colours, as the oracle makes them.
            grow(&mut mesh.colors, mesh.positions.len(), [255; 4]);
        }
        let material = match model.material {
            Some(i) if i < materials.len() => i as u32,
            _ => *default_material.get_or_insert_with(|| {
                materials.push(Material::default());
                (materials.len() - 1) as u32
            }),
        };
        // Filled on every core: one model can be the whole mesh.
        grow(&mut mesh.triangle_materials, mesh.triangles.len(), material);
    }
    mesh.materials = materials;
    let groups = (!parsed.smoothing.is_empty())
        .then(|| triangle_groups(blocks, &parsed.models, &parsed.smoothing));
    Ok((mesh, groups))
}

/// Which vertex attributes the mesh has besides positions.
#[derive(Clone, Copy)]
struct Channels {
    normals: bool,
    texcoords: bool,
    colours: bool,
}

/// A mesh with room for `triangles` and, nearly always enough, one vertex per position (no
/// regrowing). The triangle arrays, exactly as long as that and never grown, ask for 2 MB
/// pages: a 512th of the page faults of filling them (the vertex arrays may still grow,
/// which would split such pages).
fn empty_mesh(name: &str, positions: usize, triangles: usize, channels: Channels) -> Mesh {
    let room = |wanted: bool| if wanted { positions } else { 0 };
    Mesh {
        name: name.to_owned(),
        positions: Vec::with_capacity(positions),
        normals: Vec::with_capacity(room(channels.normals)),
        texcoords: Vec::with_capacity(room(channels.texcoords)),
        colors: Vec::with_capacity(room(channels.colours)),
        triangles: crate::memory::with_huge_pages(triangles),
        triangle_materials: crate::memory::with_huge_pages(triangles),
        ..Default::default()
    }
}

/// The per-position tables of the parallel de-duplications, made on first use.
#[derive(Default)]
struct Tables {
    plain: Option<PlainShared>,
    full: Option<Shared>,
}

/// Add a model spread over several pieces with `plain_dedup` (no texture coordinates and
/// normals in the mesh) or `par_dedup` (`last`: the last model); false (nothing added)
/// when its vertices would not fit 32-bit indices.
fn add_model_in_parallel<C: Corner>(
    pieces: &[Piece<C>],
    tables: &mut Tables,
    parsed: &Parsed,
    channels: Channels,
    mesh: &mut Mesh,
    last: bool,
) -> bool {
    let sources = Sources {
        positions: &parsed.positions,
        normals: channels.normals.then_some(&parsed.normals[..]),
        texcoords: channels.texcoords.then_some(&parsed.texcoords[..]),
        colors: channels.colours.then_some(&parsed.colors[..]),
    };
    let out = Output {
        positions: &mut mesh.positions,
        normals: &mut mesh.normals,
        texcoords: &mut mesh.texcoords,
        colors: &mut mesh.colors,
        triangles: &mut mesh.triangles,
    };
    let positions = parsed.positions.len();
    if !channels.normals && !channels.texcoords {
        let shared = tables.plain.get_or_insert_with(|| PlainShared::new(positions));
        return add_plain_model(pieces, shared, &sources, out, last);
    }
    let shared = tables.full.get_or_insert_with(|| Shared::new(positions));
    add_model(pieces, shared, &sources, out, last)
}

/// Add a model face by face: each new corner makes a vertex, each face its triangles.
/// `corners` is room for one face's vertex numbers, kept between models.
fn add_model_serially<C: Corner>(
    pieces: &[Piece<C>],
    dedup: &mut Dedup,
    parsed: &Parsed,
    channels: Channels,
    corners: &mut Vec<u32>,
    mesh: &mut Mesh,
    name: &str,
) -> Result<(), ObjError> {
    let base = mesh.positions.len();
    let mut vertex_count = 0usize;
    let faces = pieces.iter().flat_map(|p| {
        let mut rest = p.corners;
        p.arities.iter().map(move |&n| {
            let (face, after) = rest.split_at(n as usize);
            rest = after;
            face
        })
    });
    for face in faces {
        corners.clear();
        for &corner in face {
            let [v, vt, vn] = corner.full();
            let (index, new) = dedup.vertex(v, vt, vn);
            if new {
                vertex_count += 1;
                push_vertex(mesh, parsed, channels, [v, vt, vn]);
            }
            corners.push(index);
        }
        if base + vertex_count > u32::MAX as usize {
            return Err(too_many_vertices(name, base + vertex_count));
        }
        match corners[..] {
            [a, b, c] => mesh.triangles.push([a, b, c].map(|k| k + base as u32)),
            _ => triangulate(corners, &[corners.len() as u32], base as u32, &mut mesh.triangles),
        }
    }
    Ok(())
}

/// The vertex of corner `[v, vt, vn]`: its position and the attributes the mesh has.
#[inline]
fn push_vertex(mesh: &mut Mesh, parsed: &Parsed, channels: Channels, [v, vt, vn]: [u32; 3]) {
    mesh.positions.push(parsed.positions[v as usize]);
    if channels.normals {
        mesh.normals.push(if vn == NONE { Vec3::ZERO } else { parsed.normals[vn as usize] });
    }
    if channels.texcoords {
        mesh.texcoords.push(if vt == NONE { Vec2::ZERO } else { parsed.texcoords[vt as usize] });
    }
    if channels.colours {
        // Faces past the colours were refused in the join; white keeps it safe.
        mesh.colors.push(parsed.colors.get(v as usize).copied().unwrap_or([255; 4]));
    }
}

fn too_many_vertices(name: &str, count: usize) -> ObjError {
    let reason = format!("{count} vertices are more than 32-bit indices can address");
    ObjError::Invalid { name: name.to_owned(), reason }
}

/// The error for a NaN or infinity in the mesh: on the first line of the kinds found
/// (position, normal, texture coordinate) that holds one.
fn check_finite(mesh: &Mesh, first_lines: [Option<usize>; 3], name: &str) -> Result<(), ObjError> {
    let bad = [
        !mesh.positions.par_iter().all(|p| p.is_finite()),
        !mesh.normals.par_iter().all(|n| n.is_finite()),
        !mesh.texcoords.par_iter().all(|t| t.is_finite()),
    ];
    if !bad.contains(&true) {
        return Ok(());
    }
    let whats = ["a vertex position", "a normal", "a texture coordinate"];
    let first = (0..3)
        .filter(|&k| bad[k])
        .filter_map(|k| first_lines[k].map(|line| (line, whats[k])))
        .min();
    Err(match first {
        Some((line, what)) => ObjError::NonFinite { name: name.to_owned(), line, what },
        None => ObjError::Invalid {
            name: name.to_owned(),
            reason: "it contains a coordinate that is not a finite number".to_owned(),
        },
    })
}

/// The smoothing group of every triangle, in file order.
fn triangle_groups<C>(
    blocks: &[FaceBlock<C>],
    models: &[ModelRun],
    smoothing: &[(usize, u32)],
) -> Vec<u32> {
    let faces_total: usize = models.last().map_or(0, |m| m.faces.end);
    let mut groups = Vec::new();
    let mut runs = smoothing.iter().peekable();
    let mut group = 0u32;
    let arities = blocks.iter().flat_map(|b| &b.arities).take(faces_total);
    for (face, &n) in arities.enumerate() {
        while let Some(&(_, g)) = runs.next_if(|(first, _)| *first <= face) {
            group = g;
        }
        groups.extend(std::iter::repeat_n(group, (n as usize).saturating_sub(2)));
    }
    groups
}

/// Walks the blocks' faces in order, handing out each model's faces as pieces (its faces
/// within one block each).
struct Cursor<'b, C> {
    blocks: &'b [FaceBlock<C>],
    block: usize,
    /// Face and corner of `block` where the next model starts.
    face: usize,
    corner: usize,
}

impl<'b, C> Cursor<'b, C> {
    fn take(&mut self, mut faces: usize) -> Vec<Piece<'b, C>> {
        let mut pieces = Vec::new();
        while faces > 0 && self.block < self.blocks.len() {
            let block = &self.blocks[self.block];
            let n = faces.min(block.arities.len() - self.face);
            let arities = &block.arities[self.face..self.face + n];
            // A whole block (the common case: one model) needs no count of its corners.
            let corner_count: usize = if arities.len() == block.arities.len() {
                block.corners.len()
            } else {
                arities.iter().map(|&a| a as usize).sum()
            };
            pieces.push(Piece {
                corners: &block.corners[self.corner..self.corner + corner_count],
                arities,
            });
            (self.face, self.corner, faces) =
                (self.face + n, self.corner + corner_count, faces - n);
            if self.face == block.arities.len() {
                (self.block, self.face, self.corner) = (self.block + 1, 0, 0);
            }
        }
        pieces.retain(|p| !p.arities.is_empty());
        pieces
    }
}

/// tobj's vertex de-duplication within a model, without hashing in the common case: the
/// first vertex made from each position index is found through an array indexed by it;
/// only a position used with other texture coordinates or normals goes to a map.
struct Dedup {
    /// Per position index: the model that last made a vertex from it, and that vertex.
    model_of: Vec<u32>,
    vertex_of: Vec<u32>,
    /// Per vertex of the current model: its (vt, vn).
    attributes: Vec<(u32, u32)>,
    others: HashMap<[u32; 3], u32>,
    model: u32,
}

impl Dedup {
    fn new(positions: usize) -> Self {
        Dedup {
            model_of: vec![u32::MAX; positions],
            vertex_of: vec![0; positions],
            attributes: Vec::new(),
            others: HashMap::new(),
            model: 0,
        }
    }

    fn start_model(&mut self, model: u32) {
        self.model = model;
        self.attributes.clear();
        self.others.clear();
    }

    /// The model's vertex for a corner, and whether it was just made.
    fn vertex(&mut self, v: u32, vt: u32, vn: u32) -> (u32, bool) {
        let p = v as usize;
        if self.model_of[p] != self.model {
            self.model_of[p] = self.model;
            self.vertex_of[p] = self.attributes.len() as u32;
            self.attributes.push((vt, vn));
            return (self.vertex_of[p], true);
        }
        let first = self.vertex_of[p];
        if self.attributes[first as usize] == (vt, vn) {
            return (first, false);
        }
        let next = self.attributes.len() as u32;
        match *self.others.entry([v, vt, vn]).or_insert(next) {
            index if index == next => {
                self.attributes.push((vt, vn));
                (index, true)
            }
            index => (index, false),
        }
    }
}
