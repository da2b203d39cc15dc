//! `meshtracer bench`: the paper's tables and the scaling series, printed, and written as
//! JSON/CSV.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use clap::Args;

use crate::bench::report::{self, Report};
use crate::bench::{self, charts, paper_tables, Case, RunOptions};
use crate::gpu::khr_rt::VendorKernel;
use crate::gpu::{ContextOptions, GpuContext};
use crate::render_settings::{self as knobs, Accel, Aov, BvhLayout, RenderSettings};
use crate::scene::paper::ModelSource;
use crate::scene::preset::{self, Loaded};
use crate::scene::spec::SceneSpec;

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
    /// Occlusion rays per pixel for --ao (1..=256).
    #[arg(long, value_name = "N", default_value_t = knobs::DEFAULT_AO_SAMPLES, value_parser = clap::value_parser!(u32).range(1..=knobs::MAX_AO_SAMPLES as i64), allow_negative_numbers = true)]
    pub(crate) ao_samples: u32,
    /// How far --ao's rays look, in scene units (the model has radius 1).
    #[arg(long, value_name = "R", default_value_t = knobs::DEFAULT_AO_RADIUS, value_parser = |s: &str| knobs::AO_RADIUS.parse_f32(s), allow_negative_numbers = true)]
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
    #[arg(long, value_delimiter = ',', default_value = "512,1024", value_parser = clap::value_parser!(u32).range(1..=8192))]
    pub(crate) resolutions: Vec<u32>,
    /// Accelerations to run, comma-separated: brute, bvh, vendor.
    #[arg(long, value_delimiter = ',', default_value = "brute,bvh")]
    pub(crate) accel: Vec<Accel>,
    /// BVH layouts of the bvh rows, comma-separated: binary, wide, wide-runs (each bvh row is traced
    /// with each; with --compare, the vendor's rows follow them). Without it, a preset's
    /// layout, else wide.
    #[arg(long, value_delimiter = ',', default_value = "wide")]
    pub(crate) bvh: Vec<BvhLayout>,
    /// Triangle counts of the generated meshes for --scaling, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "100,1000,10000,100000,1000000,4000000")]
    pub(crate) triangles: Vec<usize>,
    /// Resolution (square) of the --scaling series other than resolution itself.
    #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(1..=8192))]
    pub(crate) size: u32,
    /// Bounces in the triangle series (the paper's 2; 0 = primary rays only).
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(0..=8))]
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
    #[arg(long = "charts-from", value_name = "FILE.json", num_args = 1.., requires = "charts", conflicts_with_all = ["paper", "scaling", "features", "framed", "ao", "json", "csv"])]
    pub(crate) charts_from: Vec<PathBuf>,
    /// Measure the way from each model to its first frame instead (files or names as
    /// --model takes them, e.g. torusknot:10M): each phase (read, parse, build, pack,
    /// upload), the first frame at --size in the paper's scene, the whole wait and the peak
    /// memory; with the binary tree, as the window's first frame, or each --bvh layout given.
    #[arg(long, value_name = "MODEL", num_args = 1.., conflicts_with_all = ["paper", "scaling", "features", "framed", "compare", "charts_from", "preset"])]
    pub(crate) load: Vec<String>,
    /// Benchmark exactly this preset (a TOML preset or a PNG this program wrote), one row
    /// per --accel given (else the preset's); --size and --bounces given beside it
    /// override it.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["paper", "scaling", "features", "framed", "ao", "charts_from"])]
    pub(crate) preset: Option<PathBuf>,
    /// Vulkan device index (see `meshtracer devices`).
    #[arg(long)]
    pub(crate) device: Option<usize>,
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

    /// The rows of `--preset`: the preset as it is, with --size, --bounces and --accel
    /// given beside it over it; and the preset's warnings.
    pub(crate) fn preset_cases(&self, path: &Path) -> anyhow::Result<(Vec<Case>, Vec<String>)> {
        let Loaded { mut spec, warnings } = preset::read(path).map_err(anyhow::Error::msg)?;
        // Frames are timed as colour, as the other rows are.
        spec.settings.aov = Aov::Color;
        if self.given("size") {
            (spec.settings.width, spec.settings.height) = (self.size, self.size);
        }
        if self.given("bounces") {
            spec.settings.bounces = self.bounces;
        }
        spec.validate().map_err(|e| anyhow::anyhow!("preset {}: {e}", path.display()))?;
        let accels =
            if self.given("accel") { self.accel.clone() } else { vec![spec.settings.accel] };
        let cases = accels
            .into_iter()
            .map(|accel| Case {
                series: "preset".into(),
                spec: SceneSpec {
                    settings: RenderSettings { accel, ..spec.settings },
                    ..spec.clone()
                },
                generated: None,
                paper: None,
                features: features_label(&spec),
                vendor_kernel: None,
            })
            .collect();
        Ok((cases, warnings))
    }
}

