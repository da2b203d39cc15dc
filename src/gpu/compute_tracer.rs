//! The compute tracer: the scene's device buffers, the trace pass, the output buffers and
//! the timestamps, as one object that the window, `render`, `bench` and the tests share.
//! The window records its frames' traces into its own command buffers ([`ComputeTracer::record`]);
//! the headless callers trace whole frames with [`ComputeTracer::trace`], which splits a
//! frame too big for one submission into row bands (see [`crate::tracer::budget`]).
//! `Accel::Vendor` frames (or parts of a split frame) go to the vendor path
//! ([`super::khr_rt`]), built on first use.

use std::sync::Arc;
use std::time::Instant;

use ash::vk;

use super::barrier::{self, Access};
use super::context::GpuContext;
use super::dispatch::{Band, FrameTrace, GROUP};
use super::error::{GpuError, VkContext};
use super::khr_rt::{AccelStats, VendorKernel, VendorTracer};
use super::lock::lock;
use super::scene_buffers::SceneBuffers;
use super::tile_order::TileRect;
use super::timer::GpuTimer;
use super::trace_kernels;
use super::trace_pass::{Kernel, TraceOutput, TracePass};
use crate::render_settings::{Accel, BvhLayout, RenderSettings};
use crate::tracer::budget;
use crate::tracer::frame::FrameParams;
use crate::tracer::image::Image;
use crate::tracer::loaded::LoadedScene;
use crate::tracer::packed::{GpuInstance, PackedScene, TopLevel};
use crate::tracer::textures::EnvironmentMap;

/// Timing of one traced frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TraceTiming {
    /// GPU time of the trace dispatches (timestamps), when the queue has timestamps.
    pub gpu_ms: Option<f64>,
    /// Wall-clock time from submit to completion, as the paper's fps would count it.
    pub wall_ms: f64,
    /// Submissions the frame was split into.
    pub(crate) submissions: u32,
    /// GPU time of each part of a split frame (left, right), when timed.
    pub(crate) parts_ms: Option<[f64; 2]>,
}

/// GPU milliseconds of each part of a recorded frame (left, right), None where that part
/// was not traced or its timestamps are not there.
pub(crate) type PartTimes = [Option<f64>; 2];

/// Which passes of which parts a recording timed: `[part][pass]`, part 0 left and 1
/// right, pass 0 the main pass and 1 adaptive sampling's pre-pass.
pub(crate) type TimedParts = [[bool; 2]; 2];

/// Timer pairs per timestamp slot: a main pass and a pre-pass for each of two parts.
const PAIRS_PER_SLOT: u32 = 4;

/// The compute-shader tracer of one device: a scene (once set), output buffers at one
/// resolution, the pipeline, and timestamp slots.
pub struct ComputeTracer {
    ctx: Arc<GpuContext>,
    pass: TracePass,
    scene: Option<SceneBuffers>,
    output: Option<TraceOutput>,
    timer: Option<GpuTimer>,
    /// Timestamp slots for frames recorded by a caller; one more is the headless path's.
    /// Each slot is [`PAIRS_PER_SLOT`] timer pairs.
    recorded_slots: u32,
    /// Triangles over all instances, for the work estimate that splits frames into bands.
    triangle_total: u64,
    /// The scene uploaded holds the binary and the wide BVH layout (see
    /// `packed::Layouts`).
    has_binary: bool,
    has_wide: bool,
    /// The vendor path, or why the device cannot run it.
    vendor: Result<VendorTracer, String>,
    /// (first triangle, count) of each mesh, and the instances: what the vendor's
    /// structures are built from.
    meshes: Vec<(u32, u32)>,
    instances: Vec<GpuInstance>,
    /// One command buffer and fence reused by every headless submission.
    pool: vk::CommandPool,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
}

