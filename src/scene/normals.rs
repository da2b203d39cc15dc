//! Area-weighted vertex normals on every core, with the same bits whatever the thread count.
//!
//! A scatter-add of face normals into shared per-vertex sums would race (and its float sums
//! would depend on which thread came first). Instead the triangles are cut into chunks of a
//! fixed size (never derived from the thread count), and the vertices into blocks of a fixed
//! size; each chunk sums its faces, in triangle order, into buffers of its own for only the
//! blocks of vertices it touches; then every block adds up the chunks' sums in chunk order.
//! Files list their triangles roughly in vertex order, so a chunk touches a few blocks, and
//! the buffers together are about one more normal array; a chunk that also touches vertices
//! far away (a torus's last ring closing on its first) costs a few blocks more, not a span
//! over the whole mesh. Where the buffers would be much larger (vertices used far apart all
//! over, a random order), the plain serial loop runs instead, so memory stays bounded.
//!
//! Rounding: a vertex whose faces fall in two or more chunks gets the sum grouped by chunk,
//! `(a + b) + (c + d)`, where the serial loop adds `((a + b) + c) + d`; the result can differ
//! from the serial one in the last bits (well below 1e-5 after normalising; up to about 1e-4
//! for a vertex shared by 100,000 faces). Meshes of one chunk or less take the serial loop,
//! unchanged.

use glam::Vec3;
use rayon::prelude::*;

/// Triangles per chunk: fixed, so that the grouping of the sums (and so every bit of the
/// result) does not depend on the thread count.
const CHUNK_TRIANGLES: usize = 1 << 16;
/// Vertices per block: the unit of a chunk's buffers and of the merge pass (48 KB of sums).
const BLOCK_VERTICES: usize = 1 << 12;
/// The chunks' buffers may hold at most this many blocks per block of the mesh (plus one
/// per chunk); beyond, the serial loop runs.
const MAX_BUFFERS_PER_BLOCK: usize = 2;

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
    let blocks = positions.len().div_ceil(BLOCK_VERTICES);
    // Each chunk's blocks, in increasing order.
    let touched: Vec<Vec<u32>> =
        triangles.par_chunks(CHUNK_TRIANGLES).map(|chunk| touched_blocks(chunk, blocks)).collect();
    let buffers: usize = touched.iter().map(Vec::len).sum();
    if buffers > MAX_BUFFERS_PER_BLOCK * blocks + touched.len() {
        log::debug!("normals on one thread: the chunks touch {buffers} blocks of {blocks}");
        return serial(positions, triangles, face);
    }
    // All the chunks' buffers in one array: one allocation faulted in on every core, where
    // a buffer per chunk meant an allocation and a free a chunk, queueing the threads on the
    // process's memory map.
    let mut sums = crate::memory::filled(buffers * BLOCK_VERTICES, Vec3::ZERO);
    let mut rest = sums.as_mut_slice();
    let mut jobs = Vec::with_capacity(touched.len());
    for (chunk, here) in triangles.chunks(CHUNK_TRIANGLES).zip(&touched) {
        let (mine, after) = std::mem::take(&mut rest).split_at_mut(here.len() * BLOCK_VERTICES);
        rest = after;
        jobs.push((chunk, here, mine));
    }
    jobs.into_par_iter().for_each_init(
        || vec![u32::MAX; blocks],
        |slot_of, (chunk, here, local)| {
            for (slot, &b) in here.iter().enumerate() {
                slot_of[b as usize] = slot as u32;
            }
            for t in chunk {
                let f = face(t);
                for &k in t {
                    let k = k as usize;
                    let slot = slot_of[k / BLOCK_VERTICES] as usize;
                    local[slot * BLOCK_VERTICES + k % BLOCK_VERTICES] += f;
                }
            }
        },
    );
    // Per block, the chunks' buffers that hold its sums, in chunk order.
    let mut users: Vec<Vec<&[Vec3]>> = vec![Vec::new(); blocks];
    for (&b, buffer) in touched.iter().flatten().zip(sums.chunks_exact(BLOCK_VERTICES)) {
        users[b as usize].push(buffer);
    }
    let mut normals = crate::memory::filled(positions.len(), Vec3::ZERO);
    normals.par_chunks_mut(BLOCK_VERTICES).zip(&users).for_each(|(out, buffers)| {
        // Chunk order: the same grouping of the additions on any thread count.
        for buffer in buffers {
            out.iter_mut().zip(*buffer).for_each(|(n, s)| *n += *s);
        }
        out.iter_mut().for_each(|n| *n = n.normalize_or(Vec3::Y));
    });
    crate::memory::free_on_every_core(sums);
    normals
}

