//! Closest-hit traversal of the wide tree on the CPU: the reference for `traverse_wide` in
//! `shaders/traverse_wide.glsl`, which it follows step for step (the same slot order, the
//! same stack of pending children with their entry distances), so that its counts are the
//! shader's cost AOV.
//!
//! A visit tests all eight boxes and orders the slots it hits by the distance at which the
//! ray enters them: the nearest is visited next, the others are pushed, farthest first,
//! with that distance. A pending child whose box the ray enters beyond the closest hit
//! found since is dropped when popped, unread. Against the paper's octant order (a group
//! of siblings per stack entry, a node's leaves tested before its inner children) this
//! visits 40-60% fewer nodes and triangles on the knot and on Sponza (docs/BENCHMARKS.md,
//! "Sixteenth session").

use glam::Vec3;

use super::{WideNode, WideSlot, STACK_SIZE, WIDTH};
use crate::bvh::TraversalStats;
use crate::geometry::{intersect_triangle, safe_inverse, Ray, TriHit};

/// Set in a stack entry's reference for a leaf: bits 29-30 its triangle count less one,
/// bits 0-28 its first triangle. Clear for an inner node: its index.
pub(crate) const LEAF_ENTRY: u32 = 1 << 31;

/// The stack entry of slot `s` of `node`: what it holds, as [`LEAF_ENTRY`] describes.
fn reference(node: &WideNode, s: usize) -> u32 {
    match node.slot(s) {
        WideSlot::Inner(index) => index,
        WideSlot::Leaf { first, count } => LEAF_ENTRY | (count - 1) << 29 | first,
        WideSlot::Empty => unreachable!("empty slots are never hit"),
    }
}

/// The sort key of a slot the ray enters at `t_enter` (>= 0): the distance's bits with the
/// slot in the low three. Keys of positive floats order as the floats do; the slot makes
/// each key unique and breaks ties by slot; clearing the low bits rounds the distance down,
/// so the stored distance never culls a box the ray enters before the closest hit.
fn sort_key(t_enter: f32, s: usize) -> u32 {
    (t_enter.to_bits() & 0x7fff_fff8) | s as u32
}

/// Closest hit of `ray` in (t_min, t_max) through one mesh's wide `nodes` (root first) over
/// its (v0, e1, e2) triangles `ordered` in the shared leaf order; returns (k, hit) with `k`
/// indexing `ordered`. Adds to `stats` one per node and one per triangle tested, as the
/// shader adds to its cost.
pub fn closest_hit(
    nodes: &[WideNode],
    ordered: &[[Vec3; 3]],
    ray: &Ray,
    t_min: f32,
    t_max: f32,
    stats: &mut TraversalStats,
) -> Option<(u32, TriHit)> {
    walk(nodes, ordered, ray, t_min, t_max, false, stats)
}

/// Whether `ray` hits any triangle in (t_min, t_max): the AO view's occlusion query, the
/// same walk as [`closest_hit`] but with the hit slots in slot order (any order serves, and
/// the sort cost the H100 6% on AO rays), ended by the first leaf that holds a hit (a leaf's
/// first two triangles are both tested, as the shader loads them together).
pub fn any_hit(
    nodes: &[WideNode],
    ordered: &[[Vec3; 3]],
    ray: &Ray,
    t_min: f32,
    t_max: f32,
    stats: &mut TraversalStats,
) -> bool {
    walk(nodes, ordered, ray, t_min, t_max, true, stats).is_some()
}

/// The walk both queries share (the shader's `traverse_wide`; `first` as there).
fn walk(
    nodes: &[WideNode],
    ordered: &[[Vec3; 3]],
    ray: &Ray,
    t_min: f32,
    t_max: f32,
    first: bool,
    stats: &mut TraversalStats,
) -> Option<(u32, TriHit)> {
    if nodes.is_empty() {
        return None;
    }
    let inv_dir = safe_inverse(ray.dir);
    let mut t_max = t_max;
    let mut best = None;
    let mut stack = [(0u32, 0f32); STACK_SIZE];
    let mut sp = 0;
    // (reference, entry distance); the root first.
    let mut entry = (0u32, 0f32);
    loop {
        if entry.1 <= t_max {
            if entry.0 & LEAF_ENTRY != 0 {
                let start = entry.0 & 0x1fff_ffff;
                let end = start + ((entry.0 >> 29) & 3);
                for k in start..=end {
                    let [v0, e1, e2] = ordered[k as usize];
                    stats.triangles += 1;
                    if let Some(hit) = intersect_triangle(ray, v0, e1, e2, t_min, t_max) {
                        t_max = hit.t;
                        best = Some((k, hit));
                    }
                    // The first two are tested together (loaded together in the shader).
                    if first && best.is_some() && (k > start || k == end) {
                        return best;
                    }
                }
            } else {
                let node = &nodes[entry.0 as usize];
                stats.nodes += 1;
                // All eight boxes against the same t_max, as the shader does.
                let mut keys = [0u32; WIDTH];
                let mut hit_slots = 0u32;
                for (s, key) in keys.iter_mut().enumerate() {
                    if node.meta[s] != 0 {
                        if let Some(t_enter) = node.child_box(s).intersect(ray, inv_dir, t_max) {
                            *key = sort_key(t_enter, s);
                            hit_slots |= 1 << s;
                        }
                    }
                }
                let hits = hit_slots.count_ones();
                if hits > 0 && first {
                    // An occlusion query takes any order: the slots in slot order, the last
                    // visited next, no sort (and no distances: its t_max never shrinks).
                    for s in (0..WIDTH).filter(|&s| hit_slots & (1 << s) != 0) {
                        stack[sp] = (reference(node, s), 0.0);
                        sp += 1;
                    }
                    sp -= 1;
                    entry = stack[sp];
                    continue;
                }
                if hits > 0 {
                    // Farthest first onto the stack, the nearest last: it is visited next. A
                    // slot is read off its key, so that a hit key of 0 (slot 0, entered at 0)
                    // and the zeros of slots not hit pick the same slot, as in the shader.
                    for _ in 0..hits {
                        let key = keys.iter().copied().max().unwrap_or(0);
                        let s = (key & 7) as usize;
                        keys[s] = 0;
                        stack[sp] = (reference(node, s), f32::from_bits(key & !7));
                        sp += 1;
                    }
                    sp -= 1;
                    entry = stack[sp];
                    continue;
                }
            }
        }
        if sp == 0 {
            break;
        }
        sp -= 1;
        entry = stack[sp];
    }
    best
}
