//! The egui side panel: every control in a collapsible section (later issues add sections
//! without crowding; `perf_panel` draws Performance) and the status lines.

use std::path::PathBuf;

use egui::{Color32, RichText, Sense, Ui};

use super::benchmark_panel::{benchmark_section, BenchmarkPanel};
use super::camera_panel::{camera_section, CameraFields};
use super::cost_view::heat_color;
use super::presets_panel::{presets_section, PresetPanel};
use super::frame_stats::{mrays_per_second, FrameStats};
use super::perf_panel::{performance_section, PerfPanel};
use super::open_dialog::Purpose;
use super::settings::section;
use super::split_panel::split_section;
use super::state::{CostMetric, Params, Resolution, ViewMode, PRESETS, SHORTCUTS};
use crate::scene::paper::{ModelSource, BOX_HALF_SIZE, MAX_MODELS};
use crate::scene::primitives::PaperModel;
use crate::gpu::vendor::{AccelStats, VendorKernel};
use crate::tracer::frame::{Accel, MAX_BOUNCES, MAX_RESOLUTION};

/// Colour of the GPU-time line and text.
pub const GPU_COLOR: Color32 = Color32::from_rgb(255, 150, 60);
/// Colour of the frame-time line and text.
pub const FRAME_COLOR: Color32 = Color32::from_rgb(90, 170, 255);
const ERROR_COLOR: Color32 = Color32::from_rgb(255, 110, 100);

/// Default width of the panel in points.
pub const PANEL_WIDTH: f32 = 300.0;

/// What the panel asks the tool to do beyond changing parameters.
#[derive(Clone, Debug, PartialEq)]
pub enum PanelAction {
    LoadModel(ModelSource),
    /// Load this .obj exactly as a file dropped on the window (the Open dialog's pick).
    LoadFile(PathBuf),
    /// Show the Open dialog for a model or a preset.
    Open(Purpose),
    ScreenshotTrace,
    ScreenshotWindow,
    /// The traced float output of the view shown, as OpenEXR.
    ScreenshotExr,
    /// Save the current look as a preset; replace an existing file only with `overwrite`.
    SavePreset { path: PathBuf, overwrite: bool },
    /// Take the look of a preset file (or of a PNG the program wrote).
    LoadPreset(PathBuf),
    /// Start a benchmark run of this many frames.
    Benchmark(u32),
    CancelBenchmark,
    /// Start the frame-time log (a new CSV in the screenshot folder).
    Record,
    /// Close the frame-time log.
    StopRecording,
    /// Forget the remembered settings and put the window and sections back as they open.
    ResetSettings,
    /// Trace vendor frames with this kind of vendor tracing.
    VendorKernel(VendorKernel),
}

/// The vendor path as the panel shows it.
#[derive(Clone, Debug, Default)]
pub struct VendorInfo {
    /// Why the device cannot trace with the vendor's structures (greys the choice out).
    pub unavailable: Option<String>,
    /// The kind in use, and every kind the device has.
    pub kernel: Option<VendorKernel>,
    pub kernels: Vec<VendorKernel>,
    /// What the last change built, once something was.
    pub stats: Option<AccelStats>,
}

/// A status line: text and whether it reports a failure.
#[derive(Clone, Debug, Default)]
pub struct Status {
    pub text: String,
    pub error: bool,
}

impl Status {
    pub fn ok(text: impl Into<String>) -> Self {
        Self { text: text.into(), error: false }
    }
    pub fn error(text: impl Into<String>) -> Self {
        Self { text: text.into(), error: true }
    }
}

/// The panel's own state between frames.
#[derive(Default)]
pub struct PanelState {
    /// The .obj path field.
    pub path: String,
    /// The last model load's outcome.
    pub model_status: Option<Status>,
    /// Every warning of the last model load (the status line names the first).
    pub model_warnings: Vec<String>,
    /// A render setting that could not be applied.
    pub render_status: Option<Status>,
    /// The last shader reload's outcome (`--watch-shaders`).
    pub shader_status: Option<Status>,
    /// The last screenshot's outcome.
    pub screenshot_status: Option<Status>,
    /// A file is being dragged over the window.
    pub hovering_file: bool,
    /// The camera section's typed eye and target.
    pub camera: CameraFields,
    /// The Presets section.
    pub presets: PresetPanel,
    /// The benchmark section's frame count and last summary.
    pub benchmark: BenchmarkPanel,
    /// The Performance section's graph window and frame-log status.
    pub perf: PerfPanel,
    /// The last "Reset settings" outcome.
    pub settings_status: Option<Status>,
}

