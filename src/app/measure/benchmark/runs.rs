//! The tool's benchmark runs: starting one when asked, keeping it on its orbit, stopping it
//! when the settings change, and its summary at the end (`--benchmark` quits after it).

use std::path::PathBuf;

use super::{append_json, json_path, Benchmark, Outcome, Workload};
use crate::app::state::Params;
use crate::app::status::Status;
use crate::bench::Environment;

/// The tool's benchmark runs: the one in progress, one asked for (begun at the next
/// frame, when the image area is known), and what `--benchmark` asked.
#[derive(Default)]
pub(crate) struct Runs {
    run: Option<Benchmark>,
    wanted: Option<u32>,
    /// `--benchmark`: quit when the run ends; an unfinished run is an error.
    quit_after: bool,
    /// `--benchmark-json`.
    json: Option<PathBuf>,
}

impl Runs {
    /// Runs as the command line asks: `frames` starts one at once and quits after it.
    pub(crate) fn new(frames: Option<u32>, json: Option<PathBuf>) -> Self {
        Self { run: None, wanted: frames, quit_after: frames.is_some(), json }
    }

    /// Start a run of `frames` at the next frame (replacing one in progress).
    pub(crate) fn want(&mut self, frames: u32) {
        self.wanted = Some(frames);
    }

    /// (measured, total) frames of the run in progress.
    pub(crate) fn progress(&self) -> Option<(u32, u32)> {
        self.run.as_ref().map(Benchmark::progress)
    }

    /// Before a frame: begin a run asked for, or keep the one in progress on its orbit and
    /// settings (a change of settings stops it).
    pub(crate) fn before_frame(
        &mut self,
        params: &mut Params,
        area: [u32; 2],
        outcome: &mut Outcome,
    ) -> anyhow::Result<()> {
        if let Some(frames) = self.wanted.take() {
            if let Some(old) = self.run.take() {
                old.restore(params);
            }
            self.run = Some(Benchmark::begin(frames, params, area));
            outcome.status = Some(Status::ok(format!("running {frames} frames ...")));
        }
        match &mut self.run {
            Some(run) if run.settings_changed(&params.settings_for(area)) => self.stop(
                "the benchmark stopped: the settings changed during the run",
                params,
                outcome,
            ),
            Some(run) => {
                run.hold(params);
                Ok(())
            }
            None => Ok(()),
        }
    }

    /// End the run in progress without a summary, saying `why` (an error under `--benchmark`).
    pub(crate) fn stop(
        &mut self,
        why: &str,
        params: &mut Params,
        outcome: &mut Outcome,
    ) -> anyhow::Result<()> {
        let Some(run) = self.run.take() else { return Ok(()) };
        run.restore(params);
        let (done, total) = run.progress();
        let text = format!("{why} after {done} of {total} frames");
        if self.quit_after {
            anyhow::bail!("{text}");
        }
        outcome.status = Some(Status::error(text));
        Ok(())
    }

    /// After a frame: `traced` when it presented a whole traced frame at `t` seconds;
    /// `gpu_ms` when a frame's GPU time arrived; `clock_mhz` the shader clock as last read.
    pub(crate) fn after_frame(
        &mut self,
        t: f64,
        traced: bool,
        gpu_ms: Option<f64>,
        clock_mhz: Option<f64>,
    ) {
        if let Some(run) = &mut self.run {
            if traced {
                run.frame_traced(t);
            }
            if let Some(ms) = gpu_ms {
                run.gpu_time(ms);
            }
            if let Some(mhz) = clock_mhz {
                run.clock_reading(mhz);
            }
        }
    }

    /// A finished run's summary printed, shown and appended to the JSON file; true when
    /// the tool should quit now (`--benchmark`, where a file not written is an error).
    pub(crate) fn finish(
        &mut self,
        params: &mut Params,
        outcome: &mut Outcome,
        workload: impl FnOnce(&Params) -> Workload,
        environment: impl FnOnce() -> Environment,
    ) -> anyhow::Result<bool> {
        let Some(run) = self.run.take_if(|r| r.is_finished()) else { return Ok(false) };
        run.restore(params);
        let summary = run.summary(workload(params), environment());
        let lines = summary.lines();
        for line in &lines {
            println!("{line}");
        }
        let path =
            json_path(self.json.as_deref(), &crate::app::user_files::screenshot::screenshot_dir());
        let written = append_json(&path, &summary);
        outcome.lines = lines;
        outcome.status = Some(match &written {
            Ok(()) => {
                println!("appended to {}", crate::files::shown_path(&path));
                Status::ok(format!(
                    "appended to {}",
                    crate::files::shown_path(&crate::files::canonical_or_given(&path))
                ))
            }
            Err(e) => Status::error(e.clone()),
        });
        if self.quit_after {
            written.map_err(anyhow::Error::msg)?;
        }
        Ok(self.quit_after)
    }

    /// At exit: under `--benchmark`, a run not finished is an error.
    pub(crate) fn check_exit(&self) -> anyhow::Result<()> {
        match (&self.run, self.quit_after) {
            (Some(run), true) => {
                let (done, total) = run.progress();
                anyhow::bail!("the benchmark was stopped after {done} of {total} frames (the window was closed)")
            }
            _ => Ok(()),
        }
    }
}
