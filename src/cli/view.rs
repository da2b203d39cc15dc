//! `meshtracer view`'s flags: the scene's (shared with `render` and `bench`) and the
//! window's, turned into the tool's options.

use std::path::PathBuf;

use clap::Args;

use super::args::{BvhChoice, SceneArgs};
use crate::app::measure::benchmark::DEFAULT_FRAMES;
use crate::app::SplitView;
use crate::render_settings::{Aov, BvhLayout};

/// `meshtracer view`.
#[derive(Args, Debug, Clone)]
pub struct ViewArgs {
    #[command(flatten)]
    pub(crate) scene: SceneArgs,
    /// Quit after this many frames (for scripts and tests).
    #[arg(long, conflicts_with = "benchmark")]
    pub(crate) frames: Option<u64>,
    /// Trace on this Vulkan device (see `meshtracer devices`) and show its frames through
    /// the window's device (--device, or the best one that can present): for a GPU that
    /// cannot present, such as a compute GPU on a server reached through VNC. Happens by
    /// itself when the device picked for the window cannot show it.
    #[arg(long, value_name = "INDEX")]
    pub(crate) trace_device: Option<usize>,
    /// Run the benchmark (the camera orbits once in N frames at the given settings), print
    /// its summary, append it to --benchmark-json, and quit: 0 on success, 1 on a failure.
    #[arg(long, value_name = "N", num_args = 0..=1, value_parser = clap::value_parser!(u32).range(1..=1_000_000), allow_negative_numbers = true)]
    pub(crate) benchmark: Option<Option<u32>>,
    /// Append each benchmark's summary (this run's, or the panel's) to this file as one
    /// line of JSON [default: meshtracer_benchmark.jsonl in the screenshot folder].
    #[arg(long, value_name = "FILE")]
    pub(crate) benchmark_json: Option<PathBuf>,
    /// Write the traced image (render resolution) to this PNG at exit.
    #[arg(long)]
    pub(crate) screenshot: Option<PathBuf>,
    /// Write the window as seen, panel included, to this PNG at exit.
    #[arg(long)]
    pub(crate) screenshot_ui: Option<PathBuf>,
    /// Initial window size as WIDTHxHEIGHT [default: the size it had when last closed, or 1280x800].
    #[arg(long)]
    pub(crate) window: Option<String>,
    /// Turn on the Vulkan validation layer (also MESHTRACER_VALIDATION=1).
    #[arg(long)]
    pub(crate) validation: bool,
    /// Start with the numbers over the image hidden (the I key shows them).
    #[arg(long)]
    pub(crate) no_hud: bool,
    /// Write the frame-time log to this CSV file: a row per traced frame (time, GPU and
    /// frame ms, resolution, bounces, spp, acceleration, triangles, rays) and a row per
    /// parameter change, naming it.
    #[arg(long, value_name = "FILE")]
    pub(crate) stats_csv: Option<PathBuf>,
    /// Neither read nor write the remembered settings (window size, open panel sections,
    /// recent presets); runs with --frames or --benchmark never do.
    #[arg(long)]
    pub(crate) no_persist: bool,
    /// Recompile DIR/trace.comp (a copy of shaders/) when a file in DIR changes and trace
    /// with it; a compile error is shown in the panel and the last good shader stays.
    #[arg(long, value_name = "DIR")]
    pub(crate) watch_shaders: Option<PathBuf>,
    /// Open with the A/B split view on, its line at FRACTION of the image width (0..1):
    /// left of it the settings given, right of it those changed by --split-b.
    #[arg(long, value_name = "FRACTION", num_args = 0..=1)]
    pub(crate) split: Option<Option<f32>>,
    /// What the right half (B) of the split view changes, as name=value pairs: accel=bvh|brute,
    /// bounces=N, blend=X, spp=N, adaptive|smooth|textures|env=on|off (e.g. bounces=0,smooth=off).
    /// Turns the split on (at 0.5 without --split).
    #[arg(long, value_name = "LIST")]
    pub(crate) split_b: Option<String>,
}

/// A screenshot is written as PNG (with its preset): the path must say so, and its folder
/// must take the file, before the session rather than at its end.
fn check_png_output(flag: &str, path: &std::path::Path) -> anyhow::Result<()> {
    if !path.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")) {
        anyhow::bail!(
            "{flag} {}: screenshots are written as PNG; give a path ending in .png",
            crate::files::shown_path(path)
        );
    }
    crate::files::check_writable(path)
}

impl ViewArgs {
    /// The tool's options: the CLI sits on top of the app, not the other way round.
    pub fn options(&self) -> anyhow::Result<crate::app::ViewOptions> {
        let window = self
            .window
            .as_deref()
            .map(crate::app::parse_window_size)
            .transpose()
            .map_err(anyhow::Error::msg)?;
        for (flag, path) in
            [("--screenshot", &self.screenshot), ("--screenshot-ui", &self.screenshot_ui)]
        {
            if let Some(path) = path {
                check_png_output(flag, path)?;
            }
        }
        let (spec, warnings) = self.scene.resolve(Aov::Color, true)?;
        for w in &warnings {
            log::warn!("{w}");
        }
        let scripted = self.frames.is_some() || self.benchmark.is_some();
        let auto_layout = match self.scene.bvh {
            // A preset's binary (also what one without a layout reads as) names none.
            _ if !self.scene.given("bvh") => {
                !scripted && (self.scene.preset.is_none() || spec.settings.bvh == BvhLayout::Binary)
            }
            BvhChoice::Auto => true,
            BvhChoice::Layout(_) => false,
        };
        Ok(crate::app::ViewOptions {
            spec,
            preset: self.scene.preset.clone(),
            device: self.scene.device,
            bvh_builder: self.scene.bvh_build,
            trace_device: self.trace_device,
            frames: self.frames,
            screenshot: self.screenshot.clone(),
            screenshot_ui: self.screenshot_ui.clone(),
            window,
            validation: self.validation,
            hud: !self.no_hud,
            watch_shaders: self.watch_shaders.clone(),
            benchmark: self.benchmark.map(|n| n.unwrap_or(DEFAULT_FRAMES)),
            benchmark_json: self.benchmark_json.clone(),
            stats_csv: self.stats_csv.clone(),
            no_persist: self.no_persist,
            split: self.split_view()?,
            auto_layout,
        })
    }

    /// The split view `--split` and `--split-b` ask for (off without either).
    fn split_view(&self) -> anyhow::Result<SplitView> {
        let mut split = SplitView::default();
        if let Some(Some(x)) = self.split {
            if !(0.0..=1.0).contains(&x) {
                anyhow::bail!("--split {x} is out of range (0..=1, a share of the image width)");
            }
            split.position = x;
        }
        if let Some(text) = &self.split_b {
            split.b = crate::app::SplitB::parse(text).map_err(anyhow::Error::msg)?;
        }
        split.enabled = self.split.is_some() || self.split_b.is_some();
        Ok(split)
    }
}
