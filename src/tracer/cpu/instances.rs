//! The CPU tracer's walk over the instances: the top level, then each instance's mesh in
//! its own space (the shader's `trace_instances` and `visit_instance`).

use super::{CpuScene, SceneHit};
use crate::bvh::wide::WideNode;
use crate::bvh::{self, TraversalStats};
use crate::contract::EMPTY;
use crate::geometry::{intersect_triangle, Ray};
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
    /// `instance_count` of 0 traces nothing; otherwise every instance is traced but `skip`
    /// (`EMPTY` for none), which is never visited.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn trace_instances(
        &self,
        ray: &Ray,
        (t_max, query, skip): (f32, Query, u32),
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
            for i in (0..top.instances.len() as u32).filter(|&i| i != skip) {
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
                Target::Instance(i) if i == skip => return Some(Visit::Nothing),
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
    /// from inside, the face the ray leaves by, found without testing a triangle
    /// ([`ClosedBox::exit`](crate::tracer::enclosure::ClosedBox::exit)); from outside,
    /// all twelve triangles. None where it is no closed box; Some(None) for no hit in
    /// (0, t_max).
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
        let base = inst.triangle_base as usize;
        if origin.cmplt(min).any() || origin.cmpgt(max).any() {
            // From outside: all twelve, as the shader's brute force.
            let local = Ray::new(origin, dir);
            let mut best = None;
            for k in 0..12 {
                let [v0, e1, e2] = self.edges[base + k];
                let t = best.as_ref().map_or(t_max, |b: &SceneHit| b.t);
                if let Some(h) = intersect_triangle(&local, v0, e1, e2, 0.0, t) {
                    let triangle = (base + k) as u32;
                    best = Some(SceneHit { t: h.t, u: h.u, v: h.v, triangle, instance: 0 });
                }
            }
            stats.triangles += 12;
            return Some(best);
        }
        match closed.exit(origin, dir) {
            Some(exit) if exit.t > t_max * 1.0001 => Some(None), // the wall lies beyond
            exit => {
                stats.triangles += 1;
                Some(exit.filter(|e| e.t < t_max).map(|e| SceneHit {
                    t: e.t,
                    u: e.u,
                    v: e.v,
                    triangle: (base + usize::from(e.slot)) as u32,
                    instance: 0,
                }))
            }
        }
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
