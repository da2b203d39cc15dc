//! tobj's vertex de-duplication for a model spread over several chunks, in parallel and
//! with the same result as the serial walk: every distinct corner (v, vt, vn) becomes a
//! vertex, numbered in order of its first corner.
//!
//! 1. Every corner offers its (model-relative) index for its position; the smallest wins
//!    (`fetch_min`): that corner is the first use of the position and makes a vertex.
//! 2. The winner records its (vt, vn). A later corner of the same position with the same
//!    (vt, vn) reuses that vertex; one with others ("other" corners, rare: texture seams,
//!    normal creases) is settled by a serial pass over just those, with a map.
//! 3. Each chunk counts the vertices it makes; prefix sums give it its range of vertex
//!    numbers and triangles, which it fills on its own.
//!
//! Without texture coordinates and normals `plain_dedup.rs` does the same in fewer passes.

use std::collections::{HashMap, HashSet};
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering::Relaxed};

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::convert::triangulate;
use super::corners::Corner;
use super::parse_chunk::NONE;

/// A model's faces within one chunk.
#[derive(Clone, Copy, Debug)]
pub(super) struct Piece<'b, C> {
    pub(super) corners: &'b [C],
    pub(super) arities: &'b [u32],
}

/// Per position: the first corner that uses it (model-relative), that corner's (vt, vn),
/// and the vertex it made. Allocated once per load, reset between models.
pub(super) struct Shared {
    first: Vec<AtomicU32>,
    key: Vec<AtomicU64>,
    vertex: Vec<AtomicU32>,
}

impl Shared {
    pub(super) fn new(positions: usize) -> Self {
        // Filled on every core: at 10M triangles these are ~80 MB of fresh pages.
        let atomic32 = |n| (0..n).into_par_iter().map(|_| AtomicU32::new(u32::MAX)).collect();
        Shared {
            first: atomic32(positions),
            key: (0..positions).into_par_iter().map(|_| AtomicU64::new(0)).collect(),
            vertex: atomic32(positions),
        }
    }
}

/// The element arrays a model's vertices are made from.
pub(super) struct Sources<'p> {
    pub(super) positions: &'p [Vec3],
    /// Empty when no vertex of the mesh has a normal (then none is written).
    pub(super) normals: Option<&'p [Vec3]>,
    pub(super) texcoords: Option<&'p [Vec2]>,
    /// Per position, when the file has colours.
    pub(super) colors: Option<&'p [[u8; 4]]>,
}

/// What a model adds to the mesh.
pub(super) struct Output<'m> {
    pub(super) positions: &'m mut Vec<Vec3>,
    pub(super) normals: &'m mut Vec<Vec3>,
    pub(super) texcoords: &'m mut Vec<Vec2>,
    pub(super) colors: &'m mut Vec<[u8; 4]>,
    pub(super) triangles: &'m mut Vec<[u32; 3]>,
}

fn pack(vt: u32, vn: u32) -> u64 {
    (u64::from(vt) << 32) | u64::from(vn)
}

/// Add one model (its pieces in order) to `out`; false (nothing added) when its vertices
/// would not fit 32-bit indices, for the serial path to report.
///
/// `last`: no model follows that uses `shared`, which then need not be reset.
pub(super) fn add_model<C: Corner>(
    pieces: &[Piece<C>],
    shared: &Shared,
    sources: &Sources,
    mut out: Output,
    last: bool,
) -> bool {
    let starts: Vec<u32> = pieces
        .iter()
        .scan(0u32, |at, p| {
            let start = *at;
            *at += p.corners.len() as u32;
            Some(start)
        })
        .collect();
    let model = Model { pieces, starts: &starts, shared };
    // 1 and 2, in this order: whether a corner is like the first needs the first settled.
    model.mark_first_corners();
    model.record_first_keys();
    let makers = model.other_makers(&model.other_corners());
    // 3. Vertex numbers and triangles per piece.
    let made = model.vertices_made(&makers);
    let base = out.positions.len();
    let total: usize = made.iter().sum();
    if base + total > u32::MAX as usize {
        return false;
    }
    let triangles: Vec<usize> = pieces
        .par_iter()
        .map(|p| p.arities.iter().map(|&n| (n as usize).saturating_sub(2)).sum())
        .collect();
    let tri_base = out.triangles.len();
    grow_outputs(&mut out, sources, base + total, tri_base + triangles.iter().sum::<usize>());
    let other_vertices = model.write_vertices(sources, &mut out, base, &made, &makers);
    let tri_out = &mut out.triangles[tri_base..];
    model.write_triangles(tri_out, &triangles, &other_vertices, base as u32);
    if !last {
        model.reset_first_corners();
    }
    true
}

