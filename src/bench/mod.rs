//! Benchmarks: the paper's tables re-measured and scaling series far beyond them. A run is
//! a list of [`Case`]s; each is traced headless for warm-up plus measured frames and
//! reported as GPU time (timestamps around the dispatch) and wall-clock frame time.

pub mod charts;
pub mod clock_guard;
pub mod fields;
pub mod load;
pub mod paper_tables;
pub mod report;
pub mod suite;
pub mod timing;
pub mod workload;

use std::sync::Arc;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use crate::gpu::khr_rt::VendorKernel;
use crate::gpu::{ClockProbe, ComputeTracer, GpuContext, GpuError};
use crate::render_settings::{Accel, Aov, RenderSettings};
use crate::scene::paper::{prepare_model, ModelSource};
use crate::scene::spec::SceneSpec;
use crate::scene::{EnvironmentSource, Mesh, Model};
use crate::tracer::packed::{BvhBuilder, Layouts};
use crate::tracer::{budget, FrameParams, PackedScene};
use clock_guard::{ClockGuard, CLOCKED_DOWN};
use timing::Timing;
use workload::WorkloadHeader;

/// One benchmark configuration: a scene spec and how to report it.
#[derive(Clone, Debug)]
pub struct Case {
    /// The group this row belongs to ("table1", "triangles", ...).
    pub series: String,
    /// What is traced: model, copies, camera (framed or not), environment, settings.
    pub spec: SceneSpec,
    /// Generated meshes carry their own mesh (large procedural ones).
    pub generated: Option<Arc<Mesh>>,
    /// The paper's figures for this row (fps, ms), when it has them.
    pub paper: Option<(f64, f64)>,
    /// Label of the shading features switched on, for the feature series.
    pub features: String,
    /// For `Accel::Vendor` rows: the kind of vendor tracing (None: the device's default).
    pub vendor_kernel: Option<VendorKernel>,
    /// Whether the model's share of the frame is measured or matched (`bench --fields`).
    pub coverage: Coverage,
}

/// What a row does with the share of the frame its model covers (`bench --fields`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Coverage {
    /// Nothing (a framed row reports its own).
    #[default]
    Unmeasured,
    /// Measured and reported in the row's label.
    Measured,
    /// Measured and reported, and the share a later [`Coverage::Matched`] row of the same
    /// mesh is given.
    Target,
    /// The camera moved along its view until the model covers the last target's share.
    Matched,
}

impl Case {
    /// A row of `series` on a paper model with default shading.
    pub fn new(series: &str, model: ModelSource, models: u32, settings: RenderSettings) -> Self {
        let spec = SceneSpec { model, models, settings, ..SceneSpec::default() };
        Self {
            series: series.into(),
            spec,
            generated: None,
            paper: None,
            features: String::new(),
            vendor_kernel: None,
            coverage: Coverage::Unmeasured,
        }
    }

    /// The same row with the camera moved in until the model fills the frame.
    pub fn framed(mut self) -> Self {
        self.spec.camera.framed = true;
        self
    }

    /// The same row with misses seeing `environment`.
    pub fn with_environment(mut self, environment: Option<EnvironmentSource>) -> Self {
        self.spec.environment = environment;
        self
    }
}

/// One measured (or skipped) row.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Row {
    pub series: String,
    /// Model, triangles, resolution, bounces, acceleration: flattened, so the fields stay
    /// where they always were in the JSON.
    #[serde(flatten)]
    pub workload: WorkloadHeader,
    /// Shading features on (smooth, textures, env, spp, adaptive), empty for the paper's.
    pub features: String,
    /// Rays per frame: every pixel's primary ray plus one per bounce (the mirror box is
    /// closed, so no ray escapes early).
    pub rays_per_frame: u64,
    pub gpu_ms: Option<Timing>,
    pub wall_ms: Timing,
    /// Million rays per second from the median GPU time (wall time without timestamps).
    pub mrays_per_s: f64,
    pub fps: f64,
    pub bvh_build_ms: f64,
    pub scene_bytes: u64,
    pub paper_fps: Option<f64>,
    pub paper_ms: Option<f64>,
    /// Why the row was not measured, if it was not.
    pub skipped: Option<String>,
    /// Vendor rows: how the driver's structures were traced ("query" or "pipeline").
    #[serde(default)]
    pub vendor_kernel: Option<String>,
    /// `bench --compare`: our BVH's GPU time over the vendor's on the same scene and rays
    /// (on both rows of the pair).
    #[serde(default)]
    pub ours_over_vendor: Option<f64>,
    /// The shader clock in MHz measured right after the row's frames ([`ClockProbe`]);
    /// None where the device has no shader clock. A row far below the run's highest clock
    /// was measured with the GPU clocked down.
    #[serde(default)]
    pub gpu_clock_mhz: Option<f64>,
}

