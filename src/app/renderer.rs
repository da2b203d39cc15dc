//! Recording and submitting the window's frames: trace into the output buffers at the
//! render resolution, copy the packed colour into a display image, blit it (letterboxed)
//! into the swapchain image, draw egui on top with dynamic rendering, present.
//!
//! Two frames in flight, each with its command buffer, fence, acquire semaphore and
//! timestamp slot; the render-finished semaphores belong to the swapchain images. Scene
//! resources (output size, scene buffers, instances) change only after `device_wait_idle`,
//! so the trace pass's descriptor set can be rewritten.

use std::sync::Arc;

use anyhow::{bail, Context as _};
use ash::vk;
use egui::{ClippedPrimitive, TextureId, TexturesDelta};
use egui_ash_renderer::allocator::DefaultAllocator;
use egui_ash_renderer::{DynamicRendering, Options, RenderMode};
use gpu_allocator::MemoryLocation;
use image::RgbaImage;

use super::cost_view::{heat_map, HeatMap};
use super::state::{CostMetric, PixelRect};
use crate::gpu::buffer::GpuBuffer;
use crate::gpu::error::VkContext;
use crate::gpu::scene_buffers::SceneBuffers;
use crate::gpu::swapchain::{color_layers, color_range, Acquired, GpuImage, Swapchain};
use crate::gpu::timer::GpuTimer;
use crate::gpu::trace_pass::{TraceOutput, TracePass};
use crate::gpu::GpuContext;
use crate::tracer::frame::FrameParams;
use crate::tracer::packed::{GpuInstance, PackedScene};

/// Frames the CPU may record ahead of the GPU.
pub const FRAMES_IN_FLIGHT: usize = 2;

/// The letterbox colour around the traced image.
const CLEAR: [f32; 4] = [0.06, 0.06, 0.07, 1.0];

/// One frame to draw.
pub struct FrameRequest<'a> {
    /// What to trace; None draws the panel alone (no scene yet).
    pub params: Option<FrameParams>,
    /// Show the cost heat map of this counter instead of the colour.
    pub cost: Option<CostMetric>,
    /// Where the image goes in the window (already letterboxed), physical pixels.
    pub image_rect: PixelRect,
    /// egui's tessellated output and its scale.
    pub ui: &'a [ClippedPrimitive],
    pub pixels_per_point: f32,
    /// Read the window back after drawing (window screenshot).
    pub capture_window: bool,
}

/// What drawing a frame produced.
#[derive(Default)]
pub struct FrameOutcome {
    /// A frame was submitted and presented (false: minimized or out of date, skipped).
    pub presented: bool,
    /// GPU trace milliseconds of an earlier frame whose timestamps are now available.
    pub gpu_ms: Option<f64>,
    /// The window as drawn, when asked for.
    pub window_image: Option<Result<RgbaImage, String>>,
    /// Statistics of the heat map, when one was shown.
    pub heat: Option<(f32, f32, f32)>,
}

struct FrameSlot {
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
    acquire: vk::Semaphore,
    /// The timer slot holds this slot's last trace.
    timed: bool,
}

struct CostBuffers {
    readback: GpuBuffer,
    upload: GpuBuffer,
}

/// Everything on the GPU side of the window.
pub struct Renderer {
    swapchain: Swapchain,
    swapchain_dirty: bool,
    window_extent: vk::Extent2D,
    vsync: bool,
    pool: vk::CommandPool,
    upload_pool: vk::CommandPool,
    slots: Vec<FrameSlot>,
    frame: u64,
    pass: TracePass,
    scene: Option<SceneBuffers>,
    output: Option<TraceOutput>,
    display: Option<GpuImage>,
    timer: Option<GpuTimer>,
    egui: egui_ash_renderer::Renderer<DefaultAllocator>,
    egui_format: vk::Format,
    /// Frame number that last used each of egui's per-frame vertex buffers.
    egui_mesh_frame: [Option<u64>; FRAMES_IN_FLIGHT],
    egui_draws: u64,
    pending_free: Vec<TextureId>,
    capture: Option<GpuBuffer>,
    cost: Option<CostBuffers>,
    /// The last heat map, for trace screenshots in cost view.
    last_heat: Option<(u32, u32, Vec<u8>)>,
    /// The output buffers hold a traced frame.
    traced: bool,
    // Last: everything above is freed through it.
    ctx: Arc<GpuContext>,
}

