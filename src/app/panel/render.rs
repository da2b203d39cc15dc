//! The panel's Render section: resolution, bounces, blend, the acceleration (and the
//! vendor's kind and structures), the view and its legend, and the render's status lines.

use egui::{Color32, RichText, Sense, Ui};

use crate::app::panel::info::{PanelInfo, VendorInfo};
use crate::app::panel::section::{Cx, PanelAction, Section};
use crate::app::panel::widgets::status_line;
use crate::app::panel::widgets::Status;
use crate::app::state::{CostMetric, Params, Resolution, ViewMode, PRESETS};
use crate::gpu::khr_rt::VendorKernel;
use crate::render_settings::{self as knobs, Accel, BvhLayout};
use crate::tracer::heat_map::heat_color;

/// The section's state: the outcome of render changes and shader reloads.
#[derive(Default)]
pub(crate) struct RenderPanel {
    /// A render setting that could not be applied.
    pub(crate) status: Option<Status>,
    /// The last shader reload's outcome (`--watch-shaders`).
    pub(crate) shader_status: Option<Status>,
    /// The acceleration `status` was written under (the vendor's fallback to the BVH):
    /// once another is chosen the line no longer holds and goes.
    pub(crate) status_accel: Option<Accel>,
}

impl RenderPanel {
    /// Drop a status written under another acceleration than `accel`.
    pub(crate) fn forget_stale_status(&mut self, accel: Accel) {
        if self.status_accel.is_some_and(|a| a != accel) {
            (self.status, self.status_accel) = (None, None);
        }
    }

    /// The user chose an acceleration (the A key): a status written under one no longer
    /// holds, even if the choice came back round to it before the panel showed.
    pub(crate) fn accel_chosen(&mut self) {
        if self.status_accel.is_some() {
            (self.status, self.status_accel) = (None, None);
        }
    }
}

impl Section for RenderPanel {
    fn title(&self) -> &'static str {
        "Render"
    }

    fn default_open(&self) -> bool {
        true
    }

    fn body(&mut self, ui: &mut Ui, cx: &mut Cx) {
        let (params, info, actions) = (&mut *cx.params, cx.info, &mut *cx.actions);
        self.forget_stale_status(params.scene.settings.accel);
        egui::Grid::new("render").num_columns(2).show(ui, |ui| {
            resolution_rows(ui, params, info);
            ui.label("Bounces");
            ui.add(egui::Slider::new(&mut params.scene.settings.bounces, knobs::BOUNCES.u32s()))
                .on_hover_text("mirror bounces after the primary hit (the paper's §3.3 used 2); PgUp / PgDn");
            ui.end_row();
            ui.label("Blend");
            ui.add(egui::Slider::new(&mut params.scene.settings.blend, knobs::BLEND.f32s()).fixed_decimals(2))
                .on_hover_text("reflection blend ratio (§3.3): 0 = the surface's own colour, 1 = pure mirror; [ and ]");
            ui.end_row();
            acceleration_row(ui, params, info);
            if params.scene.settings.accel == Accel::Vendor {
                vendor_rows(ui, info.vendor, actions);
            }
            if params.scene.settings.accel == Accel::Bvh {
                bvh_layout_rows(ui, params, info);
            }
            view_rows(ui, params);
        });
        render_notes(ui, params, info);
        for s in [&self.status, &self.shader_status].into_iter().flatten() {
            status_line(ui, s);
        }
        match (params.view, info.heat) {
            (ViewMode::Cost(metric), Some((top, max, mean))) => {
                heat_legend(ui, &format!("{} per pixel, all rays", metric.label()), top, max, mean)
            }
            (ViewMode::Samples, Some((top, max, mean))) => {
                heat_legend(ui, "camera samples per pixel", top, max, mean)
            }
            _ => {}
        }
        if let Some(note) = info.view_note {
            ui.label(RichText::new(note).small());
        }
    }
}

