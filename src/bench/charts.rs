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

use std::path::{Path, PathBuf};
use std::sync::Once;

use anyhow::{anyhow, Context};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};
use serde::Deserialize;

use super::paper_tables::{TABLE1, TABLE2};
use super::{Environment, Row};

/// DejaVu Sans 2.37 (Bitstream Vera licence, see assets/fonts/LICENSE-DejaVu.txt).
const FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");
const FAMILY: &str = "sans-serif";

/// The files [`write_charts`] writes, in order.
pub const CHART_FILES: [&str; 3] = ["chart_triangles.png", "chart_resolution.png", "chart_models.png"];

const WIDTH: u32 = 1400;
const HEIGHT: u32 = 820;
const LEGEND_WIDTH: u32 = 420;
const TITLE_HEIGHT: u32 = 78;

/// A saved run, as `bench --json` writes it (a hand-made file may add a `note`).
#[derive(Clone, Debug, Deserialize)]
pub struct SavedReport {
    pub environment: Environment,
    #[serde(default)]
    pub frames: u32,
    #[serde(default)]
    pub warmup: u32,
    pub rows: Vec<Row>,
    /// Free text, e.g. where hand-transcribed figures came from.
    #[serde(default)]
    pub note: Option<String>,
}

/// Read a report written by `bench --json`.
pub fn load_report(path: &Path) -> anyhow::Result<SavedReport> {
    let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("{} is not a bench JSON report", path.display()))
}

/// Draw the three charts of `rows` into `dir` (created if missing); `environments` name
/// the machines in the titles. Returns the files written.
pub fn write_charts(dir: &Path, environments: &[Environment], rows: &[Row]) -> anyhow::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let machine = machine_line(environments);
    let charts = [triangles_chart(rows, &machine), resolution_chart(rows, &machine), models_chart(rows, &machine)];
    let mut written = Vec::new();
    for (chart, name) in charts.iter().zip(CHART_FILES) {
        let path = dir.join(name);
        render(chart, &path).with_context(|| format!("cannot draw {}", path.display()))?;
        written.push(path);
    }
    Ok(written)
}

// ---------------------------------------------------------------------------------------
// What is drawn
// ---------------------------------------------------------------------------------------

#[derive(Clone, Copy, Debug, PartialEq)]
enum Marker {
    Circle,
    Square,
    Triangle,
    Diamond,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Line {
    /// Points only.
    None,
    Solid,
    Dashed,
}

#[derive(Clone, Debug)]
struct Series {
    label: String,
    color: RGBColor,
    line: Line,
    marker: Marker,
    /// (x, y), sorted by x when drawn.
    points: Vec<(f64, f64)>,
    /// A name written beside each point (empty: none).
    point_labels: Vec<String>,
}

impl Series {
    fn new(label: String, color: RGBColor, line: Line, marker: Marker) -> Self {
        Self { label, color, line, marker, points: Vec::new(), point_labels: Vec::new() }
    }

    /// Add a point unless one at the same x is there already (a row measured twice, e.g.
    /// in the scaling series and in Table 1, is drawn once).
    fn push(&mut self, x: f64, y: f64, label: Option<String>) {
        if self.points.iter().any(|p| p.0 == x) {
            return;
        }
        self.points.push((x, y));
        if let Some(l) = label {
            self.point_labels.resize(self.points.len() - 1, String::new());
            self.point_labels.push(l);
        }
    }

