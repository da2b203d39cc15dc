//! Our trace kernels: `shaders/trace.comp` as build.rs compiled it, and its variants built
//! with `CORE_ONLY`, `WIDE_ONLY` or `LEAF_RUNS`, the first three's twins with
//! `ONE_INSTANCE` and the wide kernel's with `SPHERE_LEAVES` (see `shader_compile`); which
//! one a frame runs, and making them. Each leaves out code its frames do not use, since
//! unused code still slows a frame through the registers and instructions it takes. The
//! core kernel is made with the pass; the others
//! on first use, or in the background where the window asks
//! ([`KernelVariants::prepare_in_background`]: a driver compiling a kernel on the CPU, as
//! lavapipe does, would otherwise hold up the frame that first needs it for seconds).

use std::sync::{Arc, Mutex, OnceLock};
use std::thread::JoinHandle;

use ash::vk;

use super::context::GpuContext;
use super::error::GpuError;
use super::lock::lock;
use super::pipeline::create_compute_pipeline;
use super::pipeline::words;
use crate::contract;
use crate::render_settings::RenderSettings;
use crate::tracer::frame::{self, PushConstants};

/// SPIR-V compiled from `shaders/trace.comp` by build.rs.
pub(super) static TRACE_SPV: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/trace.spv"));

/// The same with `ROW_ORDER` defined (tiles in row order, no cost record).
pub(super) static TRACE_ROWS_SPV: &[u8] =
    include_bytes!(concat!(env!("OUT_DIR"), "/trace_rows.spv"));

/// Each with `CORE_ONLY` defined: no AO view, no wide BVH (see `shader_compile::CORE_ONLY`);
/// the first for GPUs (costliest tiles first), the second with `ROW_ORDER` for CPU devices.
static TRACE_CORE_SPV: [&[u8]; 2] = [
    include_bytes!(concat!(env!("OUT_DIR"), "/trace_core.spv")),
    include_bytes!(concat!(env!("OUT_DIR"), "/trace_rows_core.spv")),
];

/// Each with `WIDE_ONLY` defined: the wide traversal alone (see `shader_compile::WIDE_ONLY`).
static TRACE_WIDE_SPV: [&[u8]; 2] = [
    include_bytes!(concat!(env!("OUT_DIR"), "/trace_wide.spv")),
    include_bytes!(concat!(env!("OUT_DIR"), "/trace_rows_wide.spv")),
];

/// The wide kernels with `SPHERE_LEAVES` defined: for top levels with sphere leaves.
static TRACE_WIDE_SPHERES_SPV: [&[u8]; 2] = [
    include_bytes!(concat!(env!("OUT_DIR"), "/trace_wide_spheres.spv")),
    include_bytes!(concat!(env!("OUT_DIR"), "/trace_rows_wide_spheres.spv")),
];

/// Each with `LEAF_RUNS` defined: the wide traversal in leaf runs (`--bvh wide-runs`).
static TRACE_RUNS_SPV: [&[u8]; 2] = [
    include_bytes!(concat!(env!("OUT_DIR"), "/trace_runs.spv")),
    include_bytes!(concat!(env!("OUT_DIR"), "/trace_rows_runs.spv")),
];

/// The full, core and wide kernels (in [`Variant::one_instance_index`] order) with
/// `ONE_INSTANCE` defined, for scenes of one instance; each for GPUs and for CPU devices
/// (row order).
static TRACE_ONE_SPV: [[&[u8]; 2]; 3] = [
    [
        include_bytes!(concat!(env!("OUT_DIR"), "/trace_one.spv")),
        include_bytes!(concat!(env!("OUT_DIR"), "/trace_rows_one.spv")),
    ],
    [
        include_bytes!(concat!(env!("OUT_DIR"), "/trace_core_one.spv")),
        include_bytes!(concat!(env!("OUT_DIR"), "/trace_rows_core_one.spv")),
    ],
    [
        include_bytes!(concat!(env!("OUT_DIR"), "/trace_wide_one.spv")),
        include_bytes!(concat!(env!("OUT_DIR"), "/trace_rows_wide_one.spv")),
    ],
];

/// Which of our kernels a frame runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Variant {
    /// Everything: the AO view, either layout, brute force.
    Full,
    /// No AO view and no wide BVH.
    Core,
    /// The wide BVH alone.
    Wide,
    /// The full kernel with the wide traversal in leaf runs.
    Runs,
}