impl Renderer {
    /// Set up the swapchain for `surface` (owned from here on) and the frame resources.
    pub fn new(ctx: &Arc<GpuContext>, surface: vk::SurfaceKHR, extent: vk::Extent2D, vsync: bool) -> anyhow::Result<Self> {
        let swapchain = Swapchain::new(ctx, surface, extent, vsync)?;
        let device = &ctx.device;
        let format_ok = |format: vk::Format, feature: vk::FormatFeatureFlags| {
            let props = unsafe { ctx.instance.get_physical_device_format_properties(ctx.physical_device, format) };
            props.optimal_tiling_features.contains(feature)
        };
        if !format_ok(vk::Format::R8G8B8A8_UNORM, vk::FormatFeatureFlags::BLIT_SRC | vk::FormatFeatureFlags::SAMPLED_IMAGE_FILTER_LINEAR) {
            bail!("the Vulkan device cannot blit from R8G8B8A8_UNORM images, which the window needs");
        }
        if swapchain.is_usable() && !format_ok(swapchain.format.format, vk::FormatFeatureFlags::BLIT_DST) {
            bail!("the Vulkan device cannot blit into the window's format {:?}", swapchain.format.format);
        }
        let pool_info = vk::CommandPoolCreateInfo::default().queue_family_index(ctx.queue_family).flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        let pool = unsafe { device.create_command_pool(&pool_info, None) }.during("creating the frame command pool")?;
        let upload_pool = unsafe { device.create_command_pool(&pool_info, None) }.during("creating the upload command pool")?;
        let alloc = vk::CommandBufferAllocateInfo::default().command_pool(pool).level(vk::CommandBufferLevel::PRIMARY).command_buffer_count(FRAMES_IN_FLIGHT as u32);
        let cmds = unsafe { device.allocate_command_buffers(&alloc) }.during("allocating frame command buffers")?;
        let mut slots = Vec::new();
        for cmd in cmds {
            let fence = unsafe { device.create_fence(&vk::FenceCreateInfo::default().flags(vk::FenceCreateFlags::SIGNALED), None) }.during("creating a fence")?;
            let acquire = unsafe { device.create_semaphore(&vk::SemaphoreCreateInfo::default(), None) }.during("creating a semaphore")?;
            slots.push(FrameSlot { cmd, fence, acquire, timed: false });
        }
        let egui_format = if swapchain.is_usable() { swapchain.format.format } else { vk::Format::B8G8R8A8_UNORM };
        let egui = egui_ash_renderer::Renderer::with_default_allocator(
            &ctx.instance,
            ctx.physical_device,
            ctx.device.clone(),
            RenderMode::DynamicRendering(DynamicRendering { color_attachment_format: egui_format, depth_attachment_format: None, stencil_attachment_format: None }),
            // UNORM target: egui's shader encodes its output to sRGB itself.
            Options { in_flight_frames: FRAMES_IN_FLIGHT, srgb_framebuffer: false, ..Default::default() },
        )
        .context("creating the egui renderer")?;
        Ok(Self {
            swapchain,
            swapchain_dirty: false,
            window_extent: extent,
            vsync,
            pool,
            upload_pool,
            slots,
            frame: 0,
            pass: TracePass::new(ctx)?,
            scene: None,
            output: None,
            display: None,
            timer: GpuTimer::new(ctx, FRAMES_IN_FLIGHT as u32)?,
            egui,
            egui_format,
            egui_mesh_frame: [None; FRAMES_IN_FLIGHT],
            egui_draws: 0,
            pending_free: Vec::new(),
            capture: None,
            cost: None,
            last_heat: None,
            traced: false,
            ctx: ctx.clone(),
        })
    }

    /// The present mode in use.
    pub fn present_mode(&self) -> vk::PresentModeKHR {
        self.swapchain.present_mode
    }

    /// Present modes the surface offers.
    pub fn present_modes(&self) -> &[vk::PresentModeKHR] {
        &self.swapchain.present_modes
    }

