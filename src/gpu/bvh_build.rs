//! A mesh's BVHs built on the device, in place in the scene's buffers: a linear BVH
//! (Karras 2012), collapsed into the compressed wide tree where one is kept, for meshes so
//! big that the CPU build is most of a load (100M triangles: 4 s binary and 8 s wide on 16
//! cores, against 0.4 and 0.9 s here on an H200). The CPU build stays the reference and the
//! default below `tracer::DEVICE_BUILD_FROM` triangles: its SAH trees trace 1.2-1.3x faster.
//!
//! The mesh's triangles and hit records are uploaded in file order, with its nodes reserved
//! (`tracer::prepare`); then, in one submission (`shaders/build/`):
//! 1. where the binary tree is the last word, the triangles and hit records are copied out
//!    to scratch buffers (the collapse instead writes them last, from scratch copies);
//! 2. `morton.comp`: each triangle's key is the Morton code of its centroid (10 bits an
//!    axis of the mesh box);
//! 3. a stable least-significant-digit radix sort of (key, index), 4 bits a pass
//!    (`radix_count`, `radix_scan`, `radix_scatter`);
//! 4. `hierarchy.comp`: runs of sorted triangles are the leaves (1 to 8 a leaf: as few as
//!    the node buffer has room for, `tracer::prepare`), and each inner node is read off the
//!    sorted codes;
//! 5. `leaves.comp`: each leaf's triangles and hit records moved into sorted order, its box
//!    made and carried up the tree with the subtree's height;
//! 6. `collapse.comp` and `next_level.comp`, where a wide tree is reserved: the greedy
//!    collapse into eight-wide nodes, a level a dispatch, the triangles moved into the wide
//!    leaves' order (and the binary tree, where kept, pointed at them).

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::barrier::{self, Access};
use super::buffer::GpuBuffer;
use super::context::GpuContext;
use super::error::GpuError;
use super::pipeline::{
    allocate_one_set, bind_compute, create_compute_pipeline, create_layout, create_set_layout,
    destroy_pipeline_objects, words,
};
use super::timer::GpuTimer;
use crate::tracer::packed::{DeviceBuild, GpuTriangle, GpuTriangleShading};

static MORTON: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/build_morton.spv"));
static RADIX_COUNT: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/build_radix_count.spv"));
static RADIX_SCAN: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/build_radix_scan.spv"));
static RADIX_SCATTER: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/build_radix_scatter.spv"));
static HIERARCHY: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/build_hierarchy.spv"));
static LEAVES: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/build_leaves.spv"));
static COLLAPSE: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/build_collapse.spv"));
static NEXT_LEVEL: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/build_next_level.spv"));

/// The kernels, in [`BvhBuildPass::pipelines`]' order.
const KERNELS: [(&[u8], &str); 8] = [
    (MORTON, "morton"),
    (RADIX_COUNT, "radix count"),
    (RADIX_SCAN, "radix scan"),
    (RADIX_SCATTER, "radix scatter"),
    (HIERARCHY, "hierarchy"),
    (LEAVES, "leaves"),
    (COLLAPSE, "collapse"),
    (NEXT_LEVEL, "next level"),
];
const MORTON_K: usize = 0;
const COUNT_K: usize = 1;
const SCAN_K: usize = 2;
const SCATTER_K: usize = 3;
const HIERARCHY_K: usize = 4;
const LEAVES_K: usize = 5;
const COLLAPSE_K: usize = 6;
const NEXT_LEVEL_K: usize = 7;

/// Bits of the Morton codes (10 an axis) and of a radix pass's digit; items of a radix
/// work group (`SORT_BLOCK` in `shaders/build/common.glsl`).
const KEY_BITS: u32 = 30;
const RADIX_BITS: u32 = 4;
const SORT_BLOCK: u32 = 2048;
/// Threads of the one-item-a-thread kernels.
const GROUP: u32 = 256;
/// Buffers the kernels bind (`common.glsl`).
const BINDINGS: u32 = 10;
/// Words of the collapse's queue header (`HEADER` in `collapse.comp`), and where in it the
/// next level's dispatch arguments lie.
const HEADER: u64 = 16;
const INDIRECT_WORD: u64 = 8;
/// Levels of the collapse recorded: each takes at least one binary level, and the binary
/// tree is at most 30 + log2(leaves) + 1 < 64 deep (`hierarchy.comp`); the levels past the
/// tree's depth dispatch no work group.
const LEVELS: u32 = 64;

