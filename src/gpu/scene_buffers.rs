//! The packed scene in device-local storage buffers, checked against the device's limits
//! before anything is uploaded.

use std::sync::Arc;

use ash::vk;

use super::buffer::GpuBuffer;
use super::bvh_build::{BuildAhead, BvhBuildPass};
use super::context::GpuContext;
use super::error::GpuError;
use crate::bvh::BvhNode;
use crate::scene::paper::MAX_MODELS;
use crate::tracer::loaded::LoadedScene;
use crate::tracer::packed::{
    environment_words, DeviceBuild, GpuInstance, GpuTriangle, GpuTriangleShading, PackedScene,
    TopLevel,
};
use crate::tracer::textures::EnvironmentMap;

/// Room in the instance buffers: every model copy plus the mirror box, plus headroom, so
/// that a change of the model count writes them in place.
pub(crate) const INSTANCE_CAPACITY: usize = MAX_MODELS as usize + 8;

/// Device buffers of one packed scene.
pub struct SceneBuffers {
    pub(crate) triangles: GpuBuffer,
    pub(crate) shading: GpuBuffer,
    pub(crate) vertex_normals: GpuBuffer,
    pub(crate) vertex_texcoords: GpuBuffer,
    pub(crate) vertex_colors: GpuBuffer,
    pub(crate) materials: GpuBuffer,
    pub(crate) nodes: GpuBuffer,
    pub(crate) instances: GpuBuffer,
    /// The top level's tree over the instances.
    pub(crate) top_nodes: GpuBuffer,
    /// The mesh table the instances index (fixed with the meshes).
    pub(crate) meshes: GpuBuffer,
    pub(crate) texels: GpuBuffer,
    pub(crate) texture_infos: GpuBuffer,
    pub(crate) environment: GpuBuffer,
    /// Instances currently uploaded.
    pub(crate) instance_count: u32,
    /// Whether they are one instance, alone or in a closed-box enclosure
    /// (`TopLevel::is_one_instance`).
    pub(crate) one_instance: bool,
    /// Bytes of device memory the scene occupies.
    pub(crate) bytes: u64,
    /// Whether every mesh with triangles has a wide tree, so that wide frames may run the
    /// kernel without the binary traversal (`TracePass`).
    pub(crate) every_mesh_wide: bool,
    /// The flags the top level asks of every frame (`TopLevel::frame_flags`: sphere
    /// leaves, convex copies).
    pub(crate) frame_flags: u32,
}

/// Refuse a scene whose buffers exceed the device's storage-buffer range or memory.
pub fn check_fits(ctx: &GpuContext, packed: &PackedScene) -> Result<(), GpuError> {
    check_sizes(ctx, packed.buffer_sizes())
}

/// [`check_fits`] on the bytes of each buffer, in `PackedScene::buffer_sizes`' order.
fn check_sizes(ctx: &GpuContext, sizes: [u64; 10]) -> Result<(), GpuError> {
    let names = [
        "triangle",
        "shading",
        "vertex normal",
        "texture coordinate",
        "vertex colour",
        "material",
        "BVH node",
        "instance",
        "top-level node",
        "texture",
    ];
    let limit = ctx.info.max_storage_buffer_range;
    for (name, bytes) in names.into_iter().zip(sizes) {
        if bytes > limit {
            return Err(GpuError::SceneTooLarge { buffer: name, bytes, limit });
        }
    }
    let total: u64 = sizes.iter().sum();
    if ctx.info.device_local_bytes > 0 && total > ctx.info.device_local_bytes / 10 * 9 {
        return Err(GpuError::SceneTooLarge {
            buffer: "whole scene",
            bytes: total,
            limit: ctx.info.device_local_bytes / 10 * 9,
        });
    }
    Ok(())
}

/// Refuse a scene of `triangles` triangle slots whose triangle buffer would pass the
/// device's storage-buffer `limit`, with the message the upload would give: the count is
/// known before the BVH build (issue #43: `torusknot:4M` on lavapipe failed only after a 10 s
/// build and 1 GB).
pub fn check_triangle_count(triangles: u64, limit: u64) -> Result<(), GpuError> {
    let item = std::mem::size_of::<crate::tracer::packed::GpuTriangle>() as u64;
    let bytes = triangles.saturating_mul(item).saturating_add(READ_AHEAD as u64);
    if bytes > limit {
        return Err(GpuError::SceneTooLarge { buffer: "triangle", bytes, limit });
    }
    Ok(())
}

