//! The panel's Shading section: the paper's future work, each a switch: smooth shading,
//! textures, environment map, supersampling, adaptive sampling, progressive accumulation;
//! and the mirror box.

use egui::{RichText, Ui};

use crate::app::panel::section::{Cx, PanelAction, Section};
use crate::app::panel::widgets::group;
use crate::app::user_files::open_dialog::Purpose;
use crate::render_settings::SPP;
use crate::scene::EnvironmentSource;

/// The section (it keeps nothing between frames).
#[derive(Default)]
pub(crate) struct ShadingPanel;

impl Section for ShadingPanel {
    fn title(&self) -> &'static str {
        "Shading"
    }

    fn default_open(&self) -> bool {
        true
    }

    fn body(&mut self, ui: &mut Ui, cx: &mut Cx) {
        let (params, info) = (&mut *cx.params, cx.info);
        egui::Grid::new("shading").num_columns(2).show(ui, |ui| {
            ui.label("Normals");
            ui.horizontal(|ui| {
                ui.radio_value(&mut params.scene.settings.smooth, false, "flat (paper)").on_hover_text("one normal per triangle, as the paper shades (§3.3)");
                ui.radio_value(&mut params.scene.settings.smooth, true, "smooth").on_hover_text("vertex normals interpolated across each triangle (§5's smooth shading)");
            });
            ui.end_row();
            ui.label("Textures");
            ui.checkbox(&mut params.scene.settings.textures, "map_Kd, colours").on_hover_text("diffuse textures from the model's .mtl (§5), and the model's vertex colours");
            ui.end_row();
            ui.label("Environment");
            let label = |e: &Option<EnvironmentSource>| match e {
                None => "none (black)".to_string(),
                Some(EnvironmentSource::Sky) => "sky".to_string(),
                Some(EnvironmentSource::File(p)) => p.file_name().map_or("file".into(), |f| f.to_string_lossy().into_owned()),
            };
            ui.horizontal(|ui| {
                egui::ComboBox::new("environment", "").selected_text(label(&params.scene.environment)).truncate().width(100.0).show_ui(ui, |ui| {
                    ui.selectable_value(&mut params.scene.environment, None, label(&None));
                    ui.selectable_value(&mut params.scene.environment, Some(EnvironmentSource::Sky), "sky");
                    if let Some(file) = params.environment_file.clone() {
                        let text = label(&Some(file.clone()));
                        ui.selectable_value(&mut params.scene.environment, Some(file), text);
                    }
                });
                if ui.small_button("file…").on_hover_text("choose an environment map: an equirectangular .hdr, .exr, .png or .jpg (as --env)").clicked() {
                    cx.actions.push(PanelAction::Open(Purpose::Environment));
                }
            });
            ui.end_row();
            ui.label("Samples/pixel");
            ui.add(egui::Slider::new(&mut params.scene.settings.spp, SPP.u32s()).logarithmic(true)).on_hover_text("jittered camera rays per pixel: anti-aliasing (§5)");
            ui.end_row();
            ui.label("Adaptive");
            ui.checkbox(&mut params.scene.settings.adaptive, "only on edges").on_hover_text("adaptive sampling (§5): all samples only where a neighbour's path meets another surface");
            ui.end_row();
            ui.label("Accumulate");
            ui.checkbox(&mut params.accumulate, "while nothing changes").on_hover_text("average successive frames into a smoother image until a setting or the view changes");
            ui.end_row();
        });
        let spp = params.scene.settings.spp as u64;
        let text = format!(
            "{} frame(s) accumulated, {} samples per pixel{}",
            group(info.accumulated_frames as u64),
            group(info.accumulated_frames as u64 * spp),
            if params.scene.settings.adaptive { " on edges" } else { "" }
        );
        ui.label(RichText::new(text).small().weak());
        ui.checkbox(&mut params.scene.mirror_box, "mirror box (the paper's six planes)")
            .on_hover_text("the six mirror planes around the model (§4's scene)");
        if params.scene.environment.is_some() && params.scene.mirror_box {
            ui.label(RichText::new("The closed mirror box hides the environment: untick it to see the environment.").small().weak());
        }
    }
}
