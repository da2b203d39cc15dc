//! The vendor's ray tracing pipeline (`VK_KHR_ray_tracing_pipeline`): `vendor/raygen.rgen`
//! runs the shared tracer (`trace.glsl`) per pixel of a band and traces its rays into
//! `closest.rchit` and `miss.rmiss`; the shader binding table holds the three groups. The
//! descriptor set is laid out as the compute trace pass's.

use std::ops::Range;
use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::gpu::barrier::{self, Access};
use crate::gpu::buffer::GpuBuffer;
use crate::gpu::context::GpuContext;
use crate::gpu::dispatch::Band;
use crate::gpu::error::{GpuError, VkContext};
use crate::gpu::pipeline::{create_layout, destroy_pipeline_objects, words};
use crate::gpu::scene_buffers::SceneBuffers;
use crate::gpu::trace_pass::{allocate_set, create_set_layout, TraceOutput};
use crate::tracer::frame::{FrameParams, PushConstants};

static RAYGEN_SPV: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/vendor_raygen.spv"));
static CLOSEST_SPV: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/vendor_closest.spv"));
static MISS_SPV: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/vendor_miss.spv"));

/// The ray tracing pipeline, its descriptor set and shader binding table.
pub(crate) struct PipelinePass {
    ctx: Arc<GpuContext>,
    loader: ash::khr::ray_tracing_pipeline::Device,
    pipeline: vk::Pipeline,
    layout: vk::PipelineLayout,
    set_layout: vk::DescriptorSetLayout,
    pool: vk::DescriptorPool,
    set: vk::DescriptorSet,
    /// The binding table's memory; the regions below point into it.
    _table: GpuBuffer,
    raygen: vk::StridedDeviceAddressRegionKHR,
    miss: vk::StridedDeviceAddressRegionKHR,
    hit: vk::StridedDeviceAddressRegionKHR,
}

impl PipelinePass {
    /// Create the pipeline (the device must offer `VK_KHR_ray_tracing_pipeline`).
    pub(crate) fn new(ctx: &Arc<GpuContext>) -> Result<Self, GpuError> {
        let device = &ctx.device;
        let loader = ash::khr::ray_tracing_pipeline::Device::new(&ctx.instance, device);
        let stages = vk::ShaderStageFlags::RAYGEN_KHR;
        let set_layout = create_set_layout(ctx, stages, true)?;
        let layout = create_layout(
            ctx,
            set_layout,
            stages,
            std::mem::size_of::<PushConstants>(),
            "creating the ray tracing pipeline layout",
        )?;
        let pipeline = create_pipeline(ctx, &loader, layout)?;
        let (pool, set) = allocate_set(ctx, set_layout, true)?;
        let (table, raygen, miss, hit) = binding_table(ctx, &loader, pipeline)?;
        Ok(Self {
            ctx: ctx.clone(),
            loader,
            pipeline,
            layout,
            set_layout,
            pool,
            set,
            _table: table,
            raygen,
            miss,
            hit,
        })
    }

    /// Point the descriptor set at a scene, an output, the top level and the slot map; the
    /// GPU must not be using the set.
    pub(crate) fn bind(
        &self,
        scene: &SceneBuffers,
        output: &TraceOutput,
        tlas: vk::AccelerationStructureKHR,
        slots: vk::Buffer,
    ) {
        crate::gpu::trace_pass::write_set(&self.ctx, self.set, scene, output, Some((tlas, slots)));
    }

    /// Record the trace of `band` as the compute pass records its dispatch: after the last
    /// trace's writes and copies' reads. The outputs are left as the compute pass leaves
    /// them (`Access::ComputeWrite`): a barrier hands the pipeline's writes on to the
    /// compute stage, which later barriers start from.
    pub(crate) fn record(&self, cmd: vk::CommandBuffer, params: &FrameParams, band: &Band) {
        let mut pc = params.push_constants(band.rows.start);
        pc.set_lanes(&band.lanes);
        self.trace(cmd, &pc, band);
    }

