//! What the tool is started with: the scene spec and the run's options. The command line
//! fills it (`ViewArgs::options`); the app never reads command-line types.

use std::path::PathBuf;

use crate::scene::spec::SceneSpec;
use crate::tracer::packed::BvhBuilder;

/// How to start the interactive tool.
#[derive(Clone, Debug, Default)]
pub struct ViewOptions {
    /// The scene and frame settings to open on.
    pub(crate) spec: SceneSpec,
    /// The preset `spec` came from (the panel lists it among the recent ones).
    pub(crate) preset: Option<PathBuf>,
    /// Vulkan device index; None picks the fastest kind present.
    pub(crate) device: Option<usize>,
    /// Where the models' BVHs are built.
    pub(crate) bvh_builder: BvhBuilder,
    /// Trace on this device and show its frames through the window's device (`--device`,
    /// or the one picked); None: the window's device traces.
    pub(crate) trace_device: Option<usize>,
    /// Quit after this many traced frames (scripts and tests); the light starts paused.
    pub(crate) frames: Option<u64>,
    /// Write the traced image (render resolution) to this PNG at exit.
    pub(crate) screenshot: Option<PathBuf>,
    /// Write the window as seen, panel included, to this PNG at exit.
    pub(crate) screenshot_ui: Option<PathBuf>,
    /// Initial window size in logical pixels; None: the remembered size, or [`DEFAULT_WINDOW`].
    pub(crate) window: Option<[u32; 2]>,
    /// Turn on the Vulkan validation layer.
    pub(crate) validation: bool,
    /// Show the numbers over the image at the start.
    pub(crate) hud: bool,
    /// Recompile the trace shader from this folder when its files change (hot reload).
    pub(crate) watch_shaders: Option<PathBuf>,
    /// Run the benchmark of this many frames at the start, then quit.
    pub(crate) benchmark: Option<u32>,
    /// Append each benchmark's summary to this JSON Lines file (default: one in the
    /// screenshot folder).
    pub(crate) benchmark_json: Option<PathBuf>,
    /// Write the frame-time log (a CSV row per frame and per parameter change) to this file.
    pub(crate) stats_csv: Option<PathBuf>,
    /// Neither read nor write the remembered settings (scripted runs never do).
    pub(crate) no_persist: bool,
    /// The A/B split view at the start (`--split`, `--split-b`).
    pub(crate) split: crate::app::split::SplitView,
    /// Pick the BVH layout by timing each (neither `--bvh` nor the preset named one, and
    /// the run is not scripted: scripts trace what they ask for).
    pub(crate) auto_layout: bool,
}

impl ViewOptions {
    /// A scripted run ends by itself (after `frames`, or the benchmark) and starts with the light still.
    pub(crate) fn scripted(&self) -> bool {
        self.frames.is_some() || self.benchmark.is_some()
    }

    /// Whether the run reads and writes the remembered settings: a script must see the
    /// same tool whatever the user did in the window last.
    pub(crate) fn persist(&self) -> bool {
        !self.no_persist && !self.scripted()
    }
}

/// The window's size in logical pixels when neither `--window` nor a remembered size says.
pub(crate) const DEFAULT_WINDOW: [u32; 2] = [1280, 800];

/// Parse `--window WIDTHxHEIGHT`.
pub(crate) fn parse_window_size(s: &str) -> Result<[u32; 2], String> {
    let bad = || format!("--window '{s}' is not WIDTHxHEIGHT (e.g. 1280x800)");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let w: u32 = w.trim().parse().map_err(|_| bad())?;
    let h: u32 = h.trim().parse().map_err(|_| bad())?;
    if !(64..=16384).contains(&w) || !(64..=16384).contains(&h) {
        return Err(format!("--window {w}x{h} is out of range (64..=16384 per side)"));
    }
    Ok([w, h])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn window_size_parses() {
        assert_eq!(parse_window_size("640x480"), Ok([640, 480]));
        assert!(parse_window_size("640").is_err());
        assert!(parse_window_size("0x5").unwrap_err().contains("out of range"));
    }
}
