//! A model's way from a file to the GPU, as the window's loader and `bench --load` both
//! walk it: the model loaded ([`load_model`]) into the scene its spec describes, every
//! mesh's BVH built and the scene packed, phase by phase, all but the triangles and their
//! hit records. Those the upload writes itself, straight from the scene's meshes into its
//! staging memory, so that a load never holds the 56 bytes a triangle of both arrays on
//! the host (they were its peak). [`LoadedScene`] keeps the scene for that upload, so the
//! upload cannot be asked for without it.

use super::packed::{BvhOrder, DeviceFit, Layouts, PackedScene, PackedTopLevel};
use super::prepare::PreparedScene;
use super::records::{shading_record, triangle_record, GpuTriangle, GpuTriangleShading};
use crate::progress::{Cancelled, Phase, Progress};
use crate::scene::formats::LoadError;
use crate::scene::spec::SceneSpec;
use crate::scene::Scene;

/// A loaded scene, packed for its upload (`ComputeTracer::set_loaded_scene`): the tables
/// on the host, the triangles to be written from the scene it keeps.
#[derive(Debug)]
pub struct LoadedScene {
    scene: Scene,
    /// Everything but `triangles` and `shading`, which stay empty.
    packed: PackedScene,
    /// Per mesh, as `packed.meshes`: what its triangles are written from.
    orders: Vec<BvhOrder>,
    /// The loader's and the packing's warnings (a missing .mtl, an unreadable texture...).
    pub warnings: Vec<String>,
}

impl LoadedScene {
    /// Load `spec`'s model and pack the scene around it for frames of `spec.settings.bvh`
    /// (with the binary trees beside wide ones: the window switches), reporting the read,
    /// parse, build and pack phases to `progress` and stopping before the next once
    /// cancelled. The error is one sentence.
    pub fn load(
        spec: &SceneSpec,
        progress: &Progress,
        device: DeviceFit,
    ) -> Result<Self, LoadError> {
        let (model, others, warnings) = spec.load_models(Some(progress))?;
        let scene = spec.scene_of(model, &others);
        let layouts = Layouts::switchable(spec.settings.bvh);
        let mut loaded = Self::pack(scene, layouts, progress, device)?;
        loaded.warnings.splice(0..0, warnings);
        Ok(loaded)
    }

    /// The build and pack phases of [`LoadedScene::load`], on a scene already made; with
    /// `device` as [`PackedScene::with_layouts_within`] takes it.
    pub(crate) fn pack(
        scene: Scene,
        layouts: Layouts,
        progress: &Progress,
        device: DeviceFit,
    ) -> Result<Self, Cancelled> {
        progress.begin(Phase::Build)?;
        let prepared = PreparedScene::new(&scene, layouts, device);
        progress.begin(Phase::Pack)?;
        let (mut packed, orders) = PackedScene::pack_tables(&scene, prepared);
        let warnings = std::mem::take(&mut packed.warnings);
        Ok(Self { scene, packed, orders, warnings })
    }

    /// The scene loaded.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The packed arrays but the triangles and hit records (empty here: [`Self::triangle`]
    /// and [`Self::shading`] make them), for the upload.
    pub(crate) fn tables(&self) -> &PackedScene {
        &self.packed
    }

    /// The SAH cost of mesh `mesh`'s binary tree as tinybvh measures it (both costs 1, over
    /// the root's area) and its node count (inner nodes and leaves), so that builds are
    /// compared at equal quality. None when the mesh was packed with a wide tree alone, or
    /// its tree is the device's to build (not made yet).
    pub fn tree_quality(&self, mesh: usize) -> Option<(f64, u64)> {
        let m = self.packed.meshes.get(mesh)?;
        if self.packed.device_builds.iter().any(|b| b.triangle_base == m.triangle_base) {
            return None;
        }
        let nodes = self.packed.nodes.get(m.node_base as usize..)?.get(..m.node_count as usize)?;
        (!nodes.is_empty())
            .then(|| (crate::bvh::sah_cost(nodes, 1.0, 1.0), crate::bvh::node_count(nodes) as u64))
    }

    /// Triangle slots of all meshes.
    pub fn triangle_count(&self) -> usize {
        self.packed.triangle_count()
    }

    /// Bytes of each GPU array, as [`PackedScene::buffer_sizes`] once the upload has
    /// written the triangles.
    pub(crate) fn buffer_sizes(&self) -> [u64; 10] {
        let count = self.triangle_count();
        self.packed.buffer_sizes_for(count, count)
    }

    /// Triangle `k`'s traversal record, as [`PackedScene::triangles`] holds it.
    pub(crate) fn triangle(&self, k: usize) -> GpuTriangle {
        let (m, prim, _) = self.source(k);
        triangle_record(&self.scene.meshes[m], prim)
    }

    /// Triangle `k`'s hit record, as [`PackedScene::shading`] holds it.
    pub(crate) fn shading(&self, k: usize) -> GpuTriangleShading {
        let (m, prim, order) = self.source(k);
        shading_record(&self.scene.meshes[m], prim, order.material_base, order.vertex_base)
    }

    /// Triangle slot `k`'s mesh, its index in the mesh's file order, and the mesh's order.
    fn source(&self, k: usize) -> (usize, u32, &BvhOrder) {
        let meshes = &self.packed.meshes;
        let m = meshes.partition_point(|m| m.triangle_base as usize <= k) - 1;
        let order = &self.orders[m];
        (m, order.prims[k - meshes[m].triangle_base as usize], order)
    }

    /// Once uploaded: the scene and the top level, the one call that drops what the GPU now
    /// holds (freed on another thread, which the next frame does not wait for).
    pub fn uploaded(self) -> (Scene, PackedTopLevel) {
        crate::memory::free_in_background(self.orders);
        (self.scene, self.packed.into_top_level())
    }
}
