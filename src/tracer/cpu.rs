//! The CPU reference tracer: the same mathematics as `shaders/trace.comp`, over the same
//! packed arrays, in plain Rust (rows in parallel with rayon). The tests use it as the
//! oracle for the GPU; `render --cpu` uses it where no Vulkan device exists.

use glam::{Vec2, Vec3, Vec4};
use rayon::prelude::*;

use super::frame::FrameParams;
use super::image::Image;
use super::packed::{
    GpuInstance, GpuMaterial, GpuTriangle, GpuTriangleShading, PackedScene, NO_TEXTURE,
};
use super::shading::{
    ao_direction, blinn_phong, light_reaches, reflect, ShadingMaterial, SmoothTriangle,
};
use super::top_level::Visit;
use crate::bvh::TraversalStats;
use crate::contract::{self, EMPTY};
use crate::geometry::Ray;
use crate::render_settings::{Accel, Aov, BvhLayout, RenderSettings};

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

mod instances;
use instances::Query;

/// The shader's PCG hash, for identical sample jitter on both tracers.
pub(crate) fn pcg(v: u32) -> u32 {
    let state = v.wrapping_mul(747796405).wrapping_add(2891336453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277803737);
    (word >> 22) ^ word
}

/// A path's surfaces count towards its key while their weight still shows in 8 bits, so
/// an edge seen in a mirror is an edge (the shader's `KEY_MIN_THROUGHPUT`).
const KEY_MIN_THROUGHPUT: f32 = 1.0 / 256.0;

/// The shader's `add_to_path_key`.
fn add_to_path_key(key: &mut u32, surface: u32, throughput: f32) {
    if throughput >= KEY_MIN_THROUGHPUT {
        *key = pcg(*key ^ surface);
    }
}

fn random01(seed: &mut u32) -> f32 {
    *seed = pcg(*seed);
    (*seed >> 8) as f32 * (1.0 / 16777216.0)
}

/// Where a camera path meets a triangle: what shading it needs of the hit.
struct Surface<'a> {
    tri: &'a GpuTriangle,
    shading: &'a GpuTriangleShading,
    /// The hit point.
    p: Vec3,
    /// The triangle's edges from its first corner.
    e1: Vec3,
    e2: Vec3,
    /// The instance the triangle was hit in.
    inst: &'a GpuInstance,
    /// Geometric and shading normals (world space), both facing the ray's origin.
    ng: Vec3,
    ns: Vec3,
    /// The same normals in the mesh's space.
    object: ObjectNormals,
    /// Whether the ray met the triangle's back, as `cross(e1, e2)` faces (the normals
    /// above are turned to face it).
    back: bool,
    /// The first corner's barycentric weight (`1 - u - v`).
    w: f32,
    /// The corner normals for the terminator offset, when smooth shading applies.
    smooth: Option<SmoothTriangle>,
}

/// A hit's geometric and shading normals in its mesh's space, facing the viewer.
struct ObjectNormals {
    ng: Vec3,
    ns: Vec3,
}

/// The packed scene, its triangles also as (v0, e1, e2) `Vec3` triples in the packed order,
/// as the intersection tests want them.
pub struct CpuScene<'a> {
    packed: &'a PackedScene,
    edges: Vec<[Vec3; 3]>,
}

impl<'a> CpuScene<'a> {
    /// Prepare a packed scene for CPU tracing.
    pub fn new(packed: &'a PackedScene) -> Self {
        Self { packed, edges: packed.triangles.iter().map(|t| t.edges()).collect() }
    }

    /// Closest hit over the first `instance_count` instances, in (0, inf), through the binary
    /// BVH (the wide one in a scene packed for wide frames alone).
    pub fn closest_hit(
        &self,
        ray: &Ray,
        accel: Accel,
        instance_count: u32,
        stats: &mut TraversalStats,
    ) -> Option<SceneHit> {
        self.closest_hit_in(ray, accel, BvhLayout::Binary, instance_count, EMPTY, stats)
    }

