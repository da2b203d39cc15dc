//! The CPU tracer's walk over the instances: the top level, then each instance's mesh in
//! its own space (the shader's `trace_instances` and `visit_instance`).

use glam::Vec3;

use super::{CpuScene, SceneHit};
use crate::bvh::wide::WideNode;
use crate::bvh::{self, TraversalStats};
use crate::contract::EMPTY;
use crate::geometry::{intersect_triangle, safe_inverse, Ray};
use crate::render_settings::{Accel, BvhLayout};
use crate::tracer::enclosure::EnclosureRecord;
use crate::tracer::packed::GpuInstance;
use crate::tracer::top_level::{self, Target, Visit};

/// What a walk over the instances looks for: the closest hit, or any hit (occlusion).
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum Query {
    Closest,
    Any,
}

impl CpuScene<'_> {
    /// The shader's `trace_instances`: every instance whose box the ray meets before the
    /// closest hit so far, through the top level (brute force: every instance, no culling),
    /// calling `found(instance, hit)` for each hit closer than the last; the walk ends
    /// when it says [`Visit::Blocked`] (occlusion), which is returned as true. An
    /// `instance_count` of 0 traces nothing; otherwise every instance is traced.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn trace_instances(
        &self,
        ray: &Ray,
        (t_max, query): (f32, Query),
        accel: Accel,
        layout: BvhLayout,
        instance_count: u32,
        stats: &mut TraversalStats,
        mut found: impl FnMut(u32, SceneHit) -> Visit,
    ) -> bool {
        if instance_count == 0 {
            return false;
        }
        let layout = self.packed.traced_layout(layout);
        let top = &self.packed.top_level;
        // The CPU reference has no vendor traversal: it traces vendor frames with our BVH.
        let brute = accel == Accel::Brute;
        let any = query == Query::Any;
        let visit = |i: u32, t_max: f32, stats: &mut TraversalStats| {
            let inst = &top.instances[i as usize];
            self.visit_instance(inst, ray, t_max, brute, any, layout, stats)
        };
        if brute {
            let mut t = t_max;
            for i in 0..top.instances.len() as u32 {
                let Some(hit) = visit(i, t, stats) else { continue };
                match found(i, hit) {
                    Visit::Nothing => {}
                    Visit::Closer(closer) => t = closer,
                    Visit::Blocked => return true,
                }
            }
            return false;
        }
        let mut inner = TraversalStats::default();
        let blocked = top_level::walk(&top.nodes, ray, t_max, stats, |target, t| {
            let (i, hit) = match target {
                Target::Instance(i) => (i, visit(i, t, &mut inner)),
                Target::ClosedBox(record) => {
                    (record.instance(), self.closed_box_hit(record, ray, t, &mut inner)?)
                }
            };
            Some(hit.map_or(Visit::Nothing, |hit| found(i, hit)))
        });
        stats.nodes += inner.nodes;
        stats.triangles += inner.triangles;
        blocked
    }

    /// The enclosure of `record` tested as a closed box (the shader's `closed_box_hit`):
    /// from inside, the two triangles of the face the ray leaves by (all twelve where
    /// rounding lets the ray slip between them, or from outside). None where it is no
    /// closed box; Some(None) for no hit in (0, t_max).
    fn closed_box_hit(
        &self,
        record: &EnclosureRecord,
        ray: &Ray,
        t_max: f32,
        stats: &mut TraversalStats,
    ) -> Option<Option<SceneHit>> {
        let closed = record.closed_box()?;
        let inst = &self.packed.top_level.instances[record.instance() as usize];
        let (min, max) = (closed.bounds.min, closed.bounds.max);
        let origin = inst.point_to_object(ray.origin);
        let dir = inst.vector_to_object(ray.dir);
        let local = Ray::new(origin, dir);
        let base = inst.triangle_base as usize;
        let mut best = None;
        let mut test = |k: usize| {
            let [v0, e1, e2] = self.edges[base + k];
            let t = best.as_ref().map_or(t_max, |b: &SceneHit| b.t);
            if let Some(h) = intersect_triangle(&local, v0, e1, e2, 0.0, t) {
                let triangle = (base + k) as u32;
                best = Some(SceneHit { t: h.t, u: h.u, v: h.v, triangle, instance: 0 });
            }
            best.is_some()
        };
        if origin.cmplt(min).any() || origin.cmpgt(max).any() {
            // From outside: all twelve, as the shader's brute force.
            for k in 0..12 {
                test(k);
            }
            stats.triangles += 12;
            return Some(best);
        }
        let up = dir.cmpge(Vec3::ZERO);
        let t3 = (Vec3::select(up, max, min) - origin) * safe_inverse(dir);
        let axis = if t3.x <= t3.y && t3.x <= t3.z {
            0
        } else if t3.y <= t3.z {
            1
        } else {
            2
        };
        if t3[axis] > t_max * 1.0001 {
            return Some(None); // the wall lies beyond
        }
        let face = 2 * axis + usize::from(up.test(axis));
        let hits = closed.faces[face].map(|k| test(usize::from(k)));
        stats.triangles += 2;
        if hits == [false; 2] {
            // Slipped between the face's triangles: all twelve, as the shader's brute force.
            for k in 0..12 {
                test(k);
            }
            stats.triangles += 12;
        }
        Some(best)
    }

    /// One instance's mesh along `ray` in (0, t_max), in the mesh's space (the shader's
    /// `visit_instance`): its closest hit there, or with `any` a hit that blocks the ray.
    #[allow(clippy::too_many_arguments)]
    fn visit_instance(
        &self,
        inst: &GpuInstance,
        ray: &Ray,
        t_max: f32,
        brute: bool,
        any: bool,
        layout: BvhLayout,
        stats: &mut TraversalStats,
    ) -> Option<SceneHit> {
        if inst.node_base == EMPTY {
            return None; // no triangles, and so no nodes of its own
        }
        let local = Ray::new(inst.point_to_object(ray.origin), inst.vector_to_object(ray.dir));
        let base = inst.triangle_base as usize;
        let count = self.packed.top_level.meshes[inst.mesh as usize].triangle_count as usize;
        let tris = &self.edges[base..base + count];
        let hit = |k: usize, h: crate::geometry::TriHit| SceneHit {
            t: h.t,
            u: h.u,
            v: h.v,
            triangle: (base + k) as u32,
            instance: 0,
        };
        if brute {
            let mut best = None;
            let mut t = t_max;
            // The shader's brute force tests blocks of eight and counts them whole.
            for (block, chunk) in tris.chunks(8).enumerate() {
                stats.triangles += chunk.len() as u32;
                for (j, [v0, e1, e2]) in chunk.iter().enumerate() {
                    if let Some(h) = intersect_triangle(&local, *v0, *e1, *e2, 0.0, t) {
                        t = h.t;
                        best = Some(hit(block * 8 + j, h));
                    }
                }
                if any && best.is_some() {
                    break;
                }
            }
            return best;
        }
        // The mesh's bounding sphere first, where it has one (as the shader's visit).
        let sphere = self.packed.top_level.meshes[inst.mesh as usize].sphere;
        if self.spheres_tested && sphere[3] > 0.0 && !meets_sphere(&local, sphere, t_max) {
            return None;
        }
        // The instance's nodes start at its node base, their indices relative to it (and to
        // the triangle base), as the shader's traverse_bvh reads them.
        let wide = self.wide_nodes(inst, layout);
        let binary = &self.packed.nodes[inst.node_base as usize..];
        if any {
            let blocked = match wide {
                Some(nodes) => bvh::wide::any_hit(nodes, tris, &local, 0.0, t_max, stats),
                None => bvh::any_hit(binary, tris, &local, 0.0, t_max, stats),
            };
            // Where it is blocked does not matter to the query.
            let anywhere = SceneHit { t: t_max, u: 0.0, v: 0.0, triangle: 0, instance: 0 };
            return blocked.then_some(anywhere);
        }
        let found = match wide {
            Some(nodes) => bvh::wide::closest_hit(nodes, tris, &local, 0.0, t_max, stats),
            None => bvh::closest_hit(binary, tris, &local, 0.0, t_max, stats),
        };
        found.map(|(k, h)| hit(k as usize, h))
    }

    /// The wide nodes `inst` is traced through in a frame of `layout`: None for binary
    /// frames, and where the wide layout was not packed or the mesh has no wide tree (its
    /// binary tree then serves, as on the GPU).
    fn wide_nodes(&self, inst: &GpuInstance, layout: BvhLayout) -> Option<&[WideNode]> {
        Some(self.packed.wide_nodes_of(inst)).filter(|nodes| layout.is_wide() && !nodes.is_empty())
    }
}

