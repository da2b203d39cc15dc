//! A `bench` run from its options to its printed table and files: which rows the series
//! asked for make ([`planned_cases`]), each row once per vendor kernel and BVH layout
//! ([`expand_cases`]), the rows run and printed, the notes, comparison and files after.

use std::path::{Path, PathBuf};

use super::report::{self, Report};
use super::{charts, fields, paper_tables, Case, Environment, Row, RunOptions};
use crate::gpu::headless::{check_validation, open_context};
use crate::gpu::khr_rt::VendorKernel;
use crate::gpu::GpuContext;
use crate::render_settings::{Accel, Aov, BvhLayout, RenderSettings};
use crate::scene::paper::ModelSource;
use crate::scene::preset::{self, Loaded};
use crate::scene::spec::SceneSpec;
use crate::tracer::packed::BvhBuilder;

/// What a `bench` run measures and writes (the command line's flags; `*_given`: the flag
/// was given, not left at its default).
#[derive(Clone, Debug)]
pub struct Suite {
    /// The paper's Table 1 and Table 2.
    pub paper: bool,
    /// Frame time against triangles, resolution, bounces and model count.
    pub scaling: bool,
    /// The cost of each shading feature.
    pub features: bool,
    /// Primary rays with the camera moved in until the model fills the frame.
    pub framed: bool,
    /// Every row with our BVH and the vendor's ray tracing, and their ratio.
    pub compare: bool,
    /// The AO view on the framed series' scenes.
    pub ao: bool,
    /// 10,000 copies of a knot against one copy at the same coverage.
    pub fields: bool,
    /// Occlusion rays per pixel for `ao`.
    pub ao_samples: u32,
    /// How far `ao`'s rays look.
    pub ao_radius: f32,
    /// How vendor rows trace the driver's structures (empty: the default or, comparing, all).
    pub vendor_kernels: Vec<VendorKernel>,
    /// Measured and warm-up frames per row, and the verbose reports.
    pub run: RunOptions,
    /// Resolutions (square) of the paper's tables.
    pub resolutions: Vec<u32>,
    /// Accelerations to run.
    pub accel: Vec<Accel>,
    /// Whether `accel` was given.
    pub accel_given: bool,
    /// BVH layouts of the bvh rows.
    pub bvh: Vec<BvhLayout>,
    /// Whether `bvh` was given.
    pub bvh_given: bool,
    /// Triangle counts of the generated meshes.
    pub triangles: Vec<usize>,
    /// Whether `triangles` was given.
    pub triangles_given: bool,
    /// Resolution (square) of the series other than the paper's.
    pub size: u32,
    /// Whether `size` was given.
    pub size_given: bool,
    /// Bounces of the triangle series.
    pub bounces: u32,
    /// Whether `bounces` was given.
    pub bounces_given: bool,
    /// Extra model files for the triangle series.
    pub models: Vec<PathBuf>,
    /// Benchmark exactly this preset instead of the series.
    pub preset: Option<PathBuf>,
    /// Vulkan device index.
    pub device: Option<usize>,
    /// Turn on the Vulkan validation layer.
    pub validation: bool,
    /// Where the rows go besides the terminal.
    pub outputs: Outputs,
}

/// The files a run writes its rows to.
#[derive(Clone, Debug, Default)]
pub struct Outputs {
    /// All rows as JSON.
    pub json: Option<PathBuf>,
    /// All rows as CSV.
    pub csv: Option<PathBuf>,
    /// A folder for PNG charts.
    pub charts: Option<PathBuf>,
}

