//! The panel's A/B split section: the switch, the line's place, which parameters B changes
//! (and to what), and each half's GPU time.

use egui::{RichText, Ui};

use crate::app::panel::section::{Cx, Section};
use crate::app::panel::widgets::GPU_COLOR;
use crate::app::split::SplitView;
use crate::render_settings::{Accel, BLEND, BOUNCES, SPP};

/// The section (it keeps nothing between frames: the split is a parameter).
#[derive(Default)]
pub(crate) struct SplitPanel;

impl Section for SplitPanel {
    fn title(&self) -> &'static str {
        "A/B split"
    }

    fn default_open(&self) -> bool {
        false
    }

    fn body(&mut self, ui: &mut Ui, cx: &mut Cx) {
        let params = &mut *cx.params;
        let (a, a_environment, times) =
            (params.scene.settings, params.scene.environment.is_some(), cx.info.split_ms);
        // B offers the vendor only where A does: greyed out with the same reason.
        let vendor_missing = cx.info.vendor.unavailable.clone();
        let (a, split) = (&a, &mut params.split);
        ui.checkbox(&mut split.enabled, "Split view (S)")
            .on_hover_text("left of the line: the settings above (A); right of it: B, the same with the parameters ticked below changed; drag the line to move it");
        ui.add_enabled_ui(split.enabled, |ui| {
            ui.horizontal(|ui| {
                ui.label("Line");
                ui.add(egui::Slider::new(&mut split.position, 0.0..=1.0).fixed_decimals(2))
                    .on_hover_text(
                        "share of the image width; the halves meet on a work-group column",
                    );
            });
            ui.label(RichText::new("B changes (ticked):").small());
            let b = &mut split.b;
            egui::Grid::new("split b").num_columns(2).show(ui, |ui| {
                differs(ui, "Acceleration", &mut b.accel, a.accel, |ui, v| {
                    ui.radio_value(v, Accel::Bvh, "BVH");
                    ui.radio_value(v, Accel::Brute, "brute");
                    let why = vendor_missing.clone().unwrap_or_default();
                    ui.add_enabled_ui(vendor_missing.is_none(), |ui| {
                        ui.radio_value(v, Accel::Vendor, "vendor")
                    })
                    .response
                    .on_disabled_hover_text(why);
                });
                differs(ui, "Bounces", &mut b.bounces, a.bounces, |ui, v| {
                    ui.add(egui::Slider::new(v, BOUNCES.u32s()));
                });
                differs(ui, "Blend", &mut b.blend, a.blend, |ui, v| {
                    ui.add(egui::Slider::new(v, BLEND.f32s()).fixed_decimals(2));
                });
                differs(ui, "Samples", &mut b.spp, a.spp, |ui, v| {
                    ui.add(egui::Slider::new(v, SPP.u32s()));
                });
                for (name, value, a_value) in [
                    ("Adaptive", &mut b.adaptive, a.adaptive),
                    ("Smooth", &mut b.smooth, a.smooth),
                    ("Textures", &mut b.textures, a.textures),
                    ("Environment", &mut b.environment, a_environment),
                ] {
                    differs(ui, name, value, a_value, |ui, v| {
                        ui.checkbox(v, "on");
                    });
                }
            });
            ui.label(
                RichText::new(format!("GPU {}", SplitView::times_text(times)))
                    .color(GPU_COLOR)
                    .monospace(),
            );
        });
    }
}

/// One row: a tick that makes B's `value` differ (starting from A's), and its editor.
fn differs<T: Copy>(
    ui: &mut Ui,
    name: &str,
    value: &mut Option<T>,
    a: T,
    edit: impl FnOnce(&mut Ui, &mut T),
) {
    let mut on = value.is_some();
    if ui.checkbox(&mut on, name).changed() {
        *value = on.then_some(a);
    }
    match value {
        Some(v) => {
            ui.horizontal(|ui| edit(ui, v));
        }
        None => {
            ui.label(RichText::new("as A").weak());
        }
    }
    ui.end_row();
}