/// Read-only facts the panel shows.
pub struct PanelInfo<'a> {
    pub device: &'a str,
    /// The tracing GPU's shader clock in MHz: the latest reading and the highest seen.
    pub clock_mhz: Option<(f64, f64)>,
    pub model: Option<&'a ModelSource>,
    pub triangles: u64,
    pub vertices: u64,
    pub render_size: [u32; 2],
    pub rays: u64,
    /// (model, stage, seconds) of a load in progress.
    pub loading: Option<(&'a str, &'a str, f64)>,
    pub present_mode: String,
    pub vsync_off_available: bool,
    /// (scale top, max, mean) of the heat map shown.
    pub heat: Option<(f32, f32, f32)>,
    /// What the colours of a depth, normal or primitive-id view mean.
    pub view_note: Option<&'a str>,
    /// Frames averaged into the image shown (progressive accumulation).
    pub accumulated_frames: u32,
    /// Share of a long frame traced so far, while it is traced in bands, and the seconds
    /// it still needs at the pace so far.
    pub progress: Option<(f32, Option<f64>)>,
    /// Ray-triangle tests one frame of brute force would ask for.
    pub brute_tests: f64,
    pub screenshot_dir: String,
    pub stats: &'a FrameStats,
    /// (measured, total) frames of a benchmark run in progress.
    pub benchmark: Option<(u32, u32)>,
    /// The frame-time log being written: its file and frames so far.
    pub recording: Option<(&'a std::path::Path, u64)>,
    /// Where the remembered settings live (None: `--no-persist` or a scripted run).
    pub settings_file: Option<&'a std::path::Path>,
    /// The vendor's ray tracing on this device.
    pub vendor: &'a VendorInfo,
    /// The latest GPU time of each half of the split view.
    pub split_ms: crate::gpu::PartTimes,
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
                    VendorKernel::Pipeline => "a ray tracing pipeline: ray generation, closest-hit and miss shaders",
                };
                let hover = format!("{what} ({})", k.extension());
                if ui.radio(vendor.kernel == Some(k), text).on_hover_text(hover).clicked() && vendor.kernel != Some(k) {
                    actions.push(PanelAction::VendorKernel(k));
                }
            }
        });
        ui.end_row();
    }
    if let Some(s) = &vendor.stats {
        ui.label("Structures");
        ui.label(RichText::new(format!(
            "{} bottom levels {:.1} ms, top level {:.1} ms, {:.1} MB; last change rebuilt the {}",
            s.bottom_count,
            s.bottom_ms,
            s.top_ms,
            s.bytes as f64 / 1e6,
            s.rebuilt
        ))
        .small())
        .on_hover_text("a new model rebuilds both levels, a new model count only the top level, the light nothing");
        ui.end_row();
    }
}

/// Show the panel's contents inside `ui` and return the actions asked for.
pub fn show(ui: &mut Ui, params: &mut Params, state: &mut PanelState, info: &PanelInfo) -> Vec<PanelAction> {
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
    egui::ScrollArea::vertical().auto_shrink([false, false]).show(ui, |ui| {
        // The live numbers first: reachable at any window size without scrolling.
        performance_section(ui, &mut state.perf, info, &mut actions);
        render_section(ui, params, state, info, &mut actions);
        model_section(ui, params, state, info, &mut actions);
        shading_section(ui, params, info);
        let (a, a_environment) = (params.settings, params.environment.is_some());
        split_section(ui, &mut params.split, &a, a_environment, info.split_ms);
        light_section(ui, params);
        camera_section(ui, params, &mut state.camera);
        display_section(ui, params, state, info, &mut actions);
        screenshot_section(ui, state, info, &mut actions);
        benchmark_section(ui, &mut state.benchmark, info.benchmark, &mut actions);
        // Presets stay last before the keys (the window test clicks there).
        presets_section(ui, &mut state.presets, &mut actions);
        section(ui, "Keys", false, |ui| {
            egui::Grid::new("keys").num_columns(2).striped(true).show(ui, |ui| {
                for (key, what) in SHORTCUTS {
                    ui.label(RichText::new(*key).monospace());
                    ui.label(*what);
                    ui.end_row();
                }
            });
        });
    });
    actions
}

