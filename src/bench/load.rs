//! `bench --load FILE...`: the way from a model file to the first frame, measured as the
//! window walks it: each phase's time (read, parse, build, pack, upload), the first
//! frame's trace, the whole wait, and the process's peak memory while loading.

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::Environment;
use crate::gpu::dispatch::FrameTrace;
use crate::gpu::ComputeTracer;
use crate::progress::{read_peak_rss, Phase, Progress};
use crate::render_settings::BvhLayout;
use crate::scene::paper::{ModelSource, MODEL_MESH};
use crate::scene::spec::SceneSpec;
use crate::tracer::loaded::LoadedScene;
use crate::tracer::packed::DeviceFit;
use crate::tracer::FrameParams;

/// One model's load, measured.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct LoadRow {
    /// The model as `--model` names it.
    pub model: String,
    /// The BVH layout loaded (binary when absent: reports written before it was recorded).
    #[serde(default = "BvhLayout::binary")]
    pub bvh: BvhLayout,
    /// The file's size in bytes (0 for a generated model).
    pub file_bytes: u64,
    pub triangles: u64,
    /// Seconds of each phase, in [`Phase::ALL`]'s order (read, parse, build, pack, upload);
    /// a generated model spends its generation in parse and reads nothing.
    pub phase_s: [f64; 5],
    /// GPU time of the first frame (timestamps), ms; None without timestamps.
    pub first_frame_gpu_ms: Option<f64>,
    /// From the start of the read until the GPU has traced the first frame: what a user of
    /// the window waits (which shows the frame without reading it back).
    pub to_first_frame_s: f64,
    /// The process's peak resident memory during the load, bytes (None where the system
    /// does not say: only Linux's /proc is read).
    pub peak_rss_bytes: Option<u64>,
    /// The peak of each phase, in [`Phase::ALL`]'s order: where the memory goes.
    #[serde(default)]
    pub phase_peak_rss_bytes: [Option<u64>; 5],
    /// The model's binary tree's SAH cost as tinybvh measures it (both costs 1, over the
    /// root's area), so that builds are compared at equal quality; None for a tree packed
    /// wide alone, and in reports from before it was recorded.
    #[serde(default)]
    pub sah_cost: Option<f64>,
    /// That tree's nodes, inner and leaves, as tinybvh's `NodeCount` counts them.
    #[serde(default)]
    pub bvh_nodes: Option<u64>,
}

impl LoadRow {
    /// Peak memory beyond the file's own size, per triangle: the measure of how
    /// much the load keeps besides the text.
    pub fn peak_bytes_per_triangle_beyond_file(&self) -> Option<f64> {
        let peak = self.peak_rss_bytes? as f64;
        (self.triangles > 0).then(|| (peak - self.file_bytes as f64) / self.triangles as f64)
    }

    /// The phase whose peak was the load's (None without the phases' peaks).
    pub fn peak_phase(&self) -> Option<Phase> {
        let (i, _) = self
            .phase_peak_rss_bytes
            .iter()
            .enumerate()
            .filter_map(|(i, p)| p.map(|p| (i, p)))
            .max_by_key(|&(_, p)| p)?;
        Some(Phase::ALL[i])
    }
}

