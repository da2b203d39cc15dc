//! The one shape every panel section has: a title, whether it opens the first time, and a
//! body drawn from what the section is given ([`Cx`]), asking the tool for anything beyond
//! the parameters through [`PanelAction`]s. A leaf: it knows no section.

use std::path::PathBuf;

use egui::Ui;

use crate::app::panel::info::PanelInfo;
use crate::app::state::Params;
use crate::app::user_files::open_dialog::Purpose;
use crate::gpu::khr_rt::VendorKernel;
use crate::scene::paper::ModelSource;

/// What the panel asks the tool to do beyond changing parameters.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum PanelAction {
    /// Load a built-in, generated or .obj model.
    LoadModel(ModelSource),
    /// Stop the load in progress; the model shown stays.
    CancelLoad,
    /// Load this .obj exactly as a file dropped on the window (the Open dialog's pick).
    LoadFile(PathBuf),
    /// Show the Open dialog for a model or a preset.
    Open(Purpose),
    /// The traced image as a PNG at render resolution.
    ScreenshotTrace,
    /// The window as seen, panel included, as a PNG.
    ScreenshotWindow,
    /// The traced float output of the view shown, as OpenEXR.
    ScreenshotExr,
    /// Save the current look as a preset; replace an existing file only with `overwrite`.
    SavePreset { path: PathBuf, overwrite: bool },
    /// Take the look of a preset file (or of a PNG the program wrote).
    LoadPreset(PathBuf),
    /// Start a benchmark run of this many frames.
    Benchmark(u32),
    /// Stop the benchmark run in progress without a summary.
    CancelBenchmark,
    /// Start the frame-time log (a new CSV in the screenshot folder).
    Record,
    /// Close the frame-time log.
    StopRecording,
    /// Forget the remembered settings and put the window and sections back as they open.
    ResetSettings,
    /// Trace vendor frames with this kind of vendor tracing.
    VendorKernel(VendorKernel),
}

/// What a section is handed each frame: the parameters it edits, the facts it shows, and
/// the list its actions go to.
pub(crate) struct Cx<'a, 'i> {
    /// The parameters the controls edit in place.
    pub(crate) params: &'a mut Params,
    /// Read-only facts to show.
    pub(crate) info: &'a PanelInfo<'i>,
    /// What the tool is asked to do after the frame.
    pub(crate) actions: &'a mut Vec<PanelAction>,
}

/// A panel section: its state is `self`, kept between frames.
pub(crate) trait Section {
    /// The header's title, also the name under which its openness is remembered.
    fn title(&self) -> &'static str;
    /// Whether the section is open the first time (before anything is remembered).
    fn default_open(&self) -> bool;
    /// Draw the section's body (the header is drawn around it by the panel).
    fn body(&mut self, ui: &mut Ui, cx: &mut Cx);
}
