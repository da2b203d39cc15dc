//! Reading back what the GPU made: the last frame's float output and 8-bit colour, and the
//! trees it built.

use super::ComputeTracer;
use crate::gpu::error::GpuError;
use crate::gpu::trace_pass::TraceOutput;
use crate::tracer::image::Image;
use crate::tracer::PackedScene;

impl ComputeTracer {
    fn traced_output(&self) -> Result<&TraceOutput, GpuError> {
        self.ctx.wait_idle()?;
        self.output.as_ref().ok_or(GpuError::NotReady("nothing has been traced yet"))
    }

    /// Read the float output of the last frame.
    pub fn read_image(&self) -> Result<Image, GpuError> {
        let out = self.traced_output()?;
        let bytes = out.float.download(out.width as u64 * out.height as u64 * 16)?;
        let floats: &[f32] = bytemuck::cast_slice(&bytes);
        Ok(Image {
            width: out.width,
            height: out.height,
            pixels: floats.chunks_exact(4).map(|c| [c[0], c[1], c[2], c[3]]).collect(),
        })
    }

    /// Read the 8-bit colour output of the last frame (RGBA bytes, row 0 at the top).
    pub(crate) fn read_rgba8(&self) -> Result<image::RgbaImage, GpuError> {
        let out = self.traced_output()?;
        let bytes = out.rgba8.download(out.width as u64 * out.height as u64 * 4)?;
        image::RgbaImage::from_raw(out.width, out.height, bytes)
            .ok_or(GpuError::NotReady("the colour readback has the wrong size"))
    }

    /// Read the trees the device built for the scene uploaded from `packed` back into it
    /// ([`SceneBuffers::read_back_device_builds`](super::scene_buffers::SceneBuffers)), so
    /// that the CPU tracer walks the same trees; nothing to do where none was built there.
    pub fn read_back_device_builds(&self, packed: &mut PackedScene) -> Result<(), GpuError> {
        self.ctx.wait_idle()?;
        let scene = self.scene.as_ref().ok_or(GpuError::NotReady("no scene is uploaded"))?;
        scene.read_back_device_builds(packed)
    }
}