/// The blocks of vertices the triangles of `chunk` use, in increasing order (`blocks` in all).
fn touched_blocks(chunk: &[[u32; 3]], blocks: usize) -> Vec<u32> {
    let mut used = vec![false; blocks];
    for &k in chunk.iter().flatten() {
        used[k as usize / BLOCK_VERTICES] = true;
    }
    (0..blocks as u32).filter(|&b| used[b as usize]).collect()
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

    /// `area_weighted_normals` on 1, 2, 3 and 8 threads: checked to give the same bits on
    /// each, and to match the serial loop within `tolerance`; the one-thread result.
    fn same_on_every_thread_count(
        positions: &[Vec3],
        triangles: &[[u32; 3]],
        tolerance: f32,
    ) -> Vec<Vec3> {
        let face = |t: &[u32; 3]| {
            let [a, b, c] = t.map(|k| positions[k as usize]);
            (b - a).cross(c - a)
        };
        let reference = serial(positions, triangles, face);
        let in_pool = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| area_weighted_normals(positions, triangles))
        };
        let one = in_pool(1);
        for (got, want) in one.iter().zip(&reference) {
            assert!((*got - *want).abs().max_element() < tolerance, "{got} vs {want}");
        }
        let bits =
            |n: &[Vec3]| n.iter().flat_map(|v| v.to_array().map(f32::to_bits)).collect::<Vec<_>>();
        for threads in [2, 3, 8] {
            assert_eq!(bits(&in_pool(threads)), bits(&one), "{threads} threads");
        }
        one
    }

    #[test]
    fn chunked_normals_match_the_serial_loop_and_do_not_depend_on_the_thread_count() {
        // ~6 chunks of triangles, plus one isolated vertex at the end.
        let (mut positions, triangles) = grid(700, 280);
        positions.push(Vec3::new(1e3, 0.0, 0.0));
        assert!(triangles.len() > 5 * CHUNK_TRIANGLES);
        let one = same_on_every_thread_count(&positions, &triangles, 1e-5);
        assert_eq!(*one.last().unwrap(), Vec3::Y);
    }

    #[test]
    fn chunks_that_also_use_far_vertices_are_summed_in_blocks_like_the_others() {
        // Every other triangle uses vertex 0 or the last one, as a torus's last ring uses its
        // first: each chunk touches two far blocks besides its own, which stays under the
        // memory bound (so this is the chunked path, not the serial loop).
        let (positions, mut triangles) = grid(700, 280);
        let last = positions.len() as u32 - 1;
        for (i, t) in triangles.iter_mut().enumerate() {
            if i % 2 == 0 {
                t[0] = if i % 4 == 0 { 0 } else { last };
            }
        }
        let blocks = positions.len().div_ceil(BLOCK_VERTICES);
        let chunks: Vec<_> = triangles.chunks(CHUNK_TRIANGLES).collect();
        let buffers: usize = chunks.iter().map(|c| touched_blocks(c, blocks).len()).sum();
        assert!(buffers <= MAX_BUFFERS_PER_BLOCK * blocks + chunks.len());
        assert!(touched_blocks(chunks[2], blocks).contains(&0));
        // Vertices 0 and `last` sum ~98,000 faces each, grouped differently: 1e-4.
        same_on_every_thread_count(&positions, &triangles, 1e-4);
    }

    #[test]
    fn vertices_in_a_random_order_take_the_serial_loop_with_the_same_result() {
        // The vertices renumbered at random: every chunk touches nearly every block.
        let (positions, triangles) = grid(700, 280);
        let n = positions.len() as u64;
        let mut order: Vec<u32> = (0..n as u32).collect();
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        for i in (1..order.len()).rev() {
            state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            order.swap(i, ((state >> 33) % (i as u64 + 1)) as usize);
        }
        let mut moved = vec![Vec3::ZERO; positions.len()];
        for (old, &new) in order.iter().enumerate() {
            moved[new as usize] = positions[old];
        }
        let triangles: Vec<[u32; 3]> =
            triangles.iter().map(|t| t.map(|k| order[k as usize])).collect();
        let face = |t: &[u32; 3]| {
            let [a, b, c] = t.map(|k| moved[k as usize]);
            (b - a).cross(c - a)
        };
        assert_eq!(area_weighted_normals(&moved, &triangles), serial(&moved, &triangles, face));
    }
}