/// [`check_triangle_count`] on every mesh of `scene` (a lower bound of its triangle slots:
/// the build may cut triangles into more), before its BVH is built; the refusal names the
/// model (`label`) and its count, which the upload's own refusal cannot.
pub fn check_before_build(
    scene: &crate::scene::Scene,
    label: &str,
    limit: u64,
) -> Result<(), String> {
    let triangles = scene.meshes.iter().map(|m| m.triangle_count() as u64).sum();
    check_triangle_count(triangles, limit)
        .map_err(|e| format!("{label} has {triangles} triangles, before its BVH is built: {e}"))
}

/// The triangle, hit-record and node buffers' usage: the vendor path reads the triangles
/// back to build the driver's structures (no host copy is kept); the test of what a load
/// writes reads both, and trees the device built are read back.
const TRIANGLE_USAGE: vk::BufferUsageFlags =
    vk::BufferUsageFlags::from_raw(STORAGE.as_raw() | vk::BufferUsageFlags::TRANSFER_SRC.as_raw());
const STORAGE: vk::BufferUsageFlags = vk::BufferUsageFlags::STORAGE_BUFFER;
/// The shaders may read this far past the last triangle (the contract's
/// TRIANGLE_READ_AHEAD); the triangle buffer ends in as many zero bytes.
const READ_AHEAD: usize = crate::contract::TRIANGLE_READ_AHEAD as usize;

impl SceneBuffers {
    /// Upload the packed scene.
    pub fn upload(ctx: &Arc<GpuContext>, packed: &PackedScene) -> Result<Self, GpuError> {
        check_fits(ctx, packed)?;
        let (records, ahead) = beside_build_ahead(ctx, packed, || {
            let triangles = GpuBuffer::device_local_with_parts(
                ctx,
                &[bytemuck::cast_slice(&packed.triangles), &[0; READ_AHEAD]],
                TRIANGLE_USAGE,
                "triangles",
            )?;
            let shading = GpuBuffer::device_local_with(
                ctx,
                bytemuck::cast_slice(&packed.shading),
                TRIANGLE_USAGE,
                "shading",
            )?;
            Ok([triangles, shading])
        })?;
        Self::around_triangles(ctx, packed, records, ahead)
    }

    /// Upload a loaded scene: its triangles and hit records are written here, into the
    /// staging memory, from the scene's meshes.
    pub(crate) fn upload_loaded(
        ctx: &Arc<GpuContext>,
        loaded: &LoadedScene,
    ) -> Result<Self, GpuError> {
        check_sizes(ctx, loaded.buffer_sizes())?;
        let count = loaded.triangle_count();
        let (records, ahead) = beside_build_ahead(ctx, loaded.tables(), || {
            let triangles = GpuBuffer::device_local_made(
                ctx,
                count,
                READ_AHEAD,
                TRIANGLE_USAGE,
                "triangles",
                |k| loaded.triangle(k),
            )?;
            let shading =
                GpuBuffer::device_local_made(ctx, count, 0, TRIANGLE_USAGE, "shading", |k| {
                    loaded.shading(k)
                })?;
            Ok([triangles, shading])
        })?;
        Self::around_triangles(ctx, loaded.tables(), records, ahead)
    }

    /// The scene's buffers around its triangles and hit records, already uploaded: the
    /// rest of `packed` uploaded, and its instances.
    fn around_triangles(
        ctx: &Arc<GpuContext>,
        packed: &PackedScene,
        [triangles, shading]: [GpuBuffer; 2],
        ahead: Option<BuildAhead>,
    ) -> Result<Self, GpuError> {
        let storage = |bytes: &[u8], name| GpuBuffer::device_local_with(ctx, bytes, STORAGE, name);
        let v = &packed.vertices;
        let vertex_normals = storage(bytemuck::cast_slice(&v.normals), "vertex normals")?;
        let vertex_texcoords = storage(bytemuck::cast_slice(&v.texcoords), "vertex texcoords")?;
        let vertex_colors = storage(bytemuck::cast_slice(&v.colors), "vertex colours")?;
        let materials = storage(bytemuck::cast_slice(&packed.materials), "materials")?;
        let nodes = node_buffer(ctx, packed)?;
        let top = &packed.top_level;
        let instances = top_level_buffer::<GpuInstance>(ctx, top.instances.len(), "instances")?;
        let top_nodes = top_level_buffer::<BvhNode>(ctx, top.nodes.len(), "top-level nodes")?;
        let meshes = storage(bytemuck::cast_slice(&top.meshes), "mesh table")?;
        let texels = storage(bytemuck::cast_slice(&packed.textures.texels), "texels")?;
        let texture_infos = storage(bytemuck::cast_slice(&packed.textures.infos), "texture infos")?;
        let environment_words = environment_words(packed.environment.as_ref());
        let environment = storage(bytemuck::cast_slice(&environment_words), "environment")?;
        let mut s = Self {
            triangles,
            shading,
            vertex_normals,
            vertex_texcoords,
            vertex_colors,
            materials,
            nodes,
            instances,
            top_nodes,
            meshes,
            texels,
            texture_infos,
            environment,
            instance_count: 0,
            one_instance: false,
            bytes: 0,
            every_mesh_wide: packed.meshes.iter().all(|m| m.has_wide || m.triangle_count == 0),
            frame_flags: 0,
        };
        s.bytes = s.all().iter().map(|b| b.size).sum();
        s.set_instances(ctx, &packed.top_level)?;
        s.build_on_device(ctx, &packed.device_builds, ahead)?;
        Ok(s)
    }

