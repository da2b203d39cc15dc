//! The scene flattened into the arrays the GPU reads (and the CPU reference reads the same
//! way): triangles in BVH order with a hit record each (their layout in `records.rs`), the
//! vertices' shading attributes, materials, every mesh's BVH nodes back to back, and the
//! instance list on top.
//!
//! Geometry is packed once per model load; the instance list (the "top level") is rebuilt
//! alone when only the model count changes, so no mesh is re-uploaded. A packing lives as
//! one of three types: [`PackedScene`], every array on the host (the CPU tracer, `render`,
//! `bench`, the tests); a load's [`LoadedScene`](super::loaded::LoadedScene), whose
//! triangles its upload writes from the scene it keeps; and [`PackedTopLevel`], what the
//! host keeps once the GPU has the geometry.

use std::collections::HashMap;

use rayon::prelude::*;

use super::enclosure::ClosedBox;
use super::prepare::PreparedScene;
pub use super::prepare::{BvhBuilder, DeviceFit, Layouts};
use super::records::pack_triangle;
pub(crate) use super::records::NO_TEXTURE;
pub use super::records::{
    GpuInstance, GpuMaterial, GpuMesh, GpuTriangle, GpuTriangleShading, PackedVertices,
};
use super::textures::{EnvironmentMap, TextureAtlas};
pub use super::top_level::TopLevel;
use super::top_level::{MeshCover, MeshPlace};
use crate::bvh::wide::{WideBvh, WideNode};
use crate::bvh::{Bvh, BvhNode};
use crate::contract::EMPTY;
use crate::geometry::Aabb;
use crate::render_settings::BvhLayout;
use crate::scene::{Instance, Material, Mesh, Scene, TextureSource};

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
    /// Its reach sampled over directions (tight world boxes for turned instances) and its
    /// bounding sphere, where that is tighter than its box (its instances' sphere leaves).
    pub(crate) cover: MeshCover,
    /// The mesh as a closed box, if it is one (for an enclosure).
    pub(crate) closed_box: Option<ClosedBox>,
    /// Its convexity code (`GpuMesh::convex`, `tracer/convex.rs`): 0 where the build cut
    /// triangles into pieces, whose windings the test did not see.
    pub(crate) convex: u32,
    /// Nodes of the mesh's BVH in `PackedScene::nodes` from `node_base` (the tree is kept
    /// only there: [`PackedMesh::bvh`] puts it back together).
    pub node_count: u32,
    /// The mesh's first node in `PackedScene::wide_nodes`.
    pub wide_base: u32,
    /// Whether the mesh has a wide tree (packed with the wide layout, and its stack need
    /// within the shader's): without, its instances trace the binary tree in either layout.
    pub(crate) has_wide: bool,
}

/// The whole scene as flat arrays, every one on the host.
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
    /// Where `wide_nodes` start in the node buffer, in 16-byte words.
    wide_word_base: u32,
    /// Packed with [`Layouts::Wide`] and some mesh has a wide tree: such meshes have no
    /// binary nodes, and binary frames are traced as wide ones.
    wide_only: bool,
    /// The instance records and the tree over them.
    pub top_level: TopLevel,
    pub meshes: Vec<PackedMesh>,
    /// Diffuse textures of all materials.
    pub textures: TextureAtlas,
    /// The environment map, when the scene has one.
    pub environment: Option<EnvironmentMap>,
    /// Problems worked around while packing (unreadable textures...).
    pub warnings: Vec<String>,
    /// Seconds spent building BVHs, for reports.
    pub(crate) bvh_build_seconds: f64,
    /// The meshes whose binary trees the device builds after the upload (`gpu::bvh_build`):
    /// here their nodes are zero and their triangles in file order until read back.
    pub(crate) device_builds: Vec<DeviceBuild>,
}

/// A mesh whose trees the device builds in place after the upload: where its triangles
/// and its reserved nodes sit in the scene's buffers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct DeviceBuild {
    pub(crate) triangle_base: u32,
    pub(crate) triangle_count: u32,
    /// Its first binary node, where its binary tree is kept (None: only the wide one is,
    /// and the build keeps the binary one in scratch memory for the collapse).
    pub(crate) node_base: Option<u32>,
    /// The wide nodes reserved for its wide tree, where it has one.
    pub(crate) wide: Option<WideReserve>,
    /// The mesh's object-space box (the build's Morton grid spans it).
    pub(crate) bounds: Aabb,
    /// Triangles a leaf holds (the last leaf may hold fewer).
    pub(crate) leaf_size: u32,
}

