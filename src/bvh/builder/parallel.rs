//! The builder's work on all threads: binning and partitioning the big top nodes (where too
//! few subtrees exist to keep the threads busy), and stitching the subtrees built on
//! different threads into one node array.
//!
//! Everything here is deterministic: the work is cut into fixed-size chunks whatever the
//! thread count, and the bins are merged with exact operations (min, max, integer sums).

use rayon::prelude::*;

use super::bins::{BinGrid, BinSet, LeftOf};
use super::prim::{Bounds, ChildRef, Prim};
use crate::bvh::{BvhNode, EMPTY};

/// Primitives per task when binning or partitioning a big node of triangles.
pub(super) const CHUNK: usize = 32 * 1024;

/// Bins `prims` on all threads (`chunk` at a time, then merged) into `bins`.
pub(super) fn bin(prims: &[Prim], grid: &BinGrid, n_bins: usize, bins: &mut BinSet, chunk: usize) {
    let reduced = prims
        .par_chunks(chunk)
        .map(|chunk| {
            let mut b = BinSet::boxed();
            b.add(chunk, grid);
            b
        })
        .reduce(BinSet::boxed, |mut a, b| {
            a.merge(&b, n_bins);
            a
        });
    bins.copy_from(&reduced);
}

/// Moves the primitives that pass `left_of` to the front, in place and on all threads
/// (`chunk` at a time), and returns how many there are.
///
/// First each chunk partitions itself (as the sequential `partition` does); then the right
/// primitives that lie in the left part overall and the left ones in the right part, which
/// in each chunk form at most one run, are swapped pairwise, run by run.
pub(super) fn partition(prims: &mut [Prim], left_of: &LeftOf, chunk: usize) -> usize {
    let lefts: Vec<usize> = prims.par_chunks_mut(chunk).map(|c| left_of.partition(c)).collect();
    let total_left: usize = lefts.iter().sum();

    // The misplaced runs, in order: right primitives before `total_left`, left ones after.
    let (mut wrong_right, mut wrong_left) = (Vec::new(), Vec::new());
    for (i, &left) in lefts.iter().enumerate() {
        let (start, end) = (i * chunk, ((i + 1) * chunk).min(prims.len()));
        let mid = start + left;
        if mid < end.min(total_left) {
            wrong_right.push(mid..end.min(total_left));
        }
        if start.max(total_left) < mid {
            wrong_left.push(start.max(total_left) - total_left..mid - total_left);
        }
    }
    // Cut both run lists into pieces of equal lengths, paired in order.
    let (mut front, mut back) = prims.split_at_mut(total_left);
    let (mut front_at, mut back_at) = (0, 0); // where `front` and `back` start now
    let (mut r, mut l) = (wrong_right.into_iter().peekable(), wrong_left.into_iter().peekable());
    let mut pairs = Vec::new();
    while let (Some(rr), Some(lr)) = (r.peek_mut(), l.peek_mut()) {
        let len = rr.len().min(lr.len());
        let (_, rest) = std::mem::take(&mut front).split_at_mut(rr.start - front_at);
        let (a, rest) = rest.split_at_mut(len);
        front = rest;
        front_at = rr.start + len;
        let (_, rest) = std::mem::take(&mut back).split_at_mut(lr.start - back_at);
        let (b, rest) = rest.split_at_mut(len);
        back = rest;
        back_at = lr.start + len;
        pairs.push((a, b));
        rr.start += len;
        lr.start += len;
        if rr.start == rr.end {
            r.next();
        }
        if lr.start == lr.end {
            l.next();
        }
    }
    debug_assert!(r.peek().is_none() && l.peek().is_none(), "as many misplaced on each side");
    pairs.into_par_iter().for_each(|(a, b)| a.swap_with_slice(b));
    total_left
}

/// A built subtree as a list of node vectors that, concatenated, are its nodes in
/// depth-first order. Stitching is deferred: each chunk remembers how far it will be
/// shifted, so joining fragments costs O(chunks), not O(nodes).
pub(super) struct Fragment {
    pub(super) child: ChildRef,
    pub(super) len: u32,
    pub(super) chunks: Vec<Chunk>,
}

/// A run of nodes whose inner-child indices are relative to the run's start; `offset` is
/// where that start lands in the enclosing fragment.
pub(super) struct Chunk {
    pub(super) offset: u32,
    pub(super) nodes: Vec<BvhNode>,
}

