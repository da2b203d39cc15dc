//! The headless GPU tracer: scene buffers + trace pass + output buffers + timer. `render`,
//! `bench` and the tests use it; the app records the same `TracePass` into its frames.

use std::sync::Arc;
use std::time::Instant;

use ash::vk;

use super::context::GpuContext;
use super::error::{GpuError, VkContext};
use super::scene_buffers::SceneBuffers;
use super::timer::GpuTimer;
use super::trace_pass::{TraceOutput, TracePass, GROUP_SIZE};
use crate::tracer::frame::{Accel, FrameParams};
use crate::tracer::image::Image;
use crate::tracer::packed::{GpuInstance, PackedScene};

/// Ray-triangle tests one submission may ask for before the frame is split into row
/// bands, each its own submission, so no single dispatch runs long enough to trip a
/// driver watchdog (brute force on big meshes).
pub const TESTS_PER_SUBMIT: f64 = 4.0e9;

/// Timing of one traced frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TraceTiming {
    /// GPU time of the trace dispatches (timestamps), when the queue has timestamps.
    pub gpu_ms: Option<f64>,
    /// Wall-clock time from submit to completion, as the paper's fps would count it.
    pub wall_ms: f64,
    /// Submissions the frame was split into.
    pub submissions: u32,
}

/// A scene on the GPU, ready to trace frames.
pub struct GpuTracer {
    ctx: Arc<GpuContext>,
    pass: TracePass,
    scene: SceneBuffers,
    output: Option<TraceOutput>,
    timer: Option<GpuTimer>,
    /// Triangles over all instances, for the per-ray cost estimate.
    triangle_total: u64,
    /// One command buffer and fence reused by every submission (no per-frame allocation).
    pool: vk::CommandPool,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
}

impl GpuTracer {
    /// Upload `packed` and build the pipeline.
    pub fn new(ctx: &Arc<GpuContext>, packed: &PackedScene) -> Result<Self, GpuError> {
        let pass = TracePass::new(ctx)?;
        let scene = SceneBuffers::upload(ctx, packed)?;
        let timer = GpuTimer::new(ctx, 1)?;
        let device = &ctx.device;
        let pool_info = vk::CommandPoolCreateInfo::default().queue_family_index(ctx.queue_family).flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        let pool = unsafe { device.create_command_pool(&pool_info, None) }.during("creating a command pool")?;
        let alloc = vk::CommandBufferAllocateInfo::default().command_pool(pool).level(vk::CommandBufferLevel::PRIMARY).command_buffer_count(1);
        let cmd = unsafe { device.allocate_command_buffers(&alloc) }.during("allocating a command buffer")?[0];
        let fence = unsafe { device.create_fence(&vk::FenceCreateInfo::default(), None) }.during("creating a fence")?;
        let triangle_total = packed.instances.iter().map(|i| i.triangle_count as u64).sum();
        Ok(Self { ctx: ctx.clone(), pass, scene, output: None, timer, triangle_total, pool, cmd, fence })
    }