/// The kernels' push constants (`Build` in `common.glsl`).
#[repr(C)]
#[derive(Clone, Copy, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct BuildConstants {
    lo: [f32; 4],
    cells: [f32; 4],
    count: u32,
    tri_base: u32,
    node_base: u32,
    leaf_size: u32,
    shift: u32,
    flip: u32,
    blocks: u32,
    leaves: u32,
    wide_word: u32,
    wide_limit: u32,
    bin_base: u32,
    patch_binary: u32,
    level: u32,
}

/// The build's pipelines and their two descriptor sets: the binary build's, and the
/// collapse's, which reads what the first writes.
pub(crate) struct BvhBuildPass {
    ctx: Arc<GpuContext>,
    pipelines: [vk::Pipeline; 8],
    layout: vk::PipelineLayout,
    set_layout: vk::DescriptorSetLayout,
    pools: [vk::DescriptorPool; 2],
    build_set: vk::DescriptorSet,
    collapse_set: vk::DescriptorSet,
}

impl BvhBuildPass {
    /// The build's pipelines.
    pub(crate) fn new(ctx: &Arc<GpuContext>) -> Result<Self, GpuError> {
        let bindings: Vec<_> = (0..BINDINGS)
            .map(|b| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(b)
                    .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                    .descriptor_count(1)
                    .stage_flags(vk::ShaderStageFlags::COMPUTE)
            })
            .collect();
        let set_layout =
            create_set_layout(ctx, &bindings, "creating the BVH build's descriptor layout")?;
        let mut pass = Self {
            ctx: ctx.clone(),
            pipelines: [vk::Pipeline::null(); 8],
            layout: vk::PipelineLayout::null(),
            set_layout,
            pools: [vk::DescriptorPool::null(); 2],
            build_set: vk::DescriptorSet::null(),
            collapse_set: vk::DescriptorSet::null(),
        };
        // From here on Drop destroys whatever was made (null handles are ignored).
        pass.layout = create_layout(
            ctx,
            set_layout,
            vk::ShaderStageFlags::COMPUTE,
            std::mem::size_of::<BuildConstants>(),
            "creating the BVH build's pipeline layout",
        )?;
        for (pipeline, (spirv, _)) in pass.pipelines.iter_mut().zip(KERNELS) {
            *pipeline = create_compute_pipeline(
                ctx,
                pass.layout,
                &words(spirv),
                vk::PipelineCreateFlags::empty(),
                ["loading a BVH build kernel", "creating a BVH build pipeline"],
            )?;
        }
        let sizes = [vk::DescriptorPoolSize {
            ty: vk::DescriptorType::STORAGE_BUFFER,
            descriptor_count: BINDINGS,
        }];
        let what = [
            "creating the BVH build's descriptor pool",
            "allocating the BVH build's descriptor set",
        ];
        (pass.pools[0], pass.build_set) = allocate_one_set(ctx, set_layout, &sizes, what)?;
        (pass.pools[1], pass.collapse_set) = allocate_one_set(ctx, set_layout, &sizes, what)?;
        Ok(pass)
    }

    /// Build `mesh`'s trees (uploaded with its triangles and hit records in file order;
    /// `tracer::prepare` leaves the device meshes of more than one leaf): the binary tree
    /// into `scene`'s nodes (or scratch memory, where only the wide tree is kept), the wide
    /// tree collapsed from it where one is reserved, and the triangles and hit records put
    /// in the order of the tree's leaves. `scene` holds the triangle, hit-record and node
    /// buffers. Waits for the GPU.
    /// `scratch`: its scratch memory where it was allocated ahead ([`BuildAhead`]).
    pub(crate) fn build(
        &self,
        scene: [&GpuBuffer; 3],
        mesh: &DeviceBuild,
        scratch: Option<Scratch>,
    ) -> Result<(), GpuError> {
        assert!(mesh.leaves() >= 2, "a mesh of one leaf is built on the CPU");
        let scratch = match scratch {
            Some(s) => s,
            None => Scratch::new(&self.ctx, mesh)?,
        };
        let [triangles, shading, nodes] = scene;
        let [source_triangles, source_shading] =
            scratch.copied.as_ref().map_or([triangles, shading], |[t, s]| [t, s]);
        let [built_triangles, built_shading] =
            scratch.sorted.as_ref().map_or([triangles, shading], |[t, s]| [t, s]);
        let binary_nodes = scratch.binary.as_ref().unwrap_or(nodes);
        let histogram = &scratch.histogram;
        self.bind(
            self.build_set,
            &[
                built_triangles,
                built_shading,
                binary_nodes,
                source_triangles,
                source_shading,
                &scratch.sort,
                histogram,
                &scratch.tree,
                histogram,
                histogram,
            ],
        );
        if let (Some([t, s]), Some(queue)) = (&scratch.sorted, &scratch.queue) {
            // The sorted copies in, the scene's buffers out.
            let (sort, tree) = (&scratch.sort, &scratch.tree);
            let buffers =
                [triangles, shading, nodes, t, s, sort, histogram, tree, binary_nodes, queue];
            self.bind(self.collapse_set, &buffers);
        }
        // Each step timed (`RUST_LOG=meshtracer=debug`): the copies, the sort, the binary
        // tree, the collapse.
        let timer = GpuTimer::new(&self.ctx, 4)?;
        self.ctx.one_shot(|cmd| {
            let time = |slot: u32, end: bool| match (&timer, end) {
                (Some(t), false) => t.begin(cmd, slot, true),
                (Some(t), true) => t.end(cmd, slot),
                (None, _) => {}
            };
            time(0, false);
            self.record_start(cmd, mesh, [triangles, shading], &scratch);
            time(0, true);
            time(1, false);
            let base = constants(mesh, scratch.sorted.is_some());
            self.record_sort(cmd, &base);
            time(1, true);
            time(2, false);
            self.step(cmd, HIERARCHY_K, &base, (base.leaves - 1).div_ceil(GROUP));
            self.step(cmd, LEAVES_K, &base, base.leaves.div_ceil(GROUP));
            time(2, true);
            time(3, false);
            if let (Some(wide), Some(queue)) = (mesh.wide, &scratch.queue) {
                let collapse = BuildConstants {
                    tri_base: mesh.triangle_base,
                    wide_word: 4 * wide.words,
                    wide_limit: wide.nodes,
                    bin_base: base.node_base,
                    patch_binary: u32::from(mesh.node_base.is_some()),
                    ..base
                };
                self.record_collapse(cmd, &collapse, queue);
            }
            time(3, true);
            // The frames after read what this wrote (and the vendor path copies triangles).
            let after = [Access::ComputeRead, Access::TransferRead];
            barrier::buffers(&self.ctx.device, cmd, &[Access::ComputeWrite], &after);
        })?;
        if let Some(t) = &timer {
            let ms = |slot| t.read_ms(slot).unwrap_or(f64::NAN);
            log::debug!(
                "device BVH build of {} triangles, leaves of {}: copies {:.1} ms, sort {:.1} \
                 ms, binary tree {:.1} ms, collapse {:.1} ms",
                mesh.triangle_count,
                mesh.leaf_size,
                ms(0),
                ms(1),
                ms(2),
                ms(3)
            );
        }
        scratch.check_collapse(mesh)
    }

    /// Record the start: the copies of the sort's input, the bookkeeping zeroed, the
    /// collapse's first item queued.
    fn record_start(
        &self,
        cmd: vk::CommandBuffer,
        mesh: &DeviceBuild,
        [triangles, shading]: [&GpuBuffer; 2],
        scratch: &Scratch,
    ) {
        let device = &self.ctx.device;
        let n = u64::from(mesh.triangle_count);
        // SAFETY: `cmd` is recording; every buffer lives until the waited-for submission
        // ends; the regions lie within them (the upload and `Scratch::new` sized them).
        unsafe {
            if let Some([t, s]) = &scratch.copied {
                for (from, to, size) in
                    [(triangles, t, TRIANGLE_BYTES), (shading, s, SHADING_BYTES)]
                {
                    let region = vk::BufferCopy {
                        src_offset: u64::from(mesh.triangle_base) * size,
                        dst_offset: 0,
                        size: n * size,
                    };
                    device.cmd_copy_buffer(cmd, from.buffer, to.buffer, &[region]);
                }
            }
            device.cmd_fill_buffer(cmd, scratch.tree.buffer, 0, vk::WHOLE_SIZE, 0);
            if let Some(queue) = &scratch.queue {
                // One item, the binary root as wide node 0; its node is taken.
                let mut header = [0u32; HEADER as usize + 3];
                (header[0], header[2]) = (1, 1);
                header[8..11].copy_from_slice(&[1, 1, 1]);
                device.cmd_update_buffer(cmd, queue.buffer, 0, bytemuck::cast_slice(&header));
            }
        }
        barrier::buffers(
            device,
            cmd,
            &[Access::TransferWrite, Access::TransferRead, Access::ComputeRead],
            &[Access::ComputeRead, Access::ComputeWrite, Access::IndirectRead],
        );
    }

    /// Record the Morton codes and their radix sort: an even number of passes, so that the
    /// sorted keys end in the A arrays.
    fn record_sort(&self, cmd: vk::CommandBuffer, base: &BuildConstants) {
        self.step(cmd, MORTON_K, base, base.count.div_ceil(GROUP));
        let passes = KEY_BITS.div_ceil(RADIX_BITS).next_multiple_of(2);
        for pass in 0..passes {
            let c = BuildConstants { shift: pass * RADIX_BITS, flip: pass % 2, ..*base };
            self.step(cmd, COUNT_K, &c, base.blocks);
            self.step(cmd, SCAN_K, &c, 1);
            self.step(cmd, SCATTER_K, &c, base.blocks);
        }
    }

    /// Record the collapse, a level a dispatch (indirect: the level before queued its
    /// items), as many as the binary tree is deep at most.
    fn record_collapse(
        &self,
        cmd: vk::CommandBuffer,
        collapse: &BuildConstants,
        queue: &GpuBuffer,
    ) {
        let device = &self.ctx.device;
        let after = [Access::ComputeRead, Access::ComputeWrite, Access::IndirectRead];
        for level in 0..LEVELS {
            let c = BuildConstants { level, ..*collapse };
            let args = Groups::Indirect(queue.buffer, 4 * INDIRECT_WORD);
            self.dispatch(cmd, COLLAPSE_K, self.collapse_set, &c, args);
            barrier::buffers(device, cmd, &[Access::ComputeWrite], &after);
            self.dispatch(cmd, NEXT_LEVEL_K, self.collapse_set, &c, Groups::Direct(1));
            barrier::buffers(device, cmd, &[Access::ComputeWrite], &after);
        }
    }

    /// Record `kernel` of the binary build over `groups` work groups, and a barrier after.
    fn step(&self, cmd: vk::CommandBuffer, kernel: usize, c: &BuildConstants, groups: u32) {
        self.dispatch(cmd, kernel, self.build_set, c, Groups::Direct(groups));
        barrier::buffers(
            &self.ctx.device,
            cmd,
            &[Access::ComputeWrite],
            &[Access::ComputeRead, Access::ComputeWrite],
        );
    }

    /// Point `set`'s bindings at `buffers`, in `common.glsl`'s order.
    fn bind(&self, set: vk::DescriptorSet, buffers: &[&GpuBuffer; BINDINGS as usize]) {
        let infos: Vec<[vk::DescriptorBufferInfo; 1]> = buffers
            .iter()
            .map(|b| [vk::DescriptorBufferInfo { buffer: b.buffer, offset: 0, range: b.size }])
            .collect();
        let writes: Vec<_> = infos
            .iter()
            .enumerate()
            .map(|(b, info)| {
                vk::WriteDescriptorSet::default()
                    .dst_set(set)
                    .dst_binding(b as u32)
                    .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                    .buffer_info(info)
            })
            .collect();
        // SAFETY: the set is not in use (every build waits for its submission); the
        // buffers are live.
        unsafe { self.ctx.device.update_descriptor_sets(&writes, &[]) };
    }

    /// Record `kernel` with `set` over `groups` work groups, spread over x and y where
    /// there are more than a dimension may hold (`flat_group` in `common.glsl`).
    fn dispatch(
        &self,
        cmd: vk::CommandBuffer,
        kernel: usize,
        set: vk::DescriptorSet,
        c: &BuildConstants,
        groups: Groups,
    ) {
        const MAX_X: u32 = 65_535;
        let device = &self.ctx.device;
        // SAFETY: `cmd` is recording; the pipeline, layout and sets are live until Drop,
        // which comes after every waited-for build; the constants fit the range; an
        // indirect buffer holds its three words at the offset.
        unsafe {
            bind_compute(
                device,
                cmd,
                self.pipelines[kernel],
                self.layout,
                set,
                bytemuck::bytes_of(c),
            );
            match groups {
                Groups::Direct(g) => {
                    let (x, y) = if g <= MAX_X { (g, 1) } else { (MAX_X, g.div_ceil(MAX_X)) };
                    device.cmd_dispatch(cmd, x.max(1), y, 1);
                }
                Groups::Indirect(buffer, offset) => {
                    device.cmd_dispatch_indirect(cmd, buffer, offset);
                }
            }
        }
    }
}

