//! The panel's Screenshots section: the traced image, the window or the EXR of the view,
//! the folder they go to, and the last one's outcome.

use egui::{RichText, Ui};

use crate::app::panel::section::{Cx, PanelAction, Section};
use crate::app::panel::widgets::{status_line, Status};

/// The section's state between frames.
#[derive(Default)]
pub(crate) struct ScreenshotPanel {
    /// The last screenshot's outcome.
    pub(crate) status: Option<Status>,
}

impl Section for ScreenshotPanel {
    fn title(&self) -> &'static str {
        "Screenshots"
    }

    fn default_open(&self) -> bool {
        true
    }

    fn body(&mut self, ui: &mut Ui, cx: &mut Cx) {
        let (info, actions) = (cx.info, &mut *cx.actions);
        ui.horizontal(|ui| {
            if ui.button("Traced image (F12)").on_hover_text("PNG at render resolution").clicked() {
                actions.push(PanelAction::ScreenshotTrace);
            }
            if ui.button("Window").on_hover_text("PNG of the window as seen, panel included (Shift+F12)").clicked() {
                actions.push(PanelAction::ScreenshotWindow);
            }
            let what = "32-bit float OpenEXR of the view shown: colour, or the raw depth (one channel Z), normal, primitive id, cost or samples";
            if ui.button("EXR").on_hover_text(what).clicked() {
                actions.push(PanelAction::ScreenshotExr);
            }
        });
        ui.add(
            egui::Label::new(
                RichText::new(format!("folder: {}", info.screenshot_dir)).small().weak(),
            )
            .truncate(),
        );
        if let Some(s) = &self.status {
            status_line(ui, s);
        }
    }
}
