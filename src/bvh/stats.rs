//! Tree statistics for reports and tests: the SAH cost, the depth and the leaf count.

use rayon::prelude::*;

use super::{BuildOptions, Bvh, BvhNode};
use crate::geometry::Aabb;

impl Bvh {
    /// SAH cost of the tree (root-surface-area normalised, with the options' costs), for reports:
    /// `(Ct * sum of node areas + Ci * sum of leaf areas * leaf sizes) / root area`, root node included.
    pub fn sah_cost(&self, options: &BuildOptions) -> f32 {
        sah_cost(&self.nodes, options.traversal_cost, options.intersection_cost) as f32
    }

    /// Nodes counted as tinybvh's `NodeCount` counts them: every inner node and every leaf
    /// (ours live in their parents, tinybvh's are nodes of their own).
    pub fn node_count(&self) -> usize {
        node_count(&self.nodes)
    }

    /// Longest root-to-leaf path in nodes (leaves live in their parent): 0 when empty, 1 for a
    /// root over leaves. A traversal needs at most this many stack entries.
    pub fn depth(&self) -> usize {
        if self.nodes.is_empty() {
            return 0;
        }
        let mut deepest = 0;
        let mut stack = vec![(0u32, 1usize)];
        while let Some((index, level)) = stack.pop() {
            deepest = deepest.max(level);
            for child in self.nodes[index as usize].children() {
                if child.is_inner() {
                    stack.push((child.index, level + 1));
                }
            }
        }
        deepest
    }

    /// Number of leaves (non-empty leaf children).
    pub fn leaf_count(&self) -> usize {
        self.nodes.iter().flat_map(|n| n.children()).filter(|c| c.is_leaf()).count()
    }
}

/// The SAH cost of the tree `nodes` hold (node 0 the root), its node visits weighing
/// `traversal` and its triangle tests `intersection`: with both 1, tinybvh's `SAHCost`, the
/// measure builds are compared by. Summed in f64 on every core: a 10M-triangle tree has
/// millions of nodes, and `bench --load` takes its cost outside its timings.
pub fn sah_cost(nodes: &[BvhNode], traversal: f32, intersection: f32) -> f64 {
    let Some(root) = nodes.first() else { return 0.0 };
    let area = |b: &Aabb| {
        let e = b.extent().as_dvec3();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    };
    let root_box = root
        .children()
        .iter()
        .filter(|c| !c.is_empty())
        .fold(Aabb::EMPTY, |b, c| b.union(c.bounds));
    // f64 so that 1e30-sized boxes do not overflow; a zero-area root (all primitives on one
    // point or line) weighs every node fully.
    let root_area = area(&root_box);
    let ratio = |b: &Aabb| if root_area > 0.0 { area(b) / root_area } else { 1.0 };
    let (ct, ci) = (traversal as f64, intersection as f64);
    let below: f64 = nodes
        .par_iter()
        .with_min_len(4096)
        .map(|node| {
            node.children()
                .iter()
                .map(|child| {
                    if child.is_leaf() {
                        ci * ratio(&child.bounds) * child.count as f64
                    } else if child.is_inner() {
                        ct * ratio(&child.bounds)
                    } else {
                        0.0
                    }
                })
                .sum::<f64>()
        })
        .sum();
    ct + below // the root is always visited
}

/// Inner nodes and leaves of the tree `nodes` hold, as tinybvh's `NodeCount` counts them.
pub fn node_count(nodes: &[BvhNode]) -> usize {
    let leaves: usize = nodes
        .par_iter()
        .with_min_len(4096)
        .map(|n| n.children().iter().filter(|c| c.is_leaf()).count())
        .sum();
    nodes.len() + leaves
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;

    /// A unit right triangle in the z = 0 plane, its right angle at `at`.
    fn flat(at: Vec3) -> [Vec3; 3] {
        [at, at + Vec3::X, at + Vec3::Y]
    }

    #[test]
    fn the_cost_and_node_count_are_tinybvhs_on_a_tree_worked_by_hand() {
        let o = BuildOptions { max_leaf_size: 1, ..Default::default() };
        // Two triangles at x = 0 and x = 2, a third far off at x = 10; the third one rises
        // to z = 1, so that no box is flat.
        let far = [Vec3::new(10.0, 0.0, 0.0), Vec3::new(11.0, 0.0, 1.0), Vec3::new(10.0, 1.0, 1.0)];
        let tris = [flat(Vec3::ZERO), flat(Vec3::new(2.0, 0.0, 0.0)), far];
        let bvh = Bvh::build(&tris, &o);
        // The split: the near pair under an inner node, the far one a leaf of the root.
        assert_eq!(bvh.nodes.len(), 2);
        assert_eq!(bvh.leaf_count(), 3);
        let far_leaf = bvh.nodes[0].children().into_iter().find(|c| c.is_leaf()).unwrap();
        assert_eq!(bvh.prim_indices[far_leaf.index as usize], 2);
        // Areas 2(xy + yz + zx): the root 11 x 1 x 1 = 2(11 + 1 + 11) = 46; the near pair's
        // box 3 x 1 x 0 = 6; each near leaf 1 x 1 x 0 = 2; the far leaf 1 x 1 x 1 = 6.
        // Cost: the root 1, the inner node 6/46, the leaves (2 + 2 + 6)/46 times one triangle.
        let expected = 1.0 + 6.0 / 46.0 + (2.0 + 2.0 + 6.0) / 46.0;
        assert!((sah_cost(&bvh.nodes, 1.0, 1.0) - expected).abs() < 1e-12);
        assert!((bvh.sah_cost(&o) as f64 - expected).abs() < 1e-6);
        // Costs weigh their parts: visits 2, tests 3.
        let weighted = 2.0 * (1.0 + 6.0 / 46.0) + 3.0 * (10.0 / 46.0);
        assert!((sah_cost(&bvh.nodes, 2.0, 3.0) - weighted).abs() < 1e-12);
        // Two inner nodes and three leaves, as tinybvh counts them.
        assert_eq!((bvh.node_count(), node_count(&bvh.nodes)), (5, 5));
        assert_eq!((sah_cost(&[], 1.0, 1.0), node_count(&[])), (0.0, 0));
    }
}