/// The resolution's menu, the custom size's fields and the size traced.
fn resolution_rows(ui: &mut Ui, params: &mut Params, info: &PanelInfo) {
    ui.label("Resolution");
    egui::ComboBox::new("resolution", "")
        .selected_text(resolution_label(params.resolution, params.custom))
        .show_ui(ui, |ui| {
            for n in PRESETS {
                ui.selectable_value(
                    &mut params.resolution,
                    Resolution::Square(n),
                    format!("{n} x {n}"),
                );
            }
            ui.selectable_value(&mut params.resolution, Resolution::MatchWindow, "match window");
            ui.selectable_value(&mut params.resolution, Resolution::Custom, "custom");
        })
        .response
        .on_hover_text("pixels traced per frame, scaled into the window; M matches the window");
    ui.end_row();
    if params.resolution == Resolution::Custom {
        ui.label("");
        ui.horizontal(|ui| {
            ui.add(
                egui::DragValue::new(&mut params.custom[0])
                    .range(knobs::RESOLUTION.u32s())
                    .speed(4),
            );
            ui.label("x");
            ui.add(
                egui::DragValue::new(&mut params.custom[1])
                    .range(knobs::RESOLUTION.u32s())
                    .speed(4),
            );
        });
        ui.end_row();
    }
    ui.label("");
    ui.label(
        RichText::new(format!("tracing {} x {}", info.settings.width, info.settings.height))
            .small()
            .weak(),
    );
    ui.end_row();
}

/// BVH, brute force or the vendor's (greyed out, saying why, where the device has none).
fn acceleration_row(ui: &mut Ui, params: &mut Params, info: &PanelInfo) {
    ui.label("Acceleration");
    ui.horizontal(|ui| {
        ui.radio_value(&mut params.scene.settings.accel, Accel::Bvh, "BVH").on_hover_text("our bounding volume hierarchy (the paper's future work, §5); A cycles BVH, brute force, vendor");
        let estimate = format!("the paper's method (§3.3): {:.1e} ray-triangle tests per frame", info.brute_tests);
        ui.radio_value(&mut params.scene.settings.accel, Accel::Brute, "brute").on_hover_text(&estimate);
        let why = info.vendor.unavailable.clone().unwrap_or_default();
        ui.add_enabled_ui(info.vendor.unavailable.is_none(), |ui| ui.radio_value(&mut params.scene.settings.accel, Accel::Vendor, "vendor"))
            .response
            .on_hover_text("the GPU driver's own acceleration structures and traversal (Vulkan ray tracing), on the same scene and shading")
            .on_disabled_hover_text(&why);
    });
    ui.end_row();
}

/// The BVH layout's menu text: "auto" alone while the window picks, since the line below
/// says which layout it traces (the menu's "auto (binary)" beside "now wide" told two).
fn layout_shown(auto: bool, bvh: BvhLayout) -> String {
    if auto {
        "auto".into()
    } else {
        bvh.to_string()
    }
}

/// The BVH layout's menu (auto or one layout) and what the automatic choice found.
fn bvh_layout_rows(ui: &mut Ui, params: &mut Params, info: &PanelInfo) {
    ui.label("BVH layout");
    let bvh = params.scene.settings.bvh;
    let response = egui::ComboBox::new("bvh_layout", "")
        .selected_text(layout_shown(params.bvh_auto, bvh))
        .show_ui(ui, |ui| {
            if ui.selectable_label(params.bvh_auto, "auto").clicked() {
                params.bvh_auto = true;
            }
            for layout in BvhLayout::ALL {
                if ui
                    .selectable_label(!params.bvh_auto && bvh == layout, layout.to_string())
                    .clicked()
                {
                    params.bvh_auto = false;
                    params.scene.settings.bvh = layout;
                }
            }
        })
        .response;
    let layouts = "binary: two children per node, float boxes; wide: eight children per node, 8-bit boxes (Ylitie et al. 2017), visited nearest first: faster on most meshes, but its tree takes several times as long to build, so it is built when first asked for (the model is loaded again); wide-runs: the wide tree, each ray testing its pending leaves back to back (faster where rays meet runs of leaves, as in some architecture; slower on scanned meshes); auto: times each on this model and view and keeps the fastest";
    match &info.auto_layout {
        Some(choice) => response.on_hover_text(format!("{choice}\n\n{layouts}")),
        None => response.on_hover_text(layouts),
    };
    if let Some(choice) = &info.auto_layout {
        ui.end_row();
        ui.label("");
        ui.label(RichText::new(choice).small().weak());
    }
    ui.end_row();
}

