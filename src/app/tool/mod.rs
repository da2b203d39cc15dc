//! The tool: a window, the GPU side (presenter and the shared compute tracer), egui, and
//! the three parts of the tool's state: [`Input`], the [`Session`] (model, loader, what
//! the tracer holds) and the [`ScriptedRun`]. One `redraw` per displayed frame.
//!
//! - `input`: mouse and keys between events; `script`: `--frames` runs and exiting;
//! - `session`: the model, its loader and what the tracer holds; `auto_layout`: the BVH
//!   layout picked by timing each;
//! - `progressive`: long frames traced in bands over several display frames;
//! - `devices`: the presenting and tracing devices ([`Gpu`]); `events`: window events;
//! - `ui`: the UI pass ([`UiPass`]: egui, the panel, the Open dialog);
//! - `frame`: what each frame traces and shows ([`Frames`]: pictures, bands);
//! - `captures`: screenshots, presets and the files written at exit ([`Captures`]);
//! - `timing`: frame times, benchmark runs and the frame-time log ([`Timing`]);
//! - `split`: the split line under the mouse.

use std::sync::Arc;
use std::time::Instant;

use raw_window_handle::{HasDisplayHandle, HasWindowHandle};
use winit::dpi::LogicalSize;
use winit::event_loop::ActiveEventLoop;
use winit::window::Window;

pub(crate) mod auto_layout;
mod captures;
pub(crate) mod devices;
mod events;
mod frame;
pub(crate) mod input;
pub(crate) mod progressive;
mod saving;
pub(crate) mod script;
pub(crate) mod session;
mod split;
mod timing;
mod ui;
mod ui_state;

use crate::app::measure::benchmark::{Runs, Workload};
use crate::app::measure::frame_log::{watched, FrameRow, Recorder};
use crate::app::measure::gpu_clock::ClockWatch;
use crate::app::options::ViewOptions;
use crate::app::options::DEFAULT_WINDOW;
use crate::app::panel::{PanelState, Status};
use crate::app::state::{fit_rect, Params, Resolution, ViewMode};
use crate::app::tool::captures::Captures;
use crate::app::tool::devices::headless_error;
use crate::app::tool::devices::Gpu;
use crate::app::tool::frame::{Frames, Prepared, Shown};
use crate::app::tool::input::Input;
use crate::app::tool::progressive::adapt_pixels;
use crate::app::tool::script::ScriptedRun;
use crate::app::tool::session::Session;
use crate::app::tool::timing::Timing;
use crate::app::tool::ui_state::UiPass;
use crate::app::user_files::open_dialog::OpenDialog;
use crate::app::user_files::settings::Store;
use crate::app::user_files::shader_watch::ShaderWatch;
use crate::gpu::present::{BandTag, FrameOutcome, FrameRequest, PixelRect, Show, FRAMES_IN_FLIGHT};
use crate::gpu::{ComputeTracer, FrameTrace, GpuError, PartTimes};
use crate::render_settings::{Accel, RenderSettings};
use crate::scene::spec::SceneSpec;

/// The tool: the window and its GPU side, the parameters and session, and the parts each
/// frame goes through (the UI pass, the frame and its bands, captures, timing).
pub(crate) struct Tool {
    /// Declared first: dropped before the window (see [`Tool::shut_down`]).
    gpu: Gpu,
    /// egui, the panel and the Open dialog (`ui.rs`).
    ui: UiPass,
    pub(crate) window: Arc<Window>,
    params: Params,
    /// The resolution `M` returns to.
    previous_resolution: Resolution,
    session: Session,
    input: Input,
    script: ScriptedRun,
    /// The frame and its bands (`frame.rs`).
    frame: Frames,
    /// Screenshots asked for and the notice of the last (`captures.rs`).
    captures: Captures,
    /// Frame times, the benchmark run and the frame-time log (`timing.rs`).
    timing: Timing,
    /// Where the remembered settings are kept (nowhere in scripted runs).
    store: Store,
    shader_watch: Option<ShaderWatch>,
}

