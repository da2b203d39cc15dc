//! Builds whose leaves hold one primitive each and carry its name (a top level over
//! instances), written where the nodes stay.
//!
//! A tree of one-primitive leaves over k primitives has exactly k - 1 inner nodes, so in
//! depth-first order a node over k primitives split at `mid` has its left subtree in the
//! next `mid - 1` slots and its right one in the `k - mid - 1` after them. Every subtree's
//! place is known before it is built: the threads write their nodes into one array, with no
//! per-subtree vectors to stitch together afterwards (on the H200's host, copying 10,000
//! nodes that sixteen threads had written cost a sixth of a top level's rebuild).

use std::mem::MaybeUninit;

use super::bins::BinSet;
use super::phases::PhaseClock;
use super::prim::{ChildRef, Prim};
use super::{Builder, LeafBox, NodeInfo, Sharing};
use crate::bvh::{BuildOptions, Bvh, BvhChild, BvhNode};
use crate::geometry::Aabb;

impl Bvh {
    /// Appends to `nodes` the tree over `leaves` with one box a leaf, whose `index` is the
    /// box's name: a top level over instances. Returns its root as a parent records it:
    /// an inner child at the first appended node, the one leaf for one box, or the absent
    /// child for none. Inner indices count from the start of `nodes`. The same tree as
    /// [`Bvh::build_from_boxes`] with leaves of one (each leaf `i` naming box
    /// `prim_indices[i]`), without that order to gather and apply afterwards or subtrees to
    /// stitch together (`build/placed.rs`).
    pub(crate) fn build_named_leaves_into(
        leaves: &mut [LeafBox],
        options: &BuildOptions,
        nodes: &mut Vec<BvhNode>,
    ) -> BvhChild {
        if leaves.is_empty() {
            return BvhChild::EMPTY;
        }
        let clock = PhaseClock::start();
        let builder =
            Builder { sharing: Sharing::BOXES, max_leaf: 1, ..Builder::new(options, &clock) };
        let (at, inner) = (nodes.len(), leaves.len() - 1);
        nodes.reserve(inner);
        let slots: &mut [MaybeUninit<BvhNode>] = &mut nodes.spare_capacity_mut()[..inner];
        let root = builder.place_parallel(leaves, NodeInfo::of(leaves), 1, slots, at as u32);
        // SAFETY: `place_parallel` wrote each of the `inner` slots (`build/placed.rs`).
        unsafe { nodes.set_len(at + inner) };
        root.to_child()
    }

    /// [`Bvh::build_named_leaves_into`] over `boxes`, box `i` named `names[i]` (or `i`): the
    /// nodes alone, none for no boxes and a root over the leaf and an absent child for one.
    pub fn build_named_leaves(
        boxes: &[Aabb],
        names: Option<&[u32]>,
        options: &BuildOptions,
    ) -> Vec<BvhNode> {
        let name = |i: usize| names.map_or(i as u32, |names| names[i]);
        let mut leaves: Vec<LeafBox> =
            boxes.iter().enumerate().map(|(i, b)| LeafBox::named(*b, name(i))).collect();
        let mut nodes = Vec::new();
        let root = Self::build_named_leaves_into(&mut leaves, options, &mut nodes);
        if root.is_leaf() {
            nodes.push(BvhNode::new(root, BvhChild::EMPTY));
        }
        nodes
    }
}