    /// The swapchain's size (0 x 0 while minimized).
    pub fn swapchain_extent(&self) -> vk::Extent2D {
        if self.swapchain.is_usable() {
            self.swapchain.extent
        } else {
            vk::Extent2D::default()
        }
    }

    /// The window now has this many physical pixels.
    pub fn resize(&mut self, width: u32, height: u32) {
        let extent = vk::Extent2D { width, height };
        if extent != self.window_extent {
            self.window_extent = extent;
            self.swapchain_dirty = true;
        }
    }

    /// Switch vsync (FIFO) on or off (MAILBOX/IMMEDIATE where offered).
    pub fn set_vsync(&mut self, vsync: bool) {
        if vsync != self.vsync {
            self.vsync = vsync;
            self.swapchain_dirty = true;
        }
    }

    fn wait_idle(&self) -> anyhow::Result<()> {
        Ok(self.ctx.wait_idle()?)
    }

    fn rebind(&self) {
        if let (Some(scene), Some(output)) = (&self.scene, &self.output) {
            self.pass.bind(scene, output);
        }
    }

    /// Make the output buffers `width` x `height`; on failure the old ones stay.
    pub fn set_resolution(&mut self, width: u32, height: u32) -> anyhow::Result<()> {
        if self.output.as_ref().is_some_and(|o| o.width == width && o.height == height) {
            return Ok(());
        }
        self.wait_idle()?;
        let usage = vk::ImageUsageFlags::TRANSFER_DST | vk::ImageUsageFlags::TRANSFER_SRC;
        // Free the old buffers first: at large sizes both may not fit.
        self.output = None;
        self.display = None;
        self.cost = None;
        self.last_heat = None;
        self.traced = false;
        let output = TraceOutput::new(&self.ctx, width, height).with_context(|| format!("creating the {width}x{height} output"))?;
        let display = GpuImage::new(&self.ctx, width, height, vk::Format::R8G8B8A8_UNORM, usage, "display image")?;
        self.output = Some(output);
        self.display = Some(display);
        self.rebind();
        Ok(())
    }

    /// The render resolution of the output buffers, if any.
    pub fn resolution(&self) -> Option<(u32, u32)> {
        self.output.as_ref().map(|o| (o.width, o.height))
    }

    /// Upload a new scene (a model load); the old one is freed first.
    pub fn set_scene(&mut self, packed: &PackedScene) -> anyhow::Result<()> {
        self.wait_idle()?;
        self.scene = None;
        self.traced = false;
        self.scene = Some(SceneBuffers::upload(&self.ctx, packed)?);
        self.rebind();
        Ok(())
    }

    /// Replace the environment image (after `PackedScene::set_environment`).
    pub fn set_environment(&mut self, packed: &PackedScene) -> anyhow::Result<()> {
        self.wait_idle()?;
        if let Some(scene) = &mut self.scene {
            scene.set_environment(&self.ctx, packed)?;
        }
        self.rebind();
        Ok(())
    }

    /// Replace the instance list (model count): no geometry is uploaded.
    pub fn set_instances(&mut self, instances: &[GpuInstance]) -> anyhow::Result<()> {
        self.wait_idle()?;
        if let Some(scene) = &mut self.scene {
            scene.set_instances(instances)?;
        }
        Ok(())
    }

    /// Instances on the GPU now.
    pub fn instance_count(&self) -> u32 {
        self.scene.as_ref().map_or(0, |s| s.instance_count)
    }

    /// Apply egui's texture changes (before drawing the frame that uses them); the delta
    /// is emptied even on failure.
    pub fn update_textures(&mut self, delta: &mut TexturesDelta) -> anyhow::Result<()> {
        let set: Vec<_> = delta.set.drain().collect();
        let free: Vec<_> = delta.free.drain().collect();
        if !self.pending_free.is_empty() || !set.is_empty() {
            // Rare (font atlas changes): wait rather than track which frame uses what.
            self.wait_idle()?;
        }
        for id in std::mem::take(&mut self.pending_free) {
            self.egui.free_texture(id).context("freeing egui textures")?;
        }
        for (id, deltas) in set {
            for image_delta in &deltas {
                self.egui.set_texture(self.ctx.queue, self.upload_pool, id, image_delta).context("uploading egui textures")?;
            }
        }
        self.pending_free.extend(free);
        Ok(())
    }

