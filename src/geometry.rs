//! Rays, boxes and the Möller–Trumbore ray/triangle test: the geometric kernel shared by
//! the CPU reference tracer, the BVH builder and its tests (the compute shader mirrors it).

use glam::Vec3;

/// A ray `origin + t * dir`; `dir` need not be normalised (instances scale it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub(crate) origin: Vec3,
    pub dir: Vec3,
}

impl Ray {
    /// Build a ray from an origin and a direction.
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Self { origin, dir }
    }

    /// The point at parameter `t`.
    pub(crate) fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }
}

/// An axis-aligned bounding box. The empty box has `min > max` so that growing it works.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Default for Aabb {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl Aabb {
    /// The empty box (contains nothing; any `grow` replaces it).
    pub const EMPTY: Aabb =
        Aabb { min: Vec3::splat(f32::INFINITY), max: Vec3::splat(f32::NEG_INFINITY) };

    /// The box of a set of points.
    pub fn from_points(points: &[Vec3]) -> Self {
        points.iter().fold(Self::EMPTY, |b, &p| b.grow_point(p))
    }

    /// This box grown to contain `p`.
    pub(crate) fn grow_point(self, p: Vec3) -> Self {
        Self { min: self.min.min(p), max: self.max.max(p) }
    }

    /// The union of two boxes.
    pub fn union(self, o: Aabb) -> Self {
        Self { min: self.min.min(o.min), max: self.max.max(o.max) }
    }

    /// True when the box contains nothing.
    pub(crate) fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    /// Box centre.
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// Edge lengths (zero for the empty box).
    pub fn extent(&self) -> Vec3 {
        if self.is_empty() {
            Vec3::ZERO
        } else {
            self.max - self.min
        }
    }

    /// True when `o` lies inside this box (with a small relative slack for float noise).
    pub(crate) fn contains(&self, o: &Aabb) -> bool {
        let slack = (self.extent().max_element() * 1e-6).max(1e-30);
        o.is_empty() || (o.min.cmpge(self.min - slack).all() && o.max.cmple(self.max + slack).all())
    }

    /// True when the two boxes share a point (touching counts).
    pub(crate) fn overlaps(&self, o: &Aabb) -> bool {
        self.min.cmple(o.max).all() && o.min.cmple(self.max).all()
    }

    /// Slab test: the entry distance if the ray meets the box within `(0, t_max)`.
    pub(crate) fn intersect(&self, ray: &Ray, inv_dir: Vec3, t_max: f32) -> Option<f32> {
        let t0 = (self.min - ray.origin) * inv_dir;
        let t1 = (self.max - ray.origin) * inv_dir;
        let tmin = t0.min(t1).max_element().max(0.0);
        // Widened as in pbrt (1 + 2*gamma3): rays through a box corner are not lost to rounding.
        let tmax = t0.max(t1).min_element().min(t_max) * 1.000_000_4;
        (tmin <= tmax).then_some(tmin)
    }
}

/// `1 / d` without infinities: a zero component becomes ±1e20 (0 * inf would give NaN in
/// the slab test). The shader's `safe_inverse` does the same.
pub(crate) fn safe_inverse(d: Vec3) -> Vec3 {
    let fix = |c: f32| if c < 0.0 { -c.abs().max(1e-20) } else { c.max(1e-20) };
    Vec3::new(fix(d.x), fix(d.y), fix(d.z)).recip()
}

/// A ray/triangle hit: distance along the ray and the barycentrics of corners 1 and 2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriHit {
    pub t: f32,
    pub(crate) u: f32,
    pub(crate) v: f32,
}

/// Möller–Trumbore, as in the paper (3.3): solve `O + tD = (1-u-v)V0 + uV1 + vV2` with
/// `E1 = V1-V0, E2 = V2-V0, P = D×E2, Q = T×E1`. Accepts hits with `t_min < t < t_max`;
/// both faces count (the mirror box is seen from inside). Edge-on and degenerate
/// triangles (|det| tiny) never hit.
#[inline]
pub fn intersect_triangle(
    ray: &Ray,
    v0: Vec3,
    e1: Vec3,
    e2: Vec3,
    t_min: f32,
    t_max: f32,
) -> Option<TriHit> {
    let p = ray.dir.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-12 {
        return None;
    }
    let inv = 1.0 / det;
    let tv = ray.origin - v0;
    let u = tv.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = tv.cross(e1);
    let v = ray.dir.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    (t > t_min && t < t_max).then_some(TriHit { t, u, v })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangle_hit_has_analytic_distance_and_barycentrics() {
        let ray = Ray::new(Vec3::new(0.25, 0.25, 5.0), Vec3::new(0.0, 0.0, -1.0));
        let h = intersect_triangle(&ray, Vec3::ZERO, Vec3::X, Vec3::Y, 0.0, f32::INFINITY).unwrap();
        assert!((h.t - 5.0).abs() < 1e-6);
        assert!((h.u - 0.25).abs() < 1e-6 && (h.v - 0.25).abs() < 1e-6);
    }

    #[test]
    fn triangle_misses_outside_edges_and_behind() {
        let v0 = Vec3::ZERO;
        let down = Vec3::new(0.0, 0.0, -1.0);
        assert!(intersect_triangle(
            &Ray::new(Vec3::new(0.8, 0.8, 1.0), down),
            v0,
            Vec3::X,
            Vec3::Y,
            0.0,
            1e30
        )
        .is_none());
        assert!(intersect_triangle(
            &Ray::new(Vec3::new(0.2, 0.2, -1.0), down),
            v0,
            Vec3::X,
            Vec3::Y,
            0.0,
            1e30
        )
        .is_none());
        // Degenerate (zero-area) triangle never hits.
        assert!(intersect_triangle(
            &Ray::new(Vec3::new(0.0, 0.0, 1.0), down),
            v0,
            Vec3::X,
            Vec3::X * 2.0,
            0.0,
            1e30
        )
        .is_none());
    }

    #[test]
    fn aabb_slab_test() {
        let b = Aabb { min: Vec3::splat(-1.0), max: Vec3::splat(1.0) };
        let r = Ray::new(Vec3::new(0.0, 0.0, 5.0), Vec3::new(0.0, 0.0, -1.0));
        assert_eq!(b.intersect(&r, r.dir.recip(), 100.0), Some(4.0));
        assert_eq!(b.intersect(&r, r.dir.recip(), 3.0), None);
    }
}
