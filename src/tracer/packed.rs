//! The scene flattened into the arrays the GPU reads (and the CPU reference reads the same
//! way): triangles in BVH order as (v0, e1, e2), their shading normals, materials, every
//! mesh's BVH nodes back to back, and the instance list on top.
//!
//! Geometry is packed once per model load; the instance list (the "top level") is rebuilt
//! alone when only the model count changes, so no mesh is re-uploaded.

use std::collections::HashMap;
use std::path::PathBuf;

use bytemuck::{Pod, Zeroable};
use rayon::prelude::*;
use glam::{Vec2, Vec3};

use super::prepare::PreparedScene;
use super::textures::{EnvironmentMap, TextureAtlas};
use crate::bvh::wide::{WideBvh, WideNode};
use crate::bvh::{Bvh, BvhNode};
use crate::geometry::Aabb;
use crate::progress::{Cancelled, Phase, Progress};
use crate::render_settings::BvhLayout;
use crate::scene::{Instance, Mesh, Scene};

/// A triangle as `shaders/scene.glsl` reads it (48 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTriangle {
    pub v0: [f32; 3],
    /// Global material index.
    pub material: u32,
    pub e1: [f32; 3],
    /// Index of the triangle in its mesh's file order.
    pub prim: u32,
    pub e2: [f32; 3],
    pub(crate) _pad: u32,
}

impl GpuTriangle {
    /// Corner 0 and the two edges, as used by Möller–Trumbore.
    pub(crate) fn edges(&self) -> [Vec3; 3] {
        [Vec3::from(self.v0), Vec3::from(self.e1), Vec3::from(self.e2)]
    }
}

/// Per-corner shading normals and texture coordinates of a triangle (64 bytes): the
/// normals' .w hold corner 2's (u, v), `uv01` corners 0 and 1.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTriangleShading {
    pub(crate) normals: [[f32; 4]; 3],
    pub(crate) uv01: [f32; 4],
}

impl GpuTriangleShading {
    /// The three corner normals.
    pub(crate) fn normal(&self, k: usize) -> Vec3 {
        Vec3::from_slice(&self.normals[k][..3])
    }

    /// The three corner texture coordinates.
    pub(crate) fn uvs(&self) -> [Vec2; 3] {
        [
            Vec2::new(self.uv01[0], self.uv01[1]),
            Vec2::new(self.uv01[2], self.uv01[3]),
            Vec2::new(self.normals[0][3], self.normals[1][3]),
        ]
    }
}

/// A Blinn–Phong material with its diffuse texture and how that is laid on (64 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuMaterial {
    pub(crate) diffuse: [f32; 3],
    pub(crate) mirror: f32,
    pub(crate) specular: [f32; 3],
    pub(crate) shininess: f32,
    /// Diffuse texture index into the atlas, or `NO_TEXTURE`.
    pub(crate) texture: u32,
    /// `contract::TEXTURE_CLAMP` when the texture clamps instead of repeating.
    pub(crate) texture_flags: u32,
    pub(crate) _pad: [u32; 2],
    /// Texture coordinates are `uv * uv_scale + uv_offset` before the lookup
    /// (`TextureTransform`).
    pub(crate) uv_scale: [f32; 2],
    /// Added to the scaled texture coordinates (`map_Kd -o`).
    pub(crate) uv_offset: [f32; 2],
}

impl GpuMaterial {
    /// The texture coordinates the lookup uses for the surface's `uv` (the shader's
    /// `material_uv`).
    pub(crate) fn texture_uv(&self, uv: Vec2) -> Vec2 {
        uv * Vec2::from(self.uv_scale) + Vec2::from(self.uv_offset)
    }

    /// True when the texture clamps at its edges instead of repeating.
    pub(crate) fn texture_clamps(&self) -> bool {
        self.texture_flags & crate::contract::TEXTURE_CLAMP != 0
    }
}

/// `GpuMaterial::texture` of an untextured material (the shader compares it with `EMPTY`).
pub(crate) const NO_TEXTURE: u32 = crate::contract::EMPTY;

