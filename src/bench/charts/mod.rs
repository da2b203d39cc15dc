//! Benchmark charts as PNG files (plotters' bitmap backend, encoded with `image`):
//!
//! - `chart_triangles.png`: GPU ms per frame against triangle count, log-log, for each
//!   acceleration, with the paper's Table 1 at 1024² and a 30 fps line;
//! - `chart_resolution.png`: GPU ms against pixels per frame (log axis, ticks at the
//!   measured resolutions), with the paper's 512²/1024² pairs of Table 1;
//! - `chart_models.png`: GPU ms against the number of model copies, with the paper's
//!   Table 2.
//!
//! The rows come from a run (`bench --charts DIR`) or from saved JSON reports
//! (`bench --charts-from FILE.json ... --charts DIR`); skipped rows and rows without GPU
//! timestamps are left out. Text uses the DejaVu Sans embedded from `assets/fonts/`, so no
//! system font is needed.

mod axes;
mod chart;
mod draw;

use std::path::{Path, PathBuf};

use anyhow::Context;
use plotters::style::{RGBColor, BLACK};
use serde::Deserialize;

use self::chart::{Chart, Line, Marker, Series, XAxis, GREY_};
use self::draw::render;
use super::paper_tables::{TABLE1, TABLE2};
use super::{Environment, Row};
use crate::render_settings::Accel;
use crate::scene::primitives::PaperModel;

/// The files [`write_charts`] writes, in order.
pub const CHART_FILES: [&str; 3] =
    ["chart_triangles.png", "chart_resolution.png", "chart_models.png"];

/// The parts of a saved run (as `bench --json` writes it) that the charts draw; the other
/// keys (`frames`, `warmup`, a hand-made file's `note`) are read past.
#[derive(Clone, Debug, Deserialize)]
pub struct SavedReport {
    pub environment: Environment,
    pub rows: Vec<Row>,
}

/// Read a report written by `bench --json`.
pub fn load_report(path: &Path) -> anyhow::Result<SavedReport> {
    let text = crate::files::read_text(path)
        .with_context(|| format!("cannot read {}", crate::files::shown_path(path)))?;
    serde_json::from_str(&text)
        .with_context(|| format!("{} is not a bench JSON report", crate::files::shown_path(path)))
}

/// Draw the three charts of `rows` into `dir` (created if missing); `environments` name
/// the machines in the titles. Returns the files written.
pub fn write_charts(
    dir: &Path,
    environments: &[Environment],
    rows: &[Row],
) -> anyhow::Result<Vec<PathBuf>> {
    crate::files::create_folder(dir)
        .with_context(|| format!("cannot create {}", crate::files::shown_path(dir)))?;
    let machine = machine_line(environments);
    let charts = [
        triangles_chart(rows, &machine),
        resolution_chart(rows, &machine),
        models_chart(rows, &machine),
    ];
    let mut written = Vec::new();
    for (chart, name) in charts.iter().zip(CHART_FILES) {
        let path = dir.join(name);
        render(chart, &path)
            .with_context(|| format!("cannot draw {}", crate::files::shown_path(&path)))?;
        written.push(path);
    }
    Ok(written)
}

const BLUE_: RGBColor = RGBColor(31, 100, 180);
const RED_: RGBColor = RGBColor(205, 40, 40);
const PURPLE_: RGBColor = RGBColor(130, 60, 170);
const BVH_SHADES: [RGBColor; 4] =
    [BLUE_, RGBColor(0, 150, 150), RGBColor(90, 140, 230), RGBColor(20, 50, 110)];
const BRUTE_SHADES: [RGBColor; 4] =
    [RED_, RGBColor(230, 130, 0), RGBColor(240, 110, 110), RGBColor(120, 30, 30)];
const VENDOR_SHADES: [RGBColor; 4] =
    [RGBColor(40, 150, 60), RGBColor(120, 170, 40), RGBColor(60, 200, 120), RGBColor(20, 90, 40)];

/// The n-th colour of an acceleration's family (blues for the BVH, reds for brute force).
fn accel_color(accel: Accel, n: usize) -> RGBColor {
    let shades = match accel {
        Accel::Bvh => &BVH_SHADES,
        Accel::Brute => &BRUTE_SHADES,
        Accel::Vendor => &VENDOR_SHADES,
    };
    shades[n % shades.len()]
}

