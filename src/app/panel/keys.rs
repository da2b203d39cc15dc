//! The panel's Keys section: every keyboard shortcut and what it does.

use egui::{Align, Label, Layout, RichText, Ui, Vec2};

use crate::app::panel::section::{Cx, Section};
use crate::app::shortcuts::SHORTCUTS;

/// The section (it keeps nothing between frames).
#[derive(Default)]
pub(crate) struct KeysPanel;

impl Section for KeysPanel {
    fn title(&self) -> &'static str {
        "Keys"
    }

    fn default_open(&self) -> bool {
        false
    }

    fn body(&mut self, ui: &mut Ui, _cx: &mut Cx) {
        // Rows of two wrapped columns within the panel's width: a grid sized its columns to
        // the longest line and widened the panel to about 570 points for the rest of the run.
        let keys_width = (ui.available_width() * 0.4).min(120.0);
        for shortcut in SHORTCUTS {
            ui.horizontal_top(|ui| {
                let keys = Layout::top_down(Align::Min);
                ui.allocate_ui_with_layout(Vec2::new(keys_width, 0.0), keys, |ui| {
                    ui.set_width(keys_width);
                    ui.add(Label::new(RichText::new(shortcut.keys).monospace()).wrap());
                });
                ui.add(Label::new(shortcut.what).wrap());
            });
        }
    }
}
