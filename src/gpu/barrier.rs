//! Pipeline barriers named by what the commands on either side do (after kajiya's
//! `barrier.rs`): `Access::ComputeWrite -> Access::TransferRead` instead of stage masks,
//! access masks and layouts spelled out at every use, so they are written once, here.
//! Every pipeline barrier of the backend is recorded here, the vendor path's
//! (acceleration-structure builds, the ray tracing pipeline) included.

use ash::vk;

use super::image::color_range;

/// One way a resource is used by the commands before or after a barrier.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Access {
    /// Not used (an image's contents are discarded, or nothing waits on it).
    Nothing,
    /// The swapchain image just acquired: the submission waits for it at the transfer
    /// stage, so the first barrier on it chains from there.
    SwapchainAcquired,
    /// Read by a compute shader.
    ComputeRead,
    /// Written by a compute shader.
    ComputeWrite,
    /// Read by a copy or blit.
    TransferRead,
    /// Written by a copy, blit or clear.
    TransferWrite,
    /// Drawn into as a colour attachment (egui), reading what is there.
    ColorAttachment,
    /// Read by the host after the submission's fence.
    HostRead,
    /// Written by the host (mapped memory) before the submission.
    HostWrite,
    /// A build's inputs (vertices, instances) read by an acceleration-structure build.
    AccelBuildInput,
    /// An acceleration structure read by a build (the top level reads the bottom ones), a
    /// copy or a query of its properties.
    AccelBuildRead,
    /// An acceleration structure written by a build or copy.
    AccelBuildWrite,
    /// An acceleration structure read by ray queries from a compute shader.
    RayQueryAccelRead,
    /// An acceleration structure read by the ray tracing pipeline's shaders.
    RayTracingAccelRead,
    /// Read by the ray tracing pipeline's shaders.
    RayTracingRead,
    /// Written by the ray tracing pipeline's shaders.
    RayTracingWrite,
    /// Handed to the presentation engine.
    Present,
    /// Read as a dispatch's arguments (`vkCmdDispatchIndirect`).
    IndirectRead,
}

impl Access {
    fn stage(self) -> vk::PipelineStageFlags {
        use vk::PipelineStageFlags as S;
        match self {
            Access::Nothing => S::TOP_OF_PIPE,
            Access::SwapchainAcquired | Access::TransferRead | Access::TransferWrite => S::TRANSFER,
            Access::ComputeRead | Access::ComputeWrite | Access::RayQueryAccelRead => {
                S::COMPUTE_SHADER
            }
            Access::ColorAttachment => S::COLOR_ATTACHMENT_OUTPUT,
            Access::HostRead | Access::HostWrite => S::HOST,
            Access::AccelBuildInput | Access::AccelBuildRead | Access::AccelBuildWrite => {
                S::ACCELERATION_STRUCTURE_BUILD_KHR
            }
            Access::RayTracingAccelRead | Access::RayTracingRead | Access::RayTracingWrite => {
                S::RAY_TRACING_SHADER_KHR
            }
            Access::Present => S::BOTTOM_OF_PIPE,
            Access::IndirectRead => S::DRAW_INDIRECT,
        }
    }

    fn access(self) -> vk::AccessFlags {
        use vk::AccessFlags as A;
        match self {
            Access::Nothing | Access::SwapchainAcquired | Access::Present => A::empty(),
            Access::ComputeRead | Access::RayTracingRead | Access::AccelBuildInput => {
                A::SHADER_READ
            }
            Access::ComputeWrite | Access::RayTracingWrite => A::SHADER_WRITE,
            Access::TransferRead => A::TRANSFER_READ,
            Access::TransferWrite => A::TRANSFER_WRITE,
            Access::ColorAttachment => A::COLOR_ATTACHMENT_READ | A::COLOR_ATTACHMENT_WRITE,
            Access::HostRead => A::HOST_READ,
            Access::HostWrite => A::HOST_WRITE,
            Access::AccelBuildRead | Access::RayQueryAccelRead | Access::RayTracingAccelRead => {
                A::ACCELERATION_STRUCTURE_READ_KHR
            }
            Access::AccelBuildWrite => A::ACCELERATION_STRUCTURE_WRITE_KHR,
            Access::IndirectRead => A::INDIRECT_COMMAND_READ,
        }
    }