/// The paper's model that a row's model name is: spelled exactly as [`PaperModel::name`],
/// as the rows spell it (a file `Sphere.obj` is not the paper's sphere).
fn paper_model(name: &str) -> Option<PaperModel> {
    PaperModel::from_name(name).filter(|m| m.name() == name)
}

/// The colour of one of the paper's models.
fn paper_model_color(model: PaperModel) -> RGBColor {
    match model {
        PaperModel::Geosphere => RGBColor(31, 100, 180),
        PaperModel::TorusKnot => RGBColor(230, 120, 0),
        PaperModel::Sphere => RGBColor(40, 150, 60),
        PaperModel::Cylinder => RGBColor(205, 40, 40),
    }
}

/// One colour per model of the paper (others from a spare palette).
fn model_color(model: &str, others: &mut Vec<String>) -> RGBColor {
    if let Some(paper) = paper_model(model) {
        return paper_model_color(paper);
    }
    let i = others.iter().position(|m| m == model).unwrap_or_else(|| {
        others.push(model.to_string());
        others.len() - 1
    });
    [PURPLE_, RGBColor(140, 90, 40), RGBColor(200, 80, 170), GREY_][i % 4]
}

fn accel_marker(accel: Accel) -> Marker {
    match accel {
        Accel::Brute => Marker::Square,
        Accel::Bvh => Marker::Circle,
        Accel::Vendor => Marker::Triangle,
    }
}

fn accel_name(accel: Accel) -> &'static str {
    match accel {
        Accel::Bvh => "BVH",
        Accel::Brute => "brute force",
        Accel::Vendor => "vendor",
    }
}

/// Brute force before the BVH in legends, as in the paper's tables.
fn accel_order(accel: Accel) -> u8 {
    match accel {
        Accel::Brute => 0,
        Accel::Bvh => 1,
        Accel::Vendor => 2,
    }
}

fn res_label(w: u32, h: u32) -> String {
    if w == h {
        format!("{w}²")
    } else {
        format!("{w}x{h}")
    }
}

fn gpu_ms(r: &Row) -> Option<f64> {
    if r.skipped.is_some() {
        return None;
    }
    r.gpu_ms.map(|g| g.median).filter(|v| v.is_finite() && *v > 0.0)
}

/// "NVIDIA H100 80GB HBM3, 2026-11-22" (several machines or dates joined).
fn machine_line(environments: &[Environment]) -> String {
    let mut devices: Vec<&str> = Vec::new();
    let mut dates: Vec<&str> = Vec::new();
    for e in environments {
        if !devices.contains(&e.device.as_str()) {
            devices.push(&e.device);
        }
        if !dates.contains(&e.date.as_str()) {
            dates.push(&e.date);
        }
    }
    dates.sort();
    format!("{}, {}", devices.join(" / "), dates.join(" / "))
}

/// Series keyed by their acceleration and `K` (what else sets them apart in a chart), in
/// order of first appearance.
struct Groups<K>(Vec<(Accel, K, Series)>);

impl<K> Default for Groups<K> {
    fn default() -> Self {
        Self(Vec::new())
    }
}

impl<K: PartialEq> Groups<K> {
    fn get(&mut self, accel: Accel, key: K, make: impl FnOnce(&Self) -> Series) -> &mut Series {
        match self.0.iter().position(|(a, k, _)| *a == accel && *k == key) {
            Some(i) => &mut self.0[i].2,
            None => {
                let s = make(self);
                self.0.push((accel, key, s));
                &mut self.0.last_mut().unwrap().2
            }
        }
    }

    /// How many series of `accel` there are so far (to pick the next shade).
    fn count_accel(&self, accel: Accel) -> usize {
        self.0.iter().filter(|(a, _, _)| *a == accel).count()
    }

    fn into_series(self) -> Vec<Series> {
        self.0.into_iter().map(|(_, _, s)| s).collect()
    }
}

/// What sets a series of the triangle chart apart, besides its acceleration.
#[derive(Clone, Copy, Debug, PartialEq)]
enum TriangleSeries {
    /// The scaling rows: generated torus knots (a line) or .obj models (labelled points).
    Scaling { generated: bool, width: u32, height: u32, bounces: u32 },
    /// Our Table 1 rows.
    Table1 { bounces: u32 },
}

