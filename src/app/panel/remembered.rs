//! The panel's part of the remembered settings (`user_files::settings`): the presets and
//! model files used lately, the graph's window and which sections are open, put into the panel at start,
//! read back at exit and forgotten on "Reset settings".

use std::collections::BTreeMap;

use crate::app::panel::widgets::Sections;
use crate::app::panel::PanelState;
use crate::app::user_files::settings::{Settings, FORMAT};

/// Put the remembered settings into the panel and egui's memory.
pub(crate) fn restore(settings: &Settings, panel: &mut PanelState, ctx: &egui::Context) {
    for p in settings.recent_presets.iter().rev() {
        panel.presets.used(p);
    }
    for p in settings.recent_models.iter().rev() {
        panel.model.loaded(p);
    }
    panel.perf.set_seconds(settings.graph_seconds);
    Sections::set(ctx, Sections { open: settings.sections.clone(), reset: false });
}

/// What to remember of the run now, with the window's logical size (None when minimized).
pub(crate) fn snapshot(
    window: Option<[u32; 2]>,
    panel: &PanelState,
    ctx: &egui::Context,
) -> Settings {
    Settings {
        version: FORMAT,
        window: window.filter(|&[w, h]| w >= 64 && h >= 64),
        sections: Sections::get(ctx).open,
        // Absolute: the next run may start in another folder.
        recent_presets: absolute(&panel.presets.recent),
        recent_models: absolute(&panel.model.recent),
        graph_seconds: Some(panel.perf.seconds),
    }
}

/// `paths` made absolute where they can be.
fn absolute(paths: &[std::path::PathBuf]) -> Vec<std::path::PathBuf> {
    paths.iter().map(|p| std::path::absolute(p).unwrap_or_else(|_| p.clone())).collect()
}

/// Forget the panel's remembered state: sections, recent presets and models and the
/// graph's window go back to how a first run opens.
pub(crate) fn reset(panel: &mut PanelState, ctx: &egui::Context) {
    panel.presets.recent.clear();
    panel.model.recent.clear();
    panel.perf.set_seconds(None);
    Sections::set(ctx, Sections { open: BTreeMap::new(), reset: true });
}
