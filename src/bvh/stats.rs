//! Tree statistics for reports and tests: the SAH cost, the depth and the leaf count.

use super::{BuildOptions, Bvh};
use crate::geometry::Aabb;

impl Bvh {
    /// SAH cost of the tree (root-surface-area normalised, with the options' costs), for reports:
    /// `(Ct * sum of node areas + Ci * sum of leaf areas * leaf sizes) / root area`, root node included.
    pub fn sah_cost(&self, options: &BuildOptions) -> f32 {
        let Some(root) = self.nodes.first() else { return 0.0 };
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
        let (ct, ci) = (options.traversal_cost as f64, options.intersection_cost as f64);
        let mut cost = ct; // the root is always visited
        for node in &self.nodes {
            for child in node.children() {
                if child.is_leaf() {
                    cost += ci * ratio(&child.bounds) * child.count as f64;
                } else if child.is_inner() {
                    cost += ct * ratio(&child.bounds);
                }
            }
        }
        cost as f32
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
