//! The trace pass: the compute pipeline running `shaders/trace.comp` (our BVH and brute
//! force) or `shaders/vendor/query.comp` (the driver's traversal through ray queries), its
//! descriptor set (scene buffers, output buffers, the driver's structure for ray queries)
//! and the recording of a band's dispatch. The layout and the descriptor writes are shared
//! with the vendor's ray tracing pipeline (`khr_rt::pipeline_pass`).

use std::ops::Range;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::{Arc, Mutex};

use ash::vk;

use super::barrier::{self, Access};
use super::buffer::GpuBuffer;
use super::context::GpuContext;
use super::dispatch::{Band, GROUP};
use super::error::GpuError;
use super::lock::lock;
use super::pipeline::{
    self, allocate_one_set, bind_compute, create_layout, destroy_pipeline_objects, words,
};
use super::scene_buffers::SceneBuffers;
use super::shader_layout::{TraceBuffer, BINDINGS, LAYOUT_SIGNATURE};
use super::tile_order::TileSchedule;
use super::trace_kernels::{create_pipeline, KernelVariants, Variant, TRACE_ROWS_SPV, TRACE_SPV};
use crate::contract::{EMPTY, TLAS_BINDING, VENDOR_SLOTS_BINDING};
use crate::tracer::frame::{FrameParams, PushConstants};

/// SPIR-V compiled from `shaders/vendor/query.comp` by build.rs (glslang).
static QUERY_SPV: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/vendor_query.spv"));

/// Which compute shader a [`TracePass`] runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Kernel {
    /// `trace.comp`: our BVH or brute force, as the frame's flags say, the tiles taken
    /// costliest first (`tile_order.rs`).
    Ours,
    /// `trace.comp` with `ROW_ORDER`: the same in row order, for CPU devices.
    OursInRowOrder,
    /// `vendor/query.comp`: the driver's traversal through `VK_KHR_ray_query`.
    RayQuery,
}

impl Kernel {
    /// Our tracer's kernel for a device: costliest tiles first on GPUs, row order on CPUs
    /// (where the order measured 1.4-2x slower on lavapipe). `MESHTRACER_TILE_ORDER=rows`
    /// or `=costliest` overrides it (the window tests trace the GPU's order on lavapipe).
    pub(crate) fn ours_for(info: &super::context::DeviceInfo) -> Self {
        match std::env::var("MESHTRACER_TILE_ORDER").as_deref() {
            Ok("rows") => Self::OursInRowOrder,
            Ok("costliest") => Self::Ours,
            _ if info.is_cpu() => Self::OursInRowOrder,
            _ => Self::Ours,
        }
    }

    /// Whether the kernel takes its tiles from the tile order (and records their costs).
    pub(crate) fn orders_tiles(self) -> bool {
        self == Self::Ours
    }
}

/// The SPIR-V of `trace.comp` that build.rs compiled into the binary.
#[cfg(test)]
pub(crate) fn built_in_trace_spirv() -> Vec<u32> {
    words(TRACE_SPV)
}

/// The descriptor set layout of the trace shaders: every storage buffer the shader
/// declares and, for the vendor shaders, the acceleration structure and the slot map;
/// seen by `stages`.
pub(crate) fn create_set_layout(
    ctx: &GpuContext,
    stages: vk::ShaderStageFlags,
    with_tlas: bool,
) -> Result<vk::DescriptorSetLayout, GpuError> {
    let mut bindings: Vec<_> = BINDINGS
        .iter()
        .map(|b| {
            vk::DescriptorSetLayoutBinding::default()
                .binding(b.binding)
                .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                .descriptor_count(1)
                .stage_flags(stages)
        })
        .collect();
    if with_tlas {
        bindings.push(
            vk::DescriptorSetLayoutBinding::default()
                .binding(TLAS_BINDING)
                .descriptor_type(vk::DescriptorType::ACCELERATION_STRUCTURE_KHR)
                .descriptor_count(1)
                .stage_flags(stages),
        );
        bindings.push(
            vk::DescriptorSetLayoutBinding::default()
                .binding(VENDOR_SLOTS_BINDING)
                .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                .descriptor_count(1)
                .stage_flags(stages),
        );
    }
    pipeline::create_set_layout(ctx, &bindings, "creating the trace descriptor layout")
}

