//! The egui side panel: every control in a collapsible section, one file per section, each
//! owning its state and drawn through the one [`Section`] shape; [`show`] lists them in
//! the order they appear.
//!
//! - `section`: the [`Section`] trait, what a section is handed ([`Cx`]) and the
//!   [`PanelAction`]s it asks of the tool; `info`: the facts shown ([`PanelInfo`]);
//!   `widgets`: the status line, the remembered collapsible section, colours;
//!   `remembered`: the panel's part of the remembered settings;
//! - the sections: `performance`, `render`, `model`, `shading`, `split`, `light`,
//!   `camera`, `display`, `screenshot`, `benchmark`, `presets`, `keys`.
//!
//! Sections import only the leaves (`section`, `info`, `widgets`), the app's parts below
//! the panel (`status`, `split`, `state`, `shortcuts`, `user_files`, `measure`) and the
//! crate's lower layers, never this file or each other. The HUD over the image is
//! `app::views::overlay`'s.

pub(crate) mod benchmark;
pub(crate) mod camera;
pub(crate) mod display;
pub(crate) mod info;
pub(crate) mod keys;
pub(crate) mod light;
pub(crate) mod model;
pub(crate) mod performance;
pub(crate) mod presets;
pub(crate) mod remembered;
pub(crate) mod render;
pub(crate) mod screenshot;
pub(crate) mod section;
pub(crate) mod shading;
pub(crate) mod split;
pub(crate) mod widgets;

use egui::{RichText, Ui};

use crate::app::state::Params;
pub(crate) use info::{PanelInfo, VendorInfo};
pub(crate) use section::{Cx, PanelAction, Section};
pub(crate) use widgets::Status;

/// Default width of the panel in points.
pub(crate) const PANEL_WIDTH: f32 = 300.0;

/// The side panel's default width and its range in a window `window` points wide: at most
/// two fifths of it, but never under [`PANEL_WIDTH`], the narrowest its rows fit in. Its rows
/// once pushed it to half a 640-point window (the cap then); now it keeps 300 there.
pub(crate) fn panel_widths(window: f32) -> (f32, std::ops::RangeInclusive<f32>) {
    let max = (window * 0.4).max(PANEL_WIDTH);
    (PANEL_WIDTH, 150.0..=max)
}

/// The panel's state between frames: one field per section.
#[derive(Default)]
pub(crate) struct PanelState {
    pub(crate) perf: performance::PerfPanel,
    pub(crate) render: render::RenderPanel,
    pub(crate) model: model::ModelPanel,
    pub(crate) shading: shading::ShadingPanel,
    pub(crate) split: split::SplitPanel,
    pub(crate) light: light::LightPanel,
    pub(crate) camera: camera::CameraPanel,
    pub(crate) display: display::DisplayPanel,
    pub(crate) screenshot: screenshot::ScreenshotPanel,
    pub(crate) benchmark: benchmark::BenchmarkPanel,
    pub(crate) presets: presets::PresetPanel,
    pub(crate) keys: keys::KeysPanel,
}

impl PanelState {
    /// Every section, in the order the panel shows them: the live numbers first
    /// (reachable at any window size without scrolling), Presets last before the keys
    /// (the window test clicks there).
    fn sections(&mut self) -> [&mut dyn Section; 12] {
        [
            &mut self.perf,
            &mut self.render,
            &mut self.model,
            &mut self.shading,
            &mut self.split,
            &mut self.light,
            &mut self.camera,
            &mut self.display,
            &mut self.screenshot,
            &mut self.benchmark,
            &mut self.presets,
            &mut self.keys,
        ]
    }
}

/// Show the panel's contents inside `ui` and return the actions asked for.
pub(crate) fn show(
    ui: &mut Ui,
    params: &mut Params,
    state: &mut PanelState,
    info: &PanelInfo,
) -> Vec<PanelAction> {
    let mut actions = Vec::new();
    ui.horizontal(|ui| {
        ui.heading("meshtracer");
        ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
            if ui.small_button("hide (H)").clicked() {
                params.panel_visible = false;
            }
        });
    });
    ui.label(RichText::new(info.device).small().weak());
    ui.separator();
    // A bar of its own beside the sections: a floating one covered the ends of their lines.
    ui.spacing_mut().scroll = egui::style::ScrollStyle::solid();
    egui::ScrollArea::vertical().auto_shrink([false, false]).show(ui, |ui| {
        let mut cx = Cx { params, info, actions: &mut actions };
        for s in state.sections() {
            widgets::section(ui, s.title(), s.default_open(), |ui| s.body(ui, &mut cx));
        }
    });
    actions
}

#[cfg(test)]
mod tests;
