//! A mesh's binary BVH built on the device, in place in the scene's buffers: a linear BVH
//! (Karras 2012) for meshes so big that the CPU build is most of a load (100M triangles:
//! 4 s on 16 cores, against tens of milliseconds here). The CPU build stays the reference
//! and the default below `tracer::DEVICE_BUILD_FROM` triangles: its SAH trees trace faster.
//!
//! The mesh's triangles and hit records are uploaded in file order, with its node range
//! reserved (`tracer::prepare`); then, in one submission (`shaders/build/`):
//! 1. the triangles and hit records are copied out to scratch buffers;
//! 2. `morton.comp`: each triangle's key is the Morton code of its centroid (10 bits an
//!    axis of the mesh box);
//! 3. a stable least-significant-digit radix sort of (key, index), 4 bits a pass
//!    (`radix_count`, `radix_scan`, `radix_scatter`);
//! 4. `hierarchy.comp`: runs of sorted triangles are the leaves (1 to 8 a leaf: as few as
//!    the node buffer has room for, `tracer::prepare`), and each
//!    inner node is read off the sorted codes;
//! 5. `leaves.comp`: each leaf's triangles and hit records moved into sorted order, its box
//!    made and carried up the tree.

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::barrier::{self, Access};
use super::buffer::GpuBuffer;
use super::context::GpuContext;
use super::error::GpuError;
use super::pipeline::{
    allocate_one_set, create_compute_pipeline, create_layout, create_set_layout,
    destroy_pipeline_objects, words,
};
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
    /// into `nodes` (or scratch memory, where only the wide tree is kept), the wide tree
    /// collapsed from it where one is reserved, and the triangles and hit records put in
    /// the order of the tree's leaves. Waits for the GPU.
    pub(crate) fn build(
        &self,
        [triangles, shading, nodes]: [&GpuBuffer; 3],
        mesh: &DeviceBuild,
    ) -> Result<(), GpuError> {
        let n = u64::from(mesh.triangle_count);
        let leaves = mesh.leaves();
        assert!(leaves >= 2, "a mesh of one leaf is built on the CPU");
        let blocks = mesh.triangle_count.div_ceil(SORT_BLOCK);
        let ctx = &self.ctx;
        let scratch = |bytes: u64, name| {
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
        let tri_bytes = std::mem::size_of::<GpuTriangle>() as u64;
        let shading_bytes = std::mem::size_of::<GpuTriangleShading>() as u64;
        let source_triangles = scratch(n * tri_bytes, "BVH build: triangles in file order")?;
        let source_shading = scratch(n * shading_bytes, "BVH build: hit records in file order")?;
        let sort = scratch(16 * n, "BVH build: sort keys and values")?;
        let histogram = scratch(4 * 16 * u64::from(blocks), "BVH build: digit counts")?;
        // Parents of the leaves and inner nodes, the inner nodes' arrivals, their
        // children's heights.
        let tree = scratch(4 * (5 * u64::from(leaves) - 4), "BVH build: parents and heights")?;
        // Where only the wide tree is kept, the binary tree and the triangles in its order
        // are the collapse's input, in scratch memory.
        let wide_alone = mesh.wide.is_some() && mesh.node_base.is_none();
        let binary_scratch = match mesh.node_base {
            None => Some(scratch(u64::from(leaves - 1) * 64, "BVH build: binary nodes")?),
            Some(_) => None,
        };
        let sorted = match mesh.wide {
            Some(_) => Some([
                scratch(n * tri_bytes, "BVH build: triangles in binary leaf order")?,
                scratch(n * shading_bytes, "BVH build: hit records in binary leaf order")?,
            ]),
            None => None,
        };
        let queue = match mesh.wide {
            Some(w) => Some(scratch(4 * (HEADER + 6 * u64::from(w.nodes)), "BVH build: queues")?),
            None => None,
        };
        let binary_nodes = binary_scratch.as_ref().unwrap_or(nodes);
        let [built_triangles, built_shading] = match &sorted {
            Some([t, s]) => [t, s],
            None => [triangles, shading],
        };
        self.bind(
            self.build_set,
            &[
                built_triangles,
                built_shading,
                binary_nodes,
                &source_triangles,
                &source_shading,
                &sort,
                &histogram,
                &tree,
                &histogram,
                &histogram,
            ],
        );
        if let (Some([t, s]), Some(queue)) = (&sorted, &queue) {
            self.bind(
                self.collapse_set,
                &[triangles, shading, nodes, t, s, &sort, &histogram, &tree, binary_nodes, queue],
            );
        }

        let extent = (mesh.bounds.max - mesh.bounds.min).max(glam::Vec3::splat(1e-30));
        let cells = glam::Vec3::splat(1024.0) / extent;
        let base = BuildConstants {
            lo: mesh.bounds.min.extend(0.0).into(),
            cells: cells.extend(0.0).into(),
            count: mesh.triangle_count,
            // Into scratch memory from its start, or into the scene's buffers.
            tri_base: if sorted.is_some() { 0 } else { mesh.triangle_base },
            node_base: mesh.node_base.unwrap_or(0),
            leaf_size: mesh.leaf_size,
            blocks,
            leaves,
            ..Default::default()
        };
        let device = &ctx.device;
        let copies =
            [(triangles, &source_triangles, tri_bytes), (shading, &source_shading, shading_bytes)];
        ctx.one_shot(|cmd| {
            // SAFETY: `cmd` is recording; every buffer lives until this waited-for
            // submission ends; the regions lie within them (the upload sized them).
            unsafe {
                for (from, to, size) in copies {
                    let region = vk::BufferCopy {
                        src_offset: u64::from(mesh.triangle_base) * size,
                        dst_offset: 0,
                        size: n * size,
                    };
                    device.cmd_copy_buffer(cmd, from.buffer, to.buffer, &[region]);
                }
                device.cmd_fill_buffer(cmd, tree.buffer, 0, vk::WHOLE_SIZE, 0);
                if let Some(queue) = &queue {
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
            let step = |kernel: usize, constants: &BuildConstants, groups: u32| {
                self.dispatch(cmd, kernel, self.build_set, constants, Groups::Direct(groups));
                barrier::buffers(
                    device,
                    cmd,
                    &[Access::ComputeWrite],
                    &[Access::ComputeRead, Access::ComputeWrite],
                );
            };
            step(MORTON_K, &base, mesh.triangle_count.div_ceil(GROUP));
            // An even number of passes: the sorted keys end in the A arrays.
            let passes = KEY_BITS.div_ceil(RADIX_BITS).next_multiple_of(2);
            for pass in 0..passes {
                let c = BuildConstants { shift: pass * RADIX_BITS, flip: pass % 2, ..base };
                step(COUNT_K, &c, blocks);
                step(SCAN_K, &c, 1);
                step(SCATTER_K, &c, blocks);
            }
            step(HIERARCHY_K, &base, (leaves - 1).div_ceil(GROUP));
            step(LEAVES_K, &base, leaves.div_ceil(GROUP));
            if let (Some(wide), Some(queue)) = (mesh.wide, &queue) {
                let collapse = BuildConstants {
                    tri_base: mesh.triangle_base,
                    wide_word: 4 * wide.words,
                    wide_limit: wide.nodes,
                    bin_base: base.node_base,
                    patch_binary: u32::from(!wide_alone),
                    ..base
                };
                let after = [Access::ComputeRead, Access::ComputeWrite, Access::IndirectRead];
                // A level a dispatch, as many as the binary tree is deep at most.
                for level in 0..LEVELS {
                    let c = BuildConstants { level, ..collapse };
                    let args = Groups::Indirect(queue.buffer, 4 * INDIRECT_WORD);
                    self.dispatch(cmd, COLLAPSE_K, self.collapse_set, &c, args);
                    barrier::buffers(device, cmd, &[Access::ComputeWrite], &after);
                    self.dispatch(cmd, NEXT_LEVEL_K, self.collapse_set, &c, Groups::Direct(1));
                    barrier::buffers(device, cmd, &[Access::ComputeWrite], &after);
                }
            }
            // The frames after read what this wrote (and the vendor path copies triangles).
            barrier::buffers(
                device,
                cmd,
                &[Access::ComputeWrite],
                &[Access::ComputeRead, Access::TransferRead],
            );
        })?;
        if let (Some(wide), Some(queue)) = (mesh.wide, &queue) {
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
        }
        Ok(())
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
            device.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, self.pipelines[kernel]);
            device.cmd_bind_descriptor_sets(
                cmd,
                vk::PipelineBindPoint::COMPUTE,
                self.layout,
                0,
                &[set],
                &[],
            );
            device.cmd_push_constants(
                cmd,
                self.layout,
                vk::ShaderStageFlags::COMPUTE,
                0,
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
