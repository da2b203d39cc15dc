//! The frame-time log (`view --stats-csv FILE`, or Record in the Performance section): one
//! CSV row per traced frame and one row per parameter change, naming it, so a user sees
//! what each change cost.
//!
//! Every row has the same columns; `row` says which kind it is:
//!
//! ```text
//! row,frame,time_s,gpu_ms,frame_ms,resolution,bounces,spp,acceleration,triangles,rays,gpu_clock_mhz,parameter,change
//! frame,41,0.684,1.902,16.671,512x512,2,1,bvh,20480,786432,1980,,
//! change,42,0.701,,,,,,,,,,bounces,2->3
//! frame,42,0.701,2.514,16.669,512x512,3,1,bvh,20480,1048576,1980,,
//! ```
//!
//! `acceleration` is bvh, brute or vendor, or for our BVH in a wide layout the layout's name
//! (wide, wide-runs). `gpu_clock_mhz` is the tracing GPU's shader clock as last read (`gpu_clock`; empty on CPU
//! devices): a GPU that idles between frames is clocked down and traces slower.
//!
//! A change row comes just before the first frame traced with the new value. A value that
//! moves over several frames (a slider or the camera dragged) gives one row once it holds
//! still for a frame, from where it started to where it stopped: frame rows are held back
//! one frame so the change row can still precede the frame where the move ended.

use std::io::{self, Write};
use std::path::{Path, PathBuf};

use crate::app::measure::frame_stats::FrameStats;
use crate::app::state::{Params, Resolution};
use crate::app::status::Status;
use crate::files::LogFile;
use crate::render_settings::{tracer_label, Accel, BvhLayout, RenderSettings};

/// The CSV header line.
pub(crate) const HEADER: &str = "row,frame,time_s,gpu_ms,frame_ms,resolution,bounces,spp,acceleration,triangles,rays,gpu_clock_mhz,parameter,change";

/// One traced frame's numbers.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct FrameRow {
    /// Seconds since the tool started (the log writes them from its first frame).
    pub(crate) time_s: f64,
    /// The latest GPU trace time measured (timestamps arrive a frame or two late).
    pub(crate) gpu_ms: Option<f64>,
    /// Time since the previous displayed frame began.
    pub(crate) frame_ms: Option<f64>,
    /// Traced width and height.
    pub(crate) size: [u32; 2],
    /// Mirror bounces after the primary hit.
    pub(crate) bounces: u32,
    /// Camera samples per pixel.
    pub(crate) spp: u32,
    /// BVH or brute force.
    pub(crate) accel: Accel,
    /// The BVH layout (the column names it for a wide one).
    pub(crate) bvh: BvhLayout,
    /// Triangles in the scene (all copies).
    pub(crate) triangles: u64,
    /// Rays the frame traces at most (every pixel, sample and bounce).
    pub(crate) rays: u64,
    /// The tracing GPU's shader clock as last read, MHz.
    pub(crate) gpu_clock_mhz: Option<f64>,
}

/// A watched parameter and its value as text.
pub(crate) type Watched = (&'static str, String);

/// A parameter that changed: its name, the old and the new value.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Change {
    /// The parameter, named as in the panel.
    pub(crate) name: &'static str,
    /// Its value before.
    pub(crate) from: String,
    /// Its value after.
    pub(crate) to: String,
}

/// The parameters the log watches, named as in the panel, with their values as text.
/// The light's position is watched only while it is paused: an orbiting light moves every
/// frame, which would be a change row per frame.
pub(crate) fn watched(p: &Params, model: &str) -> Vec<Watched> {
    let s = &p.scene.settings;
    let on = |b: bool| if b { "on" } else { "off" }.to_string();
    let v = |x: glam::Vec3| format!("{:.3} {:.3} {:.3}", x.x, x.y, x.z);
    let resolution = match p.resolution {
        Resolution::Square(n) => format!("{n}x{n}"),
        Resolution::MatchWindow => "match window".into(),
        Resolution::Custom => format!("{}x{} custom", p.custom[0], p.custom[1]),
    };
    let environment = match &p.scene.environment {
        None => "none".into(),
        Some(crate::scene::EnvironmentSource::Sky) => "sky".into(),
        Some(crate::scene::EnvironmentSource::File(f)) => f.display().to_string(),
    };
    let light = if p.light_paused {
        format!("paused at {:.1}°", p.scene.light.angle_deg)
    } else {
        format!("orbiting at {:.0}°/s", p.light_speed)
    };
    vec![
        ("model", model.to_string()),
        ("copies", p.scene.models.to_string()),
        ("resolution", resolution),
        ("bounces", s.bounces.to_string()),
        ("blend", format!("{:.2}", s.blend)),
        ("acceleration", s.accel.to_string()),
        ("view", p.view.label().to_string()),
        ("smooth", on(s.smooth)),
        ("textures", on(s.textures)),
        ("spp", s.spp.to_string()),
        ("adaptive", on(s.adaptive)),
        ("accumulate", on(p.accumulate)),
        ("environment", environment),
        ("mirror box", on(p.scene.mirror_box)),
        ("light", light),
        ("light radius", format!("{:.2}", p.scene.light.radius)),
        ("light height", format!("{:.2}", p.scene.light.height)),
        (
            "camera",
            format!(
                "eye {} target {} fov {:.1}",
                v(p.camera.position),
                v(p.camera.target),
                p.camera.vfov_deg
            ),
        ),
        ("vsync", on(p.vsync)),
        // Drawing the panel and the numbers costs frame time too.
        ("panel", on(p.panel_visible)),
        ("hud", on(p.hud_visible)),
    ]
}