/// A pool holding one set of [`create_set_layout`]'s layout, and that set.
pub(crate) fn allocate_set(
    ctx: &GpuContext,
    set_layout: vk::DescriptorSetLayout,
    with_tlas: bool,
) -> Result<(vk::DescriptorPool, vk::DescriptorSet), GpuError> {
    let storage = BINDINGS.len() as u32 + with_tlas as u32;
    let mut sizes = vec![vk::DescriptorPoolSize {
        ty: vk::DescriptorType::STORAGE_BUFFER,
        descriptor_count: storage,
    }];
    if with_tlas {
        sizes.push(vk::DescriptorPoolSize {
            ty: vk::DescriptorType::ACCELERATION_STRUCTURE_KHR,
            descriptor_count: 1,
        });
    }
    allocate_one_set(
        ctx,
        set_layout,
        &sizes,
        ["creating the trace descriptor pool", "allocating the trace descriptor set"],
    )
}

/// Point `set` at a scene, an output and (for the vendor shaders) the top-level structure
/// and the slot map. The GPU must not be using the set.
pub(crate) fn write_set(
    ctx: &GpuContext,
    set: vk::DescriptorSet,
    scene: &SceneBuffers,
    output: &TraceOutput,
    vendor: Option<(vk::AccelerationStructureKHR, vk::Buffer)>,
) {
    let whole = |buffer| [vk::DescriptorBufferInfo { buffer, offset: 0, range: vk::WHOLE_SIZE }];
    let tiles = lock(&output.tiles);
    // Each binding the shader declares, by its block name (see shader_layout).
    let mut infos: Vec<(u32, [vk::DescriptorBufferInfo; 1])> = BINDINGS
        .iter()
        .map(|b| {
            let buffer = match TraceBuffer::of(b) {
                TraceBuffer::Triangles | TraceBuffer::TriangleHalves => &scene.triangles,
                TraceBuffer::Shading => &scene.shading,
                TraceBuffer::VertexNormals => &scene.vertex_normals,
                TraceBuffer::VertexTexcoords => &scene.vertex_texcoords,
                TraceBuffer::VertexColors => &scene.vertex_colors,
                TraceBuffer::Materials => &scene.materials,
                TraceBuffer::Nodes | TraceBuffer::WideNodes => &scene.nodes,
                TraceBuffer::Instances => &scene.instances,
                TraceBuffer::TopNodes => &scene.top_nodes,
                TraceBuffer::Meshes => &scene.meshes,
                TraceBuffer::Texels => &scene.texels,
                TraceBuffer::TextureInfos => &scene.texture_infos,
                TraceBuffer::Environment => &scene.environment,
                TraceBuffer::OutRgba8 => &output.rgba8,
                TraceBuffer::OutFloat => &output.float,
                TraceBuffer::PrimIds => &output.prim_ids,
                TraceBuffer::WalkHints => &output.walk_hints,
                TraceBuffer::TileOrder => &tiles.order,
                TraceBuffer::TileCosts => &tiles.costs,
            };
            (b.binding, whole(buffer.buffer))
        })
        .collect();
    if let Some((_, slots)) = vendor {
        infos.push((VENDOR_SLOTS_BINDING, whole(slots)));
    }
    let mut writes: Vec<_> = infos
        .iter()
        .map(|(binding, info)| {
            vk::WriteDescriptorSet::default()
                .dst_set(set)
                .dst_binding(*binding)
                .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                .buffer_info(info)
        })
        .collect();
    let structures = vendor.map(|(t, _)| [t]);
    let mut tlas_write = structures.as_ref().map(|s| {
        vk::WriteDescriptorSetAccelerationStructureKHR::default().acceleration_structures(s)
    });
    if let Some(w) = tlas_write.as_mut() {
        let mut write = vk::WriteDescriptorSet::default()
            .dst_set(set)
            .dst_binding(TLAS_BINDING)
            .descriptor_type(vk::DescriptorType::ACCELERATION_STRUCTURE_KHR)
            .push_next(w);
        write.descriptor_count = 1;
        writes.push(write);
    }
    // SAFETY: the caller guarantees the set is not in use; the buffers and the structure are live.
    unsafe { ctx.device.update_descriptor_sets(&writes, &[]) };
}