impl Tool {
    /// Open the window and the GPU side, and start loading the model.
    pub(crate) fn new(event_loop: &ActiveEventLoop, options: &ViewOptions) -> anyhow::Result<Self> {
        let store = Store::new(options.persist());
        let remembered = store.load();
        let recorder =
            Recorder::from_flag(options.stats_csv.as_deref()).map_err(anyhow::Error::msg)?;
        let [w, h] = options.window.or(remembered.window).unwrap_or(DEFAULT_WINDOW);
        let attributes = Window::default_attributes()
            .with_title(format!("meshtracer — {}", options.spec.model.label()))
            .with_inner_size(LogicalSize::new(w, h));
        let window = Arc::new(
            event_loop
                .create_window(attributes)
                .map_err(|e| headless_error("cannot open a window", e))?,
        );
        let display =
            window.display_handle().map_err(|e| headless_error("no display handle", e))?.as_raw();
        let window_handle =
            window.window_handle().map_err(|e| headless_error("no window handle", e))?.as_raw();
        let mut params = Params::new(&options.spec, options.scripted());
        params.hud_visible = options.hud;
        params.split = options.split;
        params.bvh_auto = options.auto_layout;
        let physical = window.inner_size();
        // SAFETY: the handles belong to `window`, which outlives the surface: the presenter
        // owning it is dropped first (see `shut_down`).
        let devices = unsafe {
            devices::open(
                options,
                display,
                window_handle,
                [physical.width, physical.height],
                params.vsync,
            )
        }?;
        let devices::WindowDevices { presenter, ctx, trace_ctx } = devices;
        let tracer = ComputeTracer::new(&trace_ctx, FRAMES_IN_FLIGHT as u32)?;
        // While the model loads: lavapipe's compiler takes seconds over a kernel.
        tracer.prepare_kernels_in_background();
        let clock = ClockWatch::new(&trace_ctx);

        let egui_ctx = egui::Context::default();
        egui_ctx.set_theme(egui::ThemePreference::Dark);
        let max_texture = ctx.info.max_image_dimension_2d as usize;
        let egui_state = egui_winit::State::new(
            egui_ctx.clone(),
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            None,
            Some(max_texture),
        );

        let mut session = Session::default();
        let mut panel = PanelState::default();
        crate::app::panel::remembered::restore(&remembered, &mut panel, &egui_ctx);
        if let Some(path) = &options.preset {
            panel.presets.used(path);
        }
        session.loader.set_device(trace_ctx.info.fit(options.bvh_builder));
        session.start_load(options.spec.model.clone(), &mut params, &mut panel);
        let previous_resolution = if params.resolution == Resolution::MatchWindow {
            Resolution::Square(512)
        } else {
            params.resolution
        };
        Ok(Self {
            gpu: Gpu { presenter, tracer, clock, ctx, trace_ctx },
            ui: UiPass {
                egui_state,
                egui_ctx,
                panel,
                open_dialog: OpenDialog::default(),
                image_area: PixelRect::default(),
            },
            window,
            previous_resolution,
            params,
            session,
            input: Input::default(),
            script: ScriptedRun::new(
                options.frames,
                options.screenshot.clone(),
                options.screenshot_ui.clone(),
            ),
            frame: Frames::default(),
            captures: Captures::default(),
            timing: Timing::new(
                Runs::new(options.benchmark, options.benchmark_json.clone()),
                recorder,
            ),
            store,
            shader_watch: options.watch_shaders.clone().map(ShaderWatch::new),
        })
    }

    /// The window can be drawn into (not minimized, not hidden).
    pub(crate) fn can_draw(&self) -> bool {
        let size = self.window.inner_size();
        // X11 reports no Occluded event when a window is iconified; the window manager's
        // hidden state (is_minimized) says it there.
        size.width > 0
            && size.height > 0
            && !self.input.occluded
            && self.window.is_minimized() != Some(true)
    }

    /// Free everything in order; returns the validation messages seen.
    pub(crate) fn shut_down(mut self) -> Vec<String> {
        self.remember();
        let separate = self.gpu.traces_elsewhere();
        let Tool {
            gpu: Gpu { presenter, tracer, clock, ctx, trace_ctx },
            ui: UiPass { egui_state, .. },
            window,
            ..
        } = self;
        let _ = ctx.wait_idle();
        let _ = trace_ctx.wait_idle();
        drop(presenter);
        drop(tracer);
        drop(clock);
        drop(egui_state);
        drop(window);
        let mut messages = ctx.validation_messages();
        if separate {
            messages.extend(trace_ctx.validation_messages());
        }
        messages
    }

    fn area(&self) -> [u32; 2] {
        [self.ui.image_area.width, self.ui.image_area.height]
    }