/// A placed mesh (64 bytes): uniform scale then translation, and where its data lives.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuInstance {
    pub(crate) translation: [f32; 3],
    pub scale: f32,
    pub node_base: u32,
    pub triangle_base: u32,
    pub triangle_count: u32,
    /// Added to a triangle's file-order index to give the prim-id AOV.
    pub(crate) prim_base: u32,
    /// World-space bounds: the top level culls instances with them. `bounds_min[3]` holds
    /// (as u32 bits) the mesh's first wide node, in 16-byte words of the node buffer.
    pub(crate) bounds_min: [f32; 4],
    pub(crate) bounds_max: [f32; 4],
}

/// Where one mesh's data sits in the packed arrays.
#[derive(Clone, Debug)]
pub struct PackedMesh {
    pub node_base: u32,
    pub triangle_base: u32,
    pub triangle_count: u32,
    pub prim_base: u32,
    /// Object-space bounds of the mesh.
    pub(crate) bounds: Aabb,
    /// Nodes of the mesh's BVH in `PackedScene::nodes` from `node_base` (the tree is kept
    /// only there: [`PackedMesh::bvh`] puts it back together).
    pub node_count: u32,
    /// The mesh's first node in `PackedScene::wide_nodes`.
    pub wide_base: u32,
}

/// The whole scene as flat arrays.
#[derive(Clone, Debug, Default)]
pub struct PackedScene {
    pub triangles: Vec<GpuTriangle>,
    pub shading: Vec<GpuTriangleShading>,
    pub materials: Vec<GpuMaterial>,
    pub(crate) nodes: Vec<BvhNode>,
    /// Every mesh's wide BVH nodes back to back; the GPU's node buffer holds them after
    /// `nodes`.
    pub(crate) wide_nodes: Vec<WideNode>,
    /// Where `wide_nodes` start in the node buffer, in 16-byte words (kept when the host
    /// copies are dropped after upload).
    wide_word_base: u32,
    pub instances: Vec<GpuInstance>,
    pub meshes: Vec<PackedMesh>,
    /// Diffuse textures of all materials.
    pub textures: TextureAtlas,
    /// The environment map, when the scene has one.
    pub environment: Option<EnvironmentMap>,
    /// Problems worked around while packing (unreadable textures...).
    pub warnings: Vec<String>,
    texture_index: HashMap<PathBuf, u32>,
    /// Seconds spent building BVHs, for reports.
    pub(crate) bvh_build_seconds: f64,
}

impl PackedScene {
    /// Prepare (build every mesh's BVH, decode textures and the environment) and pack
    /// the scene: the one call most callers want.
    pub fn new(scene: &Scene) -> Self {
        Self::pack(scene, PreparedScene::new(scene, false))
    }

    /// [`PackedScene::new`] for frames of `layout`: with [`BvhLayout::Wide`], both layouts
    /// are packed (a frame may then pick either); binary alone otherwise.
    pub fn for_layout(scene: &Scene, layout: BvhLayout) -> Self {
        Self::pack(scene, PreparedScene::new(scene, layout == BvhLayout::Wide))
    }

    /// [`PackedScene::for_layout`] as a load's build and pack phases, reported to `progress`
    /// (the window's loader, `bench --load`); Err when the load was cancelled before either.
    pub(crate) fn for_layout_reporting(scene: &Scene, layout: BvhLayout, progress: &Progress) -> Result<Self, Cancelled> {
        progress.begin(Phase::Build)?;
        let prepared = PreparedScene::new(scene, layout == BvhLayout::Wide);
        progress.begin(Phase::Pack)?;
        Ok(Self::pack(scene, prepared))
    }

    /// True when the wide layout was packed: frames asking for it without trace the binary tree.
    pub fn has_wide(&self) -> bool {
        !self.wide_nodes.is_empty()
    }

    /// Pack `scene` into flat arrays with what `prepared` built and decoded for it. Packing
    /// only copies and reorders: nothing here builds or decodes.
    pub(crate) fn pack(scene: &Scene, prepared: PreparedScene) -> Self {
        let PreparedScene { bvhs, wide_bvhs, textures, environment, warnings, bvh_build_seconds } = prepared;
        let mut packed = PackedScene { warnings, bvh_build_seconds, environment, ..Default::default() };
        for (path, img) in textures {
            let index = packed.textures.add(&img);
            packed.texture_index.insert(path, index);
        }
        let mut prim_base = 0u32;
        for ((mesh, bvh), wide) in scene.meshes.iter().zip(bvhs).zip(wide_bvhs) {
            packed.push_mesh(mesh, bvh, wide, prim_base);
            prim_base += mesh.triangle_count() as u32;
        }
        packed.wide_word_base = (std::mem::size_of_val(packed.nodes.as_slice()) / 16) as u32;
        packed.set_instances(&scene.instances);
        packed
    }