/// The wide nodes reserved for a mesh's wide tree built on the device
/// ([`device_wide_nodes`](super::prepare::device_wide_nodes) of them: the tree takes fewer).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct WideReserve {
    /// The first, in [`PackedScene::wide_nodes`].
    pub(crate) base: u32,
    /// The first, in 16-byte words of the GPU's node buffer.
    pub(crate) words: u32,
    pub(crate) nodes: u32,
}

impl DeviceBuild {
    /// Leaves of the tree.
    pub(crate) fn leaves(&self) -> u32 {
        self.triangle_count.div_ceil(self.leaf_size)
    }

    /// Nodes of the tree: one a leaf but one (a node holds two children).
    pub(crate) fn nodes(&self) -> u32 {
        self.leaves() - 1
    }
}

/// One mesh's triangles (file order) in BVH order, and where its materials and vertices
/// start: what its triangle and hit records are written from, at once
/// ([`PackedScene::with_layouts`]) or by a load's upload.
#[derive(Clone, Debug, Default)]
pub(crate) struct BvhOrder {
    pub(crate) prims: Vec<u32>,
    pub(crate) material_base: u32,
    pub(crate) vertex_base: u32,
}

impl PackedScene {
    /// Prepare and pack `scene` with its binary BVHs: the one call most callers want.
    pub fn new(scene: &Scene) -> Self {
        Self::with_layouts(scene, Layouts::Binary)
    }

    /// Prepare (build every mesh's BVH in `layouts`, decode textures and the environment)
    /// and pack `scene`.
    pub fn with_layouts(scene: &Scene, layouts: Layouts) -> Self {
        Self::with_layouts_within(scene, layouts, DeviceFit::NONE)
    }

    /// [`PackedScene::with_layouts`] for `device`: where both layouts would not fit its
    /// storage buffers beside each other the wide trees are kept alone, a mesh whose wide
    /// tree would still not fit traces its binary tree (warnings say which;
    /// `tracer::prepare`), and the meshes it builds itself are left to it.
    pub fn with_layouts_within(scene: &Scene, layouts: Layouts, device: DeviceFit) -> Self {
        let prepared = PreparedScene::new(scene, layouts, device);
        let (mut packed, orders) = Self::pack_tables(scene, prepared);
        packed.write_triangles(scene, orders);
        packed
    }

    /// Pack `scene` with what `prepared` built and decoded for it, all but the triangles
    /// and hit records, which are left empty: each mesh's [`BvhOrder`] is returned to
    /// write them, in the layouts `prepared` kept. Packing only copies and reorders: nothing
    /// here builds or decodes.
    pub(crate) fn pack_tables(scene: &Scene, prepared: PreparedScene) -> (Self, Vec<BvhOrder>) {
        let PreparedScene {
            bvhs,
            wide_bvhs,
            on_device,
            textures,
            environment,
            warnings,
            bvh_build_seconds,
            layouts,
        } = prepared;
        let mut packed =
            PackedScene { warnings, bvh_build_seconds, environment, ..Default::default() };
        let mut texture_index = HashMap::new();
        for (source, img) in textures {
            texture_index.insert(source, packed.textures.add(&img));
        }
        let wide_only = layouts == Layouts::Wide;
        let mut orders = Vec::with_capacity(scene.meshes.len());
        let mut prim_base = 0u32;
        let meshes = scene.meshes.iter().zip(bvhs).zip(wide_bvhs).zip(on_device);
        for (((mesh, bvh), wide), on_device) in meshes {
            let tree = MeshTrees { bvh, wide, wide_only, on_device };
            orders.push(packed.push_mesh(mesh, tree, prim_base, &texture_index));
            prim_base += mesh.triangle_count() as u32;
        }
        packed.vertices.finish();
        packed.wide_only = wide_only && packed.meshes.iter().any(|m| m.has_wide);
        packed.wide_word_base = (std::mem::size_of_val(packed.nodes.as_slice()) / 16) as u32;
        let wide_words = (std::mem::size_of::<WideNode>() / 16) as u32;
        for wide in packed.device_builds.iter_mut().filter_map(|b| b.wide.as_mut()) {
            wide.words = packed.wide_word_base + wide.base * wide_words;
        }
        packed.set_instances(&scene.instances);
        (packed, orders)
    }

