//! The vendor's ray tracing beside ours (`--accel vendor`), through the driver's Vulkan KHR
//! ray tracing (hence `khr_rt`; users and the tables still call it "vendor"): the driver's
//! acceleration structures (`accel`) traced either from the compute shader with ray queries (the trace
//! pass with `Kernel::RayQuery`) or through a ray tracing pipeline (`pipeline_pass`). Both
//! run the same shading source as our tracer (`shaders/trace.glsl`); only the closest-hit
//! query differs. Built on first use, so a user who never picks it pays nothing.

pub(crate) mod accel;
pub(crate) mod pipeline_pass;

use std::fmt;
use std::ops::Range;
use std::str::FromStr;
use std::sync::Arc;

use ash::vk;

use super::barrier::Access;
use super::context::{GpuContext, VendorSupport};
use super::dispatch::Band;
use super::error::GpuError;
use super::scene_buffers::SceneBuffers;
use super::trace_pass::{Kernel, TraceOutput, TracePass};
use crate::tracer::frame::FrameParams;
use crate::tracer::packed::GpuInstance;
pub use accel::AccelStats;
use accel::VendorScene;
use pipeline_pass::PipelinePass;

/// How the driver's structures are traced.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum VendorKernel {
    /// Ray queries from the compute shader (`VK_KHR_ray_query`).
    Query,
    /// A ray tracing pipeline (`VK_KHR_ray_tracing_pipeline`).
    Pipeline,
}

impl VendorKernel {
    /// Both kinds, in the order tables list them.
    pub const ALL: [VendorKernel; 2] = [VendorKernel::Query, VendorKernel::Pipeline];

    /// The device offers this kind.
    pub fn supported(self, support: &VendorSupport) -> bool {
        match self {
            VendorKernel::Query => support.ray_query,
            VendorKernel::Pipeline => support.pipeline,
        }
    }

    /// The default where the device has `support`: ray queries, faster than the pipeline
    /// on lavapipe (docs/BENCHMARKS.md); the pipeline where that is all there is (the H100).
    pub(crate) fn preferred(support: &VendorSupport) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.supported(support))
    }

    /// The Vulkan extension that provides this kind.
    pub fn extension(self) -> &'static str {
        match self {
            VendorKernel::Query => "VK_KHR_ray_query",
            VendorKernel::Pipeline => "VK_KHR_ray_tracing_pipeline",
        }
    }
}

impl fmt::Display for VendorKernel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.pad(match self {
            VendorKernel::Query => "query",
            VendorKernel::Pipeline => "pipeline",
        })
    }
}

impl FromStr for VendorKernel {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "query" | "ray-query" => Ok(VendorKernel::Query),
            "pipeline" | "rt-pipeline" => Ok(VendorKernel::Pipeline),
            _ => Err(format!("unknown vendor kernel '{s}' (expected one of: query, pipeline)")),
        }
    }
}

/// How the traces read the driver's structures on a device with `support`: ray queries
/// from compute shaders, the ray tracing pipeline's shaders, or both.
pub(crate) fn structure_reads(support: &VendorSupport) -> Vec<Access> {
    let mut reads = Vec::with_capacity(2);
    if support.ray_query {
        reads.push(Access::RayQueryAccelRead);
    }
    if support.pipeline {
        reads.push(Access::RayTracingAccelRead);
    }
    reads
}

/// The vendor path of one tracer: the structures of its scene and the passes built so far.
pub(crate) struct VendorTracer {
    ctx: Arc<GpuContext>,
    /// The kind in use.
    pub(crate) kernel: VendorKernel,
    scene: Option<VendorScene>,
    /// The instance list changed since the top level was built.
    top_stale: bool,
    query: Option<TracePass>,
    pipeline: Option<PipelinePass>,
}

impl VendorTracer {
    /// The vendor path on `ctx`, or the one-line reason it cannot run there.
    pub(crate) fn new(ctx: &Arc<GpuContext>) -> Result<Self, String> {
        let support = &ctx.info.vendor;
        let kernel = VendorKernel::preferred(support).ok_or_else(|| {
            support
                .missing
                .clone()
                .unwrap_or_else(|| "the vendor's ray tracing is not available".into())
        })?;
        Ok(Self {
            ctx: ctx.clone(),
            kernel,
            scene: None,
            top_stale: false,
            query: None,
            pipeline: None,
        })
    }

