//! A benchmark run in the window (`view --benchmark N`, the panel's button, the B key): the
//! camera orbits its target once in N traced frames at fixed settings (light paused,
//! accumulation off, the colour view), and the run ends in a [`BenchmarkSummary`] that is
//! shown, printed and appended as one JSON line, with the device and driver as `bench`
//! reports them.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::app::state::{Params, ViewMode};
use crate::app::status::Status;
use crate::bench::timing::{mrays_per_second, Timing};
use crate::bench::workload::WorkloadHeader;
use crate::bench::Environment;
use crate::render_settings::RenderSettings;
use crate::scene::camera::Camera;
pub(crate) use runs::Runs;

mod runs;

/// Frames in a run when `--benchmark` is given without a number.
pub(crate) const DEFAULT_FRAMES: u32 = 120;
/// Traced frames at the start angle before measuring: the first frame after a change pays
/// for uploads, and GPU times arrive a few frames late (frames in flight), so those read
/// while measuring are all the run's own.
const WARMUP_FRAMES: u32 = 3;
/// Traced frames after the last measured one, waiting for its late GPU times.
const DRAIN_FRAMES: u32 = 4;
/// The file in the screenshot folder that runs are appended to without `--benchmark-json`.
pub(crate) const DEFAULT_JSON_NAME: &str = "meshtracer_benchmark.jsonl";

/// What was traced, besides the timings: filled by the tool when the run ends.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Workload {
    pub(crate) model: String,
    pub(crate) models: u32,
    pub(crate) triangles: u64,
}

/// The outcome of a run, as printed, shown and appended to the JSON file.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub(crate) struct BenchmarkSummary {
    /// Device, type, driver, Vulkan version and date, as `bench --json` writes them.
    pub(crate) environment: Environment,
    /// Model, triangles, resolution, bounces, acceleration, as `bench`'s rows write them
    /// (flattened: the fields stay where they always were in the JSON line).
    #[serde(flatten)]
    pub(crate) workload: WorkloadHeader,
    pub(crate) spp: u32,
    pub(crate) smooth: bool,
    /// Rays per frame at most (primary plus one per bounce, times spp), as `bench` counts them.
    pub(crate) rays_per_frame: u64,
    /// Measured frames (one orbit).
    pub(crate) frames: u32,
    /// Traced frame to traced frame on the CPU clock (what the user waits for).
    pub(crate) frame_ms: Timing,
    /// GPU timestamps around each frame's trace (a frame traced in bands: its bands added
    /// up); None without timestamps.
    pub(crate) gpu_ms: Option<Timing>,
    /// The lowest and highest shader clock read during the run, MHz (None on CPU devices):
    /// a GPU clocked down between frames traces slower than `bench` shows.
    #[serde(default)]
    pub(crate) gpu_clock_mhz: Option<[f64; 2]>,
    /// Frames per second from the mean frame time.
    pub(crate) fps: f64,
    /// Million rays per second from the mean GPU time (the mean frame time without one).
    pub(crate) mrays_per_s: f64,
}

impl BenchmarkSummary {
    /// The summary as a few lines of text, for the terminal and the panel.
    pub(crate) fn lines(&self) -> Vec<String> {
        let t = |t: &Timing| {
            format!("min {:.2}  mean {:.2}  p90 {:.2}  max {:.2}", t.min, t.mean, t.p90, t.max)
        };
        let (e, w) = (&self.environment, &self.workload);
        vec![
            format!(
                "benchmark: {} frames of {} x{} ({} triangles) at {}x{}, {} bounces, {}, {} spp",
                self.frames, w.model, w.models, w.triangles, w.width, w.height, w.bounces, w.accel, self.spp
            ),
            format!("  frame ms: {}  ({:.1} fps)", t(&self.frame_ms), self.fps),
            match &self.gpu_ms {
                Some(g) => format!("  gpu ms:   {}", t(g)),
                None => "  gpu ms:   - (no timestamps)".into(),
            },
            match self.gpu_clock_mhz {
                // The 80% that `bench`'s clock guard waits for.
                Some([lo, hi]) if lo < 0.8 * hi => format!("  gpu clock: {lo:.0}-{hi:.0} MHz: clocked down for part of the run, where it traces slower than `meshtracer bench` shows"),
                Some([lo, hi]) => format!("  gpu clock: {lo:.0}-{hi:.0} MHz"),
                None => "  gpu clock: - (not read on this device)".into(),
            },
            format!("  {:.1} Mrays/s on {} ({}), driver {}, Vulkan {}", self.mrays_per_s, e.device, e.device_type, e.driver, e.vulkan),
        ]
    }
}

/// What the last run said, as the panel's Benchmark section shows it.
#[derive(Clone, Debug, Default)]
pub(crate) struct Outcome {
    /// The last finished run's summary lines.
    pub(crate) lines: Vec<String>,
    /// Where the last summary went, or why a run failed or stopped.
    pub(crate) status: Option<Status>,
}

