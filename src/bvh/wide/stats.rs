//! Size statistics of a wide tree beside its binary source, for reports and tests: node
//! counts and the bytes the traversal reads per triangle.

use super::{WideBvh, WideNode, WideSlot, WIDTH};
use crate::bvh::{Bvh, BvhNode};

/// Bytes of one triangle as the traversal reads it (`GpuTriangle`: v0, e1, e2 and the
/// triangle's index; `tracer/packed.rs` checks the two agree).
pub(crate) const TRIANGLE_BYTES: usize = 40;

/// Sizes of a wide tree and its binary source.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WideStats {
    /// Triangles of the mesh.
    pub triangles: usize,
    /// Triangle slots in leaf order: more than `triangles` where the build cut triangles
    /// into pieces (one slot, and one 40-byte record, per leaf holding a piece).
    pub slots: usize,
    /// Nodes of the binary tree.
    pub binary_nodes: usize,
    /// Nodes of the wide tree.
    pub wide_nodes: usize,
    /// Leaf slots of the wide tree.
    pub wide_leaves: usize,
    /// Mean filled slots per wide node.
    pub mean_children: f64,
    /// Longest root-to-leaf path in wide nodes.
    pub wide_depth: usize,
}

impl WideStats {
    /// The statistics of `wide`, collapsed from `bvh`.
    pub fn new(bvh: &Bvh, wide: &WideBvh) -> Self {
        let filled: usize =
            wide.nodes.iter().map(|n| n.meta.iter().filter(|&&m| m != 0).count()).sum();
        let leaves = wide
            .nodes
            .iter()
            .map(|n| (0..WIDTH).filter(|&s| matches!(n.slot(s), WideSlot::Leaf { .. })).count())
            .sum();
        // Every triangle has a slot at least; a cut one has several.
        let triangles = bvh.prim_indices.iter().map(|&p| p as usize + 1).max().unwrap_or(0);
        Self {
            triangles,
            slots: bvh.prim_indices.len(),
            binary_nodes: bvh.nodes.len(),
            wide_nodes: wide.nodes.len(),
            wide_leaves: leaves,
            mean_children: if wide.nodes.is_empty() {
                0.0
            } else {
                filled as f64 / wide.nodes.len() as f64
            },
            wide_depth: wide.depth(),
        }
    }

    /// Node bytes plus triangle bytes the binary traversal reads, per triangle of the mesh.
    pub fn binary_bytes_per_triangle(&self) -> f64 {
        self.per_triangle(self.binary_nodes * std::mem::size_of::<BvhNode>())
    }

    /// Node bytes plus triangle bytes the wide traversal reads, per triangle of the mesh.
    pub fn wide_bytes_per_triangle(&self) -> f64 {
        self.per_triangle(self.wide_nodes * std::mem::size_of::<WideNode>())
    }

    /// Node bytes plus every slot's triangle record, over the mesh's triangles.
    fn per_triangle(&self, node_bytes: usize) -> f64 {
        if self.triangles == 0 {
            return 0.0;
        }
        (node_bytes + self.slots * TRIANGLE_BYTES) as f64 / self.triangles as f64
    }
}

impl WideBvh {
    /// Longest root-to-leaf path in nodes: 0 when empty.
    pub fn depth(&self) -> usize {
        self.most_along_a_path(|_| 1)
    }

    /// The most stack entries the traversal can hold: over every root-to-node path, the
    /// sum of each node's filled slots but one (a visit pushes every hit slot but the
    /// nearest), plus one. At most [`STACK_SIZE`](super::STACK_SIZE) for a tree the tracers
    /// traverse (a deeper one keeps the binary layout).
    pub fn stack_need(&self) -> usize {
        if self.nodes.is_empty() {
            return 0;
        }
        self.most_along_a_path(|node| {
            node.meta.iter().filter(|&&m| m != 0).count().saturating_sub(1)
        }) + 1
    }

    /// The largest sum of `per_node` over the nodes of a path from the root down (0 when
    /// empty).
    fn most_along_a_path(&self, per_node: impl Fn(&WideNode) -> usize) -> usize {
        if self.nodes.is_empty() {
            return 0;
        }
        let mut most = 0;
        let mut stack = vec![(0u32, 0usize)];
        while let Some((index, above)) = stack.pop() {
            let node = &self.nodes[index as usize];
            let here = above + per_node(node);
            most = most.max(here);
            for s in 0..WIDTH {
                if let WideSlot::Inner(child) = node.slot(s) {
                    stack.push((child, here));
                }
            }
        }
        most
    }
}
