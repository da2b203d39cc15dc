//! What the UI pass keeps between frames: egui's state, the panel's, the Open dialog and
//! the image area the last frame laid out.

use crate::app::panel::PanelState;
use crate::app::user_files::open_dialog::OpenDialog;
use crate::gpu::present::PixelRect;

/// egui and what is drawn with it.
pub(super) struct UiPass {
    pub(super) egui_state: egui_winit::State,
    pub(super) egui_ctx: egui::Context,
    /// The panel's sections' state.
    pub(super) panel: PanelState,
    /// The Open dialog (Ctrl+O, the panel's Open buttons).
    pub(super) open_dialog: OpenDialog,
    /// The image area, in window pixels, as the last frame laid it out.
    pub(super) image_area: PixelRect,
}
