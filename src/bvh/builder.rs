//! Binned-SAH builder (top-down, in place); the bins and the plane sweep are in
//! `build/bins.rs`, the structural checker in `validate.rs`, the tree statistics in `stats.rs`.
//!
//! The build works on one array of per-primitive boxes (`Prim`), partitioned in place:
//! every subtree owns a contiguous range of it, and a leaf is simply a range. A node of at
//! most `max_leaf_size` primitives becomes a leaf; a bigger one bins its primitives'
//! centroids into `bins` slabs per axis, sweeps the slab planes for the lowest SAH cost and
//! partitions around the winner. Where binning cannot separate the primitives (all
//! centroids in one point), or where the depth budget (`MAX_DEPTH`) runs short, it splits
//! at the object median instead, so every leaf stays within `max_leaf_size`.
//!
//! Subtrees of at least `PARALLEL_MIN_PRIMS` primitives are built on both threads
//! (`rayon::join`), each sequential subtree into its own node vector; the pieces are
//! stitched together in depth-first order at the end, on all threads. Nodes of at least
//! `PARALLEL_BIN_MIN_PRIMS` are binned and partitioned on all threads (`build/parallel.rs`).
//! Builds over boxes (a top level) share much smaller pieces of work (`Sharing::BOXES`).
//! Builds of at least `SAMPLED_TOP_MIN_PRIMS` triangles instead plan those big top nodes on
//! a sample and scatter the triangles into the buckets below them in one pass
//! (`build/top.rs`), unless they have large triangles to cut (`build/split.rs`). Nodes of
//! at most `SMALL_NODE` primitives take the exact SAH split over every centroid plane
//! instead of bins (`build/small.rs`).

mod bins;
mod parallel;
mod phases;
mod placed;
mod prim;
mod small;
mod split;
mod top;

use glam::Vec3;
use rayon::prelude::*;

use std::time::Duration;

use self::bins::{Bin, BinGrid, BinSet, LeftOf};
use self::parallel::{Chunk, Fragment};
use self::phases::PhaseClock;
use self::prim::{Bounds, ChildRef, Prim, MAX_BINS};
use super::{Bvh, BvhChild, BvhNode, MAX_DEPTH};
use crate::geometry::Aabb;

/// A box to build over and the name its leaf carries ([`Bvh::build_named_leaves_into`]).
pub(crate) use self::prim::Prim as LeafBox;

/// Build parameters.
///
/// The two costs weigh [`Bvh::sah_cost`]. The build itself does not need them: the best
/// split plane does not depend on them, and leaves are made by size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BuildOptions {
    /// Largest leaf the builder makes (clamped to 1..=255); nodes with more primitives are always split.
    pub max_leaf_size: u32,
    /// SAH bins per axis (clamped to 2..=32); small nodes use fewer.
    pub bins: u32,
    /// SAH cost of visiting one node (fetch + two box tests).
    pub traversal_cost: f32,
    /// SAH cost of one ray/triangle test.
    pub intersection_cost: f32,
    /// Extra primitives cut from large triangles before the build, as a share of the
    /// triangle count (`build/split.rs`; 0: none, every triangle referenced once). Builds of
    /// `SAMPLED_TOP_MIN_PRIMS` triangles or more cut only where a sample finds at least 1%
    /// of the triangles worth cutting (architecture); the rest keep the fast sampled path.
    pub split_budget: f32,
}

impl Default for BuildOptions {
    fn default() -> Self {
        Self {
            max_leaf_size: 4,
            bins: 16,
            traversal_cost: 1.0,
            intersection_cost: 1.0,
            split_budget: 0.0,
        }
    }
}

/// The tracers' budget of extra references from cut triangles (`build/split.rs`): on the
/// H100 a budget of 0.3 traced Crytek Sponza in 0.55 (framed) and 0.47 (the mirror box, 2
/// bounces) of the time of the uncut tree; 0.1 gave 0.70-0.83, 0.6 no more than 0.3.
const TRACING_SPLIT_BUDGET: f32 = 0.3;

