//! The Vulkan objects every pass of ours is made of, created and destroyed in one place:
//! SPIR-V words, a descriptor set layout, a pool holding the pass's one set, a pipeline
//! layout with one set and one push-constant range, a compute pipeline. The trace pass,
//! the vendor's ray tracing pipeline and the clock probe are built from these.

use ash::vk;

use super::context::GpuContext;
use super::error::{GpuError, VkContext};

/// SPIR-V words of embedded bytes.
pub(crate) fn words(bytes: &[u8]) -> Vec<u32> {
    bytes.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect()
}

/// A descriptor set layout of `bindings`; `what` names the step for errors. The caller
/// destroys it.
pub(crate) fn create_set_layout(
    ctx: &GpuContext,
    bindings: &[vk::DescriptorSetLayoutBinding],
    what: &'static str,
) -> Result<vk::DescriptorSetLayout, GpuError> {
    // SAFETY: plain object creation on the live device; the bindings outlive the call.
    unsafe {
        ctx.device.create_descriptor_set_layout(
            &vk::DescriptorSetLayoutCreateInfo::default().bindings(bindings),
            None,
        )
    }
    .during(what)
}

/// A pool of `sizes` holding one set of `set_layout`, and that set; `what` names the two
/// steps for errors: creating the pool, allocating the set. The caller destroys the pool
/// (here, when the set cannot be allocated).
pub(crate) fn allocate_one_set(
    ctx: &GpuContext,
    set_layout: vk::DescriptorSetLayout,
    sizes: &[vk::DescriptorPoolSize],
    what: [&'static str; 2],
) -> Result<(vk::DescriptorPool, vk::DescriptorSet), GpuError> {
    // SAFETY: plain object creation on the live device; the caller destroys the pool.
    let pool = unsafe {
        ctx.device.create_descriptor_pool(
            &vk::DescriptorPoolCreateInfo::default().max_sets(1).pool_sizes(sizes),
            None,
        )
    }
    .during(what[0])?;
    let set_layouts = [set_layout];
    // SAFETY: the pool holds exactly this one set of this layout.
    let set = unsafe {
        ctx.device.allocate_descriptor_sets(
            &vk::DescriptorSetAllocateInfo::default()
                .descriptor_pool(pool)
                .set_layouts(&set_layouts),
        )
    };
    match set {
        Ok(set) => Ok((pool, set[0])),
        Err(r) => {
            // SAFETY: the pool was just made and holds nothing.
            unsafe { ctx.device.destroy_descriptor_pool(pool, None) };
            Err(GpuError::vk(what[1], r))
        }
    }
}

/// A pipeline layout of the one set `set_layout` and `push_bytes` of push constants, both
/// seen by `stages`; `what` names the step for errors. The caller destroys it.
pub(crate) fn create_layout(
    ctx: &GpuContext,
    set_layout: vk::DescriptorSetLayout,
    stages: vk::ShaderStageFlags,
    push_bytes: usize,
    what: &'static str,
) -> Result<vk::PipelineLayout, GpuError> {
    let push = [vk::PushConstantRange::default().stage_flags(stages).size(push_bytes as u32)];
    let set_layouts = [set_layout];
    // SAFETY: the set layout is live; the arrays outlive the call.
    unsafe {
        ctx.device.create_pipeline_layout(
            &vk::PipelineLayoutCreateInfo::default()
                .set_layouts(&set_layouts)
                .push_constant_ranges(&push),
            None,
        )
    }
    .during(what)
}

/// A compute pipeline running `main` of the SPIR-V `code` with `layout`; `what` names the
/// two steps for errors: loading the shader module, creating the pipeline.
pub(crate) fn create_compute_pipeline(
    ctx: &GpuContext,
    layout: vk::PipelineLayout,
    code: &[u32],
    flags: vk::PipelineCreateFlags,
    what: [&'static str; 2],
) -> Result<vk::Pipeline, GpuError> {
    let device = &ctx.device;
    // SAFETY: the words are SPIR-V that naga (or glslang) wrote and validated.
    let module = unsafe {
        device.create_shader_module(&vk::ShaderModuleCreateInfo::default().code(code), None)
    }
    .during(what[0])?;
    let stage = vk::PipelineShaderStageCreateInfo::default()
        .stage(vk::ShaderStageFlags::COMPUTE)
        .module(module)
        .name(c"main");
    let info = [vk::ComputePipelineCreateInfo::default().stage(stage).layout(layout).flags(flags)];
    // SAFETY: the module and the layout are live; the create infos outlive the call.
    let pipeline =
        unsafe { device.create_compute_pipelines(vk::PipelineCache::null(), &info, None) };
    // SAFETY: the pipeline, created or not, no longer needs the module.
    unsafe { device.destroy_shader_module(module, None) };
    Ok(pipeline.map_err(|(_, r)| GpuError::vk(what[1], r))?[0])
}

/// Record the binding of a compute pass's `pipeline`, its one `set` (of `layout`) and its
/// push `constants`, ready for a dispatch.
///
/// # Safety
/// `cmd` is recording; the pipeline, layout and set outlive its execution (their owner waits
/// for the GPU before dropping them); `constants` fit the layout's push-constant range.
pub(crate) unsafe fn bind_compute(
    device: &ash::Device,
    cmd: vk::CommandBuffer,
    pipeline: vk::Pipeline,
    layout: vk::PipelineLayout,
    set: vk::DescriptorSet,
    constants: &[u8],
) {
    let compute = vk::PipelineBindPoint::COMPUTE;
    // SAFETY: as the caller promises.
    unsafe {
        device.cmd_bind_pipeline(cmd, compute, pipeline);
        device.cmd_bind_descriptor_sets(cmd, compute, layout, 0, &[set], &[]);
        device.cmd_push_constants(cmd, layout, vk::ShaderStageFlags::COMPUTE, 0, constants);
    }
}

/// Destroy a pass's Vulkan objects: its descriptor pool (and sets), pipeline, pipeline
/// layout and set layout; null handles (a constructor that failed part-way) are ignored.
///
/// # Safety
/// The GPU must be done with all of them (the owner waited for it).
pub(crate) unsafe fn destroy_pipeline_objects(
    d: &ash::Device,
    pool: vk::DescriptorPool,
    pipeline: vk::Pipeline,
    layout: vk::PipelineLayout,
    set_layout: vk::DescriptorSetLayout,
) {
    // SAFETY: the caller promises the GPU no longer uses these objects.
    unsafe {
        d.destroy_descriptor_pool(pool, None);
        d.destroy_pipeline(pipeline, None);
        d.destroy_pipeline_layout(layout, None);
        d.destroy_descriptor_set_layout(set_layout, None);
    }
}