/// The watched values that differ between `before` and `after` (two [`watched`] lists).
pub(crate) fn diff(before: &[Watched], after: &[Watched]) -> Vec<Change> {
    after
        .iter()
        .filter_map(|(name, to)| {
            let from = before.iter().find(|(n, _)| n == name).map(|(_, v)| v)?;
            (from != to).then(|| Change { name, from: from.clone(), to: to.clone() })
        })
        .collect()
}

/// A CSV field: quoted when it holds a comma, a quote or a line break.
fn field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

fn ms(v: Option<f64>) -> String {
    v.map_or(String::new(), |v| format!("{v:.3}"))
}

/// The CSV line of frame `index`, `time_s` after the log's first frame.
pub(crate) fn frame_line(index: u64, time_s: f64, r: &FrameRow) -> String {
    format!(
        "frame,{index},{time_s:.3},{},{},{}x{},{},{},{},{},{},{},,",
        ms(r.gpu_ms),
        ms(r.frame_ms),
        r.size[0],
        r.size[1],
        r.bounces,
        r.spp,
        tracer_label(r.accel, r.bvh),
        r.triangles,
        r.rays,
        r.gpu_clock_mhz.map_or(String::new(), |m| format!("{m:.0}"))
    )
}

/// The CSV line of a change that takes effect at frame `index`.
pub(crate) fn change_line(index: u64, time_s: f64, c: &Change) -> String {
    format!(
        "change,{index},{time_s:.3},,,,,,,,,,{},{}",
        field(c.name),
        field(&format!("{}->{}", c.from, c.to))
    )
}

/// The log being written: the CSV output and what it needs to place change rows.
pub(crate) struct FrameLog<W: Write> {
    out: W,
    /// Frames logged so far (the next frame's index).
    frames: u64,
    /// The first frame's time, where the log's clock starts.
    t0: Option<f64>,
    /// The watched values of the latest frame.
    last: Vec<Watched>,
    /// Values still moving: name and where the move started.
    moving: Vec<Watched>,
    /// The latest frame, written once the next one shows whether a change ended on it.
    held: Option<(u64, f64, FrameRow)>,
}

impl<W: Write> FrameLog<W> {
    /// Start a log on `out`, writing the header.
    pub(crate) fn new(mut out: W) -> io::Result<Self> {
        writeln!(out, "{HEADER}")?;
        Ok(Self { out, frames: 0, t0: None, last: Vec::new(), moving: Vec::new(), held: None })
    }

    /// Frames logged so far.
    pub(crate) fn frames(&self) -> u64 {
        self.frames
    }

    /// Log a traced frame and the parameters it was traced with.
    pub(crate) fn frame(&mut self, row: FrameRow, now: Vec<Watched>) -> io::Result<()> {
        let changed = diff(&self.last, &now);
        // Moves that did not go on into this frame ended on the held frame.
        let (ended, still): (Vec<Watched>, Vec<Watched>) = std::mem::take(&mut self.moving)
            .into_iter()
            .partition(|(name, _)| !changed.iter().any(|c| c.name == *name));
        self.moving = still;
        self.write_held(&ended)?;
        for c in changed {
            if !self.moving.iter().any(|(n, _)| *n == c.name) {
                self.moving.push((c.name, c.from));
            }
        }
        let t0 = *self.t0.get_or_insert(row.time_s);
        self.held = Some((self.frames, row.time_s - t0, row));
        self.frames += 1;
        self.last = now;
        self.out.flush()
    }

