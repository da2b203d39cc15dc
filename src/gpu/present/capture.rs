//! Reading the window back as drawn (panel included): the swapchain image is copied into a
//! host-visible buffer at the end of the frame and turned into an RGBA image.

use ash::vk;
use gpu_allocator::MemoryLocation;
use image::RgbaImage;
use std::sync::Arc;

use super::composite::whole_image_copy;
use crate::gpu::barrier::{self, Access, ImageTransition};
use crate::gpu::buffer::GpuBuffer;
use crate::gpu::context::GpuContext;
use crate::gpu::error::GpuError;

/// The readback buffer, grown to the largest window captured.
#[derive(Default)]
pub(crate) struct WindowCapture {
    buffer: Option<GpuBuffer>,
}

impl WindowCapture {
    /// Make room for a `extent` capture.
    pub(crate) fn reserve(
        &mut self,
        ctx: &Arc<GpuContext>,
        extent: vk::Extent2D,
    ) -> Result<(), GpuError> {
        let bytes = extent.width as u64 * extent.height as u64 * 4;
        if self.buffer.as_ref().is_none_or(|b| b.size < bytes) {
            self.buffer = Some(GpuBuffer::new(
                ctx,
                bytes,
                vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuToCpu,
                "window readback",
            )?);
        }
        Ok(())
    }

    /// Forget the buffer (the swapchain was recreated).
    pub(crate) fn clear(&mut self) {
        self.buffer = None;
    }

    /// Record the copy of `swap_image` (drawn as a colour attachment) into the buffer and
    /// its hand-over to the presentation engine. Needs [`Self::reserve`] first.
    pub(crate) fn record(
        &self,
        device: &ash::Device,
        cmd: vk::CommandBuffer,
        swap_image: vk::Image,
        extent: vk::Extent2D,
    ) {
        let Some(buf) = &self.buffer else { return };
        barrier::record(
            device,
            cmd,
            &[],
            &[],
            &[ImageTransition {
                image: swap_image,
                before: Access::ColorAttachment,
                after: Access::TransferRead,
                discard: false,
            }],
        );
        // SAFETY: `cmd` is recording, the image is in TRANSFER_SRC layout and the buffer
        // holds at least `extent` texels (reserve).
        unsafe {
            device.cmd_copy_image_to_buffer(
                cmd,
                swap_image,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                buf.buffer,
                &[whole_image_copy(extent.width, extent.height)],
            )
        };
        barrier::record(
            device,
            cmd,
            &[Access::TransferWrite],
            &[Access::HostRead],
            &[ImageTransition {
                image: swap_image,
                before: Access::TransferRead,
                after: Access::Present,
                discard: false,
            }],
        );
    }

    /// The captured window, after the frame's fence signalled.
    pub(crate) fn read(&mut self, extent: vk::Extent2D, bgra: bool) -> Result<RgbaImage, String> {
        let len = extent.width as usize * extent.height as usize * 4;
        let bytes = self
            .buffer
            .as_mut()
            .and_then(|b| b.mapped())
            .ok_or("the window readback memory is not mapped")?[..len]
            .to_vec();
        window_image(bytes, extent.width, extent.height, bgra)
            .ok_or_else(|| "the window readback has the wrong size".to_string())
    }
}

/// Turn a window readback (tightly packed, BGRA when `bgra`) into an opaque RGBA image.
pub(crate) fn window_image(
    mut bytes: Vec<u8>,
    width: u32,
    height: u32,
    bgra: bool,
) -> Option<RgbaImage> {
    bytes.truncate(width as usize * height as usize * 4);
    for px in bytes.chunks_exact_mut(4) {
        if bgra {
            px.swap(0, 2);
        }
        px[3] = 255;
    }
    RgbaImage::from_raw(width, height, bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bgra_readback_is_swapped_and_opaque() {
        let img = window_image(vec![1, 2, 3, 0, 4, 5, 6, 7], 2, 1, true).unwrap();
        assert_eq!(img.get_pixel(0, 0).0, [3, 2, 1, 255]);
        assert_eq!(img.get_pixel(1, 0).0, [6, 5, 4, 255]);
    }
}