/// Bytes of a triangle record and a hit record.
const TRIANGLE_BYTES: u64 = std::mem::size_of::<GpuTriangle>() as u64;
const SHADING_BYTES: u64 = std::mem::size_of::<GpuTriangleShading>() as u64;

/// The push constants of the binary build of `mesh`, writing its triangles into scratch
/// memory (`sorted`: for the collapse) or into the scene's buffers.
fn constants(mesh: &DeviceBuild, sorted: bool) -> BuildConstants {
    let extent = (mesh.bounds.max - mesh.bounds.min).max(glam::Vec3::splat(1e-30));
    let cells = glam::Vec3::splat(1024.0) / extent;
    BuildConstants {
        lo: mesh.bounds.min.extend(0.0).into(),
        cells: cells.extend(0.0).into(),
        count: mesh.triangle_count,
        tri_base: if sorted { 0 } else { mesh.triangle_base },
        node_base: mesh.node_base.unwrap_or(0),
        leaf_size: mesh.leaf_size,
        blocks: mesh.triangle_count.div_ceil(SORT_BLOCK),
        leaves: mesh.leaves(),
        ..Default::default()
    }
}

/// What a load's first device build needs, made on another thread while the triangles are
/// uploaded: the pipelines (half a second with the driver's shader cache cold) and the
/// scratch memory (0.15-0.37 s for the 8-12 GB of a 100M-triangle mesh on the H200).
pub(crate) struct BuildAhead {
    pub(crate) pass: BvhBuildPass,
    pub(crate) scratch: Scratch,
}

