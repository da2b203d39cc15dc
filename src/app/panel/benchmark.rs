//! The panel's Benchmark section: the frame count, the button that starts a run (or
//! cancels the one in progress), its progress, and the last run's summary.

use egui::{RichText, Ui};

use crate::app::measure::benchmark::{Outcome, DEFAULT_FRAMES};
use crate::app::panel::section::{Cx, PanelAction, Section};
use crate::app::panel::widgets::status_line;

/// What the section keeps between frames.
pub(crate) struct BenchmarkPanel {
    /// Frames in the next run.
    pub(crate) frames: u32,
    /// What the last run said (the run writes it).
    pub(crate) outcome: Outcome,
}

impl Default for BenchmarkPanel {
    fn default() -> Self {
        Self { frames: DEFAULT_FRAMES, outcome: Outcome::default() }
    }
}

impl Section for BenchmarkPanel {
    fn title(&self) -> &'static str {
        "Benchmark"
    }

    fn default_open(&self) -> bool {
        false
    }

    fn body(&mut self, ui: &mut Ui, cx: &mut Cx) {
        let (state, progress, actions) = (self, cx.info.benchmark, &mut *cx.actions);
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
        for line in &state.outcome.lines {
            ui.add(egui::Label::new(RichText::new(line.trim()).small().monospace()).wrap());
        }
        if let Some(s) = &state.outcome.status {
            status_line(ui, s);
        }
    }
}
