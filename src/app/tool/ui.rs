//! The UI pass: egui run once a frame over the facts the panel shows (it decides the
//! image area and which keys are shortcuts), and the actions the panel asks for. Its
//! state is [`UiPass`](super::ui_state::UiPass).

use crate::app::panel::{self, PanelAction, PanelInfo, Status, VendorInfo};
use crate::app::state::fit_rect;
use crate::app::tool::Tool;
use crate::app::tool::{devices, input};
use crate::app::user_files::open_dialog::Purpose;
use crate::app::user_files::screenshot;
use crate::app::views::overlay;
use crate::gpu::khr_rt::VendorKernel;
use crate::gpu::present::PixelRect;
use crate::render_settings::RenderSettings;
use crate::tracer::budget;

impl Tool {
    /// Run egui for this frame; returns its output and the actions the panel asked for,
    /// and updates the image area.
    pub(super) fn run_ui(&mut self) -> (egui::FullOutput, Vec<PanelAction>) {
        let raw = self.take_input();
        let mut actions = Vec::new();
        let mut central = egui::Rect::NOTHING;
        let settings: RenderSettings = self.params.settings_for(self.area());
        let screenshot_dir = screenshot::screenshot_dir();
        let dir_text = crate::files::canonical_or_given(&screenshot_dir).display().to_string();
        let (triangles, vertices) = self.session.counts();
        let vendor = self.vendor_info();
        let device = devices::describe(&self.gpu.ctx, &self.gpu.trace_ctx);
        let info = PanelInfo {
            device: &device,
            auto_layout: self.params.bvh_auto.then(|| self.session.auto_layout.describe()),
            model: self.session.model.as_ref().map(|m| &m.source),
            triangles,
            vertices,
            holds: self.session.holds(),
            settings,
            loading: self.session.loader.status(),
            present_mode: self.gpu.presenter.present_mode_name(),
            vsync_off_available: self.gpu.presenter.can_disable_vsync(),
            heat: self.frame.picture.as_ref().and_then(|h| h.stats),
            view_note: self.frame.picture.as_ref().and_then(|h| h.note.as_deref()),
            accumulated_frames: self.session.accumulation.frames,
            progress: self.frame.progressive.as_ref().map(|p| (p.progress(), p.seconds_left())),
            brute_tests: budget::tests_per_frame(
                &RenderSettings { accel: crate::render_settings::Accel::Brute, ..settings },
                triangles,
            ),
            submission_tests: self.gpu.tracer.tests_per_submission(),
            screenshot_dir: dir_text,
            stats: &self.timing.stats,
            benchmark: self.timing.benchmarks.progress(),
            recording: self.timing.recorder.info(),
            settings_file: self.store.path.as_deref(),
            vendor: &vendor,
            split_ms: self.timing.split_ms,
            clock_mhz: self.gpu.clock.latest.zip(self.gpu.clock.highest),
        };
        let light = self.light_marker();
        let split = self.split_overlay();
        let notice = self.captures.notice.as_ref();
        let params = &mut self.params;
        let panel_state = &mut self.ui.panel;
        let open_dialog = &mut self.ui.open_dialog;
        let full = self.ui.egui_ctx.run_ui(raw, |ui| {
            if params.panel_visible {
                let frame = egui::Frame::side_top_panel(ui.style()).inner_margin(8.0);
                // At most two fifths of the window, never under the width its rows need.
                let (width, range) = panel::panel_widths(ui.available_width());
                egui::Panel::left("panel").default_size(width).size_range(range).frame(frame).show(
                    ui,
                    |ui| {
                        actions = panel::show(ui, params, panel_state, &info);
                    },
                );
            }
            central = ui.available_rect_before_wrap();
            overlay::show(
                ui.ctx(),
                central,
                params.hud_visible.then_some(&info),
                light,
                split.as_ref(),
                notice,
            );
            // Last: the dialog is drawn over the panel and the image.
            match open_dialog.show(ui.ctx()) {
                Some((Purpose::Model, path)) => actions.push(PanelAction::LoadFile(path)),
                Some((Purpose::Preset, path)) => actions.push(PanelAction::LoadPreset(path)),
                Some((Purpose::Environment, path)) => {
                    params.use_environment_file(path);
                }
                None => {}
            }
        });
        self.set_image_area(central, full.pixels_per_point);
        (full, actions)
    }