    /// [`closest_hit`](Self::closest_hit) through the BVH of the given layout, where packed,
    /// never visiting instance `skip` (`EMPTY` for none; [`CpuScene::left_behind`]).
    pub fn closest_hit_in(
        &self,
        ray: &Ray,
        accel: Accel,
        layout: BvhLayout,
        instance_count: u32,
        skip: u32,
        stats: &mut TraversalStats,
    ) -> Option<SceneHit> {
        let mut best: Option<SceneHit> = None;
        let query = (f32::INFINITY, Query::Closest, skip);
        self.trace_instances(ray, query, accel, layout, instance_count, stats, |i, hit| {
            best = Some(SceneHit { instance: i, ..hit });
            Visit::Closer(hit.t)
        });
        best
    }

    /// Whether anything of the scene but instance `skip` lies along `ray` in (0, t_max):
    /// the AO view's occlusion query, the shader's `any_hit` (the vendor's frames with our
    /// BVH, as for closest hits), through `layout` where it is packed.
    #[allow(clippy::too_many_arguments)]
    pub fn any_hit(
        &self,
        ray: &Ray,
        t_max: f32,
        accel: Accel,
        layout: BvhLayout,
        instance_count: u32,
        skip: u32,
        stats: &mut TraversalStats,
    ) -> bool {
        let query = (t_max, Query::Any, skip);
        self.trace_instances(ray, query, accel, layout, instance_count, stats, |_, _| {
            Visit::Blocked
        })
    }

    /// The AO view's value at hit point `p`: the share of the frame's AO rays from `p`
    /// (lifted along `ng`) around `ns` that meet nothing within the radius, instance `skip`
    /// unvisited; the shader's `ambient_occlusion`, drawing the same directions from
    /// `sample_seed`.
    #[allow(clippy::too_many_arguments)]
    fn ambient_occlusion(
        &self,
        params: &FrameParams,
        p: Vec3,
        ng: Vec3,
        ns: Vec3,
        sample_seed: u32,
        skip: u32,
        stats: &mut TraversalStats,
    ) -> f32 {
        let s = &params.settings;
        let origin = p + ng * params.ray_epsilon;
        let open = (0..s.ao_samples)
            .filter(|&j| {
                let mut seed = pcg(sample_seed ^ pcg(j.wrapping_add(contract::AO_SEED_SALT)));
                let u1 = random01(&mut seed);
                let u2 = random01(&mut seed);
                let ray = Ray::new(origin, ao_direction(ns, ng, u1, u2));
                !self.any_hit(&ray, s.ao_radius, s.accel, s.bvh, params.instance_count, skip, stats)
            })
            .count();
        open as f32 / s.ao_samples.max(1) as f32
    }

    fn environment(&self, d: Vec3) -> Vec3 {
        self.packed.environment.as_ref().map_or(Vec3::ZERO, |env| env.sample(d))
    }

