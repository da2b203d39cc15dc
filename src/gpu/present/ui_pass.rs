//! The egui pass: egui's tessellated output drawn over the composite with dynamic
//! rendering (egui-ash-renderer), and egui's texture uploads.

use std::sync::Arc;

use anyhow::Context as _;
use ash::vk;
use egui::{ClippedPrimitive, TextureId, TexturesDelta};
use egui_ash_renderer::allocator::DefaultAllocator;
use egui_ash_renderer::{DynamicRendering, Options, RenderMode};

use super::FRAMES_IN_FLIGHT;
use crate::gpu::context::GpuContext;
use crate::gpu::error::VkContext;

/// egui's renderer and what it needs to reuse its per-frame vertex buffers safely.
pub(crate) struct UiPass {
    egui: egui_ash_renderer::Renderer<DefaultAllocator>,
    format: vk::Format,
    /// Frame number that last used each of egui's per-frame vertex buffers.
    mesh_frame: [Option<u64>; FRAMES_IN_FLIGHT],
    draws: u64,
    pending_free: Vec<TextureId>,
    upload_pool: vk::CommandPool,
    ctx: Arc<GpuContext>,
}

fn render_mode(format: vk::Format) -> RenderMode {
    RenderMode::DynamicRendering(DynamicRendering {
        color_attachment_format: format,
        depth_attachment_format: None,
        stencil_attachment_format: None,
    })
}

impl UiPass {
    /// egui drawing into images of `format`.
    pub(crate) fn new(ctx: &Arc<GpuContext>, format: vk::Format) -> anyhow::Result<Self> {
        let egui = egui_ash_renderer::Renderer::with_default_allocator(
            &ctx.instance,
            ctx.physical_device,
            ctx.device.clone(),
            render_mode(format),
            // UNORM target: egui's shader encodes its output to sRGB itself.
            Options {
                in_flight_frames: FRAMES_IN_FLIGHT,
                srgb_framebuffer: false,
                ..Default::default()
            },
        )
        .context("creating the egui renderer")?;
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(ctx.queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        // SAFETY: plain object creation on a live device; destroyed in Drop.
        let upload_pool = unsafe { ctx.device.create_command_pool(&pool_info, None) }
            .during("creating the upload command pool")?;
        Ok(Self {
            egui,
            format,
            mesh_frame: [None; FRAMES_IN_FLIGHT],
            draws: 0,
            pending_free: Vec::new(),
            upload_pool,
            ctx: ctx.clone(),
        })
    }

    /// Draw into images of `format` from now on (the swapchain's format changed).
    pub(crate) fn set_format(&mut self, format: vk::Format) -> anyhow::Result<()> {
        if format != self.format {
            self.format = format;
            self.egui
                .set_render_mode(render_mode(format))
                .context("rebuilding the egui pipeline")?;
        }
        Ok(())
    }

    /// Apply egui's texture changes (before drawing the frame that uses them); the delta
    /// is emptied even on failure.
    pub(crate) fn update_textures(&mut self, delta: &mut TexturesDelta) -> anyhow::Result<()> {
        let set: Vec<_> = delta.set.drain().collect();
        let free: Vec<_> = delta.free.drain().collect();
        if !self.pending_free.is_empty() || !set.is_empty() {
            // Rare (font atlas changes): wait rather than track which frame uses what.
            self.ctx.wait_idle()?;
        }
        for id in std::mem::take(&mut self.pending_free) {
            self.egui.free_texture(id).context("freeing egui textures")?;
        }
        for (id, deltas) in set {
            for image_delta in &deltas {
                self.egui
                    .set_texture(self.ctx.queue, self.upload_pool, id, image_delta)
                    .context("uploading egui textures")?;
            }
        }
        self.pending_free.extend(free);
        Ok(())
    }

    /// egui rotates its vertex buffers per draw call: the frame number whose slot must be
    /// finished before frame `frame` draws, if any (a different slot than `frame`'s own).
    pub(crate) fn claim_buffers(&mut self, frame: u64) -> Option<u64> {
        let k = (self.draws % FRAMES_IN_FLIGHT as u64) as usize;
        let previous = self.mesh_frame[k].replace(frame);
        self.draws += 1;
        previous
    }

    /// Record egui's draw into `view` (COLOR_ATTACHMENT_OPTIMAL) of size `extent`.
    pub(crate) fn record(
        &mut self,
        cmd: vk::CommandBuffer,
        view: vk::ImageView,
        extent: vk::Extent2D,
        pixels_per_point: f32,
        ui: &[ClippedPrimitive],
    ) -> anyhow::Result<()> {
        let attachment = [vk::RenderingAttachmentInfo::default()
            .image_view(view)
            .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
            .load_op(vk::AttachmentLoadOp::LOAD)
            .store_op(vk::AttachmentStoreOp::STORE)];
        let info = vk::RenderingInfo::default()
            .render_area(vk::Rect2D { offset: vk::Offset2D::default(), extent })
            .layer_count(1)
            .color_attachments(&attachment);
        // SAFETY: `cmd` is recording and the view's image is a colour attachment now.
        unsafe { self.ctx.device.cmd_begin_rendering(cmd, &info) };
        let drawn = self.egui.cmd_draw(cmd, extent, pixels_per_point, ui);
        // SAFETY: closes the rendering begun above.
        unsafe { self.ctx.device.cmd_end_rendering(cmd) };
        drawn.context("drawing the panel")
    }
}

impl Drop for UiPass {
    fn drop(&mut self) {
        // SAFETY: the presenter waits for the device to be idle before dropping its passes.
        unsafe { self.ctx.device.destroy_command_pool(self.upload_pool, None) };
    }
}