    /// The spec of the traced image (its resolution as traced): what presets save.
    fn scene_spec(&self) -> SceneSpec {
        let mut settings = self.params.settings_for(self.area());
        if let Some([width, height]) = self.gpu.tracer.resolution() {
            (settings.width, settings.height) = (width, height);
        }
        let model = self.session.model.as_ref().map_or_else(Default::default, |m| m.source.clone());
        self.params.scene_spec(model, settings)
    }

    /// Decide what this display frame traces and shows. A frame that fits one submission
    /// is traced whole in the frame's command buffer; a longer one (brute force on a big
    /// mesh) is traced in row bands, one per display frame, so the window keeps drawing
    /// and answering input while the image fills in, and any change starts it afresh. A
    /// tracer on another device than the window's traces here and its picture is read back.
    fn prepare_image(&mut self, params: Option<FrameTrace>) -> anyhow::Result<Prepared> {
        let Some(params) = params.filter(|_| self.gpu.tracer.is_ready()) else {
            self.frame.progressive = None;
            return Ok(Prepared::NOTHING);
        };
        self.frame.traced = true;
        if let Err(e) = self.gpu.tracer.prepare(&params) {
            // A preset or the A key asked for the vendor's ray tracing where the device has
            // none: say why and trace with our BVH from the next frame on.
            if let GpuError::VendorUnavailable(why) = &e {
                self.ui.panel.render.status =
                    Some(Status::error(format!("vendor ray tracing: {why}; tracing with the BVH")));
                self.ui.panel.render.status_accel = Some(Accel::Bvh);
                if self.params.scene.settings.accel == Accel::Vendor {
                    self.params.scene.settings.accel = Accel::Bvh;
                }
                if self.params.split.b.accel == Some(Accel::Vendor) {
                    self.params.split.b.accel = Some(Accel::Bvh);
                }
                return Ok(Prepared::NOTHING);
            }
            return Err(e.into());
        }
        self.frame.trace(&mut self.gpu, params, self.params.view)
    }

    /// One displayed frame: what finished in the background, the UI and what it changed,
    /// the traced and drawn frame, its times, benchmarks, screenshots. False: exit now.
    fn redraw(&mut self) -> anyhow::Result<bool> {
        let now = Instant::now();
        self.poll_background(now)?;
        if !self.can_draw() && !self.script.is_final_frame(false) {
            // Minimized or hidden: nothing is traced or drawn (loads still finish).
            self.take_finished_load()?;
            self.timing.last_frame = None;
            return Ok(true);
        }
        let (primitives, pixels_per_point) = self.update_ui()?;
        let drawn = self.draw_frame(now, &primitives, pixels_per_point)?;
        let (t, frame_ms) = self.record_frame(now, &drawn);
        self.finish_benchmarks(t, &drawn, frame_ms)?;

        let presented = drawn.outcome.presented;
        self.take_screenshots(presented, drawn.outcome.window_image.as_ref(), drawn.final_frame);
        if drawn.final_frame && self.script.finish_attempt(presented, !self.can_draw()) {
            self.write_exit_files(drawn.outcome.window_image)?;
            self.timing.benchmarks.check_exit()?;
            return Ok(false);
        }
        Ok(true)
    }

    /// Install a load that finished, if any. Called after the UI pass has acted on the
    /// keys and clicks that arrived during the last frame: an Escape or a Cancel pressed
    /// while the bar still showed the load stops it even when it finished during that frame
    /// (issue #43: a slow frame let the load in first).
    fn take_finished_load(&mut self) -> anyhow::Result<()> {
        if let Some(title) = self.session.poll_loader(&mut self.gpu.tracer, &mut self.ui.panel)? {
            self.window.set_title(&title);
        }
        Ok(())
    }

    /// The light's motion since the last frame and a changed shader.
    fn poll_background(&mut self, now: Instant) -> anyhow::Result<()> {
        if let Some(last) = self.timing.last_frame {
            // Capped so a stall (a model upload) does not make the light jump.
            self.params.advance_light(now.duration_since(last).as_secs_f32().min(1.0));
        }
        if self
            .shader_watch
            .as_mut()
            .is_some_and(|w| w.poll(&mut self.gpu.tracer, &mut self.ui.panel.render.shader_status))
        {
            // What was accumulated so far came from the old shader.
            self.session.accumulation = Default::default();
            self.frame.progressive = None;
        }
        Ok(())
    }