/// Output buffers at one resolution: packed 8-bit colour and float RGBA, and the order the
/// trace pass takes the tiles in.
pub(crate) struct TraceOutput {
    pub width: u32,
    pub height: u32,
    pub rgba8: GpuBuffer,
    pub float: GpuBuffer,
    /// Primary-hit ids of the adaptive-sampling pre-pass.
    pub prim_ids: GpuBuffer,
    /// Per pixel, the copy its camera ray hit in the last frame, where the top level's walk
    /// starts (`closest_hit` in `shaders/intersect.glsl`); `EMPTY` for none.
    pub walk_hints: GpuBuffer,
    /// The tiles' order and costs per frame slot (the host writes one slot's order while
    /// another slot's frame may run, hence the lock rather than `&mut`).
    pub tiles: Mutex<TileSchedule>,
}

impl TraceOutput {
    /// Output buffers for `width` x `height` pixels, with a tile order for each of `slots`
    /// frame slots.
    pub(crate) fn new(
        ctx: &Arc<GpuContext>,
        width: u32,
        height: u32,
        slots: u32,
    ) -> Result<Self, GpuError> {
        let pixels = width as u64 * height as u64;
        let limit = ctx.info.max_storage_buffer_range;
        if pixels * 16 > limit {
            return Err(GpuError::SceneTooLarge {
                buffer: "frame output (16 bytes per pixel)",
                bytes: pixels * 16,
                limit,
            });
        }
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER
            | vk::BufferUsageFlags::TRANSFER_SRC
            | vk::BufferUsageFlags::TRANSFER_DST;
        let loc = gpu_allocator::MemoryLocation::GpuOnly;
        let tiles = TileSchedule::new(ctx, width, height, slots)?;
        let output = Self {
            width,
            height,
            rgba8: GpuBuffer::new(ctx, pixels * 4, usage, loc, "output rgba8")?,
            float: GpuBuffer::new(ctx, pixels * 16, usage, loc, "output float")?,
            prim_ids: GpuBuffer::new(ctx, pixels * 4, usage, loc, "primary ids")?,
            walk_hints: GpuBuffer::new(ctx, pixels * 4, usage, loc, "walk hints")?,
            tiles: Mutex::new(tiles),
        };
        output.clear(ctx)?;
        Ok(output)
    }

    /// Fill the colour output with opaque black and the float output with zeros: a long
    /// frame's bands not yet traced after a resize show the background, never what the
    /// memory held before (issue #43: random colours for most of a minute).
    fn clear(&self, ctx: &GpuContext) -> Result<(), GpuError> {
        let device = &ctx.device;
        ctx.one_shot(|cmd| {
            // SAFETY: `cmd` is recording; the buffers are alive until one_shot has waited.
            unsafe {
                device.cmd_fill_buffer(cmd, self.rgba8.buffer, 0, vk::WHOLE_SIZE, CLEAR_RGBA8);
                device.cmd_fill_buffer(cmd, self.float.buffer, 0, vk::WHOLE_SIZE, 0);
                device.cmd_fill_buffer(cmd, self.walk_hints.buffer, 0, vk::WHOLE_SIZE, EMPTY);
            }
            let after = [Access::ComputeRead, Access::ComputeWrite, Access::TransferRead];
            barrier::buffers(device, cmd, &[Access::TransferWrite], &after);
        })
    }

    /// Forget the copies the last frames' camera rays hit (`walk_hints`), so that the next
    /// frame walks from the root as a first frame does: after a new scene or top level, whose
    /// copies the hints no longer name (a hint only changes where the walk starts, never the
    /// hit, but a frame's counts would then depend on the scene before).
    pub(crate) fn forget_hints(&self, ctx: &GpuContext) -> Result<(), GpuError> {
        let device = &ctx.device;
        ctx.one_shot(|cmd| {
            // SAFETY: `cmd` is recording; the buffer is alive until one_shot has waited.
            unsafe {
                device.cmd_fill_buffer(cmd, self.walk_hints.buffer, 0, vk::WHOLE_SIZE, EMPTY)
            };
            let after = [Access::ComputeRead, Access::ComputeWrite];
            barrier::buffers(device, cmd, &[Access::TransferWrite], &after);
        })
    }
}

/// A pixel of the colour output before it is traced: opaque black (bytes 0, 0, 0, 255).
pub(crate) const CLEAR_RGBA8: u32 = u32::from_le_bytes([0, 0, 0, 255]);

