//! Area-weighted vertex normals on every core, with the same bits whatever the thread count.
//!
//! A scatter-add of face normals into shared per-vertex sums would race (and its float sums
//! would depend on which thread came first). Instead the triangles are cut into chunks of a
//! fixed size (never derived from the thread count); each chunk sums its faces, in triangle
//! order, into a buffer of its own covering only the span of vertex indices it touches; then
//! every vertex adds up the chunks' sums in chunk order. Files list their triangles roughly
//! in vertex order, so the spans barely overlap and the buffers together are about one more
//! normal array. Where they would be much larger (vertices used far apart, a random order),
//! the plain serial loop runs instead, so memory stays bounded.
//!
//! Rounding: a vertex whose faces fall in two or more chunks gets the sum grouped by chunk,
//! `(a + b) + (c + d)`, where the serial loop adds `((a + b) + c) + d`; the result can differ
//! from the serial one in the last bits (well below 1e-5 after normalising). Meshes of one
//! chunk or less take the serial loop, unchanged.

use glam::Vec3;
use rayon::prelude::*;

/// Triangles per chunk: fixed, so that the grouping of the sums (and so every bit of the
/// result) does not depend on the thread count.
const CHUNK_TRIANGLES: usize = 1 << 16;
/// Vertices per block of the merge and normalise pass.
const MERGE_VERTICES: usize = 1 << 14;
/// The chunks' buffers may hold at most this many vertex sums per vertex of the mesh (plus
/// one chunk's worth); beyond, the serial loop runs.
const MAX_SPAN_PER_VERTEX: usize = 2;

/// The area-weighted normal of every vertex (the sum of the cross products of the faces that
/// use it, whose length is twice their area, normalised), `Vec3::Y` for a vertex no face (or
/// only degenerate faces) uses. Every index in `triangles` must be below `positions.len()`.
pub(crate) fn area_weighted_normals(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Vec3> {
    let face = |t: &[u32; 3]| {
        let [a, b, c] = t.map(|k| positions[k as usize]);
        // The cross product's length is twice the area: the weighting comes for free.
        (b - a).cross(c - a)
    };
    if triangles.len() <= CHUNK_TRIANGLES {
        return serial(positions, triangles, face);
    }
    // Each chunk's span of vertex indices, [lo, hi).
    let spans: Vec<(usize, usize)> = triangles
        .par_chunks(CHUNK_TRIANGLES)
        .map(|chunk| {
            chunk
                .iter()
                .flatten()
                .fold((usize::MAX, 0), |(lo, hi), &k| (lo.min(k as usize), hi.max(k as usize + 1)))
        })
        .collect();
    let total: usize = spans.iter().map(|(lo, hi)| hi - lo).sum();
    if total > MAX_SPAN_PER_VERTEX * positions.len() + CHUNK_TRIANGLES {
        return serial(positions, triangles, face);
    }
    let sums: Vec<Vec<Vec3>> = triangles
        .par_chunks(CHUNK_TRIANGLES)
        .zip(&spans)
        .map(|(chunk, &(lo, hi))| {
            let mut local = vec![Vec3::ZERO; hi - lo];
            for t in chunk {
                let f = face(t);
                for &k in t {
                    local[k as usize - lo] += f;
                }
            }
            local
        })
        .collect();
    let mut normals = vec![Vec3::ZERO; positions.len()];
    normals.par_chunks_mut(MERGE_VERTICES).enumerate().for_each(|(block, out)| {
        let start = block * MERGE_VERTICES;
        let end = start + out.len();
        for (sum, &(lo, hi)) in sums.iter().zip(&spans) {
            // Chunk order: the same grouping of the additions on any thread count.
            let (from, to) = (lo.max(start), hi.min(end));
            for v in from..to {
                out[v - start] += sum[v - lo];
            }
        }
        out.iter_mut().for_each(|n| *n = n.normalize_or(Vec3::Y));
    });
    normals
}

/// The one-thread loop: every face added to its corners in triangle order.
fn serial(
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    face: impl Fn(&[u32; 3]) -> Vec3,
) -> Vec<Vec3> {
    let mut n = vec![Vec3::ZERO; positions.len()];
    for t in triangles {
        let f = face(t);
        for &k in t {
            n[k as usize] += f;
        }
    }
    n.into_iter().map(|v| v.normalize_or(Vec3::Y)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grid of `w` x `h` quads on a bumpy surface, in row order (as files list them).
    fn grid(w: u32, h: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let positions = (0..=h)
            .flat_map(|y| {
                (0..=w).map(move |x| {
                    Vec3::new(x as f32, ((x * 7 + y * 13) % 5) as f32 * 0.3, y as f32 * 1.1)
                })
            })
            .collect();
        let v = |x: u32, y: u32| y * (w + 1) + x;
        let triangles = (0..h)
            .flat_map(|y| {
                (0..w).flat_map(move |x| {
                    [
                        [v(x, y), v(x + 1, y), v(x, y + 1)],
                        [v(x + 1, y), v(x + 1, y + 1), v(x, y + 1)],
                    ]
                })
            })
            .collect();
        (positions, triangles)
    }

    #[test]
    fn chunked_normals_match_the_serial_loop_and_do_not_depend_on_the_thread_count() {
        // ~6 chunks of triangles, plus one isolated vertex at the end.
        let (mut positions, triangles) = grid(700, 280);
        positions.push(Vec3::new(1e3, 0.0, 0.0));
        assert!(triangles.len() > 5 * CHUNK_TRIANGLES);
        let face = |t: &[u32; 3]| {
            let [a, b, c] = t.map(|k| positions[k as usize]);
            (b - a).cross(c - a)
        };
        let reference = serial(&positions, &triangles, face);
        let in_pool = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| area_weighted_normals(&positions, &triangles))
        };
        let one = in_pool(1);
        for (got, want) in one.iter().zip(&reference) {
            assert!((*got - *want).abs().max_element() < 1e-5, "{got} vs {want}");
        }
        assert_eq!(*one.last().unwrap(), Vec3::Y);
        let bits =
            |n: &[Vec3]| n.iter().flat_map(|v| v.to_array().map(f32::to_bits)).collect::<Vec<_>>();
        for threads in [2, 3, 8] {
            assert_eq!(bits(&in_pool(threads)), bits(&one), "{threads} threads");
        }
    }

    #[test]
    fn vertices_used_far_apart_take_the_serial_loop_with_the_same_result() {
        // Every triangle uses vertex 0 and two far ones: the spans would cover the mesh per chunk.
        let (positions, mut triangles) = grid(700, 280);
        let last = positions.len() as u32 - 1;
        for (i, t) in triangles.iter_mut().enumerate() {
            if i % 2 == 0 {
                t[0] = if i % 4 == 0 { 0 } else { last };
            }
        }
        let face = |t: &[u32; 3]| {
            let [a, b, c] = t.map(|k| positions[k as usize]);
            (b - a).cross(c - a)
        };
        assert_eq!(
            area_weighted_normals(&positions, &triangles),
            serial(&positions, &triangles, face)
        );
    }
}