    /// Build the binary trees left to the device (`tracer::prepare`), in place: each
    /// mesh's nodes written and its triangles and hit records put in its tree's order.
    /// `ahead`: the first build's pipelines and scratch memory, made during the upload.
    fn build_on_device(
        &self,
        ctx: &Arc<GpuContext>,
        builds: &[DeviceBuild],
        ahead: Option<BuildAhead>,
    ) -> Result<(), GpuError> {
        if builds.is_empty() {
            return Ok(());
        }
        let start = std::time::Instant::now();
        let (pass, mut scratch) = match ahead {
            Some(a) => (a.pass, Some(a.scratch)),
            None => (BvhBuildPass::new(ctx)?, None),
        };
        for build in builds {
            pass.build([&self.triangles, &self.shading, &self.nodes], build, scratch.take())?;
        }
        let triangles: u64 = builds.iter().map(|b| u64::from(b.triangle_count)).sum();
        log::info!(
            "built the BVH of {triangles} triangles on the device in {:.1} ms after the upload",
            start.elapsed().as_secs_f64() * 1e3,
        );
        Ok(())
    }

    /// Read what the device built back into `packed` (the scene these buffers hold): the
    /// nodes, triangles and hit records of each mesh it built, so that the host's arrays are
    /// the GPU's again (the CPU tracer, tests). Afterwards `packed` has no builds pending.
    pub(crate) fn read_back_device_builds(&self, packed: &mut PackedScene) -> Result<(), GpuError> {
        /// `into[first..][..count]` from `buffer` at `offset` bytes.
        fn read<T: bytemuck::Pod>(
            buffer: &GpuBuffer,
            offset: u64,
            (first, count): (u32, u32),
            into: &mut [T],
        ) -> Result<(), GpuError> {
            let size = std::mem::size_of::<T>() as u64;
            let bytes = buffer.download_range(offset, u64::from(count) * size)?;
            into[first as usize..][..count as usize].copy_from_slice(bytemuck::cast_slice(&bytes));
            Ok(())
        }
        for b in std::mem::take(&mut packed.device_builds) {
            if let Some(base) = b.node_base {
                let at = u64::from(base) * std::mem::size_of::<BvhNode>() as u64;
                read(&self.nodes, at, (base, b.nodes()), &mut packed.nodes)?;
            }
            if let Some(w) = b.wide {
                let at = u64::from(w.words) * 16;
                read(&self.nodes, at, (w.base, w.nodes), &mut packed.wide_nodes)?;
            }
            let tris = (b.triangle_base, b.triangle_count);
            let at = |size: usize| u64::from(b.triangle_base) * size as u64;
            read(&self.triangles, at(size_of::<GpuTriangle>()), tris, &mut packed.triangles)?;
            read(&self.shading, at(size_of::<GpuTriangleShading>()), tris, &mut packed.shading)?;
        }
        Ok(())
    }

    /// One line per buffer: where its memory lives (`bench --verbose`).
    pub(crate) fn describe(&self) -> Vec<String> {
        self.all().iter().map(|b| b.describe()).collect()
    }

    /// Every buffer of the scene.
    fn all(&self) -> [&GpuBuffer; 13] {
        [
            &self.triangles,
            &self.shading,
            &self.vertex_normals,
            &self.vertex_texcoords,
            &self.vertex_colors,
            &self.materials,
            &self.nodes,
            &self.instances,
            &self.top_nodes,
            &self.meshes,
            &self.texels,
            &self.texture_infos,
            &self.environment,
        ]
    }