impl Variant {
    /// The index of the variant's `ONE_INSTANCE` twin in [`TRACE_ONE_SPV`]; the leaf-runs
    /// kernel, kept for measuring the wide traversal, has none.
    fn one_instance_index(self) -> Option<usize> {
        match self {
            Variant::Full => Some(0),
            Variant::Core => Some(1),
            Variant::Wide => Some(2),
            Variant::Runs => None,
        }
    }
}

/// Whether a frame of `pc` over a scene that is one instance or not runs a `ONE_INSTANCE`
/// twin: a scene of one instance alone (the instance count as the shader reads it), or
/// of one in a closed-box enclosure when traced through the BVH (the twin's brute force
/// visits the first instance only).
pub(crate) fn runs_one_instance(pc: &PushConstants, one_instance: bool) -> bool {
    let (instances, bvh) = (pc.misc[0], pc.dims[3] & contract::FLAG_BVH != 0);
    one_instance && (instances == 1 || (instances > 1 && bvh))
}

/// The kernel for a frame of these push-constant flags (`PushConstants::dims[3]`) over a
/// scene whose every mesh has a wide tree or not (a mesh without one needs the binary
/// traversal, which the wide kernel lacks). The wide kernel traces one sample a pixel, so
/// frames of more (`--spp`) run the full kernel.
pub(crate) fn variant(flags: u32, every_mesh_wide: bool) -> Variant {
    let ao = (flags >> contract::AOV_SHIFT) & contract::AOV_MASK == contract::AOV_AO;
    let wide = flags & contract::FLAG_BVH != 0 && flags & contract::FLAG_WIDE != 0;
    let one_sample = (flags >> contract::SPP_SHIFT) & contract::SPP_MASK <= 1;
    if flags & contract::FLAG_LEAF_RUNS != 0 && wide {
        Variant::Runs
    } else if wide && every_mesh_wide && !ao && one_sample {
        Variant::Wide
    } else if ao || flags & contract::FLAG_WIDE != 0 {
        Variant::Full
    } else {
        Variant::Core
    }
}

/// The kernel frames of `settings` run over a scene whose every mesh has a wide tree (what
/// `render` makes before its first frame).
pub(crate) fn variant_for(settings: &RenderSettings) -> Variant {
    variant(frame::flags_for(settings, false), true)
}

/// A kernel made on first use or in the background: None inside when making it failed
/// (logged once), and its frames then run the full kernel.
type Lazy = Arc<OnceLock<Option<vk::Pipeline>>>;

/// The core, wide and leaf-runs kernels beside a pass's full one.
pub(crate) struct KernelVariants {
    ctx: Arc<GpuContext>,
    layout: vk::PipelineLayout,
    /// 0 for a GPU's kernels, 1 for a CPU device's (row order): the index into the SPIR-V pairs.
    order: usize,
    core: vk::Pipeline,
    wide: Lazy,
    /// The wide kernel's twin for top levels with sphere leaves or convex copies.
    wide_spheres: Lazy,
    runs: Lazy,
    /// The full, core and wide kernels' `ONE_INSTANCE` twins, made on first use.
    one_instance: [Lazy; 3],
    /// Threads making kernels in the background, joined before they are destroyed.
    jobs: Mutex<Vec<JoinHandle<()>>>,
}

impl KernelVariants {
    /// The variants for pipelines of `layout`; `row_order` for a CPU device's kernels. Makes
    /// the core kernel now.
    pub(crate) fn new(
        ctx: &Arc<GpuContext>,
        layout: vk::PipelineLayout,
        row_order: bool,
    ) -> Result<Self, GpuError> {
        let order = row_order as usize;
        let core = create_pipeline(ctx, layout, &words(TRACE_CORE_SPV[order]))?;
        Ok(Self {
            ctx: ctx.clone(),
            layout,
            order,
            core,
            wide: Lazy::default(),
            wide_spheres: Lazy::default(),
            runs: Lazy::default(),
            one_instance: Default::default(),
            jobs: Mutex::new(Vec::new()),
        })
    }

    /// The pipeline for a frame of `pc` (`full`: the pass's full kernel) over a scene that
    /// is one instance or not (`TopLevel::is_one_instance`), and whose top level has sphere
    /// leaves or convex copies where `pc` says so (`FLAG_SPHERES`, `FLAG_CONVEX`: the wide
    /// kernel's twin); a kernel not made yet is made now, or waited for if a background
    /// thread is making it.
    pub(crate) fn for_frame(
        &self,
        pc: &PushConstants,
        every_mesh_wide: bool,
        one_instance: bool,
        full: vk::Pipeline,
    ) -> vk::Pipeline {
        let v = variant(pc.dims[3], every_mesh_wide);
        let one_instance = runs_one_instance(pc, one_instance);
        let twin = pc.dims[3] & (contract::FLAG_SPHERES | contract::FLAG_CONVEX) != 0;
        self.made_for(v, one_instance, twin).unwrap_or(match v {
            Variant::Core => self.core,
            _ => full,
        })
    }

