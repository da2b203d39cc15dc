//! The top levels of a big build, planned on a sample of the triangles.
//!
//! Binning and partitioning the whole array at each of the top levels (a 10M-triangle
//! build has about six above the 128K-triangle subtrees) streams its 320 MB of boxes from
//! memory four times a level; with every core busy that traffic, not the arithmetic, set the
//! pace. Instead the top splits are chosen on every `SAMPLE_STRIDE`-th triangle (the same
//! binned SAH; a 128K-triangle node still has 4K samples to bin), and the triangles then go
//! straight from the mesh to their top-level bucket: one pass counts each chunk's triangles
//! per bucket, a second writes each triangle's box into its place, totting up every bucket's
//! exact bounds on the way. Each bucket is then built as before, and the top nodes take
//! their boxes from their children: every box in the tree is exact, only the choice of the
//! top planes comes from the sample.
//!
//! The sample's triangles are real triangles, classified by the very test that split the
//! sample, so no side of a planned split is empty. Everything is deterministic: fixed
//! chunks, exact merges.

use std::mem::MaybeUninit;

use glam::Vec3;
use rayon::prelude::*;

use super::bins::{BinSet, LeftOf};
use super::parallel::Fragment;
use super::phases::PhaseClock;
use super::prim::Prim;
use super::{Builder, NodeInfo, PARALLEL_BIN_MIN_PRIMS, PARALLEL_MIN_PRIMS};
use crate::memory;

/// Every this many triangles, one plans the top levels.
const SAMPLE_STRIDE: usize = 32;

/// Builds of at least this many triangles plan their top levels on a sample; smaller ones
/// have at most two levels above the buckets to save.
pub(super) const SAMPLED_TOP_MIN_PRIMS: usize = 4 * PARALLEL_BIN_MIN_PRIMS;

/// A planned node of fewer triangles than this (as the sample estimates) becomes a bucket,
/// built from its exact triangles: below it, the subtrees keep every thread busy.
const BUCKET_PRIMS: usize = PARALLEL_BIN_MIN_PRIMS;

/// The plan goes no deeper than this, so that a bucket's subtree keeps its depth budget.
const MAX_PLAN_DEPTH: usize = 16;

/// Triangles per task when classifying and scattering.
const CHUNK: usize = 64 * 1024;

/// The planned top levels in depth-first order: a split's left child follows it.
#[derive(Clone, Copy)]
enum PlanNode {
    /// Triangles that pass `test` go left; `right` is the right child's node, and
    /// `right_bucket` the first bucket under it.
    Split { test: LeftOf, right: u32, right_bucket: u32 },
    /// A leaf of the plan: the bucket of this number (numbered depth-first).
    Bucket(u32),
}

/// The plan as a tree while it is made (each half on its own thread).
enum PlanTree {
    Split(LeftOf, Box<PlanTree>, Box<PlanTree>),
    Bucket,
}

struct Plan {
    nodes: Vec<PlanNode>,
    buckets: usize,
}

impl Plan {
    fn flatten(tree: &PlanTree) -> Plan {
        let mut plan = Plan { nodes: Vec::new(), buckets: 0 };
        plan.push(tree);
        plan
    }

    fn push(&mut self, tree: &PlanTree) {
        match tree {
            PlanTree::Bucket => {
                self.nodes.push(PlanNode::Bucket(self.buckets as u32));
                self.buckets += 1;
            }
            PlanTree::Split(test, left, right) => {
                let at = self.nodes.len();
                self.nodes.push(PlanNode::Bucket(0)); // filled in below
                self.push(left);
                self.nodes[at] = PlanNode::Split {
                    test: *test,
                    right: self.nodes.len() as u32,
                    right_bucket: self.buckets as u32,
                };
                self.push(right);
            }
        }
    }

    /// The bucket a triangle with box `p` goes to.
    #[inline(always)]
    fn bucket_of(&self, p: &Prim) -> usize {
        let mut at = 0;
        loop {
            match self.nodes[at] {
                PlanNode::Split { test, right, .. } => {
                    at = if test.test(p) { at + 1 } else { right as usize }
                }
                PlanNode::Bucket(b) => return b as usize,
            }
        }
    }
}