fn resolution_label(r: Resolution, custom: [u32; 2]) -> String {
    match r {
        Resolution::Square(n) => format!("{n} x {n}"),
        Resolution::MatchWindow => "match window".into(),
        Resolution::Custom => format!("custom ({} x {})", custom[0], custom[1]),
    }
}

fn render_section(ui: &mut Ui, params: &mut Params, state: &PanelState, info: &PanelInfo, actions: &mut Vec<PanelAction>) {
    section(ui, "Render", true, |ui| {
        egui::Grid::new("render").num_columns(2).show(ui, |ui| {
            ui.label("Resolution");
            egui::ComboBox::new("resolution", "").selected_text(resolution_label(params.resolution, params.custom)).show_ui(ui, |ui| {
                for n in PRESETS {
                    ui.selectable_value(&mut params.resolution, Resolution::Square(n), format!("{n} x {n}"));
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
                    ui.add(egui::DragValue::new(&mut params.custom[0]).range(1..=MAX_RESOLUTION).speed(4));
                    ui.label("x");
                    ui.add(egui::DragValue::new(&mut params.custom[1]).range(1..=MAX_RESOLUTION).speed(4));
                });
                ui.end_row();
            }
            ui.label("");
            ui.label(RichText::new(format!("tracing {} x {}", info.render_size[0], info.render_size[1])).small().weak());
            ui.end_row();
            ui.label("Bounces");
            ui.add(egui::Slider::new(&mut params.settings.bounces, 0..=MAX_BOUNCES))
                .on_hover_text("mirror bounces after the primary hit (the paper's §3.3 used 2); PgUp / PgDn");
            ui.end_row();
            ui.label("Blend");
            ui.add(egui::Slider::new(&mut params.settings.blend, 0.0..=1.0).fixed_decimals(2))
                .on_hover_text("reflection blend ratio (§3.3): 0 = the surface's own colour, 1 = pure mirror; [ and ]");
            ui.end_row();
            ui.label("Acceleration");
            ui.horizontal(|ui| {
                ui.radio_value(&mut params.settings.accel, Accel::Bvh, "BVH").on_hover_text("our bounding volume hierarchy (the paper's future work, §5); A cycles BVH, brute force, vendor");
                let estimate = format!("the paper's method (§3.3): {:.1e} ray-triangle tests per frame", info.brute_tests);
                ui.radio_value(&mut params.settings.accel, Accel::Brute, "brute").on_hover_text(&estimate);
                let why = info.vendor.unavailable.clone().unwrap_or_default();
                ui.add_enabled_ui(info.vendor.unavailable.is_none(), |ui| ui.radio_value(&mut params.settings.accel, Accel::Vendor, "vendor"))
                    .response
                    .on_hover_text("the GPU driver's own acceleration structures and traversal (Vulkan ray tracing), on the same scene and shading")
                    .on_disabled_hover_text(&why);
            });
            ui.end_row();
            if params.settings.accel == Accel::Vendor {
                vendor_rows(ui, info.vendor, actions);
            }
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
                let bvh = params.settings.accel == Accel::Bvh;
                ui.horizontal(|ui| {
                    ui.add_enabled_ui(bvh, |ui| ui.radio_value(metric, CostMetric::Nodes, "nodes")).response.on_disabled_hover_text("brute force visits no BVH nodes");
                    ui.radio_value(metric, CostMetric::Triangles, "triangles");
                });
                ui.end_row();
            }
        });
        if params.settings.accel == Accel::Vendor && matches!(params.view, ViewMode::Cost(_)) {
            ui.label(RichText::new("the vendor's traversal reports no cost: this view is empty under it").small());
        }
        if params.settings.accel == Accel::Brute && info.brute_tests > crate::tracer::budget::tests_per_submission() {
            // Said before the wait, not after: the frame is long and comes in bands.
            let text = format!("brute force: {:.1e} ray-triangle tests per frame, traced in bands over many displayed frames", info.brute_tests);
            ui.add(egui::Label::new(RichText::new(text).small()).wrap());
        }
        for s in [&state.render_status, &state.shader_status].into_iter().flatten() {
            status_line(ui, s);
        }
        match (params.view, info.heat) {
            (ViewMode::Cost(metric), Some((top, max, mean))) => heat_legend(ui, &format!("{} per pixel, all rays", metric.label()), top, max, mean),
            (ViewMode::Samples, Some((top, max, mean))) => heat_legend(ui, "camera samples per pixel", top, max, mean),
            _ => {}
        }
        if let Some(note) = info.view_note {
            ui.label(RichText::new(note).small());
        }
    });
}