    /// Record with `record` into the reusable command buffer, submit, and wait.
    fn submit_and_wait(&self, record: impl FnOnce(vk::CommandBuffer)) -> Result<(), GpuError> {
        let device = &self.ctx.device;
        let cmd = self.cmd;
        unsafe {
            device.reset_command_buffer(cmd, vk::CommandBufferResetFlags::empty()).during("resetting a command buffer")?;
            device
                .begin_command_buffer(cmd, &vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT))
                .during("recording commands")?;
            record(cmd);
            device.end_command_buffer(cmd).during("recording commands")?;
            let cmds = [cmd];
            let submit = [vk::SubmitInfo::default().command_buffers(&cmds)];
            device.reset_fences(&[self.fence]).during("resetting a fence")?;
            self.ctx.submit(&submit, self.fence)?;
            device.wait_for_fences(&[self.fence], true, u64::MAX).during("waiting for the trace")
        }
    }

    /// The context this tracer runs on.
    pub fn context(&self) -> &Arc<GpuContext> {
        &self.ctx
    }

    /// Replace the instance list (model count change): no geometry is re-uploaded.
    pub fn set_instances(&mut self, instances: &[GpuInstance]) -> Result<(), GpuError> {
        self.scene.set_instances(instances)?;
        self.triangle_total = instances.iter().map(|i| i.triangle_count as u64).sum();
        Ok(())
    }

    /// Replace the environment image (after `PackedScene::set_environment`).
    pub fn set_environment(&mut self, packed: &PackedScene) -> Result<(), GpuError> {
        self.scene.set_environment(&self.ctx, packed)?;
        if let Some(out) = &self.output {
            self.pass.bind(&self.scene, out);
        }
        Ok(())
    }

    /// Bytes of device memory the scene uses.
    pub fn scene_bytes(&self) -> u64 {
        self.scene.bytes
    }

    fn ensure_output(&mut self, width: u32, height: u32) -> Result<(), GpuError> {
        if self.output.as_ref().is_none_or(|o| o.width != width || o.height != height) {
            self.output = None; // free the old buffers first
            let out = TraceOutput::new(&self.ctx, width, height)?;
            self.pass.bind(&self.scene, &out);
            self.output = Some(out);
        } else if let Some(out) = &self.output {
            // Instance buffer contents may have changed; the binding itself has not.
            let _ = out;
        }
        Ok(())
    }

    /// Rows per submission so that each stays under `TESTS_PER_SUBMIT` tests (a multiple of the group size).
    fn rows_per_submit(&self, params: &FrameParams) -> u32 {
        let s = &params.settings;
        let tests_per_ray = match s.accel {
            Accel::Brute => self.triangle_total.max(1) as f64,
            Accel::Bvh => 256.0,
        };
        let per_row = s.width as f64 * (s.bounces as f64 + 1.0) * tests_per_ray;
        let rows = (TESTS_PER_SUBMIT / per_row).floor() as u32;
        let rows = rows.max(1).div_ceil(GROUP_SIZE) * GROUP_SIZE;
        rows.min(s.height.div_ceil(GROUP_SIZE) * GROUP_SIZE)
    }

    /// Trace one frame into the output buffers and wait for it.
    pub fn trace(&mut self, params: &FrameParams) -> Result<TraceTiming, GpuError> {
        let s = params.settings;
        self.ensure_output(s.width, s.height)?;
        let mut params = *params;
        params.instance_count = params.instance_count.min(self.scene.instance_count);
        let band = self.rows_per_submit(&params);
        let mut timing = TraceTiming { gpu_ms: self.timer.as_ref().map(|_| 0.0), ..Default::default() };
        let start = Instant::now();
        let mut row = 0;
        let mut first = true;
        while row < s.height {
            let id_pass = first && s.adaptive;
            first = false;
            let rows = band.min(s.height - row);
            let pass = &self.pass;
            let timer = self.timer.as_ref();
            let device = &self.ctx.device;
            self.submit_and_wait(|cmd| unsafe {
                if let Some(t) = timer {
                    t.begin(cmd, 0);
                }
                // The previous band or frame wrote the outputs; order the writes.
                let barrier = [vk::MemoryBarrier::default()
                    .src_access_mask(vk::AccessFlags::SHADER_WRITE | vk::AccessFlags::TRANSFER_READ)
                    .dst_access_mask(vk::AccessFlags::SHADER_WRITE)];
                device.cmd_pipeline_barrier(
                    cmd,
                    vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER,
                    vk::PipelineStageFlags::COMPUTE_SHADER,
                    vk::DependencyFlags::empty(),
                    &barrier,
                    &[],
                    &[],
                );
                if id_pass {
                    pass.record_id_pass(cmd, &params);
                }
                pass.record(cmd, &params, row, rows);
                if let Some(t) = timer {
                    t.end(cmd, 0);
                }
            })?;
            if let (Some(t), Some(total)) = (timer, timing.gpu_ms.as_mut()) {
                *total += t.read_ms(0).unwrap_or(0.0);
            }
            timing.submissions += 1;
            row += rows;
        }
        timing.wall_ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(timing)
    }

    /// Trace a frame and read back the float image (colour or AOV).
    pub fn render(&mut self, params: &FrameParams) -> Result<(Image, TraceTiming), GpuError> {
        let timing = self.trace(params)?;
        Ok((self.read_image()?, timing))
    }

    /// Read the float output of the last frame.
    pub fn read_image(&self) -> Result<Image, GpuError> {
        let out = self.output.as_ref().expect("trace() before read_image()");
        let bytes = out.float.download(out.width as u64 * out.height as u64 * 16)?;
        let floats: &[f32] = bytemuck::cast_slice(&bytes);
        Ok(Image { width: out.width, height: out.height, pixels: floats.chunks_exact(4).map(|c| [c[0], c[1], c[2], c[3]]).collect() })
    }

    /// Read the 8-bit colour output of the last frame (RGBA bytes, row 0 at the top).
    pub fn read_rgba8(&self) -> Result<image::RgbaImage, GpuError> {
        let out = self.output.as_ref().expect("trace() before read_rgba8()");
        let bytes = out.rgba8.download(out.width as u64 * out.height as u64 * 4)?;
        Ok(image::RgbaImage::from_raw(out.width, out.height, bytes).expect("size matches"))
    }
}

impl Drop for GpuTracer {
    fn drop(&mut self) {
        let device = &self.ctx.device;
        unsafe {
            device.destroy_fence(self.fence, None);
            device.destroy_command_pool(self.pool, None);
        }
    }
}
