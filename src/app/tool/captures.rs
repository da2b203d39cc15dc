//! Screenshots asked for (F12, Shift+F12, the panel's buttons), taken when the frame
//! allows, and the notice of the last over the image. Taking them is `saving.rs`'s.

use crate::app::views::overlay::Notice;

/// Screenshots asked for, taken when the frame allows, and the notice of the last.
#[derive(Default)]
pub(super) struct Captures {
    /// F12: the traced image, at the end of this frame.
    pub(super) want_trace_shot: bool,
    /// The panel's EXR button: the float output, as the trace shot once the frame is whole.
    pub(super) want_exr_shot: bool,
    /// Shift+F12: the window, once a frame is presented.
    pub(super) want_window_shot: bool,
    /// A short notice over the image (a screenshot written).
    pub(super) notice: Option<Notice>,
}