impl Fragment {
    /// The fragment of a new node over `left` and `right`, whose box is `bounds`: in
    /// depth-first order, the node, then the left fragment, then the right one.
    pub(super) fn join(mut left: Fragment, mut right: Fragment, bounds: Bounds) -> Fragment {
        left.shift(1);
        right.shift(1 + left.len);
        let node = BvhNode::new(left.child.to_child(), right.child.to_child());
        let mut chunks = Vec::with_capacity(1 + left.chunks.len() + right.chunks.len());
        chunks.push(Chunk { offset: 0, nodes: vec![node] });
        chunks.append(&mut left.chunks);
        chunks.append(&mut right.chunks);
        Fragment {
            child: ChildRef { bounds, index: 0, count: 0 },
            len: 1 + left.len + right.len,
            chunks,
        }
    }

    /// Moves the fragment `by` nodes further into its parent's node list.
    pub(super) fn shift(&mut self, by: u32) {
        for chunk in &mut self.chunks {
            chunk.offset += by;
        }
        if self.child.count == 0 {
            self.child.index += by;
        }
    }

    /// The nodes in their final places, inner-child indices made absolute; each chunk is
    /// copied by its own task (one thread copying a 10M-triangle tree took 0.1 s).
    pub(super) fn flatten(mut self) -> Vec<BvhNode> {
        if self.chunks.len() == 1 && self.chunks[0].offset == 0 {
            return self.chunks.pop().map(|chunk| chunk.nodes).unwrap_or_default();
            // already in place
        }
        // Written straight into the new memory, not zeroed first: 64 bytes a node not written twice.
        // Not on huge pages: the packing appends other meshes' nodes to this array, and moving
        // a huge-page array to a larger place split its pages (0.2-0.3 s at 10M triangles).
        let mut nodes = Vec::with_capacity(self.len as usize);
        let mut rest = &mut nodes.spare_capacity_mut()[..self.len as usize];
        let mut places = Vec::with_capacity(self.chunks.len());
        for chunk in &self.chunks {
            debug_assert_eq!(chunk.offset as usize + rest.len(), self.len as usize);
            let (place, tail) = std::mem::take(&mut rest).split_at_mut(chunk.nodes.len());
            places.push(place);
            rest = tail;
        }
        assert!(rest.is_empty(), "the chunks hold the fragment's nodes");
        self.chunks.par_iter().zip(places).for_each(|(chunk, place)| {
            let inner = |index: u32, count: u32| count == 0 && index != EMPTY;
            for (out, n) in place.iter_mut().zip(&chunk.nodes) {
                let mut n = *n;
                if inner(n.left_index, n.left_count) {
                    n.left_index += chunk.offset;
                }
                if inner(n.right_index, n.right_count) {
                    n.right_index += chunk.offset;
                }
                out.write(n);
            }
        });
        // SAFETY: the chunks cover `0..len` exactly (asserted above) and wrote all their nodes.
        unsafe { nodes.set_len(self.len as usize) };
        nodes
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;

    #[test]
    fn partition_puts_the_same_primitives_on_each_side_as_the_sequential_one() {
        // Positions along x shuffled (every chunk holds both sides) and sorted (whole chunks
        // on one side, and runs of misplaced primitives that end at a chunk's end).
        let n = 3 * CHUNK + 1234;
        let shuffled: Vec<u32> =
            (0..n as u32).map(|i| i.wrapping_mul(2_654_435_761) % 1000).collect();
        let mut sorted = shuffled.clone();
        sorted.sort_unstable();
        sorted.reverse();
        for xs in [shuffled, sorted] {
            let prims: Vec<Prim> = xs
                .iter()
                .enumerate()
                .map(|(i, &x)| {
                    Prim::new(
                        Vec3::new(x as f32, 0.0, 0.0),
                        Vec3::new(x as f32 + 1.0, 1.0, 1.0),
                        i as u32,
                    )
                })
                .collect();
            let centroids = Bounds {
                min: Vec3::new(0.5, 0.5, 0.5).into(),
                max: Vec3::new(999.5, 0.5, 0.5).into(),
            };
            let grid = BinGrid::new(&centroids, 16).unwrap();
            for plane in [1, 7, 15] {
                let (mut seq, mut par) = (prims.clone(), prims.clone());
                let left_of = grid.left_of(0, plane);
                let mid = left_of.partition(&mut seq);
                assert_eq!(partition(&mut par, &left_of, CHUNK), mid, "plane {plane}");
                let left_set = |p: &[Prim]| {
                    let mut left: Vec<u32> = p[..mid].iter().map(|p| p.index).collect();
                    left.sort_unstable();
                    left
                };
                assert_eq!(left_set(&seq), left_set(&par), "plane {plane}");
                // The test agrees with the bins: x in [0.5, 999.5] spread over 16 bins.
                let bin = |p: &Prim| (((p.min.x + 0.5) - 0.5) * (16.0 / 999.0)) as usize;
                assert!(par[..mid].iter().all(|p| bin(p) < plane));
                assert!(par[mid..].iter().all(|p| bin(p) >= plane));
            }
        }
    }
}