/// Run the series `suite` asks for, print the rows as they come, then the notes and the
/// comparison, and write the files.
pub fn run(suite: &Suite) -> anyhow::Result<()> {
    let cases = planned_cases(suite)?;
    let ctx = open_context(suite.device, suite.validation)?;
    let kernels = vendor_kernels(&ctx, suite, &cases)?;
    let cases = expand_cases(cases, &kernels, suite);
    let env = super::environment(&ctx);
    print_device(&env);
    println!("{} rows, {} warm-up + {} measured frames each; gpu ms = timestamps around the trace dispatch, frame ms = submit..wait wall clock (medians); MHz = the shader clock during the row (the lower of two probes, before and after; each row first waits for the clock to come up)", cases.len(), suite.run.warmup, suite.run.frames);
    println!("{}", report::header());
    let total = cases.len();
    let progress = std::io::IsTerminal::is_terminal(&std::io::stderr());
    let mut rows = super::run(&ctx, &cases, &suite.run, |i, row| {
        println!("{}", report::format_row(row));
        // Progress only on a terminal: piped or captured stderr stays clean.
        if progress {
            eprint!("\r[{}/{}]\r", i + 1, total);
        }
    })?;
    note_clocked_down(&rows);
    if suite.compare {
        super::pair_with_vendor(&mut rows);
        println!("\nours (BVH) / vendor, GPU ms medians (below 1: ours is faster):");
        print!("{}", report::compare_table(&rows));
    }
    let fields = fields::summary(&rows);
    if !fields.is_empty() {
        println!(
            "\nfields: 10,000 copies against one at the same share of the frame (GPU ms medians):"
        );
        for line in fields {
            println!("  {line}");
        }
    }
    check_validation(&ctx)?;
    write_outputs(&suite.outputs, &env, &suite.run, &rows)
}

/// The device line every run starts with.
pub(crate) fn print_device(env: &Environment) {
    println!(
        "device: {} ({}), driver {}, Vulkan {}, {}",
        env.device, env.device_type, env.driver, env.vulkan, env.date
    );
}

/// The rows of the series asked for, before the vendor kernels and layouts multiply them:
/// a preset's, else the paper's tables unless only other series are asked for.
pub fn planned_cases(suite: &Suite) -> anyhow::Result<Vec<Case>> {
    let mut cases = Vec::new();
    let extra: Vec<ModelSource> =
        suite.models.iter().map(|p| ModelSource::File(p.clone())).collect();
    // --compare adds the vendor's rows to our BVH's (brute force only when asked: on big
    // meshes its frames take minutes); the framed series is BVH-only otherwise.
    let accels: Vec<Accel> = match (suite.compare, suite.accel_given) {
        (true, true) => suite.accel.iter().copied().filter(|a| *a != Accel::Vendor).collect(),
        (true, false) => vec![Accel::Bvh],
        (false, _) => suite.accel.clone(),
    };
    let framed_accels =
        if suite.accel_given || suite.compare { accels.clone() } else { vec![Accel::Bvh] };
    let (size, triangles) = (suite.size, &suite.triangles);
    if let Some(path) = &suite.preset {
        let (preset_cases, warnings) = preset_cases(suite, path)?;
        for w in &warnings {
            log::warn!("{w}");
        }
        cases.extend(preset_cases);
    } else if suite.paper
        || !(suite.scaling || suite.features || suite.framed || suite.ao || suite.fields)
    {
        cases.extend(paper_tables::paper_cases(&suite.resolutions, &accels));
    }
    if suite.scaling {
        let bounces = suite.bounces;
        cases.extend(paper_tables::scaling_cases(triangles, &extra, &accels, size, bounces));
    }
    if suite.framed {
        cases.extend(paper_tables::framed_cases(triangles, &extra, &framed_accels, size));
    }
    if suite.ao {
        let (samples, radius) = (suite.ao_samples, suite.ao_radius);
        let ao = paper_tables::ao_cases(triangles, &extra, &framed_accels, size, samples, radius);
        cases.extend(ao);
    }
    if suite.fields {
        // One knot unless asked: a field of the default series' 4M knot is 4 * 10^10
        // triangles, and its small ones say little.
        let knots =
            if suite.triangles_given { triangles.clone() } else { vec![fields::DEFAULT_TRIANGLES] };
        cases.extend(fields::field_cases(&knots, &framed_accels, size));
    }
    if suite.features {
        let textured = extra.first().cloned();
        let sphere = ModelSource::Paper(crate::scene::primitives::PaperModel::Sphere);
        cases.extend(paper_tables::feature_cases(size, sphere, textured));
    }
    Ok(cases)
}