    /// The image layout this access needs (the vendor path's accesses are of buffers and
    /// structures only: GENERAL).
    fn layout(self) -> vk::ImageLayout {
        use vk::ImageLayout as L;
        match self {
            Access::Nothing | Access::SwapchainAcquired => L::UNDEFINED,
            Access::ComputeRead | Access::ComputeWrite | Access::HostRead | Access::HostWrite => {
                L::GENERAL
            }
            Access::AccelBuildInput | Access::AccelBuildRead | Access::AccelBuildWrite => {
                L::GENERAL
            }
            Access::RayQueryAccelRead
            | Access::RayTracingAccelRead
            | Access::RayTracingRead
            | Access::RayTracingWrite
            | Access::IndirectRead => L::GENERAL,
            Access::TransferRead => L::TRANSFER_SRC_OPTIMAL,
            Access::TransferWrite => L::TRANSFER_DST_OPTIMAL,
            Access::ColorAttachment => L::COLOR_ATTACHMENT_OPTIMAL,
            Access::Present => L::PRESENT_SRC_KHR,
        }
    }
}

fn stages(accesses: &[Access], empty: vk::PipelineStageFlags) -> vk::PipelineStageFlags {
    let s = accesses.iter().fold(vk::PipelineStageFlags::empty(), |s, a| s | a.stage());
    if s.is_empty() {
        empty
    } else {
        s
    }
}

/// Only writes need to be made available; reads before a barrier need only its execution
/// dependency.
fn writes(accesses: &[Access]) -> vk::AccessFlags {
    use vk::AccessFlags as A;
    let write = A::SHADER_WRITE
        | A::TRANSFER_WRITE
        | A::COLOR_ATTACHMENT_WRITE
        | A::HOST_WRITE
        | A::ACCELERATION_STRUCTURE_WRITE_KHR;
    accesses.iter().fold(vk::AccessFlags::empty(), |s, a| s | a.access()) & write
}

fn reads_and_writes(accesses: &[Access]) -> vk::AccessFlags {
    accesses.iter().fold(vk::AccessFlags::empty(), |s, a| s | a.access())
}

/// A layout transition of a whole single-level colour image.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ImageTransition {
    pub image: vk::Image,
    pub before: Access,
    pub after: Access,
    /// The old contents are not needed (transition from UNDEFINED).
    pub discard: bool,
}

/// Record one barrier: buffers (global memory) used as `before` are next used as `after`,
/// and each image of `images` goes through its transition.
pub(crate) fn record(
    device: &ash::Device,
    cmd: vk::CommandBuffer,
    before: &[Access],
    after: &[Access],
    images: &[ImageTransition],
) {
    let mut src = stages(before, vk::PipelineStageFlags::empty());
    let mut dst = stages(after, vk::PipelineStageFlags::empty());
    let image_barriers: Vec<_> = images
        .iter()
        .map(|t| {
            src |= t.before.stage();
            dst |= t.after.stage();
            vk::ImageMemoryBarrier::default()
                .image(t.image)
                .old_layout(if t.discard { vk::ImageLayout::UNDEFINED } else { t.before.layout() })
                .new_layout(t.after.layout())
                .src_access_mask(writes(&[t.before]))
                .dst_access_mask(reads_and_writes(&[t.after]))
                .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                .subresource_range(color_range())
        })
        .collect();
    let memory: Vec<_> = if before.is_empty() && after.is_empty() {
        Vec::new()
    } else {
        vec![vk::MemoryBarrier::default()
            .src_access_mask(writes(before))
            .dst_access_mask(reads_and_writes(after))]
    };
    let src = if src.is_empty() { vk::PipelineStageFlags::TOP_OF_PIPE } else { src };
    let dst = if dst.is_empty() { vk::PipelineStageFlags::BOTTOM_OF_PIPE } else { dst };
    // SAFETY: `cmd` is in the recording state (callers record into their own command
    // buffers) and every image handle is alive for the command buffer's lifetime.
    unsafe {
        device.cmd_pipeline_barrier(
            cmd,
            src,
            dst,
            vk::DependencyFlags::empty(),
            &memory,
            &[],
            &image_barriers,
        )
    };
}

