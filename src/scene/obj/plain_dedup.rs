//! tobj's vertex de-duplication for a model spread over several chunks when no corner has
//! a texture coordinate or normal (`f 1 2 3`): then a vertex is a position, and the
//! model's vertices are its positions in order of first use. Three passes over the
//! corners, in parallel, with the same result as the serial walk:
//!
//! 1. Every corner offers its piece's number for its position; the smallest wins
//!    (`fetch_min`): the piece of the position's first use.
//! 2. That piece numbers the positions it uses first, in order of first use (its own
//!    vertex numbers, from 0).
//! 3. Prefix sums of those counts give each piece its first vertex; each corner's vertex
//!    is its winning piece's first vertex plus the number given there, and each piece
//!    writes its own vertices and its triangles.
//!
//! `par_dedup.rs` does the general case (with texture coordinates and normals), with four
//! passes over corners three times as large.

use std::sync::atomic::{AtomicU64, Ordering::Relaxed};

use rayon::prelude::*;

use super::convert::triangulate;
use super::corners::Corner;
use super::par_dedup::{grow_outputs, take_front, Output, Piece, Sources};

/// Not yet numbered (the low half of a mark).
const UNNUMBERED: u64 = u32::MAX as u64;

/// Per position, (piece of its first use) << 32 | (its number within that piece), or
/// `u64::MAX` when unused. Allocated once per load, reset between models.
pub(super) struct PlainShared {
    marks: Vec<AtomicU64>,
}

impl PlainShared {
    pub(super) fn new(positions: usize) -> Self {
        // Filled on every core, on 2 MB pages: at 10M triangles this is ~40 MB of fresh
        // memory (`par_extend` of an exact length fills the room reserved, never moves it).
        let mut marks = crate::memory::with_huge_pages(positions);
        marks.par_extend((0..positions).into_par_iter().map(|_| AtomicU64::new(u64::MAX)));
        PlainShared { marks }
    }

    #[inline(always)]
    fn mark(&self, c: impl Corner) -> &AtomicU64 {
        &self.marks[c.position() as usize]
    }
}

/// Add one model (its pieces in order, no corner with a texture coordinate or normal) to
/// `out`; false (nothing added) when its vertices would not fit 32-bit indices, for the
/// serial path to report. `last`: no model follows that uses `shared`, which then need not
/// be reset.
pub(super) fn add_plain_model<C: Corner>(
    pieces: &[Piece<C>],
    shared: &PlainShared,
    sources: &Sources,
    mut out: Output,
    last: bool,
) -> bool {
    // More pieces than marks can name: the serial path.
    if pieces.len() >= u32::MAX as usize {
        return false;
    }
    let mut laps = crate::progress::Laps::start("obj plain de-duplication");
    // 1. The first piece of each position.
    pieces.par_iter().enumerate().for_each(|(p, piece)| {
        let mark = (p as u64) << 32 | UNNUMBERED;
        for &c in piece.corners {
            let m = shared.mark(c);
            // A plain load first: most corners meet a position already marked, and
            // `fetch_min` is a compare-and-swap loop on x86.
            if m.load(Relaxed) > mark {
                m.fetch_min(mark, Relaxed);
            }
        }
    });
    laps.lap("first uses");
    // 2. Each piece numbers the positions it uses first (no other piece writes those).
    let made: Vec<u64> = pieces
        .par_iter()
        .enumerate()
        .map(|(p, piece)| {
            let (mark, mut count) = ((p as u64) << 32 | UNNUMBERED, 0u64);
            for &c in piece.corners {
                let m = shared.mark(c);
                if m.load(Relaxed) == mark {
                    m.store((p as u64) << 32 | count, Relaxed);
                    count += 1;
                }
            }
            count
        })
        .collect();
    laps.lap("numbered");
    // 3. Vertices and triangles.
    let base = out.positions.len();
    let total: u64 = made.iter().sum();
    if base as u64 + total > u64::from(u32::MAX) {
        return false;
    }
    let firsts: Vec<u32> = made
        .iter()
        .scan(base as u32, |at, &n| {
            let first = *at;
            *at += n as u32;
            Some(first)
        })
        .collect();
    let triangles: Vec<usize> = pieces
        .par_iter()
        .map(|p| p.arities.iter().map(|&n| (n as usize).saturating_sub(2)).sum())
        .collect();
    let tri_base = out.triangles.len();
    grow_outputs(
        &mut out,
        sources,
        base + total as usize,
        tri_base + triangles.iter().sum::<usize>(),
    );
    laps.lap("outputs grown");
    write(pieces, shared, sources, &mut out, base, tri_base, &made, &firsts, &triangles);
    laps.lap("written");
    if !last {
        pieces.par_iter().for_each(|p| {
            p.corners.iter().for_each(|&c| shared.mark(c).store(u64::MAX, Relaxed));
        });
    }
    true
}

/// Pass 3: each piece writes the vertices it numbered (`made`, from `firsts` of the whole
/// mesh on, in `out` from `base`) and its triangles (`triangles`, from `tri_base`).
#[allow(clippy::too_many_arguments)]
fn write<C: Corner>(
    pieces: &[Piece<C>],
    shared: &PlainShared,
    sources: &Sources,
    out: &mut Output,
    base: usize,
    tri_base: usize,
    made: &[u64],
    firsts: &[u32],
    triangles: &[usize],
) {
    let mut positions = &mut out.positions[base..];
    let mut colors = if sources.colors.is_some() { &mut out.colors[base..] } else { &mut [][..] };
    let mut tris = &mut out.triangles[tri_base..];
    let mut jobs = Vec::with_capacity(pieces.len());
    for (p, (&n, &t)) in pieces.iter().zip(made.iter().zip(triangles)) {
        let pos = take_front(&mut positions, n as usize, true);
        let col = take_front(&mut colors, n as usize, sources.colors.is_some());
        let (mine, after) = std::mem::take(&mut tris).split_at_mut(t);
        tris = after;
        jobs.push((p, pos, col, mine));
    }
    jobs.into_par_iter().enumerate().for_each(|(p, (piece, pos, col, mine))| {
        let mut next = 0u32;
        // The corner's vertex in the mesh; the piece's own first uses write their vertex.
        let mut vertex = |c: C| {
            let mark = shared.mark(c).load(Relaxed);
            let (q, number) = ((mark >> 32) as usize, mark as u32);
            if q == p && number == next {
                let v = c.position() as usize;
                if let (Some(slot), Some(&position)) =
                    (pos.get_mut(next as usize), sources.positions.get(v))
                {
                    *slot = position;
                }
                if let (Some(colors), Some(slot)) = (sources.colors, col.get_mut(next as usize)) {
                    *slot = colors.get(v).copied().unwrap_or([255; 4]);
                }
                next += 1;
            }
            firsts.get(q).map_or(0, |first| first + number)
        };
        let mut mine = mine.iter_mut();
        let (mut corner, mut local, mut made) = (0usize, Vec::new(), Vec::new());
        for &n in piece.arities {
            let face = &piece.corners[corner..corner + n as usize];
            corner += n as usize;
            // Triangles (nearly all faces) straight into place.
            if let &[a, b, c] = face {
                let t = [vertex(a), vertex(b), vertex(c)];
                if let Some(slot) = mine.next() {
                    *slot = t;
                }
                continue;
            }
            local.clear();
            local.extend(face.iter().map(|&c| vertex(c)));
            made.clear();
            triangulate(&local, &[n], 0, &mut made);
            // `made` first: a zip that ends on it takes nothing more from `mine`.
            for (m, t) in made.iter().zip(&mut mine) {
                *t = *m;
            }
        }
    });
}
