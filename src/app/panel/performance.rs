//! The panel's Performance section: the frame-time graph (egui_plot: a legend, hover
//! read-outs, zoom and a selectable window), the numbers, and the frame-time log's
//! Record / Stop.

use egui::{Color32, PointerButton, RichText, Ui};
use egui_plot::{uniform_grid_spacer, Corner, GridMark, Legend, Line, Plot, PlotPoints};

use crate::app::measure::frame_stats::{FrameStats, Series, HISTORY_SECONDS};
use crate::app::panel::info::PanelInfo;
use crate::app::panel::section::{Cx, PanelAction, Section};
use crate::app::panel::widgets::{group, mrays_text, status_line, Status, FRAME_COLOR, GPU_COLOR};

/// The graph's window lengths, in seconds.
pub(crate) const WINDOWS: [f64; 4] = [5.0, 10.0, 30.0, HISTORY_SECONDS];

/// The window the graph opens with.
pub(crate) const DEFAULT_WINDOW: f64 = 10.0;

/// The section's state between frames.
pub(crate) struct PerfPanel {
    /// Seconds of history the graph and the min/mean/max show.
    pub(crate) seconds: f64,
    /// The frame-time log's last outcome (written, or failed).
    pub(crate) status: Option<Status>,
    /// The graph shows the whole window again at its next draw (a window was chosen, or the
    /// settings were reset), whatever zoom the user left it in.
    reset_graph: bool,
}

impl Default for PerfPanel {
    fn default() -> Self {
        Self { seconds: DEFAULT_WINDOW, status: None, reset_graph: false }
    }
}

impl PerfPanel {
    /// A window length from the remembered settings, if it is one the graph offers; the
    /// graph leaves any zoom and shows that whole window.
    pub(crate) fn set_seconds(&mut self, seconds: Option<f64>) {
        self.seconds = seconds.filter(|s| WINDOWS.contains(s)).unwrap_or(DEFAULT_WINDOW);
        self.reset_graph = true;
    }
}

/// The id of the graph's memory (its zoom), fixed so that tests can read it.
pub(crate) fn graph_id() -> egui::Id {
    egui::Id::new("meshtracer frame-time graph")
}

/// A time in ms in at most five characters below 100 s, to three or four significant
/// digits: the table keeps its width (the panel grew, and the image moved, the first time
/// a frame took 100 ms or more, when two decimals made six).
fn ms_text(ms: f64) -> String {
    match ms {
        v if v < 1.0 => format!("{v:.3}"),
        v if v < 10.0 => format!("{v:.2}"),
        v if v < 100.0 => format!("{v:.1}"),
        v => format!("{v:.0}"),
    }
}

fn summary_row(ui: &mut Ui, name: &str, color: Color32, series: &Series, seconds: f64) {
    ui.label(RichText::new(name).color(color));
    match series.current().zip(series.summary_over(seconds)) {
        Some((current, s)) => {
            for v in [current, s.min, s.mean, s.max] {
                ui.label(RichText::new(ms_text(v)).monospace());
            }
        }
        None => {
            for _ in 0..4 {
                ui.label("-");
            }
        }
    }
    ui.end_row();
}