fn heat_legend(ui: &mut Ui, what: &str, top: f32, max: f32, mean: f32) {
    ui.label(RichText::new(what).small());
    let (rect, _) = ui.allocate_exact_size(egui::vec2(ui.available_width().min(260.0), 14.0), Sense::hover());
    let steps = 64;
    for i in 0..steps {
        let t0 = i as f32 / steps as f32;
        let t1 = (i + 1) as f32 / steps as f32;
        let [r, g, b] = heat_color((t0 + t1) * 0.5);
        let x0 = rect.left() + rect.width() * t0;
        let x1 = rect.left() + rect.width() * t1;
        ui.painter().rect_filled(egui::Rect::from_x_y_ranges(x0..=x1 + 0.5, rect.y_range()), 0.0, Color32::from_rgb(r, g, b));
    }
    ui.horizontal(|ui| {
        ui.label(RichText::new("0").small());
        ui.with_layout(egui::Layout::right_to_left(egui::Align::Center), |ui| {
            ui.label(RichText::new(format!("{top:.0} (99th pct.)")).small());
        });
    });
    ui.label(RichText::new(format!("mean {mean:.1}, max {max:.0}")).small().weak());
}

fn model_section(ui: &mut Ui, params: &mut Params, state: &mut PanelState, info: &PanelInfo, actions: &mut Vec<PanelAction>) {
    section(ui, "Model", true, |ui| {
        let current = info.model.map_or("(none)".to_string(), |m| m.label());
        ui.horizontal(|ui| {
            ui.label("Model");
            egui::ComboBox::new("model", "").selected_text(current).width(ui.available_width() - 24.0).truncate().show_ui(ui, |ui| {
                for m in PaperModel::ALL {
                    let selected = info.model == Some(&ModelSource::Paper(m));
                    if ui.selectable_label(selected, m.name()).clicked() && !selected {
                        // The path field no longer names what is shown.
                        state.path.clear();
                        actions.push(PanelAction::LoadModel(ModelSource::Paper(m)));
                    }
                }
            });
        });
        ui.horizontal(|ui| {
            let field = ui
                .add(egui::TextEdit::singleline(&mut state.path).hint_text("model.obj or torusknot:1M").desired_width(ui.available_width() - 52.0))
                .on_hover_text("an .obj path, a model name (geosphere, torusknot, sphere, cylinder) or torusknot:N, a generated knot of N triangles");
            let enter = field.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
            let clicked = ui.add_enabled(!state.path.trim().is_empty(), egui::Button::new("Load")).clicked();
            if (clicked || enter) && !state.path.trim().is_empty() {
                // The same names as --model: built-ins and generated knots too.
                actions.push(PanelAction::LoadModel(ModelSource::parse(state.path.trim())));
            }
        });
        ui.horizontal(|ui| {
            if ui.button("Open .obj…").on_hover_text("choose an .obj file (Ctrl+O)").clicked() {
                actions.push(PanelAction::Open(Purpose::Model));
            }
            ui.label(RichText::new(if state.hovering_file { "drop the file to load it" } else { "or drop one on the window" }).small().weak());
        });
        if let Some((label, stage, secs)) = info.loading {
            ui.horizontal(|ui| {
                ui.spinner();
                // Elided: a long path must not widen the panel.
                ui.add(egui::Label::new(format!("{label}: {stage} ({secs:.1} s)")).truncate());
            });
        } else if let Some(s) = &state.model_status {
            status_line(ui, s);
            if state.model_warnings.len() > 1 {
                egui::CollapsingHeader::new(format!("{} warnings", state.model_warnings.len())).id_salt("model warnings").default_open(false).show(ui, |ui| {
                    for w in &state.model_warnings {
                        ui.add(egui::Label::new(RichText::new(w).small()).wrap());
                    }
                });
            }
        }
        ui.horizontal(|ui| {
            ui.label("Copies");
            ui.add(egui::Slider::new(&mut params.model_count, 1..=MAX_MODELS));
        });
        ui.label(RichText::new(format!("{} triangles, {} vertices in the scene", group(info.triangles), group(info.vertices))).small());
    });
}