/// The rows of a preset: the preset as it is, with the size, bounces and accelerations
/// given beside it over it; and the preset's warnings.
pub fn preset_cases(suite: &Suite, path: &Path) -> anyhow::Result<(Vec<Case>, Vec<String>)> {
    let Loaded { mut spec, warnings } = preset::read(path).map_err(anyhow::Error::msg)?;
    // Frames are timed as colour, as the other rows are, but for the AO view, a tracer
    // workload of its own (`--ao`'s rows): a preset saved in it times its occlusion rays.
    if spec.settings.aov != Aov::Ao {
        spec.settings.aov = Aov::Color;
    }
    if suite.size_given {
        (spec.settings.width, spec.settings.height) = (suite.size, suite.size);
    }
    if suite.bounces_given {
        spec.settings.bounces = suite.bounces;
    }
    spec.validate()
        .map_err(|e| anyhow::anyhow!("preset {}: {e}", crate::files::shown_path(path)))?;
    let accels = if suite.accel_given { suite.accel.clone() } else { vec![spec.settings.accel] };
    let cases = accels
        .into_iter()
        .map(|accel| Case {
            series: "preset".into(),
            spec: SceneSpec { settings: RenderSettings { accel, ..spec.settings }, ..spec.clone() },
            generated: None,
            paper: None,
            features: features_label(&spec),
            vendor_kernel: None,
            coverage: super::Coverage::Unmeasured,
        })
        .collect();
    Ok((cases, warnings))
}

