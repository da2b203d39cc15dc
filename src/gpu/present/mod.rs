//! Presenting frames in a window: the surface and swapchain ([`swapchain`]), the composite
//! of the traced picture into the swapchain image ([`composite`]), the egui pass
//! ([`ui_pass`]) and the window readback ([`capture`]), submitted by the [`Presenter`].
//!
//! Two frames in flight, each with its command buffer, fence, acquire semaphore and
//! timestamp slot; the render-finished semaphores belong to the swapchain images. The
//! trace is recorded into the frame by the shared [`ComputeTracer`], so the window traces
//! exactly as `render` and `bench` do.

pub(crate) mod capture;
pub(crate) mod composite;
pub(crate) mod surface;
pub(crate) mod swapchain;
pub(crate) mod ui_pass;

use std::sync::Arc;

use anyhow::bail;
use ash::vk;
use egui::{ClippedPrimitive, TexturesDelta};
use gpu_allocator::MemoryLocation;
use image::RgbaImage;

use super::barrier::{self, Access, ImageTransition};
use super::buffer::GpuBuffer;
use super::compute_tracer::{ComputeTracer, PartTimes, TimedParts};
use super::context::GpuContext;
use super::dispatch::{Band, FrameTrace};
use super::error::VkContext;
use super::image::GpuImage;
use capture::WindowCapture;
pub use composite::PixelRect;
use swapchain::{Acquired, Swapchain};
use ui_pass::UiPass;

/// Frames the CPU may record ahead of the GPU.
pub(crate) const FRAMES_IN_FLIGHT: usize = 2;

/// What the image area shows this frame.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Show<'a> {
    /// Nothing yet (no model loaded): the panel alone.
    Nothing,
    /// The tracer's colour output, after this frame's trace if it has one.
    Output,
    /// These packed RGBA8 pixels (a heat map made on the CPU).
    Pixels { rgba: &'a [u8], width: u32, height: u32 },
}

/// Which traced frame a band belongs to, whether it is the frame's last band and its
/// pixels: handed back with the band's GPU time, which arrives a frame or two later.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct BandTag {
    /// The traced frame's number (the caller's count).
    pub frame: u64,
    /// The band completes its frame.
    pub last: bool,
    /// The band's pixels, which the next bands are sized from with its time.
    pub pixels: u64,
}

/// One frame to draw.
pub(crate) struct FrameRequest<'a> {
    /// Pixels of a frame to trace in this frame's command buffer (all of them when the
    /// frame fits one submission; a band of a long frame traced over several).
    pub trace: Option<(FrameTrace, Band)>,
    /// What `trace` is a band of, returned with its time.
    pub tag: BandTag,
    pub show: Show<'a>,
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
pub(crate) struct FrameOutcome {
    /// A frame was submitted and presented (false: minimized or out of date, skipped).
    pub presented: bool,
    /// GPU trace milliseconds of an earlier frame whose timestamps are now available.
    pub gpu_ms: Option<f64>,
    /// The same frame's milliseconds per part (left, right) of a split frame.
    pub part_ms: PartTimes,
    /// The tag of the band those times are of.
    pub tag: Option<BandTag>,
    /// The window as drawn, when asked for.
    pub window_image: Option<Result<RgbaImage, String>>,
}

struct FrameSlot {
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
    acquire: vk::Semaphore,
    /// The parts of this slot's last trace that the tracer's timer slot holds.
    timed: TimedParts,
    /// What that trace was a band of.
    tag: BandTag,
}

/// Everything on the GPU side of the window except the tracer.
pub(crate) struct Presenter {
    swapchain: Swapchain,
    swapchain_dirty: bool,
    window_extent: vk::Extent2D,
    vsync: bool,
    pool: vk::CommandPool,
    slots: Vec<FrameSlot>,
    frame: u64,
    /// The traced picture on its way to the screen, the size of the last source.
    display: Option<GpuImage>,
    /// CPU-made pixels (heat maps) on their way to the display image.
    upload: Option<GpuBuffer>,
    ui: UiPass,
    capture: WindowCapture,
    // Last: everything above is freed through it.
    ctx: Arc<GpuContext>,
}

