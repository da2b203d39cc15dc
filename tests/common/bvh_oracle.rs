//! The oracle the BVH tests check the trees against: brute force over every triangle, on
//! random rays aimed so that most of them hit.

use glam::Vec3;
use meshtracer::geometry::{intersect_triangle, Aabb, Ray, TriHit};

use super::random::Rng;

/// The box around `tris`.
pub fn bounds(tris: &[[Vec3; 3]]) -> Aabb {
    tris.iter().fold(Aabb::EMPTY, |b, t| b.union(Aabb::from_points(t)))
}

/// The closest hit of `ray` among `tris` (by index), testing every one: the answer a
/// traversal must give, up to ties.
pub fn brute_force(tris: &[[Vec3; 3]], ray: &Ray) -> Option<(u32, TriHit)> {
    let mut best: Option<(u32, TriHit)> = None;
    for (i, t) in tris.iter().enumerate() {
        let t_max = best.map_or(f32::INFINITY, |(_, h)| h.t);
        if let Some(h) = intersect_triangle(ray, t[0], t[1] - t[0], t[2] - t[0], 0.0, t_max) {
            best = Some((i as u32, h));
        }
    }
    best
}

/// Zero-area triangles collapsed onto their first corner, so that neither brute force nor
/// a traversal "hits" them.
///
/// Möller–Trumbore's determinant of a (nearly) degenerate triangle is rounding noise that
/// can pass its absolute threshold and yield hits far outside the triangle's box; brute
/// force would report those and the BVH (rightly) cull them, as the packer zeroes their
/// edges. A collapsed triangle has exactly zero edges and never hits. Trees are still built
/// over the original corners.
pub fn hittable(tris: &[[Vec3; 3]]) -> Vec<[Vec3; 3]> {
    tris.iter()
        .map(|&[a, b, c]| {
            let (e1, e2) = (b - a, c - a);
            if e1.cross(e2).length() <= 1e-5 * e1.length() * e2.length() {
                [a, a, a]
            } else {
                [a, b, c]
            }
        })
        .collect()
}

/// Where on a target triangle [`random_rays`] aims.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Aim {
    /// A uniform random point of the triangle, its edges included.
    Anywhere,
    /// A point well inside it (barycentric u, v in 0.05..0.45), off its edges.
    Inside,
}

/// `count` random rays: origins inside and around the bounds of `tris` (a unit box when it
/// is empty), every other one aimed at a point of a random triangle of `targets` (so that
/// most hit, placed as `aim` says), the others in uniform random directions.
pub fn random_rays(
    rng: &mut Rng,
    tris: &[[Vec3; 3]],
    targets: &[[Vec3; 3]],
    aim: Aim,
    count: usize,
) -> Vec<Ray> {
    let b = if tris.is_empty() { Aabb { min: Vec3::ZERO, max: Vec3::ONE } } else { bounds(tris) };
    let pad = b.extent().max_element().max(1e-3);
    let around = Aabb { min: b.min - pad, max: b.max + pad };
    (0..count)
        .map(|i| {
            let origin = if i % 3 == 0 { rng.vec_in(&b) } else { rng.vec_in(&around) };
            let dir = if i % 2 == 0 && !targets.is_empty() {
                let t = targets[rng.below(targets.len())];
                let (u, v) = match aim {
                    Aim::Anywhere => match (rng.f(), rng.f()) {
                        (u, v) if u + v > 1.0 => (1.0 - u, 1.0 - v),
                        uv => uv,
                    },
                    Aim::Inside => (rng.range(0.05, 0.45), rng.range(0.05, 0.45)),
                };
                let target = t[0] + (t[1] - t[0]) * u + (t[2] - t[0]) * v;
                (target - origin).try_normalize().unwrap_or(Vec3::Z)
            } else {
                rng.unit()
            };
            Ray::new(origin, dir)
        })
        .collect()
}
