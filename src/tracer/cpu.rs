//! The CPU reference tracer: the same mathematics as `shaders/trace.comp`, over the same
//! packed arrays, in plain Rust (rows in parallel with rayon). The tests use it as the
//! oracle for the GPU; `render --cpu` uses it where no Vulkan device exists.

use glam::Vec3;
use rayon::prelude::*;

use super::frame::{Accel, Aov, FrameParams};
use super::image::Image;
use super::packed::PackedScene;
use super::shading::{blinn_phong, reflect, ShadingMaterial};
use crate::bvh::TraversalStats;
use crate::geometry::{intersect_triangle, Aabb, Ray};

/// A closest hit in the packed scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneHit {
    pub t: f32,
    pub u: f32,
    pub v: f32,
    /// Index into `PackedScene::triangles`.
    pub triangle: u32,
    /// Index into `PackedScene::instances`.
    pub instance: u32,
}

/// The packed scene with each mesh's triangles as (v0, e1, e2) triples, as BVH traversal wants.
pub struct CpuScene<'a> {
    packed: &'a PackedScene,
    edges: Vec<[Vec3; 3]>,
}

impl<'a> CpuScene<'a> {
    /// Prepare a packed scene for CPU tracing.
    pub fn new(packed: &'a PackedScene) -> Self {
        Self { packed, edges: packed.triangles.iter().map(|t| t.edges()).collect() }
    }

    /// Closest hit over the first `instance_count` instances, in (0, inf).
    pub fn closest_hit(&self, ray: &Ray, accel: Accel, instance_count: u32, stats: &mut TraversalStats) -> Option<SceneHit> {
        let mut best: Option<SceneHit> = None;
        let inv_dir = crate::geometry::safe_inverse(ray.dir);
        for (i, inst) in self.packed.instances.iter().take(instance_count as usize).enumerate() {
            if accel == Accel::Bvh {
                let bounds = Aabb { min: Vec3::from_slice(&inst.bounds_min[..3]), max: Vec3::from_slice(&inst.bounds_max[..3]) };
                if bounds.intersect(ray, inv_dir, best.map_or(f32::INFINITY, |h| h.t)).is_none() {
                    continue;
                }
            }
            // Uniform scale: the object-space ray keeps world-space distances.
            let local = Ray::new((ray.origin - Vec3::from(inst.translation)) / inst.scale, ray.dir / inst.scale);
            let t_max = best.map_or(f32::INFINITY, |h| h.t);
            let base = inst.triangle_base as usize;
            let tris = &self.edges[base..base + inst.triangle_count as usize];
            match accel {
                Accel::Brute => {
                    stats.triangles += inst.triangle_count;
                    for (k, [v0, e1, e2]) in tris.iter().enumerate() {
                        let t_max = best.map_or(f32::INFINITY, |h| h.t);
                        if let Some(h) = intersect_triangle(&local, *v0, *e1, *e2, 0.0, t_max) {
                            best = Some(SceneHit { t: h.t, u: h.u, v: h.v, triangle: (base + k) as u32, instance: i as u32 });
                        }
                    }
                }
                Accel::Bvh => {
                    let mesh = self.packed.meshes.iter().find(|m| m.triangle_base == inst.triangle_base).expect("instance mesh");
                    if let Some((k, h)) = mesh.bvh.closest_hit(tris, &local, 0.0, t_max, stats) {
                        best = Some(SceneHit { t: h.t, u: h.u, v: h.v, triangle: inst.triangle_base + k, instance: i as u32 });
                    }
                }
            }
        }
        best
    }

    fn material(&self, triangle: u32) -> ShadingMaterial {
        let m = &self.packed.materials[self.packed.triangles[triangle as usize].material as usize];
        ShadingMaterial { diffuse: m.diffuse.into(), specular: m.specular.into(), shininess: m.shininess, mirror: m.mirror }
    }

    /// Trace one pixel: the colour (or AOV) the shader would write.
    pub fn trace_pixel(&self, params: &FrameParams, px: u32, py: u32) -> [f32; 4] {
        let s = &params.settings;
        let mut ray = params.camera.primary_ray(px, py, s.width, s.height);
        let bounces = if matches!(s.aov, Aov::Color | Aov::Cost) { s.bounces } else { 0 };
        let background = params.background_quantized();
        let mut color = Vec3::ZERO;
        let mut throughput = 1.0f32;
        let mut aux = [-1.0f32, -1.0, -1.0, 0.0];
        let mut stats = TraversalStats::default();

        for bounce in 0..=bounces {
            let Some(hit) = self.closest_hit(&ray, s.accel, params.instance_count, &mut stats) else {
                color += throughput * background;
                if bounce == 0 && s.aov == Aov::Normal {
                    aux = [0.0; 4];
                }
                break;
            };
            let tri = &self.packed.triangles[hit.triangle as usize];
            let p = ray.at(hit.t);
            let mut n = Vec3::from(tri.e1).cross(Vec3::from(tri.e2)).normalize();
            if n.dot(ray.dir) > 0.0 {
                n = -n;
            }
            let mat = self.material(hit.triangle);
            let local = blinn_phong(&mat, p, n, -ray.dir, params.light_position, params.light_color, params.ambient);
            if bounce == 0 {
                let prim = (tri.prim + self.packed.instances[hit.instance as usize].prim_base) as f32;
                match s.aov {
                    Aov::Depth => aux = [hit.t, hit.t, hit.t, 1.0],
                    Aov::Normal => aux = [n.x, n.y, n.z, 1.0],
                    Aov::PrimId => aux = [prim, prim, prim, 1.0],
                    Aov::Color | Aov::Cost => {}
                }
            }
            let r = s.blend * mat.mirror;
            if bounce == bounces {
                color += throughput * local;
                break;
            }
            color += throughput * (1.0 - r) * local;
            throughput *= r;
            if r <= 0.0 {
                break;
            }
            ray = Ray::new(p + n * params.ray_epsilon, reflect(ray.dir, n));
        }
        match s.aov {
            Aov::Color => [color.x, color.y, color.z, 1.0],
            Aov::Cost => [stats.nodes as f32, stats.triangles as f32, 0.0, 1.0],
            _ => aux,
        }
    }
}

/// Render a whole frame on the CPU.
pub fn render(packed: &PackedScene, params: &FrameParams) -> Image {
    let scene = CpuScene::new(packed);
    let (w, h) = (params.settings.width, params.settings.height);
    let mut image = Image::new(w, h);
    image.pixels.par_chunks_mut(w as usize).enumerate().for_each(|(y, row)| {
        for (x, px) in row.iter_mut().enumerate() {
            *px = scene.trace_pixel(params, x as u32, y as u32);
        }
    });
    image
}
