//! The composite pass: the traced picture (packed RGBA8 in a buffer) is copied into the
//! display image and blitted, letterboxed, into the swapchain image, which is cleared
//! around it and left ready for the egui pass as a colour attachment.

use ash::vk;

use crate::gpu::barrier::{self, Access, ImageTransition};
use crate::gpu::image::{color_layers, GpuImage};

/// The letterbox colour around the traced image.
const CLEAR: [f32; 4] = [0.06, 0.06, 0.07, 1.0];

/// A rectangle in physical pixels: x, y of the top-left corner, width, height.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct PixelRect {
    pub x: i32,
    pub y: i32,
    pub width: u32,
    pub height: u32,
}

/// A copy between a tightly packed buffer and a whole `width` x `height` colour image.
pub(crate) fn whole_image_copy(width: u32, height: u32) -> vk::BufferImageCopy {
    vk::BufferImageCopy {
        buffer_offset: 0,
        buffer_row_length: 0,
        buffer_image_height: 0,
        image_subresource: color_layers(),
        image_offset: vk::Offset3D::default(),
        image_extent: vk::Extent3D { width, height, depth: 1 },
    }
}

/// The blit from the display image to the part of `rect` inside the swapchain's `extent`
/// (source coordinates scaled to match), or None when nothing of it is on screen.
fn clipped_blit(display: [u32; 2], rect: PixelRect, extent: vk::Extent2D) -> Option<vk::ImageBlit> {
    let x0 = rect.x.clamp(0, extent.width as i32);
    let y0 = rect.y.clamp(0, extent.height as i32);
    let x1 = (rect.x + rect.width as i32).clamp(0, extent.width as i32);
    let y1 = (rect.y + rect.height as i32).clamp(0, extent.height as i32);
    if x1 <= x0 || y1 <= y0 {
        return None;
    }
    let sx = display[0] as f64 / rect.width.max(1) as f64;
    let sy = display[1] as f64 / rect.height.max(1) as f64;
    let src0 =
        [((x0 - rect.x) as f64 * sx).round() as i32, ((y0 - rect.y) as f64 * sy).round() as i32];
    let src1 =
        [((x1 - rect.x) as f64 * sx).round() as i32, ((y1 - rect.y) as f64 * sy).round() as i32];
    Some(vk::ImageBlit {
        src_subresource: color_layers(),
        src_offsets: [
            vk::Offset3D { x: src0[0], y: src0[1], z: 0 },
            vk::Offset3D {
                x: src1[0].min(display[0] as i32),
                y: src1[1].min(display[1] as i32),
                z: 1,
            },
        ],
        dst_subresource: color_layers(),
        dst_offsets: [vk::Offset3D { x: x0, y: y0, z: 0 }, vk::Offset3D { x: x1, y: y1, z: 1 }],
    })
}

fn acquired(swap_image: vk::Image) -> ImageTransition {
    ImageTransition {
        image: swap_image,
        before: Access::SwapchainAcquired,
        after: Access::TransferWrite,
        discard: true,
    }
}

/// Record a frame with no picture: the swapchain image is cleared, ready for egui.
pub(crate) fn record_clear(device: &ash::Device, cmd: vk::CommandBuffer, swap_image: vk::Image) {
    barrier::record(device, cmd, &[], &[], &[acquired(swap_image)]);
    clear(device, cmd, swap_image);
    to_attachment(device, cmd, swap_image);
}

/// Record the composite: `source` (packed RGBA8 the size of `display`, last written as
/// `source_access`) goes through `display` into `rect` of `swap_image`.
pub(crate) fn record(
    device: &ash::Device,
    cmd: vk::CommandBuffer,
    source: (vk::Buffer, Access),
    display: &GpuImage,
    swap_image: vk::Image,
    extent: vk::Extent2D,
    rect: PixelRect,
) {
    let (buffer, source_access) = source;
    let acquired = acquired(swap_image);
    let display_dst = ImageTransition {
        image: display.image,
        before: Access::Nothing,
        after: Access::TransferWrite,
        discard: true,
    };
    barrier::record(
        device,
        cmd,
        &[source_access],
        &[Access::TransferRead],
        &[acquired, display_dst],
    );
    clear(device, cmd, swap_image);
    // SAFETY: `cmd` is recording; the buffer holds width x height packed RGBA8 texels and
    // the display image is in TRANSFER_DST layout after the barrier above.
    unsafe {
        device.cmd_copy_buffer_to_image(
            cmd,
            buffer,
            display.image,
            vk::ImageLayout::TRANSFER_DST_OPTIMAL,
            &[whole_image_copy(display.width, display.height)],
        );
    }
    barrier::record(
        device,
        cmd,
        &[],
        &[],
        &[
            ImageTransition {
                image: display.image,
                before: Access::TransferWrite,
                after: Access::TransferRead,
                discard: false,
            },
            // The clear and the blit both write the swapchain image.
            ImageTransition {
                image: swap_image,
                before: Access::TransferWrite,
                after: Access::TransferWrite,
                discard: false,
            },
        ],
    );
    if let Some(blit) = clipped_blit([display.width, display.height], rect, extent) {
        // Magnified pixels stay sharp; minified ones are filtered.
        let filter =
            if rect.width >= display.width { vk::Filter::NEAREST } else { vk::Filter::LINEAR };
        // SAFETY: both images are in the layouts the barriers above put them in.
        unsafe {
            device.cmd_blit_image(
                cmd,
                display.image,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                swap_image,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &[blit],
                filter,
            );
        }
    }
    to_attachment(device, cmd, swap_image);
}

fn clear(device: &ash::Device, cmd: vk::CommandBuffer, swap_image: vk::Image) {
    // SAFETY: the swapchain image is in TRANSFER_DST layout (the caller's barrier).
    unsafe {
        device.cmd_clear_color_image(
            cmd,
            swap_image,
            vk::ImageLayout::TRANSFER_DST_OPTIMAL,
            &vk::ClearColorValue { float32: CLEAR },
            &[crate::gpu::image::color_range()],
        );
    }
}

fn to_attachment(device: &ash::Device, cmd: vk::CommandBuffer, swap_image: vk::Image) {
    barrier::record(
        device,
        cmd,
        &[],
        &[],
        &[ImageTransition {
            image: swap_image,
            before: Access::TransferWrite,
            after: Access::ColorAttachment,
            discard: false,
        }],
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blits_are_clipped_to_the_swapchain() {
        let extent = vk::Extent2D { width: 100, height: 100 };
        let inside =
            clipped_blit([50, 50], PixelRect { x: 0, y: 0, width: 100, height: 100 }, extent)
                .unwrap();
        assert_eq!(inside.src_offsets[1], vk::Offset3D { x: 50, y: 50, z: 1 });
        // Half off the right edge: half the source is drawn.
        let half =
            clipped_blit([50, 50], PixelRect { x: 50, y: 0, width: 100, height: 100 }, extent)
                .unwrap();
        assert_eq!(half.dst_offsets[1].x, 100);
        assert_eq!(half.src_offsets[1].x, 25);
        assert!(clipped_blit([50, 50], PixelRect { x: 200, y: 0, width: 10, height: 10 }, extent)
            .is_none());
    }
}