    /// One camera sample through image position `pos` (pixel units): colour or AOV. With
    /// `path_key`, also folds the surfaces along the path into it (the shader's pre-pass).
    /// `sample_seed` seeds the AO view's rays.
    fn trace_sample(
        &self,
        params: &FrameParams,
        pos: Vec2,
        sample_seed: u32,
        stats: &mut TraversalStats,
        mut path_key: Option<&mut u32>,
    ) -> Vec4 {
        let s = &params.settings;
        let mut ray = params.camera.ray_at(pos.x, pos.y, s.width, s.height);
        let bounces =
            if matches!(s.aov, Aov::Color | Aov::Cost | Aov::Samples) { s.bounces } else { 0 };
        let spread = 2.0 * params.camera.up.length() / s.height as f32;
        let mut path_length = 0.0f32;
        let mut color = Vec3::ZERO;
        let mut throughput = 1.0f32;
        let mut aux = Vec4::new(-1.0, -1.0, -1.0, 0.0);
        // The instance the next ray cannot meet (`left_behind`): none for the camera's.
        let mut skip = EMPTY;

        for bounce in 0..=bounces {
            let hit = self.closest_hit_in(&ray, s.accel, s.bvh, params.instance_count, skip, stats);
            if let Some(key) = path_key.as_deref_mut() {
                add_to_path_key(key, self.surface_key(hit), throughput);
            }
            let Some(hit) = hit else {
                let miss = if params.environment {
                    self.environment(ray.dir)
                } else {
                    params.background_quantized()
                };
                color += throughput * miss;
                if bounce == 0 && s.aov == Aov::Normal {
                    aux = Vec4::ZERO;
                }
                if bounce == 0 && s.aov == Aov::Ao {
                    aux = Vec4::new(1.0, 1.0, 1.0, 0.0); // open sky, no coverage
                }
                break;
            };
            path_length += hit.t;
            let surface = self.surface_at(&hit, &ray, s.smooth);
            let (p, ng, ns) = (surface.p, surface.ng, surface.ns);
            let behind = self.left_behind(&hit, &surface, s.accel);
            if s.aov == Aov::Ao {
                let open = self.ambient_occlusion(params, p, ng, ns, sample_seed, behind, stats);
                aux = Vec3::splat(open).extend(1.0);
                break;
            }
            let gm = &self.packed.materials[surface.shading.material as usize];
            let mat = ShadingMaterial {
                diffuse: gm.diffuse.into(),
                specular: gm.specular.into(),
                shininess: gm.shininess,
                mirror: gm.mirror,
            };
            let kd = self.diffuse_at(s.textures, gm, &hit, &surface, ray.dir, spread * path_length);
            let l = (params.light_position - p).normalize();
            // Decided in the mesh's space, as the shader does.
            let inst = surface.inst;
            let lit = light_reaches(
                inst.vector_to_object(l),
                surface.object.ng,
                surface.object.ns,
                surface.smooth.as_ref(),
                inst.point_to_object(p),
                inst.point_to_object(params.light_position),
            );
            let local =
                blinn_phong(&mat, kd, l, ns, lit, -ray.dir, params.light_color, params.ambient);
            if bounce == 0 {
                aux = self.first_hit_aov(s.aov, &hit, &surface).unwrap_or(aux);
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
            let mut reflected = reflect(ray.dir, ns);
            if reflected.dot(ng) <= 0.0 {
                reflected = reflect(ray.dir, ng);
            }
            ray = Ray::new(p + ng * params.ray_epsilon, reflected);
            skip = behind;
        }
        match s.aov {
            Aov::Color | Aov::Samples => color.extend(1.0),
            _ => aux,
        }
    }

    /// The hit's point, its triangle's records and normals: the geometric one and the
    /// shading one (interpolated with `smooth`), both on the viewer's side.
    #[inline]
    fn surface_at(&self, hit: &SceneHit, ray: &Ray, smooth: bool) -> Surface<'a> {
        let tri = &self.packed.triangles[hit.triangle as usize];
        let shading = &self.packed.shading[hit.triangle as usize];
        let inst = &self.packed.top_level.instances[hit.instance as usize];
        let p = ray.at(hit.t);
        let (e1, e2) = (Vec3::from(tri.e1), Vec3::from(tri.e2));
        // The normals in the mesh's space, turned to the viewer there (the same side as in
        // the world), then carried out by the inverse transpose (the shader's comment).
        let d_object = inst.vector_to_object(ray.dir);
        let mut ng = e1.cross(e2).normalize();
        let back = ng.dot(d_object) > 0.0;
        if back {
            ng = -ng;
        }
        let mut ns = ng;
        let w = 1.0 - hit.u - hit.v;
        // The corner normals on the viewer's side, for the terminator offset.
        let mut smooth_triangle = None;
        if smooth {
            let [n0, n1, n2] = self.packed.vertices.normals_of(shading.corners);
            let interp = n0 * w + n1 * hit.u + n2 * hit.v;
            if interp.length_squared() > 1e-12 {
                ns = interp.normalize();
                let mut side = 1.0;
                if ns.dot(ng) < 0.0 {
                    ns = -ns;
                    side = -1.0;
                }
                let normals = [n0 * side, n1 * side, n2 * side];
                smooth_triangle = Some(SmoothTriangle { u: hit.u, v: hit.v, e1, e2, normals });
            }
        }
        let object = ObjectNormals { ng, ns };
        let (ng, ns) = (inst.normal_to_world(ng).normalize(), inst.normal_to_world(ns).normalize());
        Surface { tri, shading, inst, p, e1, e2, ng, ns, object, back, w, smooth: smooth_triangle }
    }