/// One model's pieces, where each piece's corners start (model-relative), and the
/// per-position marks they share.
struct Model<'a, 'b, C> {
    pieces: &'a [Piece<'b, C>],
    starts: &'a [u32],
    shared: &'a Shared,
}

impl<C: Corner> Model<'_, '_, C> {
    /// The first corner (model-relative) that uses `c`'s position.
    #[inline]
    fn first(&self, c: C) -> u32 {
        self.shared.first[c.position() as usize].load(Relaxed)
    }

    /// Corner `k` is neither the first of its position nor like it (the same vt, vn).
    #[inline]
    fn is_other(&self, c: C, k: u32) -> bool {
        let [v, vt, vn] = c.full();
        self.first(c) != k && self.shared.key[v as usize].load(Relaxed) != pack(vt, vn)
    }

    /// 1. The first corner of each position.
    fn mark_first_corners(&self) {
        self.pieces.par_iter().zip(self.starts).for_each(|(p, &start)| {
            for (i, c) in p.corners.iter().enumerate() {
                let (first, k) = (&self.shared.first[c.position() as usize], start + i as u32);
                // A plain load first: most corners meet a position already marked, and
                // `fetch_min` is a compare-and-swap loop on x86.
                if first.load(Relaxed) > k {
                    first.fetch_min(k, Relaxed);
                }
            }
        });
    }

    /// 2. Its (vt, vn).
    fn record_first_keys(&self) {
        self.pieces.par_iter().zip(self.starts).for_each(|(p, &start)| {
            for (i, &c) in p.corners.iter().enumerate() {
                if self.first(c) == start + i as u32 {
                    let [v, vt, vn] = c.full();
                    self.shared.key[v as usize].store(pack(vt, vn), Relaxed);
                }
            }
        });
    }

    /// Per piece, the corners that are neither first nor like it.
    fn other_corners(&self) -> Vec<Vec<u32>> {
        self.pieces
            .par_iter()
            .zip(self.starts)
            .map(|(p, &start)| {
                (0..p.corners.len() as u32)
                    .filter(|&i| self.is_other(p.corners[i as usize], start + i))
                    .map(|i| start + i)
                    .collect()
            })
            .collect()
    }

    /// The first corner of each distinct "other" corner: it makes a vertex too.
    fn other_makers(&self, others: &[Vec<u32>]) -> HashSet<u32> {
        let mut seen = HashSet::new();
        self.pieces
            .iter()
            .zip(self.starts)
            .zip(others)
            .flat_map(|((p, &start), list)| {
                list.iter().map(move |&k| (k, p.corners[(k - start) as usize].full()))
            })
            .filter(|(_, c)| seen.insert(*c))
            .map(|(k, _)| k)
            .collect()
    }

    /// How many vertices each piece makes.
    fn vertices_made(&self, makers: &HashSet<u32>) -> Vec<usize> {
        let makes = |c: C, k: u32| self.first(c) == k || makers.contains(&k);
        self.pieces
            .par_iter()
            .zip(self.starts)
            .map(|(p, &start)| {
                let corners = p.corners.iter().enumerate();
                corners.filter(|&(i, &c)| makes(c, start + i as u32)).count()
            })
            .collect()
    }

    /// Vertices: each piece writes the ones it makes, in order, and records their numbers
    /// (a first corner's in `shared.vertex`, an other corner's in the map returned).
    fn write_vertices(
        &self,
        sources: &Sources,
        out: &mut Output,
        base: usize,
        made: &[usize],
        makers: &HashSet<u32>,
    ) -> HashMap<[u32; 3], u32> {
        let mut positions = &mut out.positions[base..];
        let mut normals =
            if sources.normals.is_some() { &mut out.normals[base..] } else { &mut [][..] };
        let mut texcoords =
            if sources.texcoords.is_some() { &mut out.texcoords[base..] } else { &mut [][..] };
        let mut colors =
            if sources.colors.is_some() { &mut out.colors[base..] } else { &mut [][..] };
        let mut jobs = Vec::with_capacity(self.pieces.len());
        let mut first_vertex = 0u32;
        for ((p, &start), &n) in self.pieces.iter().zip(self.starts).zip(made) {
            let pos = take_front(&mut positions, n, true);
            let nor = take_front(&mut normals, n, sources.normals.is_some());
            let tex = take_front(&mut texcoords, n, sources.texcoords.is_some());
            let col = take_front(&mut colors, n, sources.colors.is_some());
            jobs.push((p, start, first_vertex, pos, nor, tex, col));
            first_vertex += n as u32;
        }
        let made_others: Vec<Vec<([u32; 3], u32)>> = jobs
            .into_par_iter()
            .map(|(p, start, mut next, pos, nor, tex, col)| {
                let mut mine = Vec::new();
                let mut slot = 0;
                for (i, &corner) in p.corners.iter().enumerate() {
                    let (k, c) = (start + i as u32, corner.full());
                    let primary = self.first(corner) == k;
                    if !primary && !makers.contains(&k) {
                        continue;
                    }
                    pos[slot] = sources.positions[c[0] as usize];
                    if let Some(normals) = sources.normals {
                        nor[slot] = if c[2] == NONE { Vec3::ZERO } else { normals[c[2] as usize] };
                    }
                    if let Some(texcoords) = sources.texcoords {
                        tex[slot] =
                            if c[1] == NONE { Vec2::ZERO } else { texcoords[c[1] as usize] };
                    }
                    if let Some(colors) = sources.colors {
                        col[slot] = colors.get(c[0] as usize).copied().unwrap_or([255; 4]);
                    }
                    if primary {
                        self.shared.vertex[c[0] as usize].store(next, Relaxed);
                    } else {
                        mine.push((c, next));
                    }
                    slot += 1;
                    next += 1;
                }
                mine
            })
            .collect();
        made_others.into_iter().flatten().collect()
    }

