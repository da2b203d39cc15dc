//! The surface and its swapchain, with a view and a render-finished semaphore per image.
//!
//! One render-finished semaphore per swapchain *image*, not per frame in flight: a
//! semaphore waited on by a present can only be reused once that image is acquired again,
//! which is exactly when its index comes back.

use std::sync::Arc;

use crate::gpu::context::GpuContext;
use crate::gpu::error::{GpuError, VkContext};
use crate::gpu::image::color_range;
use ash::vk;

/// Surface formats the traced pixels can be copied into unchanged (no sRGB encode).
pub(crate) const UNORM_FORMATS: [vk::Format; 2] =
    [vk::Format::B8G8R8A8_UNORM, vk::Format::R8G8B8A8_UNORM];

/// What `acquire` found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Acquired {
    /// An image to draw into; `suboptimal` asks for a recreate after presenting.
    Image { index: u32, suboptimal: bool },
    /// The swapchain no longer matches the surface: recreate it and try again.
    OutOfDate,
}

/// A surface and its swapchain.
pub(crate) struct Swapchain {
    ctx: Arc<GpuContext>,
    surface_loader: ash::khr::surface::Instance,
    loader: ash::khr::swapchain::Device,
    surface: vk::SurfaceKHR,
    handle: vk::SwapchainKHR,
    pub format: vk::SurfaceFormatKHR,
    pub extent: vk::Extent2D,
    pub present_mode: vk::PresentModeKHR,
    /// Present modes the surface offers.
    pub present_modes: Vec<vk::PresentModeKHR>,
    pub images: Vec<vk::Image>,
    pub views: Vec<vk::ImageView>,
    /// Signalled by the frame that draws image `i`, waited on by its present.
    pub render_finished: Vec<vk::Semaphore>,
    /// The images can be copied from (window screenshots).
    pub transfer_src: bool,
}

/// FIFO for vsync; otherwise MAILBOX, then IMMEDIATE, where offered.
pub(crate) fn choose_present_mode(
    available: &[vk::PresentModeKHR],
    vsync: bool,
) -> vk::PresentModeKHR {
    if !vsync {
        for mode in [vk::PresentModeKHR::MAILBOX, vk::PresentModeKHR::IMMEDIATE] {
            if available.contains(&mode) {
                return mode;
            }
        }
    }
    vk::PresentModeKHR::FIFO
}

/// A UNORM 8-bit format if offered (traced pixels then land unchanged), else the first one.
pub(crate) fn choose_format(available: &[vk::SurfaceFormatKHR]) -> Option<vk::SurfaceFormatKHR> {
    UNORM_FORMATS
        .iter()
        .find_map(|f| {
            available
                .iter()
                .find(|a| a.format == *f && a.color_space == vk::ColorSpaceKHR::SRGB_NONLINEAR)
        })
        .or_else(|| available.first())
        .copied()
}

impl Swapchain {
    /// Take ownership of `surface` (destroyed with the swapchain, also on error) and create
    /// a swapchain of about `extent` pixels.
    pub(crate) fn new(
        ctx: &Arc<GpuContext>,
        surface: vk::SurfaceKHR,
        extent: vk::Extent2D,
        vsync: bool,
    ) -> Result<Self, GpuError> {
        let mut s = Self {
            ctx: ctx.clone(),
            surface_loader: ash::khr::surface::Instance::new(&ctx.entry, &ctx.instance),
            loader: ash::khr::swapchain::Device::new(&ctx.instance, &ctx.device),
            surface,
            handle: vk::SwapchainKHR::null(),
            format: vk::SurfaceFormatKHR::default(),
            extent: vk::Extent2D::default(),
            present_mode: vk::PresentModeKHR::FIFO,
            present_modes: Vec::new(),
            images: Vec::new(),
            views: Vec::new(),
            render_finished: Vec::new(),
            transfer_src: false,
        };
        s.recreate(extent, vsync)?;
        Ok(s)
    }

    /// True when the swapchain exists (the window had a non-zero size when last (re)created).
    pub(crate) fn is_usable(&self) -> bool {
        self.handle != vk::SwapchainKHR::null()
    }

    /// True for B8G8R8A8 formats (window screenshots swap red and blue).
    pub(crate) fn is_bgra(&self) -> bool {
        matches!(self.format.format, vk::Format::B8G8R8A8_UNORM | vk::Format::B8G8R8A8_SRGB)
    }