/// The compute pipeline and its one descriptor set.
pub(crate) struct TracePass {
    ctx: Arc<GpuContext>,
    kernel: Kernel,
    pipeline: vk::Pipeline,
    /// Our kernel's core, wide and leaf-runs variants; None for the vendor's kernel and
    /// after a reload (the reloaded shader then runs every frame).
    variants: Option<KernelVariants>,
    /// Whether every mesh of the bound scene has a wide tree (`SceneBuffers::every_mesh_wide`).
    every_mesh_wide: AtomicBool,
    /// The flags the bound scene's top level asks of every frame
    /// (`SceneBuffers::frame_flags`: `FLAG_SPHERES`, `FLAG_CONVEX`).
    frame_flags: AtomicU32,
    /// Whether the bound scene is one instance (`SceneBuffers::one_instance`).
    one_instance: AtomicBool,
    layout: vk::PipelineLayout,
    set_layout: vk::DescriptorSetLayout,
    pool: vk::DescriptorPool,
    set: vk::DescriptorSet,
}

impl TracePass {
    /// Create the pipeline of `kernel` (ray queries need the device's support, see
    /// `DeviceInfo::vendor`).
    pub(crate) fn new(ctx: &Arc<GpuContext>, kernel: Kernel) -> Result<Self, GpuError> {
        let with_tlas = kernel == Kernel::RayQuery;
        let set_layout = create_set_layout(ctx, vk::ShaderStageFlags::COMPUTE, with_tlas)?;
        let layout = create_layout(
            ctx,
            set_layout,
            vk::ShaderStageFlags::COMPUTE,
            std::mem::size_of::<PushConstants>(),
            "creating the trace pipeline layout",
        )?;
        let code = words(match kernel {
            Kernel::Ours => TRACE_SPV,
            Kernel::OursInRowOrder => TRACE_ROWS_SPV,
            Kernel::RayQuery => QUERY_SPV,
        });
        let pipeline = create_pipeline(ctx, layout, &code)?;
        let variants = match kernel {
            Kernel::Ours | Kernel::OursInRowOrder => {
                Some(KernelVariants::new(ctx, layout, kernel == Kernel::OursInRowOrder)?)
            }
            Kernel::RayQuery => None,
        };
        let (pool, set) = allocate_set(ctx, set_layout, with_tlas)?;
        Ok(Self {
            ctx: ctx.clone(),
            kernel,
            pipeline,
            variants,
            every_mesh_wide: AtomicBool::new(false),
            frame_flags: AtomicU32::new(0),
            one_instance: AtomicBool::new(false),
            layout,
            set_layout,
            pool,
            set,
        })
    }

    /// The kernel the pass runs.
    pub(crate) fn kernel(&self) -> Kernel {
        self.kernel
    }

    /// What the driver compiled the kernel that frames of `params` run (`dispatch` picks
    /// it) to, one `name: value` per statistic it reports (registers, local and shared
    /// memory, instructions); empty where the device does not offer
    /// `VK_KHR_pipeline_executable_properties`.
    pub(crate) fn frame_kernel_statistics(&self, params: &FrameParams) -> Vec<String> {
        let (_, pipeline) = self.frame_kernel(&params.push_constants(0));
        super::trace_kernels::statistics(&self.ctx, pipeline)
    }

    /// Swap in a pipeline built from `spirv` (a shader with the same interface, checked by
    /// [`compile_trace_shader`]); on failure the current pipeline stays.
    pub(crate) fn reload(&mut self, spirv: &[u32]) -> Result<(), GpuError> {
        debug_assert_ne!(self.kernel, Kernel::RayQuery, "only trace.comp is reloaded");
        let pipeline = create_pipeline(&self.ctx, self.layout, spirv)?;
        // The old pipeline may still be in a submitted command buffer.
        if let Err(e) = self.ctx.wait_idle() {
            // SAFETY: the new pipeline was never used.
            unsafe { self.ctx.device.destroy_pipeline(pipeline, None) };
            return Err(e);
        }
        // SAFETY: the GPU is idle, so nothing uses the old pipelines.
        unsafe {
            self.ctx.device.destroy_pipeline(std::mem::replace(&mut self.pipeline, pipeline), None);
            // None from now: the reloaded shader runs every frame.
            if let Some(variants) = self.variants.take() {
                variants.destroy();
            }
        }
        Ok(())
    }