    /// Read the last traced image (render resolution, RGBA); None before the first frame.
    pub fn read_trace(&self) -> anyhow::Result<Option<RgbaImage>> {
        self.wait_idle()?;
        if !self.traced {
            return Ok(None);
        }
        if let Some((w, h, rgba)) = &self.last_heat {
            return Ok(RgbaImage::from_raw(*w, *h, rgba.clone()));
        }
        let Some(out) = &self.output else { return Ok(None) };
        let bytes = out.rgba8.download(out.width as u64 * out.height as u64 * 4)?;
        Ok(RgbaImage::from_raw(out.width, out.height, bytes))
    }

    fn ensure_swapchain(&mut self) -> anyhow::Result<bool> {
        if self.window_extent.width == 0 || self.window_extent.height == 0 {
            return Ok(false);
        }
        if self.swapchain_dirty || !self.swapchain.is_usable() {
            self.wait_idle()?;
            self.swapchain_dirty = false;
            if !self.swapchain.recreate(self.window_extent, self.vsync)? {
                return Ok(false);
            }
            if self.swapchain.format.format != self.egui_format {
                self.egui_format = self.swapchain.format.format;
                let mode = RenderMode::DynamicRendering(DynamicRendering { color_attachment_format: self.egui_format, depth_attachment_format: None, stencil_attachment_format: None });
                self.egui.set_render_mode(mode).context("rebuilding the egui pipeline")?;
            }
            self.capture = None;
        }
        Ok(true)
    }

    /// Trace the cost AOV now and turn it into a heat map in the upload buffer.
    fn trace_cost(&mut self, params: &FrameParams, metric: CostMetric, slot: usize) -> anyhow::Result<(Option<f64>, HeatMap)> {
        self.wait_idle()?;
        let out = self.output.as_ref().context("no output buffers")?;
        let (w, h) = (out.width, out.height);
        let pixels = w as u64 * h as u64;
        if self.cost.is_none() {
            let readback = GpuBuffer::new(&self.ctx, pixels * 16, vk::BufferUsageFlags::TRANSFER_DST, MemoryLocation::GpuToCpu, "cost readback")?;
            let upload = GpuBuffer::new(&self.ctx, pixels * 4, vk::BufferUsageFlags::TRANSFER_SRC, MemoryLocation::CpuToGpu, "heat map upload")?;
            self.cost = Some(CostBuffers { readback, upload });
        }
        let cost = self.cost.as_mut().expect("created above");
        let device = &self.ctx.device;
        let timer = self.timer.as_ref();
        let pass = &self.pass;
        self.ctx.one_shot(|cmd| unsafe {
            if let Some(t) = timer {
                t.begin(cmd, slot as u32);
            }
            let before = [vk::MemoryBarrier::default().src_access_mask(vk::AccessFlags::SHADER_WRITE).dst_access_mask(vk::AccessFlags::SHADER_WRITE)];
            device.cmd_pipeline_barrier(cmd, vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER, vk::PipelineStageFlags::COMPUTE_SHADER, vk::DependencyFlags::empty(), &before, &[], &[]);
            if params.settings.adaptive {
                pass.record_id_pass(cmd, params);
            }
            pass.record(cmd, params, 0, h);
            if let Some(t) = timer {
                t.end(cmd, slot as u32);
            }
            let to_copy = [vk::MemoryBarrier::default().src_access_mask(vk::AccessFlags::SHADER_WRITE).dst_access_mask(vk::AccessFlags::TRANSFER_READ)];
            device.cmd_pipeline_barrier(cmd, vk::PipelineStageFlags::COMPUTE_SHADER, vk::PipelineStageFlags::TRANSFER, vk::DependencyFlags::empty(), &to_copy, &[], &[]);
            device.cmd_copy_buffer(cmd, out.float.buffer, cost.readback.buffer, &[vk::BufferCopy { src_offset: 0, dst_offset: 0, size: pixels * 16 }]);
            let to_host = [vk::MemoryBarrier::default().src_access_mask(vk::AccessFlags::TRANSFER_WRITE).dst_access_mask(vk::AccessFlags::HOST_READ)];
            device.cmd_pipeline_barrier(cmd, vk::PipelineStageFlags::TRANSFER, vk::PipelineStageFlags::HOST, vk::DependencyFlags::empty(), &to_host, &[], &[]);
        })?;
        let gpu_ms = timer.and_then(|t| t.read_ms(slot as u32));
        let floats: Vec<f32> = bytemuck::pod_collect_to_vec(&cost.readback.mapped().context("readback memory is not mapped")?[..(pixels * 16) as usize]);
        let heat = heat_map(&floats, metric);
        cost.upload.mapped().context("upload memory is not mapped")?[..heat.rgba.len()].copy_from_slice(&heat.rgba);
        Ok((gpu_ms, heat))
    }

