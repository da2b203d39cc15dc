//! The Open dialog (Ctrl+O, the Model section's "Open model…", the Presets section's
//! "Open…", the Shading section's environment "file…"): egui-file-dialog, drawn by egui in the tool's own window, so it works under a
//! bare X11 session with no desktop portal, GTK or zenity. It only picks a path; the tool
//! loads it exactly as a dropped file or a typed path.

use std::path::{Path, PathBuf};

use egui_file_dialog::{DialogState, FileDialog, Filter};

/// What the file picked is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Purpose {
    /// A model (OBJ, PLY or glTF), loaded as if dropped on the window.
    Model,
    /// A preset (.toml, or a PNG the program wrote), loaded as the Presets section's Load.
    Preset,
    /// An environment map (an equirectangular image), chosen in the Shading section.
    Environment,
}

/// The name of the filter the dialog opens with, for each purpose.
const MODEL_FILTER: &str = "Models (.obj, .ply, .gltf, .glb)";
const PRESET_FILTER: &str = "Presets (.toml, .png)";
const IMAGE_FILTER: &str = "Images (.hdr, .exr, .png, .jpg)";

/// The extensions of the environment maps the image decoder reads.
const IMAGE_EXTENSIONS: [&str; 5] = ["hdr", "exr", "png", "jpg", "jpeg"];

/// The dialog, when one is open, and what it is for.
#[derive(Default)]
pub(crate) struct OpenDialog {
    open: Option<(Purpose, FileDialog)>,
}

impl OpenDialog {
    /// Open the dialog for `purpose` in the folder of `near` (the model or preset in use),
    /// or in the current folder; one already open is replaced.
    pub(crate) fn open(&mut self, purpose: Purpose, near: Option<&Path>) {
        let dialog = FileDialog::new()
            .title(match purpose {
                Purpose::Model => "Open a model",
                Purpose::Preset => "Open a preset",
                Purpose::Environment => "Open an environment map",
            })
            .initial_directory(start_folder(near))
            .add_file_filter(MODEL_FILTER, extensions(&crate::scene::formats::MODEL_EXTENSIONS))
            .add_file_filter(PRESET_FILTER, extensions(&["toml", "png"]))
            .add_file_filter(IMAGE_FILTER, extensions(&IMAGE_EXTENSIONS))
            .default_file_filter(match purpose {
                Purpose::Model => MODEL_FILTER,
                Purpose::Preset => PRESET_FILTER,
                Purpose::Environment => IMAGE_FILTER,
            })
            // "All files" stays in the filter list, to see what else the folder holds.
            .show_all_files_filter(true);
        let mut dialog = dialog;
        dialog.pick_file();
        self.open = Some((purpose, dialog));
    }

    /// The dialog is showing: the tool's shortcuts and camera controls wait until it closes
    /// (its own keys, Escape and Enter among them, are its own).
    pub(crate) fn is_open(&self) -> bool {
        self.open.is_some()
    }

    /// Draw the dialog for this frame; returns the file picked, once, with its purpose.
    pub(crate) fn show(&mut self, ctx: &egui::Context) -> Option<(Purpose, PathBuf)> {
        let (purpose, dialog) = self.open.as_mut()?;
        let purpose = *purpose;
        let focused = ctx.memory(|m| m.focused());
        dialog.update(ctx);
        // `/` opened the path field holding the current folder: select it all, so a typed
        // path (the `/` itself first, in the next frame's input) replaces it.
        let now = ctx.memory(|m| m.focused());
        if let Some(field) =
            now.filter(|&id| Some(id) != focused && ctx.input(|i| i.key_pressed(egui::Key::Slash)))
        {
            select_all(ctx, field);
        }
        match dialog.state() {
            DialogState::Open => None,
            DialogState::Picked(_) => {
                let picked = dialog.take_picked();
                self.open = None;
                picked.map(|p| (purpose, p))
            }
            // Cancelled, closed, or a multiple pick (not asked for): nothing to load.
            _ => {
                self.open = None;
                None
            }
        }
    }
}