impl BuildAhead {
    /// The pipelines and `first`'s scratch memory.
    pub(crate) fn new(ctx: &Arc<GpuContext>, first: &DeviceBuild) -> Result<Self, GpuError> {
        let start = std::time::Instant::now();
        let ahead = Self { pass: BvhBuildPass::new(ctx)?, scratch: Scratch::new(ctx, first)? };
        let ms = start.elapsed().as_secs_f64() * 1e3;
        log::debug!("device BVH build: pipelines and scratch memory ahead in {ms:.1} ms");
        Ok(ahead)
    }
}

/// The scratch memory of one build, freed when it ends.
pub(crate) struct Scratch {
    /// The sort's input in file order, copied out where the binary tree is the last word
    /// (None: the collapse writes the scene's buffers last, so the build reads them).
    copied: Option<[GpuBuffer; 2]>,
    /// Keys and values of the sort, twice.
    sort: GpuBuffer,
    /// Each block's digit counts.
    histogram: GpuBuffer,
    /// Parents of the leaves and inner nodes, the inner nodes' arrivals, their children's
    /// heights.
    tree: GpuBuffer,
    /// The binary tree where only the wide one is kept.
    binary: Option<GpuBuffer>,
    /// The triangles and hit records in the binary tree's order, where the collapse moves
    /// them on into the wide tree's.
    sorted: Option<[GpuBuffer; 2]>,
    /// The collapse's work queues.
    queue: Option<GpuBuffer>,
}

