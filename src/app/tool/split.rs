//! The tool's side of the A/B split view: where its line is in the window, grabbing and
//! moving it with the mouse, what the overlay draws, and each half's GPU time.

use crate::app::split::GRAB_PIXELS;
use crate::app::state::fit_rect;
use crate::app::tool::Tool;
use crate::app::views::overlay::SplitOverlay;
use crate::gpu::present::PixelRect;
use crate::gpu::PartTimes;

impl Tool {
    /// The image as shown (letterboxed) and the line's x there, physical pixels; None
    /// when the split is off or nothing is traced.
    fn split_line(&self) -> Option<(PixelRect, f64)> {
        let split = &self.params.split;
        let size = self
            .gpu
            .tracer
            .resolution()
            .filter(|_| split.enabled && self.session.model.is_some())?;
        let shown = fit_rect(size, self.ui.image_area);
        let w = size[0];
        if shown.width == 0 {
            return None;
        }
        let x = shown.x as f64 + split.column(w) as f64 / w as f64 * shown.width as f64;
        Some((shown, x))
    }

    /// The cursor is on the split line (within [`GRAB_PIXELS`]), over the image.
    pub(super) fn on_split_line(&self) -> bool {
        let (Some((shown, x)), Some(c)) = (self.split_line(), self.input.cursor) else {
            return false;
        };
        (c.x - x).abs() <= GRAB_PIXELS
            && c.y >= shown.y as f64
            && c.y < shown.y as f64 + shown.height as f64
    }

    /// Put the line under the cursor (a drag that began on it).
    pub(super) fn move_split(&mut self) {
        if let (Some((shown, _)), Some(c)) = (self.split_line(), self.input.cursor) {
            self.params.split.move_to(((c.x - shown.x as f64) / shown.width.max(1) as f64) as f32);
        }
    }

    /// What the overlay draws for the split: the line and each half's label, in points.
    pub(super) fn split_overlay(&self) -> Option<SplitOverlay> {
        let (shown, x) = self.split_line()?;
        let ppp = self.window.scale_factor() as f32;
        let [a, b] = self.timing.split_ms;
        let ms = |m: Option<f64>| m.map_or(String::new(), |m| format!(" {m:.1} ms"));
        Some(SplitOverlay {
            x: x as f32 / ppp,
            top: shown.y as f32 / ppp,
            bottom: (shown.y as f32 + shown.height as f32) / ppp,
            a: format!("A{}", ms(a)),
            b: format!("B{}", ms(b)),
            b_changes: self.params.split.b.describe(),
        })
    }

    /// Keep each half's latest GPU time: that of the last frame whose time is in (its
    /// bands added up).
    pub(super) fn note_split_times(&mut self, frame_parts: Option<PartTimes>) {
        if !self.params.split.enabled {
            self.timing.split_ms = [None; 2];
        } else if let Some(parts) = frame_parts {
            self.timing.split_ms = parts;
        }
    }
}