    /// Triangles: each piece its range of `out` (`triangles` per piece), corners looked up.
    fn write_triangles(
        &self,
        out: &mut [[u32; 3]],
        triangles: &[usize],
        other_vertices: &HashMap<[u32; 3], u32>,
        base: u32,
    ) {
        let mut rest = out;
        let mut jobs = Vec::with_capacity(self.pieces.len());
        for ((p, &start), &n) in self.pieces.iter().zip(self.starts).zip(triangles) {
            let (mine, after) = std::mem::take(&mut rest).split_at_mut(n);
            rest = after;
            jobs.push((p, start, mine));
        }
        jobs.into_par_iter().for_each(|(p, start, mine)| {
            let vertex = |c: &C, k: u32| {
                if self.is_other(*c, k) {
                    other_vertices.get(&c.full()).copied().unwrap_or_default()
                } else {
                    self.shared.vertex[c.position() as usize].load(Relaxed)
                }
            };
            let mut mine = mine.iter_mut();
            let (mut corner, mut local, mut made) = (0usize, Vec::new(), Vec::new());
            for &n in p.arities {
                let face = &p.corners[corner..corner + n as usize];
                let k = start + corner as u32;
                corner += n as usize;
                // Triangles (nearly all faces) straight into place.
                if let [a, b, c] = face {
                    if let Some(t) = mine.next() {
                        *t = [vertex(a, k), vertex(b, k + 1), vertex(c, k + 2)].map(|v| v + base);
                    }
                    continue;
                }
                local.clear();
                local.extend(face.iter().zip(k..).map(|(c, k)| vertex(c, k)));
                made.clear();
                triangulate(&local, &[n], base, &mut made);
                // `made` first: a zip that ends on it takes nothing more from `mine`.
                for (m, t) in made.iter().zip(&mut mine) {
                    *t = *m;
                }
            }
        });
    }

    /// Reset the first-use marks of the model's positions for the next model.
    fn reset_first_corners(&self) {
        self.pieces.par_iter().for_each(|p| {
            p.corners
                .iter()
                .for_each(|c| self.shared.first[c.position() as usize].store(u32::MAX, Relaxed))
        });
    }
}

/// Grow the outputs the model writes to `vertices` and `triangles` elements, on every core
/// (`resize` writes, and faults in, the new pages on one thread).
pub(super) fn grow_outputs(out: &mut Output, sources: &Sources, vertices: usize, triangles: usize) {
    grow(out.positions, vertices, Vec3::ZERO);
    if sources.normals.is_some() {
        grow(out.normals, vertices, Vec3::ZERO);
    }
    if sources.texcoords.is_some() {
        grow(out.texcoords, vertices, Vec2::ZERO);
    }
    if sources.colors.is_some() {
        grow(out.colors, vertices, [255; 4]);
    }
    grow(out.triangles, triangles, [0; 3]);
}

/// `v.resize(len, value)` with the new elements written in parallel.
pub(super) fn grow<T: Copy + Send + Sync>(v: &mut Vec<T>, len: usize, value: T) {
    if len > v.len() {
        let more = len - v.len();
        v.par_extend(rayon::iter::repeat_n(value, more));
    }
}

/// The first `n` elements of `s` (which keeps the rest), or none when `wanted` is false.
pub(super) fn take_front<'a, T>(s: &mut &'a mut [T], n: usize, wanted: bool) -> &'a mut [T] {
    if !wanted {
        return &mut [];
    }
    let (front, rest) = std::mem::take(s).split_at_mut(n);
    *s = rest;
    front
}