/// Meshes of fewer triangles are not cut for tracing: the paper's scenes (up to 1.2K
/// triangles) are also traced by brute force, which tests every slot (the cylinder's cut
/// caps would have cost it 30% more tests), and a tree that small gains little.
const TRACING_SPLIT_MIN_TRIANGLES: usize = 16 * 1024;

impl BuildOptions {
    /// What the tracers build with over `triangles` triangles: leaves of at most 2
    /// triangles, and large triangles cut (`TRACING_SPLIT_BUDGET`) in meshes of at least
    /// `TRACING_SPLIT_MIN_TRIANGLES`. On the H100 leaves of 2 traced primary rays 7-11%
    /// faster than leaves of 4 on 0.2M-4M-triangle meshes (1 gave 13% on the 4M knot but
    /// doubled the dragon's time; 8 was 18-25% slower) and made no difference on the paper's
    /// scenes: big meshes pay for triangle bytes more than for node visits
    /// (docs/BENCHMARKS.md).
    pub(crate) fn for_tracing(triangles: usize) -> Self {
        let split_budget =
            if triangles >= TRACING_SPLIT_MIN_TRIANGLES { TRACING_SPLIT_BUDGET } else { 0.0 };
        Self { max_leaf_size: 2, split_budget, ..Self::default() }
    }
}

/// Subtrees at least this big are split off onto the other thread; below it the fork
/// overhead outweighs the gain.
const PARALLEL_MIN_PRIMS: usize = 8 * 1024;

/// Nodes at least this big are binned and partitioned on all threads (only the top few levels,
/// where too few subtrees exist to keep the threads busy).
const PARALLEL_BIN_MIN_PRIMS: usize = 128 * 1024;

/// When a build hands work to other threads: subtrees of at least `fork_min` primitives are
/// forked, nodes of at least `bin_min` binned and partitioned `chunk` primitives a task.
#[derive(Clone, Copy)]
struct Sharing {
    fork_min: usize,
    bin_min: usize,
    chunk: usize,
}

impl Sharing {
    /// Triangle builds: millions of primitives, where a task must be big to pay its way.
    const TRIANGLES: Sharing = Sharing {
        fork_min: PARALLEL_MIN_PRIMS,
        bin_min: PARALLEL_BIN_MIN_PRIMS,
        chunk: parallel::CHUNK,
    };

    /// Builds over boxes (a top level over instances) are made again whenever instances
    /// change and should take about a millisecond for 10,000 boxes: they share much sooner
    /// (a subtree of 256 boxes is still some 100 µs of work, a chunk of 1,024 some 20 µs).
    const BOXES: Sharing = Sharing { fork_min: 256, bin_min: 4 * 1024, chunk: 1024 };
}

impl Bvh {
    /// Binned-SAH build over triangles given as corner triples (any order; index i = triangle i).
    pub fn build(triangles: &[[Vec3; 3]], options: &BuildOptions) -> Bvh {
        Self::build_timed(triangles, options).0
    }