    /// Write the held frame, preceded by the change rows of the moves in `ended`.
    fn write_held(&mut self, ended: &[Watched]) -> io::Result<()> {
        let Some((index, t, row)) = self.held.take() else { return Ok(()) };
        // In the order of the watched list, so simultaneous changes (a preset) read the same every time.
        for (name, to) in &self.last {
            if let Some((_, from)) = ended.iter().find(|(n, _)| n == name) {
                if from != to {
                    writeln!(
                        self.out,
                        "{}",
                        change_line(index, t, &Change { name, from: from.clone(), to: to.clone() })
                    )?;
                }
            }
        }
        writeln!(self.out, "{}", frame_line(index, t, &row))
    }

    /// Write what is held back and flush; returns the output.
    pub(crate) fn finish(mut self) -> io::Result<W> {
        let ended = std::mem::take(&mut self.moving);
        self.write_held(&ended)?;
        self.out.flush()?;
        Ok(self.out)
    }
}

/// The tool's recording: a log on a file, started by `--stats-csv` or the panel.
pub(crate) struct Recording {
    /// The file written.
    pub(crate) path: PathBuf,
    log: FrameLog<LogFile>,
}

impl Recording {
    /// Create (or replace) `path` and write the header.
    pub(crate) fn create(path: &Path) -> Result<Self, String> {
        let fail = |e: io::Error| {
            format!("cannot write the frame log {}: {e}", crate::files::shown_path(path))
        };
        let file = crate::files::create_log(path).map_err(fail)?;
        Ok(Self { path: path.to_path_buf(), log: FrameLog::new(file).map_err(fail)? })
    }

    /// Frames logged so far.
    pub(crate) fn frames(&self) -> u64 {
        self.log.frames()
    }

    /// Log a traced frame; the error is one sentence naming the file.
    pub(crate) fn frame(&mut self, row: FrameRow, now: Vec<Watched>) -> Result<(), String> {
        self.log.frame(row, now).map_err(|e| {
            format!("writing the frame log {} failed: {e}", crate::files::shown_path(&self.path))
        })
    }

    /// Close the file; returns what to tell the user.
    pub(crate) fn finish(self) -> Result<String, String> {
        let frames = self.log.frames();
        match self.log.finish() {
            Ok(_) => {
                Ok(format!("wrote {frames} frames to {}", crate::files::shown_path(&self.path)))
            }
            Err(e) => Err(format!(
                "writing the frame log {} failed: {e}",
                crate::files::shown_path(&self.path)
            )),
        }
    }
}

impl FrameRow {
    /// The row of a frame traced with `settings` at `time_s`: the latest times of `stats`.
    pub(crate) fn new(
        time_s: f64,
        stats: &FrameStats,
        settings: &RenderSettings,
        triangles: u64,
        gpu_clock_mhz: Option<f64>,
    ) -> Self {
        Self {
            time_s,
            gpu_ms: stats.gpu.samples.back().map(|s| s.1),
            // Only a frame-to-frame time measured at this frame (none after a pause).
            frame_ms: stats.frame.samples.back().filter(|s| s.0 == time_s).map(|s| s.1),
            size: [settings.width, settings.height],
            bounces: settings.bounces,
            spp: settings.spp,
            accel: settings.accel,
            bvh: settings.bvh,
            triangles,
            rays: settings.max_rays(),
            gpu_clock_mhz,
        }
    }
}

/// The tool's frame-time log: at most one recording at a time, from `--stats-csv` or the
/// panel's Record, and what became of the last one.
#[derive(Default)]
pub(crate) struct Recorder {
    recording: Option<Recording>,
    /// A write failure of `--stats-csv`'s log, reported again at exit (a script must see it).
    failure: Option<String>,
    /// The recording running is `--stats-csv`'s.
    from_flag: bool,
}

impl Recorder {
    /// Start `--stats-csv`'s log; a file that cannot be created stops the tool.
    pub(crate) fn from_flag(path: Option<&Path>) -> Result<Self, String> {
        let recording = path.map(Recording::create).transpose()?;
        Ok(Self { from_flag: recording.is_some(), recording, failure: None })
    }

    /// The file being written and its frames so far.
    pub(crate) fn info(&self) -> Option<(&Path, u64)> {
        self.recording.as_ref().map(|r| (r.path.as_path(), r.frames()))
    }