/// The view's menu, and the cost view's counter or the AO view's knobs under it.
fn view_rows(ui: &mut Ui, params: &mut Params) {
    ui.label("View");
    egui::ComboBox::new("view", "").selected_text(params.view.label()).show_ui(ui, |ui| {
        for view in ViewMode::ALL {
            let current = params.view.same_kind(view);
            if ui.selectable_label(current, view.label()).clicked() && !current {
                params.view = view;
                params.fit_cost_metric();
            }
        }
    })
    .response
    .on_hover_text("what the image shows: the shaded colour, or one of the tracer's other outputs; C toggles the cost view");
    ui.end_row();
    if let ViewMode::Cost(metric) = &mut params.view {
        ui.label("Counter");
        // Brute force visits no nodes: only the triangle counter means something.
        let bvh = params.scene.settings.accel == Accel::Bvh;
        ui.horizontal(|ui| {
            ui.add_enabled_ui(bvh, |ui| ui.radio_value(metric, CostMetric::Nodes, "nodes"))
                .response
                .on_disabled_hover_text("brute force visits no BVH nodes");
            ui.radio_value(metric, CostMetric::Triangles, "triangles");
        });
        ui.end_row();
    }
    if params.view == ViewMode::Ao {
        ao_rows(ui, &mut params.scene.settings);
    }
}

/// Lines under the grid on what this acceleration does with this view or scene.
fn render_notes(ui: &mut Ui, params: &Params, info: &PanelInfo) {
    if params.scene.settings.accel == Accel::Vendor && matches!(params.view, ViewMode::Cost(_)) {
        ui.label(
            RichText::new("the vendor's traversal reports no cost: this view is empty under it")
                .small(),
        );
    }
    if params.scene.settings.accel == Accel::Brute && info.brute_tests > info.submission_tests {
        // Said before the wait, not after: the frame is long and comes in bands.
        let text = format!("brute force: {:.1e} ray-triangle tests per frame, traced in bands over many displayed frames", info.brute_tests);
        ui.add(egui::Label::new(RichText::new(text).small()).wrap());
    }
}

/// The AO view's knobs: rays per hit and radius, within their ranges (`render_settings`).
fn ao_rows(ui: &mut Ui, s: &mut crate::render_settings::RenderSettings) {
    ui.label("AO rays");
    ui.add(egui::Slider::new(&mut s.ao_samples, knobs::AO_SAMPLES.u32s()).logarithmic(true))
        .on_hover_text("occlusion rays per primary hit and frame (--ao-samples), cosine-weighted around the normal; accumulation adds a new set each frame");
    ui.end_row();
    ui.label("AO radius");
    let (lo, hi) = (knobs::AO_RADIUS.lo as f32, knobs::AO_RADIUS.hi as f32);
    ui.add(egui::Slider::new(&mut s.ao_radius, lo..=hi).logarithmic(true).smallest_positive(1e-3).max_decimals(3))
        .on_hover_text("how far an AO ray looks for an occluder, in scene units (--ao-radius): the model has radius 1, the mirror box reaches 4");
    // The slider's low end is the open range's bound: keep the radius inside it.
    s.ao_radius = s.ao_radius.max(1e-3);
    ui.end_row();
}

/// The resolution as the combo box names it.
fn resolution_label(r: Resolution, custom: [u32; 2]) -> String {
    match r {
        Resolution::Square(n) => format!("{n} x {n}"),
        Resolution::MatchWindow => "match window".into(),
        Resolution::Custom => format!("custom ({} x {})", custom[0], custom[1]),
    }
}