    /// The instance a ray leaving `surface` (lifted off it along its normal, heading away
    /// from its plane) skips: the hit's own where its mesh is convex and the ray met it
    /// from outside, since the whole mesh lies behind the triangle's plane
    /// (`tracer/convex.rs`); else `EMPTY`. Brute force, the paper's every triangle, skips
    /// nothing. The shader's `left_behind`.
    fn left_behind(&self, hit: &SceneHit, surface: &Surface, accel: Accel) -> u32 {
        let convex = self.packed.top_level.meshes[surface.inst.mesh as usize].convex;
        let outside = if surface.back { contract::CONVEX_INWARD } else { contract::CONVEX_OUTWARD };
        if accel != Accel::Brute && convex == outside {
            hit.instance
        } else {
            EMPTY
        }
    }

    /// The diffuse colour at the hit: the material's `diffuse`, times the vertex colours and
    /// the texture (at the level of detail for a pixel `width_at_hit` wide there).
    #[inline]
    fn diffuse_at(
        &self,
        textures: bool,
        gm: &GpuMaterial,
        hit: &SceneHit,
        surface: &Surface,
        ray_dir: Vec3,
        width_at_hit: f32,
    ) -> Vec3 {
        let (w, e1, e2, ng) = (surface.w, surface.e1, surface.e2, surface.ng);
        let corners = surface.shading.corners;
        let mut kd: Vec3 = gm.diffuse.into();
        if textures && gm.has_vertex_colors() {
            let [c0, c1, c2] = self.packed.vertices.colors_of(corners);
            kd *= c0 * w + c1 * hit.u + c2 * hit.v;
        }
        if textures && gm.texture != NO_TEXTURE {
            let [uv0, uv1, uv2] =
                self.packed.vertices.texcoords_of(corners).map(|uv| gm.texture_uv(uv));
            let uv = uv0 * w + uv1 * hit.u + uv2 * hit.v;
            let info = self.packed.textures.infos[gm.texture as usize];
            let world_area = 0.5 * surface.inst.world_area(e1.cross(e2));
            let (d1, d2) = (uv1 - uv0, uv2 - uv0);
            let texel_area =
                0.5 * (d1.x * d2.y - d1.y * d2.x).abs() * info[1] as f32 * info[2] as f32;
            let mut lod = 0.0;
            if world_area > 0.0 && texel_area > 0.0 {
                lod = width_at_hit.max(1e-20).log2() + 0.5 * (texel_area / world_area).log2()
                    - ng.dot(ray_dir).abs().max(1e-4).log2();
            }
            kd *= self
                .packed
                .textures
                .sample_with(gm.texture, uv, lod, gm.texture_clamps())
                .truncate();
        }
        kd
    }

    /// What the first hit shows in an AOV view that is not traced further (none for the
    /// colour, cost, samples and AO views).
    #[inline]
    fn first_hit_aov(&self, aov: Aov, hit: &SceneHit, surface: &Surface) -> Option<Vec4> {
        let mesh = &self.packed.top_level.meshes[surface.inst.mesh as usize];
        let prim = (surface.tri.prim + mesh.prim_base) as f32;
        match aov {
            Aov::Depth => Some(Vec4::new(hit.t, hit.t, hit.t, 1.0)),
            Aov::Normal => Some(surface.ns.extend(1.0)),
            Aov::PrimId => Some(Vec4::new(prim, prim, prim, 1.0)),
            Aov::Color | Aov::Cost | Aov::Samples | Aov::Ao => None,
        }
    }

    /// The shader's `surface_key`: instance, material and plane of the hit triangle, so
    /// coplanar triangles of one material count as one surface (`u32::MAX` on a miss).
    pub(crate) fn surface_key(&self, hit: Option<SceneHit>) -> u32 {
        let Some(hit) = hit else { return u32::MAX };
        let tri = &self.packed.triangles[hit.triangle as usize];
        let mut n = Vec3::from(tri.e1).cross(Vec3::from(tri.e2)).normalize();
        if n.x < 0.0 || (n.x == 0.0 && (n.y < 0.0 || (n.y == 0.0 && n.z < 0.0))) {
            n = -n;
        }
        let q = (n * 1024.0).round();
        let (qx, qy, qz) = (q.x as i32 as u32, q.y as i32 as u32, q.z as i32 as u32);
        let key = pcg(qx ^ pcg(qy ^ pcg(qz)));
        let key = pcg(key ^ self.packed.shading[hit.triangle as usize].material)
            ^ pcg(hit.instance.wrapping_add(0x9e3779b9));
        if key == u32::MAX {
            0
        } else {
            key
        }
    }