impl Scratch {
    fn new(ctx: &Arc<GpuContext>, mesh: &DeviceBuild) -> Result<Self, GpuError> {
        let n = u64::from(mesh.triangle_count);
        let leaves = u64::from(mesh.leaves());
        let buffer = |bytes: u64, name| {
            GpuBuffer::new(
                ctx,
                bytes,
                vk::BufferUsageFlags::STORAGE_BUFFER
                    | vk::BufferUsageFlags::TRANSFER_DST
                    | vk::BufferUsageFlags::TRANSFER_SRC
                    | vk::BufferUsageFlags::INDIRECT_BUFFER,
                MemoryLocation::GpuOnly,
                name,
            )
        };
        let records = |what: [&'static str; 2]| -> Result<[GpuBuffer; 2], GpuError> {
            Ok([buffer(n * TRIANGLE_BYTES, what[0])?, buffer(n * SHADING_BYTES, what[1])?])
        };
        let wide = mesh.wide.is_some();
        Ok(Self {
            copied: (!wide)
                .then(|| records(["BVH build: triangles", "BVH build: hit records"]))
                .transpose()?,
            sort: buffer(16 * n, "BVH build: sort keys and values")?,
            histogram: buffer(
                4 * 16 * u64::from(mesh.triangle_count.div_ceil(SORT_BLOCK)),
                "BVH build: digit counts",
            )?,
            tree: buffer(4 * (5 * leaves - 4), "BVH build: parents and heights")?,
            binary: mesh
                .node_base
                .is_none()
                .then(|| buffer((leaves - 1) * 64, "BVH build: binary nodes"))
                .transpose()?,
            sorted: wide
                .then(|| records(["BVH build: sorted triangles", "BVH build: sorted hit records"]))
                .transpose()?,
            queue: mesh
                .wide
                .map(|w| buffer(4 * (HEADER + 6 * u64::from(w.nodes)), "BVH build: queues"))
                .transpose()?,
        })
    }