/// Triangle `i`'s box.
#[inline(always)]
fn prim_of(corners: &(impl Fn(usize) -> [Vec3; 3] + Sync), i: usize) -> Prim {
    Prim::of_triangle(corners(i), i as u32)
}

impl Builder<'_> {
    /// Builds over `count >= SAMPLED_TOP_MIN_PRIMS` triangles with sampled top levels.
    /// Returns the triangles' tree order (`Bvh::prim_indices`) and the tree as a fragment.
    pub(super) fn build_sampled(
        &self,
        count: usize,
        corners: &(impl Fn(usize) -> [Vec3; 3] + Sync),
        clock: &PhaseClock,
    ) -> (Vec<u32>, Fragment) {
        let mut sample: Vec<Prim> = (0..count.div_ceil(SAMPLE_STRIDE))
            .into_par_iter()
            .map(|s| prim_of(corners, s * SAMPLE_STRIDE))
            .collect();
        let info =
            sample.par_chunks(CHUNK).map(NodeInfo::of).reduce(|| NodeInfo::EMPTY, NodeInfo::union);
        let tree = self.plan(&mut sample, info, 1);
        drop(sample);
        let plan = Plan::flatten(&tree);
        clock.mark("top plan (sample)");

        // Each chunk's triangles per bucket, then where each chunk's share of a bucket starts.
        let mut buckets: Vec<u32> = memory::with_huge_pages(count);
        let counts: Vec<Vec<u32>> = buckets.spare_capacity_mut()[..count]
            .par_chunks_mut(CHUNK)
            .enumerate()
            .map(|(c, out)| {
                let mut counts = vec![0u32; plan.buckets];
                for (j, b) in out.iter_mut().enumerate() {
                    let bucket = plan.bucket_of(&prim_of(corners, c * CHUNK + j));
                    b.write(bucket as u32);
                    counts[bucket] += 1;
                }
                counts
            })
            .collect();
        // SAFETY: the chunks above wrote all `count` ids.
        unsafe { buckets.set_len(count) };
        let mut bucket_start = vec![0usize; plan.buckets + 1];
        for b in 0..plan.buckets {
            bucket_start[b + 1] =
                bucket_start[b] + counts.iter().map(|c| c[b] as usize).sum::<usize>();
        }
        // Each bucket holds at least the sample triangles that planned it (an empty one would
        // become a leaf of no triangles, which the node layout cannot tell from an inner node).
        assert!(bucket_start.windows(2).all(|w| w[0] < w[1]), "a planned bucket is empty");
        let mut next = bucket_start[..plan.buckets].to_vec();
        let starts: Vec<Vec<usize>> = counts
            .iter()
            .map(|c| {
                let start = next.clone();
                next.iter_mut().zip(c).for_each(|(n, &c)| *n += c as usize);
                start
            })
            .collect();
        clock.mark("classify");

        // Every triangle's box into its place, each chunk into its own slots.
        let mut prims: Vec<Prim> = memory::with_huge_pages(count);
        let out = SharedSlots(prims.as_mut_ptr());
        let infos: Vec<Vec<NodeInfo>> = buckets
            .par_chunks(CHUNK)
            .zip(starts)
            .enumerate()
            .map(|(c, (buckets, mut at))| {
                let out = &out;
                let mut infos = vec![NodeInfo::EMPTY; plan.buckets];
                for (j, &b) in buckets.iter().enumerate() {
                    let p = prim_of(corners, c * CHUNK + j);
                    let b = b as usize;
                    infos[b].add(&p);
                    // SAFETY: the slots `starts` hands each chunk for a bucket are its own and
                    // number exactly its triangles in that bucket (the counts above), so every
                    // slot of `0..count` is written once, by one task.
                    unsafe { out.0.add(at[b]).write(p) };
                    at[b] += 1;
                }
                infos
            })
            .collect();
        // SAFETY: all `count` slots were written above.
        unsafe { prims.set_len(count) };
        drop(buckets);
        let bucket_info: Vec<NodeInfo> = (0..plan.buckets)
            .map(|b| infos.iter().fold(NodeInfo::EMPTY, |acc, i| acc.union(i[b])))
            .collect();
        clock.mark("scatter");

        // Each bucket writes its triangles' order as soon as it is built, while its boxes are
        // still in cache (a pass of its own over all the boxes took 22 ms of a 10M build on
        // 16 cores).
        let mut order: Vec<u32> = memory::with_huge_pages(count);
        let places =
            Places { prims: &mut prims, order: &mut order.spare_capacity_mut()[..count], first: 0 };
        let tree = self.build_planned(&plan, 0, places, 1, &bucket_info, &bucket_start);
        // SAFETY: the buckets cover `0..count` and each wrote its whole range.
        unsafe { order.set_len(count) };
        (order, tree)
    }

    /// Plans the top levels on `sample`, which it partitions like a build would.
    fn plan(&self, sample: &mut [Prim], info: NodeInfo, level: usize) -> PlanTree {
        if sample.len() * SAMPLE_STRIDE < BUCKET_PRIMS || level > MAX_PLAN_DEPTH {
            return PlanTree::Bucket;
        }
        let bins = &mut BinSet::boxed();
        let Some((split, test)) = self.sah_split(sample, &info, bins) else {
            return PlanTree::Bucket; // the bucket's own build finds a way to split it
        };
        let (left, right) = sample.split_at_mut(split.mid);
        let (left, right) = if sample_is_big(left.len() + right.len()) {
            rayon::join(
                || self.plan(left, split.left, level + 1),
                || self.plan(right, split.right, level + 1),
            )
        } else {
            (self.plan(left, split.left, level + 1), self.plan(right, split.right, level + 1))
        };
        PlanTree::Split(test, Box::new(left), Box::new(right))
    }

    /// Builds plan node `at` over its buckets' triangles, `places`.
    fn build_planned(
        &self,
        plan: &Plan,
        at: usize,
        places: Places,
        level: usize,
        bucket_info: &[NodeInfo],
        bucket_start: &[usize],
    ) -> Fragment {
        match plan.nodes[at] {
            PlanNode::Bucket(b) => {
                let Places { prims, order, first } = places;
                let tree = self.build_parallel(prims, first, bucket_info[b as usize], level);
                order.iter_mut().zip(prims.iter()).for_each(|(o, p)| {
                    o.write(p.index);
                });
                tree
            }
            PlanNode::Split { right, right_bucket, .. } => {
                let (left_places, right_places) =
                    places.split_at(bucket_start[right_bucket as usize]);
                let (left, right) = rayon::join(
                    || {
                        self.build_planned(
                            plan,
                            at + 1,
                            left_places,
                            level + 1,
                            bucket_info,
                            bucket_start,
                        )
                    },
                    || {
                        self.build_planned(
                            plan,
                            right as usize,
                            right_places,
                            level + 1,
                            bucket_info,
                            bucket_start,
                        )
                    },
                );
                let bounds = left.child.bounds.union(right.child.bounds);
                Fragment::join(left, right, bounds)
            }
        }
    }
}

/// A range of the tree's boxes and of its triangle order, which starts at `first`.
struct Places<'a> {
    prims: &'a mut [Prim],
    order: &'a mut [MaybeUninit<u32>],
    first: u32,
}

impl<'a> Places<'a> {
    /// The places before triangle `at` (of the whole array) and those from it on.
    fn split_at(self, at: usize) -> (Places<'a>, Places<'a>) {
        let mid = at - self.first as usize;
        let (left_prims, right_prims) = self.prims.split_at_mut(mid);
        let (left_order, right_order) = self.order.split_at_mut(mid);
        (
            Places { prims: left_prims, order: left_order, first: self.first },
            Places { prims: right_prims, order: right_order, first: at as u32 },
        )
    }
}

/// Whether planning a sample node this big is worth a task of its own.
fn sample_is_big(len: usize) -> bool {
    len >= PARALLEL_MIN_PRIMS
}

/// The boxes' array as the scatter's tasks share it (each writes only its own slots).
struct SharedSlots(*mut Prim);
// SAFETY: the tasks write disjoint slots (see `build_sampled`).
unsafe impl Sync for SharedSlots {}
