//! The scene flattened into the arrays the GPU reads (and the CPU reference reads the same
//! way): triangles in BVH order as (v0, e1, e2) with a hit record each (corner vertices and
//! material), the vertices' shading attributes, materials, every mesh's BVH nodes back to
//! back, and the instance list on top.
//!
//! Geometry is packed once per model load; the instance list (the "top level") is rebuilt
//! alone when only the model count changes, so no mesh is re-uploaded.

use std::collections::HashMap;
use std::path::PathBuf;

use bytemuck::{Pod, Zeroable};
use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::prepare::PreparedScene;
use super::textures::{EnvironmentMap, TextureAtlas};
use crate::bvh::wide::{WideBvh, WideNode};
use crate::bvh::{Bvh, BvhNode};
use crate::contract::EMPTY;
use crate::geometry::Aabb;
use crate::progress::{Cancelled, Phase, Progress};
use crate::render_settings::BvhLayout;
use crate::scene::{Instance, Mesh, Scene};

/// A triangle as the traversal reads it (40 bytes: `shaders/scene.glsl`'s
/// `load_triangle` reads it as five 8-byte words). The material is in
/// [`GpuTriangleShading`], read only at a hit. 40 bytes rather than 48 took 5-7% off the
/// 4M and 10M knots' frames on the H100 and put nodes and triangles under the driver's
/// structure (76.7 against 79.8 bytes a triangle); 36 (nine single floats) was as fast on
/// the big meshes but up to 10% slower on Sponza: its nine 4-byte loads against five
/// 8-byte ones (docs/BENCHMARKS.md).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTriangle {
    pub v0: [f32; 3],
    pub e1: [f32; 3],
    pub e2: [f32; 3],
    /// Index of the triangle in its mesh's file order (the prim-id view).
    pub prim: u32,
}

// The size statistics count triangle bytes as the traversal reads them.
const _: () =
    assert!(std::mem::size_of::<GpuTriangle>() == crate::bvh::wide::stats::TRIANGLE_BYTES);

/// What the shading reads at a triangle's hit (16 bytes, one `uvec4`): its corners'
/// indices into [`PackedVertices`] and its global material index.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTriangleShading {
    pub corners: [u32; 3],
    pub material: u32,
}

impl GpuTriangle {
    /// Corner 0 and the two edges, as used by Möller–Trumbore.
    pub(crate) fn edges(&self) -> [Vec3; 3] {
        [Vec3::from(self.v0), Vec3::from(self.e1), Vec3::from(self.e2)]
    }
}

/// The vertex attributes the shading reads at a hit, shared by the triangles that meet at
/// a vertex (`GpuTriangleShading::corners` index them): 12 to 24 bytes a vertex, where a
/// 64-byte record of three corners a triangle used to be. Arrays a scene does not use stay
/// empty (no mesh with texture coordinates, none with colours).
#[derive(Clone, Debug, Default)]
pub struct PackedVertices {
    /// Vertex normals (object space), every vertex of every mesh.
    pub normals: Vec<[f32; 3]>,
    /// Texture coordinates per vertex, or empty when no mesh has any (zero where a mesh
    /// lacks them).
    pub texcoords: Vec<[f32; 2]>,
    /// RGBA8 colours per vertex, or empty when no mesh has any (white where a mesh lacks
    /// them).
    pub colors: Vec<[u8; 4]>,
}

impl PackedVertices {
    /// The normals of `corners`.
    pub(crate) fn normals_of(&self, corners: [u32; 3]) -> [Vec3; 3] {
        corners.map(|k| Vec3::from(self.normals[k as usize]))
    }

    /// The texture coordinates of `corners` (zero without any).
    pub(crate) fn texcoords_of(&self, corners: [u32; 3]) -> [Vec2; 3] {
        corners.map(|k| self.texcoords.get(k as usize).map_or(Vec2::ZERO, |&t| Vec2::from(t)))
    }