impl Row {
    /// The scene and rays of the row, without the acceleration and the notes (a vendor
    /// row's notes also name its kernel).
    fn scene_and_rays(&self) -> (&str, &str, u32, u64, u32, u32, u32) {
        let w = &self.workload;
        (&self.series, &w.model, w.models, w.triangles, w.width, w.height, w.bounces)
    }
}

/// `bench --compare`: each vendor row's partners, the nearest BVH row before it with the same
/// workload for each BVH layout (the CLI puts the vendor rows right after their BVH rows):
/// (ours, vendor) indices.
pub fn vendor_pairs(rows: &[Row]) -> Vec<(usize, usize)> {
    let mut pairs = Vec::new();
    for (j, theirs) in rows.iter().enumerate().filter(|(_, r)| r.workload.accel == Accel::Vendor) {
        let mut ours: Vec<usize> = Vec::new();
        for i in (0..j).rev().filter(|&i| {
            rows[i].workload.accel == Accel::Bvh
                && rows[i].scene_and_rays() == theirs.scene_and_rays()
        }) {
            if ours.iter().all(|&k| rows[k].workload.bvh != rows[i].workload.bvh) {
                ours.push(i);
            }
        }
        pairs.extend(ours.into_iter().rev().map(|i| (i, j)));
    }
    pairs
}

/// `bench --compare`: set [`Row::ours_over_vendor`] on both rows of each pair (on the BVH
/// row, from its first vendor partner).
pub fn pair_with_vendor(rows: &mut [Row]) {
    for (i, j) in vendor_pairs(rows) {
        if let (Some(ours), Some(theirs)) = (rows[i].gpu_ms, rows[j].gpu_ms) {
            let ratio = ours.median / theirs.median;
            rows[j].ours_over_vendor = Some(ratio);
            rows[i].ours_over_vendor.get_or_insert(ratio);
        }
    }
}

/// Rows measured at a shader clock below [`CLOCKED_DOWN`] of the run's highest: the GPU's
/// clock was lowered (and did not come back in time), so their times are not the tracer's.
pub fn clocked_down(rows: &[Row]) -> Vec<&Row> {
    let highest = rows.iter().filter_map(|r| r.gpu_clock_mhz).fold(0.0, f64::max);
    rows.iter()
        .filter(|r| r.gpu_clock_mhz.is_some_and(|mhz| mhz < CLOCKED_DOWN * highest))
        .collect()
}

/// Options of a run.
#[derive(Clone, Debug)]
pub struct RunOptions {
    pub frames: u32,
    pub warmup: u32,
    /// Print where each scene buffer's memory lives when a scene is uploaded.
    pub verbose: bool,
    /// Where the scenes' BVHs are built.
    pub bvh_builder: BvhBuilder,
}

/// The machine a run happened on.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Environment {
    pub device: String,
    pub device_type: String,
    pub driver: String,
    pub vulkan: String,
    pub date: String,
}

/// Describe the context's device.
pub fn environment(ctx: &GpuContext) -> Environment {
    Environment {
        device: ctx.info.name.clone(),
        device_type: ctx.info.device_type.clone(),
        driver: ctx.info.driver.clone(),
        vulkan: ctx.info.api_version.clone(),
        date: chrono::Local::now().format("%Y-%m-%d").to_string(),
    }
}