/// The shading features a preset switches on, named as the feature series names them.
fn features_label(spec: &SceneSpec) -> String {
    let s = &spec.settings;
    let mut on = Vec::new();
    if s.smooth {
        on.push("smooth".to_string());
    }
    if spec.environment.is_some() {
        on.push("env".into());
    }
    if s.spp > 1 {
        on.push(format!("{} {}", if s.adaptive { "adaptive" } else { "spp" }, s.spp));
    }
    if !spec.mirror_box {
        on.push("no box".into());
    }
    on.join(", ")
}

/// Run the benchmark.
pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    if !args.charts_from.is_empty() {
        return charts_from_files(args);
    }
    if !args.load.is_empty() {
        return run_load(args);
    }
    let mut cases = Vec::new();
    let extra: Vec<ModelSource> = args.objs.iter().map(|p| ModelSource::File(p.clone())).collect();
    // --compare adds the vendor's rows to our BVH's (brute force only when asked: on big
    // meshes its frames take minutes); the framed series is BVH-only otherwise.
    let accels: Vec<Accel> = match (args.compare, args.given("accel")) {
        (true, true) => args.accel.iter().copied().filter(|a| *a != Accel::Vendor).collect(),
        (true, false) => vec![Accel::Bvh],
        (false, _) => args.accel.clone(),
    };
    let framed_accels =
        if args.given("accel") || args.compare { accels.clone() } else { vec![Accel::Bvh] };
    if let Some(path) = &args.preset {
        let (preset_cases, warnings) = args.preset_cases(path)?;
        for w in &warnings {
            log::warn!("{w}");
        }
        cases.extend(preset_cases);
    } else if args.paper || !(args.scaling || args.features || args.framed || args.ao) {
        cases.extend(paper_tables::paper_cases(&args.resolutions, &accels));
    }
    if args.scaling {
        cases.extend(paper_tables::scaling_cases(
            &args.triangles,
            &extra,
            &accels,
            args.size,
            args.bounces,
        ));
    }
    if args.framed {
        cases.extend(paper_tables::framed_cases(
            &args.triangles,
            &extra,
            &framed_accels,
            args.size,
        ));
    }
    if args.ao {
        cases.extend(paper_tables::ao_cases(
            &args.triangles,
            &extra,
            &framed_accels,
            args.size,
            args.ao_samples,
            args.ao_radius,
        ));
    }
    if args.features {
        let textured = extra.first().cloned();
        cases.extend(paper_tables::feature_cases(
            args.size,
            ModelSource::Paper(crate::scene::primitives::PaperModel::Sphere),
            textured,
        ));
    }
    let ctx = GpuContext::new(&ContextOptions {
        validation: args.validation,
        device_index: args.device,
        ..Default::default()
    })?;
    let support = &ctx.info.vendor;
    let wants_vendor = args.compare || cases.iter().any(|c| c.spec.settings.accel == Accel::Vendor);
    if wants_vendor && !support.available() {
        anyhow::bail!("{}", support.missing.clone().unwrap_or_default());
    }
    if let Some(k) = args.vendor_kernel.iter().find(|k| !k.supported(support)) {
        anyhow::bail!(
            "{} does not offer the vendor kernel '{k}' (it has: {})",
            ctx.info.name,
            VendorKernel::ALL
                .iter()
                .filter(|k| k.supported(support))
                .map(|k| k.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    let kernels: Vec<Option<VendorKernel>> = match (args.vendor_kernel.is_empty(), args.compare) {
        (false, _) => args.vendor_kernel.iter().copied().map(Some).collect(),
        (true, true) => {
            VendorKernel::ALL.into_iter().filter(|k| k.supported(support)).map(Some).collect()
        }
        (true, false) => vec![None],
    };
    let cases: Vec<Case> = cases
        .into_iter()
        .flat_map(|case| {
            let accel = case.spec.settings.accel;
            let mut out = Vec::new();
            if accel == Accel::Vendor {
                out.extend(kernels.iter().map(|&k| Case { vendor_kernel: k, ..case.clone() }));
            } else if accel == Accel::Bvh && args.given("bvh") {
                for &layout in &args.bvh {
                    let mut ours = case.clone();
                    ours.spec.settings.bvh = layout;
                    out.push(ours);
                }
            } else {
                out.push(case.clone());
            }
            if args.compare && accel == Accel::Bvh {
                for &k in &kernels {
                    let mut vendor = Case { vendor_kernel: k, ..case.clone() };
                    vendor.spec.settings.accel = Accel::Vendor;
                    out.push(vendor);
                }
            }
            out
        })
        .collect();
    let env = bench::environment(&ctx);
    println!(
        "device: {} ({}), driver {}, Vulkan {}, {}",
        env.device, env.device_type, env.driver, env.vulkan, env.date
    );
    println!("{} rows, {} warm-up + {} measured frames each; gpu ms = timestamps around the trace dispatch, frame ms = submit..wait wall clock (medians); MHz = the shader clock during the row (the lower of two probes, before and after; each row first waits for the clock to come up)", cases.len(), args.warmup, args.frames);
    println!("{}", report::header());
    let total = cases.len();
    let progress = std::io::IsTerminal::is_terminal(&std::io::stderr());
    let rows = bench::run(
        &ctx,
        &cases,
        &RunOptions { frames: args.frames, warmup: args.warmup, verbose: args.verbose },
        |i, row| {
            println!("{}", report::format_row(row));
            // Progress only on a terminal: piped or captured stderr stays clean.
            if progress {
                eprint!("\r[{}/{}]\r", i + 1, total);
            }
        },
    )?;
    let mut rows = rows;
    let slow = bench::clocked_down(&rows);
    if !slow.is_empty() {
        let highest = rows.iter().filter_map(|r| r.gpu_clock_mhz).fold(0.0, f64::max);
        let names: Vec<String> = slow
            .iter()
            .map(|r| {
                format!(
                    "{} {} {} ({:.0} MHz)",
                    r.series,
                    r.workload.model,
                    r.workload.accel,
                    r.gpu_clock_mhz.unwrap_or_default()
                )
            })
            .collect();
        println!(
            "\nnote: {} row(s) ran with the GPU clocked below {:.0}% of this run's highest shader clock ({highest:.0} MHz), so their times are the clock's, not the tracer's; run them again: {}",
            slow.len(),
            bench::clock_guard::CLOCKED_DOWN * 100.0,
            names.join(", ")
        );
    }
    if args.compare {
        bench::pair_with_vendor(&mut rows);
        println!("\nours (BVH) / vendor, GPU ms medians (below 1: ours is faster):");
        print!("{}", report::compare_table(&rows));
    }
    let messages = ctx.validation_messages();
    if !messages.is_empty() {
        anyhow::bail!(
            "the Vulkan validation layer reported {} problem(s), the first: {}",
            messages.len(),
            messages[0]
        );
    }
    if let Some(path) = &args.json {
        report::write_json(
            path,
            &Report { environment: &env, frames: args.frames, warmup: args.warmup, rows: &rows },
        )?;
        println!("wrote {}", path.display());
    }
    if let Some(path) = &args.csv {
        report::write_csv(path, &env, &rows)?;
        println!("wrote {}", path.display());
    }
    if let Some(dir) = &args.charts {
        for path in charts::write_charts(dir, std::slice::from_ref(&env), &rows)? {
            println!("wrote {}", path.display());
        }
    }
    Ok(())
}

/// `--load MODEL...`: each model's way to its first frame, one row each, one tracer for all.
fn run_load(args: &BenchArgs) -> anyhow::Result<()> {
    let ctx = GpuContext::new(&ContextOptions {
        validation: args.validation,
        device_index: args.device,
        ..Default::default()
    })?;
    let env = bench::environment(&ctx);
    println!(
        "device: {} ({}), driver {}, Vulkan {}, {}",
        env.device, env.device_type, env.driver, env.vulkan, env.date
    );
    println!("each model in the paper's mirror box at {0}x{0}, {1} bounces: phase times, the first frame's GPU time, read start to first frame, peak memory (and beyond the file's size, per triangle)", args.size, args.bounces);
    let mut tracer = crate::gpu::ComputeTracer::new(&ctx, 0)?;
    let mut rows = Vec::new();
    // The window's first frame is the binary tree's (it loads the wide one after): the
    // default here too; `--bvh` loads those layouts instead, one row each.
    let layouts = if args.given("bvh") { args.bvh.clone() } else { vec![BvhLayout::Binary] };
    for name in &args.load {
        for &layout in &layouts {
            let mut spec = SceneSpec { model: ModelSource::parse(name), ..SceneSpec::default() };
            (spec.settings.width, spec.settings.height, spec.settings.bounces, spec.settings.bvh) =
                (args.size, args.size, args.bounces, layout);
            rows.push(
                bench::load::measure(&spec, &mut tracer)
                    .map_err(|e| anyhow::anyhow!("{name}: {e:#}"))?,
            );
        }
    }
    print!("{}", bench::load::table(&rows));
    let messages = ctx.validation_messages();
    if !messages.is_empty() {
        anyhow::bail!(
            "the Vulkan validation layer reported {} problem(s), the first: {}",
            messages.len(),
            messages[0]
        );
    }
    if let Some(path) = &args.json {
        let text = serde_json::to_string_pretty(&bench::load::LoadReport {
            environment: &env,
            rows: &rows,
        })?;
        bench::load::write(path, &text)?;
        println!("wrote {}", path.display());
    }
    if let Some(path) = &args.csv {
        bench::load::write(path, &bench::load::csv(&env, &rows))?;
        println!("wrote {}", path.display());
    }
    Ok(())
}

/// `--charts-from FILE.json ... --charts DIR`: the charts of saved reports, no GPU needed.
fn charts_from_files(args: &BenchArgs) -> anyhow::Result<()> {
    let dir =
        args.charts.as_ref().ok_or_else(|| anyhow::anyhow!("--charts-from needs --charts DIR"))?;
    let mut environments = Vec::new();
    let mut rows = Vec::new();
    for path in &args.charts_from {
        let saved = charts::load_report(path)?;
        println!(
            "{}: {} rows ({}, {})",
            path.display(),
            saved.rows.len(),
            saved.environment.device,
            saved.environment.date
        );
        environments.push(saved.environment);
        rows.extend(saved.rows);
    }
    for path in charts::write_charts(dir, &environments, &rows)? {
        println!("wrote {}", path.display());
    }
    Ok(())
}