    /// Replace the environment image (None: misses see the background colour), decoded
    /// with [`EnvironmentMap::from_source`].
    pub(crate) fn set_environment(&mut self, environment: Option<EnvironmentMap>) {
        self.environment = environment;
    }

    /// The environment buffer as the shader reads it: width, height, then RGB9E5 texels.
    pub(crate) fn environment_words(&self) -> Vec<u32> {
        match &self.environment {
            Some(env) => {
                let mut words = vec![env.width, env.height];
                words.extend_from_slice(&env.texels);
                words
            }
            None => vec![1, 1, 0],
        }
    }

    fn push_mesh(&mut self, mesh: &Mesh, bvh: Bvh, wide: Option<WideBvh>, prim_base: u32) {
        let material_base = self.materials.len() as u32;
        let texture_of = |m: &crate::scene::Material| {
            m.diffuse_texture.as_ref().filter(|_| !mesh.texcoords.is_empty()).and_then(|p| self.texture_index.get(p).copied()).unwrap_or(NO_TEXTURE)
        };
        let materials: Vec<GpuMaterial> = mesh
            .materials
            .iter()
            .map(|m| GpuMaterial {
                diffuse: m.diffuse.to_array(),
                mirror: m.mirror,
                specular: m.specular.to_array(),
                shininess: m.shininess,
                texture: texture_of(m),
                texture_flags: if m.texture_transform.clamp { crate::contract::TEXTURE_CLAMP } else { 0 },
                _pad: [0; 2],
                uv_scale: m.texture_transform.scale.to_array(),
                uv_offset: m.texture_transform.offset.to_array(),
            })
            .collect();
        self.materials.extend(materials);
        let triangle_base = self.triangles.len() as u32;
        // In BVH order, on every core: at 10M triangles this was a second of one thread.
        let (triangles, shading): (Vec<GpuTriangle>, Vec<GpuTriangleShading>) =
            bvh.prim_indices.par_iter().map(|&prim| pack_triangle(mesh, prim, material_base)).unzip();
        append(&mut self.triangles, triangles);
        append(&mut self.shading, shading);
        let node_base = self.nodes.len() as u32;
        let node_count = bvh.nodes.len() as u32;
        append(&mut self.nodes, bvh.nodes);
        let wide_base = self.wide_nodes.len() as u32;
        if let Some(wide) = wide {
            append(&mut self.wide_nodes, wide.nodes);
        }
        self.meshes.push(PackedMesh {
            node_base,
            node_count,
            wide_base,
            triangle_base,
            triangle_count: mesh.triangle_count() as u32,
            prim_base,
            bounds: mesh.bounds(),
        });
    }

    /// Rebuild the instance list (the top level) alone; geometry is untouched.
    pub fn set_instances(&mut self, instances: &[Instance]) {
        self.instances = instances
            .iter()
            .map(|inst| {
                let m = &self.meshes[inst.mesh];
                let b = m.bounds;
                let (lo, hi) = if b.is_empty() {
                    (Vec3::ZERO, Vec3::ZERO)
                } else {
                    (b.min * inst.scale + inst.translation, b.max * inst.scale + inst.translation)
                };
                let wide_words = self.wide_word_base + m.wide_base * (std::mem::size_of::<WideNode>() / 16) as u32;
                GpuInstance {
                    bounds_min: lo.extend(f32::from_bits(wide_words)).to_array(),
                    bounds_max: hi.extend(0.0).to_array(),
                    translation: inst.translation.to_array(),
                    scale: inst.scale,
                    node_base: m.node_base,
                    triangle_base: m.triangle_base,
                    triangle_count: m.triangle_count,
                    prim_base: m.prim_base,
                }
            })
            .collect();
    }

    /// Bytes of each GPU array: triangles, shading, materials, nodes (both layouts),
    /// instances, texels.
    pub(crate) fn buffer_sizes(&self) -> [u64; 6] {
        fn bytes<T>(v: &[T]) -> u64 {
            std::mem::size_of_val(v) as u64
        }
        let nodes = bytes(&self.nodes) + bytes(&self.wide_nodes);
        [bytes(&self.triangles), bytes(&self.shading), bytes(&self.materials), nodes, bytes(&self.instances), bytes(&self.textures.texels)]
    }