    /// Replace the environment image (None: misses see the background colour; rebind the
    /// trace pass afterwards: the buffer is new); the GPU must not be using it.
    pub(crate) fn set_environment(
        &mut self,
        ctx: &Arc<GpuContext>,
        environment: Option<&EnvironmentMap>,
    ) -> Result<(), GpuError> {
        let words = environment_words(environment);
        self.bytes -= self.environment.size;
        self.environment = GpuBuffer::device_local_with(
            ctx,
            bytemuck::cast_slice(&words),
            STORAGE,
            "environment",
        )?;
        self.bytes += self.environment.size;
        Ok(())
    }

    /// Replace the top level (instance records and their tree); the GPU must not be using
    /// it. Returns true when the buffers were too small and are new (rebind the trace pass).
    pub(crate) fn set_instances(
        &mut self,
        ctx: &Arc<GpuContext>,
        top: &TopLevel,
    ) -> Result<bool, GpuError> {
        let records: &[u8] = bytemuck::cast_slice(&top.instances);
        let nodes: &[u8] = bytemuck::cast_slice(&top.nodes);
        let grown =
            records.len() as u64 > self.instances.size || nodes.len() as u64 > self.top_nodes.size;
        if grown {
            self.bytes -= self.instances.size + self.top_nodes.size;
            self.instances =
                top_level_buffer::<GpuInstance>(ctx, top.instances.len(), "instances")?;
            self.top_nodes = top_level_buffer::<BvhNode>(ctx, top.nodes.len(), "top-level nodes")?;
            self.bytes += self.instances.size + self.top_nodes.size;
        }
        self.instances.upload(records)?;
        self.top_nodes.upload(nodes)?;
        self.instance_count = top.instances.len() as u32;
        self.one_instance = top.is_one_instance();
        self.frame_flags = top.frame_flags();
        Ok(grown)
    }
}

/// `upload` (the triangle and hit-record buffers: most of an upload) run beside the making
/// of what the first of `packed`'s device builds needs, on another thread.
fn beside_build_ahead(
    ctx: &Arc<GpuContext>,
    packed: &PackedScene,
    upload: impl FnOnce() -> Result<[GpuBuffer; 2], GpuError>,
) -> Result<([GpuBuffer; 2], Option<BuildAhead>), GpuError> {
    let Some(first) = packed.device_builds.first() else { return Ok((upload()?, None)) };
    std::thread::scope(|s| {
        let ahead = s.spawn(|| BuildAhead::new(ctx, first));
        let records = upload();
        let ahead =
            ahead.join().unwrap_or(Err(GpuError::NotReady("the BVH build's thread failed")));
        Ok((records?, Some(ahead?)))
    })
}

/// The BVH nodes, both layouts in one buffer: the shader reads the binary nodes as `nodes`,
/// the wide ones as 16-byte words (`wide_nodes`). The nodes reserved for the trees the
/// device builds are not uploaded (the build writes them: at 100M triangles 2.3-3.2 GB of
/// zeros, a third of a second).
fn node_buffer(ctx: &Arc<GpuContext>, packed: &PackedScene) -> Result<GpuBuffer, GpuError> {
    let binary: &[u8] = bytemuck::cast_slice(&packed.nodes);
    let wide: &[u8] = bytemuck::cast_slice(&packed.wide_nodes);
    let node = std::mem::size_of::<BvhNode>();
    let wide_node = std::mem::size_of::<crate::bvh::wide::WideNode>();
    // The reserved byte ranges, in the buffer's offsets.
    let mut holes: Vec<std::ops::Range<usize>> = Vec::new();
    for b in &packed.device_builds {
        if let Some(base) = b.node_base {
            let at = base as usize * node;
            holes.push(at..at + b.nodes() as usize * node);
        }
        if let Some(w) = b.wide {
            let at = w.words as usize * 16;
            holes.push(at..at + w.nodes as usize * wide_node);
        }
    }
    // The bytes between every two cuts are either all reserved or all uploaded, from one
    // layout's array.
    let total = binary.len() + wide.len();
    let mut cuts: Vec<usize> = holes.iter().flat_map(|h| [h.start, h.end]).collect();
    cuts.extend([0, binary.len(), total]);
    cuts.sort_unstable();
    cuts.dedup();
    let mut pieces = Vec::new();
    for r in cuts.windows(2).map(|w| w[0]..w[1]) {
        if holes.iter().any(|h| h.start <= r.start && r.end <= h.end) {
            continue;
        }
        let (array, base) = if r.start < binary.len() { (binary, 0) } else { (wide, binary.len()) };
        pieces.push((r.start, &array[r.start - base..r.end - base]));
    }
    // Read back where the device built trees (`read_back_device_builds`).
    GpuBuffer::device_local_with_pieces(ctx, total, &pieces, TRIANGLE_USAGE, "bvh nodes")
}