    /// [`Bvh::build`], also returning where the time went: each phase's wall time in order,
    /// then the thread time of the top splits and of the sequential subtrees (for the build
    /// benchmark).
    #[doc(hidden)]
    pub fn build_timed(
        triangles: &[[Vec3; 3]],
        options: &BuildOptions,
    ) -> (Bvh, Vec<(&'static str, Duration)>) {
        Self::build_indexed_timed(triangles.len(), |i| triangles[i], options)
    }

    /// [`Bvh::build`] over `count` triangles whose corners `corners(i)` gives: no array of
    /// corner triples is made (36 bytes a triangle the caller need not hold).
    pub fn build_indexed(
        count: usize,
        corners: impl Fn(usize) -> [Vec3; 3] + Sync,
        options: &BuildOptions,
    ) -> Bvh {
        Self::build_indexed_timed(count, corners, options).0
    }

    fn build_indexed_timed(
        count: usize,
        corners: impl Fn(usize) -> [Vec3; 3] + Sync,
        options: &BuildOptions,
    ) -> (Bvh, Vec<(&'static str, Duration)>) {
        let clock = PhaseClock::start();
        // A big mesh worth cutting (architecture) takes the full binned build over its
        // pieces; others plan their top levels on a sample, uncut.
        let cut_big = || options.split_budget > 0.0 && split::worth_cutting(count, &corners);
        if count < top::SAMPLED_TOP_MIN_PRIMS || cut_big() {
            let prims = split::split_prims(count, &corners, options.split_budget);
            clock.mark("prim boxes");
            let bvh = build_from_prims(prims, &Builder::new(options, &clock));
            return (bvh, clock.finish());
        }
        let builder = Builder::new(options, &clock);
        let (prim_indices, root) = builder.build_sampled(count, &corners, &clock);
        clock.mark("tree (and prim_indices)");
        let bvh = finish(prim_indices, root, &clock);
        (bvh, clock.finish())
    }

    /// Same over arbitrary boxes (used for a top level over instances); empty boxes are
    /// treated as a point at the origin.
    pub fn build_from_boxes(boxes: &[Aabb], options: &BuildOptions) -> Bvh {
        let prims = boxes
            .par_iter()
            .enumerate()
            .map(|(i, b)| {
                let b = if b.is_empty() { Aabb { min: Vec3::ZERO, max: Vec3::ZERO } } else { *b };
                Prim::new(b.min, b.max, i as u32)
            })
            .collect();
        let clock = PhaseClock::start();
        let builder = Builder { sharing: Sharing::BOXES, ..Builder::new(options, &clock) };
        build_from_prims(prims, &builder)
    }
}

/// What a node needs to know about its primitives: their box and the box of their centroids.
#[derive(Clone, Copy, Debug)]
struct NodeInfo {
    bounds: Bounds,
    centroids: Bounds,
}

impl NodeInfo {
    const EMPTY: NodeInfo = NodeInfo { bounds: Bounds::EMPTY, centroids: Bounds::EMPTY };

    fn of(prims: &[Prim]) -> NodeInfo {
        let mut info = NodeInfo::EMPTY;
        for p in prims {
            info.add(p);
        }
        info
    }

    #[inline(always)]
    fn add(&mut self, p: &Prim) {
        self.bounds.grow(p.bounds_min(), p.bounds_max());
        let c = p.centroid();
        self.centroids.grow(c, c);
    }

    fn union(self, o: NodeInfo) -> NodeInfo {
        NodeInfo {
            bounds: self.bounds.union(o.bounds),
            centroids: self.centroids.union(o.centroids),
        }
    }
}

/// A split of a node's primitive range: `prims[..mid]` go left, the rest right.
struct Split {
    mid: usize,
    left: NodeInfo,
    right: NodeInfo,
}

/// The resolved build options shared by all threads.
struct Builder<'c> {
    max_leaf: usize,
    bins: usize,
    sharing: Sharing,
    clock: &'c PhaseClock,
}

fn build_from_prims(mut prims: Vec<Prim>, builder: &Builder) -> Bvh {
    let clock = builder.clock;
    if prims.is_empty() {
        return Bvh::default();
    }
    let info =
        prims.par_chunks(64 * 1024).map(NodeInfo::of).reduce(|| NodeInfo::EMPTY, NodeInfo::union);
    clock.mark("root bounds");
    let root = builder.build_parallel(&mut prims, 0, info, 1);
    clock.mark("tree");
    // The records go before the stitching, which holds the subtrees' nodes and their joined
    // copy at once: 32 bytes a triangle less at the build's peak.
    let prim_indices = prims.par_iter().map(|p| p.index).collect();
    drop(prims);
    clock.mark("prim_indices gather");
    finish(prim_indices, root, clock)
}

/// The tree from its primitive order and its nodes as fragments: the nodes in one array.
fn finish(prim_indices: Vec<u32>, root: Fragment, clock: &PhaseClock) -> Bvh {
    let nodes = if root.child.count > 0 {
        // A single leaf: the root node holds it on the left and nothing on the right.
        vec![BvhNode::new(root.child.to_child(), BvhChild::EMPTY)]
    } else {
        root.flatten()
    };
    clock.mark("stitching");
    Bvh { nodes, prim_indices }
}

impl<'c> Builder<'c> {
    fn new(options: &BuildOptions, clock: &'c PhaseClock) -> Self {
        Builder {
            max_leaf: options.max_leaf_size.clamp(1, 255) as usize,
            bins: (options.bins as usize).clamp(2, MAX_BINS),
            sharing: Sharing::TRIANGLES,
            clock,
        }
    }
}

impl Builder<'_> {
    /// Builds the subtree over `prims` (which start at `first` in the whole array) into
    /// `nodes`, depth-first, and returns it as its parent will record it. `level` is the
    /// depth of the node this call would create (root = 1).
    fn build_subtree(
        &self,
        prims: &mut [Prim],
        first: u32,
        info: NodeInfo,
        level: usize,
        nodes: &mut Vec<BvhNode>,
        bins: &mut BinSet,
    ) -> ChildRef {
        if prims.len() <= self.max_leaf {
            return ChildRef { bounds: info.bounds, index: first, count: prims.len() as u32 };
        }
        let split = self.split(prims, &info, level, bins);
        let slot = nodes.len();
        nodes.push(BvhNode::default()); // filled in once both children exist
        let (left_prims, right_prims) = prims.split_at_mut(split.mid);
        let left = self.build_subtree(left_prims, first, split.left, level + 1, nodes, bins);
        let right = self.build_subtree(
            right_prims,
            first + split.mid as u32,
            split.right,
            level + 1,
            nodes,
            bins,
        );
        nodes[slot] = BvhNode::new(left.to_child(), right.to_child());
        ChildRef { bounds: info.bounds, index: slot as u32, count: 0 }
    }