/// Prepared geometry shared by the rows that use the same mesh.
struct Loaded {
    key: String,
    model: Model,
    /// The objects' other models ([`SceneSpec::object_sources`]).
    others: Vec<Model>,
}

/// Run `cases` on `ctx`, calling `progress` after each row.
pub fn run(
    ctx: &Arc<GpuContext>,
    cases: &[Case],
    options: &RunOptions,
    mut progress: impl FnMut(usize, &Row),
) -> anyhow::Result<Vec<Row>> {
    let mut rows = Vec::with_capacity(cases.len());
    let mut loaded: Option<Loaded> = None;
    // The uploaded scene is reused while mesh (and so BVH) stays the same.
    let mut current: Option<(String, PackedScene, ComputeTracer)> = None;
    let mut clock = ClockProbe::new(ctx)?.map(ClockGuard::new).transpose()?;
    let mut coverage = fields::CoverageRuns::default();
    for (i, case) in cases.iter().enumerate() {
        let key = match &case.generated {
            Some(m) => format!("generated:{}:{}", m.name, m.triangle_count()),
            None => format!("{:?} {:?}", case.spec.model, case.spec.objects),
        };
        if loaded.as_ref().is_none_or(|l| l.key != key) {
            current = None;
            let (model, others) = match &case.generated {
                Some(m) => {
                    let mut model = Model::from((**m).clone());
                    prepare_model(&mut model);
                    (model, Vec::new())
                }
                None => {
                    let (model, others, warnings) = case.spec.load_models(None)?;
                    for w in &warnings {
                        log::warn!("{w}");
                    }
                    (model, others)
                }
            };
            loaded = Some(Loaded { key: key.clone(), model, others });
        }
        let l = loaded.as_ref().unwrap();
        let mut scene = case.spec.scene_of(l.model.clone(), &l.others);
        let mesh_key = key.clone();
        let layout = case.spec.settings.bvh;
        let key = format!("{key}:{:?}:{}:{layout}", case.spec.environment, case.spec.mirror_box);
        if current.as_ref().is_none_or(|c| c.0 != key) {
            let limit = ctx.info.max_storage_buffer_range;
            crate::gpu::scene_buffers::check_before_build(&scene, &case.spec.model.label(), limit)
                .map_err(anyhow::Error::msg)?;
            let packed = PackedScene::with_layouts_within(
                &scene,
                Layouts::only(layout),
                ctx.info.fit(options.bvh_builder),
            );
            for w in &packed.warnings {
                log::warn!("{w}");
            }
            let tracer = ComputeTracer::with_scene(ctx, &packed)?;
            if options.verbose {
                for line in tracer.describe_memory() {
                    println!("  memory: {line}");
                }
            }
            current = Some((key.clone(), packed, tracer));
        }
        let (_, packed, tracer) = current.as_mut().unwrap();
        packed.set_instances(&scene.instances);
        tracer.set_instances(&packed.top_level)?;
        let share = coverage.prepare(case, &mesh_key, tracer, &mut scene)?;
        let mut row = measure(tracer, packed, &scene, case, options, clock.as_mut())?;
        if let Some(share) = share {
            row.features = fields::labelled(&row.features, share);
        }
        progress(i, &row);
        rows.push(row);
    }
    Ok(rows)
}