    /// Start a log from the panel in `dir`.
    pub(crate) fn start(&mut self, dir: &Path) -> Option<Status> {
        if self.recording.is_some() {
            return None;
        }
        match Recording::create(&new_path(dir)) {
            Ok(r) => {
                self.recording = Some(r);
                self.from_flag = false;
                None
            }
            Err(e) => Some(Status::error(e)),
        }
    }

    /// Close the log; what to tell the user.
    pub(crate) fn stop(&mut self) -> Option<Status> {
        let finished = self.recording.take()?.finish();
        Some(self.outcome(finished))
    }

    fn outcome(&mut self, finished: Result<String, String>) -> Status {
        match finished {
            Ok(text) => Status::ok(text),
            Err(e) => {
                if self.from_flag {
                    self.failure = Some(e.clone());
                }
                Status::error(e)
            }
        }
    }

    /// Log a traced frame; a write failure ends the log and is returned.
    pub(crate) fn frame(
        &mut self,
        row: impl FnOnce() -> (FrameRow, Vec<Watched>),
    ) -> Option<Status> {
        let recording = self.recording.as_mut()?;
        let (row, now) = row();
        let e = recording.frame(row, now).err()?;
        self.recording = None;
        Some(self.outcome(Err(e)))
    }

    /// Close the log at exit; returns the line to print. `--stats-csv`'s failures are
    /// the run's error; the panel's were shown in the panel.
    pub(crate) fn finish(&mut self) -> Result<Option<String>, String> {
        let status = self.stop();
        match self.failure.take() {
            Some(e) => Err(e),
            None => Ok(status.filter(|s| !s.error).map(|s| s.text)),
        }
    }
}

