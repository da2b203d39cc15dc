//! Bench output: an aligned table on the terminal (with the paper's figures beside each
//! row), JSON and CSV files.

use std::fmt::Write as _;
use std::path::Path;

use serde::Serialize;

use super::{Environment, Row};
use crate::render_settings::Accel;

/// `bench --compare`'s closing table: per pair of rows, both GPU times, the ratio (ours over
/// the vendor's: below 1 we are faster), and the build time and memory of both structures.
pub fn compare_table(rows: &[Row]) -> String {
    let mut out = format!(
        "{:<10} {:<12} {:>9} {:>11} {:<2} {:<6} {:>9} {:>9} {:<8} {:>7} {:>10} {:>12} {:>8} {:>10}\n",
        "series", "model", "triangles", "resolution", "b", "ours", "ours ms", "vendor ms", "kernel", "ratio", "bvh build", "vendor build", "bvh MB", "vendor MB"
    );
    for (i, j) in super::vendor_pairs(rows) {
        let (ours, theirs) = (&rows[i], &rows[j]);
        {
            let (Some(a), Some(b)) = (ours.gpu_ms, theirs.gpu_ms) else { continue };
            let _ = writeln!(
                out,
                "{:<10} {:<12} {:>9} {:>5}x{:<5} b{} {:<6} {:>9.3} {:>9.3} {:<8} {:>7.2} {:>7.1} ms {:>9.1} ms {:>8.1} {:>10.1}",
                ours.series,
                ours.workload.model,
                ours.workload.triangles,
                ours.workload.width,
                ours.workload.height,
                ours.workload.bounces,
                ours.workload.accel_label(),
                a.median,
                b.median,
                theirs.vendor_kernel.as_deref().unwrap_or("-"),
                a.median / b.median,
                ours.bvh_build_ms,
                theirs.bvh_build_ms,
                ours.scene_bytes as f64 / 1e6,
                theirs.scene_bytes as f64 / 1e6
            );
        }
    }
    out
}

/// A whole run, as written to JSON.
#[derive(Serialize)]
pub struct Report<'a> {
    pub environment: &'a Environment,
    pub frames: u32,
    pub warmup: u32,
    pub rows: &'a [Row],
}

/// One table line for a row.
pub fn format_row(r: &Row) -> String {
    let paper = match (r.paper_fps, r.paper_ms) {
        (Some(f), Some(m)) => format!("{f:>6.0} fps {m:>7.2} ms"),
        _ => String::new(),
    };
    if let Some(why) = &r.skipped {
        return format!(
            "{:<10} {:<12} x{:<2} {:>9} {:>5}x{:<5} b{} {:<6} skipped: {why}",
            r.series,
            r.workload.model,
            r.workload.models,
            r.workload.triangles,
            r.workload.width,
            r.workload.height,
            r.workload.bounces,
            r.workload.accel_label()
        );
    }
    let gpu = r.gpu_ms.map_or("      -".into(), |g| format!("{:>9.3}", g.median));
    let mut notes = r.features.clone();
    if let Some(kernel) = &r.vendor_kernel {
        notes = [notes.as_str(), kernel.as_str()]
            .into_iter()
            .filter(|s| !s.is_empty())
            .collect::<Vec<_>>()
            .join(", ");
    }
    if let (Some(ratio), Accel::Vendor) = (r.ours_over_vendor, r.workload.accel) {
        notes.push_str(&format!(" (ours/vendor {ratio:.2})"));
    }
    let clock = r.gpu_clock_mhz.map_or("    -".into(), |mhz| format!("{mhz:>5.0}"));
    format!(
        "{:<10} {:<12} x{:<2} {:>9} {:>5}x{:<5} b{} {:<6} {gpu} {:>9.3} {:>8.1} {:>9.1} {clock}   {paper}{}",
        r.series, r.workload.model, r.workload.models, r.workload.triangles, r.workload.width, r.workload.height, r.workload.bounces, r.workload.accel_label(), r.wall_ms.median, r.fps, r.mrays_per_s, notes
    )
}

/// The header matching `format_row`.
pub fn header() -> String {
    format!(
        "{:<10} {:<12} {:<3} {:>9} {:>11} {:<2} {:<6} {:>9} {:>9} {:>8} {:>9} {:>5}   {}",
        "series",
        "model",
        "n",
        "triangles",
        "resolution",
        "b",
        "accel",
        "gpu ms",
        "frame ms",
        "fps",
        "Mrays/s",
        "MHz",
        "paper (GTX 1080 Ti, brute force)"
    )
}

/// Write the run as pretty JSON.
pub fn write_json(path: &Path, report: &Report) -> anyhow::Result<()> {
    let text = serde_json::to_string_pretty(report)?;
    crate::files::write_bytes_atomic(path, text.as_bytes())
}

/// Write the rows as CSV.
pub fn write_csv(path: &Path, env: &Environment, rows: &[Row]) -> anyhow::Result<()> {
    let mut s = String::from("series,model,models,triangles,width,height,bounces,accel,features,rays_per_frame,gpu_ms_median,gpu_ms_p10,gpu_ms_p90,wall_ms_median,wall_ms_p10,wall_ms_p90,mrays_per_s,fps,bvh_build_ms,scene_bytes,paper_fps,paper_ms,skipped,vendor_kernel,ours_over_vendor,gpu_clock_mhz,device,driver,date\n");
    for r in rows {
        let g = r.gpu_ms.unwrap_or_default();
        let opt = |v: Option<f64>| v.map_or(String::new(), |v| v.to_string());
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{:.3},{:.3},{:.3},{},{},{},{},{},{},{},\"{}\",\"{}\",{}",
            r.series, r.workload.model, r.workload.models, r.workload.triangles, r.workload.width, r.workload.height, r.workload.bounces, r.workload.accel_label(), r.features, r.rays_per_frame,
            g.median, g.p10, g.p90, r.wall_ms.median, r.wall_ms.p10, r.wall_ms.p90, r.mrays_per_s, r.fps, r.bvh_build_ms, r.scene_bytes,
            opt(r.paper_fps), opt(r.paper_ms), r.skipped.clone().unwrap_or_default(), r.vendor_kernel.clone().unwrap_or_default(),
            opt(r.ours_over_vendor), opt(r.gpu_clock_mhz.map(f64::round)), env.device, env.driver, env.date
        );
    }
    crate::files::write_bytes_atomic(path, s.as_bytes())
}
