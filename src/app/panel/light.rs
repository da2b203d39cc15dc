//! The panel's Light section: the light's orbit, speed, pause and phase.

use egui::Ui;

use crate::app::panel::section::{Cx, Section};
use crate::scene::paper::BOX_HALF_SIZE;

/// The section (it keeps nothing between frames).
#[derive(Default)]
pub(crate) struct LightPanel;

impl Section for LightPanel {
    fn title(&self) -> &'static str {
        "Light"
    }

    fn default_open(&self) -> bool {
        true
    }

    fn body(&mut self, ui: &mut Ui, cx: &mut Cx) {
        let params = &mut *cx.params;
        let limit = BOX_HALF_SIZE * 0.98;
        egui::Grid::new("light").num_columns(2).show(ui, |ui| {
            ui.label("Orbit radius");
            ui.add(egui::Slider::new(&mut params.scene.light.radius, 0.0..=limit).fixed_decimals(2)).on_hover_text("distance of the light's circle from the vertical axis (inside the box)");
            ui.end_row();
            ui.label("Height");
            ui.add(egui::Slider::new(&mut params.scene.light.height, -limit..=limit).fixed_decimals(2)).on_hover_text("height of the light's circle");
            ui.end_row();
            ui.label("Speed");
            ui.add(egui::Slider::new(&mut params.light_speed, -180.0..=180.0).suffix(" °/s").fixed_decimals(0)).on_hover_text("how fast the light orbits (the paper's moving light, §4); negative turns the other way");
            ui.end_row();
            ui.label("");
            ui.checkbox(&mut params.light_paused, "paused (Space)").on_hover_text("stop the light where it is; the phase slider then places it");
            ui.end_row();
            ui.label("Phase");
            ui.add_enabled(params.light_paused, egui::Slider::new(&mut params.scene.light.angle_deg, 0.0..=360.0).suffix("°").fixed_decimals(1));
            ui.end_row();
        });
    }
}