/// Record a global memory barrier between buffer uses.
pub(crate) fn buffers(
    device: &ash::Device,
    cmd: vk::CommandBuffer,
    before: &[Access],
    after: &[Access],
) {
    record(device, cmd, before, after, &[]);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_before_a_barrier_make_nothing_available() {
        assert_eq!(writes(&[Access::TransferRead, Access::ComputeRead]), vk::AccessFlags::empty());
        assert_eq!(
            writes(&[Access::ComputeWrite, Access::TransferRead]),
            vk::AccessFlags::SHADER_WRITE
        );
        assert_eq!(reads_and_writes(&[Access::TransferRead]), vk::AccessFlags::TRANSFER_READ);
    }

    #[test]
    fn stages_and_layouts_follow_the_access() {
        assert_eq!(
            stages(&[Access::ComputeWrite, Access::TransferRead], vk::PipelineStageFlags::empty()),
            vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER
        );
        assert_eq!(Access::Present.layout(), vk::ImageLayout::PRESENT_SRC_KHR);
        assert_eq!(
            Access::SwapchainAcquired.stage(),
            vk::PipelineStageFlags::TRANSFER,
            "chains from the acquire wait"
        );
    }

    /// The vendor path's barriers, named, keep the masks they were first written with.
    #[test]
    fn the_vendor_paths_accesses_keep_their_masks() {
        use vk::AccessFlags as A;
        use vk::PipelineStageFlags as S;
        let masks = |before: &[Access], after: &[Access]| {
            (
                stages(before, S::empty()),
                writes(before),
                stages(after, S::empty()),
                reads_and_writes(after),
            )
        };
        // A build's inputs, uploaded or written by the host.
        assert_eq!(
            masks(
                &[Access::TransferWrite, Access::HostWrite],
                &[Access::AccelBuildInput, Access::AccelBuildRead]
            ),
            (
                S::TRANSFER | S::HOST,
                A::TRANSFER_WRITE | A::HOST_WRITE,
                S::ACCELERATION_STRUCTURE_BUILD_KHR,
                A::ACCELERATION_STRUCTURE_READ_KHR | A::SHADER_READ
            )
        );
        // A build before the query of its compacted size.
        let build = S::ACCELERATION_STRUCTURE_BUILD_KHR;
        assert_eq!(
            masks(&[Access::AccelBuildWrite], &[Access::AccelBuildRead]),
            (build, A::ACCELERATION_STRUCTURE_WRITE_KHR, build, A::ACCELERATION_STRUCTURE_READ_KHR)
        );
        // A built structure, read by later builds and both kinds of trace.
        assert_eq!(
            masks(
                &[Access::AccelBuildWrite],
                &[Access::AccelBuildRead, Access::RayQueryAccelRead, Access::RayTracingAccelRead]
            ),
            (
                build,
                A::ACCELERATION_STRUCTURE_WRITE_KHR,
                build | S::COMPUTE_SHADER | S::RAY_TRACING_SHADER_KHR,
                A::ACCELERATION_STRUCTURE_READ_KHR
            )
        );
        // Around the ray tracing pipeline's launch.
        let rt = S::RAY_TRACING_SHADER_KHR;
        assert_eq!(
            masks(
                &[Access::ComputeWrite, Access::TransferRead],
                &[Access::RayTracingRead, Access::RayTracingWrite]
            ),
            (
                S::COMPUTE_SHADER | S::TRANSFER,
                A::SHADER_WRITE,
                rt,
                A::SHADER_READ | A::SHADER_WRITE
            )
        );
        assert_eq!(
            masks(&[Access::RayTracingWrite], &[Access::ComputeRead, Access::ComputeWrite]),
            (rt, A::SHADER_WRITE, S::COMPUTE_SHADER, A::SHADER_READ | A::SHADER_WRITE)
        );
        // The upload and readback copies.
        assert_eq!(
            masks(&[Access::TransferWrite], &[Access::ComputeRead]),
            (S::TRANSFER, A::TRANSFER_WRITE, S::COMPUTE_SHADER, A::SHADER_READ)
        );
        assert_eq!(
            masks(&[Access::ComputeWrite], &[Access::TransferRead]),
            (S::COMPUTE_SHADER, A::SHADER_WRITE, S::TRANSFER, A::TRANSFER_READ)
        );
        assert_eq!(
            masks(&[Access::TransferWrite], &[Access::HostRead]),
            (S::TRANSFER, A::TRANSFER_WRITE, S::HOST, A::HOST_READ)
        );
    }
}
