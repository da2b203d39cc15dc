//! The panel's benchmark section: the frame count, the button that starts a run (or
//! cancels the one in progress), its progress, and the last run's summary.

use egui::{RichText, Ui};

use super::benchmark::DEFAULT_FRAMES;
use super::panel::{status_line, PanelAction, Status};

/// What the section keeps between frames.
pub struct BenchmarkPanel {
    /// Frames in the next run.
    pub frames: u32,
    /// The last finished run's summary lines.
    pub lines: Vec<String>,
    /// Where the last summary went, or why a run failed or stopped.
    pub status: Option<Status>,
}

impl Default for BenchmarkPanel {
    fn default() -> Self {
        Self { frames: DEFAULT_FRAMES, lines: Vec::new(), status: None }
    }
}

/// The section; `progress` is (measured, total) frames of the run in progress.
pub fn benchmark_section(ui: &mut Ui, state: &mut BenchmarkPanel, progress: Option<(u32, u32)>, actions: &mut Vec<PanelAction>) {
    super::settings::section(ui, "Benchmark", false, |ui| {
        ui.horizontal(|ui| {
            match progress {
                Some((done, total)) => {
                    ui.add(egui::ProgressBar::new(done as f32 / total.max(1) as f32).desired_width(120.0).text(format!("{done} / {total}")));
                    if ui.button("Cancel").clicked() {
                        actions.push(PanelAction::CancelBenchmark);
                    }
                }
                None => {
                    ui.add(egui::DragValue::new(&mut state.frames).range(1..=100_000).suffix(" frames"));
                    if ui.button("Run benchmark").on_hover_text("The camera orbits once at the current settings (light paused, no accumulation); B starts it too").clicked() {
                        actions.push(PanelAction::Benchmark(state.frames));
                    }
                }
            }
        });
        for line in &state.lines {
            ui.add(egui::Label::new(RichText::new(line.trim()).small().monospace()).wrap());
        }
        if let Some(s) = &state.status {
            status_line(ui, s);
        }
    });
}