/// The shading features a preset switches on, named as the feature series names them.
fn features_label(spec: &SceneSpec) -> String {
    let s = &spec.settings;
    let mut on = Vec::new();
    if s.aov == Aov::Ao {
        on.push(format!("ao {} rays, r {}", s.ao_samples, s.ao_radius));
    }
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

/// The vendor kernels the vendor rows run (None: the device's default), after checking
/// that the device has the vendor's ray tracing where a row needs it, and each kernel asked.
fn vendor_kernels(
    ctx: &GpuContext,
    suite: &Suite,
    cases: &[Case],
) -> anyhow::Result<Vec<Option<VendorKernel>>> {
    let support = &ctx.info.vendor;
    let wants_vendor =
        suite.compare || cases.iter().any(|c| c.spec.settings.accel == Accel::Vendor);
    if wants_vendor && !support.available() {
        anyhow::bail!("{}", support.missing.clone().unwrap_or_default());
    }
    let offered = || VendorKernel::ALL.into_iter().filter(|k| k.supported(support));
    if let Some(k) = suite.vendor_kernels.iter().find(|k| !k.supported(support)) {
        let names: Vec<String> = offered().map(|k| k.to_string()).collect();
        anyhow::bail!(
            "{} does not offer the vendor kernel '{k}' (it has: {})",
            ctx.info.name,
            names.join(", ")
        );
    }
    Ok(match (suite.vendor_kernels.is_empty(), suite.compare) {
        (false, _) => suite.vendor_kernels.iter().copied().map(Some).collect(),
        (true, true) => offered().map(Some).collect(),
        (true, false) => vec![None],
    })
}

/// Each vendor row once per kernel, each bvh row once per layout given, and comparing, the
/// vendor's rows after each of ours.
pub fn expand_cases(
    cases: Vec<Case>,
    kernels: &[Option<VendorKernel>],
    suite: &Suite,
) -> Vec<Case> {
    let expand = |case: Case| {
        let accel = case.spec.settings.accel;
        let mut out = Vec::new();
        if accel == Accel::Vendor {
            out.extend(kernels.iter().map(|&k| Case { vendor_kernel: k, ..case.clone() }));
        } else if accel == Accel::Bvh && suite.bvh_given {
            for &layout in &suite.bvh {
                let mut ours = case.clone();
                ours.spec.settings.bvh = layout;
                out.push(ours);
            }
        } else {
            out.push(case.clone());
        }
        if suite.compare && accel == Accel::Bvh {
            for &k in kernels {
                let mut vendor = Case { vendor_kernel: k, ..case.clone() };
                vendor.spec.settings.accel = Accel::Vendor;
                out.push(vendor);
            }
        }
        out
    };
    cases.into_iter().flat_map(expand).collect()
}

/// Name the rows that ran with the GPU clocked down, whose times are the clock's.
fn note_clocked_down(rows: &[Row]) {
    let slow = super::clocked_down(rows);
    if slow.is_empty() {
        return;
    }
    let highest = rows.iter().filter_map(|r| r.gpu_clock_mhz).fold(0.0, f64::max);
    let names: Vec<String> = slow
        .iter()
        .map(|r| {
            let (w, mhz) = (&r.workload, r.gpu_clock_mhz.unwrap_or_default());
            format!("{} {} {} ({mhz:.0} MHz)", r.series, w.model, w.accel)
        })
        .collect();
    println!(
        "\nnote: {} row(s) ran with the GPU clocked below {:.0}% of this run's highest shader clock ({highest:.0} MHz), so their times are the clock's, not the tracer's; run them again: {}",
        slow.len(),
        super::clock_guard::CLOCKED_DOWN * 100.0,
        names.join(", ")
    );
}

/// Write the rows as JSON, CSV and charts where asked, naming each file written.
fn write_outputs(
    outputs: &Outputs,
    env: &Environment,
    run: &RunOptions,
    rows: &[Row],
) -> anyhow::Result<()> {
    if let Some(path) = &outputs.json {
        let (frames, warmup) = (run.frames, run.warmup);
        report::write_json(path, &Report { environment: env, frames, warmup, rows })?;
        println!("wrote {}", crate::files::shown_path(path));
    }
    if let Some(path) = &outputs.csv {
        report::write_csv(path, env, rows)?;
        println!("wrote {}", crate::files::shown_path(path));
    }
    if let Some(dir) = &outputs.charts {
        for path in charts::write_charts(dir, std::slice::from_ref(env), rows)? {
            println!("wrote {}", crate::files::shown_path(&path));
        }
    }
    Ok(())
}

/// The charts of saved `--json` reports, drawn into `dir`: no GPU needed.
pub fn charts_from_reports(reports: &[PathBuf], dir: &Path) -> anyhow::Result<()> {
    let mut environments = Vec::new();
    let mut rows = Vec::new();
    for path in reports {
        let saved = charts::load_report(path)?;
        println!(
            "{}: {} rows ({}, {})",
            crate::files::shown_path(path),
            saved.rows.len(),
            saved.environment.device,
            saved.environment.date
        );
        environments.push(saved.environment);
        rows.extend(saved.rows);
    }
    for path in charts::write_charts(dir, &environments, &rows)? {
        println!("wrote {}", crate::files::shown_path(&path));
    }
    Ok(())
}

/// `--load`: each model's way to its first frame at `size` and `bounces`, one row per
/// model and layout (`layouts`), one tracer for all; the table printed, JSON and CSV written.
pub fn run_loads(
    models: &[String],
    layouts: &[BvhLayout],
    (size, bounces): (u32, u32),
    (device, validation, builder): (Option<usize>, bool, BvhBuilder),
    outputs: &Outputs,
) -> anyhow::Result<()> {
    let ctx = open_context(device, validation)?;
    let env = super::environment(&ctx);
    print_device(&env);
    println!("each model in the paper's mirror box at {size}x{size}, {bounces} bounces: phase times, the first frame's GPU time, read start to first frame, peak memory (and beyond the file's size, per triangle)");
    let mut tracer = crate::gpu::ComputeTracer::new(&ctx, 0)?;
    let mut rows = Vec::new();
    for name in models {
        for &layout in layouts {
            let mut spec = SceneSpec { model: ModelSource::parse(name), ..SceneSpec::default() };
            let s = &mut spec.settings;
            (s.width, s.height, s.bounces, s.bvh) = (size, size, bounces, layout);
            let row = super::load::measure(&spec, &mut tracer, ctx.info.fit(builder));
            rows.push(row.map_err(|e| anyhow::anyhow!("{name}: {e:#}"))?);
        }
    }
    print!("{}", super::load::table(&rows));
    check_validation(&ctx)?;
    if let Some(path) = &outputs.json {
        let report = super::load::LoadReport { environment: &env, rows: &rows };
        super::load::write(path, &serde_json::to_string_pretty(&report)?)?;
        println!("wrote {}", crate::files::shown_path(path));
    }
    if let Some(path) = &outputs.csv {
        super::load::write(path, &super::load::csv(&env, &rows))?;
        println!("wrote {}", crate::files::shown_path(path));
    }
    Ok(())
}