    /// Record adaptive sampling's pre-pass over `columns` (all rows), as the compute pass does.
    pub(crate) fn record_ids(
        &self,
        cmd: vk::CommandBuffer,
        params: &FrameParams,
        columns: &Range<u32>,
    ) {
        let mut pc = params.push_constants(0);
        pc.dims[3] |= crate::contract::FLAG_ID_PASS;
        self.trace(cmd, &pc, &Band::rect(0..params.settings.height, columns.clone()));
    }

    fn trace(&self, cmd: vk::CommandBuffer, pc: &PushConstants, band: &Band) {
        let device = &self.ctx.device;
        // A launch has no base offset: the band's first column rides in misc.y's high half
        // (raygen.rgen), beside its first row.
        let mut pc = *pc;
        pc.misc[1] = (band.columns.start << 16) | (pc.misc[1] & 0xffff);
        // After the last trace's writes and copies' reads, as the compute pass's dispatch.
        barrier::buffers(
            device,
            cmd,
            &[Access::ComputeWrite, Access::TransferRead],
            &[Access::RayTracingRead, Access::RayTracingWrite],
        );
        // SAFETY: `cmd` is recording; the pipeline, layout, set and table outlive its
        // execution (the owner waits for the GPU before dropping them); the push constants
        // fit the layout's range.
        unsafe {
            device.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::RAY_TRACING_KHR, self.pipeline);
            device.cmd_bind_descriptor_sets(
                cmd,
                vk::PipelineBindPoint::RAY_TRACING_KHR,
                self.layout,
                0,
                &[self.set],
                &[],
            );
            device.cmd_push_constants(
                cmd,
                self.layout,
                vk::ShaderStageFlags::RAYGEN_KHR,
                0,
                bytemuck::bytes_of(&pc),
            );
            let callable = vk::StridedDeviceAddressRegionKHR::default();
            self.loader.cmd_trace_rays(
                cmd,
                &self.raygen,
                &self.miss,
                &self.hit,
                &callable,
                band.columns.len() as u32,
                band.rows.len() as u32,
                1,
            );
        }
        // Handed on to the compute stage, where later barriers start from.
        barrier::buffers(
            device,
            cmd,
            &[Access::RayTracingWrite],
            &[Access::ComputeRead, Access::ComputeWrite],
        );
    }
}

/// The pipeline: group 0 ray generation, 1 miss, 2 the triangle hit group (closest hit).
fn create_pipeline(
    ctx: &GpuContext,
    loader: &ash::khr::ray_tracing_pipeline::Device,
    layout: vk::PipelineLayout,
) -> Result<vk::Pipeline, GpuError> {
    let device = &ctx.device;
    let mut modules = Vec::new();
    for code in [RAYGEN_SPV, MISS_SPV, CLOSEST_SPV] {
        let code = words(code);
        // SAFETY: the words are SPIR-V that glslang wrote at build time.
        match unsafe {
            device.create_shader_module(&vk::ShaderModuleCreateInfo::default().code(&code), None)
        } {
            Ok(m) => modules.push(m),
            Err(r) => {
                // SAFETY: the modules made so far are used by nothing.
                unsafe { modules.iter().for_each(|&m| device.destroy_shader_module(m, None)) };
                return Err(GpuError::vk("loading the ray tracing shaders", r));
            }
        }
    }
    let stages = [
        vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::RAYGEN_KHR)
            .module(modules[0])
            .name(c"main"),
        vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::MISS_KHR)
            .module(modules[1])
            .name(c"main"),
        vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::CLOSEST_HIT_KHR)
            .module(modules[2])
            .name(c"main"),
    ];
    let general = |i: u32| {
        vk::RayTracingShaderGroupCreateInfoKHR::default()
            .ty(vk::RayTracingShaderGroupTypeKHR::GENERAL)
            .general_shader(i)
            .closest_hit_shader(vk::SHADER_UNUSED_KHR)
            .any_hit_shader(vk::SHADER_UNUSED_KHR)
            .intersection_shader(vk::SHADER_UNUSED_KHR)
    };
    let groups = [
        general(0),
        general(1),
        vk::RayTracingShaderGroupCreateInfoKHR::default()
            .ty(vk::RayTracingShaderGroupTypeKHR::TRIANGLES_HIT_GROUP)
            .general_shader(vk::SHADER_UNUSED_KHR)
            .closest_hit_shader(2)
            .any_hit_shader(vk::SHADER_UNUSED_KHR)
            .intersection_shader(vk::SHADER_UNUSED_KHR),
    ];
    // Rays are traced from the ray generation shader only.
    let info = [vk::RayTracingPipelineCreateInfoKHR::default()
        .stages(&stages)
        .groups(&groups)
        .max_pipeline_ray_recursion_depth(1)
        .layout(layout)];
    // SAFETY: the modules and layout are live; the create infos outlive the call.
    let pipeline = unsafe {
        loader.create_ray_tracing_pipelines(
            vk::DeferredOperationKHR::null(),
            vk::PipelineCache::null(),
            &info,
            None,
        )
    };
    // SAFETY: the pipeline, created or not, no longer needs the modules.
    unsafe { modules.iter().for_each(|&m| device.destroy_shader_module(m, None)) };
    Ok(pipeline.map_err(|(_, r)| GpuError::vk("creating the ray tracing pipeline", r))?[0])
}