    /// Draw and present one frame.
    pub fn draw(&mut self, req: &FrameRequest) -> anyhow::Result<FrameOutcome> {
        let mut outcome = FrameOutcome::default();
        if !self.ensure_swapchain()? {
            return Ok(outcome);
        }
        let f = (self.frame % FRAMES_IN_FLIGHT as u64) as usize;
        let device = self.ctx.device.clone();
        let fence = self.slots[f].fence;
        unsafe { device.wait_for_fences(&[fence], true, u64::MAX) }.during("waiting for a frame")?;
        if self.slots[f].timed {
            self.slots[f].timed = false;
            outcome.gpu_ms = self.timer.as_ref().and_then(|t| t.read_ms(f as u32));
        }
        let index = match self.swapchain.acquire(self.slots[f].acquire)? {
            Acquired::OutOfDate => {
                self.swapchain_dirty = true;
                return Ok(outcome);
            }
            Acquired::Image { index, suboptimal } => {
                self.swapchain_dirty |= suboptimal;
                index
            }
        };

        // What the image area shows this frame: the trace's colour, or a heat map.
        let traceable = req.params.filter(|_| self.scene.is_some() && self.output.is_some());
        let mut source: Option<vk::Buffer> = None;
        let mut trace_in_frame = false;
        if let Some(params) = &traceable {
            if let Some(metric) = req.cost {
                let (gpu_ms, heat) = self.trace_cost(params, metric, f)?;
                outcome.gpu_ms = gpu_ms.or(outcome.gpu_ms);
                outcome.heat = Some((heat.scale_max, heat.max, heat.mean));
                let out = self.output.as_ref().expect("checked");
                self.last_heat = Some((out.width, out.height, heat.rgba));
                source = self.cost.as_ref().map(|c| c.upload.buffer);
            } else {
                self.last_heat = None;
                trace_in_frame = true;
                source = self.output.as_ref().map(|o| o.rgba8.buffer);
            }
            self.traced = true;
        }

        // egui's vertex buffers rotate per draw call: make sure the one it reuses is free.
        if !req.ui.is_empty() {
            let k = (self.egui_draws % FRAMES_IN_FLIGHT as u64) as usize;
            if let Some(used_by) = self.egui_mesh_frame[k] {
                let s = (used_by % FRAMES_IN_FLIGHT as u64) as usize;
                if s != f {
                    unsafe { device.wait_for_fences(&[self.slots[s].fence], true, u64::MAX) }.during("waiting for a frame")?;
                }
            }
            self.egui_mesh_frame[k] = Some(self.frame);
            self.egui_draws += 1;
        }

        let capture = req.capture_window && self.swapchain.transfer_src;
        let extent = self.swapchain.extent;
        if capture && self.capture.as_ref().is_none_or(|c| c.size < extent.width as u64 * extent.height as u64 * 4) {
            self.capture = Some(GpuBuffer::new(&self.ctx, extent.width as u64 * extent.height as u64 * 4, vk::BufferUsageFlags::TRANSFER_DST, MemoryLocation::GpuToCpu, "window readback")?);
        }

        let cmd = self.slots[f].cmd;
        unsafe {
            device.reset_fences(&[fence]).during("resetting a fence")?;
            device.reset_command_buffer(cmd, vk::CommandBufferResetFlags::empty()).during("resetting a command buffer")?;
            device.begin_command_buffer(cmd, &vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT)).during("recording a frame")?;
        }
        if trace_in_frame {
            let params = traceable.as_ref().expect("checked");
            self.record_trace(cmd, params, f);
            self.slots[f].timed = self.timer.is_some();
        }
        let swap_image = self.swapchain.images[index as usize];
        self.record_composite(cmd, source, swap_image, req.image_rect);
        self.record_ui(cmd, index, req)?;
        self.record_present_transition(cmd, swap_image, capture);
        unsafe { device.end_command_buffer(cmd) }.during("recording a frame")?;