/// Trace `case`'s warm-up and measured frames; with a clock guard, the GPU is first kept busy
/// until its clock is up, and the row reports the lower of the clocks before and after.
fn measure(
    tracer: &mut ComputeTracer,
    packed: &PackedScene,
    scene: &crate::scene::Scene,
    case: &Case,
    options: &RunOptions,
    clock: Option<&mut ClockGuard>,
) -> Result<Row, GpuError> {
    let s = case.spec.settings;
    let mut row = unmeasured_row(tracer, packed, scene, case);
    if let Some(why) = budget::refusal(&s, row.workload.triangles) {
        row.skipped = Some(why);
        return Ok(row);
    }
    let params = FrameParams::new(scene, s);
    if s.accel == Accel::Vendor {
        if let Some(kernel) = case.vendor_kernel {
            tracer.set_vendor_kernel(kernel)?;
        }
        let kernel =
            tracer.vendor_kernel().map_err(|why| GpuError::VendorUnavailable(why.to_string()))?;
        row.vendor_kernel = Some(kernel.to_string());
        tracer.prepare(&crate::gpu::FrameTrace::whole(params))?;
    }
    if case.spec.camera.framed {
        let framed = framed_share(tracer, scene, s)?;
        // After the case's own label (the AO series names its rays), if it has one.
        row.features =
            if case.features.is_empty() { framed } else { format!("{}, {framed}", case.features) };
    }
    // The driver's traversal reports no cost.
    if options.verbose && s.accel != Accel::Vendor {
        println!("  work: {}", work_per_ray(tracer, scene, s)?);
    }
    let frames = timed_frames(tracer, &params, options, clock)?;
    if options.verbose && s.accel != Accel::Vendor {
        // The kernel the frames ran, which the first frame made if it was made on first use.
        for line in tracer.frame_kernel_statistics(&params) {
            println!("  kernel: {line}");
        }
    }
    row.gpu_clock_mhz = frames.clock_mhz;
    if s.accel == Accel::Vendor {
        // The driver's structures stand in for our BVH in the build and memory columns. Read
        // after the frames: a tracer new to this row builds them with its first frame (its
        // output image does not exist before), and the columns had shown our own figures.
        let stats = tracer.vendor_stats().ok_or_else(|| {
            GpuError::VendorUnavailable("the vendor's structures were not built".into())
        })?;
        row.bvh_build_ms = stats.bottom_ms + stats.top_ms;
        row.scene_bytes = stats.bytes;
    }
    row.wall_ms = Timing::of(&frames.wall_ms).unwrap_or_default();
    row.gpu_ms = Timing::of(&frames.gpu_ms);
    let ms = row.gpu_ms.map_or(row.wall_ms.median, |g| g.median);
    // A measured frame always took time: the rate is never the zero-time fallback.
    row.mrays_per_s = timing::mrays_per_second(row.rays_per_frame, ms);
    row.fps = 1e3 / row.wall_ms.median;
    Ok(row)
}

/// `case`'s row before anything is traced: the workload, the scene's build time and bytes,
/// and no timings yet.
fn unmeasured_row(
    tracer: &ComputeTracer,
    packed: &PackedScene,
    scene: &crate::scene::Scene,
    case: &Case,
) -> Row {
    let s = case.spec.settings;
    Row {
        series: case.series.clone(),
        workload: WorkloadHeader {
            model: match &case.generated {
                Some(m) => m.name.clone(),
                None => case.spec.model.label(),
            },
            models: case.spec.models,
            triangles: scene.triangle_count() as u64,
            width: s.width,
            height: s.height,
            bounces: s.bounces,
            accel: s.accel,
            bvh: s.bvh,
        },
        features: case.features.clone(),
        rays_per_frame: s.max_rays(),
        gpu_ms: None,
        wall_ms: Timing::default(),
        mrays_per_s: 0.0,
        fps: 0.0,
        bvh_build_ms: packed.bvh_build_seconds * 1e3,
        scene_bytes: tracer.scene_bytes(),
        paper_fps: case.paper.map(|p| p.0),
        paper_ms: case.paper.map(|p| p.1),
        skipped: None,
        vendor_kernel: None,
        ours_over_vendor: None,
        gpu_clock_mhz: None,
    }
}

/// What share of the frame the model covers, as a feature label ("framed, 40% model").
fn framed_share(
    tracer: &mut ComputeTracer,
    scene: &crate::scene::Scene,
    s: RenderSettings,
) -> Result<String, GpuError> {
    Ok(format!("framed, {}", fields::coverage_label(fields::coverage(tracer, scene, s)?)))
}

