//! Closest-hit traversal on the CPU over the packed two-child nodes: the reference for
//! `traverse_bvh` in `shaders/intersect.glsl`, which it follows step for step (fixed stack,
//! both child boxes tested against the same `t_max`, leaves tested on the spot, the near
//! inner child visited next), so that its counts are the shader's cost AOV; and the AO
//! view's any-hit query ([`any_hit`]), the same walk ended by the first hit.

use glam::Vec3;

use super::{Bvh, BvhChild, BvhNode, STACK_SIZE};
use crate::geometry::{intersect_triangle, safe_inverse, Ray, TriHit};

/// Counters for the cost view: nodes visited and triangles tested for one ray.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TraversalStats {
    pub nodes: u32,
    pub triangles: u32,
}

impl Bvh {
    /// Closest hit of `ray` in (t_min, t_max) over triangles given in BVH order as (v0, e1, e2) triples
    /// (i.e. `ordered[k]` is triangle `prim_indices[k]`); returns (k, hit). Adds to `stats`.
    pub fn closest_hit(
        &self,
        ordered: &[[Vec3; 3]],
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        stats: &mut TraversalStats,
    ) -> Option<(u32, TriHit)> {
        closest_hit(&self.nodes, ordered, ray, t_min, t_max, stats)
    }
}

/// Closest hit of `ray` in (t_min, t_max) through one mesh's `nodes` as the GPU stores them
/// (root first, child and leaf indices relative to the mesh's node and triangle bases) over
/// its BVH-ordered (v0, e1, e2) triangles `ordered`; returns (k, hit) with `k` indexing
/// `ordered`. Adds to `stats` what the shader adds to its cost: one per node, one per triangle.
pub fn closest_hit(
    nodes: &[BvhNode],
    ordered: &[[Vec3; 3]],
    ray: &Ray,
    t_min: f32,
    t_max: f32,
    stats: &mut TraversalStats,
) -> Option<(u32, TriHit)> {
    walk(nodes, ordered, ray, t_min, t_max, stats, Stop::AtClosest)
}

/// Whether `ray` hits any triangle in (t_min, t_max) through one mesh's `nodes` (laid out
/// as for [`closest_hit`]): the AO view's occlusion query, the reference for `traverse_bvh`
/// in `shaders/intersect.glsl` with `any`. The same walk as [`closest_hit`] (leaves tested
/// as their box is hit, the near inner child next), ended by the first hit found.
pub fn any_hit(
    nodes: &[BvhNode],
    ordered: &[[Vec3; 3]],
    ray: &Ray,
    t_min: f32,
    t_max: f32,
    stats: &mut TraversalStats,
) -> bool {
    walk(nodes, ordered, ray, t_min, t_max, stats, Stop::AtFirst).is_some()
}

/// When a walk ends: with every box the closest hit leaves open visited, or at the first hit.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Stop {
    AtClosest,
    AtFirst,
}

/// The traversal both queries share (the shader's `traverse_bvh`; its `any` is
/// [`Stop::AtFirst`]).
fn walk(
    nodes: &[BvhNode],
    ordered: &[[Vec3; 3]],
    ray: &Ray,
    t_min: f32,
    t_max: f32,
    stats: &mut TraversalStats,
    stop: Stop,
) -> Option<(u32, TriHit)> {
    if nodes.is_empty() {
        return None;
    }
    let inv_dir = safe_inverse(ray.dir);
    let mut t_max = t_max; // shrinks with every hit, so later boxes are culled harder
    let mut best = None;
    let mut stack = [0u32; STACK_SIZE];
    let mut sp = 0;
    let mut node = 0u32;

    loop {
        let [left, right] = nodes[node as usize].children();
        stats.nodes += 1;
        // Both boxes first, against the same t_max: a hit in the left leaf does not cull the
        // right box (as in the shader, whose cost AOV counts these tests).
        let enter = |child: &BvhChild| {
            if child.is_empty() {
                None
            } else {
                child.bounds.intersect(ray, inv_dir, t_max)
            }
        };
        let (mut t_left, mut t_right) = (enter(&left), enter(&right));
        for (child, t_enter) in [(&left, &mut t_left), (&right, &mut t_right)] {
            if t_enter.is_some() && child.is_leaf() {
                for k in child.index..child.index + child.count {
                    let [v0, e1, e2] = ordered[k as usize];
                    stats.triangles += 1;
                    if let Some(hit) = intersect_triangle(ray, v0, e1, e2, t_min, t_max) {
                        if stop == Stop::AtFirst {
                            return Some((k, hit));
                        }
                        t_max = hit.t;
                        best = Some((k, hit));
                    }
                }
                *t_enter = None;
            }
        }
        // Inner children: the near one next (the left one on a tie), the far one stacked.
        node = match (t_left, t_right) {
            (Some(l), Some(r)) => {
                let (near, far) =
                    if l <= r { (left.index, right.index) } else { (right.index, left.index) };
                stack[sp] = far;
                sp += 1;
                near
            }
            (Some(_), None) => left.index,
            (None, Some(_)) => right.index,
            (None, None) => {
                if sp == 0 {
                    break;
                }
                sp -= 1;
                stack[sp]
            }
        };
    }
    best
}