impl Section for PerfPanel {
    fn title(&self) -> &'static str {
        "Performance"
    }

    fn default_open(&self) -> bool {
        true
    }

    fn body(&mut self, ui: &mut Ui, cx: &mut Cx) {
        let (state, info, actions) = (self, cx.info, &mut *cx.actions);
        frame_graph(ui, info.stats, state.seconds, std::mem::take(&mut state.reset_graph));
        ui.horizontal(|ui| {
            ui.label(RichText::new("last").small());
            for s in WINDOWS {
                let label = RichText::new(format!("{s:.0} s")).small();
                // Even the window already shown: a click on it is how to leave a zoom.
                if ui.selectable_label(state.seconds == s, label).clicked() {
                    state.set_seconds(Some(s));
                    ui.ctx().request_repaint();
                }
            }
        });
        egui::Grid::new("times").num_columns(5).spacing([10.0, 2.0]).striped(true).show(ui, |ui| {
            ui.label("ms");
            for h in ["now", "min", "mean", "max"] {
                ui.label(RichText::new(h).small().weak());
            }
            ui.end_row();
            summary_row(ui, "GPU trace", GPU_COLOR, &info.stats.gpu, state.seconds);
            summary_row(ui, "frame", FRAME_COLOR, &info.stats.frame, state.seconds);
        });
        egui::Grid::new("counts").num_columns(2).show(ui, |ui| {
            ui.label("fps");
            ui.label(format!("{:.1}", info.stats.fps()));
            ui.end_row();
            ui.label("rays / frame");
            ui.label(format!("{} (at most)", group(info.settings.max_rays())));
            ui.end_row();
            ui.label("Mrays/s");
            ui.label(mrays_text(info.stats.gpu_now(&info.settings).map(|(_, mrays)| mrays)));
            ui.end_row();
            if let Some((now, highest)) = info.clock_mhz {
                let why = "the tracing GPU's shader clock, read twice a second. A GPU that idles between frames (vsync, a slow window) is clocked down by its driver and traces slower than `meshtracer bench` shows";
                ui.label("GPU clock").on_hover_text(why);
                ui.label(format!("{now:.0} MHz (highest {highest:.0})")).on_hover_text(why);
                ui.end_row();
            }
        });
        log_controls(ui, state, info, actions);
    }
}

/// Record / Stop of the frame-time log, and what it is writing or wrote.
fn log_controls(ui: &mut Ui, state: &PerfPanel, info: &PanelInfo, actions: &mut Vec<PanelAction>) {
    ui.horizontal(|ui| {
        match info.recording {
            Some(_) => {
                if ui.button("Stop").on_hover_text("close the frame-time log").clicked() {
                    actions.push(PanelAction::StopRecording);
                }
            }
            None => {
                let what = "write a CSV row per frame (times, resolution, bounces, spp, acceleration, triangles, rays) and a row per parameter change, to compare settings";
                if ui.button("Record").on_hover_text(what).clicked() {
                    actions.push(PanelAction::Record);
                }
            }
        }
        if let Some((path, frames)) = info.recording {
            let name = path.file_name().map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into_owned());
            ui.add(egui::Label::new(RichText::new(format!("recording: {} frames to {name}", group(frames))).small()).truncate()).on_hover_text(path.display().to_string());
        }
    });
    if info.recording.is_none() {
        if let Some(s) = &state.status {
            status_line(ui, s);
        }
    }
}

/// The last `seconds` of both series, seconds before now on x: the lines scroll. A drag
/// across the graph zooms into the stretch it covers (Ctrl+wheel zooms too), and the zoom
/// stays on that stretch before now until a double click, a window button or "Reset
/// settings" (`reset`) shows the whole window again.
fn frame_graph(ui: &mut Ui, stats: &FrameStats, seconds: f64, reset: bool) {
    let now = stats.latest();
    let gpu: PlotPoints = stats.gpu.recent(seconds, now).collect();
    let frame: PlotPoints = stats.frame.recent(seconds, now).collect();
    let mut plot = Plot::new("frame times")
        .id(graph_id())
        .height(120.0)
        .legend(Legend::default().position(Corner::LeftTop).background_alpha(0.6))
        .include_x(-seconds)
        .include_x(0.0)
        .include_y(0.0)
        .allow_scroll(false)
        .allow_drag(false)
        .allow_boxed_zoom(true)
        .boxed_zoom_pointer_button(PointerButton::Primary)
        .allow_double_click_reset(true)
        .y_axis_min_width(40.0)
        .y_grid_spacer(uniform_grid_spacer(|input| y_steps(input.bounds)))
        .x_axis_formatter(|mark, _| format!("{:.0} s", mark.value))
        .y_axis_formatter(|mark, _| y_label(mark))
        .label_formatter(|pos| match pos {
            egui_plot::HoverPosition::NearDataPoint { plot_name, position, .. } => {
                Some(format!("{plot_name}: {:.2} ms\n{:.1} s ago", position.y, -position.x))
            }
            egui_plot::HoverPosition::Elsewhere { position } => {
                Some(format!("{:.1} ms", position.y))
            }
        });
    if reset {
        plot = plot.reset();
    }
    plot.show(ui, |plot| {
        plot.line(Line::new("frame ms", frame).color(FRAME_COLOR).width(1.5));
        plot.line(Line::new("GPU ms", gpu).color(GPU_COLOR).width(1.5));
    });
}