fn light_section(ui: &mut Ui, params: &mut Params) {
    section(ui, "Light", true, |ui| {
        let limit = BOX_HALF_SIZE * 0.98;
        egui::Grid::new("light").num_columns(2).show(ui, |ui| {
            ui.label("Orbit radius");
            ui.add(egui::Slider::new(&mut params.light.radius, 0.0..=limit).fixed_decimals(2)).on_hover_text("distance of the light's circle from the vertical axis (inside the box)");
            ui.end_row();
            ui.label("Height");
            ui.add(egui::Slider::new(&mut params.light.height, -limit..=limit).fixed_decimals(2)).on_hover_text("height of the light's circle");
            ui.end_row();
            ui.label("Speed");
            ui.add(egui::Slider::new(&mut params.light_speed, -180.0..=180.0).suffix(" °/s").fixed_decimals(0)).on_hover_text("how fast the light orbits (the paper's moving light, §4); negative turns the other way");
            ui.end_row();
            ui.label("");
            ui.checkbox(&mut params.light_paused, "paused (Space)").on_hover_text("stop the light where it is; the phase slider then places it");
            ui.end_row();
            ui.label("Phase");
            ui.add_enabled(params.light_paused, egui::Slider::new(&mut params.light.angle_deg, 0.0..=360.0).suffix("°").fixed_decimals(1));
            ui.end_row();
        });
    });
}

fn display_section(ui: &mut Ui, params: &mut Params, state: &PanelState, info: &PanelInfo, actions: &mut Vec<PanelAction>) {
    section(ui, "Display", false, |ui| {
        ui.checkbox(&mut params.hud_visible, "numbers over the image (I)");
        ui.add_enabled(info.vsync_off_available || !params.vsync, egui::Checkbox::new(&mut params.vsync, "vsync (V)"));
        ui.label(RichText::new(format!("present mode: {}", info.present_mode)).small().weak());
        if !info.vsync_off_available {
            ui.label(RichText::new("this surface offers only FIFO (vsync)").small().weak());
        }
        ui.separator();
        let remembered = match info.settings_file {
            Some(path) => format!("window size, open sections and recent presets are remembered in {}", path.display()),
            None => "settings are not remembered in this run (--no-persist or a scripted run)".to_string(),
        };
        ui.add(egui::Label::new(RichText::new(remembered).small().weak()).wrap());
        if ui.add_enabled(info.settings_file.is_some(), egui::Button::new("Reset settings")).on_hover_text("forget the remembered settings; the window and sections return to how they first open").clicked() {
            actions.push(PanelAction::ResetSettings);
        }
        if let Some(s) = &state.settings_status {
            status_line(ui, s);
        }
    });
}

/// The compact numbers drawn over a corner of the image (the HUD): visible at any window
/// size, whether the panel is shown or scrolled.
pub fn hud(ui: &mut Ui, info: &PanelInfo) {
    let gpu = info.stats.gpu.summary().map(|s| s.current);
    let frame = info.stats.frame.summary().map(|s| s.current);
    let ms = |v: Option<f64>| v.map_or("-".into(), |v| format!("{v:.2}"));
    let lines = [
        format!("{:.1} fps", info.stats.fps()),
        format!("GPU {} ms", ms(gpu)),
        format!("frame {} ms", ms(frame)),
        format!("{} Mrays/s", gpu.map_or("-".into(), |g| format!("{:.0}", mrays_per_second(info.rays, g)))),
        format!("{} triangles", group(info.triangles)),
    ];
    let banded = info.progress.map(|(p, left)| match left {
        Some(s) => format!("tracing in bands: {:.0}%, {} left", p * 100.0, duration(s)),
        None => format!("tracing in bands: {:.0}%", p * 100.0),
    });
    for (i, line) in lines.iter().chain(banded.iter()).enumerate() {
        let color = match i {
            1 => GPU_COLOR,
            2 => FRAME_COLOR,
            _ => Color32::from_gray(230),
        };
        ui.add(egui::Label::new(RichText::new(line).monospace().color(color)).wrap_mode(egui::TextWrapMode::Extend));
    }
}

fn screenshot_section(ui: &mut Ui, state: &PanelState, info: &PanelInfo, actions: &mut Vec<PanelAction>) {
    section(ui, "Screenshots", true, |ui| {
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
        ui.add(egui::Label::new(RichText::new(format!("folder: {}", info.screenshot_dir)).small().weak()).truncate());
        if let Some(s) = &state.screenshot_status {
            status_line(ui, s);
        }
    });
}

