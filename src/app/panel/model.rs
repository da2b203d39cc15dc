//! The panel's Model section: the built-in models, the path field and Open dialog, the
//! files loaded lately, a load in progress and its outcome, and the number of copies.

use std::path::{Path, PathBuf};

use egui::{RichText, Ui};

use crate::app::panel::info::PanelInfo;
use crate::app::panel::section::{Cx, PanelAction, Section};
use crate::app::panel::widgets::{group, status_line, Status};
use crate::app::user_files::model_loader::LoadStatus;
use crate::app::user_files::open_dialog::Purpose;
use crate::progress::Phase;
use crate::render_settings::MODELS;
use crate::scene::paper::ModelSource;
use crate::scene::primitives::PaperModel;

/// The section's state between frames.
#[derive(Default)]
pub(crate) struct ModelPanel {
    /// The model path field.
    pub(crate) path: String,
    /// The last model load's outcome.
    pub(crate) status: Option<Status>,
    /// Every warning of the last model load (the status line names the first).
    pub(crate) warnings: Vec<String>,
    /// A file is being dragged over the window.
    pub(crate) hovering_file: bool,
    /// Model files loaded lately, the latest first (remembered between runs).
    pub(crate) recent: Vec<PathBuf>,
}

/// How many recently loaded model files the section lists.
pub(crate) const RECENT_MODELS: usize = 6;

impl ModelPanel {
    /// Put `path`, just loaded, first in the recent list (once).
    pub(crate) fn loaded(&mut self, path: &Path) {
        self.recent.retain(|p| p != path);
        self.recent.insert(0, path.to_path_buf());
        self.recent.truncate(RECENT_MODELS);
    }
}

impl Section for ModelPanel {
    fn title(&self) -> &'static str {
        "Model"
    }

    fn default_open(&self) -> bool {
        true
    }

    fn body(&mut self, ui: &mut Ui, cx: &mut Cx) {
        let (params, info, actions) = (&mut *cx.params, cx.info, &mut *cx.actions);
        let current = info.model.map_or("(none)".to_string(), |m| m.label());
        ui.horizontal(|ui| {
            ui.label("Model");
            egui::ComboBox::new("model", "")
                .selected_text(current)
                .width(ui.available_width() - 24.0)
                .truncate()
                .show_ui(ui, |ui| {
                    for m in PaperModel::ALL {
                        let selected = info.model == Some(&ModelSource::Paper(m));
                        if ui.selectable_label(selected, m.name()).clicked() && !selected {
                            // The path field no longer names what is shown.
                            self.path.clear();
                            actions.push(PanelAction::LoadModel(ModelSource::Paper(m)));
                        }
                    }
                });
        });
        ui.horizontal(|ui| {
            let field = ui
                .add(egui::TextEdit::singleline(&mut self.path).hint_text("model.obj|ply|glb or torusknot:1M").desired_width(ui.available_width() - 52.0))
                .on_hover_text("an OBJ, PLY or glTF path, a model name (geosphere, torusknot, sphere, cylinder) or torusknot:N, a generated knot of N triangles");
            let enter = field.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
            // Always enabled: on a slow machine a name typed and Load clicked at once reach
            // the same frame, and a button disabled in the frame before takes no click.
            let clicked = ui.button("Load").clicked();
            if (clicked || enter) && !self.path.trim().is_empty() {
                // The same names as --model: built-ins and generated knots too.
                actions.push(PanelAction::LoadModel(ModelSource::parse(self.path.trim())));
            } else if clicked {
                self.status = Some(Status::error("type a model's path or name first, then Load"));
            }
        });
        ui.horizontal(|ui| {
            if ui
                .button("Open model…")
                .on_hover_text("choose an OBJ, PLY or glTF file (Ctrl+O)")
                .clicked()
            {
                actions.push(PanelAction::Open(Purpose::Model));
            }
            ui.label(
                RichText::new(if self.hovering_file {
                    "drop the file to load it"
                } else {
                    "or drop one on the window"
                })
                .small()
                .weak(),
            );
        });
        recent_models(ui, &self.recent, actions);
        if let Some(loading) = &info.loading {
            loading_progress(ui, loading, actions);
        } else if let Some(s) = &self.status {
            status_line(ui, s);
            if self.warnings.len() > 1 {
                egui::CollapsingHeader::new(format!("{} warnings", self.warnings.len()))
                    .id_salt("model warnings")
                    .default_open(false)
                    .show(ui, |ui| {
                        for w in &self.warnings {
                            ui.add(egui::Label::new(RichText::new(w).small()).wrap());
                        }
                    });
            }
        }
        ui.horizontal(|ui| {
            ui.label("Copies");
            ui.add(egui::Slider::new(&mut params.scene.models, MODELS.u32s()).logarithmic(true))
                .on_hover_text("up to 27 along the axes (the paper's Table 2), a field beyond");
        });
        let mut scattered = params.scene.scatter != 0;
        if ui
            .checkbox(&mut scattered, "turn and scale copies at random")
            .on_hover_text("each copy a random rotation and a scale of 0.5 to 1 (--scatter 1)")
            .changed()
        {
            params.scene.scatter = u32::from(scattered);
        }
        ui.label(RichText::new(scene_holds_text(info)).small());
    }
}