/// The y grid's three step sizes for the visible `bounds` (ms): the labelled one a 1, 2 or 5
/// times a power of ten that puts four or five labels on the graph's 120 points (egui_plot's
/// powers of ten alone labelled only "0" for 200-800 ms, the next label being 1000).
fn y_steps(bounds: (f64, f64)) -> [f64; 3] {
    let span = (bounds.1 - bounds.0).abs().max(1e-6);
    let rough = span / 4.0;
    let power = 10f64.powf(rough.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0].into_iter().map(|m| m * power).find(|&s| s >= rough);
    let step = step.unwrap_or(10.0 * power);
    [step / 5.0, step, step * 10.0]
}

/// A y label in ms with as many decimals as its step needs: marks a step apart always
/// read differently ("250 ms", "0.02 ms").
fn y_label(mark: GridMark) -> String {
    let decimals = (-mark.step_size.log10()).ceil().clamp(0.0, 6.0) as usize;
    format!("{:.*} ms", decimals, mark.value)
}

#[cfg(test)]
mod tests {
    use super::{ms_text, y_label, y_steps, GridMark};

    /// The labels of the labelled (middle) step's marks within `bounds`.
    fn labels(bounds: (f64, f64)) -> Vec<String> {
        let step = y_steps(bounds)[1];
        let first = (bounds.0 / step).ceil() as i64;
        let last = (bounds.1 / step).floor() as i64;
        (first..=last)
            .map(|i| y_label(GridMark { value: i as f64 * step, step_size: step }))
            .collect()
    }

    #[test]
    fn the_y_axis_labels_frame_times_of_hundreds_of_ms_distinctly() {
        // #43: 200-800 ms frames showed a single "0" on the y axis.
        for bounds in [(0.0, 800.0), (200.0, 800.0), (0.0, 0.8), (0.0, 3.0), (0.0, 60_000.0)] {
            let l = labels(bounds);
            assert!(l.len() >= 3, "{bounds:?}: only {l:?}");
            let mut unique = l.clone();
            unique.dedup();
            assert_eq!(unique, l, "{bounds:?}: labels repeat");
            assert!(l.iter().all(|t| t.ends_with(" ms")), "{l:?}");
        }
        assert_eq!(labels((0.0, 800.0)), ["0 ms", "200 ms", "400 ms", "600 ms", "800 ms"]);
        assert_eq!(labels((0.0, 0.8)), ["0.0 ms", "0.2 ms", "0.4 ms", "0.6 ms", "0.8 ms"]);
    }

    #[test]
    fn times_keep_to_five_characters_below_a_hundred_seconds() {
        assert_eq!(ms_text(0.4126), "0.413");
        assert_eq!(ms_text(9.994), "9.99");
        assert_eq!(ms_text(62.66), "62.7");
        assert_eq!(ms_text(249.63), "250");
        assert_eq!(ms_text(99_999.0), "99999");
        // Every value a frame can take up to 100 s, including those that round up.
        for v in (0..999_990).map(|i| i as f64 * 0.1).chain([0.9996, 9.996, 99.96]) {
            assert!(ms_text(v).len() <= 5, "{v} ms shows as {}", ms_text(v));
        }
    }
}