/// What a run changed in the parameters, given back when it ends.
#[derive(Clone, Debug)]
struct Saved {
    camera: Camera,
    light_paused: bool,
    accumulate: bool,
    view: ViewMode,
}

/// A run in progress.
#[derive(Clone, Debug)]
pub(crate) struct Benchmark {
    frames: u32,
    start: Camera,
    /// The settings it measures: any change cancels the run.
    settings: RenderSettings,
    saved: Saved,
    warmup_left: u32,
    drained: u32,
    /// Time (seconds) of the last traced frame.
    last: Option<f64>,
    frame_ms: Vec<f64>,
    gpu_ms: Vec<f64>,
    /// Lowest and highest shader clock read while measuring, MHz.
    clock_mhz: Option<[f64; 2]>,
}

impl Benchmark {
    /// Begin a run of `frames` traced frames (at least 1): the camera goes back to where
    /// the scene opens, the light stops, accumulation and other views are switched off;
    /// `area` is the image area (for the render size).
    pub(crate) fn begin(frames: u32, params: &mut Params, area: [u32; 2]) -> Self {
        let saved = Saved {
            camera: params.camera,
            light_paused: params.light_paused,
            accumulate: params.accumulate,
            view: params.view,
        };
        params.view = ViewMode::Color;
        let mut run = Self {
            frames: frames.max(1),
            start: params.scene.camera.camera(),
            settings: params.settings_for(area),
            saved,
            warmup_left: WARMUP_FRAMES,
            drained: 0,
            last: None,
            frame_ms: Vec::new(),
            gpu_ms: Vec::new(),
            clock_mhz: None,
        };
        run.hold(params);
        run
    }

    /// Keep the run's fixed settings and put the camera where the next frame needs it
    /// (before each frame: keys and drags would move them).
    pub(crate) fn hold(&mut self, params: &mut Params) {
        params.light_paused = true;
        params.accumulate = false;
        params.camera = self.camera();
    }

    /// The parameters changed under the run (another resolution, bounces, view ...).
    pub(crate) fn settings_changed(&self, now: &RenderSettings) -> bool {
        *now != self.settings
    }

    /// The camera of the next traced frame: the start orbited by 360°/N per measured frame.
    pub(crate) fn camera(&self) -> Camera {
        let mut c = self.start;
        let done = self.frame_ms.len().min(self.frames as usize);
        // From the start each time, so the orbit does not drift with rounding; the first
        // frame is the start view exactly (orbiting by 0 rounds).
        if done > 0 {
            c.orbit(std::f32::consts::TAU / self.frames as f32 * done as f32, 0.0, 1.0);
        }
        c
    }

    /// A traced frame was presented at time `t` seconds.
    pub(crate) fn frame_traced(&mut self, t: f64) {
        if self.warmup_left > 0 {
            self.warmup_left -= 1;
        } else if self.frame_ms.len() < self.frames as usize {
            if let Some(last) = self.last {
                self.frame_ms.push((t - last) * 1e3);
            }
        } else {
            self.drained += 1;
        }
        self.last = Some(t);
    }

    /// A GPU trace time arrived (it belongs to a frame traced a few frames ago).
    pub(crate) fn gpu_time(&mut self, ms: f64) {
        // Before measuring, times may be of frames before the run; warm-up frames are the
        // run's own settings, so times read while measuring all count.
        if self.warmup_left == 0
            && !self.frame_ms.is_empty()
            && self.gpu_ms.len() < self.frames as usize
        {
            self.gpu_ms.push(ms);
        }
    }

    /// The shader clock as last read, MHz (kept while measuring).
    pub(crate) fn clock_reading(&mut self, mhz: f64) {
        if self.warmup_left == 0
            && !self.frame_ms.is_empty()
            && self.frame_ms.len() < self.frames as usize
        {
            self.clock_mhz =
                Some(self.clock_mhz.map_or([mhz, mhz], |[lo, hi]| [lo.min(mhz), hi.max(mhz)]));
        }
    }

    /// Measured frames so far and the run's length, for the panel.
    pub(crate) fn progress(&self) -> (u32, u32) {
        (self.frame_ms.len() as u32, self.frames)
    }

    /// Every frame is measured and its GPU time has arrived (or will not).
    pub(crate) fn is_finished(&self) -> bool {
        self.frame_ms.len() >= self.frames as usize
            && (self.gpu_ms.len() >= self.frames as usize || self.drained >= DRAIN_FRAMES)
    }

    /// Give the parameters back as they were before the run.
    pub(crate) fn restore(&self, params: &mut Params) {
        params.camera = self.saved.camera;
        params.light_paused = self.saved.light_paused;
        params.accumulate = self.saved.accumulate;
        params.view = self.saved.view;
    }