    /// Make the kernel of `v` (its `ONE_INSTANCE` twin with `one_instance`, its twin for
    /// sphere leaves and convex copies with `twin`) now if it is one made on first use, so
    /// that a caller with other work to overlap can pay for the driver's compiler early.
    pub(crate) fn make_now(&self, v: Variant, one_instance: bool, twin: bool) {
        self.made_for(v, one_instance, twin);
    }

    /// The kernel of `v` (or a twin: for one instance, or for sphere leaves and convex
    /// copies) made on first use, made now if it is not yet; None for the full and core
    /// kernels, and where the driver failed it.
    fn made_for(&self, v: Variant, one_instance: bool, twin: bool) -> Option<vk::Pipeline> {
        if let Some(i) = v.one_instance_index().filter(|_| one_instance) {
            let code = TRACE_ONE_SPV[i][self.order];
            return self.one_instance[i]
                .get_or_init(|| make(&self.ctx, self.layout, code, "one-instance"))
                .or_else(|| self.made_for(v, false, twin));
        }
        match v {
            Variant::Full | Variant::Core => None,
            Variant::Wide if twin => *self.wide_spheres.get_or_init(|| {
                make(&self.ctx, self.layout, TRACE_WIDE_SPHERES_SPV[self.order], "wide spheres")
            }),
            Variant::Wide => *self
                .wide
                .get_or_init(|| make(&self.ctx, self.layout, TRACE_WIDE_SPV[self.order], "wide")),
            Variant::Runs => *self.runs.get_or_init(|| {
                make(&self.ctx, self.layout, TRACE_RUNS_SPV[self.order], "leaf-runs")
            }),
        }
    }

    /// Start making the kernels made on first use on threads of their own, so that the
    /// first frame that needs one does not wait for the driver's compiler.
    pub(crate) fn prepare_in_background(&self) {
        let mut jobs = lock(&self.jobs);
        let names = ["full one-instance", "core one-instance", "wide one-instance"];
        let twins = self.one_instance.iter().zip(TRACE_ONE_SPV).zip(names);
        let kernels = [
            (&self.wide, TRACE_WIDE_SPV, "wide"),
            (&self.wide_spheres, TRACE_WIDE_SPHERES_SPV, "wide spheres"),
            (&self.runs, TRACE_RUNS_SPV, "leaf-runs"),
        ]
        .into_iter()
        .chain(twins.map(|((cell, code), name)| (cell, code, name)));
        for (cell, code, name) in kernels {
            let (cell, ctx, layout, code) =
                (cell.clone(), self.ctx.clone(), self.layout, code[self.order]);
            let job = std::thread::Builder::new().name(format!("{name} kernel")).spawn(move || {
                cell.get_or_init(|| make(&ctx, layout, code, name));
            });
            match job {
                Ok(job) => jobs.push(job),
                // Made on first use instead.
                Err(e) => {
                    log::warn!("could not start making the {name} kernel in the background ({e})")
                }
            }
        }
    }

    /// Whether every kernel made on first use is made (or failed), so that no frame waits
    /// for one.
    pub(crate) fn ready(&self) -> bool {
        let made = |cell: &Lazy| cell.get().is_some();
        made(&self.wide)
            && made(&self.wide_spheres)
            && made(&self.runs)
            && self.one_instance.iter().all(made)
    }

    /// Whether the kernel of `v` (wide or leaf runs) has been made.
    #[cfg(test)]
    pub(crate) fn made(&self, v: Variant) -> bool {
        let cell = if v == Variant::Wide { &self.wide } else { &self.runs };
        cell.get().is_some_and(Option::is_some)
    }

    /// Whether the wide kernel's twin for sphere leaves has been made.
    #[cfg(test)]
    pub(crate) fn made_wide_spheres(&self) -> bool {
        self.wide_spheres.get().is_some_and(Option::is_some)
    }

    /// Whether the `ONE_INSTANCE` twin of `v` has been made.
    #[cfg(test)]
    pub(crate) fn made_one_instance(&self, v: Variant) -> bool {
        v.one_instance_index()
            .is_some_and(|i| self.one_instance[i].get().is_some_and(Option::is_some))
    }