    /// Rebuild for the window's current size and the wanted present mode. The GPU must be
    /// idle. Returns false (and leaves no swapchain) when the surface has zero extent
    /// (a minimized window): skip drawing until the next resize.
    pub(crate) fn recreate(&mut self, want: vk::Extent2D, vsync: bool) -> Result<bool, GpuError> {
        let (caps, formats) = self.query_surface()?;
        let extent = fit_extent(&caps, want);
        if extent.width == 0 || extent.height == 0 {
            self.destroy_swapchain();
            return Ok(false);
        }
        let format = choose_format(&formats).ok_or(GpuError::Vulkan {
            what: "choosing a window format",
            result: vk::Result::ERROR_FORMAT_NOT_SUPPORTED,
        })?;
        let present_mode = choose_present_mode(&self.present_modes, vsync);
        self.transfer_src = caps.supported_usage_flags.contains(vk::ImageUsageFlags::TRANSFER_SRC);
        let mut usage = vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_DST;
        if self.transfer_src {
            usage |= vk::ImageUsageFlags::TRANSFER_SRC;
        }
        let info = vk::SwapchainCreateInfoKHR::default()
            .surface(self.surface)
            .min_image_count(image_count(&caps))
            .image_format(format.format)
            .image_color_space(format.color_space)
            .image_extent(extent)
            .image_array_layers(1)
            .image_usage(usage)
            .image_sharing_mode(vk::SharingMode::EXCLUSIVE)
            .pre_transform(pre_transform(&caps))
            .composite_alpha(composite_alpha(&caps))
            .present_mode(present_mode)
            .clipped(true)
            .old_swapchain(self.handle);
        // SAFETY: the create info's surface is ours and the old swapchain it names is live
        // (retired here).
        let handle = unsafe { self.loader.create_swapchain(&info, None) }
            .during("creating the swapchain")?;
        // The old swapchain goes only now: the new one was made from it.
        self.destroy_swapchain();
        self.handle = handle;
        self.format = format;
        self.extent = extent;
        self.present_mode = present_mode;
        // SAFETY: the swapchain was just created.
        self.images = unsafe { self.loader.get_swapchain_images(handle) }
            .during("listing the swapchain images")?;
        self.make_views_and_semaphores()?;
        Ok(true)
    }

    /// The surface's capabilities and formats; its present modes go to `present_modes`.
    fn query_surface(
        &mut self,
    ) -> Result<(vk::SurfaceCapabilitiesKHR, Vec<vk::SurfaceFormatKHR>), GpuError> {
        let pd = self.ctx.physical_device;
        // SAFETY: the surface and the physical device belong to this context's instance.
        let caps = unsafe {
            self.surface_loader.get_physical_device_surface_capabilities(pd, self.surface)
        }
        .during("querying the window surface")?;
        // SAFETY: as above.
        let formats =
            unsafe { self.surface_loader.get_physical_device_surface_formats(pd, self.surface) }
                .during("querying the window surface formats")?;
        // SAFETY: as above.
        self.present_modes = unsafe {
            self.surface_loader.get_physical_device_surface_present_modes(pd, self.surface)
        }
        .during("querying the present modes")?;
        Ok((caps, formats))
    }

    /// A view per swapchain image, and a render-finished semaphore per image.
    fn make_views_and_semaphores(&mut self) -> Result<(), GpuError> {
        let device = &self.ctx.device;
        for &image in &self.images {
            let view_info = vk::ImageViewCreateInfo::default()
                .image(image)
                .view_type(vk::ImageViewType::TYPE_2D)
                .format(self.format.format)
                .subresource_range(color_range());
            // SAFETY: the image belongs to the live swapchain; its views are destroyed
            // before it.
            let view = unsafe { device.create_image_view(&view_info, None) }
                .during("creating a swapchain image view")?;
            self.views.push(view);
        }
        // Semaphores are kept across recreations (a present may still wait on one); only
        // add what a larger image count needs.
        while self.render_finished.len() < self.images.len() {
            // SAFETY: plain object creation on the live device; destroyed in Drop.
            let sem = unsafe { device.create_semaphore(&vk::SemaphoreCreateInfo::default(), None) }
                .during("creating a semaphore")?;
            self.render_finished.push(sem);
        }
        Ok(())
    }

    fn destroy_swapchain(&mut self) {
        // SAFETY: callers have the GPU idle (recreate requires it, Drop waits), so no view
        // or image is in use; the views go before their swapchain.
        unsafe {
            for view in self.views.drain(..) {
                self.ctx.device.destroy_image_view(view, None);
            }
            if self.handle != vk::SwapchainKHR::null() {
                self.loader.destroy_swapchain(self.handle, None);
            }
        }
        self.handle = vk::SwapchainKHR::null();
        self.images.clear();
    }

    /// Acquire the next image, signalling `semaphore` when it may be written.
    pub(crate) fn acquire(&self, semaphore: vk::Semaphore) -> Result<Acquired, GpuError> {
        // SAFETY: `Presenter::draw` acquires only from a usable swapchain, with its frame
        // slot's
        // semaphore, unsignalled once the slot's fence has been waited for.
        match unsafe {
            self.loader.acquire_next_image(self.handle, u64::MAX, semaphore, vk::Fence::null())
        } {
            Ok((index, suboptimal)) => Ok(Acquired::Image { index, suboptimal }),
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => Ok(Acquired::OutOfDate),
            Err(r) => Err(GpuError::vk("acquiring a swapchain image", r)),
        }
    }