    fn sorted(&self) -> Vec<(f64, f64, String)> {
        let mut v: Vec<_> = self.points.iter().enumerate().map(|(i, p)| (p.0, p.1, self.point_labels.get(i).cloned().unwrap_or_default())).collect();
        v.sort_by(|a, b| a.0.total_cmp(&b.0));
        v
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum XAxis {
    /// Triangle counts: decades labelled 100, 1k, 1M.
    Count,
    /// Pixels per frame: ticks at the resolutions drawn, labelled 512².
    Pixels,
    /// Model copies: ticks at the counts drawn.
    Copies,
}

struct Chart {
    title: String,
    subtitle: String,
    x_desc: String,
    y_desc: String,
    x_axis: XAxis,
    series: Vec<Series>,
    /// Horizontal reference lines: (y, label).
    hlines: Vec<(f64, String)>,
}

const BLUE_: RGBColor = RGBColor(31, 100, 180);
const RED_: RGBColor = RGBColor(205, 40, 40);
const PURPLE_: RGBColor = RGBColor(130, 60, 170);
const GREY_: RGBColor = RGBColor(110, 110, 110);
const BVH_SHADES: [RGBColor; 4] = [BLUE_, RGBColor(0, 150, 150), RGBColor(90, 140, 230), RGBColor(20, 50, 110)];
const BRUTE_SHADES: [RGBColor; 4] = [RED_, RGBColor(230, 130, 0), RGBColor(240, 110, 110), RGBColor(120, 30, 30)];
const OTHER_SHADES: [RGBColor; 4] = [RGBColor(40, 140, 60), RGBColor(150, 110, 40), RGBColor(200, 80, 170), RGBColor(80, 80, 80)];

/// The n-th colour of an acceleration's family (blues for the BVH, reds for brute force).
fn accel_color(accel: &str, n: usize) -> RGBColor {
    let shades = match accel {
        "bvh" => &BVH_SHADES,
        "brute" => &BRUTE_SHADES,
        _ => &OTHER_SHADES,
    };
    shades[n % shades.len()]
}

/// One colour per model of the paper (others from a spare palette).
fn model_color(model: &str, others: &mut Vec<String>) -> RGBColor {
    match model {
        "geosphere" => RGBColor(31, 100, 180),
        "torusknot" => RGBColor(230, 120, 0),
        "sphere" => RGBColor(40, 150, 60),
        "cylinder" => RGBColor(205, 40, 40),
        _ => {
            let i = others.iter().position(|m| m == model).unwrap_or_else(|| {
                others.push(model.to_string());
                others.len() - 1
            });
            [PURPLE_, RGBColor(140, 90, 40), RGBColor(200, 80, 170), GREY_][i % 4]
        }
    }
}

fn accel_marker(accel: &str) -> Marker {
    if accel == "brute" {
        Marker::Square
    } else {
        Marker::Circle
    }
}

fn accel_name(accel: &str) -> String {
    match accel {
        "bvh" => "BVH".into(),
        "brute" => "brute force".into(),
        other => other.into(),
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

/// Series keyed by a string, in order of first appearance.
#[derive(Default)]
struct Groups(Vec<(String, Series)>);

impl Groups {
    fn get(&mut self, key: String, make: impl FnOnce(&Self) -> Series) -> &mut Series {
        match self.0.iter().position(|(k, _)| *k == key) {
            Some(i) => &mut self.0[i].1,
            None => {
                let s = make(self);
                self.0.push((key, s));
                &mut self.0.last_mut().unwrap().1
            }
        }
    }

    /// How many series of `accel` there are so far (to pick the next shade).
    fn count_accel(&self, accel: &str) -> usize {
        self.0.iter().filter(|(k, _)| k.starts_with(&format!("{accel}|"))).count()
    }

    fn into_series(self) -> Vec<Series> {
        self.0.into_iter().map(|(_, s)| s).collect()
    }
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
        let generated = r.model.starts_with("torusknot-");
        let key = format!("{}|{}|{}x{}|{}", r.accel, generated, r.width, r.height, r.bounces);
        let accel = r.accel.clone();
        let what = if generated { "torus knots" } else { ".obj models" };
        let label = format!("ours, {}: {what}, {}, {}", accel_name(&accel), res_label(r.width, r.height), bounces_note(r.bounces));
        let s = groups.get(key, |g| {
            if generated {
                Series::new(label, accel_color(&accel, g.count_accel(&accel)), Line::Solid, accel_marker(&accel))
            } else {
                // .obj models as labelled points in purples and greens, apart from the lines.
                let n = g.0.iter().filter(|(k, s)| k.starts_with(&format!("{accel}|")) && s.marker == Marker::Diamond).count();
                let shades = if accel == "brute" { [RGBColor(150, 110, 40), RGBColor(200, 80, 170)] } else { [PURPLE_, RGBColor(40, 140, 60)] };
                Series::new(label, shades[n % 2], Line::None, Marker::Diamond)
            }
        });
        s.push(r.triangles as f64, ms, (!generated).then(|| r.model.clone()));
    }
    // Our Table 1 rows at their largest resolution, as points beside the paper's.
    let table1: Vec<&Row> = rows.iter().filter(|r| r.series == "table1" && gpu_ms(r).is_some()).collect();
    if let Some(size) = table1.iter().map(|r| r.width as u64 * r.height as u64).max() {
        for r in table1.iter().filter(|r| r.width as u64 * r.height as u64 == size) {
            let key = format!("{}|table1|{}", r.accel, r.bounces);
            let accel = r.accel.clone();
            let label = format!("ours, {}: Table 1 models, {}, {}", accel_name(&accel), res_label(r.width, r.height), bounces_note(r.bounces));
            let s = groups.get(key, |g| Series::new(label, accel_color(&accel, g.count_accel(&accel) + 1), Line::None, accel_marker(&accel)));
            s.push(r.triangles as f64, gpu_ms(r).unwrap(), None);
        }
    }
    let mut series = groups.into_series();
    let mut paper = Series::new("paper: Table 1 at 1024² (triangles as listed)".into(), BLACK, Line::Dashed, Marker::Triangle);
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
        let key = format!("{}|{}|{}|{}", r.accel, r.model, r.models, r.bounces);
        let copies = if r.models > 1 { format!(" x{}", r.models) } else { String::new() };
        let extra = if r.bounces != 2 { format!(", {}", bounces_note(r.bounces)) } else { String::new() };
        let label = format!("ours, {}: {}{copies}{extra}", accel_name(&r.accel), r.model);
        let color = model_color(&r.model, &mut others);
        let s = groups.get(key, |_| Series::new(label, color, Line::Solid, accel_marker(&r.accel)));
        s.push(r.width as f64 * r.height as f64, ms, None);
    }
    let mut series = Vec::new();
    for (model, figures) in TABLE1 {
        let mut s = Series::new(format!("paper: {}", model.name()), model_color(model.name(), &mut others), Line::Dashed, Marker::Triangle);
        s.push(512.0 * 512.0, figures[0].1, None);
        s.push(1024.0 * 1024.0, figures[1].1, None);
        series.push(s);
    }
    // Brute force before the BVH in the legend, as in the tables.
    groups.0.sort_by_key(|(key, _)| {
        let parts: Vec<&str> = key.split('|').collect();
        let model = TABLE1.iter().position(|(m, _)| m.name() == parts[1]).unwrap_or(TABLE1.len());
        (if parts[0] == "brute" { 0 } else { 1 }, parts[0].to_string(), model)
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
        if !sizes.contains(&(r.width, r.height)) {
            sizes.push((r.width, r.height));
        }
        let key = format!("{}|{}|{}x{}|{}", r.accel, r.model, r.width, r.height, r.bounces);
        let accel = r.accel.clone();
        let label = format!("ours, {}: {} copies, {}, {}", accel_name(&accel), r.model, res_label(r.width, r.height), bounces_note(r.bounces));
        let s = groups.get(key, |_| Series::new(label, BLACK, Line::Solid, accel_marker(&accel)));
        s.push(r.models as f64, ms, None);
    }
    // Brute force first, then the largest resolution first within each acceleration, each
    // acceleration in its family of colours.
    let rank = |key: &str| {
        let parts: Vec<&str> = key.split('|').collect();
        let (w, h) = parts[2].split_once('x').map(|(w, h)| (w.parse::<u64>().unwrap_or(0), h.parse::<u64>().unwrap_or(0))).unwrap_or((0, 0));
        (if parts[0] == "brute" { 0 } else { 1 }, parts[0].to_string(), std::cmp::Reverse(w * h), parts[3].to_string())
    };
    groups.0.sort_by_key(|(k, _)| rank(k));
    let mut shade = std::collections::HashMap::<String, usize>::new();
    for (k, s) in &mut groups.0 {
        let accel = k.split('|').next().unwrap_or("").to_string();
        let n = shade.entry(accel.clone()).or_insert(0);
        s.color = accel_color(&accel, *n);
        *n += 1;
    }
    let mut series = Vec::new();
    // The paper at 1024² always, at 512² when we have rows there too.
    for (i, size) in [1024u32, 512].into_iter().enumerate() {
        if i > 0 && !sizes.contains(&(size, size)) {
            continue;
        }
        let mut s = Series::new(format!("paper: Table 2, geosphere copies, {size}²"), if i == 0 { BLACK } else { GREY_ }, Line::Dashed, Marker::Triangle);
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

// ---------------------------------------------------------------------------------------
// Axes
// ---------------------------------------------------------------------------------------

/// A number in at most 3 significant digits, without trailing zeros: 0.05, 1, 250, 5000.
fn short_number(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let digits = (2 - v.abs().log10().floor() as i32).max(0) as usize;
    let s = format!("{v:.digits$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// 100, 1k, 10k, 1M, 10M.
fn count_label(v: f64) -> String {
    let (d, suffix) = if v >= 1e9 {
        (1e9, "G")
    } else if v >= 1e6 {
        (1e6, "M")
    } else if v >= 1e3 {
        (1e3, "k")
    } else {
        (1.0, "")
    };
    format!("{}{suffix}", short_number(v / d))
}

/// 512² for a square pixel count, else the count.
fn pixels_label(v: f64) -> String {
    let side = v.sqrt().round();
    if (side * side - v).abs() < 0.5 {
        format!("{side}²")
    } else {
        count_label(v)
    }
}

/// Bold ticks (decades, with 2 and 5 between them on a short range) and light grid lines
/// (every integer multiple of each decade) inside `lo..hi`.
fn log_ticks(lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>) {
    let first = lo.log10().floor() as i32;
    let last = hi.log10().ceil() as i32;
    let short = last - first <= 3;
    let mut bold = Vec::new();
    let mut light = Vec::new();
    for e in first..=last {
        let decade = 10f64.powi(e);
        for m in 1..10 {
            let v = decade * m as f64;
            if v < lo || v > hi {
                continue;
            }
            if m == 1 || (short && (m == 2 || m == 5)) {
                bold.push(v);
            } else {
                light.push(v);
            }
        }
    }
    (bold, light)
}

/// The nearest of 1, 2, 5 times a power of ten below `v` (above with `up`).
fn snap_125(v: f64, up: bool) -> f64 {
    let decade = 10f64.powf(v.log10().floor());
    let candidates = [1.0, 2.0, 5.0, 10.0].map(|m| m * decade);
    if up {
        candidates.into_iter().find(|c| *c >= v * (1.0 - 1e-9)).unwrap_or(10.0 * decade)
    } else {
        candidates.into_iter().rev().find(|c| *c <= v * (1.0 + 1e-9)).unwrap_or(decade)
    }
}

/// Range of the values, widened by `pad` on each side (factor, for log axes).
fn log_range(values: impl Iterator<Item = f64>, pad: f64) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite() && *v > 0.0) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (0.1, 10.0);
    }
    if hi / lo < 4.0 {
        let mid = (hi * lo).sqrt();
        lo = lo.min(mid / 2.0);
        hi = hi.max(mid * 2.0);
    }
    (lo / pad, hi * pad)
}

// ---------------------------------------------------------------------------------------
// Drawing
// ---------------------------------------------------------------------------------------

fn register_fonts() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        for style in [FontStyle::Normal, FontStyle::Bold] {
            // The font is a fixed, valid file; a failure here would show as missing text.
            let _ = register_font(FAMILY, style, FONT);
        }
    });
}

fn err<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow!("plotters: {e:?}")
}

fn render(chart: &Chart, path: &Path) -> anyhow::Result<()> {
    register_fonts();
    let mut buffer = vec![255u8; (WIDTH * HEIGHT * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buffer, (WIDTH, HEIGHT)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let (top, rest) = root.split_vertically(TITLE_HEIGHT);
        top.draw_text(&chart.title, &(FAMILY, 28).into_font().color(&BLACK), (24, 12)).map_err(err)?;
        top.draw_text(&chart.subtitle, &(FAMILY, 16).into_font().color(&GREY_), (24, 50)).map_err(err)?;
        let (plot_area, legend_area) = rest.split_horizontally(WIDTH - LEGEND_WIDTH);
        draw_plot(chart, &plot_area)?;
        draw_legend(chart, &legend_area)?;
        root.present().map_err(err)?;
    }
    let image = image::RgbImage::from_raw(WIDTH, HEIGHT, buffer).ok_or_else(|| anyhow!("bad image buffer"))?;
    image.save(path)?;
    Ok(())
}

fn draw_plot<DB: DrawingBackend>(chart: &Chart, area: &DrawingArea<DB, Shift>) -> anyhow::Result<()> {
    let xs = chart.series.iter().flat_map(|s| s.points.iter().map(|p| p.0));
    let ys = chart.series.iter().flat_map(|s| s.points.iter().map(|p| p.1)).chain(chart.hlines.iter().map(|h| h.0));
    let (x_pad, y_pad) = match chart.x_axis {
        XAxis::Count => (1.6, 1.6),
        XAxis::Pixels | XAxis::Copies => (1.35, 1.6),
    };
    let (x_lo, x_hi) = log_range(xs, x_pad);
    let (y_lo, y_hi) = log_range(ys, y_pad);
    let (y_lo, y_hi) = (snap_125(y_lo, false), snap_125(y_hi, true));
    let (x_bold, x_light) = match chart.x_axis {
        XAxis::Count => log_ticks(x_lo, x_hi),
        XAxis::Pixels | XAxis::Copies => {
            let mut v: Vec<f64> = chart.series.iter().flat_map(|s| s.points.iter().map(|p| p.0)).collect();
            v.sort_by(f64::total_cmp);
            v.dedup();
            (v, Vec::new())
        }
    };
    let (y_bold, y_light) = log_ticks(y_lo, y_hi);
    let x_spec = (x_lo..x_hi).log_scale().with_key_points(x_bold).with_light_points(x_light);
    let y_spec = (y_lo..y_hi).log_scale().with_key_points(y_bold).with_light_points(y_light);
    let x_axis = chart.x_axis;
    let x_format = move |v: &f64| match x_axis {
        XAxis::Count => count_label(*v),
        XAxis::Pixels => pixels_label(*v),
        XAxis::Copies => short_number(*v),
    };
    let mut ctx = ChartBuilder::on(area)
        .margin_left(12)
        .margin_right(24)
        .margin_top(12)
        .margin_bottom(8)
        .x_label_area_size(62)
        .y_label_area_size(86)
        .build_cartesian_2d(x_spec, y_spec)
        .map_err(err)?;
    ctx.configure_mesh()
        .x_desc(chart.x_desc.as_str())
        .y_desc(chart.y_desc.as_str())
        .axis_desc_style((FAMILY, 19))
        .label_style((FAMILY, 16))
        .x_label_formatter(&x_format)
        .y_label_formatter(&|v: &f64| short_number(*v))
        .bold_line_style(BLACK.mix(0.18))
        .light_line_style(BLACK.mix(0.06))
        .draw()
        .map_err(err)?;
    let label_font = (FAMILY, 15).into_font().color(&GREY_);
    for (y, label) in &chart.hlines {
        let style = GREY_.stroke_width(2);
        ctx.draw_series(DashedLineSeries::new([(x_lo, *y), (x_hi, *y)], 12, 8, style)).map_err(err)?;
        let width = (label.chars().count() as i32) * 8 + 12;
        ctx.draw_series(std::iter::once(EmptyElement::at((x_hi, *y)) + Text::new(label.clone(), (-width, -22), label_font.clone())))
            .map_err(err)?;
    }
    for s in &chart.series {
        let points = s.sorted();
        let xy = points.iter().map(|p| (p.0, p.1));
        let style = s.color.stroke_width(2);
        match s.line {
            Line::None => {}
            Line::Solid => {
                ctx.draw_series(LineSeries::new(xy.clone(), style)).map_err(err)?;
            }
            Line::Dashed => {
                ctx.draw_series(DashedLineSeries::new(xy.clone(), 10, 6, style)).map_err(err)?;
            }
        }
        let plot = ctx.plotting_area();
        for p in &points {
            draw_marker(plot, (p.0, p.1), s.marker, s.color)?;
            if !p.2.is_empty() {
                // Below the point when a labelled neighbour (within a factor 2 in x) is higher.
                let below = points.iter().any(|q| !q.2.is_empty() && q.1 > p.1 && (q.0 / p.0).abs().log2().abs() < 1.0);
                let font = (FAMILY, 15).into_font().color(&s.color);
                let offset = if below { (10, 4) } else { (10, -22) };
                plot.draw(&(EmptyElement::at((p.0, p.1)) + Text::new(p.2.clone(), offset, font))).map_err(err)?;
            }
        }
    }
    Ok(())
}

/// A marker centred on `at`.
fn draw_marker<DB, CT>(area: &DrawingArea<DB, CT>, at: CT::From, marker: Marker, color: RGBColor) -> anyhow::Result<()>
where
    DB: DrawingBackend,
    CT: plotters::coord::CoordTranslate,
    CT::From: Clone,
{
    let fill = color.filled();
    let outline = WHITE.stroke_width(1);
    match marker {
        Marker::Circle => {
            area.draw(&(EmptyElement::at(at.clone()) + Circle::new((0, 0), 6, fill))).map_err(err)?;
            area.draw(&(EmptyElement::at(at) + Circle::new((0, 0), 6, outline))).map_err(err)?;
        }
        Marker::Square => {
            area.draw(&(EmptyElement::at(at.clone()) + Rectangle::new([(-5, -5), (5, 5)], fill))).map_err(err)?;
            area.draw(&(EmptyElement::at(at) + Rectangle::new([(-5, -5), (5, 5)], outline))).map_err(err)?;
        }
        Marker::Triangle => {
            area.draw(&(EmptyElement::at(at) + Polygon::new(vec![(0, -8), (-7, 5), (7, 5)], fill))).map_err(err)?;
        }
        Marker::Diamond => {
            area.draw(&(EmptyElement::at(at) + Polygon::new(vec![(0, -8), (7, 0), (0, 8), (-7, 0)], fill))).map_err(err)?;
        }
    }
    Ok(())
}

/// Words of `text` in lines of at most `width` characters.
fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines = vec![String::new()];
    for word in text.split(' ') {
        let last = lines.last_mut().unwrap();
        if !last.is_empty() && last.chars().count() + 1 + word.chars().count() > width {
            lines.push(word.to_string());
        } else {
            if !last.is_empty() {
                last.push(' ');
            }
            last.push_str(word);
        }
    }
    lines
}

fn draw_legend<DB: DrawingBackend>(chart: &Chart, area: &DrawingArea<DB, Shift>) -> anyhow::Result<()> {
    let font = (FAMILY, 16).into_font().color(&BLACK);
    let line_height = 20;
    let mut y = 22;
    area.draw_text("Legend", &(FAMILY, 18).into_font().color(&GREY_), (16, y)).map_err(err)?;
    y += 32;
    for s in &chart.series {
        let mid = y + 9;
        let style = s.color.stroke_width(2);
        match s.line {
            Line::None => {}
            Line::Solid => area.draw(&PathElement::new(vec![(14, mid), (62, mid)], style)).map_err(err)?,
            Line::Dashed => area.draw(&plotters::element::DashedPathElement::new(vec![(14, mid), (62, mid)], 8, 5, style)).map_err(err)?,
        }
        draw_marker(area, (38, mid), s.marker, s.color)?;
        let lines = wrap(&s.label, 38);
        for (i, l) in lines.iter().enumerate() {
            area.draw_text(l, &font, (74, y + i as i32 * line_height)).map_err(err)?;
        }
        y += lines.len() as i32 * line_height + 12;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels() {
        assert_eq!(count_label(100.0), "100");
        assert_eq!(count_label(1000.0), "1k");
        assert_eq!(count_label(4_000_000.0), "4M");
        assert_eq!(short_number(0.05), "0.05");
        assert_eq!(short_number(0.2), "0.2");
        assert_eq!(short_number(5000.0), "5000");
        assert_eq!(short_number(33.3333), "33.3");
        assert_eq!(pixels_label(512.0 * 512.0), "512²");
        let (bold, light) = log_ticks(0.15, 40.0);
        assert_eq!(bold, vec![0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0]);
        assert!(light.contains(&3.0) && !light.contains(&2.0));
    }

    #[test]
    fn wraps_on_words() {
        assert_eq!(wrap("ours, BVH: torus knots, 1024², 2 bounces", 20), vec!["ours, BVH: torus", "knots, 1024², 2", "bounces"]);
    }
}
