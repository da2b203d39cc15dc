//! The CPU tracer's walk over the instances: the top level, then each instance's mesh in
//! its own space (the shader's `trace_instances` and `visit_instance`).

use super::{CpuScene, SceneHit};
use crate::bvh::wide::WideNode;
use crate::bvh::{self, TraversalStats};
use crate::contract::EMPTY;
use crate::geometry::{intersect_triangle, Ray};
use crate::render_settings::{Accel, BvhLayout};
use crate::tracer::packed::GpuInstance;
use crate::tracer::top_level::{self, Visit};

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
        let mut visit = |i: u32, t_max: f32, stats: &mut TraversalStats| match self.visit_instance(
            &top.instances[i as usize],
            ray,
            t_max,
            brute,
            any,
            layout,
            stats,
        ) {
            Some(hit) => found(i, hit),
            None => Visit::Nothing,
        };
        if brute {
            let mut t = t_max;
            for i in 0..top.instances.len() as u32 {
                match visit(i, t, stats) {
                    Visit::Nothing => {}
                    Visit::Closer(closer) => t = closer,
                    Visit::Blocked => return true,
                }
            }
            return false;
        }
        let mut inner = TraversalStats::default();
        let blocked =
            top_level::walk(&top.nodes, ray, t_max, stats, |i, t| visit(i, t, &mut inner));
        stats.nodes += inner.nodes;
        stats.triangles += inner.triangles;
        blocked
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
