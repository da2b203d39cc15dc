//! The panel's Presets section: save the look as a TOML preset (asking before replacing a
//! file), load a preset (or a PNG the program wrote), and the presets used this session.

use std::path::{Path, PathBuf};

use egui::{RichText, Ui};

use crate::app::panel::section::{Cx, PanelAction, Section};
use crate::app::panel::widgets::{status_line, Status};
use crate::app::user_files::open_dialog::Purpose;

/// How many recently used presets the section lists.
const RECENT: usize = 8;

/// The section's state between frames.
#[derive(Default)]
pub(crate) struct PresetPanel {
    /// The path field.
    pub(crate) path: String,
    /// A save that would replace this file, waiting for the user's yes or no.
    pub(crate) confirm: Option<PathBuf>,
    /// Presets saved or loaded this session, the latest first.
    pub(crate) recent: Vec<PathBuf>,
    /// The last save's or load's outcome.
    pub(crate) status: Option<Status>,
    /// Every warning of the last load (unknown keys).
    pub(crate) warnings: Vec<String>,
}

impl PresetPanel {
    /// Put `path` first in the recent list (once) and in the path field.
    pub(crate) fn used(&mut self, path: &Path) {
        self.recent.retain(|p| p != path);
        self.recent.insert(0, path.to_path_buf());
        self.recent.truncate(RECENT);
        self.path = path.display().to_string();
    }
}

/// The file the path field names: as typed, with `.toml` added when it has no extension
/// (so "look" saves a preset that `--preset look.toml` finds).
pub(crate) fn preset_path(typed: &str) -> Option<PathBuf> {
    let typed = typed.trim();
    if typed.is_empty() {
        return None;
    }
    let path = PathBuf::from(typed);
    Some(if path.extension().is_none() { path.with_extension("toml") } else { path })
}

/// Whether `path` names an image (where a preset must not be written).
fn is_image(path: &Path) -> bool {
    path.extension().is_some_and(|e| {
        ["png", "jpg", "jpeg", "exr", "hdr"].iter().any(|i| e.eq_ignore_ascii_case(i))
    })
}

impl Section for PresetPanel {
    fn title(&self) -> &'static str {
        "Presets"
    }

    fn default_open(&self) -> bool {
        false
    }

    fn body(&mut self, ui: &mut Ui, cx: &mut Cx) {
        let (state, actions) = (self, &mut *cx.actions);
        ui.label(
            RichText::new(
                "everything tunable, as TOML; meshtracer render --preset FILE renders it headless",
            )
            .small()
            .weak(),
        );
        ui.add(
            egui::TextEdit::singleline(&mut state.path)
                .hint_text("look.toml")
                .desired_width(ui.available_width()),
        )
        .on_hover_text(
            "a preset file to save to or load from (a PNG this program wrote loads too)",
        );
        let path = preset_path(&state.path);
        ui.horizontal(|ui| {
            if ui.add_enabled(path.is_some(), egui::Button::new("Save")).on_hover_text("asks before replacing a file").clicked() {
                state.confirm = None;
                match path.clone().filter(|p| !is_image(p)) {
                    Some(path) => actions.push(PanelAction::SavePreset { path, overwrite: false }),
                    // A preset is text: written over a PNG it would destroy the image.
                    None => state.status = Some(Status::error("a preset is a text file: give it a .toml name (F12 writes PNGs, which carry their preset)")),
                }
            }
            if ui.add_enabled(path.is_some(), egui::Button::new("Load")).clicked() {
                state.confirm = None;
                // Load what was typed: a PNG or a preset with another extension loads as is.
                actions.push(PanelAction::LoadPreset(PathBuf::from(state.path.trim())));
            }
            if ui.button("Open…").on_hover_text("choose a preset or a PNG to load").clicked() {
                state.confirm = None;
                actions.push(PanelAction::Open(Purpose::Preset));
            }
        });
        if let Some(target) = state.confirm.clone() {
            ui.label(
                RichText::new(format!("{} exists. Replace it?", crate::files::shown_path(&target)))
                    .small(),
            );
            ui.horizontal(|ui| {
                if ui.button("Replace").clicked() {
                    state.confirm = None;
                    actions.push(PanelAction::SavePreset { path: target, overwrite: true });
                }
                if ui.button("Cancel").clicked() {
                    state.confirm = None;
                    state.status = Some(Status::ok("not saved"));
                }
            });
        }
        if let Some(s) = &state.status {
            status_line(ui, s);
        }
        for w in &state.warnings {
            ui.add(egui::Label::new(RichText::new(w).small()).wrap());
        }
        if !state.recent.is_empty() {
            ui.label(RichText::new("recent (click to load)").small().weak());
            for p in state.recent.clone() {
                let name = p
                    .file_name()
                    .map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into_owned());
                if ui.small_button(name).on_hover_text(p.display().to_string()).clicked() {
                    state.confirm = None;
                    actions.push(PanelAction::LoadPreset(p));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn typed_paths_get_the_toml_extension() {
        assert_eq!(preset_path("  look "), Some(PathBuf::from("look.toml")));
        assert_eq!(preset_path("dir/look.toml"), Some(PathBuf::from("dir/look.toml")));
        assert_eq!(preset_path("shot.png"), Some(PathBuf::from("shot.png")));
        assert_eq!(preset_path("   "), None);
        assert!(is_image(Path::new("shot.PNG")) && !is_image(Path::new("look.toml")));
    }

    #[test]
    fn recent_presets_are_latest_first_without_repeats() {
        let mut p = PresetPanel::default();
        for name in ["a.toml", "b.toml", "a.toml"] {
            p.used(Path::new(name));
        }
        assert_eq!(p.recent, [PathBuf::from("a.toml"), PathBuf::from("b.toml")]);
        assert_eq!(p.path, "a.toml");
        for i in 0..20 {
            p.used(&PathBuf::from(format!("{i}.toml")));
        }
        assert_eq!(p.recent.len(), RECENT);
    }
}