    /// Point the descriptor set at a scene, an output and (ray queries) the top-level
    /// structure and slot map; the GPU must not be using the set.
    pub(crate) fn bind(
        &self,
        scene: &SceneBuffers,
        output: &TraceOutput,
        vendor: Option<(vk::AccelerationStructureKHR, vk::Buffer)>,
    ) {
        debug_assert_eq!(
            vendor.is_some(),
            self.kernel == Kernel::RayQuery,
            "ray queries need the structure, our tracer none"
        );
        write_set(&self.ctx, self.set, scene, output, vendor);
        self.every_mesh_wide.store(scene.every_mesh_wide, Ordering::Relaxed);
        self.instances_changed(scene);
    }

    /// Note the bound scene's new top level (`SceneBuffers::set_instances`): whether it is
    /// one instance picks the kernels of the frames to come, and whether it has sphere
    /// leaves and convex copies their flags.
    pub(crate) fn instances_changed(&self, scene: &SceneBuffers) {
        self.one_instance.store(scene.one_instance, Ordering::Relaxed);
        self.frame_flags.store(scene.frame_flags, Ordering::Relaxed);
    }

    /// Record the trace of the pixels in `band`, with the barrier it needs first: after
    /// the last trace wrote (accumulation reads what it wrote; the main pass reads adaptive
    /// sampling's keys) and copies read the outputs. The outputs are left as
    /// `Access::ComputeWrite`. `tile_base`: the frame slot's first entry of the tile order
    /// (`TileSchedule::order`; the vendor's query shader has none and ignores it).
    pub(crate) fn record(
        &self,
        cmd: vk::CommandBuffer,
        params: &FrameParams,
        band: &Band,
        tile_base: u32,
    ) {
        barrier::buffers(
            &self.ctx.device,
            cmd,
            &[Access::ComputeWrite, Access::TransferRead],
            &[Access::ComputeRead, Access::ComputeWrite],
        );
        // Rows are offset through the push constants, columns through the dispatch base;
        // a band finer than a group names its lanes there too.
        let mut pc = params.push_constants(band.rows.start);
        pc.set_lanes(&band.lanes);
        pc.cam_up[3] = f32::from_bits(tile_base);
        self.dispatch(cmd, &pc, band);
    }

    /// Record adaptive sampling's pre-pass over `columns` (all rows): the key of each
    /// pixel's path (primary hit and mirror bounces), which the main pass compares with the
    /// neighbours'. Recorded before a frame's first main band, with the same barrier.
    pub(crate) fn record_ids(
        &self,
        cmd: vk::CommandBuffer,
        params: &FrameParams,
        columns: &Range<u32>,
    ) {
        barrier::buffers(
            &self.ctx.device,
            cmd,
            &[Access::ComputeWrite, Access::TransferRead],
            &[Access::ComputeRead, Access::ComputeWrite],
        );
        let mut pc = params.push_constants(0);
        pc.dims[3] |= crate::contract::FLAG_ID_PASS;
        self.dispatch(cmd, &pc, &Band::rect(0..params.settings.height, columns.clone()));
    }

    /// The push constants a frame of `pc` runs with over the bound scene, and its kernel.
    fn frame_kernel(&self, pc: &PushConstants) -> (PushConstants, vk::Pipeline) {
        // FLAG_SPHERES says the top level has sphere leaves: the walk then tests them, and
        // a wide frame runs the wide kernel's twin that can (`SPHERE_LEAVES`), as it does
        // for convex copies (FLAG_CONVEX), which the plain wide kernel never skips.
        let mut pc = *pc;
        pc.dims[3] |= self.frame_flags.load(Ordering::Relaxed);
        let pipeline = match &self.variants {
            Some(variants) => variants.for_frame(
                &pc,
                self.every_mesh_wide.load(Ordering::Relaxed),
                self.one_instance.load(Ordering::Relaxed),
                self.pipeline,
            ),
            None => self.pipeline,
        };
        (pc, pipeline)
    }