    /// Destroy the kernels, after waiting for the threads still making them.
    ///
    /// # Safety
    /// The GPU must be done with the kernels (the owner waited for it).
    pub(crate) unsafe fn destroy(&self) {
        for job in lock(&self.jobs).drain(..) {
            // A thread that panicked made nothing to destroy.
            let _ = job.join();
        }
        let d = &self.ctx.device;
        // SAFETY: the caller promises the GPU no longer uses them; no thread makes them now.
        unsafe {
            d.destroy_pipeline(self.core, None);
            let lazies =
                [&self.wide, &self.wide_spheres, &self.runs].into_iter().chain(&self.one_instance);
            for made in lazies.filter_map(|cell| cell.get()).flatten() {
                d.destroy_pipeline(*made, None);
            }
        }
    }
}

/// The compute pipeline of `code` (SPIR-V of `trace.comp`) with `layout`.
pub(super) fn create_pipeline(
    ctx: &GpuContext,
    layout: vk::PipelineLayout,
    code: &[u32],
) -> Result<vk::Pipeline, GpuError> {
    // DISPATCH_BASE: a band may start at a column other than 0 (vkCmdDispatchBase).
    let mut flags = vk::PipelineCreateFlags::DISPATCH_BASE;
    if ctx.info.shader_statistics {
        flags |= vk::PipelineCreateFlags::CAPTURE_STATISTICS_KHR;
    }
    create_compute_pipeline(
        ctx,
        layout,
        code,
        flags,
        ["loading the trace shader", "creating the trace pipeline"],
    )
}

/// What the driver compiled `pipeline` to, one `name: value` per statistic it reports
/// (registers, local and shared memory, instructions); empty where the device does not
/// offer `VK_KHR_pipeline_executable_properties`.
pub(super) fn statistics(ctx: &GpuContext, pipeline: vk::Pipeline) -> Vec<String> {
    if !ctx.info.shader_statistics {
        return Vec::new();
    }
    let loader = ash::khr::pipeline_executable_properties::Device::new(&ctx.instance, &ctx.device);
    let pipeline = vk::PipelineInfoKHR::default().pipeline(pipeline);
    // SAFETY: the pipeline is live and was created with CAPTURE_STATISTICS.
    let executables =
        unsafe { loader.get_pipeline_executable_properties(&pipeline) }.unwrap_or_default();
    let mut lines = Vec::new();
    for index in 0..executables.len() as u32 {
        let info = vk::PipelineExecutableInfoKHR::default()
            .pipeline(pipeline.pipeline)
            .executable_index(index);
        // SAFETY: as above; `index` is one of the pipeline's executables.
        let statistics =
            unsafe { loader.get_pipeline_executable_statistics(&info) }.unwrap_or_default();
        for st in statistics {
            let name =
                st.name_as_c_str().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
            // SAFETY: `format` says which member of the union the driver wrote.
            let value = unsafe {
                match st.format {
                    vk::PipelineExecutableStatisticFormatKHR::BOOL32 => {
                        (st.value.b32 == vk::TRUE).to_string()
                    }
                    vk::PipelineExecutableStatisticFormatKHR::INT64 => st.value.i64.to_string(),
                    vk::PipelineExecutableStatisticFormatKHR::UINT64 => st.value.u64.to_string(),
                    _ => format!("{:.3}", st.value.f64),
                }
            };
            lines.push(format!("{name}: {value}"));
        }
    }
    lines
}

/// Make the kernel `name` from `code`; None, logged, when the driver fails it.
fn make(
    ctx: &GpuContext,
    layout: vk::PipelineLayout,
    code: &[u8],
    name: &str,
) -> Option<vk::Pipeline> {
    create_pipeline(ctx, layout, &words(code))
        .map_err(|e| log::warn!("the {name} kernel failed ({e}); its frames trace the full kernel"))
        .ok()
}

#[cfg(test)]
mod tests {
    use super::super::shader_compile::{
        self, CORE_ONLY, LEAF_RUNS, ONE_INSTANCE, ROW_ORDER, SPHERE_LEAVES, WIDE_ONLY,
    };
    use super::*;

    /// `trace.comp` compiled at run time with `defines`, as bytes.
    fn compiled(defines: &[&str]) -> Vec<u8> {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders/trace.comp");
        let contract = shader_compile::contract_glsl(contract::ALL, "src/contract.rs");
        shader_compile::compile(&path, &contract, defines)
            .unwrap()
            .spirv
            .iter()
            .flat_map(|w| w.to_le_bytes())
            .collect()
    }

