//! The clock the GPU's shaders run at, measured: `shaders/probe/clock.comp` counts its
//! subgroup's clock cycles over a chain of dependent fmas, and timestamps around the
//! dispatch give the nanoseconds. The NVIDIA driver lowers the clock at times (an H100 at
//! 555-645 MHz instead of 1980 for the rest of a process), which slows every row 3x;
//! `bench` reports the clock beside each row so that such rows are seen for what they are.

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

static CLOCK_SPV: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/probe_clock.spv"));

/// Fmas in the probe's chain: about a millisecond on a 2 GHz GPU (4-cycle fma latency),
/// long enough that the dispatch's own microseconds do not matter.
const ITERATIONS: u32 = 500_000;

/// The probe's push constants (`Probe` in clock.comp).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct ProbeConstants {
    iterations: u32,
    a: f32,
    b: f32,
}

/// One measurement: shader clock cycles over the dispatch's GPU time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ClockReading {
    /// Subgroup clock cycles the fma chain took.
    pub(crate) cycles: u64,
    /// GPU milliseconds between the timestamps around the dispatch.
    pub(crate) gpu_ms: f64,
}

impl ClockReading {
    /// The shader clock rate in MHz (cycles per microsecond).
    pub(crate) fn mhz(&self) -> f64 {
        self.cycles as f64 / (self.gpu_ms * 1e3)
    }
}

/// The probe's pipeline, its result buffer and timestamps.
pub(crate) struct ClockProbe {
    ctx: Arc<GpuContext>,
    pipeline: vk::Pipeline,
    layout: vk::PipelineLayout,
    set_layout: vk::DescriptorSetLayout,
    pool: vk::DescriptorPool,
    set: vk::DescriptorSet,
    result: GpuBuffer,
    timer: GpuTimer,
}

impl ClockProbe {
    /// The probe; None where the device has no subgroup clock (`VK_KHR_shader_clock`) or
    /// no timestamps.
    pub(crate) fn new(ctx: &Arc<GpuContext>) -> Result<Option<Self>, GpuError> {
        if !ctx.info.shader_clock {
            return Ok(None);
        }
        let Some(timer) = GpuTimer::new(ctx, 1)? else { return Ok(None) };
        let device = &ctx.device;
        let result = GpuBuffer::new(
            ctx,
            16,
            vk::BufferUsageFlags::STORAGE_BUFFER,
            MemoryLocation::GpuToCpu,
            "clock probe",
        )?;
        let binding = [vk::DescriptorSetLayoutBinding::default()
            .binding(0)
            .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
            .descriptor_count(1)
            .stage_flags(vk::ShaderStageFlags::COMPUTE)];
        // Destroyed in Drop (or below on error).
        let set_layout =
            create_set_layout(ctx, &binding, "creating the clock probe's descriptor layout")?;
        let mut probe = Self {
            ctx: ctx.clone(),
            pipeline: vk::Pipeline::null(),
            layout: vk::PipelineLayout::null(),
            set_layout,
            pool: vk::DescriptorPool::null(),
            set: vk::DescriptorSet::null(),
            result,
            timer,
        };
        // From here on Drop destroys whatever was made (null handles are ignored).
        probe.layout = create_layout(
            ctx,
            set_layout,
            vk::ShaderStageFlags::COMPUTE,
            std::mem::size_of::<ProbeConstants>(),
            "creating the clock probe's pipeline layout",
        )?;
        probe.pipeline = create_compute_pipeline(
            ctx,
            probe.layout,
            &words(CLOCK_SPV),
            vk::PipelineCreateFlags::empty(),
            ["loading the clock probe", "creating the clock probe's pipeline"],
        )?;
        let sizes = [vk::DescriptorPoolSize {
            ty: vk::DescriptorType::STORAGE_BUFFER,
            descriptor_count: 1,
        }];
        (probe.pool, probe.set) = allocate_one_set(
            ctx,
            set_layout,
            &sizes,
            [
                "creating the clock probe's descriptor pool",
                "allocating the clock probe's descriptor set",
            ],
        )?;
        let buffer_info = [vk::DescriptorBufferInfo {
            buffer: probe.result.buffer,
            offset: 0,
            range: vk::WHOLE_SIZE,
        }];
        let write = [vk::WriteDescriptorSet::default()
            .dst_set(probe.set)
            .dst_binding(0)
            .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
            .buffer_info(&buffer_info)];
        // SAFETY: the set is not in use; the buffer is live.
        unsafe { device.update_descriptor_sets(&write, &[]) };
        Ok(Some(probe))
    }

    /// Run the probe once and wait for it.
    pub(crate) fn measure(&mut self) -> Result<ClockReading, GpuError> {
        let device = &self.ctx.device;
        let constants = ProbeConstants { iterations: ITERATIONS, a: 0.999_999, b: 1e-6 };
        self.ctx.one_shot(|cmd| {
            self.timer.begin(cmd, 0, false);
            // SAFETY: `cmd` is recording; the pipeline, layout and set are live until Drop,
            // which comes after this waited-for submission; the constants fit the range.
            unsafe {
                bind_compute(
                    device,
                    cmd,
                    self.pipeline,
                    self.layout,
                    self.set,
                    bytemuck::bytes_of(&constants),
                );
                device.cmd_dispatch(cmd, 1, 1, 1);
            }
            self.timer.end(cmd, 0);
            barrier::buffers(device, cmd, &[Access::ComputeWrite], &[Access::HostRead]);
        })?;
        let gpu_ms = self.timer.read_ms(0).ok_or_else(|| {
            GpuError::vk("reading the clock probe's timestamps", vk::Result::NOT_READY)
        })?;
        let bytes = self.result.mapped().expect("GpuToCpu memory is mapped");
        let low = u32::from_le_bytes(bytes[0..4].try_into().unwrap());
        let high = u32::from_le_bytes(bytes[4..8].try_into().unwrap());
        Ok(ClockReading { cycles: (u64::from(high) << 32) | u64::from(low), gpu_ms })
    }
}

impl Drop for ClockProbe {
    fn drop(&mut self) {
        let d = &self.ctx.device;
        // SAFETY: `measure` waits for its submission, so the GPU uses none of these; null
        // handles (a `new` that failed part-way) are ignored by the destroy calls.
        unsafe {
            destroy_pipeline_objects(d, self.pool, self.pipeline, self.layout, self.set_layout);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::ContextOptions;

    /// The probe runs under validation and counts a plausible clock: the chain's 500,000
    /// dependent fmas take at least one cycle each, and no GPU or CPU clocks above 10 GHz.
    #[test]
    fn the_probe_counts_cycles_at_a_plausible_rate() {
        let ctx = GpuContext::new(&ContextOptions::validated())
            .expect("Vulkan with the validation layer");
        let mut probe = ClockProbe::new(&ctx)
            .unwrap()
            .expect("the device offers VK_KHR_shader_clock and timestamps");
        let first = probe.measure().unwrap();
        let second = probe.measure().unwrap();
        for r in [first, second] {
            assert!(r.cycles >= u64::from(ITERATIONS), "{r:?}: fewer cycles than dependent fmas");
            assert!(r.gpu_ms > 0.0, "{r:?}");
            assert!(r.mhz() > 1.0 && r.mhz() < 10_000.0, "{r:?}: {} MHz", r.mhz());
        }
        assert!(ctx.validation_messages().is_empty(), "{:?}", ctx.validation_messages());
    }
}