    fn dispatch(&self, cmd: vk::CommandBuffer, pc: &PushConstants, band: &Band) {
        let device = &self.ctx.device;
        let (pc, pipeline) = self.frame_kernel(pc);
        let pc = &pc;
        debug_assert!(band.columns.start % GROUP.width == 0, "a band starts at a group boundary");
        let base_x = band.columns.start / GROUP.width;
        let groups_x = band.columns.len().div_ceil(GROUP.width as usize) as u32;
        let groups_y = band.rows.len().div_ceil(GROUP.height as usize) as u32;
        debug_assert!(
            !band.is_finer_than_a_group() || groups_x * groups_y == 1,
            "a band finer than a group is one group: {band:?}"
        );
        // SAFETY: `cmd` is recording; the pipeline (created with DISPATCH_BASE), layout and set
        // outlive its execution (the owner waits for the GPU before dropping them) and the
        // push constants fit the layout's range.
        unsafe {
            bind_compute(device, cmd, pipeline, self.layout, self.set, bytemuck::bytes_of(pc));
            device.cmd_dispatch_base(cmd, base_x, 0, 0, groups_x, groups_y, 1);
        }
    }
}

impl TracePass {
    /// Start making the kernels that are otherwise made by the first frame needing them
    /// (`KernelVariants::prepare_in_background`).
    pub(crate) fn prepare_kernels_in_background(&self) {
        if let Some(variants) = &self.variants {
            variants.prepare_in_background();
        }
    }

    /// Make the kernel of `v` now rather than at the first frame that runs it
    /// (`KernelVariants::make_now`).
    pub(crate) fn make_kernel_now(&self, v: Variant, one_instance: bool, twin: bool) {
        if let Some(variants) = &self.variants {
            variants.make_now(v, one_instance, twin);
        }
    }

    /// Whether every kernel a frame may need is made (always, for the vendor's kernel).
    pub(crate) fn kernels_ready(&self) -> bool {
        self.variants.as_ref().is_none_or(KernelVariants::ready)
    }

    /// Whether the variant kernel of `v` (wide or leaf runs) has been made.
    #[cfg(test)]
    pub(crate) fn made(&self, v: Variant) -> bool {
        self.variants.as_ref().is_some_and(|k| k.made(v))
    }

    /// Whether the wide kernel's twin for sphere leaves has been made.
    #[cfg(test)]
    pub(crate) fn made_wide_spheres(&self) -> bool {
        self.variants.as_ref().is_some_and(KernelVariants::made_wide_spheres)
    }

    /// Whether the `ONE_INSTANCE` twin of `v` has been made.
    #[cfg(test)]
    pub(crate) fn made_one_instance(&self, v: Variant) -> bool {
        self.variants.as_ref().is_some_and(|k| k.made_one_instance(v))
    }
}

/// Compile `dir/trace.comp` (and what it includes) at run time for [`TracePass::reload`],
/// as `kernel` (one of ours) builds it. A shader whose bindings, push constants or work
/// group differ from the built-in one's is refused: the host's buffers and structs are
/// built for that interface.
pub(crate) fn compile_trace_shader(
    dir: &std::path::Path,
    kernel: Kernel,
) -> Result<Vec<u32>, String> {
    use super::shader_compile;
    let contract = shader_compile::contract_glsl(crate::contract::ALL, "src/contract.rs");
    let defines: &[&str] =
        if kernel == Kernel::OursInRowOrder { &[shader_compile::ROW_ORDER] } else { &[] };
    let shader = shader_compile::compile(&dir.join("trace.comp"), &contract, defines)?;
    let signature = shader_compile::layout_signature(&shader.module)?;
    if let Some((new, old)) = signature.lines().zip(LAYOUT_SIGNATURE.lines()).find(|(a, b)| a != b)
    {
        return Err(format!("the edited shader changes the interface the host is built for (`{old}` became `{new}`); rebuild meshtracer for that"));
    }
    if signature.lines().count() != LAYOUT_SIGNATURE.lines().count() {
        return Err("the edited shader adds or removes a buffer binding or the push constants; rebuild meshtracer for that".into());
    }
    Ok(shader.spirv)
}

impl Drop for TracePass {
    fn drop(&mut self) {
        let d = &self.ctx.device;
        // SAFETY: the owner (`ComputeTracer`) waits for the GPU before dropping the pass,
        // so nothing uses these objects.
        unsafe {
            if let Some(variants) = &self.variants {
                variants.destroy();
            }
            destroy_pipeline_objects(d, self.pool, self.pipeline, self.layout, self.set_layout);
        }
    }
}

#[cfg(test)]
#[path = "trace_pass_tests.rs"]
mod tests;