    /// Run the UI, carry out what it asked for and apply the parameters to the session
    /// (before the frame is traced, so it traces them). Returns the UI's shapes to draw.
    fn update_ui(&mut self) -> anyhow::Result<(Vec<egui::ClippedPrimitive>, f32)> {
        let (mut full, actions) = self.run_ui();
        self.gpu.presenter.update_textures(&mut full.textures_delta)?;
        for action in actions {
            self.act(action)?;
        }
        self.take_finished_load()?;
        self.ui.egui_state.handle_platform_output(&self.window, full.platform_output);
        let area = self.area();
        if self.timing.benchmarks.progress().is_none() {
            self.session.pick_layout(&mut self.params, area, self.gpu.tracer.kernels_ready());
        }
        self.session.apply(&mut self.params, area, &mut self.gpu.tracer, &mut self.ui.panel)?;
        self.gpu.presenter.set_vsync(self.params.vsync);
        self.timing.benchmarks.before_frame(
            &mut self.params,
            area,
            &mut self.ui.panel.benchmark.outcome,
        )?;
        let primitives = self.ui.egui_ctx.tessellate(full.shapes, full.pixels_per_point);
        Ok((primitives, full.pixels_per_point))
    }

    /// Trace (all of the frame or a band) and draw it with the UI, then keep what the
    /// next frames need: the picture of another view's last band, the band size.
    fn draw_frame(
        &mut self,
        now: Instant,
        primitives: &[egui::ClippedPrimitive],
        pixels_per_point: f32,
    ) -> anyhow::Result<DrawnFrame> {
        let area = self.area();
        // A frame being traced in bands keeps its parameters (accumulation waits for it).
        let params =
            self.session.frame_params(&self.params, area, self.frame.progressive.is_some());
        let prepared = self.prepare_image(params)?;
        // What this frame traces (a long frame keeps the settings it began with).
        let frame_settings = prepared
            .trace
            .as_ref()
            .map(|(p, _)| p.params.settings)
            .or(params.map(|p| p.params.settings));
        let final_frame = self.script.is_final_frame(prepared.completes);
        let capture =
            self.captures.want_window_shot || (final_frame && self.script.screenshot_ui.is_some());
        let image_rect =
            fit_rect(self.gpu.tracer.resolution().unwrap_or_default(), self.ui.image_area);
        let recorded_band = prepared.trace.as_ref().is_some_and(|(p, band)| {
            band.pixels() != p.params.settings.width as u64 * p.params.settings.height as u64
        });
        let pixels = prepared.trace.as_ref().map_or(0, |(_, band)| band.pixels());
        let tag = BandTag { frame: self.frame.number, last: prepared.completes, pixels };
        if let Some(s) = frame_settings {
            self.frame.note_settings(tag.frame, s);
        }
        let show = match (prepared.show, &self.frame.picture) {
            (Shown::Output, _) => Show::Output,
            (Shown::Picture, Some(h)) => {
                Show::Pixels { rgba: &h.rgba, width: h.width, height: h.height }
            }
            _ => Show::Nothing,
        };
        let request = FrameRequest {
            trace: prepared.trace.clone(),
            tag,
            show,
            image_rect,
            ui: primitives,
            pixels_per_point,
            capture_window: capture,
        };
        // A tracer on another device has traced already; its buffers are not the window's.
        let recording = Some(&self.gpu.tracer).filter(|_| !self.gpu.traces_elsewhere());
        let outcome = self.gpu.presenter.draw(recording, &request)?;
        if recorded_band && prepared.completes && self.params.view != ViewMode::Color {
            // The last band of a long frame of another view: its picture replaces the last.
            let image = self.gpu.tracer.read_image()?;
            self.frame.set_picture(&image, self.params.view);
        }
        // Sized from the timed band's own pixels: with frames in flight it may be an
        // earlier band than the last one recorded, of another size.
        if let (true, Some(ms), Some(timed)) = (recorded_band, outcome.gpu_ms, outcome.tag) {
            if timed.pixels > 0 {
                self.frame.band_pixels = adapt_pixels(timed.pixels, ms, u64::MAX);
            }
        }
        self.gpu.clock.poll(now);
        Ok(DrawnFrame { prepared, outcome, frame_settings, final_frame, tag })
    }