/// The measured frames' times in milliseconds, and the GPU clock they ran at.
struct Frames {
    wall_ms: Vec<f64>,
    gpu_ms: Vec<f64>,
    /// The lower of the clocks before and after the frames (with a clock guard).
    clock_mhz: Option<f64>,
}

/// The warm-up frames, the wait for the clock (with a guard), then the measured frames.
fn timed_frames(
    tracer: &mut ComputeTracer,
    params: &FrameParams,
    options: &RunOptions,
    mut clock: Option<&mut ClockGuard>,
) -> Result<Frames, GpuError> {
    for _ in 0..options.warmup {
        tracer.trace(params)?;
    }
    let clock_before = match clock.as_deref_mut() {
        Some(guard) => Some(guard.settle(|| tracer.trace(params).map(|_| ()))?),
        None => None,
    };
    let mut gpu = Vec::new();
    let mut wall = Vec::new();
    for _ in 0..options.frames.max(1) {
        let start = Instant::now();
        let t = tracer.trace(params)?;
        wall.push(start.elapsed().as_secs_f64() * 1e3);
        if let Some(g) = t.gpu_ms {
            gpu.push(g);
        }
    }
    let clock_mhz = match (clock, clock_before) {
        (Some(guard), Some(before)) => Some(before.min(guard.read()?)),
        _ => None,
    };
    Ok(Frames { wall_ms: wall, gpu_ms: gpu, clock_mhz })
}

/// Mean BVH nodes visited and triangles tested per pixel (the cost AOV, summed over the
/// path's rays), and the bytes of node and triangle records that makes.
fn work_per_ray(
    tracer: &mut ComputeTracer,
    scene: &crate::scene::Scene,
    s: RenderSettings,
) -> Result<String, GpuError> {
    let cost =
        FrameParams::new(scene, RenderSettings { aov: Aov::Cost, spp: 1, adaptive: false, ..s });
    let (image, _) = tracer.render(&cost)?;
    let n = image.pixels.len().max(1) as f64;
    let nodes = image.pixels.iter().map(|p| p[0] as f64).sum::<f64>() / n;
    let tris = image.pixels.iter().map(|p| p[1] as f64).sum::<f64>() / n;
    // The layout traced: a scene packed with one layout traces it whatever the frame asks.
    let node_bytes = if tracer.traced_layout(s.bvh).is_wide() {
        std::mem::size_of::<crate::bvh::wide::WideNode>()
    } else {
        std::mem::size_of::<crate::bvh::BvhNode>()
    } as f64;
    let tri_bytes = std::mem::size_of::<crate::tracer::packed::GpuTriangle>() as f64;
    let tail = PathTail::of(&image, crate::gpu::GROUP.width);
    Ok(format!(
        "{nodes:.1} nodes ({node_bytes} B) + {tris:.1} triangles ({tri_bytes} B) per pixel, {:.0} B per pixel ({} rays per pixel at most); \
         longest path {:.0} steps, a {}-pixel run's longest: median {:.0}, 99.9th percentile {:.0}",
        nodes * node_bytes + tris * tri_bytes,
        s.bounces + 1,
        tail.longest,
        crate::gpu::GROUP.width,
        tail.run_median,
        tail.run_p999,
    ))
}

/// The long paths of a cost image, in steps (nodes visited plus triangles tested, over all
/// of a pixel's rays). A subgroup traces a run of a row's pixels and takes as long as its
/// longest lane, so where the mean work per pixel says little about a frame (the mirror
/// box: a few hundred runs hold a ray that grazes the model), these do.
struct PathTail {
    /// The costliest pixel's steps.
    longest: f32,
    /// The median over every run of its costliest pixel.
    run_median: f32,
    /// The 99.9th percentile (nearest rank) over every run of its costliest pixel.
    run_p999: f32,
}

