//! The read-only facts the panel (and the HUD over the image) show, gathered by the tool
//! once a frame. A leaf: it knows no section.

use crate::app::measure::frame_stats::FrameStats;
use crate::app::user_files::model_loader::LoadStatus;
use crate::gpu::khr_rt::{AccelStats, VendorKernel};
use crate::render_settings::RenderSettings;
use crate::scene::paper::ModelSource;
use crate::tracer::packed::SceneHolds;

/// The vendor path as the panel shows it.
#[derive(Clone, Debug, Default)]
pub(crate) struct VendorInfo {
    /// Why the device cannot trace with the vendor's structures (greys the choice out).
    pub(crate) unavailable: Option<String>,
    /// The kind in use, and every kind the device has.
    pub(crate) kernel: Option<VendorKernel>,
    pub(crate) kernels: Vec<VendorKernel>,
    /// What the last change built, once something was.
    pub(crate) stats: Option<AccelStats>,
}

/// Read-only facts the panel shows.
pub(crate) struct PanelInfo<'a> {
    /// The tracing device's name.
    pub(crate) device: &'a str,
    /// The measured choice of BVH layout, in words, while the panel's layout is "auto".
    pub(crate) auto_layout: Option<String>,
    /// The tracing GPU's shader clock in MHz: the latest reading and the highest seen.
    pub(crate) clock_mhz: Option<(f64, f64)>,
    /// The model shown (None before the first load).
    pub(crate) model: Option<&'a ModelSource>,
    pub(crate) triangles: u64,
    pub(crate) vertices: u64,
    /// What the scene holds: meshes, instances, and the two levels' sizes.
    pub(crate) holds: Option<SceneHolds>,
    /// What a frame traced now asks for (a GPU time is shown only for a frame of these).
    pub(crate) settings: RenderSettings,
    /// A load in progress: the model and its phases so far.
    pub(crate) loading: Option<LoadStatus<'a>>,
    pub(crate) present_mode: String,
    pub(crate) vsync_off_available: bool,
    /// (scale top, max, mean) of the heat map shown.
    pub(crate) heat: Option<(f32, f32, f32)>,
    /// What the colours of a depth, normal or primitive-id view mean.
    pub(crate) view_note: Option<&'a str>,
    /// Frames averaged into the image shown (progressive accumulation).
    pub(crate) accumulated_frames: u32,
    /// Share of a long frame traced so far, while it is traced in bands, and the seconds
    /// it still needs at the pace so far.
    pub(crate) progress: Option<(f32, Option<f64>)>,
    /// Ray-triangle tests one frame of brute force would ask for.
    pub(crate) brute_tests: f64,
    /// Ray-triangle tests one submission may ask of the tracing device: a frame over it is
    /// traced in bands.
    pub(crate) submission_tests: f64,
    pub(crate) screenshot_dir: String,
    /// The frame-time history.
    pub(crate) stats: &'a FrameStats,
    /// (measured, total) frames of a benchmark run in progress.
    pub(crate) benchmark: Option<(u32, u32)>,
    /// The frame-time log being written: its file and frames so far.
    pub(crate) recording: Option<(&'a std::path::Path, u64)>,
    /// Where the remembered settings live (None: `--no-persist` or a scripted run).
    pub(crate) settings_file: Option<&'a std::path::Path>,
    /// The vendor's ray tracing on this device.
    pub(crate) vendor: &'a VendorInfo,
    /// The latest GPU time of each half of the split view.
    pub(crate) split_ms: crate::gpu::PartTimes,
}