        let waits = [self.slots[f].acquire];
        let stages = [vk::PipelineStageFlags::TRANSFER | vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT];
        let signals = [self.swapchain.render_finished[index as usize]];
        let cmds = [cmd];
        let submit = [vk::SubmitInfo::default().wait_semaphores(&waits).wait_dst_stage_mask(&stages).command_buffers(&cmds).signal_semaphores(&signals)];
        self.ctx.submit(&submit, fence)?;
        self.swapchain_dirty |= self.swapchain.present(index)?;
        self.frame += 1;
        outcome.presented = true;

        if req.capture_window {
            outcome.window_image = Some(if capture {
                unsafe { device.wait_for_fences(&[fence], true, u64::MAX) }.during("waiting for a frame")?;
                let buf = self.capture.as_mut().expect("created above");
                let len = extent.width as usize * extent.height as usize * 4;
                let bytes = buf.mapped().context("readback memory is not mapped")?[..len].to_vec();
                super::screenshot::window_image(bytes, extent.width, extent.height, self.swapchain.is_bgra()).ok_or_else(|| "the window readback has the wrong size".to_string())
            } else {
                Err("this window surface cannot be read back (no TRANSFER_SRC usage)".to_string())
            });
        }
        Ok(outcome)
    }

    fn record_trace(&self, cmd: vk::CommandBuffer, params: &FrameParams, slot: usize) {
        let device = &self.ctx.device;
        unsafe {
            if let Some(t) = &self.timer {
                t.begin(cmd, slot as u32);
            }
            // The previous frame's trace wrote, and its copy read, the output buffers.
            let barrier = [vk::MemoryBarrier::default().src_access_mask(vk::AccessFlags::SHADER_WRITE).dst_access_mask(vk::AccessFlags::SHADER_WRITE)];
            device.cmd_pipeline_barrier(cmd, vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER, vk::PipelineStageFlags::COMPUTE_SHADER, vk::DependencyFlags::empty(), &barrier, &[], &[]);
            if params.settings.adaptive {
                self.pass.record_id_pass(cmd, params);
            }
            self.pass.record(cmd, params, 0, params.settings.height);
            if let Some(t) = &self.timer {
                t.end(cmd, slot as u32);
            }
        }
    }

    /// Copy `source` (packed RGBA8) into the display image and blit it into the swapchain
    /// image, which is cleared around it; the swapchain image ends as a colour attachment.
    fn record_composite(&self, cmd: vk::CommandBuffer, source: Option<vk::Buffer>, swap_image: vk::Image, rect: PixelRect) {
        let device = &self.ctx.device;
        let extent = self.swapchain.extent;
        let display = self.display.as_ref().filter(|_| source.is_some());
        unsafe {
            let mut image_barriers = vec![image_barrier(
                swap_image,
                vk::ImageLayout::UNDEFINED,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                vk::AccessFlags::empty(),
                vk::AccessFlags::TRANSFER_WRITE,
            )];
            if let Some(d) = display {
                image_barriers.push(image_barrier(d.image, vk::ImageLayout::UNDEFINED, vk::ImageLayout::TRANSFER_DST_OPTIMAL, vk::AccessFlags::empty(), vk::AccessFlags::TRANSFER_WRITE));
            }
            let traced = [vk::MemoryBarrier::default().src_access_mask(vk::AccessFlags::SHADER_WRITE).dst_access_mask(vk::AccessFlags::TRANSFER_READ)];
            device.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::TRANSFER,
                vk::DependencyFlags::empty(),
                &traced,
                &[],
                &image_barriers,
            );
            device.cmd_clear_color_image(cmd, swap_image, vk::ImageLayout::TRANSFER_DST_OPTIMAL, &vk::ClearColorValue { float32: CLEAR }, &[color_range()]);
            if let (Some(d), Some(src)) = (display, source) {
                let region = whole_image_copy(d.width, d.height);
                device.cmd_copy_buffer_to_image(cmd, src, d.image, vk::ImageLayout::TRANSFER_DST_OPTIMAL, &[region]);
                let barriers = [
                    image_barrier(d.image, vk::ImageLayout::TRANSFER_DST_OPTIMAL, vk::ImageLayout::TRANSFER_SRC_OPTIMAL, vk::AccessFlags::TRANSFER_WRITE, vk::AccessFlags::TRANSFER_READ),
                    // The clear and the blit both write the swapchain image.
                    image_barrier(swap_image, vk::ImageLayout::TRANSFER_DST_OPTIMAL, vk::ImageLayout::TRANSFER_DST_OPTIMAL, vk::AccessFlags::TRANSFER_WRITE, vk::AccessFlags::TRANSFER_WRITE),
                ];
                device.cmd_pipeline_barrier(cmd, vk::PipelineStageFlags::TRANSFER, vk::PipelineStageFlags::TRANSFER, vk::DependencyFlags::empty(), &[], &[], &barriers);
                // Clip the destination to the swapchain.
                let x0 = rect.x.clamp(0, extent.width as i32);
                let y0 = rect.y.clamp(0, extent.height as i32);
                let x1 = (rect.x + rect.width as i32).clamp(0, extent.width as i32);
                let y1 = (rect.y + rect.height as i32).clamp(0, extent.height as i32);
                if x1 > x0 && y1 > y0 {
                    // Map the clipped destination back to the source.
                    let sx = d.width as f64 / rect.width.max(1) as f64;
                    let sy = d.height as f64 / rect.height.max(1) as f64;
                    let src0 = [((x0 - rect.x) as f64 * sx).round() as i32, ((y0 - rect.y) as f64 * sy).round() as i32];
                    let src1 = [((x1 - rect.x) as f64 * sx).round() as i32, ((y1 - rect.y) as f64 * sy).round() as i32];
                    let blit = vk::ImageBlit {
                        src_subresource: color_layers(),
                        src_offsets: [vk::Offset3D { x: src0[0], y: src0[1], z: 0 }, vk::Offset3D { x: src1[0].min(d.width as i32), y: src1[1].min(d.height as i32), z: 1 }],
                        dst_subresource: color_layers(),
                        dst_offsets: [vk::Offset3D { x: x0, y: y0, z: 0 }, vk::Offset3D { x: x1, y: y1, z: 1 }],
                    };
                    // Magnified pixels stay sharp; minified ones are filtered.
                    let filter = if rect.width >= d.width { vk::Filter::NEAREST } else { vk::Filter::LINEAR };
                    device.cmd_blit_image(cmd, d.image, vk::ImageLayout::TRANSFER_SRC_OPTIMAL, swap_image, vk::ImageLayout::TRANSFER_DST_OPTIMAL, &[blit], filter);
                }
            }
            let to_attachment = [image_barrier(
                swap_image,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
                vk::AccessFlags::TRANSFER_WRITE,
                vk::AccessFlags::COLOR_ATTACHMENT_READ | vk::AccessFlags::COLOR_ATTACHMENT_WRITE,
            )];
            device.cmd_pipeline_barrier(cmd, vk::PipelineStageFlags::TRANSFER, vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT, vk::DependencyFlags::empty(), &[], &[], &to_attachment);
        }
    }

    fn record_ui(&mut self, cmd: vk::CommandBuffer, index: u32, req: &FrameRequest) -> anyhow::Result<()> {
        if req.ui.is_empty() {
            return Ok(());
        }
        let extent = self.swapchain.extent;
        let attachment = [vk::RenderingAttachmentInfo::default()
            .image_view(self.swapchain.views[index as usize])
            .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
            .load_op(vk::AttachmentLoadOp::LOAD)
            .store_op(vk::AttachmentStoreOp::STORE)];
        let info = vk::RenderingInfo::default()
            .render_area(vk::Rect2D { offset: vk::Offset2D::default(), extent })
            .layer_count(1)
            .color_attachments(&attachment);
        unsafe { self.ctx.device.cmd_begin_rendering(cmd, &info) };
        let drawn = self.egui.cmd_draw(cmd, extent, req.pixels_per_point, req.ui);
        unsafe { self.ctx.device.cmd_end_rendering(cmd) };
        drawn.context("drawing the panel")
    }

    fn record_present_transition(&self, cmd: vk::CommandBuffer, swap_image: vk::Image, capture: bool) {
        let device = &self.ctx.device;
        let extent = self.swapchain.extent;
        unsafe {
            if let (true, Some(buf)) = (capture, &self.capture) {
                let to_src = [image_barrier(
                    swap_image,
                    vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
                    vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                    vk::AccessFlags::COLOR_ATTACHMENT_WRITE,
                    vk::AccessFlags::TRANSFER_READ,
                )];
                device.cmd_pipeline_barrier(cmd, vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT, vk::PipelineStageFlags::TRANSFER, vk::DependencyFlags::empty(), &[], &[], &to_src);
                let region = whole_image_copy(extent.width, extent.height);
                device.cmd_copy_image_to_buffer(cmd, swap_image, vk::ImageLayout::TRANSFER_SRC_OPTIMAL, buf.buffer, &[region]);
                let to_host = [vk::MemoryBarrier::default().src_access_mask(vk::AccessFlags::TRANSFER_WRITE).dst_access_mask(vk::AccessFlags::HOST_READ)];
                let to_present = [image_barrier(swap_image, vk::ImageLayout::TRANSFER_SRC_OPTIMAL, vk::ImageLayout::PRESENT_SRC_KHR, vk::AccessFlags::TRANSFER_READ, vk::AccessFlags::empty())];
                device.cmd_pipeline_barrier(cmd, vk::PipelineStageFlags::TRANSFER, vk::PipelineStageFlags::HOST | vk::PipelineStageFlags::BOTTOM_OF_PIPE, vk::DependencyFlags::empty(), &to_host, &[], &to_present);
            } else {
                let to_present = [image_barrier(
                    swap_image,
                    vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
                    vk::ImageLayout::PRESENT_SRC_KHR,
                    vk::AccessFlags::COLOR_ATTACHMENT_WRITE,
                    vk::AccessFlags::empty(),
                )];
                device.cmd_pipeline_barrier(cmd, vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT, vk::PipelineStageFlags::BOTTOM_OF_PIPE, vk::DependencyFlags::empty(), &[], &[], &to_present);
            }
        }
    }
}