impl PathTail {
    /// Over runs of `run` pixels along each row (the last one of a row may be shorter).
    fn of(image: &crate::tracer::Image, run: u32) -> Self {
        let steps = |p: &[f32; 4]| p[0] + p[1];
        let mut runs: Vec<f32> = image
            .pixels
            .chunks(image.width.max(1) as usize)
            .flat_map(|row| {
                row.chunks(run.max(1) as usize).map(|r| r.iter().map(steps).fold(0.0, f32::max))
            })
            .collect();
        runs.sort_by(f32::total_cmp);
        let rank = |q: f64| {
            runs.get(((q * runs.len() as f64).ceil() as usize).clamp(1, runs.len().max(1)) - 1)
                .copied()
                .unwrap_or(0.0)
        };
        Self {
            longest: runs.last().copied().unwrap_or(0.0),
            run_median: rank(0.5),
            run_p999: rank(0.999),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn path_tail_takes_each_runs_costliest_pixel() {
        // Two rows of 64 pixels: four runs of 32. One grazing ray of 900 nodes and 100
        // triangles; every other pixel 8 + 2.
        let mut image =
            crate::tracer::Image { width: 64, height: 2, pixels: vec![[8.0, 2.0, 0.0, 1.0]; 128] };
        image.pixels[70] = [900.0, 100.0, 0.0, 1.0];
        image.pixels[3] = [20.0, 5.0, 0.0, 1.0];
        let tail = PathTail::of(&image, 32);
        assert_eq!(tail.longest, 1000.0);
        // Run maxima 25, 10, 1000, 10: the median is the second smallest, 10.
        assert_eq!(tail.run_median, 10.0);
        assert_eq!(tail.run_p999, 1000.0);
        // A frame narrower than a run: one run per row.
        let narrow = crate::tracer::Image {
            width: 3,
            height: 1,
            pixels: vec![[1.0, 1.0, 0.0, 1.0], [4.0, 0.0, 0.0, 1.0], [0.0, 0.0, 0.0, 1.0]],
        };
        let tail = PathTail::of(&narrow, 32);
        assert_eq!((tail.longest, tail.run_median, tail.run_p999), (4.0, 4.0, 4.0));
        // An empty image has no paths.
        let empty = crate::tracer::Image { width: 0, height: 0, pixels: Vec::new() };
        assert_eq!(PathTail::of(&empty, 32).longest, 0.0);
    }

    #[test]
    fn rows_below_the_share_of_the_highest_clock_are_clocked_down() {
        let row = |mhz: Option<f64>| Row {
            gpu_clock_mhz: mhz,
            ..serde_json::from_str::<Row>(ROW_JSON).unwrap()
        };
        let rows = [row(Some(1980.0)), row(Some(600.0)), row(None), row(Some(1800.0))];
        let low = clocked_down(&rows);
        assert_eq!(low.len(), 1);
        assert_eq!(low[0].gpu_clock_mhz, Some(600.0));
        assert!(clocked_down(&rows[2..3]).is_empty(), "no clock, nothing to flag");
    }

    /// A row as an older report wrote it (no clock, no vendor fields).
    const ROW_JSON: &str = r#"{"series":"framed","model":"dragon","models":1,"triangles":202532,"width":1024,"height":1024,"bounces":0,"accel":"bvh","features":"","rays_per_frame":1048576,"gpu_ms":{"median":0.356,"p10":0.355,"p90":0.357},"wall_ms":{"median":0.43,"p10":0.42,"p90":0.44},"mrays_per_s":2945.0,"fps":2325.0,"bvh_build_ms":40.0,"scene_bytes":30283232,"paper_fps":null,"paper_ms":null,"skipped":null}"#;

    #[test]
    fn a_row_writes_its_workload_where_it_always_was() {
        let row: Row = serde_json::from_str(ROW_JSON).unwrap();
        assert_eq!(row.workload.model, "dragon");
        // Written since: the timings' min, mean and max (read as 0 from an older row).
        let newer = ROW_JSON
            .replace(
                "null}",
                r#"null,"vendor_kernel":null,"ours_over_vendor":null,"gpu_clock_mhz":null}"#,
            )
            .replace(r#"_ms":{"median""#, r#"_ms":{"min":0.0,"mean":0.0,"max":0.0,"median""#);
        assert_eq!(serde_json::to_string(&row).unwrap(), newer);
    }
}