    /// As `build_subtree`, but forks big subtrees onto the other thread and splits big nodes
    /// on all threads. Each sequential subtree gets its own node vector; the result is a list
    /// of them in depth-first order.
    fn build_parallel(
        &self,
        prims: &mut [Prim],
        first: u32,
        info: NodeInfo,
        level: usize,
    ) -> Fragment {
        if prims.len() < self.sharing.fork_min || prims.len() <= self.max_leaf {
            // At most n - 1 inner nodes: reserved, not touched, and never grown by copying.
            let mut nodes = Vec::with_capacity(prims.len().saturating_sub(1));
            let child = self.clock.subtree(|| {
                self.build_subtree(prims, first, info, level, &mut nodes, &mut BinSet::boxed())
            });
            return Fragment {
                child,
                len: nodes.len() as u32,
                chunks: vec![Chunk { offset: 0, nodes }],
            };
        }
        let split = self.clock.top_split(|| self.split(prims, &info, level, &mut BinSet::boxed()));
        let (left_prims, right_prims) = prims.split_at_mut(split.mid);
        let right_first = first + split.mid as u32;
        let (left, right) = rayon::join(
            || self.build_parallel(left_prims, first, split.left, level + 1),
            || self.build_parallel(right_prims, right_first, split.right, level + 1),
        );
        Fragment::join(left, right, info.bounds)
    }

    /// Chooses how to split a node that must be split: the best binned-SAH plane, or the
    /// median when binning cannot separate the primitives or the depth budget runs out.
    fn split(&self, prims: &mut [Prim], info: &NodeInfo, level: usize, bins: &mut BinSet) -> Split {
        // A median split from here on needs ceil(log2(n)) more levels at most; keep that
        // within MAX_DEPTH so that the traversal stack can never overflow.
        if level + ceil_log2(prims.len()) < MAX_DEPTH {
            if prims.len() <= small::SMALL_NODE {
                return small::exact_split(prims, &info.bounds);
            }
            if let Some((split, _)) = self.sah_split(prims, info, bins) {
                return split;
            }
            // The centroid box handed down is loose (see `sah_split`), so all centroids may
            // share a bin of it where the exact box still separates them: retry with that.
            let exact = NodeInfo::of(prims);
            let loose = exact.centroids.min != info.centroids.min
                || exact.centroids.max != info.centroids.max;
            if loose {
                if let Some((split, _)) = self.sah_split(prims, &exact, bins) {
                    return split;
                }
            }
        }
        median_split(prims, info)
    }