    /// A traced frame's GPU time (total and parts) and the settings it was traced with: its
    /// bands' times added up, from a trace done before this frame or recorded into an
    /// earlier one and timed now.
    fn frame_gpu_time(
        &mut self,
        drawn: &DrawnFrame,
    ) -> Option<((f64, PartTimes), Option<RenderSettings>)> {
        let (prepared, outcome, tag) = (&drawn.prepared, &drawn.outcome, drawn.tag);
        let mut frame_time = None;
        if let Some(ms) = prepared.gpu_ms {
            let parts = prepared.part_ms.map_or([None; 2], |p| p.map(Some));
            frame_time = self.frame.band_times.add(tag, ms, parts).map(|t| (t, tag.frame));
        }
        if let (Some(ms), Some(band)) = (outcome.gpu_ms, outcome.tag) {
            frame_time = self
                .frame
                .band_times
                .add(band, ms, outcome.part_ms)
                .map(|t| (t, band.frame))
                .or(frame_time);
        }
        frame_time.map(|(t, number)| (t, self.frame.settings_of(number)))
    }

    /// Count the frame and note its times: GPU time in the split, the stats and the
    /// automatic layout; display time and the frame log when presented. Returns the
    /// seconds since start and the frame's GPU milliseconds.
    fn record_frame(&mut self, now: Instant, drawn: &DrawnFrame) -> (f64, Option<f64>) {
        let frame_time = self.frame_gpu_time(drawn);
        let traced = drawn.prepared.completes;
        if traced {
            self.frame.traced_frames += 1;
        }
        self.note_split_times(frame_time.map(|((_, parts), _)| parts));
        let t = now.duration_since(self.timing.start).as_secs_f64();
        // Before the frame is logged: its row carries the latest GPU time.
        if let Some(((ms, _), timed_settings)) = frame_time {
            self.timing.stats.push_gpu(t, ms, timed_settings);
            if let Some(settings) = timed_settings {
                self.session.auto_layout.frame_timed(ms, settings);
            }
        }
        if drawn.outcome.presented {
            if let Some(last) = self.timing.last_frame {
                self.timing.stats.push_frame(t, now.duration_since(last).as_secs_f64() * 1e3);
            }
            self.timing.last_frame = Some(now);
            if traced {
                self.script.frames += 1;
                self.log_frame(t, drawn.frame_settings.unwrap_or_default());
            }
        } else if !self.can_draw() {
            self.timing.last_frame = None;
        }
        (t, frame_time.map(|((ms, _), _)| ms))
    }

    /// A presented traced frame's row in the frame-time log (when one is kept).
    fn log_frame(&mut self, t: f64, settings: RenderSettings) {
        let (stats, params, session, clock) =
            (&self.timing.stats, &self.params, &self.session, self.gpu.clock.latest);
        let row = || {
            (
                FrameRow::new(t, stats, &settings, session.counts().0, clock),
                watched(params, &session.model_label()),
            )
        };
        if let Some(status) = self.timing.recorder.frame(row) {
            self.ui.panel.perf.status = Some(status);
        }
    }

    /// Give a running benchmark the frame; when the last run is done, write its outcome
    /// and exit if it was asked for on the command line.
    fn finish_benchmarks(
        &mut self,
        t: f64,
        drawn: &DrawnFrame,
        frame_ms: Option<f64>,
    ) -> anyhow::Result<()> {
        self.timing.benchmarks.after_frame(
            t,
            drawn.outcome.presented && drawn.prepared.completes,
            frame_ms,
            self.gpu.clock.latest,
        );
        let (session, ctx) = (&self.session, &self.gpu.trace_ctx);
        let workload = |p: &Params| Workload {
            model: session.model_label(),
            models: p.scene.models,
            triangles: session.counts().0,
        };
        if self.timing.benchmarks.finish(
            &mut self.params,
            &mut self.ui.panel.benchmark.outcome,
            workload,
            || crate::bench::environment(ctx),
        )? {
            self.script.request_exit();
        }
        Ok(())
    }
}

/// What `draw_frame` traced and presented, for the steps after it.
struct DrawnFrame {
    prepared: Prepared,
    outcome: FrameOutcome,
    /// The settings this frame traces with (a long frame keeps those it began with).
    frame_settings: Option<RenderSettings>,
    /// The scripted run's last frame.
    final_frame: bool,
    /// The frame (and whether this is its last band) the trace belongs to.
    tag: BandTag,
}