impl Builder<'_> {
    /// Builds the tree over `prims` into `nodes`, exactly `prims.len() - 1` of them, whose
    /// first is node `at` of the whole array, writing each once; forks big subtrees onto
    /// other threads. Returns the root as its parent records it.
    pub(super) fn place_parallel(
        &self,
        prims: &mut [Prim],
        info: NodeInfo,
        level: usize,
        nodes: &mut [MaybeUninit<BvhNode>],
        at: u32,
    ) -> ChildRef {
        if prims.len() < self.sharing.fork_min {
            return self.place(prims, info, level, nodes, at, &mut BinSet::boxed());
        }
        let split = self.clock.top_split(|| self.split(prims, &info, level, &mut BinSet::boxed()));
        let (left_prims, right_prims) = prims.split_at_mut(split.mid);
        let (node, rest) = nodes.split_first_mut().expect("a node over two or more primitives");
        let (left_nodes, right_nodes) = rest.split_at_mut(split.mid - 1);
        let right_at = at + split.mid as u32;
        let (left, right) = rayon::join(
            || self.place_parallel(left_prims, split.left, level + 1, left_nodes, at + 1),
            || self.place_parallel(right_prims, split.right, level + 1, right_nodes, right_at),
        );
        node.write(BvhNode::new(left.to_child(), right.to_child()));
        ChildRef { bounds: info.bounds, index: at, count: 0 }
    }

    /// [`Builder::place_parallel`] on this thread, for one primitive (a leaf naming it) or more.
    fn place(
        &self,
        prims: &mut [Prim],
        info: NodeInfo,
        level: usize,
        nodes: &mut [MaybeUninit<BvhNode>],
        at: u32,
        bins: &mut BinSet,
    ) -> ChildRef {
        if let [prim] = prims {
            return ChildRef { bounds: info.bounds, index: prim.index, count: 1 };
        }
        let split = self.split(prims, &info, level, bins);
        let (left_prims, right_prims) = prims.split_at_mut(split.mid);
        let (node, rest) = nodes.split_first_mut().expect("a node over two or more primitives");
        let (left_nodes, right_nodes) = rest.split_at_mut(split.mid - 1);
        let left = self.place(left_prims, split.left, level + 1, left_nodes, at + 1, bins);
        let right_at = at + split.mid as u32;
        let right = self.place(right_prims, split.right, level + 1, right_nodes, right_at, bins);
        node.write(BvhNode::new(left.to_child(), right.to_child()));
        ChildRef { bounds: info.bounds, index: at, count: 0 }
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use crate::bvh::{BuildOptions, Bvh, BvhChild, BvhNode};
    use crate::geometry::Aabb;

    /// `n` boxes scattered by a hash, some overlapping, a few empty.
    fn boxes(n: usize) -> Vec<Aabb> {
        let hash = |i: usize, k: u32| {
            ((i as u32).wrapping_mul(2_654_435_761).rotate_left(k) % 10_000) as f32 / 100.0
        };
        (0..n)
            .map(|i| {
                if i % 97 == 5 {
                    return Aabb::EMPTY;
                }
                let min = Vec3::new(hash(i, 0), hash(i, 7), hash(i, 13));
                Aabb { min, max: min + Vec3::new(hash(i, 3), hash(i, 9), hash(i, 21)) * 0.05 }
            })
            .collect()
    }

    #[test]
    fn named_leaves_are_the_general_build_with_its_leaves_renamed() {
        // Sizes that take the sequential path, the forked one (256 and up) and the binning
        // on every thread (4,096 and up).
        for n in [0, 1, 2, 3, 9, 100, 1000, 5000] {
            let boxes = boxes(n);
            let names: Vec<u32> = (0..n as u32).map(|i| 3 * i + 1).collect();
            let options = BuildOptions { max_leaf_size: 1, ..BuildOptions::default() };
            let general = Bvh::build_from_boxes(&boxes, &options);
            let renamed: Vec<BvhNode> = general
                .nodes
                .iter()
                .map(|node| {
                    let [a, b] = node.children().map(|c| match c.is_leaf() {
                        true => BvhChild {
                            index: names[general.prim_indices[c.index as usize] as usize],
                            ..c
                        },
                        false => c,
                    });
                    BvhNode::new(a, b)
                })
                .collect();
            let named = Bvh::build_named_leaves(&boxes, Some(&names), &options);
            assert_eq!(named, renamed, "{n} boxes");
        }
    }
}