    #[test]
    fn each_variant_is_built_from_the_same_sources_and_smaller_than_the_full_kernel() {
        let full = [TRACE_SPV, TRACE_ROWS_SPV];
        for (define, built) in [(CORE_ONLY, TRACE_CORE_SPV), (WIDE_ONLY, TRACE_WIDE_SPV)] {
            for (order, defines) in [vec![define], vec![ROW_ORDER, define]].into_iter().enumerate()
            {
                assert!(
                    compiled(&defines) == built[order],
                    "run-time SPIR-V of {defines:?} differs from build.rs's"
                );
                // Smaller by the code it drops (the AO view and a traversal or two).
                assert!(
                    built[order].len() + 1000 < full[order].len(),
                    "{defines:?}: {} vs full {} bytes",
                    built[order].len(),
                    full[order].len()
                );
            }
        }
        // The twins for scenes of one instance: without the top level's walk.
        let bases = [full, TRACE_CORE_SPV, TRACE_WIDE_SPV];
        for ((kind, twins), bases) in
            [None, Some(CORE_ONLY), Some(WIDE_ONLY)].iter().zip(TRACE_ONE_SPV).zip(bases)
        {
            for (order, rows) in [vec![], vec![ROW_ORDER]].into_iter().enumerate() {
                let defines: Vec<&str> =
                    rows.into_iter().chain(*kind).chain([ONE_INSTANCE]).collect();
                assert!(
                    compiled(&defines) == twins[order],
                    "run-time SPIR-V of {defines:?} differs from build.rs's"
                );
                assert!(twins[order].len() < bases[order].len(), "{defines:?} drops the walk");
            }
        }
        // The wide kernel's twin for sphere leaves and convex copies: with the spheres' test
        // and the skip, without the walk hints.
        for (order, rows) in [vec![], vec![ROW_ORDER]].into_iter().enumerate() {
            let defines: Vec<&str> = rows.into_iter().chain([WIDE_ONLY, SPHERE_LEAVES]).collect();
            assert!(
                compiled(&defines) == TRACE_WIDE_SPHERES_SPV[order],
                "run-time SPIR-V of {defines:?} differs from build.rs's"
            );
            let (twin, wide) = (TRACE_WIDE_SPHERES_SPV[order], TRACE_WIDE_SPV[order]);
            assert!(twin != wide, "{defines:?} changes the kernel");
        }
        for (order, defines) in
            [vec![LEAF_RUNS], vec![ROW_ORDER, LEAF_RUNS]].into_iter().enumerate()
        {
            assert!(
                compiled(&defines) == TRACE_RUNS_SPV[order],
                "run-time SPIR-V of {defines:?} differs from build.rs's"
            );
            assert!(TRACE_RUNS_SPV[order] != full[order], "LEAF_RUNS changes the kernel");
        }
    }

    #[test]
    fn each_frame_runs_the_kernel_that_has_its_code() {
        let (bvh, wide, runs, ao) = (
            contract::FLAG_BVH,
            contract::FLAG_WIDE,
            contract::FLAG_LEAF_RUNS,
            contract::AOV_AO << contract::AOV_SHIFT,
        );
        for every_mesh_wide in [false, true] {
            assert_eq!(variant(bvh, every_mesh_wide), Variant::Core);
            assert_eq!(variant(0, every_mesh_wide), Variant::Core, "brute force");
            assert_eq!(variant(bvh | ao, every_mesh_wide), Variant::Full);
            assert_eq!(variant(bvh | wide | ao, every_mesh_wide), Variant::Full);
            assert_eq!(variant(bvh | wide | runs, every_mesh_wide), Variant::Runs);
            assert_eq!(variant(bvh | wide | runs | ao, every_mesh_wide), Variant::Runs);
        }
        // The wide kernel only where every mesh has a wide tree.
        assert_eq!(variant(bvh | wide, true), Variant::Wide);
        assert_eq!(variant(bvh | wide, false), Variant::Full);
        // Brute force with the wide flag (not a BVH frame) keeps the full kernel.
        assert_eq!(variant(wide, true), Variant::Full);
        // The wide kernel traces one sample a pixel: more run the full kernel.
        let spp = |n: u32| n << contract::SPP_SHIFT;
        assert_eq!(variant(bvh | wide | spp(1), true), Variant::Wide);
        assert_eq!(variant(bvh | wide | spp(2), true), Variant::Full);
        assert_eq!(variant(bvh | wide | spp(4) | contract::FLAG_ADAPTIVE, true), Variant::Full);
    }
}