    /// The summary of a finished run on `environment`'s device.
    pub(crate) fn summary(&self, workload: Workload, environment: Environment) -> BenchmarkSummary {
        let s = &self.settings;
        let frame_ms = Timing::of(&self.frame_ms).unwrap_or_default();
        // A short run may lack some GPU times.
        let gpu_ms = Timing::of(&self.gpu_ms);
        let rays = s.max_rays();
        let fps = if frame_ms.mean > 0.0 { 1e3 / frame_ms.mean } else { 0.0 };
        BenchmarkSummary {
            environment,
            workload: WorkloadHeader {
                model: workload.model,
                models: workload.models,
                triangles: workload.triangles,
                width: s.width,
                height: s.height,
                bounces: s.bounces,
                accel: s.accel,
                bvh: s.bvh,
            },
            spp: s.spp,
            smooth: s.smooth,
            rays_per_frame: rays,
            frames: self.frame_ms.len() as u32,
            frame_ms,
            gpu_ms,
            gpu_clock_mhz: self.clock_mhz,
            fps,
            mrays_per_s: mrays_per_second(rays, gpu_ms.map_or(frame_ms.mean, |g| g.mean)),
        }
    }
}

/// Where a run's JSON line goes: `--benchmark-json`, or a file in the screenshot folder.
pub(crate) fn json_path(given: Option<&Path>, screenshot_dir: &Path) -> PathBuf {
    given.map_or_else(|| screenshot_dir.join(DEFAULT_JSON_NAME), Path::to_path_buf)
}