/// Load `spec`'s model into `spec`'s scene as the window's loader does ([`LoadedScene::load`]:
/// read, parse, build, pack, each timed by a [`Progress`]), upload it to `tracer` and trace one
/// frame at `spec`'s settings. The peak memory counts from the start of this call.
/// `device` is the tracer's device: what it holds and builds ([`LoadedScene::load`]).
pub fn measure(
    spec: &SceneSpec,
    tracer: &mut ComputeTracer,
    device: DeviceFit,
) -> anyhow::Result<LoadRow> {
    spec.validate().map_err(anyhow::Error::msg)?;
    spec.model.check_name().map_err(anyhow::Error::msg)?;
    let file_bytes = match &spec.model {
        ModelSource::File(p) => crate::files::regular_file_size(p, "model").unwrap_or(0),
        _ => 0,
    };
    // Where the peak cannot be reset, the readings are the process's peak so far.
    let progress = Progress::default();
    progress.track_peak_memory();
    let start = Instant::now();
    let loaded = LoadedScene::load(spec, &progress, device)?;
    let triangles = loaded.scene().meshes[MODEL_MESH].triangle_count() as u64;
    // The layout the model traces: binary where its wide tree did not fit the device.
    let model_wide = loaded.tables().meshes[MODEL_MESH].has_wide;
    let bvh = if model_wide { spec.settings.bvh } else { BvhLayout::Binary };
    for w in &loaded.warnings {
        log::warn!("{w}");
    }
    // The tree's quality is summed between two phases and its time taken off the wait: the
    // window never computes it.
    progress.finish();
    let quality_start = Instant::now();
    let quality = loaded.tree_quality(MODEL_MESH);
    let quality_time = quality_start.elapsed();
    progress.begin(Phase::Upload)?;
    tracer.set_loaded_scene(&loaded)?;
    // As the window does: the host's copy goes on another thread, the first frame does not
    // wait for its pages to be unmapped.
    let (scene, _top_level) = loaded.uploaded();
    progress.finish();
    // The first frame is done when the GPU is: the window shows it without reading it back
    // (reading a 1024² float image back took 19 ms on the 2-core dev machine).
    let params = FrameParams::new(&scene, spec.settings);
    let timing = tracer.trace_frame(&FrameTrace::whole(params))?;
    let to_first_frame_s = start.elapsed().saturating_sub(quality_time).as_secs_f64();
    let snapshot = progress.snapshot();
    let mut phase_s = [0.0; 5];
    let mut phase_peak_rss_bytes = [None; 5];
    for ((slot, peak), phase) in phase_s.iter_mut().zip(&mut phase_peak_rss_bytes).zip(Phase::ALL) {
        *slot = snapshot.seconds(phase);
        *peak = snapshot
            .phases
            .iter()
            .filter(|p| p.phase == phase)
            .filter_map(|p| p.peak_rss_bytes)
            .max();
    }
    // The first frame after the last phase counts too.
    let peak_rss_bytes =
        phase_peak_rss_bytes.iter().flatten().copied().chain(read_peak_rss()).max();
    Ok(LoadRow {
        model: spec.model.label(),
        bvh,
        file_bytes,
        triangles,
        phase_s,
        first_frame_gpu_ms: timing.gpu_ms,
        to_first_frame_s,
        peak_rss_bytes,
        phase_peak_rss_bytes,
        sah_cost: quality.map(|(cost, _)| cost),
        bvh_nodes: quality.map(|(_, nodes)| nodes),
    })
}

/// The table `bench --load` prints: a header and one line per row.
pub fn table(rows: &[LoadRow]) -> String {
    let mut s = format!(
        "{:<20} {:<9} {:>11} {:>9} {:>7} {:>7} {:>7} {:>7} {:>7} {:>9} {:>10} {:>9} {:>10} {:>7} {:>7} {:>10}\n",
        "model",
        "bvh",
        "triangles",
        "file MB",
        "read s",
        "parse s",
        "build s",
        "pack s",
        "upload s",
        "frame ms",
        "to frame s",
        "peak MB",
        "B/tri+file",
        "peak in",
        "SAH",
        "nodes"
    );
    for r in rows {
        let [read, parse, build, pack, upload] = r.phase_s;
        let mb = |b: u64| b as f64 / 1e6;
        let _ = writeln!(
            s,
            "{:<20} {:<9} {:>11} {:>9.1} {:>7.3} {:>7.3} {:>7.3} {:>7.3} {:>7.3} {:>9} {:>10.3} {:>9} {:>10} {:>7} {:>7} {:>10}",
            truncate(&r.model, 20),
            r.bvh.to_string(),
            r.triangles,
            mb(r.file_bytes),
            read,
            parse,
            build,
            pack,
            upload,
            r.first_frame_gpu_ms.map_or("-".into(), |ms| format!("{ms:.2}")),
            r.to_first_frame_s,
            r.peak_rss_bytes.map_or("-".into(), |b| format!("{:.0}", mb(b))),
            r.peak_bytes_per_triangle_beyond_file().map_or("-".into(), |b| format!("{b:.0}")),
            r.peak_phase().map_or("-", |p| p.name()),
            r.sah_cost.map_or("-".into(), |c| format!("{c:.2}")),
            r.bvh_nodes.map_or("-".into(), |n| n.to_string()),
        );
    }
    s
}