/// The shader binding table: each group's handle in its own region, each region aligned
/// as the device asks. Returns the buffer and the ray generation, miss and hit regions.
#[allow(clippy::type_complexity)]
fn binding_table(
    ctx: &Arc<GpuContext>,
    loader: &ash::khr::ray_tracing_pipeline::Device,
    pipeline: vk::Pipeline,
) -> Result<
    (
        GpuBuffer,
        vk::StridedDeviceAddressRegionKHR,
        vk::StridedDeviceAddressRegionKHR,
        vk::StridedDeviceAddressRegionKHR,
    ),
    GpuError,
> {
    let mut properties = vk::PhysicalDeviceRayTracingPipelinePropertiesKHR::default();
    let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut properties);
    // SAFETY: `props2` and the struct chained to it outlive the call.
    unsafe { ctx.instance.get_physical_device_properties2(ctx.physical_device, &mut props2) };
    let handle_size = properties.shader_group_handle_size as u64;
    let stride =
        handle_size.next_multiple_of(properties.shader_group_handle_alignment.max(1) as u64);
    let base = (properties.shader_group_base_alignment.max(1) as u64).max(stride);
    // SAFETY: the pipeline has 3 groups; the data size is 3 handles.
    let handles = unsafe {
        loader.get_ray_tracing_shader_group_handles(pipeline, 0, 3, 3 * handle_size as usize)
    }
    .during("reading the shader group handles")?;
    // Three regions `base` apart, and room to align the start.
    let usage = vk::BufferUsageFlags::SHADER_BINDING_TABLE_KHR
        | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
    let mut table =
        GpuBuffer::new(ctx, 4 * base, usage, MemoryLocation::CpuToGpu, "shader binding table")?;
    let address = table.device_address();
    let start = address.next_multiple_of(base) - address;
    let bytes = table.mapped().expect("the binding table is mapped");
    for group in 0..3u64 {
        let at = (start + group * base) as usize;
        let from = (group * handle_size) as usize;
        bytes[at..at + handle_size as usize]
            .copy_from_slice(&handles[from..from + handle_size as usize]);
    }
    let region = |group: u64, size: u64| vk::StridedDeviceAddressRegionKHR {
        device_address: address + start + group * base,
        stride,
        size,
    };
    // The ray generation region's size must equal its stride.
    let raygen = vk::StridedDeviceAddressRegionKHR { stride: base, ..region(0, base) };
    Ok((table, raygen, region(1, stride), region(2, stride)))
}

impl Drop for PipelinePass {
    fn drop(&mut self) {
        let d = &self.ctx.device;
        // SAFETY: the owner waits for the GPU before dropping the pass.
        unsafe {
            destroy_pipeline_objects(d, self.pool, self.pipeline, self.layout, self.set_layout);
        }
    }
}