    /// The wide nodes of instance `inst`'s mesh (root first), as the CPU tracer walks them.
    pub(crate) fn wide_nodes_of(&self, inst: &GpuInstance) -> &[WideNode] {
        let words = inst.bounds_min[3].to_bits().saturating_sub(self.wide_word_base) as usize;
        self.wide_nodes.get(words / (std::mem::size_of::<WideNode>() / 16)..).unwrap_or(&[])
    }
}

/// One triangle's traversal record and shading record (`prim` in file order).
fn pack_triangle(mesh: &Mesh, prim: u32, material_base: u32) -> (GpuTriangle, GpuTriangleShading) {
    let [a, b, c] = mesh.corners(prim as usize);
    let (mut e1, mut e2) = (b - a, c - a);
    // A (nearly) degenerate triangle would pass Möller–Trumbore's absolute determinant test
    // on rounding noise and report hits far outside itself: zero its edges so that both
    // tracers skip it.
    if e1.cross(e2).length() <= 1e-7 * e1.length() * e2.length() {
        (e1, e2) = (Vec3::ZERO, Vec3::ZERO);
    }
    let triangle = GpuTriangle {
        v0: a.to_array(),
        material: material_base + mesh.triangle_materials.get(prim as usize).copied().unwrap_or(0),
        e1: e1.to_array(),
        prim,
        e2: e2.to_array(),
        _pad: 0,
    };
    let idx = mesh.triangles[prim as usize];
    let normal = |k: u32| mesh.normals.get(k as usize).copied().unwrap_or(Vec3::ZERO);
    let uv = |k: u32| mesh.texcoords.get(k as usize).copied().unwrap_or(Vec2::ZERO);
    let [t0, t1, t2] = idx.map(uv);
    let shading = GpuTriangleShading {
        normals: [normal(idx[0]).extend(t2.x).to_array(), normal(idx[1]).extend(t2.y).to_array(), normal(idx[2]).extend(0.0).to_array()],
        uv01: [t0.x, t0.y, t1.x, t1.y],
    };
    (triangle, shading)
}

/// `to.extend(from)`, moving `from` in whole when `to` is empty (the first mesh: no copy).
fn append<T>(to: &mut Vec<T>, mut from: Vec<T>) {
    if to.is_empty() {
        *to = from;
    } else {
        to.append(&mut from);
    }
}

impl PackedMesh {
    /// The mesh's BVH as built, put back together from `packed` (for validation: tests,
    /// fuzzing; a scene whose arrays were freed after the upload has none).
    pub fn bvh(&self, packed: &PackedScene) -> Bvh {
        let nodes = packed.nodes[self.node_base as usize..][..self.node_count as usize].to_vec();
        let range = self.triangle_base as usize..(self.triangle_base + self.triangle_count) as usize;
        Bvh { nodes, prim_indices: packed.triangles[range].iter().map(|t| t.prim).collect() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gpu_structs_match_the_shader_layout() {
        assert_eq!(std::mem::size_of::<GpuTriangle>(), 48);
        assert_eq!(std::mem::size_of::<GpuTriangleShading>(), 64);
        assert_eq!(std::mem::size_of::<GpuMaterial>(), 64);
        assert_eq!(std::mem::size_of::<GpuInstance>(), 64);
        assert_eq!(std::mem::size_of::<BvhNode>(), 64);
        assert_eq!(std::mem::size_of::<WideNode>(), 80);
    }

    #[test]
    fn the_mesh_tables_boxes_give_the_scenes_bounds() {
        // The window takes the world bounds (the ray offset) from the mesh table each frame.
        use crate::scene::paper::{paper_scene, prepare_model, LightOrbit};
        use crate::scene::primitives::PaperModel;
        let mut mesh = PaperModel::TorusKnot.mesh();
        prepare_model(&mut mesh);
        let mut scene = paper_scene(mesh, 3, LightOrbit::default());
        scene.instances[1].translation.x += 7.5;
        let packed = PackedScene::new(&scene);
        let boxes: Vec<_> = packed.meshes.iter().map(|m| m.bounds).collect();
        assert_eq!(scene.bounds_with(&boxes), scene.bounds());
        assert!(scene.bounds().max.x > 7.5, "the moved copy counts");
    }
}