impl ComputeTracer {
    /// A tracer with no scene yet, with `recorded_slots` timestamp slots for frames that
    /// a caller records into its own command buffers (its frames in flight).
    pub(crate) fn new(ctx: &Arc<GpuContext>, recorded_slots: u32) -> Result<Self, GpuError> {
        let pass = TracePass::new(ctx, Kernel::ours_for(&ctx.info))?;
        let timer = GpuTimer::new(ctx, (recorded_slots + 1) * PAIRS_PER_SLOT)?;
        let device = &ctx.device;
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(ctx.queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        // SAFETY: plain object creation on a live device; each object is destroyed in Drop.
        let pool = unsafe { device.create_command_pool(&pool_info, None) }
            .during("creating a command pool")?;
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: as above; the buffer is freed with its pool.
        let cmd = unsafe { device.allocate_command_buffers(&alloc) }
            .during("allocating a command buffer")?[0];
        // SAFETY: as above.
        let fence = unsafe { device.create_fence(&vk::FenceCreateInfo::default(), None) }
            .during("creating a fence")?;
        let vendor = VendorTracer::new(ctx);
        Ok(Self {
            ctx: ctx.clone(),
            pass,
            scene: None,
            output: None,
            timer,
            recorded_slots,
            triangle_total: 0,
            has_binary: true,
            has_wide: false,
            vendor,
            meshes: Vec::new(),
            instances: Vec::new(),
            pool,
            cmd,
            fence,
        })
    }

    /// A headless tracer with `packed` uploaded.
    pub fn with_scene(ctx: &Arc<GpuContext>, packed: &PackedScene) -> Result<Self, GpuError> {
        let mut tracer = Self::new(ctx, 0)?;
        tracer.set_scene(packed)?;
        Ok(tracer)
    }

    /// Upload a new scene; the old one is freed first (the GPU is waited for).
    pub fn set_scene(&mut self, packed: &PackedScene) -> Result<(), GpuError> {
        self.set_scene_with(packed, |ctx| SceneBuffers::upload(ctx, packed))
    }

    /// [`ComputeTracer::set_scene`] for a loaded scene: its triangles are written from its
    /// meshes ([`LoadedScene`]).
    pub(crate) fn set_loaded_scene(&mut self, loaded: &LoadedScene) -> Result<(), GpuError> {
        self.set_scene_with(loaded.tables(), |ctx| SceneBuffers::upload_loaded(ctx, loaded))
    }

    /// Free the old scene, then upload the new one with `upload`; `packed` holds its tables.
    fn set_scene_with(
        &mut self,
        packed: &PackedScene,
        upload: impl FnOnce(&Arc<GpuContext>) -> Result<SceneBuffers, GpuError>,
    ) -> Result<(), GpuError> {
        self.ctx.wait_idle()?;
        self.scene = None;
        if let Ok(v) = &mut self.vendor {
            v.scene_changed();
        }
        self.scene = Some(upload(&self.ctx)?);
        self.triangle_total = packed.top_level.triangle_slots();
        (self.has_binary, self.has_wide) = (packed.has_binary(), packed.has_wide());
        self.meshes = packed.meshes.iter().map(|m| (m.triangle_base, m.triangle_count)).collect();
        self.instances = packed.top_level.instances.clone();
        self.output.as_ref().map_or(Ok(()), |o| o.forget_hints(&self.ctx))?;
        self.rebind();
        Ok(())
    }

    /// Replace the top level (model count, transforms, mirror box): no geometry is
    /// re-uploaded. A bigger instance list than the buffers hold gets new buffers.
    pub fn set_instances(&mut self, top_level: &TopLevel) -> Result<(), GpuError> {
        self.ctx.wait_idle()?;
        if let Some(scene) = &mut self.scene {
            let grown = scene.set_instances(&self.ctx, top_level)?;
            self.pass.instances_changed(scene);
            if grown {
                self.rebind();
            }
            self.triangle_total = top_level.triangle_slots();
            self.instances = top_level.instances.clone();
            if let Ok(v) = &mut self.vendor {
                v.instances_changed();
            }
        }
        self.output.as_ref().map_or(Ok(()), |o| o.forget_hints(&self.ctx))
    }

    /// Replace the environment image (None: misses see the background colour).
    pub(crate) fn set_environment(
        &mut self,
        environment: Option<&EnvironmentMap>,
    ) -> Result<(), GpuError> {
        self.ctx.wait_idle()?;
        if let Some(scene) = &mut self.scene {
            scene.set_environment(&self.ctx, environment)?;
        }
        self.rebind();
        Ok(())
    }

    /// Make the output buffers `width` x `height`; the old ones are freed first (at large
    /// sizes both may not fit), so on failure there are none.
    pub(crate) fn set_resolution(&mut self, width: u32, height: u32) -> Result<(), GpuError> {
        if self.resolution() == Some([width, height]) {
            return Ok(());
        }
        self.ctx.wait_idle()?;
        self.output = None;
        self.output = Some(TraceOutput::new(&self.ctx, width, height, self.recorded_slots + 1)?);
        self.rebind();
        Ok(())
    }

    /// The size of the output buffers, if any.
    pub(crate) fn resolution(&self) -> Option<[u32; 2]> {
        self.output.as_ref().map(|o| [o.width, o.height])
    }

    /// A scene and output buffers are there: frames can be traced.
    pub(crate) fn is_ready(&self) -> bool {
        self.scene.is_some() && self.output.is_some()
    }

    /// The layout a frame asking for `layout` traces: the one uploaded where only one is.
    pub fn traced_layout(&self, layout: BvhLayout) -> BvhLayout {
        layout.traced_with(self.has_binary, self.has_wide)
    }

    /// Bytes of device memory the scene uses.
    pub fn scene_bytes(&self) -> u64 {
        self.scene.as_ref().map_or(0, |s| s.bytes)
    }

    /// Which of our kernels traces (costliest tiles first, or rows on a CPU device).
    pub(crate) fn kernel(&self) -> Kernel {
        self.pass.kernel()
    }

    /// Start making the trace kernels that the first frame needing one would otherwise wait
    /// for (the window: a CPU device's compiler takes seconds over one).
    pub(crate) fn prepare_kernels_in_background(&self) {
        self.pass.prepare_kernels_in_background();
    }

    /// Make now the kernel that frames of `settings` run over a scene that is one instance
    /// (`TopLevel::is_one_instance`) or not, and that runs the wide kernel's twin or not
    /// (`twin`: sphere leaves or convex copies, `TopLevel::has_spheres`, `has_convex`),
    /// where it is one made on first use: `render` does this beside the load and the BVH
    /// build, so its frame does not wait for it.
    pub(crate) fn make_kernel_for(
        &self,
        settings: &RenderSettings,
        one_instance: bool,
        twin: bool,
    ) {
        let one_instance = one_instance && settings.accel == Accel::Bvh;
        self.pass.make_kernel_now(trace_kernels::variant_for(settings), one_instance, twin);
    }

    /// Whether every trace kernel a frame may need is made, so that none waits for one.
    pub(crate) fn kernels_ready(&self) -> bool {
        self.pass.kernels_ready()
    }

    /// Trace with `kernel` (one of ours) from now on: the tests run the GPU's tile order on
    /// lavapipe with it.
    #[cfg(test)]
    pub(crate) fn use_kernel(&mut self, kernel: Kernel) -> Result<(), GpuError> {
        self.ctx.wait_idle()?;
        self.pass = TracePass::new(&self.ctx, kernel)?;
        self.rebind();
        Ok(())
    }

    /// Swap the trace pipeline for one built from `spirv` (see `trace_pass::compile_trace_shader`);
    /// on failure the current one stays.
    pub(crate) fn reload_shader(&mut self, spirv: &[u32]) -> Result<(), GpuError> {
        self.pass.reload(spirv)
    }

    /// The driver's statistics of the trace kernel that frames of `params` run, one line
    /// each (`bench --verbose`; empty where the device does not report them).
    pub(crate) fn frame_kernel_statistics(&self, params: &FrameParams) -> Vec<String> {
        self.pass.frame_kernel_statistics(params)
    }

    /// Where each scene buffer's memory lives, one line each (`bench --verbose`).
    pub(crate) fn describe_memory(&self) -> Vec<String> {
        self.scene.as_ref().map_or_else(Vec::new, |s| s.describe())
    }

    /// Instances on the GPU now.
    pub(crate) fn instance_count(&self) -> u32 {
        self.scene.as_ref().map_or(0, |s| s.instance_count)
    }

    /// The packed 8-bit colour output: (buffer, width, height).
    pub(crate) fn colour_output(&self) -> Option<(vk::Buffer, u32, u32)> {
        self.output.as_ref().map(|o| (o.rgba8.buffer, o.width, o.height))
    }

    fn rebind(&self) {
        if let (Some(scene), Some(output)) = (&self.scene, &self.output) {
            self.pass.bind(scene, output, None);
            if let Ok(v) = &self.vendor {
                v.bind(scene, output);
            }
        }
    }

    /// The vendor kernel in use, or why the device has no vendor path (one sentence).
    pub(crate) fn vendor_kernel(&self) -> Result<VendorKernel, &str> {
        self.vendor.as_ref().map(|v| v.kernel).map_err(String::as_str)
    }

    /// Trace `Accel::Vendor` frames with `kernel` from now on (if the device has it).
    pub fn set_vendor_kernel(&mut self, kernel: VendorKernel) -> Result<(), GpuError> {
        let v = self.vendor.as_mut().map_err(|why| GpuError::VendorUnavailable(why.clone()))?;
        v.set_kernel(kernel).map_err(GpuError::VendorUnavailable)
    }

    /// What the vendor path last built (structures, times, bytes), once it has built.
    pub fn vendor_stats(&self) -> Option<AccelStats> {
        self.vendor.as_ref().ok().and_then(|v| v.stats().cloned())
    }

    /// Build what a frame needs before it is recorded: where a part of it is traced with
    /// `Accel::Vendor`, the driver's structures of the scene and the kernel's pipeline
    /// (waits for the GPU when it builds). Our tracer needs nothing. An error says why the
    /// vendor path cannot run here.
    pub(crate) fn prepare(&mut self, frame: &FrameTrace) -> Result<(), GpuError> {
        if !frame.parts().iter().any(|(_, p, _)| p.settings.accel == Accel::Vendor) {
            return Ok(());
        }
        let vendor =
            self.vendor.as_mut().map_err(|why| GpuError::VendorUnavailable(why.clone()))?;
        if let (Some(scene), Some(output)) = (&self.scene, &self.output) {
            vendor.prepare(scene, output, &self.meshes, &self.instances)?;
        }
        Ok(())
    }

    /// Rows per submission for `frame`, a multiple of the work-group height: the budget of
    /// the costlier part of a split frame, as if it covered the whole width.
    pub(crate) fn rows_per_submission(&self, frame: &FrameTrace) -> u32 {
        let budget = self.budget();
        let rows = |p: &FrameParams| {
            budget::rows_per_submission(&p.settings, self.triangle_total, GROUP.height, &budget)
        };
        frame.parts().iter().map(|(_, p, _)| rows(p)).min().unwrap_or_else(|| rows(&frame.params))
    }

    /// Pixels per submission for `frame` (at least one): the budget of its costlier part,
    /// which the window's bands of a long frame stay within.
    pub(crate) fn pixels_per_submission(&self, frame: &FrameTrace) -> u64 {
        let budget = self.budget();
        let pixels = |p: &FrameParams| {
            budget::pixels_per_submission(&p.settings, self.triangle_total, &budget)
        };
        let parts = frame.parts();
        parts.iter().map(|(_, p, _)| pixels(p)).min().unwrap_or_else(|| pixels(&frame.params))
    }

    /// What one submission may ask of this tracer's device (a CPU device's budget is far
    /// smaller, and its brute-force tests weigh more: see [`budget::Budget`]).
    pub(crate) fn budget(&self) -> budget::Budget {
        let cpu = self.ctx.info.is_cpu();
        budget::Budget::of(if cpu { budget::DeviceKind::Cpu } else { budget::DeviceKind::Gpu })
    }

    /// Brute-force ray-triangle tests one submission may ask (the panel says past it that
    /// brute force is traced in bands).
    pub(crate) fn tests_per_submission(&self) -> f64 {
        self.budget().brute_tests()
    }

    /// The frame fits one submission (the window records it into its own frame).
    pub(crate) fn fits_one_submission(&self, frame: &FrameTrace) -> bool {
        self.rows_per_submission(frame) >= frame.params.settings.height
    }

    /// `params` limited to the instances uploaded.
    fn clamped(&self, params: &FrameParams) -> FrameParams {
        let mut settings = params.settings;
        // A scene packed with one layout traces that one.
        settings.bvh = self.traced_layout(settings.bvh);
        FrameParams {
            instance_count: params.instance_count.min(self.instance_count()),
            settings,
            ..*params
        }
    }

    /// Record the trace of `band` of a frame into `cmd`, each part of a split frame with
    /// its own parameters and timed on its own in `timer_slot` (one of the
    /// `recorded_slots`); returns what was timed. The frame's first band (at its first
    /// pixel) runs adaptive sampling's pre-pass of every part that samples adaptively
    /// before any main pass, so that every key is there when a neighbour reads it (across
    /// a split line, the other part's). Our passes take their tiles costliest first, by
    /// the costs the slot's last frame recorded (`tile_order.rs`), so the slot's earlier
    /// commands must be done. The trace pass adds the barriers it needs; the outputs are
    /// left as `Access::ComputeWrite` for whoever reads them next. Needs [`Self::is_ready`].
    pub(crate) fn record(
        &self,
        cmd: vk::CommandBuffer,
        frame: &FrameTrace,
        band: &Band,
        timer_slot: Option<u32>,
    ) -> TimedParts {
        let tile_slot = timer_slot.unwrap_or(self.recorded_slots);
        // Our pass over `band`, its tiles ordered by the slot's last costs.
        let trace = |params: &FrameParams, band: &Band| {
            let base = match &self.output {
                Some(out) if self.pass.kernel().orders_tiles() => {
                    lock(&out.tiles).order(tile_slot, &TileRect::of_band(band))
                }
                _ => 0,
            };
            self.pass.record(cmd, params, band, base);
        };
        let mut timed = [[false; 2]; 2];
        let mut any = false;
        // Timer pair `part * 2 + pass` of the slot, pass 0 the main pass and 1 the pre-pass.
        let mut time = |part: usize, pass: usize, record: &dyn Fn()| {
            let timer = self
                .timer
                .as_ref()
                .zip(timer_slot.map(|s| s * PAIRS_PER_SLOT + (part * 2 + pass) as u32));
            if let Some((t, pair)) = timer {
                t.begin(cmd, pair, any);
            }
            record();
            if let Some((t, pair)) = timer {
                t.end(cmd, pair);
                timed[part][pass] = true;
            }
            any = true;
        };
        let parts: Vec<_> = frame
            .parts()
            .into_iter()
            .map(|(i, p, columns)| (i, self.clamped(p), columns))
            .collect();
        // Each part with the tracer its acceleration asks for.
        let vendor = |p: &FrameParams| {
            self.vendor.as_ref().ok().filter(|_| p.settings.accel == Accel::Vendor)
        };
        if band.starts_frame() {
            for (i, params, columns) in parts.iter().filter(|(_, p, _)| p.settings.adaptive) {
                match vendor(params) {
                    Some(v) => time(*i, 1, &|| v.record_ids(cmd, params, columns)),
                    None => time(*i, 1, &|| self.pass.record_ids(cmd, params, columns)),
                }
            }
        }
        for (i, params, columns) in &parts {
            if let Some(part_band) = band.within(columns) {
                match vendor(params) {
                    Some(v) => time(*i, 0, &|| v.record(cmd, params, &part_band)),
                    None => time(*i, 0, &|| trace(params, &part_band)),
                }
            }
        }
        // The tiles' costs (written where our kernel ordered tiles) are read by the host
        // once the slot's fence has signalled.
        if self.pass.kernel().orders_tiles() && parts.iter().any(|(_, p, _)| vendor(p).is_none()) {
            barrier::buffers(&self.ctx.device, cmd, &[Access::ComputeWrite], &[Access::HostRead]);
        }
        timed
    }

    /// Milliseconds of each part `timed` by the recording with `timer_slot` (its passes
    /// added), once its commands completed; None for a part with a pass not yet done.
    pub(crate) fn timer_ms(&self, timer_slot: u32, timed: TimedParts) -> PartTimes {
        let Some(t) = &self.timer else { return [None; 2] };
        let part = |i: usize| {
            let passes = (0..2).filter(|&p| timed[i][p]);
            let ms: Option<f64> = passes
                .clone()
                .map(|p| t.read_ms(timer_slot * PAIRS_PER_SLOT + (i * 2 + p) as u32))
                .sum();
            ms.filter(|_| passes.count() > 0)
        };
        [part(0), part(1)]
    }

    /// Record with `record` into the reusable command buffer, submit, and wait.
    fn submit_and_wait(&self, record: impl FnOnce(vk::CommandBuffer)) -> Result<(), GpuError> {
        let device = &self.ctx.device;
        let cmd = self.cmd;
        // SAFETY: the command buffer and fence are ours and idle (every submission is
        // waited for before this returns), so they may be reset and re-recorded.
        unsafe {
            device
                .reset_command_buffer(cmd, vk::CommandBufferResetFlags::empty())
                .during("resetting a command buffer")?;
            device
                .begin_command_buffer(
                    cmd,
                    &vk::CommandBufferBeginInfo::default()
                        .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
                )
                .during("recording commands")?;
            record(cmd);
            device.end_command_buffer(cmd).during("recording commands")?;
            let cmds = [cmd];
            let submit = [vk::SubmitInfo::default().command_buffers(&cmds)];
            device.reset_fences(&[self.fence]).during("resetting a fence")?;
            self.ctx.submit(&submit, self.fence)?;
            device.wait_for_fences(&[self.fence], true, u64::MAX).during("waiting for the trace")
        }
    }

    /// Trace one whole frame now, in as many row bands as the budget asks, and wait for it.
    pub fn trace(&mut self, params: &FrameParams) -> Result<TraceTiming, GpuError> {
        self.trace_frame(&FrameTrace::whole(*params))
    }

    /// Trace one whole frame, split or not, as [`Self::trace`] does.
    pub(crate) fn trace_frame(&mut self, frame: &FrameTrace) -> Result<TraceTiming, GpuError> {
        let s = frame.params.settings;
        self.set_resolution(s.width, s.height)?;
        if self.scene.is_none() {
            return Err(GpuError::NotReady("no scene was uploaded before tracing"));
        }
        self.prepare(frame)?;
        let band = self.rows_per_submission(frame);
        let timed = self.timer.is_some();
        let mut timing = TraceTiming {
            gpu_ms: timed.then_some(0.0),
            parts_ms: (timed && frame.split.is_some()).then_some([0.0; 2]),
            ..Default::default()
        };
        let start = Instant::now();
        let mut row = 0;
        while row < s.height {
            let rows = Band::rows(row..(row + band).min(s.height), s.width);
            let ms = self.trace_band(frame, &rows)?.map(|m| m.unwrap_or(0.0));
            if let Some(total) = timing.gpu_ms.as_mut() {
                *total += ms[0] + ms[1];
            }
            if let Some(halves) = timing.parts_ms.as_mut() {
                halves[0] += ms[0];
                halves[1] += ms[1];
            }
            timing.submissions += 1;
            row = rows.rows.end;
        }
        timing.wall_ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(timing)
    }

    /// Trace `band` of a frame now in one submission and wait for it; the milliseconds of
    /// each part it traced. The frame's resolution must be set and the tracer prepared
    /// for it ([`Self::prepare`]).
    pub(crate) fn trace_band(
        &self,
        frame: &FrameTrace,
        band: &Band,
    ) -> Result<PartTimes, GpuError> {
        let slot = self.recorded_slots;
        let mut parts = [[false; 2]; 2];
        self.submit_and_wait(|cmd| parts = self.record(cmd, frame, band, Some(slot)))?;
        Ok(self.timer_ms(slot, parts))
    }

    /// Trace a frame and read back the float image (colour or AOV).
    pub fn render(&mut self, params: &FrameParams) -> Result<(Image, TraceTiming), GpuError> {
        self.render_frame(&FrameTrace::whole(*params))
    }

    /// Trace a frame, split or not, and read back the float image.
    pub(crate) fn render_frame(
        &mut self,
        frame: &FrameTrace,
    ) -> Result<(Image, TraceTiming), GpuError> {
        let timing = self.trace_frame(frame)?;
        Ok((self.read_image()?, timing))
    }
}

impl Drop for ComputeTracer {
    fn drop(&mut self) {
        let device = &self.ctx.device;
        // SAFETY: the GPU is idle before these are destroyed (headless submissions are
        // waited for; callers recording into their own frames wait idle before dropping).
        unsafe {
            let _ = self.ctx.wait_idle();
            device.destroy_fence(self.fence, None);
            device.destroy_command_pool(self.pool, None);
        }
    }
}

#[path = "compute_tracer_readback.rs"]
mod readback;

#[cfg(test)]
#[path = "compute_tracer_tests.rs"]
mod tests;
