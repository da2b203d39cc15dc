//! Closest-hit traversal of the wide tree on the CPU: the reference for `traverse_wide` in
//! `shaders/traverse_wide.glsl`, which it follows step for step (the same box decoding,
//! slot order and stack of node groups), so that its counts are the shader's cost AOV.

use glam::Vec3;

use super::{WideNode, WideSlot, WIDTH};
use crate::bvh::{TraversalStats, STACK_SIZE};
use crate::geometry::{intersect_triangle, safe_inverse, Ray, TriHit};

/// A group of sibling inner nodes still to visit: the first sibling's index, the hit
/// slots still pending (bit `s ^ octant`) and the parent's `imask`.
#[derive(Clone, Copy, Debug, Default)]
struct NodeGroup {
    base: u32,
    hits: u32,
    imask: u32,
}

/// Closest hit of `ray` in (t_min, t_max) through one mesh's wide `nodes` (root first) over
/// its (v0, e1, e2) triangles `ordered` in the shared leaf order; returns (k, hit) with `k`
/// indexing `ordered`. Adds to `stats` one per node and one per triangle tested, as the
/// shader adds to its cost.
pub fn closest_hit(nodes: &[WideNode], ordered: &[[Vec3; 3]], ray: &Ray, t_min: f32, t_max: f32, stats: &mut TraversalStats) -> Option<(u32, TriHit)> {
    if nodes.is_empty() {
        return None;
    }
    let inv_dir = safe_inverse(ray.dir);
    let octant = (ray.dir.x < 0.0) as u32 | ((ray.dir.y < 0.0) as u32) << 1 | ((ray.dir.z < 0.0) as u32) << 2;
    let mut t_max = t_max;
    let mut best = None;
    let mut stack = [NodeGroup::default(); STACK_SIZE];
    let mut sp = 0;
    // The root as a group of one inner node in slot 0.
    let mut group = NodeGroup { base: 0, hits: 1 << octant, imask: 1 };
    loop {
        if group.hits == 0 {
            if sp == 0 {
                break;
            }
            sp -= 1;
            group = stack[sp];
        }
        // The nearest pending slot by the octant order, then the rest of the group saved.
        let bit = group.hits.trailing_zeros();
        group.hits &= !(1 << bit);
        let slot = bit ^ octant;
        let index = group.base + (group.imask & ((1 << slot) - 1)).count_ones();
        if group.hits != 0 {
            stack[sp] = group;
            sp += 1;
        }
        let node = &nodes[index as usize];
        stats.nodes += 1;
        // All eight boxes against the same t_max, as the shader does.
        let mut inner_hits = 0u32;
        let mut leaf_bits = 0u32;
        for s in 0..WIDTH {
            let meta = node.meta[s] as u32;
            if meta == 0 || node.child_box(s).intersect(ray, inv_dir, t_max).is_none() {
                continue;
            }
            match node.slot(s) {
                WideSlot::Inner(_) => inner_hits |= 1 << (s as u32 ^ octant),
                WideSlot::Leaf { .. } => leaf_bits |= (meta >> 5) << (meta & 31),
                WideSlot::Empty => {}
            }
        }
        // This node's leaves now, in slot order (their triangles lie in that order).
        while leaf_bits != 0 {
            let offset = leaf_bits.trailing_zeros();
            leaf_bits &= leaf_bits - 1;
            let k = node.triangle_base + offset;
            let [v0, e1, e2] = ordered[k as usize];
            stats.triangles += 1;
            if let Some(hit) = intersect_triangle(ray, v0, e1, e2, t_min, t_max) {
                t_max = hit.t;
                best = Some((k, hit));
            }
        }
        group = NodeGroup { base: node.child_base, hits: inner_hits, imask: node.imask() };
    }
    best
}