    /// The colours of `corners`, in [0, 1] (white without any).
    pub(crate) fn colors_of(&self, corners: [u32; 3]) -> [Vec3; 3] {
        corners.map(|k| {
            self.colors
                .get(k as usize)
                .map_or(Vec3::ONE, |c| Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) / 255.0)
        })
    }

    /// Append `mesh`'s vertices; returns the index its first vertex gets.
    fn push_mesh(&mut self, mesh: &Mesh) -> u32 {
        let base = self.normals.len();
        let count = mesh.positions.len();
        if mesh.normals.len() == count {
            self.normals.par_extend(mesh.normals.par_iter().map(|n| n.to_array()));
        } else {
            self.normals.resize(base + count, [0.0; 3]);
        }
        if mesh.texcoords.len() == count && count > 0 {
            self.texcoords.resize(base, [0.0; 2]);
            self.texcoords.extend(mesh.texcoords.iter().map(|t| t.to_array()));
        }
        if mesh.colors.len() == count && count > 0 {
            self.colors.resize(base, [255; 4]);
            self.colors.extend_from_slice(&mesh.colors);
        }
        base as u32
    }

    /// Fill the attributes of the last meshes that lacked them up to the vertex count.
    fn finish(&mut self) {
        let count = self.normals.len();
        if !self.texcoords.is_empty() {
            self.texcoords.resize(count, [0.0; 2]);
        }
        if !self.colors.is_empty() {
            self.colors.resize(count, [255; 4]);
        }
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
    /// `contract::TEXTURE_CLAMP` when the texture clamps instead of repeating,
    /// `contract::MATERIAL_VERTEX_COLORS` when the mesh's vertex colours tint it.
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

    /// True when the mesh's vertex colours multiply the diffuse colour.
    pub(crate) fn has_vertex_colors(&self) -> bool {
        self.texture_flags & crate::contract::MATERIAL_VERTEX_COLORS != 0
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
    /// Triangle slots from `triangle_base` (more than the mesh's triangles where the build
    /// cut some into pieces: one slot per leaf that holds a piece).
    pub triangle_count: u32,
    /// Added to a triangle's file-order index to give the prim-id AOV.
    pub(crate) prim_base: u32,
    /// World-space bounds: the top level culls instances with them. `bounds_min[3]` holds
    /// (as u32 bits) the mesh's first wide node, in 16-byte words of the node buffer, or
    /// `EMPTY` for a mesh without a wide tree.
    pub(crate) bounds_min: [f32; 4],
    pub(crate) bounds_max: [f32; 4],
}

/// Where one mesh's data sits in the packed arrays.
#[derive(Clone, Debug)]
pub struct PackedMesh {
    pub node_base: u32,
    pub triangle_base: u32,
    /// Triangle slots in BVH order (see [`GpuInstance::triangle_count`]).
    pub triangle_count: u32,
    pub prim_base: u32,
    /// Object-space bounds of the mesh.
    pub(crate) bounds: Aabb,
    /// Nodes of the mesh's BVH in `PackedScene::nodes` from `node_base` (the tree is kept
    /// only there: [`PackedMesh::bvh`] puts it back together).
    pub node_count: u32,
    /// The mesh's first node in `PackedScene::wide_nodes`.
    pub wide_base: u32,
    /// Whether the mesh has a wide tree (packed with the wide layout, and its stack need
    /// within the shader's): without, its instances trace the binary tree in either layout.
    pub(crate) has_wide: bool,
}

/// The whole scene as flat arrays.
#[derive(Clone, Debug, Default)]
pub struct PackedScene {
    pub triangles: Vec<GpuTriangle>,
    /// Each triangle's corners and material, in the order of `triangles`.
    pub shading: Vec<GpuTriangleShading>,
    /// The vertex attributes that `shading` indexes.
    pub vertices: PackedVertices,
    pub materials: Vec<GpuMaterial>,
    pub(crate) nodes: Vec<BvhNode>,
    /// Every mesh's wide BVH nodes back to back; the GPU's node buffer holds them after
    /// `nodes`.
    pub(crate) wide_nodes: Vec<WideNode>,
    /// Where `wide_nodes` start in the node buffer, in 16-byte words (kept when the host
    /// copies are dropped after upload).
    wide_word_base: u32,
    /// Packed for wide frames alone ([`PackedScene::for_layout`]) and some mesh has a wide
    /// tree: such meshes have no binary nodes, and binary frames are traced as wide ones.
    wide_only: bool,
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
    /// Set when `triangles` and `shading` were left empty for the upload to write them
    /// straight from the scene's meshes ([`PackedScene::for_loading`]).
    pub(crate) deferred: Option<DeferredTriangles>,
}

/// What the upload needs to write a loaded scene's triangles and hit records itself, in its
/// staging memory: each mesh's BVH order and where its materials and vertices start. A load
/// then never holds the 56 bytes a triangle of both arrays on the host, its peak.
#[derive(Clone, Debug, Default)]
pub(crate) struct DeferredTriangles {
    /// Per mesh, as `PackedScene::meshes`: its triangles (file order) in BVH order.
    orders: Vec<Vec<u32>>,
    /// Per mesh: its first global material and first vertex.
    bases: Vec<(u32, u32)>,
}

impl PackedScene {
    /// Prepare (build every mesh's BVH, decode textures and the environment) and pack
    /// the scene: the one call most callers want.
    pub fn new(scene: &Scene) -> Self {
        Self::pack(scene, PreparedScene::new(scene, false))
    }

    /// [`PackedScene::new`] for frames of `layout` alone, the least memory: a wide layout
    /// packs the wide trees, and binary nodes only for a mesh without one (at 16M triangles
    /// the binary nodes are a third of the scene: 1.15 GB instead of 1.69). A frame of a
    /// layout not packed traces the one that is.
    pub fn for_layout(scene: &Scene, layout: BvhLayout) -> Self {
        Self::pack_with(scene, PreparedScene::new(scene, layout.is_wide()), false, layout.is_wide())
    }

    /// [`PackedScene::new`] with both trees, so that each frame may pick its layout (the
    /// window, which switches between them).
    pub fn with_both_layouts(scene: &Scene) -> Self {
        Self::pack(scene, PreparedScene::new(scene, true))
    }

    /// [`PackedScene::for_layout`] as a load's build and pack phases, reported to `progress`
    /// (the window's loader, `bench --load`), with both trees where `layout` is wide (the
    /// window switches); Err when the load was cancelled before either.
    /// The triangles and hit records are left to the upload, which writes them from `scene`'s
    /// meshes (`ComputeTracer::set_loaded_scene`): the CPU tracer cannot trace the result.
    pub(crate) fn for_loading(
        scene: &Scene,
        layout: BvhLayout,
        progress: &Progress,
    ) -> Result<Self, Cancelled> {
        progress.begin(Phase::Build)?;
        let prepared = PreparedScene::new(scene, layout.is_wide());
        progress.begin(Phase::Pack)?;
        Ok(Self::pack_with(scene, prepared, true, false))
    }

    /// Make mesh `m` trace its binary tree in wide frames too, as a mesh whose wide tree could
    /// overflow the traversal's stack does (for tests of that fallback); `instances` as
    /// [`PackedScene::set_instances`] takes them.
    #[doc(hidden)]
    pub fn drop_wide_tree(&mut self, m: usize, instances: &[Instance]) {
        assert!(
            !self.wide_only,
            "a scene packed for wide frames alone has no binary tree to fall back on"
        );
        self.meshes[m].has_wide = false;
        self.set_instances(instances);
    }

    /// True when the wide layout was packed: frames asking for it without trace the binary tree.
    pub fn has_wide(&self) -> bool {
        !self.wide_nodes.is_empty()
    }

    /// False when packed for wide frames alone ([`PackedScene::for_layout`]): binary frames
    /// then trace the wide trees.
    pub fn has_binary(&self) -> bool {
        !self.wide_only
    }

    /// The layout a frame asking for `layout` traces: the one packed where only one is.
    pub fn traced_layout(&self, layout: BvhLayout) -> BvhLayout {
        layout.traced_with(self.has_binary(), self.has_wide())
    }

    /// Pack `scene` into flat arrays with what `prepared` built and decoded for it. Packing
    /// only copies and reorders: nothing here builds or decodes.
    pub(crate) fn pack(scene: &Scene, prepared: PreparedScene) -> Self {
        Self::pack_with(scene, prepared, false, false)
    }

    /// [`PackedScene::pack`], leaving the triangles and hit records to the upload when
    /// `defer`, and the binary nodes of meshes with a wide tree out when `wide_only`.
    fn pack_with(scene: &Scene, prepared: PreparedScene, defer: bool, wide_only: bool) -> Self {
        let PreparedScene { bvhs, wide_bvhs, textures, environment, warnings, bvh_build_seconds } =
            prepared;
        let mut packed =
            PackedScene { warnings, bvh_build_seconds, environment, ..Default::default() };
        if defer {
            packed.deferred = Some(DeferredTriangles::default());
        }
        for (path, img) in textures {
            let index = packed.textures.add(&img);
            packed.texture_index.insert(path, index);
        }
        let mut prim_base = 0u32;
        for ((mesh, bvh), wide) in scene.meshes.iter().zip(bvhs).zip(wide_bvhs) {
            packed.push_mesh(mesh, bvh, wide, prim_base, wide_only);
            prim_base += mesh.triangle_count() as u32;
        }
        packed.vertices.finish();
        packed.wide_only = wide_only && packed.meshes.iter().any(|m| m.has_wide);
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

    fn push_mesh(
        &mut self,
        mesh: &Mesh,
        bvh: Bvh,
        wide: Option<WideBvh>,
        prim_base: u32,
        wide_only: bool,
    ) {
        let material_base = self.materials.len() as u32;
        let with_colors = !mesh.colors.is_empty() && mesh.colors.len() == mesh.positions.len();
        let vertex_base = self.vertices.push_mesh(mesh);
        let texture_of = |m: &crate::scene::Material| {
            m.diffuse_texture
                .as_ref()
                .filter(|_| !mesh.texcoords.is_empty())
                .and_then(|p| self.texture_index.get(p).copied())
                .unwrap_or(NO_TEXTURE)
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
                texture_flags: if m.texture_transform.clamp {
                    crate::contract::TEXTURE_CLAMP
                } else {
                    0
                } | if with_colors {
                    crate::contract::MATERIAL_VERTEX_COLORS
                } else {
                    0
                },
                _pad: [0; 2],
                uv_scale: m.texture_transform.scale.to_array(),
                uv_offset: m.texture_transform.offset.to_array(),
            })
            .collect();
        self.materials.extend(materials);
        let triangle_base = self.meshes.last().map_or(0, |m| m.triangle_base + m.triangle_count);
        // Slots, not triangles: a triangle the build cut into pieces fills one slot per leaf.
        let triangle_count = bvh.prim_indices.len() as u32;
        if let Some(deferred) = &mut self.deferred {
            deferred.orders.push(bvh.prim_indices);
            deferred.bases.push((material_base, vertex_base));
        } else {
            // In BVH order, on every core: at 10M triangles this was a second of one thread.
            // Written in place: no intermediate pieces to join.
            let (mut triangles, mut shading) = (Vec::new(), Vec::new());
            bvh.prim_indices
                .par_iter()
                .map(|&prim| pack_triangle(mesh, prim, material_base, vertex_base))
                .unzip_into_vecs(&mut triangles, &mut shading);
            append(&mut self.triangles, triangles);
            append(&mut self.shading, shading);
        }
        let node_base = self.nodes.len() as u32;
        let keep_binary = !(wide_only && wide.is_some());
        let node_count = if keep_binary { bvh.nodes.len() as u32 } else { 0 };
        if keep_binary {
            append(&mut self.nodes, bvh.nodes);
        }
        let wide_base = self.wide_nodes.len() as u32;
        let has_wide = wide.is_some();
        if let Some(wide) = wide {
            append(&mut self.wide_nodes, wide.nodes);
        }
        self.meshes.push(PackedMesh {
            node_base,
            node_count,
            wide_base,
            has_wide,
            triangle_base,
            triangle_count,
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
                let wide_words = if m.has_wide {
                    self.wide_word_base
                        + m.wide_base * (std::mem::size_of::<WideNode>() / 16) as u32
                } else {
                    EMPTY
                };
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

    /// Bytes of each GPU array: triangles (with the shaders' read-ahead), shading, normals, texture coordinates, colours,
    /// materials, nodes (both layouts), instances, texels.
    pub(crate) fn buffer_sizes(&self) -> [u64; 9] {
        fn bytes<T>(v: &[T]) -> u64 {
            std::mem::size_of_val(v) as u64
        }
        let nodes = self.nodes_bytes() as u64;
        let v = &self.vertices;
        // Deferred arrays are as big as they will be once the upload writes them.
        let deferred = |written: u64, item: usize| {
            if self.deferred.is_some() {
                self.triangle_count() as u64 * item as u64
            } else {
                written
            }
        };
        [
            deferred(bytes(&self.triangles), std::mem::size_of::<GpuTriangle>())
                + crate::contract::TRIANGLE_READ_AHEAD as u64,
            deferred(bytes(&self.shading), std::mem::size_of::<GpuTriangleShading>()),
            bytes(&v.normals),
            bytes(&v.texcoords),
            bytes(&v.colors),
            bytes(&self.materials),
            nodes,
            bytes(&self.instances),
            bytes(&self.textures.texels),
        ]
    }

    /// Bytes of the BVH nodes, both layouts (the GPU's node buffer).
    pub fn nodes_bytes(&self) -> usize {
        std::mem::size_of_val(self.nodes.as_slice())
            + std::mem::size_of_val(self.wide_nodes.as_slice())
    }

    /// Triangles of all meshes.
    pub(crate) fn triangle_count(&self) -> usize {
        self.meshes.last().map_or(0, |m| (m.triangle_base + m.triangle_count) as usize)
    }

    /// Triangle `k`'s traversal record for a deferred scene (see [`DeferredTriangles`]), from
    /// `scene`'s meshes, the ones it was packed from.
    pub(crate) fn deferred_triangle(&self, scene: &Scene, k: usize) -> GpuTriangle {
        let (m, prim, _) = self.deferred_source(k);
        triangle_record(&scene.meshes[m], prim)
    }

    /// Triangle `k`'s hit record for a deferred scene, as [`PackedScene::deferred_triangle`].
    pub(crate) fn deferred_shading(&self, scene: &Scene, k: usize) -> GpuTriangleShading {
        let (m, prim, (material_base, vertex_base)) = self.deferred_source(k);
        shading_record(&scene.meshes[m], prim, material_base, vertex_base)
    }

    /// Deferred triangle `k`'s mesh, its index in the mesh's file order, and the mesh's first
    /// material and vertex.
    fn deferred_source(&self, k: usize) -> (usize, u32, (u32, u32)) {
        let deferred = self.deferred.as_ref().expect("a deferred scene");
        let m = self.meshes.partition_point(|m| m.triangle_base as usize <= k) - 1;
        let local = k - self.meshes[m].triangle_base as usize;
        (m, deferred.orders[m][local], deferred.bases[m])
    }

    /// The wide nodes of instance `inst`'s mesh (root first), as the CPU tracer walks them.
    pub(crate) fn wide_nodes_of(&self, inst: &GpuInstance) -> &[WideNode] {
        if inst.bounds_min[3].to_bits() == EMPTY {
            return &[];
        }
        let words = inst.bounds_min[3].to_bits().saturating_sub(self.wide_word_base) as usize;
        self.wide_nodes.get(words / (std::mem::size_of::<WideNode>() / 16)..).unwrap_or(&[])
    }
}

/// One triangle's traversal record and shading record (`prim` in file order; the mesh's
/// vertices start at `vertex_base`).
fn pack_triangle(
    mesh: &Mesh,
    prim: u32,
    material_base: u32,
    vertex_base: u32,
) -> (GpuTriangle, GpuTriangleShading) {
    (triangle_record(mesh, prim), shading_record(mesh, prim, material_base, vertex_base))
}

/// Triangle `prim` (file order) of `mesh` as the traversal reads it.
fn triangle_record(mesh: &Mesh, prim: u32) -> GpuTriangle {
    let [a, b, c] = mesh.corners(prim as usize);
    let (mut e1, mut e2) = (b - a, c - a);
    // A (nearly) degenerate triangle would pass Möller–Trumbore's absolute determinant test
    // on rounding noise and report hits far outside itself: zero its edges so that both
    // tracers skip it.
    if e1.cross(e2).length() <= 1e-7 * e1.length() * e2.length() {
        (e1, e2) = (Vec3::ZERO, Vec3::ZERO);
    }
    GpuTriangle { v0: a.to_array(), e1: e1.to_array(), e2: e2.to_array(), prim }
}

/// Triangle `prim`'s hit record, its mesh's vertices and materials starting at the bases.
fn shading_record(
    mesh: &Mesh,
    prim: u32,
    material_base: u32,
    vertex_base: u32,
) -> GpuTriangleShading {
    GpuTriangleShading {
        corners: mesh.triangles[prim as usize].map(|k| vertex_base + k),
        material: material_base + mesh.triangle_materials.get(prim as usize).copied().unwrap_or(0),
    }
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
    /// fuzzing; a scene whose arrays were freed after the upload, or one packed for wide
    /// frames alone, has none).
    pub fn bvh(&self, packed: &PackedScene) -> Bvh {
        let nodes = packed.nodes[self.node_base as usize..][..self.node_count as usize].to_vec();
        let range =
            self.triangle_base as usize..(self.triangle_base + self.triangle_count) as usize;
        Bvh { nodes, prim_indices: packed.triangles[range].iter().map(|t| t.prim).collect() }
    }
}

#[cfg(test)]
#[path = "packed_tests.rs"]
mod tests;
