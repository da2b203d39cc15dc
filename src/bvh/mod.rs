//! Bounding volume hierarchy over one mesh's triangles: a binned-SAH build on the CPU and
//! a compact two-children-per-node layout that the compute shader traverses as is.
//!
//! Node layout (64 bytes, `BvhNode`): each node stores the boxes of its two children, so a
//! traversal step loads one node and tests two boxes. A child with `count == 0` is an inner
//! node (`index` = node index); `count > 0` is a leaf holding triangles
//! `index .. index + count` of the BVH-ordered triangle array; `index == EMPTY` with
//! `count == 0` is an absent child (only in a root over fewer than two triangles).

mod builder;
mod stats;
mod traverse;
mod validate;
pub mod wide;

pub use builder::BuildOptions;
pub(crate) use builder::LeafBox;
pub use stats::{node_count, sah_cost};
#[cfg(any(test, feature = "dev"))]
pub use traverse::ordered_edges;
pub use traverse::TraversalStats;
pub(crate) use traverse::{any_hit, closest_hit};

use bytemuck::{Pod, Zeroable};

use crate::contract;
use crate::geometry::Aabb;

/// Marks an absent child (its box must not be tested); the shader's `EMPTY`.
pub(crate) const EMPTY: u32 = contract::EMPTY;

/// Entries in the traversal stack (CPU and shader alike).
pub const STACK_SIZE: usize = contract::STACK_SIZE as usize;

/// Deepest tree the builder makes, in nodes ([`Bvh::depth`]). A traversal needs at most
/// `depth` stack entries, so this stays within [`STACK_SIZE`].
pub const MAX_DEPTH: usize = 60;

/// One BVH node in the GPU layout (std430-compatible, 64 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BvhNode {
    pub(crate) left_min: [f32; 3],
    pub left_index: u32,
    pub(crate) left_max: [f32; 3],
    pub(crate) left_count: u32,
    pub(crate) right_min: [f32; 3],
    pub right_index: u32,
    pub(crate) right_max: [f32; 3],
    pub(crate) right_count: u32,
}

/// A BVH over `prim_indices.len()` triangles. Node 0 is the root.
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    pub nodes: Vec<BvhNode>,
    /// BVH order -> original triangle index: leaf ranges index this array.
    pub prim_indices: Vec<u32>,
}

/// One child of a node as its parent records it: its box, and what `index`/`count` mean
/// (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BvhChild {
    pub bounds: Aabb,
    pub index: u32,
    pub count: u32,
}

impl BvhChild {
    /// The absent child.
    pub const EMPTY: BvhChild = BvhChild { bounds: Aabb::EMPTY, index: EMPTY, count: 0 };

    /// True for the absent child (its box must not be tested).
    pub fn is_empty(&self) -> bool {
        self.count == 0 && self.index == EMPTY
    }

    /// True for a leaf: triangles `index .. index + count` in BVH order.
    pub fn is_leaf(&self) -> bool {
        self.count > 0
    }

    /// True for an inner node: `nodes[index]`.
    pub fn is_inner(&self) -> bool {
        self.count == 0 && self.index != EMPTY
    }
}

impl BvhNode {
    /// A node from its two children.
    pub fn new(left: BvhChild, right: BvhChild) -> Self {
        Self {
            left_min: left.bounds.min.into(),
            left_index: left.index,
            left_max: left.bounds.max.into(),
            left_count: left.count,
            right_min: right.bounds.min.into(),
            right_index: right.index,
            right_max: right.bounds.max.into(),
            right_count: right.count,
        }
    }

    /// Child 0 (left) or 1 (right).
    pub fn child(&self, i: usize) -> BvhChild {
        let (min, max, index, count) = if i == 0 {
            (self.left_min, self.left_max, self.left_index, self.left_count)
        } else {
            (self.right_min, self.right_max, self.right_index, self.right_count)
        };
        BvhChild { bounds: Aabb { min: min.into(), max: max.into() }, index, count }
    }

    /// Both children, left first.
    pub fn children(&self) -> [BvhChild; 2] {
        [self.child(0), self.child(1)]
    }
}

// The shader reads nodes as 64-byte std430 records.
const _: () = assert!(std::mem::size_of::<BvhNode>() == 64);