    /// Use `kernel` from now on, if the device has it.
    pub(crate) fn set_kernel(&mut self, kernel: VendorKernel) -> Result<(), String> {
        if !kernel.supported(&self.ctx.info.vendor) {
            let what = match kernel {
                VendorKernel::Query => "ray queries",
                VendorKernel::Pipeline => "ray tracing pipeline",
            };
            return Err(format!(
                "{} does not offer the vendor's {what} ({})",
                self.ctx.info.name,
                kernel.extension()
            ));
        }
        self.kernel = kernel;
        Ok(())
    }

    /// Forget the structures (a new scene): they are built again at the next trace.
    pub(crate) fn scene_changed(&mut self) {
        self.scene = None;
    }

    /// A new instance list: only the top level is rebuilt, at the next trace.
    pub(crate) fn instances_changed(&mut self) {
        self.top_stale = self.scene.is_some();
    }

    /// What the last build did, once something was built.
    pub(crate) fn stats(&self) -> Option<&AccelStats> {
        self.scene.as_ref().map(|s| &s.stats)
    }

    /// Build what is missing for the next trace (structures, the pass of the kernel in
    /// use) and bind it to `scene` and `output`. True when something was (re)built or
    /// bound, and the GPU was waited for.
    /// `meshes` are (first triangle, count) of each mesh in `scene.triangles`.
    pub(crate) fn prepare(
        &mut self,
        scene: &SceneBuffers,
        output: &TraceOutput,
        meshes: &[(u32, u32)],
        instances: &[GpuInstance],
    ) -> Result<bool, GpuError> {
        let mut changed = false;
        if self.scene.is_none() {
            self.ctx.wait_idle()?;
            self.top_stale = false;
            self.scene = Some(VendorScene::build(&self.ctx, &scene.triangles, meshes, instances)?);
            changed = true;
        }
        if let (true, Some(vs)) = (self.top_stale, self.scene.as_mut()) {
            self.ctx.wait_idle()?;
            vs.set_instances(instances)?;
            self.top_stale = false;
            changed = true;
        }
        // A kernel's first use rebinds both passes' sets below, and the other kernel's set
        // may belong to frames still in flight (the window switching kernels): wait first.
        let new_pass = match self.kernel {
            VendorKernel::Query => self.query.is_none(),
            VendorKernel::Pipeline => self.pipeline.is_none(),
        };
        if new_pass && !changed {
            self.ctx.wait_idle()?;
        }
        match self.kernel {
            VendorKernel::Query if self.query.is_none() => {
                self.query = Some(TracePass::new(&self.ctx, Kernel::RayQuery)?);
                changed = true;
            }
            VendorKernel::Pipeline if self.pipeline.is_none() => {
                self.pipeline = Some(PipelinePass::new(&self.ctx)?);
                changed = true;
            }
            _ => {}
        }
        if changed {
            self.bind(scene, output);
        }
        Ok(changed)
    }

    /// Point the passes at `scene`, `output` and the top level (the GPU is not using them).
    pub(crate) fn bind(&self, scene: &SceneBuffers, output: &TraceOutput) {
        let Some((tlas, slots)) = self.scene.as_ref().and_then(|s| Some((s.top()?, s.slots())))
        else {
            return;
        };
        if let Some(pass) = &self.query {
            pass.bind(scene, output, Some((tlas, slots)));
        }
        if let Some(pass) = &self.pipeline {
            pass.bind(scene, output, tlas, slots);
        }
    }

    /// Record the trace of `band` with the kernel in use (see `TracePass::record`).
    pub(crate) fn record(&self, cmd: vk::CommandBuffer, params: &FrameParams, band: &Band) {
        match (self.kernel, &self.query, &self.pipeline) {
            (VendorKernel::Query, Some(pass), _) => pass.record(cmd, params, band, 0),
            (VendorKernel::Pipeline, _, Some(pass)) => pass.record(cmd, params, band),
            _ => debug_assert!(false, "VendorTracer::prepare comes before a vendor frame"),
        }
    }

    /// Record adaptive sampling's pre-pass over `columns` with the kernel in use.
    pub(crate) fn record_ids(
        &self,
        cmd: vk::CommandBuffer,
        params: &FrameParams,
        columns: &Range<u32>,
    ) {
        match (self.kernel, &self.query, &self.pipeline) {
            (VendorKernel::Query, Some(pass), _) => pass.record_ids(cmd, params, columns),
            (VendorKernel::Pipeline, _, Some(pass)) => pass.record_ids(cmd, params, columns),
            _ => debug_assert!(false, "VendorTracer::prepare comes before a vendor frame"),
        }
    }
}

#[cfg(test)]
#[path = "kernel_switch_test.rs"]
mod kernel_switch_test;
