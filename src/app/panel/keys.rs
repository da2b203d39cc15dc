//! The panel's Keys section: every keyboard shortcut and what it does.

use egui::{RichText, Ui};

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
        egui::Grid::new("keys").num_columns(2).striped(true).show(ui, |ui| {
            for shortcut in SHORTCUTS {
                ui.label(RichText::new(shortcut.keys).monospace());
                ui.label(shortcut.what);
                ui.end_row();
            }
        });
    }
}