/// The vendor path's kind (when the device has both) and what its last change built.
fn vendor_rows(ui: &mut Ui, vendor: &VendorInfo, actions: &mut Vec<PanelAction>) {
    if vendor.kernels.len() > 1 {
        ui.label("Vendor");
        ui.horizontal(|ui| {
            for &k in &vendor.kernels {
                let text = match k {
                    VendorKernel::Query => "ray query",
                    VendorKernel::Pipeline => "RT pipeline",
                };
                let what = match k {
                    VendorKernel::Query => "the driver's traversal from our compute shader",
                    VendorKernel::Pipeline => {
                        "a ray tracing pipeline: ray generation, closest-hit and miss shaders"
                    }
                };
                let hover = format!("{what} ({})", k.extension());
                if ui.radio(vendor.kernel == Some(k), text).on_hover_text(hover).clicked()
                    && vendor.kernel != Some(k)
                {
                    actions.push(PanelAction::VendorKernel(k));
                }
            }
        });
        ui.end_row();
    }
    if let Some(s) = &vendor.stats {
        ui.label("Structures");
        // Wrapped to the panel: a long line would widen the panel and shrink the image.
        ui.add(egui::Label::new(RichText::new(format!(
            "{} bottom levels {:.1} ms, top level {:.1} ms, {:.1} MB; last change rebuilt the {}",
            s.bottom_count,
            s.bottom_ms,
            s.top_ms,
            s.bytes as f64 / 1e6,
            s.rebuilt
        ))
        .small())
        .wrap())
        .on_hover_text("a new model rebuilds both levels, a new model count only the top level, the light nothing");
        ui.end_row();
    }
}

/// The heat map's colour scale from 0 to `top`, with the mean and max under it.
fn heat_legend(ui: &mut Ui, what: &str, top: f32, max: f32, mean: f32) {
    ui.add(egui::Label::new(RichText::new(what).small()).wrap());
    let (rect, _) =
        ui.allocate_exact_size(egui::vec2(ui.available_width().min(260.0), 14.0), Sense::hover());
    let steps = 64;
    for i in 0..steps {
        let t0 = i as f32 / steps as f32;
        let t1 = (i + 1) as f32 / steps as f32;
        let [r, g, b] = heat_color((t0 + t1) * 0.5);
        let x0 = rect.left() + rect.width() * t0;
        let x1 = rect.left() + rect.width() * t1;
        ui.painter().rect_filled(
            egui::Rect::from_x_y_ranges(x0..=x1 + 0.5, rect.y_range()),
            0.0,
            Color32::from_rgb(r, g, b),
        );
    }
    ui.horizontal(|ui| {
        ui.label(RichText::new("0").small());
        ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
            ui.label(RichText::new(format!("{top:.0} (99th pct.)")).small());
        });
    });
    ui.label(RichText::new(format!("mean {mean:.1}, max {max:.0}")).small().weak());
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_vendor_fallback_line_goes_when_another_acceleration_is_chosen() {
        // The red "tracing with the BVH" line stayed after A chose brute force (#30).
        let mut panel = RenderPanel {
            status: Some(Status::error("vendor ray tracing: none here; tracing with the BVH")),
            status_accel: Some(Accel::Bvh),
            ..Default::default()
        };
        panel.forget_stale_status(Accel::Bvh);
        assert!(panel.status.is_some(), "still tracing with the BVH: the line holds");
        panel.forget_stale_status(Accel::Brute);
        assert!(panel.status.is_none() && panel.status_accel.is_none());
        // A key's choice drops it at once, whatever it chose; other lines stay.
        let line = Some(Status::error("vendor ray tracing: none here; tracing with the BVH"));
        let mut panel =
            RenderPanel { status: line, status_accel: Some(Accel::Bvh), ..Default::default() };
        panel.accel_chosen();
        assert!(panel.status.is_none() && panel.status_accel.is_none());
        let mut panel = RenderPanel { status: Some(Status::error("other")), ..Default::default() };
        panel.accel_chosen();
        assert!(panel.status.is_some());
    }

    #[test]
    fn the_layout_menu_names_auto_alone_while_the_window_picks() {
        // #43: "auto (binary)" showed beside "timing each layout, now wide".
        assert_eq!(super::layout_shown(true, BvhLayout::Binary), "auto");
        assert_eq!(super::layout_shown(true, BvhLayout::Wide), "auto");
        assert_eq!(super::layout_shown(false, BvhLayout::Wide), BvhLayout::Wide.to_string());
    }
}