fn bounces_note(b: u32) -> String {
    if b == 1 {
        "1 bounce".into()
    } else {
        format!("{b} bounces")
    }
}

const SUBTITLE: &str = "GPU time per frame: median of Vulkan timestamps around the trace dispatch. Paper: GTX 1080 Ti, brute force, 2 bounces.";

fn triangles_chart(rows: &[Row], machine: &str) -> Chart {
    let mut groups = Groups::default();
    for r in rows.iter().filter(|r| r.series == "triangles") {
        let Some(ms) = gpu_ms(r) else { continue };
        // Generated meshes are named `torusknot-<triangles>` (`ModelSource::label`).
        let generated = r.workload.model.starts_with("torusknot-");
        let key = TriangleSeries::Scaling {
            generated,
            width: r.workload.width,
            height: r.workload.height,
            bounces: r.workload.bounces,
        };
        let accel = r.workload.accel;
        let what = if generated { "torus knots" } else { ".obj models" };
        let label = format!(
            "ours, {}: {what}, {}, {}",
            accel_name(accel),
            res_label(r.workload.width, r.workload.height),
            bounces_note(r.workload.bounces)
        );
        let s = groups.get(accel, key, |g| {
            if generated {
                Series::new(
                    label,
                    accel_color(accel, g.count_accel(accel)),
                    Line::Solid,
                    accel_marker(accel),
                )
            } else {
                // .obj models as labelled points in purples and greens, apart from the lines.
                let n =
                    g.0.iter()
                        .filter(|(a, _, s)| *a == accel && s.marker == Marker::Diamond)
                        .count();
                let shades = match accel {
                    Accel::Brute => [RGBColor(150, 110, 40), RGBColor(200, 80, 170)],
                    Accel::Bvh => [PURPLE_, RGBColor(40, 140, 60)],
                    Accel::Vendor => [RGBColor(20, 120, 20), RGBColor(100, 160, 60)],
                };
                Series::new(label, shades[n % 2], Line::None, Marker::Diamond)
            }
        });
        s.push(r.workload.triangles as f64, ms, (!generated).then(|| r.workload.model.clone()));
    }
    // Our Table 1 rows at their largest resolution, as points beside the paper's.
    let table1: Vec<&Row> =
        rows.iter().filter(|r| r.series == "table1" && gpu_ms(r).is_some()).collect();
    if let Some(size) =
        table1.iter().map(|r| r.workload.width as u64 * r.workload.height as u64).max()
    {
        for r in
            table1.iter().filter(|r| r.workload.width as u64 * r.workload.height as u64 == size)
        {
            let accel = r.workload.accel;
            let label = format!(
                "ours, {}: Table 1 models, {}, {}",
                accel_name(accel),
                res_label(r.workload.width, r.workload.height),
                bounces_note(r.workload.bounces)
            );
            let key = TriangleSeries::Table1 { bounces: r.workload.bounces };
            let s = groups.get(accel, key, |g| {
                Series::new(
                    label,
                    accel_color(accel, g.count_accel(accel) + 1),
                    Line::None,
                    accel_marker(accel),
                )
            });
            s.push(r.workload.triangles as f64, gpu_ms(r).unwrap(), None);
        }
    }
    let mut series = groups.into_series();
    let mut paper = Series::new(
        "paper: Table 1 at 1024² (triangles as listed)".into(),
        BLACK,
        Line::Dashed,
        Marker::Triangle,
    );
    for (model, figures) in TABLE1 {
        paper.push(model.paper_counts().1 as f64, figures[1].1, None);
    }
    series.push(paper);
    Chart {
        title: format!("Frame time against triangle count — {machine}"),
        subtitle: SUBTITLE.into(),
        x_desc: "triangles in the scene (log)".into(),
        y_desc: "GPU ms per frame (log)".into(),
        x_axis: XAxis::Count,
        series,
        hlines: vec![(1000.0 / 30.0, "30 fps (33.3 ms)".into())],
    }
}

