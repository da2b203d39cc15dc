//! `meshtracer bench`: the paper's tables and the scaling series, printed, and written as
//! JSON/CSV.

use std::collections::HashSet;
use std::path::PathBuf;

use clap::Args;

use super::args::{defaults, ranged};
use crate::bench::suite::{self, Outputs, Suite};
use crate::bench::RunOptions;
use crate::gpu::khr_rt::VendorKernel;
use crate::render_settings::{self as knobs, Accel, BvhLayout};
use crate::tracer::packed::BvhBuilder;

/// `meshtracer bench` flags.
#[derive(Args, Debug, Clone)]
pub struct BenchArgs {
    /// The paper's Table 1 (four models) and Table 2 (1..4 geospheres), 2 bounces.
    #[arg(long)]
    pub(crate) paper: bool,
    /// Frame time against triangles, resolution, bounces and model count.
    #[arg(long)]
    pub(crate) scaling: bool,
    /// The cost of each shading feature (smooth, env, spp, adaptive; textures on the first --model).
    #[arg(long)]
    pub(crate) features: bool,
    /// Primary rays with the camera moved in until the model fills the frame (--triangles
    /// knots and --model files at --size): the vendor's comparison.
    #[arg(long)]
    pub(crate) framed: bool,
    /// Trace every row with our BVH and with the vendor's ray tracing (and brute force with
    /// --accel brute,bvh, where it fits the GPU watchdog's budget) on the same scene, camera
    /// and rays, and end with a table of the ratio ours / vendor, build times and memory of
    /// both.
    #[arg(long)]
    pub(crate) compare: bool,
    /// The AO view on the framed series' scenes (--triangles knots and --model files at
    /// --size): a primary ray and --ao-samples occlusion (any-hit) rays per pixel; with
    /// --compare, ours against the vendor's.
    #[arg(long)]
    pub(crate) ao: bool,
    /// 10,000 copies of a knot (--triangles, else 1M; identical, then turned and scaled),
    /// no box, primary rays at --size, as the window frames them, against one copy with its
    /// camera moved until it covers the same share of the frame; ends with their ratios.
    #[arg(long)]
    pub(crate) fields: bool,
    /// Occlusion rays per pixel for --ao (1..=256).
    #[arg(long, value_name = "N", default_value_t = defaults().settings.ao_samples, value_parser = ranged(knobs::AO_SAMPLES), allow_negative_numbers = true)]
    pub(crate) ao_samples: u32,
    /// How far --ao's rays look, in scene units (the model has radius 1).
    #[arg(long, value_name = "R", default_value_t = defaults().settings.ao_radius, value_parser = |s: &str| knobs::AO_RADIUS.parse_f32(s), allow_negative_numbers = true)]
    pub(crate) ao_radius: f32,
    /// How vendor rows trace the driver's structures: query (ray queries from the compute
    /// shader), pipeline (a ray tracing pipeline), comma-separated. Default: with --compare
    /// every kind the device has, else the device's default.
    #[arg(long, value_delimiter = ',')]
    pub(crate) vendor_kernel: Vec<VendorKernel>,
    /// Measured frames per row.
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u32).range(1..=100000))]
    pub(crate) frames: u32,
    /// Discarded warm-up frames per row. After them, each row also waits (tracing its own
    /// frames) until the GPU's shader clock is back near the run's highest: drivers lower
    /// the clock while the host builds the next scene.
    #[arg(long, default_value_t = 5)]
    pub(crate) warmup: u32,
    /// Resolutions (square) for --paper, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "512,1024", value_parser = ranged(knobs::RESOLUTION))]
    pub(crate) resolutions: Vec<u32>,
    /// Accelerations to run, comma-separated: brute, bvh, vendor.
    #[arg(long, value_delimiter = ',', default_value = "brute,bvh")]
    pub(crate) accel: Vec<Accel>,
    /// BVH layouts of the bvh rows, comma-separated: binary, wide, wide-runs (each bvh row is traced
    /// with each; with --compare, the vendor's rows follow them). Without it, a preset's
    /// layout, else wide.
    #[arg(long, value_delimiter = ',', default_values_t = [defaults().settings.bvh])]
    pub(crate) bvh: Vec<BvhLayout>,
    /// Triangle counts of the generated meshes for --scaling, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "100,1000,10000,100000,1000000,4000000")]
    pub(crate) triangles: Vec<usize>,
    /// Resolution (square) of the --scaling series other than resolution itself.
    #[arg(long, default_value_t = 1024, value_parser = ranged(knobs::RESOLUTION))]
    pub(crate) size: u32,
    /// Bounces in the triangle series (the paper's 2; 0 = primary rays only).
    #[arg(long, default_value_t = defaults().settings.bounces, value_parser = ranged(knobs::BOUNCES))]
    pub(crate) bounces: u32,
    /// Extra model files (OBJ, PLY, glTF) for the triangle series.
    #[arg(long = "model", alias = "obj", value_name = "FILE")]
    pub(crate) objs: Vec<PathBuf>,
    /// Write all rows as JSON here.
    #[arg(long)]
    pub(crate) json: Option<PathBuf>,
    /// Write all rows as CSV here.
    #[arg(long)]
    pub(crate) csv: Option<PathBuf>,
    /// Draw PNG charts of the rows into this folder (chart_triangles.png,
    /// chart_resolution.png, chart_models.png).
    #[arg(long, value_name = "DIR")]
    pub(crate) charts: Option<PathBuf>,
    /// Draw the charts from these saved --json reports instead of running anything
    /// (with --charts DIR).
    #[arg(long = "charts-from", value_name = "FILE.json", num_args = 1.., requires = "charts", conflicts_with_all = ["paper", "scaling", "features", "framed", "ao", "fields", "json", "csv"])]
    pub(crate) charts_from: Vec<PathBuf>,
    /// Measure the way from each model to its first frame instead (files or names as
    /// --model takes them, e.g. torusknot:10M): each phase (read, parse, build, pack,
    /// upload), the first frame at --size in the paper's scene, the whole wait and the peak
    /// memory; with the binary tree, as the window's first frame, or each --bvh layout given.
    #[arg(long, value_name = "MODEL", num_args = 1.., conflicts_with_all = ["paper", "scaling", "features", "framed", "fields", "compare", "charts_from", "preset"])]
    pub(crate) load: Vec<String>,
    /// Benchmark exactly this preset (a TOML preset or a PNG this program wrote), one row
    /// per --accel given (else the preset's); --size and --bounces given beside it
    /// override it.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["paper", "scaling", "features", "framed", "ao", "fields", "charts_from"])]
    pub(crate) preset: Option<PathBuf>,
    /// Vulkan device index (see `meshtracer devices`).
    #[arg(long)]
    pub(crate) device: Option<usize>,
    /// Where the BVHs are built: cpu, device (a linear BVH on the GPU) or auto (the device
    /// for meshes of 50M triangles and more), as `render --bvh-build` takes it.
    #[arg(long, value_name = "WHERE", default_value_t = BvhBuilder::Auto)]
    pub(crate) bvh_build: BvhBuilder,
    /// Turn on the Vulkan validation layer.
    #[arg(long)]
    pub(crate) validation: bool,
    /// Print where each scene buffer's memory lives (memory flags, dedicated or not), the work
    /// per ray and its longest paths, and what the driver compiled the trace shader to
    /// (registers, local memory).
    #[arg(long)]
    pub(crate) verbose: bool,
    /// The flags given on the command line (clap's ids); None: all of them count as given.
    #[arg(skip)]
    pub(crate) given: Option<HashSet<String>>,
}