    /// Write every mesh's triangles and hit records in BVH order, each mesh's on every core
    /// (at 10M triangles this was a second of one thread) and in place: no pieces to join.
    fn write_triangles(&mut self, scene: &Scene, orders: Vec<BvhOrder>) {
        for (mesh, order) in scene.meshes.iter().zip(orders) {
            let (mut triangles, mut shading) = (Vec::new(), Vec::new());
            order
                .prims
                .par_iter()
                .map(|&prim| pack_triangle(mesh, prim, order.material_base, order.vertex_base))
                .unzip_into_vecs(&mut triangles, &mut shading);
            append(&mut self.triangles, triangles);
            append(&mut self.shading, shading);
        }
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

    /// False when packed for wide frames alone ([`Layouts::Wide`]): binary frames then trace
    /// the wide trees.
    pub fn has_binary(&self) -> bool {
        !self.wide_only
    }

    /// The layout a frame asking for `layout` traces: the one packed where only one is.
    pub fn traced_layout(&self, layout: BvhLayout) -> BvhLayout {
        layout.traced_with(self.has_binary(), self.has_wide())
    }

    /// Whether some mesh with triangles traces its binary tree in wide frames: it has no
    /// wide tree (one that would not fit the device, `tracer::prepare`).
    pub fn some_mesh_lacks_wide(&self) -> bool {
        self.meshes.iter().any(|m| !m.has_wide && m.triangle_count > 0)
    }

    /// Append one mesh: its materials, vertices and trees, and its row of the mesh table;
    /// returns its BVH order (its triangles are written from it).
    fn push_mesh(
        &mut self,
        mesh: &Mesh,
        trees: MeshTrees,
        prim_base: u32,
        texture_index: &HashMap<TextureSource, u32>,
    ) -> BvhOrder {
        let MeshTrees { bvh, wide, wide_only, on_device } = trees;
        let material_base = self.materials.len() as u32;
        let with_colors = !mesh.colors.is_empty() && mesh.colors.len() == mesh.positions.len();
        let vertex_base = self.vertices.push_mesh(mesh);
        let texture_of = |m: &Material| {
            m.diffuse_texture
                .as_ref()
                .filter(|_| !mesh.texcoords.is_empty())
                .and_then(|p| texture_index.get(p).copied())
                .unwrap_or(NO_TEXTURE)
        };
        self.materials
            .extend(mesh.materials.iter().map(|m| GpuMaterial::new(m, texture_of(m), with_colors)));
        let triangle_base = self.meshes.last().map_or(0, |m| m.triangle_base + m.triangle_count);
        // Slots, not triangles: a triangle the build cut into pieces fills one slot per leaf.
        let triangle_count = bvh.prim_indices.len() as u32;
        let node_base = self.nodes.len() as u32;
        let keep_binary = !(wide_only && wide.is_some());
        let node_count = if keep_binary { bvh.nodes.len() as u32 } else { 0 };
        let cover = if on_device.is_some() {
            MeshCover::of_box(mesh.bounds())
        } else {
            let corners = |slot: u32| mesh.corners(bvh.prim_indices[slot as usize] as usize);
            MeshCover::of_tree(&bvh.nodes, corners, mesh.bounds())
        };
        if let Some(leaf_size) = on_device {
            let wide = wide.as_ref().map(|w| WideReserve {
                base: self.wide_nodes.len() as u32,
                words: 0, // once the binary nodes' bytes are known (`pack_tables`)
                nodes: w.nodes.len() as u32,
            });
            self.device_builds.push(DeviceBuild {
                triangle_base,
                triangle_count,
                node_base: keep_binary.then_some(node_base),
                wide,
                bounds: mesh.bounds(),
                leaf_size,
            });
        }
        let closed_box = (bvh.prim_indices.len() == 12 && on_device.is_none())
            .then(|| {
                let slots: Vec<_> =
                    bvh.prim_indices.iter().map(|&k| mesh.corners(k as usize)).collect();
                ClosedBox::of(&slots)
            })
            .flatten();
        let whole = on_device.is_none() && bvh.prim_indices.len() == mesh.triangle_count();
        let convex = if whole { super::convex::winding(mesh) } else { 0 };
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
            cover,
            closed_box,
            convex,
        });
        BvhOrder { prims: bvh.prim_indices, material_base, vertex_base }
    }

    /// Rebuild the top level (instance records and their tree) alone; geometry is untouched.
    pub fn set_instances(&mut self, instances: &[Instance]) {
        rebuild_top_level(&mut self.top_level, &self.meshes, self.wide_word_base, instances);
    }

    /// Bytes of each GPU array: triangles (with the shaders' read-ahead), shading, normals,
    /// texture coordinates, colours, materials, nodes (both layouts), instances, the top
    /// level's nodes, texels.
    pub(crate) fn buffer_sizes(&self) -> [u64; 10] {
        self.buffer_sizes_for(self.triangles.len(), self.shading.len())
    }

    /// [`PackedScene::buffer_sizes`] with `triangles` traversal records and `shading` hit
    /// records (a load's, which its upload writes).
    pub(crate) fn buffer_sizes_for(&self, triangles: usize, shading: usize) -> [u64; 10] {
        fn bytes<T>(v: &[T]) -> u64 {
            std::mem::size_of_val(v) as u64
        }
        let v = &self.vertices;
        [
            (triangles * std::mem::size_of::<GpuTriangle>()) as u64
                + crate::contract::TRIANGLE_READ_AHEAD as u64,
            (shading * std::mem::size_of::<GpuTriangleShading>()) as u64,
            bytes(&v.normals),
            bytes(&v.texcoords),
            bytes(&v.colors),
            bytes(&self.materials),
            self.nodes_bytes() as u64,
            bytes(&self.top_level.instances),
            bytes(&self.top_level.nodes),
            bytes(&self.textures.texels),
        ]
    }

    /// Bytes of the BVH nodes, both layouts (the GPU's node buffer).
    pub fn nodes_bytes(&self) -> usize {
        std::mem::size_of_val(self.nodes.as_slice())
            + std::mem::size_of_val(self.wide_nodes.as_slice())
    }

    /// Triangle slots of all meshes.
    pub(crate) fn triangle_count(&self) -> usize {
        self.meshes.last().map_or(0, |m| (m.triangle_base + m.triangle_count) as usize)
    }

    /// The wide nodes of instance `inst`'s mesh (root first), as the CPU tracer walks them.
    pub(crate) fn wide_nodes_of(&self, inst: &GpuInstance) -> &[WideNode] {
        if inst.wide_words == EMPTY {
            return &[];
        }
        let words = inst.wide_words.saturating_sub(self.wide_word_base) as usize;
        self.wide_nodes.get(words / (std::mem::size_of::<WideNode>() / 16)..).unwrap_or(&[])
    }

    /// Keep the top level (the mesh table and instances) and free the rest on another thread:
    /// unmapping a 10M-triangle model's arrays took tens of milliseconds, which the next
    /// frame would wait for.
    pub(crate) fn into_top_level(mut self) -> PackedTopLevel {
        let bottom_bytes = (self.nodes_bytes()
            + self.triangle_count() * std::mem::size_of::<GpuTriangle>())
            as u64;
        let top = PackedTopLevel {
            bottom_bytes,
            meshes: std::mem::take(&mut self.meshes),
            top_level: std::mem::take(&mut self.top_level),
            wide_word_base: self.wide_word_base,
            has_wide: self.has_wide(),
        };
        crate::memory::free_in_background(self);
        top
    }
}