/// Select all the text of the text field `id`.
fn select_all(ctx: &egui::Context, id: egui::Id) {
    use egui::text::{CCursor, CCursorRange};
    if let Some(mut state) = egui::TextEdit::load_state(ctx, id) {
        // The end is clamped to the text's length when the field next runs.
        state
            .cursor
            .set_char_range(Some(CCursorRange::two(CCursor::new(0), CCursor::new(usize::MAX))));
        state.store(ctx, id);
    }
}

/// A filter for files with one of `names` as extension, in any case (the crate's own
/// extension filter would miss MODEL.OBJ).
fn extensions(names: &'static [&'static str]) -> Filter<Path> {
    Filter::new(move |p: &Path| has_extension(p, names))
}

/// Whether `path`'s extension is one of `names`, ignoring case.
fn has_extension(path: &Path, names: &[&str]) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| names.iter().any(|n| e.eq_ignore_ascii_case(n)))
}

/// The folder the dialog starts in: that of `near` when it names a file or folder that
/// exists (a relative path is taken from the current folder), else the current folder.
pub(crate) fn start_folder(near: Option<&Path>) -> PathBuf {
    let current = std::env::current_dir().unwrap_or_else(|_| PathBuf::from("."));
    let Some(near) = near else { return current };
    let near = current.join(near);
    let folder = if near.is_dir() { Some(near.as_path()) } else { near.parent() };
    folder.filter(|f| f.is_dir()).map_or(current.clone(), Path::to_path_buf)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_dialog_starts_beside_the_file_in_use_or_in_the_current_folder() {
        let here = std::env::current_dir().unwrap();
        assert_eq!(start_folder(None), here);
        let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
        assert_eq!(start_folder(Some(&manifest.join("Cargo.toml"))), manifest);
        assert_eq!(start_folder(Some(&manifest.join("src"))), manifest.join("src"));
        // A file that is gone opens its folder; a folder that is gone, the current one.
        assert_eq!(start_folder(Some(&manifest.join("gone.obj"))), manifest);
        assert_eq!(start_folder(Some(Path::new("/nonexistent/folder/model.obj"))), here);
        // Relative to the current folder (the tests run in the package root).
        assert_eq!(start_folder(Some(Path::new("src/main.rs"))), here.join("src"));
    }

    #[test]
    fn the_filters_ignore_case() {
        assert!(has_extension(Path::new("a/MODEL.OBJ"), &["obj"]));
        assert!(has_extension(Path::new("look.toml"), &["toml", "png"]));
        assert!(!has_extension(Path::new("model.obj.bak"), &["obj"]));
        assert!(!has_extension(Path::new("obj"), &["obj"]));
    }

    #[test]
    fn opening_shows_until_cancelled_and_picks_nothing() {
        let mut dialog = OpenDialog::default();
        assert!(!dialog.is_open());
        dialog.open(Purpose::Model, None);
        assert!(dialog.is_open());
        let ctx = egui::Context::default();
        let mut picked = None;
        // No renderer here: the font texture's upload is dropped on purpose.
        ctx.run_ui(egui::RawInput::default(), |ui| picked = dialog.show(ui.ctx()))
            .textures_delta
            .clear();
        assert_eq!(picked, None);
        assert!(dialog.is_open(), "the dialog closed by itself");
        // Escape is the dialog's cancel key.
        let escape = egui::Event::Key {
            key: egui::Key::Escape,
            physical_key: None,
            pressed: true,
            repeat: false,
            modifiers: egui::Modifiers::NONE,
        };
        let raw = egui::RawInput { events: vec![escape], ..Default::default() };
        ctx.run_ui(raw, |ui| picked = dialog.show(ui.ctx())).textures_delta.clear();
        assert_eq!(picked, None);
        assert!(!dialog.is_open(), "Escape did not close the dialog");
    }

    #[test]
    fn slash_opens_the_path_field_so_that_a_typed_absolute_path_replaces_the_folder() {
        let dir =
            std::env::temp_dir().join(format!("meshtracer-open-dialog-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let model = dir.join("cube.obj");
        std::fs::write(&model, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        let expected = model.canonicalize().unwrap();
        let mut dialog = OpenDialog::default();
        // Opened in the manifest's folder: the field would hold it, and the path appended.
        dialog.open(Purpose::Model, Some(Path::new(env!("CARGO_MANIFEST_DIR"))));
        let ctx = egui::Context::default();
        let key = |key| egui::Event::Key {
            key,
            physical_key: None,
            pressed: true,
            repeat: false,
            modifiers: egui::Modifiers::NONE,
        };
        let mut picked = None;
        // Frames as the tool cuts them: "/" ends its frame, its text and the path follow.
        let frames = [
            vec![],
            vec![key(egui::Key::Slash)],
            vec![
                egui::Event::Text("/".into()),
                egui::Event::Text(model.to_str().unwrap()[1..].into()),
            ],
            vec![key(egui::Key::Enter)],
        ];
        for events in frames {
            let raw = egui::RawInput { events, ..Default::default() };
            ctx.run_ui(raw, |ui| picked = picked.take().or(dialog.show(ui.ctx())))
                .textures_delta
                .clear();
        }
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(
            picked,
            Some((Purpose::Model, expected)),
            "the path typed after / was not the one picked"
        );
    }

    /// Open the dialog on the manifest's folder and deliver `burst` (a path typed after `/`,
    /// then Enter) all at once after `quiet` passes, cut into passes as the tool cuts them;
    /// returns what the dialog picked.
    fn type_in_one_burst(model: &Path, quiet: usize, enter: bool) -> Option<(Purpose, PathBuf)> {
        use crate::app::tool::input::{focus_cut, Input};
        let key = |key| egui::Event::Key {
            key,
            physical_key: None,
            pressed: true,
            repeat: false,
            modifiers: egui::Modifiers::NONE,
        };
        // Each `/` of the path is a key with its text, as egui-winit gives them.
        let mut burst = Vec::new();
        for c in model.to_str().unwrap().chars() {
            if c == '/' {
                burst.push(key(egui::Key::Slash));
            }
            burst.push(egui::Event::Text(c.to_string()));
        }
        if enter {
            burst.push(key(egui::Key::Enter));
        }
        let mut dialog = OpenDialog::default();
        dialog.open(Purpose::Model, Some(Path::new(env!("CARGO_MANIFEST_DIR"))));
        let (ctx, mut input, mut picked) = (egui::Context::default(), Input::default(), None);
        let mut pending = Vec::new();
        for pass in 0..quiet + 6 {
            if pass == quiet {
                pending.append(&mut burst);
                input.events_arrived(pending.len(), pass as f64);
            }
            let mut raw =
                egui::RawInput { events: std::mem::take(&mut pending), ..Default::default() };
            let wants_keys = ctx.egui_wants_keyboard_input();
            let open = dialog.is_open();
            pending = input.take_pass(&mut raw, pass as f64, |e| focus_cut(e, open, wants_keys)).1;
            ctx.run_ui(raw, |ui| picked = picked.take().or(dialog.show(ui.ctx())))
                .textures_delta
                .clear();
        }
        picked
    }

    #[test]
    fn a_path_and_enter_typed_in_one_burst_are_picked() {
        let dir = std::env::temp_dir().join(format!("meshtracer-burst-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let model = dir.join("cube.obj");
        std::fs::write(&model, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        let expected = Some((Purpose::Model, model.canonicalize().unwrap()));
        // The burst in the dialog's first frame (typed with Ctrl+O) or a later one (typed
        // during the slow frame after it): the dialog reads Enter before its path field
        // takes the frame's text, so the text must come a frame before Enter.
        let (first, later) =
            (type_in_one_burst(&model, 0, true), type_in_one_burst(&model, 2, true));
        // Without Enter nothing is picked (the path waits in the field).
        let unsent = type_in_one_burst(&model, 1, false);
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(first, expected, "a path typed in the dialog's first frame was lost");
        assert_eq!(later, expected, "a path typed with its Enter in one burst was lost");
        assert_eq!(unsent, None);
    }
}