impl BenchArgs {
    /// Whether flag `id` was given on the command line.
    pub(crate) fn given(&self, id: &str) -> bool {
        self.given.as_ref().is_none_or(|g| g.contains(id))
    }

    /// The run these flags ask for.
    pub(crate) fn suite(&self) -> Suite {
        Suite {
            paper: self.paper,
            scaling: self.scaling,
            features: self.features,
            framed: self.framed,
            compare: self.compare,
            ao: self.ao,
            fields: self.fields,
            ao_samples: self.ao_samples,
            ao_radius: self.ao_radius,
            vendor_kernels: self.vendor_kernel.clone(),
            run: RunOptions {
                frames: self.frames,
                warmup: self.warmup,
                verbose: self.verbose,
                bvh_builder: self.bvh_build,
            },
            resolutions: self.resolutions.clone(),
            accel: self.accel.clone(),
            accel_given: self.given("accel"),
            bvh: self.bvh.clone(),
            bvh_given: self.given("bvh"),
            triangles: self.triangles.clone(),
            triangles_given: self.given("triangles"),
            size: self.size,
            size_given: self.given("size"),
            bounces: self.bounces,
            bounces_given: self.given("bounces"),
            models: self.objs.clone(),
            preset: self.preset.clone(),
            device: self.device,
            validation: self.validation,
            outputs: self.outputs(),
        }
    }

    fn outputs(&self) -> Outputs {
        Outputs { json: self.json.clone(), csv: self.csv.clone(), charts: self.charts.clone() }
    }
}

/// Run the benchmark.
pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    if !args.charts_from.is_empty() {
        let dir = args
            .charts
            .as_ref()
            .ok_or_else(|| anyhow::anyhow!("--charts-from needs --charts DIR"))?;
        return suite::charts_from_reports(&args.charts_from, dir);
    }
    if !args.load.is_empty() {
        // The window's first frame is the binary tree's (it loads the wide one after): the
        // default here too; `--bvh` loads those layouts instead, one row each.
        let layouts = if args.given("bvh") { args.bvh.clone() } else { vec![BvhLayout::Binary] };
        let (size, device) =
            ((args.size, args.bounces), (args.device, args.validation, args.bvh_build));
        return suite::run_loads(&args.load, &layouts, size, device, &args.outputs());
    }
    suite::run(&args.suite())
}
