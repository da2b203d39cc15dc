//! From the joined parse to one `Mesh`, as the loader has always built it from tobj's
//! models: per model (a run of faces with one material) every distinct corner (v, vt, vn)
//! becomes a vertex, numbered in order of first use; faces are triangulated (quads as the
//! paper splits them, fans beyond); then the checks on the whole mesh (no faces, too many
//! vertices, non-finite values) and the normals.

use std::collections::HashMap;

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::convert::{finish_normals, triangulate, NormalSources};
use super::par_dedup::{add_model, grow, Output, Piece, Shared, Sources};
use super::parallel::{FaceBlock, ModelRun, Parsed};
use super::parse_chunk::NONE;
use super::{LoadOptions, ObjError};
use crate::scene::{Material, Mesh};

/// Build the mesh; `materials` are the merged libraries' materials, converted.
pub(super) fn assemble(
    parsed: Parsed,
    mut materials: Vec<Material>,
    name: &str,
    options: &LoadOptions,
) -> Result<Mesh, ObjError> {
    let triangle_total: usize = parsed
        .blocks
        .par_iter()
        .map(|b| b.arities.iter().map(|&n| (n as usize).saturating_sub(2)).sum::<usize>())
        .sum();
    if triangle_total == 0 {
        return Err(ObjError::NoFaces { name: name.to_owned() });
    }
    let (with_normals, with_texcoords) = (parsed.any_normal, parsed.any_texcoord);
    let with_colours = !parsed.colors.is_empty();
    // Nearly always each position makes one vertex: room for that many, no regrowing.
    let vertices = parsed.positions.len();
    let mut mesh = Mesh {
        name: name.to_owned(),
        positions: Vec::with_capacity(vertices),
        normals: Vec::with_capacity(if with_normals { vertices } else { 0 }),
        texcoords: Vec::with_capacity(if with_texcoords { vertices } else { 0 }),
        colors: Vec::with_capacity(if with_colours { vertices } else { 0 }),
        triangles: Vec::with_capacity(triangle_total),
        triangle_materials: Vec::with_capacity(triangle_total),
        ..Default::default()
    };
    // Made on the first model that needs it: its table is a serial fill of 4 bytes a position.
    let mut dedup: Option<Dedup> = None;
    let mut shared = None;
    let mut cursor = Cursor { blocks: &parsed.blocks, block: 0, face: 0, corner: 0 };
    let mut corners = Vec::new();
    let mut default_material = None;
    for (m, model) in parsed.models.iter().enumerate() {
        let base = mesh.positions.len();
        let pieces = cursor.take(model.faces.len());
        // A model over several chunks is de-duplicated in parallel, a chunk at a time.
        let parallel = pieces.len() > 1 && {
            let shared = shared.get_or_insert_with(|| Shared::new(parsed.positions.len()));
            let sources = Sources {
                positions: &parsed.positions,
                normals: with_normals.then_some(&parsed.normals[..]),
                texcoords: with_texcoords.then_some(&parsed.texcoords[..]),
                colors: with_colours.then_some(&parsed.colors[..]),
            };
            let out = Output {
                positions: &mut mesh.positions,
                normals: &mut mesh.normals,
                texcoords: &mut mesh.texcoords,
                colors: &mut mesh.colors,
                triangles: &mut mesh.triangles,
            };
            add_model(&pieces, shared, &sources, out)
        };
        let mut serial = (!parallel).then(|| {
            let dedup = dedup.get_or_insert_with(|| Dedup::new(parsed.positions.len()));
            dedup.start_model(m as u32);
            dedup
        });
        let mut vertex_count = 0usize;
        let faces = pieces.iter().filter(|_| !parallel).flat_map(|p| {
            let mut rest = p.corners;
            p.arities.iter().map(move |&n| {
                let (face, after) = rest.split_at(n as usize);
                rest = after;
                face
            })
        });
        for face in faces {
            let Some(dedup) = serial.as_deref_mut() else { break };
            corners.clear();
            for &[v, vt, vn] in face {
                let (index, new) = dedup.vertex(v, vt, vn);
                if new {
                    vertex_count += 1;
                    mesh.positions.push(parsed.positions[v as usize]);
                    if with_normals {
                        mesh.normals.push(if vn == NONE {
                            Vec3::ZERO
                        } else {
                            parsed.normals[vn as usize]
                        });
                    }
                    if with_texcoords {
                        mesh.texcoords.push(if vt == NONE {
                            Vec2::ZERO
                        } else {
                            parsed.texcoords[vt as usize]
                        });
                    }
                    if with_colours {
                        // Faces past the colours were refused in the join; white keeps it safe.
                        mesh.colors
                            .push(parsed.colors.get(v as usize).copied().unwrap_or([255; 4]));
                    }
                }
                corners.push(index);
            }
            if base + vertex_count > u32::MAX as usize {
                return Err(too_many_vertices(name, base + vertex_count));
            }
            match corners[..] {
                [a, b, c] => mesh.triangles.push([a, b, c].map(|k| k + base as u32)),
                _ => {
                    triangulate(&corners, &[corners.len() as u32], base as u32, &mut mesh.triangles)
                }
            }
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
    let sources = NormalSources {
        with_normals,
        all_normals: parsed.all_normals,
        with_texcoords,
        models_with_faces: parsed.models.iter().filter(|m| !m.faces.is_empty()).count(),
    };
    let groups = (!parsed.smoothing.is_empty())
        .then(|| triangle_groups(&parsed.blocks, &parsed.models, &parsed.smoothing));
    let non_finite = parsed.non_finite;
    super::free_in_background(parsed);
    check_finite(&mesh, non_finite, name)?;
    finish_normals(&mut mesh, groups.as_deref(), sources, options);
    Ok(mesh)
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
fn triangle_groups(
    blocks: &[FaceBlock],
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
struct Cursor<'b> {
    blocks: &'b [FaceBlock],
    block: usize,
    /// Face and corner of `block` where the next model starts.
    face: usize,
    corner: usize,
}

impl<'b> Cursor<'b> {
    fn take(&mut self, mut faces: usize) -> Vec<Piece<'b>> {
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