/// The model files loaded lately, a small button each (its name; the whole path on hover)
/// that loads it again as the Open dialog's pick would.
fn recent_models(ui: &mut Ui, recent: &[PathBuf], actions: &mut Vec<PanelAction>) {
    if recent.is_empty() {
        return;
    }
    ui.horizontal_wrapped(|ui| {
        ui.label(RichText::new("recent:").small().weak());
        for p in recent {
            let name = p.file_name().map_or_else(
                || crate::files::shown_path(p),
                |n| crate::files::shown(&n.to_string_lossy(), 40),
            );
            if ui.small_button(name).on_hover_text(crate::files::shown_path(p)).clicked() {
                actions.push(PanelAction::LoadFile(p.clone()));
            }
        }
    });
}

/// What the scene holds, in two lines: meshes and instances with their triangles, then
/// the GPU bytes of the two levels.
fn scene_holds_text(info: &PanelInfo) -> String {
    let Some(h) = info.holds else {
        return format!(
            "{} triangles, {} vertices in the scene",
            group(info.triangles),
            group(info.vertices)
        );
    };
    let plural = |n: usize, one: &str| {
        if n == 1 {
            format!("1 {one}")
        } else {
            format!("{} {one}es", group(n as u64))
        }
    };
    format!(
        "{}, {} instance{}: {} triangles stored, {} placed\ntop level {}, bottom levels {}",
        plural(h.meshes, "mesh"),
        group(h.instances as u64),
        if h.instances == 1 { "" } else { "s" },
        group(h.unique_triangles),
        group(h.instanced_triangles),
        bytes_text(h.top_bytes),
        bytes_text(h.bottom_bytes),
    )
}

/// Bytes in the nearest binary unit (B, KiB, MiB, GiB), three figures.
fn bytes_text(bytes: u64) -> String {
    let units = ["B", "KiB", "MiB", "GiB"];
    let mut value = bytes as f64;
    let mut unit = 0;
    while value >= 1024.0 && unit + 1 < units.len() {
        value /= 1024.0;
        unit += 1;
    }
    let decimals = if unit == 0 || value >= 100.0 {
        0
    } else if value >= 10.0 {
        1
    } else {
        2
    };
    format!("{value:.decimals$} {}", units[unit])
}

/// How full the load's bar is: each phase an equal share, the running one filled as far as
/// it reports. A phase that reports nothing (the BVH build) fills by its time instead, as
/// t / (t + T) of its share with T the time the phases before it took (at least half a
/// second): the bar moves while it runs and never claims its end.
pub(crate) fn bar_fraction(snapshot: &crate::progress::Snapshot) -> f32 {
    let done = snapshot.phases.iter().filter(|p| p.done).count();
    let before: f64 = snapshot.phases.iter().filter(|p| p.done).map(|p| p.seconds).sum();
    let running = snapshot.phases.last().filter(|p| !p.done);
    let share = match running {
        Some(_) if snapshot.fraction > 0.0 => snapshot.fraction,
        Some(p) => (p.seconds / (p.seconds + before.max(0.5))) as f32,
        None => 0.0,
    };
    ((done as f32 + share) / Phase::ALL.len() as f32).min(1.0)
}

/// A load in progress: a bar over the phases (each an equal share, the running one filled
/// as far as it reports), the finished phases' times, and a Cancel button (Escape).
fn loading_progress(ui: &mut Ui, loading: &LoadStatus, actions: &mut Vec<PanelAction>) {
    let snapshot = &loading.snapshot;
    let running = snapshot.phases.last();
    let overall = bar_fraction(snapshot);
    let text = match running {
        Some(p) if !p.done => format!("{}: {} {:.1} s", loading.label, p.phase.name(), p.seconds),
        Some(_) => format!("{}: uploading", loading.label),
        None => format!("{}: starting", loading.label),
    };
    ui.horizontal(|ui| {
        if ui
            .button("Cancel")
            .on_hover_text("stop loading and keep the model shown (Escape)")
            .clicked()
        {
            actions.push(PanelAction::CancelLoad);
        }
        // The bar's text is elided by the bar: a long path must not widen the panel.
        ui.add(egui::ProgressBar::new(overall).text(text).animate(true));
    });
    let finished: Vec<String> = snapshot
        .phases
        .iter()
        .filter(|p| p.done)
        .map(|p| format!("{} {:.2} s", p.phase.name(), p.seconds))
        .collect();
    if !finished.is_empty() {
        ui.add(egui::Label::new(RichText::new(finished.join(" · ")).small().weak()).truncate());
    }
}