impl Presenter {
    /// Set up the swapchain for `surface` (owned from here on) and the frame resources;
    /// `extent` is the window's size in physical pixels.
    pub(crate) fn new(
        ctx: &Arc<GpuContext>,
        surface: vk::SurfaceKHR,
        extent: [u32; 2],
        vsync: bool,
    ) -> anyhow::Result<Self> {
        let extent = vk::Extent2D { width: extent[0], height: extent[1] };
        let swapchain = Swapchain::new(ctx, surface, extent, vsync)?;
        let device = &ctx.device;
        let format_ok = |format: vk::Format, feature: vk::FormatFeatureFlags| {
            // SAFETY: a query on the live physical device.
            let props = unsafe {
                ctx.instance.get_physical_device_format_properties(ctx.physical_device, format)
            };
            props.optimal_tiling_features.contains(feature)
        };
        if !format_ok(
            vk::Format::R8G8B8A8_UNORM,
            vk::FormatFeatureFlags::BLIT_SRC | vk::FormatFeatureFlags::SAMPLED_IMAGE_FILTER_LINEAR,
        ) {
            bail!(
                "the Vulkan device cannot blit from R8G8B8A8_UNORM images, which the window needs"
            );
        }
        if swapchain.is_usable()
            && !format_ok(swapchain.format.format, vk::FormatFeatureFlags::BLIT_DST)
        {
            bail!(
                "the Vulkan device cannot blit into the window's format {:?}",
                swapchain.format.format
            );
        }
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(ctx.queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        // SAFETY: plain object creation on a live device; everything is destroyed in Drop.
        let pool = unsafe { device.create_command_pool(&pool_info, None) }
            .during("creating the frame command pool")?;
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(FRAMES_IN_FLIGHT as u32);
        // SAFETY: as above; the buffers are freed with their pool.
        let cmds = unsafe { device.allocate_command_buffers(&alloc) }
            .during("allocating frame command buffers")?;
        let mut slots = Vec::new();
        for cmd in cmds {
            // SAFETY: as above.
            let fence = unsafe {
                device.create_fence(
                    &vk::FenceCreateInfo::default().flags(vk::FenceCreateFlags::SIGNALED),
                    None,
                )
            }
            .during("creating a fence")?;
            // SAFETY: as above.
            let acquire =
                unsafe { device.create_semaphore(&vk::SemaphoreCreateInfo::default(), None) }
                    .during("creating a semaphore")?;
            slots.push(FrameSlot {
                cmd,
                fence,
                acquire,
                timed: Default::default(),
                tag: BandTag::default(),
            });
        }
        let ui_format = if swapchain.is_usable() {
            swapchain.format.format
        } else {
            vk::Format::B8G8R8A8_UNORM
        };
        let ui = UiPass::new(ctx, ui_format)?;
        Ok(Self {
            swapchain,
            swapchain_dirty: false,
            window_extent: extent,
            vsync,
            pool,
            slots,
            frame: 0,
            display: None,
            upload: None,
            ui,
            capture: WindowCapture::default(),
            ctx: ctx.clone(),
        })
    }

    /// The present mode in use, for the panel ("Fifo", "Mailbox", ...).
    pub(crate) fn present_mode_name(&self) -> String {
        format!("{:?}", self.swapchain.present_mode)
    }

    /// The surface offers a present mode without vsync.
    pub(crate) fn can_disable_vsync(&self) -> bool {
        self.swapchain
            .present_modes
            .iter()
            .any(|m| *m != vk::PresentModeKHR::FIFO && *m != vk::PresentModeKHR::FIFO_RELAXED)
    }

    /// The window now has this many physical pixels.
    pub(crate) fn resize(&mut self, width: u32, height: u32) {
        let extent = vk::Extent2D { width, height };
        if extent != self.window_extent {
            self.window_extent = extent;
            self.swapchain_dirty = true;
        }
    }

    /// Switch vsync (FIFO) on or off (MAILBOX/IMMEDIATE where offered).
    pub(crate) fn set_vsync(&mut self, vsync: bool) {
        if vsync != self.vsync {
            self.vsync = vsync;
            self.swapchain_dirty = true;
        }
    }

    /// Apply egui's texture changes before drawing the frame that uses them.
    pub(crate) fn update_textures(&mut self, delta: &mut TexturesDelta) -> anyhow::Result<()> {
        self.ui.update_textures(delta)
    }

    fn ensure_swapchain(&mut self) -> anyhow::Result<bool> {
        if self.window_extent.width == 0 || self.window_extent.height == 0 {
            return Ok(false);
        }
        if self.swapchain_dirty || !self.swapchain.is_usable() {
            self.ctx.wait_idle()?;
            self.swapchain_dirty = false;
            if !self.swapchain.recreate(self.window_extent, self.vsync)? {
                return Ok(false);
            }
            self.ui.set_format(self.swapchain.format.format)?;
            self.capture.clear();
        }
        Ok(true)
    }

    /// A display image of `width` x `height` (recreated, after the GPU is idle, on a change).
    fn ensure_display(&mut self, width: u32, height: u32) -> anyhow::Result<&GpuImage> {
        if self.display.as_ref().is_none_or(|d| d.width != width || d.height != height) {
            self.ctx.wait_idle()?;
            self.display = None;
            let usage = vk::ImageUsageFlags::TRANSFER_DST | vk::ImageUsageFlags::TRANSFER_SRC;
            self.display = Some(GpuImage::new(
                &self.ctx,
                width,
                height,
                vk::Format::R8G8B8A8_UNORM,
                usage,
                "display image",
            )?);
        }
        Ok(self.display.as_ref().expect("created above"))
    }

    /// Put CPU-made pixels in the upload buffer (after the GPU is done with it).
    fn upload_pixels(&mut self, rgba: &[u8]) -> anyhow::Result<vk::Buffer> {
        self.ctx.wait_idle()?;
        if self.upload.as_ref().is_none_or(|u| u.size < rgba.len() as u64) {
            self.upload = None;
            self.upload = Some(GpuBuffer::new(
                &self.ctx,
                rgba.len() as u64,
                vk::BufferUsageFlags::TRANSFER_SRC,
                MemoryLocation::CpuToGpu,
                "heat map upload",
            )?);
        }
        let upload = self.upload.as_mut().expect("created above");
        let mapped =
            upload.mapped().ok_or_else(|| anyhow::anyhow!("the upload memory is not mapped"))?;
        mapped[..rgba.len()].copy_from_slice(rgba);
        Ok(upload.buffer)
    }

    /// Draw and present one frame; `tracer` traces or holds the picture asked for.
    pub(crate) fn draw(
        &mut self,
        tracer: Option<&ComputeTracer>,
        req: &FrameRequest,
    ) -> anyhow::Result<FrameOutcome> {
        let mut outcome = FrameOutcome::default();
        if !self.ensure_swapchain()? {
            return Ok(outcome);
        }
        let f = (self.frame % FRAMES_IN_FLIGHT as u64) as usize;
        let device = self.ctx.device.clone();
        self.wait_for_slot(&device, f, tracer, &mut outcome)?;
        let Some(index) = self.acquire(f)? else {
            return Ok(outcome);
        };
        let ready = tracer.filter(|t| t.is_ready());
        let source = self.picture_source(req.show, ready)?;
        let trace = req.trace.clone().filter(|_| ready.is_some());
        if !req.ui.is_empty() {
            self.wait_for_ui_buffers(&device, f)?;
        }
        let capture = req.capture_window && self.swapchain.transfer_src;
        let extent = self.swapchain.extent;
        if capture {
            self.capture.reserve(&self.ctx, extent)?;
        }

        let cmd = self.begin_frame(&device, f)?;
        if let (Some((frame, band)), Some(t)) = (trace, ready) {
            self.slots[f].timed = t.record(cmd, &frame, &band, Some(f as u32));
            self.slots[f].tag = req.tag;
        }
        self.record_picture_and_ui(&device, cmd, index, source, req, capture)?;
        // SAFETY: recording began in `begin_frame`.
        unsafe { device.end_command_buffer(cmd) }.during("recording a frame")?;
        self.submit_and_present(f, index)?;
        outcome.presented = true;

        if req.capture_window {
            outcome.window_image = Some(if capture {
                // SAFETY: the fence is ours; waiting has no other requirement.
                unsafe { device.wait_for_fences(&[self.slots[f].fence], true, u64::MAX) }
                    .during("waiting for a frame")?;
                self.capture.read(extent, self.swapchain.is_bgra())
            } else {
                Err("this window surface cannot be read back (no TRANSFER_SRC usage)".to_string())
            });
        }
        Ok(outcome)
    }

    /// Wait until slot `f`'s last frame is done, and hand its trace's GPU times (once every
    /// part it traced has its timestamps) to `outcome`.
    fn wait_for_slot(
        &mut self,
        device: &ash::Device,
        f: usize,
        tracer: Option<&ComputeTracer>,
        outcome: &mut FrameOutcome,
    ) -> anyhow::Result<()> {
        // SAFETY: the fence is ours; waiting has no other requirement.
        unsafe { device.wait_for_fences(&[self.slots[f].fence], true, u64::MAX) }
            .during("waiting for a frame")?;
        let timed = std::mem::take(&mut self.slots[f].timed);
        if let (true, Some(t)) = (timed.iter().flatten().any(|&p| p), tracer) {
            outcome.part_ms = t.timer_ms(f as u32, timed);
            // The frame's time once every part it traced has its timestamps.
            outcome.gpu_ms =
                (0..2).filter(|&i| timed[i].contains(&true)).map(|i| outcome.part_ms[i]).sum();
            outcome.tag = Some(self.slots[f].tag);
        }
        Ok(())
    }

    /// The next swapchain image's index, or none when the swapchain is out of date (it is
    /// remade before the next frame).
    fn acquire(&mut self, f: usize) -> anyhow::Result<Option<u32>> {
        Ok(match self.swapchain.acquire(self.slots[f].acquire)? {
            Acquired::OutOfDate => {
                self.swapchain_dirty = true;
                None
            }
            Acquired::Image { index, suboptimal } => {
                self.swapchain_dirty |= suboptimal;
                Some(index)
            }
        })
    }

    /// Where the picture comes from (a buffer, how it was last written, its size), with
    /// the display image made to its size.
    fn picture_source(
        &mut self,
        show: Show,
        ready: Option<&ComputeTracer>,
    ) -> anyhow::Result<Option<PictureSource>> {
        let source = match (show, ready) {
            (Show::Output, Some(t)) => {
                t.colour_output().map(|(b, w, h)| (b, Access::ComputeWrite, [w, h]))
            }
            (Show::Pixels { rgba, width, height }, _) => {
                Some((self.upload_pixels(rgba)?, Access::Nothing, [width, height]))
            }
            _ => None,
        };
        if let Some((_, _, [w, h])) = source {
            self.ensure_display(w, h)?;
        }
        Ok(source)
    }

    /// The UI pass's buffers may still be read by another slot's frame: wait for it.
    fn wait_for_ui_buffers(&mut self, device: &ash::Device, f: usize) -> anyhow::Result<()> {
        if let Some(used_by) = self.ui.claim_buffers(self.frame) {
            let s = (used_by % FRAMES_IN_FLIGHT as u64) as usize;
            if s != f {
                // SAFETY: the fence is ours; waiting has no other requirement.
                unsafe { device.wait_for_fences(&[self.slots[s].fence], true, u64::MAX) }
                    .during("waiting for a frame")?;
            }
        }
        Ok(())
    }

    /// Reset slot `f`'s fence and command buffer and begin recording into it.
    fn begin_frame(&mut self, device: &ash::Device, f: usize) -> anyhow::Result<vk::CommandBuffer> {
        let cmd = self.slots[f].cmd;
        // SAFETY: the slot's fence signalled, so its command buffer is idle and may be reset.
        unsafe {
            device.reset_fences(&[self.slots[f].fence]).during("resetting a fence")?;
            device
                .reset_command_buffer(cmd, vk::CommandBufferResetFlags::empty())
                .during("resetting a command buffer")?;
            device
                .begin_command_buffer(
                    cmd,
                    &vk::CommandBufferBeginInfo::default()
                        .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
                )
                .during("recording a frame")?;
        }
        Ok(cmd)
    }

    /// Record the picture's composite (or a clear), the UI over it, and the swapchain
    /// image's move to presenting (through the capture's copy when the window is read).
    fn record_picture_and_ui(
        &mut self,
        device: &ash::Device,
        cmd: vk::CommandBuffer,
        index: u32,
        source: Option<PictureSource>,
        req: &FrameRequest,
        capture: bool,
    ) -> anyhow::Result<()> {
        let extent = self.swapchain.extent;
        let swap_image = self.swapchain.images[index as usize];
        match (&self.display, source) {
            (Some(display), Some((buffer, access, _))) => composite::record(
                device,
                cmd,
                (buffer, access),
                display,
                swap_image,
                extent,
                req.image_rect,
            ),
            _ => composite::record_clear(device, cmd, swap_image),
        }
        if !req.ui.is_empty() {
            self.ui.record(
                cmd,
                self.swapchain.views[index as usize],
                extent,
                req.pixels_per_point,
                req.ui,
            )?;
        }
        if capture {
            self.capture.record(device, cmd, swap_image, extent);
        } else {
            barrier::record(
                device,
                cmd,
                &[],
                &[],
                &[ImageTransition {
                    image: swap_image,
                    before: Access::ColorAttachment,
                    after: Access::Present,
                    discard: false,
                }],
            );
        }
        Ok(())
    }

    /// Submit slot `f`'s commands (after the image is acquired) and present image `index`
    /// (after they finish).
    fn submit_and_present(&mut self, f: usize, index: u32) -> anyhow::Result<()> {
        let waits = [self.slots[f].acquire];
        let stages =
            [vk::PipelineStageFlags::TRANSFER | vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT];
        let signals = [self.swapchain.render_finished[index as usize]];
        let cmds = [self.slots[f].cmd];
        let submit = [vk::SubmitInfo::default()
            .wait_semaphores(&waits)
            .wait_dst_stage_mask(&stages)
            .command_buffers(&cmds)
            .signal_semaphores(&signals)];
        self.ctx.submit(&submit, self.slots[f].fence)?;
        self.swapchain_dirty |= self.swapchain.present(index)?;
        self.frame += 1;
        Ok(())
    }
}

/// Where a frame's picture comes from: a buffer, how it was last written, its size.
type PictureSource = (vk::Buffer, Access, [u32; 2]);

impl Drop for Presenter {
    fn drop(&mut self) {
        let device = &self.ctx.device;
        // SAFETY: the device is idle before the frame objects are destroyed.
        unsafe {
            let _ = self.ctx.wait_idle();
            for slot in &self.slots {
                device.destroy_fence(slot.fence, None);
                device.destroy_semaphore(slot.acquire, None);
            }
            device.destroy_command_pool(self.pool, None);
        }
    }
}
