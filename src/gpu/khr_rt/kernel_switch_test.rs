//! A kernel switch while a frame is in flight (the window's case, #30): the new kernel's
//! pass is made and both passes' sets rebound only once the GPU is done with the old one.

use crate::gpu::dispatch::Band;
use crate::gpu::khr_rt::VendorKernel;
use crate::gpu::{ComputeTracer, ContextOptions, FrameTrace, GpuContext};
use crate::render_settings::{Accel, RenderSettings};
use crate::scene::paper::{paper_scene, prepare_mesh, LightOrbit};
use crate::scene::primitives::PaperModel;
use crate::tracer::{FrameParams, PackedScene};

#[test]
fn switching_kernels_with_a_frame_in_flight_writes_no_set_in_use() {
    let ctx =
        GpuContext::new(&ContextOptions::validated()).expect("Vulkan with the validation layer");
    let support = &ctx.info.vendor;
    assert!(
        VendorKernel::Query.supported(support) && VendorKernel::Pipeline.supported(support),
        "the test needs a device with both kernels (lavapipe from Mesa 25 has them): {}",
        ctx.info.name
    );
    let mut mesh = PaperModel::Geosphere.mesh();
    prepare_mesh(&mut mesh);
    let scene = paper_scene(mesh, 1, LightOrbit::default());
    let packed = PackedScene::new(&scene);
    let mut tracer = ComputeTracer::with_scene(&ctx, &packed).unwrap();
    let settings =
        RenderSettings { width: 64, height: 32, accel: Accel::Vendor, ..Default::default() };
    let frame = FrameTrace::whole(FrameParams::new(&scene, settings));
    tracer.set_vendor_kernel(VendorKernel::Query).unwrap();
    tracer.trace(&frame.params).unwrap();

    // A frame recorded and submitted as the window does, not waited for.
    let device = &ctx.device;
    let pool_info = ash::vk::CommandPoolCreateInfo::default().queue_family_index(ctx.queue_family);
    // SAFETY: the pool, its command buffer and the fence are made, used and destroyed here,
    // and the fence is waited for before any of them is destroyed.
    unsafe {
        let pool = device.create_command_pool(&pool_info, None).unwrap();
        let info = ash::vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .command_buffer_count(1);
        let cmd = device.allocate_command_buffers(&info).unwrap()[0];
        let fence = device.create_fence(&ash::vk::FenceCreateInfo::default(), None).unwrap();
        device.begin_command_buffer(cmd, &ash::vk::CommandBufferBeginInfo::default()).unwrap();
        tracer.record(cmd, &frame, &Band::rows(0..32, 64), None);
        device.end_command_buffer(cmd).unwrap();
        let cmds = [cmd];
        ctx.submit(&[ash::vk::SubmitInfo::default().command_buffers(&cmds)], fence).unwrap();

        // The switch, with that frame pending: the pipeline kernel's first use.
        tracer.set_vendor_kernel(VendorKernel::Pipeline).unwrap();
        tracer.prepare(&frame).unwrap();

        device.wait_for_fences(&[fence], true, u64::MAX).unwrap();
        device.destroy_fence(fence, None);
        device.destroy_command_pool(pool, None);
    }
    tracer.trace(&frame.params).unwrap();
    drop(tracer);
    let messages = ctx.validation_messages();
    assert!(
        messages.is_empty(),
        "{} validation message(s), the first: {}",
        messages.len(),
        messages.first().map_or("", |m| m.as_str())
    );
}