    /// This frame's egui input, with the keys that are the tool's taken out of it and acted
    /// on as shortcuts.
    fn take_input(&mut self) -> egui::RawInput {
        let mut raw = self.ui.egui_state.take_egui_input(&self.window);
        // The keys are the tool's unless egui wants the keyboard (as it did at the end of the
        // last frame, which is how it will see them) or the Open dialog shows (its keys,
        // Escape, Enter and arrows, are its own whether or not a text field has the focus;
        // Ctrl+O among the keys opens it for those after).
        let egui_wants_keys = self.ui.egui_ctx.egui_wants_keyboard_input();
        // Keys that move the focus, or that the Open dialog acts on before its fields run, cut
        // the frame's input (`input::focus_cut`).
        let (dialog_open, now) = (self.ui.open_dialog.is_open(), self.input.now());
        let cut_at = |e: &egui::Event| input::focus_cut(e, dialog_open, egui_wants_keys);
        let (keys, held) = self.input.take_pass(&mut raw, now, cut_at);
        input::trace_pass(&raw.events, dialog_open, egui_wants_keys);
        if !held.is_empty() {
            self.ui.egui_state.egui_input_mut().events = held;
            self.window.request_redraw();
        }
        for key in keys {
            if !egui_wants_keys && !self.ui.open_dialog.is_open() {
                self.shortcut(key);
            }
        }
        raw
    }

    /// The image area in pixels: what egui left beside the panel (`central`, in points),
    /// within the window.
    fn set_image_area(&mut self, central: egui::Rect, ppp: f32) {
        let size = self.window.inner_size();
        let x0 = (central.left() * ppp).round().clamp(0.0, size.width as f32) as i32;
        let y0 = (central.top() * ppp).round().clamp(0.0, size.height as f32) as i32;
        let x1 = (central.right() * ppp).round().clamp(0.0, size.width as f32) as i32;
        let y1 = (central.bottom() * ppp).round().clamp(0.0, size.height as f32) as i32;
        self.ui.image_area = PixelRect {
            x: x0,
            y: y0,
            width: (x1 - x0).max(0) as u32,
            height: (y1 - y0).max(0) as u32,
        };
    }

    /// The vendor path as the panel shows it.
    fn vendor_info(&self) -> VendorInfo {
        let tracer = &self.gpu.tracer;
        let support = &self.gpu.trace_ctx.info.vendor;
        VendorInfo {
            unavailable: tracer.vendor_kernel().err().map(str::to_string),
            kernel: tracer.vendor_kernel().ok(),
            kernels: VendorKernel::ALL.into_iter().filter(|k| k.supported(support)).collect(),
            stats: tracer.vendor_stats(),
        }
    }

    /// Where the light appears over the image shown, in points (None when no image).
    fn light_marker(&self) -> Option<egui::Pos2> {
        let [w, h] = self.gpu.tracer.resolution()?;
        self.session.model.as_ref()?;
        let shown = fit_rect([w, h], self.ui.image_area);
        let (sx, sy) =
            self.params.camera.basis(w, h).project(self.params.light_position(), w, h)?;
        let ppp = self.window.scale_factor() as f32;
        let x = shown.x as f32 + sx / w as f32 * shown.width as f32;
        let y = shown.y as f32 + sy / h as f32 * shown.height as f32;
        Some(egui::pos2(x / ppp, y / ppp))
    }

    /// Do what the panel asked beyond changing parameters.
    pub(super) fn act(&mut self, action: PanelAction) -> anyhow::Result<()> {
        match action {
            PanelAction::LoadModel(source) => {
                self.session.start_load(source, &mut self.params, &mut self.ui.panel)
            }
            PanelAction::CancelLoad => self.cancel_load(),
            PanelAction::LoadFile(path) => self.load_file(path),
            PanelAction::Open(purpose) => self.open(purpose),
            PanelAction::ScreenshotTrace => self.captures.want_trace_shot = true,
            PanelAction::ScreenshotWindow => self.captures.want_window_shot = true,
            PanelAction::ScreenshotExr => self.captures.want_exr_shot = true,
            PanelAction::SavePreset { path, overwrite } => self.save_preset(&path, overwrite),
            PanelAction::LoadPreset(path) => self.load_preset(&path),
            PanelAction::Benchmark(frames) => self.timing.benchmarks.want(frames),
            PanelAction::CancelBenchmark => self.timing.benchmarks.stop(
                "the benchmark was cancelled",
                &mut self.params,
                &mut self.ui.panel.benchmark.outcome,
            )?,
            PanelAction::Record => {
                self.ui.panel.perf.status =
                    self.timing.recorder.start(&screenshot::screenshot_dir())
            }
            PanelAction::StopRecording => self.ui.panel.perf.status = self.timing.recorder.stop(),
            PanelAction::ResetSettings => self.reset_settings(),
            PanelAction::VendorKernel(kernel) => {
                if let Err(e) = self.gpu.tracer.set_vendor_kernel(kernel) {
                    self.ui.panel.render.status = Some(Status::error(e.to_string()));
                }
            }
        }
        Ok(())
    }
}