/// The rows as CSV, one line each, with the device.
pub fn csv(env: &Environment, rows: &[LoadRow]) -> String {
    let mut s = String::from("model,bvh,triangles,file_bytes,read_s,parse_s,build_s,pack_s,upload_s,first_frame_gpu_ms,to_first_frame_s,peak_rss_bytes,read_peak_rss_bytes,parse_peak_rss_bytes,build_peak_rss_bytes,pack_peak_rss_bytes,upload_peak_rss_bytes,device,driver,date,sah_cost,bvh_nodes\n");
    for r in rows {
        let [read, parse, build, pack, upload] = r.phase_s;
        let _ = writeln!(
            s,
            "{},{},{},{},{read:.4},{parse:.4},{build:.4},{pack:.4},{upload:.4},{},{:.4},{},{},\"{}\",\"{}\",{},{},{}",
            r.model,
            r.bvh,
            r.triangles,
            r.file_bytes,
            r.first_frame_gpu_ms.map_or(String::new(), |v| format!("{v:.4}")),
            r.to_first_frame_s,
            r.peak_rss_bytes.map_or(String::new(), |v| v.to_string()),
            r.phase_peak_rss_bytes.map(|p| p.map_or(String::new(), |v| v.to_string())).join(","),
            env.device,
            env.driver,
            env.date,
            r.sah_cost.map_or(String::new(), |c| format!("{c:.4}")),
            r.bvh_nodes.map_or(String::new(), |n| n.to_string()),
        );
    }
    s
}

fn truncate(s: &str, n: usize) -> String {
    if s.chars().count() <= n {
        s.to_owned()
    } else {
        s.chars().take(n - 1).chain(['…']).collect()
    }
}

/// The rows as a file: `bench --load --json`.
#[derive(Serialize)]
pub struct LoadReport<'a> {
    pub environment: &'a Environment,
    pub rows: &'a [LoadRow],
}

/// Write `text` to `path` atomically (a failed write keeps the old file).
pub fn write(path: &Path, text: &str) -> anyhow::Result<()> {
    crate::files::write_bytes_atomic(path, text.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_and_csv_carry_every_phase() {
        let row = LoadRow {
            model: "knot".into(),
            bvh: BvhLayout::Wide,
            file_bytes: 1_000_000,
            triangles: 1000,
            phase_s: [0.1, 0.2, 0.3, 0.4, 0.5],
            first_frame_gpu_ms: Some(1.5),
            to_first_frame_s: 1.6,
            peak_rss_bytes: Some(1_120_000),
            phase_peak_rss_bytes: [
                Some(900_000),
                Some(1_000_000),
                Some(1_120_000),
                Some(1_100_000),
                None,
            ],
            sah_cost: Some(59.4567),
            bvh_nodes: Some(1234),
        };
        assert_eq!(row.peak_bytes_per_triangle_beyond_file(), Some(120.0));
        assert_eq!(row.peak_phase(), Some(Phase::Build));
        let table = table(std::slice::from_ref(&row));
        assert_eq!(table.lines().count(), 2);
        for figure in ["wide", "0.100", "0.500", "1.50", "1.600", "120", "build", "59.46", "1234"] {
            assert!(
                table.lines().nth(1).unwrap().contains(figure),
                "{figure} missing from {table}"
            );
        }
        let mut old_report = serde_json::to_value(&row).unwrap();
        for column in ["bvh", "sah_cost", "bvh_nodes"] {
            old_report.as_object_mut().unwrap().remove(column);
        }
        let old_row = serde_json::from_value::<LoadRow>(old_report).unwrap();
        assert_eq!(old_row.bvh, BvhLayout::Binary, "a report from before the column");
        assert_eq!((old_row.sah_cost, old_row.bvh_nodes), (None, None));
        let env = Environment::default();
        let csv = csv(&env, &[row]);
        assert_eq!(
            csv.lines().nth(1).unwrap().split(',').count(),
            csv.lines().next().unwrap().split(',').count()
        );
        assert!(csv.lines().nth(1).unwrap().ends_with(",59.4567,1234"), "{csv}");
    }

    #[test]
    fn peak_memory_is_read_on_linux() {
        if cfg!(target_os = "linux") {
            assert!(read_peak_rss().is_some_and(|b| b > 0));
        }
    }
}