    /// The best binned-SAH split, and the test that sent each primitive to its side; `None`
    /// when binning cannot separate the primitives.
    fn sah_split(
        &self,
        prims: &mut [Prim],
        info: &NodeInfo,
        bins: &mut BinSet,
    ) -> Option<(Split, LeftOf)> {
        let n_bins = self.bins.min(prims.len()); // few primitives need few bins
        let grid = BinGrid::new(&info.centroids, n_bins)?;

        let big = prims.len() >= self.sharing.bin_min;
        if big {
            parallel::bin(prims, &grid, n_bins, bins, self.sharing.chunk);
        } else {
            bins.clear(n_bins);
            bins.add(prims, &grid);
        }

        let (axis, plane) = bins.best_plane(&grid, &info.bounds)?;
        let left_of = grid.left_of(axis, plane);
        let mid = if big {
            parallel::partition(prims, &left_of, self.sharing.chunk)
        } else {
            left_of.partition(prims)
        };
        // Each side's box is the union of its bins. Its centroids lie in that box and in the
        // node's centroid box: the intersection bounds them (loosely; binning only needs a
        // range that covers them, and tracking them exactly would cost a pass).
        let axis_bins = &bins.bins[axis][..n_bins];
        let side = |bins: &[Bin]| {
            let bounds = bins.iter().fold(Bounds::EMPTY, |b, bin| b.union(bin.bounds));
            let centroids = Bounds {
                min: bounds.min.max(info.centroids.min),
                max: bounds.max.min(info.centroids.max),
            };
            NodeInfo { bounds, centroids }
        };
        Some((
            Split { mid, left: side(&axis_bins[..plane]), right: side(&axis_bins[plane..]) },
            left_of,
        ))
    }
}

/// `ceil(log2(n))` for `n >= 1`: the levels a median split needs to bring `n` down to 1.
fn ceil_log2(n: usize) -> usize {
    (usize::BITS - (n - 1).leading_zeros()) as usize
}