/// Seconds as "12 s" or "3 min".
fn duration(s: f64) -> String {
    if s < 90.0 { format!("{s:.0} s") } else { format!("{:.0} min", s / 60.0) }
}

/// A status line, red for a failure, wrapped to the panel's width.
pub(crate) fn status_line(ui: &mut Ui, s: &Status) {
    let text = RichText::new(&s.text).small();
    ui.add(egui::Label::new(if s.error { text.color(ERROR_COLOR) } else { text }).wrap());
}

/// 1234567 -> "1 234 567".
pub fn group(n: u64) -> String {
    let s = n.to_string();
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if i > 0 && (s.len() - i) % 3 == 0 {
            out.push(' ');
        }
        out.push(c);
    }
    out
}

/// The paper's future work, each a switch: smooth shading, textures, environment map,
/// supersampling, adaptive sampling, progressive accumulation.
fn shading_section(ui: &mut Ui, params: &mut Params, info: &PanelInfo) {
    use crate::scene::EnvironmentSource;
    use crate::tracer::frame::MAX_SPP;
    section(ui, "Shading", true, |ui| {
        egui::Grid::new("shading").num_columns(2).show(ui, |ui| {
            ui.label("Normals");
            ui.horizontal(|ui| {
                ui.radio_value(&mut params.settings.smooth, false, "flat (paper)").on_hover_text("one normal per triangle, as the paper shades (§3.3)");
                ui.radio_value(&mut params.settings.smooth, true, "smooth").on_hover_text("vertex normals interpolated across each triangle (§5's smooth shading)");
            });
            ui.end_row();
            ui.label("Textures");
            ui.checkbox(&mut params.settings.textures, "map_Kd").on_hover_text("diffuse textures from the model's .mtl (§5)");
            ui.end_row();
            ui.label("Environment");
            let label = |e: &Option<EnvironmentSource>| match e {
                None => "none (black)".to_string(),
                Some(EnvironmentSource::Sky) => "sky".to_string(),
                Some(EnvironmentSource::File(p)) => p.file_name().map_or("file".into(), |f| f.to_string_lossy().into_owned()),
            };
            egui::ComboBox::new("environment", "").selected_text(label(&params.environment)).show_ui(ui, |ui| {
                ui.selectable_value(&mut params.environment, None, label(&None));
                ui.selectable_value(&mut params.environment, Some(EnvironmentSource::Sky), "sky");
                if let Some(file) = params.environment_file.clone() {
                    let text = label(&Some(file.clone()));
                    ui.selectable_value(&mut params.environment, Some(file), text);
                }
            });
            ui.end_row();
            ui.label("Samples/pixel");
            ui.add(egui::Slider::new(&mut params.settings.spp, 1..=MAX_SPP).logarithmic(true)).on_hover_text("jittered camera rays per pixel: anti-aliasing (§5)");
            ui.end_row();
            ui.label("Adaptive");
            ui.checkbox(&mut params.settings.adaptive, "extra samples on edges only").on_hover_text("adaptive sampling (§5): all samples only where a neighbour's path meets another surface");
            ui.end_row();
            ui.label("Accumulate");
            ui.checkbox(&mut params.accumulate, "while nothing changes").on_hover_text("average successive frames into a smoother image until a setting or the view changes");
            ui.end_row();
        });
        let spp = params.settings.spp as u64;
        let text = format!(
            "{} frame(s) accumulated, {} samples per pixel{}",
            group(info.accumulated_frames as u64),
            group(info.accumulated_frames as u64 * spp),
            if params.settings.adaptive { " on edges" } else { "" }
        );
        ui.label(RichText::new(text).small().weak());
        ui.checkbox(&mut params.mirror_box, "mirror box (the paper's six planes)").on_hover_text("the six mirror planes around the model (§4's scene)");
        if params.environment.is_some() && params.mirror_box {
            ui.label(RichText::new("The closed mirror box hides the environment: untick it to see the environment.").small().weak());
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn digits_are_grouped() {
        assert_eq!(group(0), "0");
        assert_eq!(group(999), "999");
        assert_eq!(group(1000), "1 000");
        assert_eq!(group(1234567), "1 234 567");
    }

}
