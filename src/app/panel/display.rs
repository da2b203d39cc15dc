//! The panel's Display section: the HUD, vsync and the present mode, and the remembered
//! settings (where they live, and Reset).

use egui::{RichText, Ui};

use crate::app::panel::section::{Cx, PanelAction, Section};
use crate::app::panel::widgets::{status_line, Status};

/// The section's state between frames.
#[derive(Default)]
pub(crate) struct DisplayPanel {
    /// The last "Reset settings" outcome.
    pub(crate) settings_status: Option<Status>,
}

impl Section for DisplayPanel {
    fn title(&self) -> &'static str {
        "Display"
    }

    fn default_open(&self) -> bool {
        false
    }

    fn body(&mut self, ui: &mut Ui, cx: &mut Cx) {
        let (params, info, actions) = (&mut *cx.params, cx.info, &mut *cx.actions);
        ui.checkbox(&mut params.hud_visible, "numbers over the image (I)");
        ui.add_enabled(
            info.vsync_off_available || !params.vsync,
            egui::Checkbox::new(&mut params.vsync, "vsync (V)"),
        );
        ui.label(RichText::new(format!("present mode: {}", info.present_mode)).small().weak());
        if !info.vsync_off_available {
            ui.label(RichText::new("this surface offers only FIFO (vsync)").small().weak());
        }
        ui.separator();
        let remembered = match info.settings_file {
            Some(path) => format!(
                "window size, open sections, recent presets and models are remembered in {}",
                crate::files::shown_path(path)
            ),
            None => "settings are not remembered in this run (--no-persist or a scripted run)"
                .to_string(),
        };
        ui.add(egui::Label::new(RichText::new(remembered).small().weak()).wrap());
        if ui.add_enabled(info.settings_file.is_some(), egui::Button::new("Reset settings")).on_hover_text("forget the remembered settings; the window and sections return to how they first open").clicked() {
            actions.push(PanelAction::ResetSettings);
        }
        if let Some(s) = &self.settings_status {
            status_line(ui, s);
        }
    }
}