/// A fresh file name in `dir` for a log recorded from the panel.
pub(crate) fn new_path(dir: &Path) -> PathBuf {
    let stamp = crate::app::user_files::screenshot::timestamp();
    let mut path = dir.join(format!("meshtracer_frames_{stamp}.csv"));
    let mut n = 2;
    while path.exists() {
        path = dir.join(format!("meshtracer_frames_{stamp}_{n}.csv"));
        n += 1;
    }
    path
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::spec::SceneSpec;

    fn row(t: f64, bounces: u32) -> FrameRow {
        FrameRow {
            time_s: t,
            gpu_ms: Some(1.5),
            frame_ms: Some(16.6667),
            size: [512, 256],
            bounces,
            spp: 1,
            accel: Accel::Bvh,
            bvh: BvhLayout::Binary,
            triangles: 20480,
            rays: 512 * 256 * (bounces as u64 + 1),
            gpu_clock_mhz: Some(1980.4),
        }
    }

    fn params() -> Params {
        Params::new(&SceneSpec::default(), true)
    }

    fn lines(log: FrameLog<Vec<u8>>) -> Vec<String> {
        String::from_utf8(log.finish().unwrap()).unwrap().lines().map(str::to_string).collect()
    }

    #[test]
    fn rows_have_the_header_columns() {
        let columns = HEADER.split(',').count();
        let f = frame_line(3, 0.25, &row(10.0, 2));
        assert_eq!(f, "frame,3,0.250,1.500,16.667,512x256,2,1,bvh,20480,393216,1980,,");
        let c = change_line(4, 0.5, &Change { name: "camera", from: "a,b".into(), to: "c".into() });
        assert_eq!(c, "change,4,0.500,,,,,,,,,,camera,\"a,b->c\"");
        let unknown = frame_line(
            0,
            0.0,
            &FrameRow { gpu_ms: None, frame_ms: None, gpu_clock_mhz: None, ..row(0.0, 2) },
        );
        assert!(unknown.starts_with("frame,0,0.000,,,512x256,"), "{unknown}");
        for line in [
            f,
            unknown,
            change_line(0, 0.0, &Change { name: "bounces", from: "2".into(), to: "3".into() }),
        ] {
            assert_eq!(line.split(',').count(), columns, "{line}");
        }
    }

    #[test]
    fn the_diff_names_the_changed_parameters() {
        let a = params();
        let mut b = a.clone();
        assert!(diff(&watched(&a, "geosphere"), &watched(&b, "geosphere")).is_empty());
        b.scene.settings.bounces = 3;
        b.scene.settings.accel = Accel::Brute;
        let changes = diff(&watched(&a, "geosphere"), &watched(&b, "sphere"));
        let named: Vec<String> =
            changes.iter().map(|c| format!("{} {}->{}", c.name, c.from, c.to)).collect();
        assert_eq!(named, ["model geosphere->sphere", "bounces 2->3", "acceleration bvh->brute"]);
        // An orbiting light moves every frame without being a change.
        let mut moving = a.clone();
        moving.light_paused = false;
        let mut later = moving.clone();
        later.scene.light.angle_deg += 10.0;
        assert!(diff(&watched(&moving, ""), &watched(&later, "")).is_empty());
    }

    #[test]
    fn a_key_change_comes_before_its_first_frame() {
        let mut log = FrameLog::new(Vec::new()).unwrap();
        let (a, mut b) = (params(), params());
        b.scene.settings.bounces = 3;
        log.frame(row(5.0, 2), watched(&a, "m")).unwrap();
        log.frame(row(5.1, 3), watched(&b, "m")).unwrap();
        log.frame(row(5.2, 3), watched(&b, "m")).unwrap();
        assert_eq!(log.frames(), 3);
        let lines = lines(log);
        assert_eq!(lines[0], HEADER);
        assert!(lines[1].starts_with("frame,0,0.000,"), "{}", lines[1]);
        assert_eq!(lines[2], "change,1,0.100,,,,,,,,,,bounces,2->3");
        assert!(
            lines[3].starts_with("frame,1,0.100,") && lines[3].contains(",3,1,bvh,"),
            "{}",
            lines[3]
        );
        assert!(lines[4].starts_with("frame,2,"));
        assert_eq!(lines.len(), 5);
    }

    #[test]
    fn a_drag_is_one_change_from_start_to_end() {
        let mut log = FrameLog::new(Vec::new()).unwrap();
        let mut p = params();
        for (i, blend) in [0.5, 0.6, 0.7, 0.8, 0.8, 0.8].into_iter().enumerate() {
            p.scene.settings.blend = blend;
            log.frame(row(i as f64, 2), watched(&p, "m")).unwrap();
        }
        let lines = lines(log);
        let changes: Vec<&String> = lines.iter().filter(|l| l.starts_with("change")).collect();
        assert_eq!(changes, ["change,3,3.000,,,,,,,,,,blend,0.50->0.80"]);
        // Placed before frame 3, the first traced at 0.8.
        let at = lines.iter().position(|l| l.starts_with("change")).unwrap();
        assert!(lines[at + 1].starts_with("frame,3,"));
        assert_eq!(lines.iter().filter(|l| l.starts_with("frame")).count(), 6);
    }

    #[test]
    fn a_change_on_the_last_frame_is_still_written() {
        let mut log = FrameLog::new(Vec::new()).unwrap();
        let mut p = params();
        log.frame(row(0.0, 2), watched(&p, "m")).unwrap();
        p.scene.settings.spp = 4;
        log.frame(row(0.1, 2), watched(&p, "m")).unwrap();
        let lines = lines(log);
        assert_eq!(lines[2], "change,1,0.100,,,,,,,,,,spp,1->4");
        assert!(lines[3].starts_with("frame,1,"));
    }

    #[test]
    fn a_file_that_cannot_be_created_is_one_sentence() {
        let Err(e) = Recorder::from_flag(Some(Path::new("/nonexistent-dir/x.csv"))) else {
            panic!("created a file in a missing folder")
        };
        assert!(e.starts_with("cannot write the frame log /nonexistent-dir/x.csv: "), "{e}");
        assert!(!e.contains('\n'));
        let mut panel = Recorder::default();
        assert!(panel.start(Path::new("/nonexistent-dir")).is_some_and(|s| s.error));
        assert!(panel.info().is_none());
    }

    #[test]
    fn the_recorder_writes_a_file_from_the_panel() {
        let dir = std::env::temp_dir().join(format!("meshtracer-frame-log-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut recorder = Recorder::default();
        assert!(recorder.frame(|| unreachable!("nothing is recorded")).is_none());
        assert!(recorder.start(&dir).is_none());
        let p = params();
        for i in 0..3 {
            assert!(recorder.frame(|| (row(i as f64, 2), watched(&p, "m"))).is_none());
        }
        let path = recorder.info().unwrap().0.to_path_buf();
        let status = recorder.stop().unwrap();
        assert!(!status.error && status.text.starts_with("wrote 3 frames to "), "{}", status.text);
        let text = std::fs::read_to_string(&path).unwrap();
        assert_eq!(text.lines().count(), 4);
        assert_eq!(recorder.finish(), Ok(None), "nothing left open");
        // One left open is closed at exit.
        assert!(recorder.start(&dir).is_none());
        assert!(recorder.finish().unwrap().unwrap().starts_with("wrote 0 frames"));
        std::fs::remove_dir_all(dir).unwrap();
    }
}