    /// Present image `index` once its render-finished semaphore is signalled. Returns true
    /// when the swapchain should be recreated (out of date or suboptimal).
    pub(crate) fn present(&self, index: u32) -> Result<bool, GpuError> {
        let waits = [self.render_finished[index as usize]];
        let swapchains = [self.handle];
        let indices = [index];
        let info = vk::PresentInfoKHR::default()
            .wait_semaphores(&waits)
            .swapchains(&swapchains)
            .image_indices(&indices);
        let presented = {
            let _queue = self.ctx.lock_queue();
            // SAFETY: the queue lock is held; the info's swapchain, image index and
            // semaphore are live.
            unsafe { self.loader.queue_present(self.ctx.queue, &info) }
        };
        match presented {
            Ok(suboptimal) => Ok(suboptimal),
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => Ok(true),
            Err(r) => Err(GpuError::vk("presenting a frame", r)),
        }
    }
}

impl Drop for Swapchain {
    fn drop(&mut self) {
        // SAFETY: after waiting for the GPU nothing uses the swapchain, its semaphores or
        // the surface; the surface goes last.
        unsafe {
            let _ = self.ctx.wait_idle();
            self.destroy_swapchain();
            for sem in self.render_finished.drain(..) {
                self.ctx.device.destroy_semaphore(sem, None);
            }
            self.surface_loader.destroy_surface(self.surface, None);
        }
    }
}

/// The surface's own extent, or `want` within its limits where the surface leaves it to
/// the swapchain.
fn fit_extent(caps: &vk::SurfaceCapabilitiesKHR, want: vk::Extent2D) -> vk::Extent2D {
    if caps.current_extent.width == u32::MAX {
        vk::Extent2D {
            width: want.width.clamp(caps.min_image_extent.width, caps.max_image_extent.width),
            height: want.height.clamp(caps.min_image_extent.height, caps.max_image_extent.height),
        }
    } else {
        caps.current_extent
    }
}

/// One image more than the least, within the most.
fn image_count(caps: &vk::SurfaceCapabilitiesKHR) -> u32 {
    let mut image_count = caps.min_image_count + 1;
    if caps.max_image_count > 0 {
        image_count = image_count.min(caps.max_image_count);
    }
    image_count
}

/// Opaque where offered, else the first mode the surface has.
fn composite_alpha(caps: &vk::SurfaceCapabilitiesKHR) -> vk::CompositeAlphaFlagsKHR {
    [
        vk::CompositeAlphaFlagsKHR::OPAQUE,
        vk::CompositeAlphaFlagsKHR::INHERIT,
        vk::CompositeAlphaFlagsKHR::PRE_MULTIPLIED,
        vk::CompositeAlphaFlagsKHR::POST_MULTIPLIED,
    ]
    .into_iter()
    .find(|c| caps.supported_composite_alpha.contains(*c))
    .unwrap_or(vk::CompositeAlphaFlagsKHR::OPAQUE)
}

/// No transform where offered, else the surface's current one.
fn pre_transform(caps: &vk::SurfaceCapabilitiesKHR) -> vk::SurfaceTransformFlagsKHR {
    if caps.supported_transforms.contains(vk::SurfaceTransformFlagsKHR::IDENTITY) {
        vk::SurfaceTransformFlagsKHR::IDENTITY
    } else {
        caps.current_transform
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn present_mode_prefers_mailbox_then_immediate_without_vsync() {
        use vk::PresentModeKHR as P;
        assert_eq!(choose_present_mode(&[P::FIFO, P::IMMEDIATE, P::MAILBOX], true), P::FIFO);
        assert_eq!(choose_present_mode(&[P::FIFO, P::IMMEDIATE, P::MAILBOX], false), P::MAILBOX);
        assert_eq!(choose_present_mode(&[P::FIFO, P::IMMEDIATE], false), P::IMMEDIATE);
        assert_eq!(choose_present_mode(&[P::FIFO], false), P::FIFO);
    }

    #[test]
    fn format_prefers_unorm() {
        let f = |format| vk::SurfaceFormatKHR {
            format,
            color_space: vk::ColorSpaceKHR::SRGB_NONLINEAR,
        };
        let chosen =
            choose_format(&[f(vk::Format::B8G8R8A8_SRGB), f(vk::Format::B8G8R8A8_UNORM)]).unwrap();
        assert_eq!(chosen.format, vk::Format::B8G8R8A8_UNORM);
        assert_eq!(
            choose_format(&[f(vk::Format::A2B10G10R10_UNORM_PACK32)]).unwrap().format,
            vk::Format::A2B10G10R10_UNORM_PACK32
        );
        assert!(choose_format(&[]).is_none());
    }
}