/// Whether `ray` meets the sphere `[centre, radius]` for some t in [0, t_max], loosely (the
/// shader's `meets_sphere`, step for step): yes for a ray that passes by within rounding,
/// never no for one that meets it. From the ray's closest approach to the centre, which
/// keeps its precision far from the sphere (Haines et al., Ray Tracing Gems, chapter 7).
fn meets_sphere(ray: &Ray, sphere: [f32; 4], t_max: f32) -> bool {
    let [x, y, z, radius] = sphere;
    let oc = ray.origin - Vec3::new(x, y, z);
    let inv_a = 1.0 / ray.dir.dot(ray.dir);
    let tm = -oc.dot(ray.dir) * inv_a;
    let l = oc + tm * ray.dir;
    let r = radius + 1e-5 * (radius + oc.length());
    let h2 = r * r - l.dot(l);
    if h2 < 0.0 {
        return false;
    }
    let dt = (h2 * inv_a).sqrt();
    tm + dt >= 0.0 && tm - dt <= t_max * 1.0001
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The ray against the sphere in double precision: the distance by which it misses
    /// (negative: how deep it passes inside), its entry and exit, and the slack a clear
    /// miss must exceed (a hundredth of the radius, and the test's own padding for rays
    /// from far away), as a distance and along the ray.
    fn exact(ray: &Ray, sphere: [f32; 4]) -> (f64, f64, f64, f64, f64) {
        let d = ray.dir.as_dvec3();
        let oc = ray.origin.as_dvec3() - Vec3::new(sphere[0], sphere[1], sphere[2]).as_dvec3();
        let tm = -oc.dot(d) / d.dot(d);
        let closest = (oc + tm * d).length();
        let r = f64::from(sphere[3]);
        let half = (r * r - closest * closest).max(0.0).sqrt() / d.length();
        let slack = 0.01 * r + 1e-4 * oc.length();
        (closest - r, tm - half, tm + half, slack, slack / d.length())
    }

    #[test]
    fn the_sphere_test_never_turns_away_a_ray_that_meets_the_sphere() {
        // Rays from near and far (up to 10^4 radii), with directions of any length (an
        // instance's scale), grazing, missing by a little and passing through.
        let mut seed = 7u32;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            seed as f32 / u32::MAX as f32
        };
        let (mut met, mut turned_away) = (0, 0);
        for _ in 0..20_000 {
            let radius = 10f32.powf(next() * 6.0 - 3.0);
            let centre = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * radius * 20.0;
            let sphere = [centre.x, centre.y, centre.z, radius];
            let away = radius * 10f32.powf(next() * 4.0);
            let origin = centre + Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 2.0 * away;
            // Aim at a point near the sphere's surface: inside, on it, or just outside.
            let aim = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize_or(Vec3::X);
            let target = centre + aim * radius * (0.9 + 0.2 * next());
            let dir = (target - origin) * 10f32.powf(next() * 4.0 - 2.0);
            if dir.length_squared() == 0.0 || !dir.is_finite() {
                continue;
            }
            let ray = Ray::new(origin, dir);
            let t_max = if next() < 0.5 { f32::INFINITY } else { next() * 2.0 };
            let (miss, enter, exit, slack, slack_t) = exact(&ray, sphere);
            let meets = miss <= 0.0 && exit >= 0.0 && enter <= f64::from(t_max);
            let said = meets_sphere(&ray, sphere, t_max);
            assert!(said || !meets, "{ray:?} meets {sphere:?} before {t_max}");
            met += usize::from(meets);
            // Clear misses (beside, behind or beyond t_max by more than the slack) are
            // turned away: the test is no constant yes.
            let clear =
                miss > slack || exit < -slack_t || enter > 1.01 * f64::from(t_max) + slack_t;
            turned_away += usize::from(clear && !said);
            assert!(said == meets || !clear, "{ray:?} clearly misses {sphere:?} before {t_max}");
        }
        assert!(met > 3_000 && turned_away > 3_000, "{met} met, {turned_away} turned away");
    }
}