    /// Key of the path through the centre of each pixel (primary hit and the mirror bounces
    /// that still show): adaptive sampling's edge test, as the shader's pre-pass.
    pub(crate) fn path_keys(&self, params: &FrameParams) -> Vec<u32> {
        let (w, h) = (params.settings.width, params.settings.height);
        let color = FrameParams {
            settings: RenderSettings { aov: Aov::Color, ..params.settings },
            ..*params
        };
        (0..w * h)
            .into_par_iter()
            .map(|i| {
                let mut stats = TraversalStats::default();
                let mut key = 0;
                let centre = Vec2::new((i % w) as f32 + 0.5, (i / w) as f32 + 0.5);
                self.trace_sample(&color, centre, 0, &mut stats, Some(&mut key));
                key
            })
            .collect()
    }

    /// Trace one pixel: the value the shader writes to the float output (before accumulation).
    pub(crate) fn trace_pixel(
        &self,
        params: &FrameParams,
        px: u32,
        py: u32,
        ids: Option<&[u32]>,
    ) -> [f32; 4] {
        let s = &params.settings;
        let (w, h) = (s.width, s.height);
        let pixel = py * w + px;
        let single_value = matches!(s.aov, Aov::Depth | Aov::Normal | Aov::PrimId);
        let mut spp = if single_value { 1 } else { s.spp.clamp(1, contract::SPP_MASK) };
        if let (true, Some(ids), false) = (s.adaptive, ids, single_value) {
            let id = ids[pixel as usize];
            let at = |x: u32, y: u32| ids[(y * w + x) as usize];
            let edge = at(px.saturating_sub(1), py) != id
                || at((px + 1).min(w - 1), py) != id
                || at(px, py.saturating_sub(1)) != id
                || at(px, (py + 1).min(h - 1)) != id;
            if !edge {
                spp = 1;
            }
        }
        let jitter = !single_value && (spp > 1 || params.frame_index > 0);
        let mut stats = TraversalStats::default();
        let mut sum = Vec4::ZERO;
        for sample in 0..spp {
            let mut offset = Vec2::splat(0.5);
            // The sample's seed: its jitter and its AO rays (a new set each accumulated frame).
            let sample_seed =
                pcg(pixel ^ pcg(params.frame_index.wrapping_mul(256).wrapping_add(sample)));
            if jitter {
                let mut seed = sample_seed;
                offset = Vec2::new(random01(&mut seed), random01(&mut seed));
            }
            sum += self.trace_sample(
                params,
                Vec2::new(px as f32, py as f32) + offset,
                sample_seed,
                &mut stats,
                None,
            );
        }
        let value = sum / spp as f32;
        match s.aov {
            Aov::Cost => [stats.nodes as f32, stats.triangles as f32, 0.0, 1.0],
            Aov::Samples => [spp as f32, spp as f32, spp as f32, 1.0],
            _ => value.to_array(),
        }
    }
}

/// Render a whole frame on the CPU (`params.frame_index` must be 0; see [`accumulate`]).
pub fn render(packed: &PackedScene, params: &FrameParams) -> Image {
    let mut image = Image::new(params.settings.width, params.settings.height);
    accumulate(packed, params, &mut image);
    image
}

/// Trace a frame and fold it into `image` as the running mean of `params.frame_index + 1`
/// frames (frame 0 overwrites), as the shader does for progressive accumulation.
pub fn accumulate(packed: &PackedScene, params: &FrameParams, image: &mut Image) {
    let scene = CpuScene::new(packed);
    let w = params.settings.width;
    let ids = params.settings.adaptive.then(|| scene.path_keys(params));
    let n = params.frame_index;
    image.pixels.par_chunks_mut(w as usize).enumerate().for_each(|(y, row)| {
        for (x, px) in row.iter_mut().enumerate() {
            let v = scene.trace_pixel(params, x as u32, y as u32, ids.as_deref());
            *px = if n > 0 && matches!(params.settings.aov, Aov::Color | Aov::Ao) {
                let prev = Vec4::from(*px);
                (prev + (Vec4::from(v) - prev) / (n + 1) as f32).to_array()
            } else {
                v
            };
        }
    });
}
