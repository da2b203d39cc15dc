//! [`GpuImage`], a device-local 2D image (the traced picture on its way to the screen),
//! and the subresource helpers of single-level colour images.

use std::sync::Arc;

use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;

use super::context::GpuContext;
use super::error::{GpuError, VkContext};

/// The whole colour subresource of a single-level 2D image.
pub(crate) fn color_range() -> vk::ImageSubresourceRange {
    vk::ImageSubresourceRange {
        aspect_mask: vk::ImageAspectFlags::COLOR,
        base_mip_level: 0,
        level_count: 1,
        base_array_layer: 0,
        layer_count: 1,
    }
}

/// The colour layer of a single-level 2D image, for copies and blits.
pub(crate) fn color_layers() -> vk::ImageSubresourceLayers {
    vk::ImageSubresourceLayers {
        aspect_mask: vk::ImageAspectFlags::COLOR,
        mip_level: 0,
        base_array_layer: 0,
        layer_count: 1,
    }
}

/// A device-local 2D image with one mip level; freed on drop.
pub(crate) struct GpuImage {
    ctx: Arc<GpuContext>,
    pub image: vk::Image,
    allocation: Option<Allocation>,
    pub width: u32,
    pub height: u32,
}

impl GpuImage {
    /// Create a `width` x `height` image of `format` with optimal tiling.
    pub(crate) fn new(
        ctx: &Arc<GpuContext>,
        width: u32,
        height: u32,
        format: vk::Format,
        usage: vk::ImageUsageFlags,
        name: &'static str,
    ) -> Result<Self, GpuError> {
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D { width, height, depth: 1 })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        let device = &ctx.device;
        // SAFETY: the create info outlives the call; the image is destroyed in Drop or on
        // the error paths below.
        let image = unsafe { device.create_image(&info, None) }.during("creating an image")?;
        // SAFETY: the image was just created on this device.
        let requirements = unsafe { device.get_image_memory_requirements(image) };
        let allocation = ctx.allocator().allocate(&AllocationCreateDesc {
            name,
            requirements,
            location: MemoryLocation::GpuOnly,
            linear: false,
            allocation_scheme: AllocationScheme::GpuAllocatorManaged,
        });
        let allocation = match allocation {
            Ok(a) => a,
            Err(source) => {
                // SAFETY: the image has no memory and nothing uses it.
                unsafe { device.destroy_image(image, None) };
                return Err(GpuError::Allocation { what: name, source });
            }
        };
        // SAFETY: the allocation is fresh and meets the image's size and alignment
        // requirements.
        if let Err(r) =
            unsafe { device.bind_image_memory(image, allocation.memory(), allocation.offset()) }
        {
            let _ = ctx.allocator().free(allocation);
            // SAFETY: binding failed, so nothing uses the image; its allocation was freed
            // above.
            unsafe { device.destroy_image(image, None) };
            return Err(GpuError::vk("binding image memory", r));
        }
        Ok(Self { ctx: ctx.clone(), image, allocation: Some(allocation), width, height })
    }
}

impl Drop for GpuImage {
    fn drop(&mut self) {
        if let Some(a) = self.allocation.take() {
            let _ = self.ctx.allocator().free(a);
        }
        // SAFETY: the owner drops the image only after waiting for the GPU (`Presenter`
        // waits for idle first).
        unsafe { self.ctx.device.destroy_image(self.image, None) };
    }
}