    /// After the collapse: an error where it needed more wide nodes than were reserved (or
    /// did not place every triangle).
    fn check_collapse(&self, mesh: &DeviceBuild) -> Result<(), GpuError> {
        let (Some(wide), Some(queue)) = (mesh.wide, &self.queue) else { return Ok(()) };
        let header = queue.download_range(0, 4 * HEADER)?;
        let word = |i: usize| u32::from_le_bytes(header[4 * i..4 * i + 4].try_into().unwrap());
        let (made, placed, overflow) = (word(2), word(3), word(4));
        log::debug!("device collapse: {made} wide nodes of {} reserved", wide.nodes);
        if overflow != 0 || placed != mesh.triangle_count {
            return Err(GpuError::NotReady(
                "the wide BVH built on the device needs more nodes than were reserved for it \
                 (try --bvh binary, or --bvh-build cpu)",
            ));
        }
        Ok(())
    }
}

/// A dispatch's work groups: a count, or the three words in a buffer at an offset.
#[derive(Clone, Copy)]
enum Groups {
    Direct(u32),
    Indirect(vk::Buffer, u64),
}

impl Drop for BvhBuildPass {
    fn drop(&mut self) {
        let d = &self.ctx.device;
        // SAFETY: every build waits for its submission, so the GPU uses none of these; null
        // handles (a `new` that failed part-way) are ignored by the destroy calls.
        unsafe {
            for &p in &self.pipelines {
                d.destroy_pipeline(p, None);
            }
            d.destroy_descriptor_pool(self.pools[1], None);
            destroy_pipeline_objects(
                d,
                self.pools[0],
                vk::Pipeline::null(),
                self.layout,
                self.set_layout,
            );
        }
    }
}