/// Object-median split along the widest centroid axis; when all centroids coincide, any
/// halving is as good as another, so the range is just cut in two. Ties go by original
/// index (then box: `Prim::tie_break`), so that the halves do not depend on the order the partitions left the range in
/// (which differs between the sequential and the parallel partition).
fn median_split(prims: &mut [Prim], info: &NodeInfo) -> Split {
    let mid = prims.len() / 2;
    let extent = info.centroids.max - info.centroids.min;
    if extent.max_element() > 0.0 {
        let axis = extent.max_position();
        prims.select_nth_unstable_by(mid, |a, b| {
            a.centroid()[axis].total_cmp(&b.centroid()[axis]).then_with(|| a.tie_break(b))
        });
    } else {
        prims.select_nth_unstable_by(mid, Prim::tie_break);
    }
    Split { mid, left: NodeInfo::of(&prims[..mid]), right: NodeInfo::of(&prims[mid..]) }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn soup(n: usize, seed: u64) -> Vec<[Vec3; 3]> {
        let mut s = seed;
        let mut next = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 40) as f32 / (1u64 << 24) as f32
        };
        (0..n)
            .map(|_| {
                let c = Vec3::new(next(), next(), next()) * 10.0;
                [
                    c,
                    c + Vec3::new(next(), next(), next()) * 0.3,
                    c + Vec3::new(next(), next(), next()) * 0.3,
                ]
            })
            .collect()
    }

    #[test]
    fn empty_and_single() {
        let o = BuildOptions::default();
        let bvh = Bvh::build(&[], &o);
        assert!(bvh.nodes.is_empty() && bvh.prim_indices.is_empty());
        assert_eq!(bvh.validate(&[]), Ok(()));
        assert_eq!((bvh.depth(), bvh.leaf_count(), bvh.sah_cost(&o)), (0, 0, 0.0));

        let tri = [[Vec3::ZERO, Vec3::X, Vec3::Y]];
        let bvh = Bvh::build(&tri, &o);
        assert_eq!(bvh.nodes.len(), 1);
        assert_eq!(bvh.nodes[0].child(0).count, 1);
        assert!(bvh.nodes[0].child(1).is_empty());
        assert_eq!(bvh.validate(&tri), Ok(()));
        assert_eq!((bvh.depth(), bvh.leaf_count()), (1, 1));
        assert!((bvh.sah_cost(&o) - 2.0).abs() < 1e-6); // one node + one triangle
    }

    #[test]
    fn sequential_and_parallel_paths_are_valid() {
        let o = BuildOptions::default();
        for n in [5, 100, 3000, PARALLEL_MIN_PRIMS * 5] {
            let tris = soup(n, 7 + n as u64);
            let bvh = Bvh::build(&tris, &o);
            assert_eq!(bvh.validate(&tris), Ok(()), "n = {n}");
            assert!(bvh.depth() <= MAX_DEPTH);
            // Depth-first order: each inner child comes after its parent.
            for (i, node) in bvh.nodes.iter().enumerate() {
                for c in node.children() {
                    assert!(!c.is_inner() || c.index as usize > i);
                }
            }
        }
    }

    #[test]
    fn leaf_size_option_is_respected() {
        let tris = soup(2000, 3);
        for leaf in [1, 2, 8] {
            let o = BuildOptions { max_leaf_size: leaf, ..Default::default() };
            let bvh = Bvh::build(&tris, &o);
            assert_eq!(bvh.validate_with(&tris, &o), Ok(()));
        }
    }

    #[test]
    fn depth_budget_holds_for_exponential_spacing() {
        // Triangles at 2^k: binned SAH peels one off per level; the budget must cap the depth.
        let tris: Vec<[Vec3; 3]> = (0..120)
            .flat_map(|k| {
                let x = 2f32.powi(k - 60);
                (0..8).map(move |j| {
                    let p = Vec3::new(x, j as f32 * x, 0.0);
                    [p, p + Vec3::X * x * 0.1, p + Vec3::Y * x * 0.1]
                })
            })
            .collect();
        let bvh = Bvh::build(&tris, &BuildOptions { max_leaf_size: 1, ..Default::default() });
        assert_eq!(
            bvh.validate_with(&tris, &BuildOptions { max_leaf_size: 1, ..Default::default() }),
            Ok(())
        );
        assert!(bvh.depth() <= MAX_DEPTH);
    }

    #[test]
    fn sharing_work_sooner_builds_the_same_tree() {
        // 20,000 boxes: the box sharing forks subtrees and bins the top nodes on all
        // threads, the triangle sharing builds it all on one; the trees must not differ.
        let boxes: Vec<Aabb> = soup(20_000, 5).iter().map(|t| Aabb::from_points(t)).collect();
        let o = BuildOptions { max_leaf_size: 1, ..Default::default() };
        let clock = PhaseClock::start();
        let prims = || boxes.iter().enumerate().map(|(i, b)| Prim::new(b.min, b.max, i as u32));
        let build = |sharing| {
            let builder = Builder { sharing, ..Builder::new(&o, &clock) };
            build_from_prims(prims().collect(), &builder)
        };
        let (shared, alone) = (build(Sharing::BOXES), build(Sharing::TRIANGLES));
        assert_eq!(shared.prim_indices, alone.prim_indices);
        assert_eq!(shared.nodes, alone.nodes);
        assert_eq!(shared.validate_boxes(&boxes, &o), Ok(()));
    }

    #[test]
    fn boxes_build_is_valid() {
        let boxes: Vec<Aabb> =
            soup(500, 11).iter().map(|t| Aabb::from_points(t)).chain([Aabb::EMPTY]).collect();
        let o = BuildOptions::default();
        let bvh = Bvh::build_from_boxes(&boxes, &o);
        assert_eq!(bvh.validate_boxes(&boxes, &o), Ok(()));
    }
}