/// A copy between a tightly packed buffer and a whole `width` x `height` colour image.
fn whole_image_copy(width: u32, height: u32) -> vk::BufferImageCopy {
    vk::BufferImageCopy {
        buffer_offset: 0,
        buffer_row_length: 0,
        buffer_image_height: 0,
        image_subresource: color_layers(),
        image_offset: vk::Offset3D::default(),
        image_extent: vk::Extent3D { width, height, depth: 1 },
    }
}

fn image_barrier(image: vk::Image, old: vk::ImageLayout, new: vk::ImageLayout, src: vk::AccessFlags, dst: vk::AccessFlags) -> vk::ImageMemoryBarrier<'static> {
    vk::ImageMemoryBarrier::default()
        .image(image)
        .old_layout(old)
        .new_layout(new)
        .src_access_mask(src)
        .dst_access_mask(dst)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .subresource_range(color_range())
}

impl Drop for Renderer {
    fn drop(&mut self) {
        let device = &self.ctx.device;
        unsafe {
            let _ = device.device_wait_idle();
            for slot in &self.slots {
                device.destroy_fence(slot.fence, None);
                device.destroy_semaphore(slot.acquire, None);
            }
            device.destroy_command_pool(self.pool, None);
            device.destroy_command_pool(self.upload_pool, None);
        }
    }
}