/// A buffer of the top level, written by `SceneBuffers::set_instances`: room for `T`s of
/// every model copy and the mirror box (and `count`, should a scene have more).
fn top_level_buffer<T>(
    ctx: &Arc<GpuContext>,
    count: usize,
    name: &'static str,
) -> Result<GpuBuffer, GpuError> {
    let capacity = (INSTANCE_CAPACITY.max(count).max(1) * std::mem::size_of::<T>()) as u64;
    GpuBuffer::new(
        ctx,
        capacity,
        STORAGE | vk::BufferUsageFlags::TRANSFER_DST,
        gpu_allocator::MemoryLocation::GpuOnly,
        name,
    )
}

#[cfg(test)]
mod tests {
    use glam::Vec2;

    use super::*;
    use crate::gpu::{ContextOptions, GpuContext};
    use crate::progress::Progress;
    use crate::scene::paper::{paper_scene, prepare_mesh, LightOrbit};
    use crate::scene::primitives::PaperModel;
    use crate::tracer::packed::{DeviceFit, Layouts};

    #[test]
    fn a_scene_packed_for_loading_uploads_the_same_bytes() {
        // Triangles and hit records written into the staging memory from the meshes equal
        // the host arrays of a full packing, for the model and the mirror box after it.
        let ctx = GpuContext::new(&ContextOptions::validated())
            .expect("Vulkan with the validation layer");
        let mut mesh = PaperModel::TorusKnot.mesh();
        prepare_mesh(&mut mesh);
        mesh.texcoords = mesh.positions.iter().map(|p| Vec2::new(p.x, p.y)).collect();
        mesh.colors = vec![[10, 20, 30, 255]; mesh.positions.len()];
        let scene = paper_scene(mesh, 2, LightOrbit::default());
        let full = PackedScene::new(&scene);
        let loaded =
            LoadedScene::pack(scene, Layouts::Binary, &Progress::default(), DeviceFit::NONE)
                .unwrap();
        assert!(
            loaded.tables().triangles.is_empty() && loaded.tables().shading.is_empty(),
            "nothing of them on the host"
        );
        assert_eq!(loaded.buffer_sizes(), full.buffer_sizes());
        let written = SceneBuffers::upload_loaded(&ctx, &loaded).unwrap();
        let triangles: &[u8] = bytemuck::cast_slice(&full.triangles);
        let shading: &[u8] = bytemuck::cast_slice(&full.shading);
        assert_eq!(written.triangles.download(triangles.len() as u64).unwrap(), triangles);
        assert_eq!(written.shading.download(shading.len() as u64).unwrap(), shading);
        // Both ways of uploading end the triangles in the zeroed read-ahead.
        let read_ahead = crate::contract::TRIANGLE_READ_AHEAD as usize;
        let both = SceneBuffers::upload(&ctx, &full).unwrap();
        for buffer in [&written.triangles, &both.triangles] {
            let bytes = buffer.download((triangles.len() + read_ahead) as u64).unwrap();
            assert_eq!(&bytes[..triangles.len()], triangles);
            assert!(bytes[triangles.len()..].iter().all(|&b| b == 0));
        }
        let m = ctx.validation_messages();
        assert!(m.is_empty(), "{m:?}");
    }

    /// The end of what `load_triangle_pair` in shaders/scene.glsl reads for a leaf starting
    /// at triangle k: words 5k/2 to 5k/2 + 4, and one more for k odd.
    fn pair_read_end(k: usize) -> usize {
        16 * ((5 * k) / 2 + if k % 2 == 1 { 6 } else { 5 })
    }

    #[test]
    fn the_read_ahead_covers_a_pair_starting_at_the_last_triangle() {
        let read_ahead = crate::contract::TRIANGLE_READ_AHEAD as usize;
        let size = std::mem::size_of::<crate::tracer::packed::GpuTriangle>();
        for count in 1..64 {
            assert!(pair_read_end(count - 1) <= count * size + read_ahead, "{count} triangles");
        }
        // And no more than the worst case needs.
        assert_eq!((1..64).map(|n| pair_read_end(n - 1) - n * size).max(), Some(read_ahead));
    }
}