fn resolution_chart(rows: &[Row], machine: &str) -> Chart {
    let mut others = Vec::new();
    let mut groups = Groups::default();
    for r in rows.iter().filter(|r| r.series == "resolution" || r.series == "table1") {
        let Some(ms) = gpu_ms(r) else { continue };
        // (model, copies, bounces)
        let key = (r.workload.model.clone(), r.workload.models, r.workload.bounces);
        let copies =
            if r.workload.models > 1 { format!(" x{}", r.workload.models) } else { String::new() };
        let extra = if r.workload.bounces != 2 {
            format!(", {}", bounces_note(r.workload.bounces))
        } else {
            String::new()
        };
        let label =
            format!("ours, {}: {}{copies}{extra}", accel_name(r.workload.accel), r.workload.model);
        let color = model_color(&r.workload.model, &mut others);
        let s = groups.get(r.workload.accel, key, |_| {
            Series::new(label, color, Line::Solid, accel_marker(r.workload.accel))
        });
        s.push(r.workload.width as f64 * r.workload.height as f64, ms, None);
    }
    let mut series = Vec::new();
    for (model, figures) in TABLE1 {
        let mut s = Series::new(
            format!("paper: {}", model.name()),
            paper_model_color(model),
            Line::Dashed,
            Marker::Triangle,
        );
        s.push(512.0 * 512.0, figures[0].1, None);
        s.push(1024.0 * 1024.0, figures[1].1, None);
        series.push(s);
    }
    // Brute force before the BVH in the legend, as in the tables.
    groups.0.sort_by_key(|(accel, (model, _, _), _)| {
        let model = paper_model(model)
            .and_then(|m| TABLE1.iter().position(|(t, _)| *t == m))
            .unwrap_or(TABLE1.len());
        (accel_order(*accel), model)
    });
    series.extend(groups.into_series());
    Chart {
        title: format!("Frame time against resolution — {machine}"),
        subtitle: SUBTITLE.into(),
        x_desc: "pixels per frame (log)".into(),
        y_desc: "GPU ms per frame (log)".into(),
        x_axis: XAxis::Pixels,
        series,
        hlines: Vec::new(),
    }
}

fn models_chart(rows: &[Row], machine: &str) -> Chart {
    let mut groups = Groups::default();
    let mut sizes: Vec<(u32, u32)> = Vec::new();
    for r in rows.iter().filter(|r| r.series == "models" || r.series == "table2") {
        let Some(ms) = gpu_ms(r) else { continue };
        if !sizes.contains(&(r.workload.width, r.workload.height)) {
            sizes.push((r.workload.width, r.workload.height));
        }
        // (model, (width, height), bounces)
        let key =
            (r.workload.model.clone(), (r.workload.width, r.workload.height), r.workload.bounces);
        let label = format!(
            "ours, {}: {} copies, {}, {}",
            accel_name(r.workload.accel),
            r.workload.model,
            res_label(r.workload.width, r.workload.height),
            bounces_note(r.workload.bounces)
        );
        let s = groups.get(r.workload.accel, key, |_| {
            Series::new(label, BLACK, Line::Solid, accel_marker(r.workload.accel))
        });
        s.push(r.workload.models as f64, ms, None);
    }
    // Brute force first, then the largest resolution first within each acceleration, each
    // acceleration in its family of colours.
    groups.0.sort_by_key(|(accel, (_, (w, h), bounces), _)| {
        (accel_order(*accel), std::cmp::Reverse(*w as u64 * *h as u64), *bounces)
    });
    let mut shade = std::collections::HashMap::<Accel, usize>::new();
    for (accel, _, s) in &mut groups.0 {
        let n = shade.entry(*accel).or_insert(0);
        s.color = accel_color(*accel, *n);
        *n += 1;
    }
    let mut series = Vec::new();
    // The paper at 1024² always, at 512² when we have rows there too.
    for (i, size) in [1024u32, 512].into_iter().enumerate() {
        if i > 0 && !sizes.contains(&(size, size)) {
            continue;
        }
        let mut s = Series::new(
            format!("paper: Table 2, geosphere copies, {size}²"),
            if i == 0 { BLACK } else { GREY_ },
            Line::Dashed,
            Marker::Triangle,
        );
        for (count, figures) in TABLE2 {
            s.push(count as f64, figures[1 - i].1, None);
        }
        series.push(s);
    }
    series.extend(groups.into_series());
    Chart {
        title: format!("Frame time against model copies — {machine}"),
        subtitle: SUBTITLE.into(),
        x_desc: "copies of the model in the scene (log)".into(),
        y_desc: "GPU ms per frame (log)".into(),
        x_axis: XAxis::Copies,
        series,
        hlines: Vec::new(),
    }
}