/// Append the summary to `path` as one line of JSON (JSON Lines: runs accumulate).
pub(crate) fn append_json(path: &Path, summary: &BenchmarkSummary) -> Result<(), String> {
    let line = serde_json::to_string(summary)
        .map_err(|e| format!("cannot write the benchmark as JSON ({e})"))?;
    crate::files::append_line(path, &line).map_err(|e| {
        format!("cannot append the benchmark to {} ({e})", crate::files::shown_path(path))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::spec::SceneSpec;

    fn environment() -> Environment {
        Environment {
            device: "Test GPU".into(),
            device_type: "discrete".into(),
            driver: "1.2.3".into(),
            vulkan: "1.3".into(),
            date: "2024-01-01".into(),
        }
    }

    fn workload() -> Workload {
        Workload { model: "geosphere".into(), models: 1, triangles: 1280 }
    }

    /// Feed a run `frames` traced frames `ms` apart with GPU times `gpu` each.
    fn run(frames: u32, frame_ms: &[f64], gpu: Option<f64>) -> (Benchmark, Params) {
        let mut params = Params::new(&SceneSpec::default(), false);
        let mut b = Benchmark::begin(frames, &mut params, [800, 600]);
        let mut t = 0.0;
        let mut i = 0;
        while !b.is_finished() {
            b.hold(&mut params);
            t += if b.warmup_left > 0 { 0.5 } else { frame_ms[i % frame_ms.len()] * 1e-3 };
            if b.warmup_left == 0 && b.frame_ms.len() < frames as usize {
                i += 1;
            }
            b.frame_traced(t);
            if let Some(g) = gpu {
                b.gpu_time(g);
            }
            assert!(i < 10_000, "the run never ends");
        }
        (b, params)
    }

    #[test]
    fn summary_counts_measured_frames_only() {
        // Warm-up frames are 500 ms apart: none of them may reach the statistics.
        let (b, _) = run(10, &[10.0, 20.0], Some(5.0));
        let s = b.summary(workload(), environment());
        assert_eq!(s.frames, 10);
        assert!(
            (s.frame_ms.min - 10.0).abs() < 1e-6 && (s.frame_ms.max - 20.0).abs() < 1e-6,
            "{:?}",
            s.frame_ms
        );
        assert!((s.frame_ms.mean - 15.0).abs() < 1e-6);
        assert!((s.fps - 1e3 / 15.0).abs() < 1e-6);
        let gpu = s.gpu_ms.expect("GPU times were given");
        assert_eq!((gpu.min, gpu.max), (5.0, 5.0));
        // 512 x 512 pixels x (2 bounces + 1) rays in 5 ms.
        assert_eq!(s.rays_per_frame, 512 * 512 * 3);
        assert!(
            (s.mrays_per_s - 512.0 * 512.0 * 3.0 / 5e-3 / 1e6).abs() < 1e-6,
            "{}",
            s.mrays_per_s
        );
    }

    #[test]
    fn without_timestamps_the_run_ends_and_uses_frame_time() {
        let (b, _) = run(4, &[8.0], None);
        let s = b.summary(workload(), environment());
        assert_eq!(s.gpu_ms, None);
        assert!((s.mrays_per_s - 512.0 * 512.0 * 3.0 / 8e-3 / 1e6).abs() < 1e-6);
    }

    #[test]
    fn the_clock_read_while_measuring_is_reported() {
        let mut params = Params::new(&SceneSpec::default(), false);
        let mut b = Benchmark::begin(4, &mut params, [800, 600]);
        // Warm-up readings do not count; those while measuring give the range.
        for (i, mhz) in
            [100.0, 100.0, 100.0, 1980.0, 345.0, 1500.0, 1980.0, 90.0].into_iter().enumerate()
        {
            b.frame_traced(i as f64);
            b.gpu_time(1.0);
            b.clock_reading(mhz);
        }
        let s = b.summary(workload(), environment());
        assert_eq!(s.gpu_clock_mhz, Some([345.0, 1980.0]));
        assert!(
            s.lines().iter().any(|l| l.contains("345-1980 MHz: clocked down")),
            "{:?}",
            s.lines()
        );
        // A run without readings says so.
        let (b, _) = run(4, &[8.0], Some(1.0));
        assert!(b
            .summary(workload(), environment())
            .lines()
            .iter()
            .any(|l| l.contains("gpu clock: -")));
    }

    #[test]
    fn the_camera_orbits_once_and_the_parameters_come_back() {
        let mut params = Params::new(&SceneSpec::default(), false);
        params.camera.orbit(0.3, 0.2, 0.5);
        params.view = ViewMode::Cost(crate::app::state::CostMetric::Nodes);
        let before = params.clone();
        let mut b = Benchmark::begin(8, &mut params, [800, 600]);
        assert_eq!(
            params.camera,
            params.scene.camera.camera(),
            "a run starts where the scene opens"
        );
        assert!(params.light_paused && !params.accumulate && params.view == ViewMode::Color);
        let home = params.scene.camera.camera();
        let dist = (home.position - home.target).length();
        let mut angles = Vec::new();
        for i in 0..30 {
            b.hold(&mut params);
            let c = params.camera;
            assert!(
                ((c.position - c.target).length() - dist).abs() < 1e-3,
                "the orbit keeps its distance"
            );
            assert!((c.position.y - home.position.y).abs() < 1e-3, "the orbit keeps its height");
            angles.push((c.position - c.target).z.atan2((c.position - c.target).x));
            b.frame_traced(i as f64);
        }
        // Eight evenly spaced angles: 45° apart, all different.
        let mut distinct: Vec<f32> = angles
            .iter()
            .map(|a| (a.to_degrees().rem_euclid(360.0) / 45.0).round() % 8.0)
            .collect();
        distinct.dedup();
        distinct.sort_by(f32::total_cmp);
        distinct.dedup();
        assert_eq!(distinct.len(), 8, "{angles:?}");
        b.restore(&mut params);
        assert_eq!(params, before);
    }

    #[test]
    fn a_settings_change_is_seen() {
        let mut params = Params::new(&SceneSpec::default(), false);
        let b = Benchmark::begin(8, &mut params, [800, 600]);
        assert!(!b.settings_changed(&params.settings_for([800, 600])));
        params.scene.settings.bounces += 1;
        assert!(b.settings_changed(&params.settings_for([800, 600])));
    }

    #[test]
    fn json_lines_accumulate_and_read_back() {
        let dir =
            std::env::temp_dir().join(format!("meshtracer-bench-json-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = json_path(None, &dir);
        assert_eq!(path, dir.join(DEFAULT_JSON_NAME));
        let _ = std::fs::remove_file(&path);
        let (b, _) = run(3, &[10.0], Some(2.0));
        let s = b.summary(workload(), environment());
        append_json(&path, &s).unwrap();
        append_json(&path, &s).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let rows: Vec<BenchmarkSummary> =
            text.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
        assert_eq!(rows.len(), 2);
        assert_eq!(rows[0].environment.driver, "1.2.3");
        assert_eq!(rows[1].frames, 3);
        assert_eq!(rows[1].workload, s.workload);
        // The flattened workload keeps the line's fields in their old order.
        let line = text.lines().next().unwrap();
        let at = |key: &str| {
            line.find(&format!("\"{key}\":")).unwrap_or_else(|| panic!("{key} in {line}"))
        };
        let keys = [
            "environment",
            "model",
            "models",
            "triangles",
            "width",
            "height",
            "bounces",
            "accel",
            "spp",
            "smooth",
            "rays_per_frame",
            "frames",
        ];
        assert!(keys.windows(2).all(|k| at(k[0]) < at(k[1])), "{line}");
        let e = append_json(&dir.join("no/such/dir/x.jsonl"), &s).unwrap_err();
        assert!(e.starts_with("cannot append the benchmark to"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
        assert!(s.lines()[0].contains("3 frames of geosphere"));
    }
}