/// A mesh's trees as the packing takes them: the binary one, the wide one when built,
/// whether a mesh with a wide tree leaves its binary nodes out ([`Layouts::Wide`]), and
/// the leaf size of the device's build where the binary one is its stand-in.
struct MeshTrees {
    bvh: Bvh,
    wide: Option<WideBvh>,
    wide_only: bool,
    on_device: Option<u32>,
}

/// What the host keeps of a scene once the GPU holds its geometry: the mesh table, for the
/// instance list (the top level) rebuilt when the model count changes, and that list.
#[derive(Clone, Debug, Default)]
pub struct PackedTopLevel {
    /// Where each mesh sits in the GPU's arrays, and its bounds.
    pub meshes: Vec<PackedMesh>,
    /// The top level uploaded last ([`PackedTopLevel::set_instances`]).
    pub top_level: TopLevel,
    /// As [`PackedScene`]'s: where the wide nodes start in the GPU's node buffer.
    wide_word_base: u32,
    has_wide: bool,
    /// Bytes of the bottom levels on the GPU: every mesh's BVH nodes and triangle records.
    bottom_bytes: u64,
}

/// What a scene holds, for the panel: its meshes and their instances, triangles stored and
/// triangles placed, and the GPU bytes of the two levels.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SceneHolds {
    pub meshes: usize,
    pub instances: usize,
    /// Triangles stored, each mesh's once.
    pub unique_triangles: u64,
    /// Triangles in the world, each instance's.
    pub instanced_triangles: u64,
    /// Instance records and the tree over them.
    pub top_bytes: u64,
    /// Every mesh's BVH nodes and triangle records.
    pub bottom_bytes: u64,
}