/// Triangles (corners) -> BVH-ordered (v0, e1, e2) triples, as the GPU stores them: what
/// the CPU traversals take, for the tests and benches (the tracers pack their own).
#[cfg(any(test, feature = "dev"))]
pub fn ordered_edges(bvh: &Bvh, triangles: &[[Vec3; 3]]) -> Vec<[Vec3; 3]> {
    bvh.prim_indices
        .iter()
        .map(|&i| {
            let [v0, v1, v2] = triangles[i as usize];
            [v0, v1 - v0, v2 - v0]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::BuildOptions;

    #[test]
    fn single_triangle_hit_and_miss() {
        let tris = [[Vec3::ZERO, Vec3::X, Vec3::Y]];
        let bvh = Bvh::build(&tris, &BuildOptions::default());
        let ordered = ordered_edges(&bvh, &tris);
        let mut stats = TraversalStats::default();
        let down = Vec3::new(0.0, 0.0, -1.0);
        let hit = bvh.closest_hit(
            &ordered,
            &Ray::new(Vec3::new(0.2, 0.2, 3.0), down),
            0.0,
            f32::INFINITY,
            &mut stats,
        );
        assert_eq!(hit.map(|(k, h)| (k, h.t)), Some((0, 3.0)));
        assert_eq!(stats, TraversalStats { nodes: 1, triangles: 1 });
        let miss = bvh.closest_hit(
            &ordered,
            &Ray::new(Vec3::new(2.0, 2.0, 3.0), down),
            0.0,
            f32::INFINITY,
            &mut stats,
        );
        assert!(miss.is_none());
        assert_eq!(stats.nodes, 2);
    }

    #[test]
    fn any_hit_agrees_with_closest_hit_within_t_max() {
        // The same stack of parallel triangles at z = 0..63, rays from above and from the side.
        let tris: Vec<[Vec3; 3]> = (0..64)
            .map(|i| ((i * 37) % 64) as f32)
            .map(|z| [Vec3::new(0.0, 0.0, z), Vec3::new(1.0, 0.0, z), Vec3::new(0.0, 1.0, z)])
            .collect();
        let bvh = Bvh::build(&tris, &BuildOptions::default());
        let ordered = ordered_edges(&bvh, &tris);
        let mut stats = TraversalStats::default();
        for (origin, dir) in [
            (Vec3::new(0.25, 0.25, 100.0), Vec3::NEG_Z),
            (Vec3::new(0.2, 0.2, -5.0), Vec3::Z),
            (Vec3::new(5.0, 5.0, 5.0), Vec3::X),
        ] {
            let ray = Ray::new(origin, dir);
            for t_max in [0.5, 4.0, 36.5, 37.5, 1e3, f32::INFINITY] {
                let closest = bvh.closest_hit(&ordered, &ray, 0.0, t_max, &mut stats).is_some();
                assert_eq!(
                    any_hit(&bvh.nodes, &ordered, &ray, 0.0, t_max, &mut stats),
                    closest,
                    "{origin} {dir} t_max {t_max}"
                );
            }
        }
        // Early exit: every triangle lies across the ray from above, so the first tested ends it.
        let mut one = TraversalStats::default();
        assert!(any_hit(
            &bvh.nodes,
            &ordered,
            &Ray::new(Vec3::new(0.25, 0.25, 100.0), Vec3::NEG_Z),
            0.0,
            f32::INFINITY,
            &mut one
        ));
        assert_eq!(one.triangles, 1, "{one:?}");
    }

    #[test]
    fn nearest_of_a_stack_of_parallel_triangles() {
        // 64 parallel unit triangles at z = 0..63, shuffled; the ray from above must stop at z = 63.
        let tris: Vec<[Vec3; 3]> = (0..64)
            .map(|i| ((i * 37) % 64) as f32)
            .map(|z| [Vec3::new(0.0, 0.0, z), Vec3::new(1.0, 0.0, z), Vec3::new(0.0, 1.0, z)])
            .collect();
        let bvh = Bvh::build(&tris, &BuildOptions::default());
        let ordered = ordered_edges(&bvh, &tris);
        let mut stats = TraversalStats::default();
        let ray = Ray::new(Vec3::new(0.25, 0.25, 100.0), Vec3::new(0.0, 0.0, -1.0));
        let (k, hit) = bvh.closest_hit(&ordered, &ray, 0.0, f32::INFINITY, &mut stats).unwrap();
        assert_eq!(tris[bvh.prim_indices[k as usize] as usize][0].z, 63.0);
        assert!((hit.t - 37.0).abs() < 1e-5);
        // Near-first order with t_max shrinking: far fewer tests than the 64 of brute force.
        assert!(stats.triangles < 16, "{stats:?}");
    }
}