impl PackedTopLevel {
    /// Rebuild the instance list alone, as [`PackedScene::set_instances`] does.
    pub fn set_instances(&mut self, instances: &[Instance]) {
        rebuild_top_level(&mut self.top_level, &self.meshes, self.wide_word_base, instances);
    }

    /// True when the wide layout was packed (see [`PackedScene::has_wide`]).
    pub fn has_wide(&self) -> bool {
        self.has_wide
    }

    /// What `scene` (the scene this was packed from) holds.
    pub fn holds(&self, scene: &Scene) -> SceneHolds {
        SceneHolds {
            meshes: scene.meshes.len(),
            instances: scene.instances.len(),
            unique_triangles: scene.meshes.iter().map(|m| m.triangle_count() as u64).sum(),
            instanced_triangles: scene.triangle_count() as u64,
            top_bytes: self.top_level.bytes() as u64,
            bottom_bytes: self.bottom_bytes,
        }
    }
}

/// `top` rebuilt over `instances`: each with its mesh's place in the packed arrays (from
/// `meshes`), and the tree over their world boxes.
fn rebuild_top_level(
    top: &mut TopLevel,
    meshes: &[PackedMesh],
    wide_word_base: u32,
    instances: &[Instance],
) {
    let places: Vec<MeshPlace> = meshes
        .iter()
        .map(|m| MeshPlace {
            node_base: m.node_base,
            triangle_base: m.triangle_base,
            triangle_count: m.triangle_count,
            prim_base: m.prim_base,
            wide_words: if m.has_wide {
                wide_word_base + m.wide_base * (std::mem::size_of::<WideNode>() / 16) as u32
            } else {
                EMPTY
            },
            cover: m.cover,
            closed_box: m.closed_box,
            convex: m.convex,
        })
        .collect();
    top.rebuild(&places, instances);
}

/// The environment buffer as the shader reads it: width, height, then RGB9E5 texels (a
/// black 1x1 image without a map).
pub(crate) fn environment_words(environment: Option<&EnvironmentMap>) -> Vec<u32> {
    match environment {
        Some(env) => {
            let mut words = vec![env.width, env.height];
            words.extend_from_slice(&env.texels);
            words
        }
        None => vec![1, 1, 0],
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
    /// Whether the mesh has a wide tree: without, wide frames trace its binary one.
    pub fn has_wide_tree(&self) -> bool {
        self.has_wide
    }

    /// The mesh's wide BVH as packed (its nodes up to the next mesh's; a device build's
    /// reserve may end in nodes it did not need), empty without one.
    pub fn wide_tree(&self, packed: &PackedScene) -> WideBvh {
        if !self.has_wide {
            return WideBvh::default();
        }
        let end = packed
            .meshes
            .iter()
            .filter(|m| m.has_wide && m.wide_base > self.wide_base)
            .map(|m| m.wide_base as usize)
            .min()
            .unwrap_or(packed.wide_nodes.len());
        WideBvh { nodes: packed.wide_nodes[self.wide_base as usize..end].to_vec() }
    }

    /// The mesh's BVH as built, put back together from `packed` (for validation: tests,
    /// fuzzing; a scene packed for wide frames alone has none).
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
