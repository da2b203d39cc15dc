//! The tool: a window, the GPU side (presenter and the shared compute tracer), egui, and
//! the three parts of the tool's state: [`Input`], the [`Session`] (model, loader, what
//! the tracer holds) and the [`ScriptedRun`]. One `redraw` per displayed frame.
//!
//! - `input`: mouse and keys between events; `script`: `--frames` runs and exiting;
//! - `session`: the model, its loader and what the tracer holds;
//! - `progressive`: long frames traced in bands over several display frames;
//! - `devices`: the presenting and tracing devices; `files`: presets, screenshots and the
//!   files written at exit; `split`: the split line under the mouse.

use std::sync::Arc;
use std::time::Instant;

use raw_window_handle::{HasDisplayHandle, HasWindowHandle};
use winit::dpi::LogicalSize;
use winit::event::{ElementState, KeyEvent, MouseButton, WindowEvent};
use winit::event_loop::ActiveEventLoop;
use winit::keyboard::PhysicalKey;
use winit::window::Window;

mod devices;
mod files;
pub(crate) mod input;
pub(crate) mod progressive;
pub(crate) mod script;
pub(crate) mod session;
mod split;

use crate::app::views::aov;
use crate::app::measure::benchmark::{Runs, Workload};
use crate::app::views::cost::heat_map;
use crate::app::measure::frame_log::{watched, FrameRow, Recorder};
use crate::app::measure::frame_stats::FrameStats;
use crate::app::measure::gpu_clock::ClockWatch;
use crate::app::tool::input::{Drag, Input, KeyPress};
use crate::app::panel::{self, PanelAction, PanelInfo, PanelState, Status, VendorInfo};
use crate::app::files::screenshot::{self, Kind};
use crate::app::tool::script::ScriptedRun;
use crate::app::files::shader_watch::ShaderWatch;
use crate::app::views::overlay::{self, Notice};
use crate::app::tool::progressive::{adapt_groups, BandTimes, Progressive};
use crate::app::tool::session::Session;
use crate::app::files::settings::{self, Store};
use crate::app::state::{fit_rect, KeyAction, Params, Resolution, ViewMode};
use crate::app::files::open_dialog::{OpenDialog, Purpose};
use crate::app::options::DEFAULT_WINDOW;
use crate::app::{headless_error, ViewOptions};
use crate::gpu::present::{BandTag, FrameRequest, PixelRect, Presenter, Show, FRAMES_IN_FLIGHT};
use crate::gpu::trace_pass::GROUP;
use crate::gpu::vendor::VendorKernel;
use crate::gpu::{Band, ComputeTracer, FrameTrace, GpuContext, GpuError, PartTimes};
use crate::scene::spec::SceneSpec;
use crate::tracer::budget;
use crate::tracer::frame::{Accel, RenderSettings};

/// A picture made or read back on the CPU: a view other than colour (cost heat map,
/// depth, ...), or the colour traced on a device other than the window's. Its pixels (for
/// F12) and its legend.
struct Picture {
    width: u32,
    height: u32,
    rgba: Vec<u8>,
    /// (scale top, max, mean) of a heat map, for the panel's legend.
    stats: Option<(f32, f32, f32)>,
    /// What the colours mean, for the other views.
    note: Option<String>,
}

/// What the image area shows, decided before the frame is drawn.
#[derive(Clone, Copy)]
enum Shown {
    Nothing,
    /// The tracer's colour output.
    Output,
    /// The pixels in `Tool::picture`.
    Picture,
}

/// What one display frame traces and shows.
struct Prepared {
    /// Pixels to trace in the frame's command buffer.
    trace: Option<(FrameTrace, Band)>,
    show: Shown,
    /// GPU time of a trace done before the frame (the cost view's synchronous trace).
    gpu_ms: Option<f64>,
    /// That trace's time per half of a split frame.
    part_ms: Option<[f64; 2]>,
    /// This display frame finishes a traced frame (the last or only band).
    completes: bool,
}

/// The GPU side: declared in drop order (before the contexts, the window's surface last).
struct Gpu {
    presenter: Presenter,
    tracer: ComputeTracer,
    /// The tracing device's shader clock.
    clock: ClockWatch,
    /// The device that presents.
    ctx: Arc<GpuContext>,
    /// The device that traces: `ctx` itself, or another one (see `devices.rs`).
    trace_ctx: Arc<GpuContext>,
}

impl Gpu {
    /// The tracer is on a device other than the window's: each frame is traced and read
    /// back before it is drawn, instead of recorded into the frame's commands.
    fn traces_elsewhere(&self) -> bool {
        !Arc::ptr_eq(&self.ctx, &self.trace_ctx)
    }
}

pub struct Tool {
    gpu: Gpu,
    egui_state: egui_winit::State,
    egui_ctx: egui::Context,
    pub window: Arc<Window>,
    params: Params,
    /// The resolution `M` returns to.
    previous_resolution: Resolution,
    session: Session,
    input: Input,
    script: ScriptedRun,
    stats: FrameStats,
    panel: PanelState,
    picture: Option<Picture>,
    /// The long frame being traced in bands, if any.
    progressive: Option<Progressive>,
    /// A short notice over the image (a screenshot written).
    notice: Option<Notice>,
    /// Work groups per band of a long frame (adapted to the GPU's speed).
    band_groups: u32,
    /// Frames traced to their last pixel so far (the number a band's time comes back with).
    traced_frames: u64,
    /// The GPU time of the frame whose bands are being timed.
    band_times: BandTimes,
    /// A frame has been traced: F12 has something to save.
    traced: bool,
    start: Instant,
    last_frame: Option<Instant>,
    image_area: PixelRect,
    want_trace_shot: bool,
    want_window_shot: bool,
    benchmarks: Runs,
    /// The frame-time log (`--stats-csv`, Record).
    recorder: Recorder,
    /// Where the remembered settings are kept (nowhere in scripted runs).
    store: Store,
    shader_watch: Option<ShaderWatch>,
    /// The latest GPU time of each half of the split view (left A, right B).
    split_ms: PartTimes,
    /// The Open dialog (Ctrl+O, the panel's Open buttons).
    open_dialog: OpenDialog,
}

impl Tool {
    /// Open the window and the GPU side, and start loading the model.
    pub fn new(event_loop: &ActiveEventLoop, options: &ViewOptions) -> anyhow::Result<Self> {
        let store = Store::new(options.persist());
        let remembered = store.load();
        let recorder = Recorder::from_flag(options.stats_csv.as_deref()).map_err(anyhow::Error::msg)?;
        let [w, h] = options.window.or(remembered.window).unwrap_or(DEFAULT_WINDOW);
        let attributes = Window::default_attributes().with_title(format!("meshtracer — {}", options.spec.model.label())).with_inner_size(LogicalSize::new(w, h));
        let window = Arc::new(event_loop.create_window(attributes).map_err(|e| headless_error("cannot open a window", e))?);
        let display = window.display_handle().map_err(|e| headless_error("no display handle", e))?.as_raw();
        let window_handle = window.window_handle().map_err(|e| headless_error("no window handle", e))?.as_raw();
        let mut params = Params::new(&options.spec, options.scripted());
        params.hud_visible = options.hud;
        params.split = options.split;
        let physical = window.inner_size();
        // SAFETY: the handles belong to `window`, which outlives the surface: the presenter
        // owning it is dropped first (see `shut_down`).
        let devices = unsafe { devices::open(options, display, window_handle, [physical.width, physical.height], params.vsync) }?;
        let devices::WindowDevices { presenter, ctx, trace_ctx } = devices;
        let tracer = ComputeTracer::new(&trace_ctx, FRAMES_IN_FLIGHT as u32)?;
        let clock = ClockWatch::new(&trace_ctx);

        let egui_ctx = egui::Context::default();
        egui_ctx.set_theme(egui::ThemePreference::Dark);
        let max_texture = ctx.info.max_image_dimension_2d as usize;
        let egui_state = egui_winit::State::new(egui_ctx.clone(), egui::ViewportId::ROOT, &window, Some(window.scale_factor() as f32), None, Some(max_texture));

        let mut session = Session::default();
        let mut panel = PanelState::default();
        settings::restore(&remembered, &mut panel, &egui_ctx);
        if let Some(path) = &options.preset {
            panel.presets.used(path);
        }
        session.start_load(options.spec.model.clone(), &params, &mut panel);
        let previous_resolution = if params.resolution == Resolution::MatchWindow { Resolution::Square(512) } else { params.resolution };
        Ok(Self {
            gpu: Gpu { presenter, tracer, clock, ctx, trace_ctx },
            egui_state,
            egui_ctx,
            window,
            previous_resolution,
            params,
            session,
            input: Input::default(),
            script: ScriptedRun::new(options.frames, options.screenshot.clone(), options.screenshot_ui.clone()),
            stats: FrameStats::default(),
            panel,
            picture: None,
            progressive: None,
            band_groups: 1,
            traced_frames: 0,
            band_times: BandTimes::default(),
            notice: None,
            traced: false,
            start: Instant::now(),
            last_frame: None,
            image_area: PixelRect::default(),
            want_trace_shot: false,
            want_window_shot: false,
            benchmarks: Runs::new(options.benchmark, options.benchmark_json.clone()),
            recorder,
            store,
            shader_watch: options.watch_shaders.clone().map(ShaderWatch::new),
            split_ms: [None; 2],
            open_dialog: OpenDialog::default(),
        })
    }

    /// The window can be drawn into (not minimized, not hidden).
    pub fn can_draw(&self) -> bool {
        let size = self.window.inner_size();
        // X11 reports no Occluded event when a window is iconified; the window manager's
        // hidden state (is_minimized) says it there.
        size.width > 0 && size.height > 0 && !self.input.occluded && self.window.is_minimized() != Some(true)
    }

    /// Free everything in order; returns the validation messages seen.
    pub fn shut_down(mut self) -> Vec<String> {
        self.remember();
        let separate = self.gpu.traces_elsewhere();
        let Tool { gpu: Gpu { presenter, tracer, clock, ctx, trace_ctx }, egui_state, window, .. } = self;
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

    /// A raw mouse button from winit's device events (see [`Input::raw_button`]).
    pub fn raw_button(&mut self, button: u32, state: winit::event::ElementState) {
        self.input.raw_button(button, state);
    }

    /// Handle one window event; Ok(false) quits.
    pub fn window_event(&mut self, event: &WindowEvent) -> anyhow::Result<bool> {
        // Its `consumed` is not used: for a key it comes from the focus before the clicks
        // that egui has not run yet (keys wait for the frame, `Input::frame_keys`).
        let _ = self.egui_state.on_window_event(&self.window, event);
        match event {
            WindowEvent::CloseRequested => self.script.request_exit(),
            WindowEvent::Resized(size) => self.gpu.presenter.resize(size.width, size.height),
            WindowEvent::Occluded(occluded) => self.input.occluded = *occluded,
            WindowEvent::ModifiersChanged(m) => self.input.modifiers = m.state(),
            WindowEvent::RedrawRequested => return self.redraw(),
            // Synthetic presses (keys held while the window gains focus) are not the user's.
            // A press waits for the frame, which decides whether it is a shortcut (`input.rs`).
            WindowEvent::KeyboardInput { event: KeyEvent { physical_key: PhysicalKey::Code(code), state: ElementState::Pressed, repeat, .. }, is_synthetic: false, .. } => {
                self.input.key_pressed(*code, *repeat, self.egui_state.egui_input().events.len());
            }
            WindowEvent::MouseInput { state, button: MouseButton::Left, .. } => {
                // A press on the split line moves the line, not the camera.
                let kind = if self.on_split_line() { Drag::Split } else { Drag::Orbit };
                self.input.drag_button(*state, kind, self.camera_area());
            }
            WindowEvent::MouseInput { state, button: MouseButton::Middle, .. } => self.input.drag_button(*state, Drag::Pan, self.camera_area()),
            WindowEvent::CursorMoved { position, .. } => match self.input.cursor_moved(*position) {
                Some((Drag::Orbit, dx, dy)) => self.params.drag_camera(dx, dy),
                Some((Drag::Split, _, _)) => self.move_split(),
                Some((Drag::Pan, dx, dy)) => {
                    // Pixels of the image as shown: the scene follows the cursor.
                    let shown = fit_rect(self.gpu.tracer.resolution().unwrap_or([1, 1]), self.image_area);
                    self.params.pan_camera(dx, dy, shown.height as f32);
                }
                None => {}
            },
            WindowEvent::CursorLeft { .. } => self.input.cursor = None,
            WindowEvent::MouseWheel { delta, .. } => {
                if let Some(steps) = self.input.wheel(*delta, self.camera_area()) {
                    self.params.zoom_camera(steps);
                }
            }
            WindowEvent::HoveredFile(_) => self.panel.model.hovering_file = true,
            WindowEvent::HoveredFileCancelled => self.panel.model.hovering_file = false,
            WindowEvent::DroppedFile(path) => {
                self.panel.model.hovering_file = false;
                self.load_file(path.clone());
            }
            _ => {}
        }
        Ok(true)
    }

    /// Load an .obj dropped on the window or picked in the Open dialog (one path for both).
    fn load_file(&mut self, path: std::path::PathBuf) {
        self.panel.model.path = path.display().to_string();
        self.session.start_load(crate::scene::paper::ModelSource::File(path), &self.params, &mut self.panel);
    }

    /// Show the Open dialog for `purpose`, in the folder of the model or preset in use.
    fn open(&mut self, purpose: Purpose) {
        let near = match purpose {
            Purpose::Model => match self.session.model.as_ref().map(|m| &m.source) {
                Some(crate::scene::paper::ModelSource::File(p)) => Some(p.clone()),
                _ => None,
            },
            Purpose::Preset => self.panel.presets.recent.first().cloned(),
        };
        self.open_dialog.open(purpose, near.as_deref());
    }

    /// Where a mouse press or the wheel moves the camera: the image, unless the Open dialog
    /// covers it (then nowhere).
    fn camera_area(&self) -> PixelRect {
        if self.open_dialog.is_open() { PixelRect::default() } else { self.image_area }
    }

    fn area(&self) -> [u32; 2] {
        [self.image_area.width, self.image_area.height]
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

    /// Run egui for this frame; returns its output and the actions the panel asked for,
    /// and updates the image area.
    fn run_ui(&mut self) -> (egui::FullOutput, Vec<PanelAction>) {
        let mut raw = self.egui_state.take_egui_input(&self.window);
        let (keys, held) = self.input.frame_keys(&mut raw.events);
        if !held.is_empty() {
            self.egui_state.egui_input_mut().events = held;
            self.window.request_redraw();
        }
        // The keys are the tool's unless egui wants the keyboard (as it did at the end of the
        // last frame, which is how it will see them) or the Open dialog shows (its keys,
        // Escape, Enter and arrows, are its own whether or not a text field has the focus;
        // Ctrl+O among the keys opens it for those after).
        let egui_wants_keys = self.egui_ctx.egui_wants_keyboard_input();
        for key in keys {
            if !egui_wants_keys && !self.open_dialog.is_open() {
                self.shortcut(key);
            }
        }
        let mut actions = Vec::new();
        let mut central = egui::Rect::NOTHING;
        let settings: RenderSettings = self.params.settings_for(self.area());
        let screenshot_dir = screenshot::screenshot_dir();
        let dir_text = std::fs::canonicalize(&screenshot_dir).unwrap_or(screenshot_dir).display().to_string();
        let (triangles, vertices) = self.session.counts();
        let vendor = self.vendor_info();
        let device = devices::describe(&self.gpu.ctx, &self.gpu.trace_ctx);
        let info = PanelInfo {
            device: &device,
            model: self.session.model.as_ref().map(|m| &m.source),
            triangles,
            vertices,
            render_size: [settings.width, settings.height],
            rays: settings.max_rays(),
            loading: self.session.loader.status(),
            present_mode: self.gpu.presenter.present_mode_name(),
            vsync_off_available: self.gpu.presenter.can_disable_vsync(),
            heat: self.picture.as_ref().and_then(|h| h.stats),
            view_note: self.picture.as_ref().and_then(|h| h.note.as_deref()),
            accumulated_frames: self.session.accumulation.frames,
            progress: self.progressive.as_ref().map(|p| (p.progress(), p.seconds_left())),
            brute_tests: budget::tests_per_frame(&RenderSettings { accel: crate::tracer::Accel::Brute, ..settings }, triangles),
            screenshot_dir: dir_text,
            stats: &self.stats,
            benchmark: self.benchmarks.progress(),
            recording: self.recorder.info(),
            settings_file: self.store.path.as_deref(),
            vendor: &vendor,
            split_ms: self.split_ms,
            clock_mhz: self.gpu.clock.latest.zip(self.gpu.clock.highest),
        };
        let light = self.light_marker();
        let split = self.split_overlay();
        let notice = self.notice.as_ref();
        let params = &mut self.params;
        let panel_state = &mut self.panel;
        let open_dialog = &mut self.open_dialog;
        let full = self.egui_ctx.run_ui(raw, |ui| {
            if params.panel_visible {
                let frame = egui::Frame::side_top_panel(ui.style()).inner_margin(8.0);
                // At most half a small window, so the image stays visible.
                let max = (ui.available_width() * 0.5).max(160.0);
                egui::Panel::left("panel").default_size(panel::PANEL_WIDTH.min(max)).size_range(150.0..=max).frame(frame).show(ui, |ui| {
                    actions = panel::show(ui, params, panel_state, &info);
                });
            }
            central = ui.available_rect_before_wrap();
            overlay::show(ui.ctx(), central, params.hud_visible.then_some(&info), light, split.as_ref(), notice);
            // Last: the dialog is drawn over the panel and the image.
            match open_dialog.show(ui.ctx()) {
                Some((Purpose::Model, path)) => actions.push(PanelAction::LoadFile(path)),
                Some((Purpose::Preset, path)) => actions.push(PanelAction::LoadPreset(path)),
                None => {}
            }
        });
        let ppp = full.pixels_per_point;
        let size = self.window.inner_size();
        let x0 = (central.left() * ppp).round().clamp(0.0, size.width as f32) as i32;
        let y0 = (central.top() * ppp).round().clamp(0.0, size.height as f32) as i32;
        let x1 = (central.right() * ppp).round().clamp(0.0, size.width as f32) as i32;
        let y1 = (central.bottom() * ppp).round().clamp(0.0, size.height as f32) as i32;
        self.image_area = PixelRect { x: x0, y: y0, width: (x1 - x0).max(0) as u32, height: (y1 - y0).max(0) as u32 };
        (full, actions)
    }

    /// Act on a key press that egui did not want.
    fn shortcut(&mut self, key: KeyPress) {
        match self.params.apply_key(key.code, key.shift, key.ctrl, &mut self.previous_resolution) {
            KeyAction::None => {}
            // A held key steps a parameter again and again; it does not repeat actions.
            _ if key.repeat => {}
            KeyAction::ScreenshotTrace => self.want_trace_shot = true,
            KeyAction::ScreenshotWindow => self.want_window_shot = true,
            KeyAction::FrameModel => self.frame_model(),
            KeyAction::Benchmark => self.benchmarks.want(self.panel.benchmark.frames),
            KeyAction::OpenModel => self.open(Purpose::Model),
            KeyAction::Quit => self.script.request_exit(),
        }
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
        let shown = fit_rect([w, h], self.image_area);
        let (sx, sy) = self.params.camera.basis(w, h).project(self.params.light_position(), w, h)?;
        let ppp = self.window.scale_factor() as f32;
        let x = shown.x as f32 + sx / w as f32 * shown.width as f32;
        let y = shown.y as f32 + sy / h as f32 * shown.height as f32;
        Some(egui::pos2(x / ppp, y / ppp))
    }

    /// Point the camera at the models in view from where it looks now (F).
    fn frame_model(&mut self) {
        if let Some(model) = &self.session.model {
            let b = model.scene.model_bounds(self.params.model_count as usize);
            if !b.is_empty() {
                self.params.frame_model(b.center(), b.extent().length() * 0.5);
            }
        }
    }

    /// Decide what this display frame traces and shows. A frame that fits one submission
    /// is traced whole in the frame's command buffer; a longer one (brute force on a big
    /// mesh) is traced in row bands, one per display frame, so the window keeps drawing
    /// and answering input while the image fills in, and any change starts it afresh. A
    /// tracer on another device than the window's traces here and its picture is read back.
    fn prepare_image(&mut self, params: Option<FrameTrace>) -> anyhow::Result<Prepared> {
        let Some(params) = params.filter(|_| self.gpu.tracer.is_ready()) else {
            self.progressive = None;
            return Ok(Prepared { trace: None, show: Shown::Nothing, gpu_ms: None, part_ms: None, completes: false });
        };
        let (width, height) = (params.params.settings.width, params.params.settings.height);
        self.traced = true;
        if let Err(e) = self.gpu.tracer.prepare(&params) {
            // A preset or the A key asked for the vendor's ray tracing where the device has
            // none: say why and trace with our BVH from the next frame on.
            if let GpuError::VendorUnavailable(why) = &e {
                self.panel.render.status = Some(Status::error(format!("vendor ray tracing: {why}; tracing with the BVH")));
                if self.params.settings.accel == Accel::Vendor {
                    self.params.settings.accel = Accel::Bvh;
                }
                if self.params.split.b.accel == Some(Accel::Vendor) {
                    self.params.split.b.accel = Some(Accel::Bvh);
                }
                return Ok(Prepared { trace: None, show: Shown::Nothing, gpu_ms: None, part_ms: None, completes: false });
            }
            return Err(e.into());
        }
        // Views other than colour are pictures made on the CPU from the float output.
        let cost = (self.params.view != ViewMode::Color).then_some(self.params.view);
        if self.gpu.tracer.fits_one_submission(&params) {
            self.progressive = None;
            if let Some(view) = cost {
                let (image, timing) = self.gpu.tracer.render_frame(&params)?;
                self.set_picture(&image, view);
                return Ok(Prepared { trace: None, show: Shown::Picture, gpu_ms: timing.gpu_ms, part_ms: timing.parts_ms, completes: true });
            }
            if self.gpu.traces_elsewhere() {
                let timing = self.gpu.tracer.trace_frame(&params)?;
                self.read_back_colour()?;
                return Ok(Prepared { trace: None, show: Shown::Picture, gpu_ms: timing.gpu_ms, part_ms: timing.parts_ms, completes: true });
            }
            self.picture = None;
            let whole = Band::rows(0..height, width);
            return Ok(Prepared { trace: Some((params, whole)), show: Shown::Output, gpu_ms: None, part_ms: None, completes: true });
        }
        // A moving light does not restart a long frame: the frame keeps the light it began
        // with; any other change starts afresh.
        if !self.progressive.as_ref().is_some_and(|p| p.continues(&params)) {
            self.progressive = Some(Progressive::new(params, GROUP));
        }
        let most = (self.gpu.tracer.rows_per_submission(&params) / GROUP.height) * width.div_ceil(GROUP.width);
        self.band_groups = self.band_groups.clamp(1, most.max(1));
        let progressive = self.progressive.as_mut().expect("set above");
        let params = progressive.frame;
        let band = progressive.next_band(self.band_groups).expect("a frame in progress has pixels left");
        let completes = progressive.is_done();
        if completes {
            self.progressive = None;
        }
        if self.gpu.traces_elsewhere() {
            let ms = self.gpu.tracer.trace_band(&params, &band)?;
            let total: f64 = ms.iter().flatten().sum();
            self.band_groups = adapt_groups(self.band_groups, total, u32::MAX);
            match cost {
                None => self.read_back_colour()?,
                Some(view) if completes => {
                    let image = self.gpu.tracer.read_image()?;
                    self.set_picture(&image, view);
                }
                Some(_) => {}
            }
            let show = if self.picture.is_some() { Shown::Picture } else { Shown::Nothing };
            let part_ms = params.split.is_some().then(|| ms.map(|m| m.unwrap_or(0.0)));
            return Ok(Prepared { trace: None, show, gpu_ms: Some(total), part_ms, completes });
        }
        let show = match cost {
            Some(_) if self.picture.is_some() => Shown::Picture,
            Some(_) => Shown::Nothing,
            None => {
                self.picture = None;
                Shown::Output
            }
        };
        Ok(Prepared { trace: Some((params, band)), show, gpu_ms: None, part_ms: None, completes })
    }

    /// Show the tracer's colour output as it is now, read back from the tracing device.
    fn read_back_colour(&mut self) -> anyhow::Result<()> {
        let image = self.gpu.tracer.read_rgba8()?;
        let (width, height) = image.dimensions();
        self.picture = Some(Picture { width, height, rgba: image.into_raw(), stats: None, note: None });
        Ok(())
    }

    /// Make the picture of a view other than colour, traced into `image`, the one shown.
    fn set_picture(&mut self, image: &crate::tracer::Image, view: ViewMode) {
        let (width, height) = (image.width, image.height);
        self.picture = match (view, aov::picture(image, view)) {
            (ViewMode::Cost(metric), _) => {
                let map = heat_map(bytemuck::cast_slice(&image.pixels), metric);
                Some(Picture { width, height, rgba: map.rgba, stats: Some((map.scale_max, map.max, map.mean)), note: None })
            }
            (_, Some(p)) => Some(Picture { width, height, rgba: p.rgba, stats: p.heat, note: p.note }),
            (_, None) => None,
        };
    }

    fn redraw(&mut self) -> anyhow::Result<bool> {
        let now = Instant::now();
        if let Some(last) = self.last_frame {
            // Capped so a stall (a model upload) does not make the light jump.
            self.params.advance_light(now.duration_since(last).as_secs_f32().min(1.0));
        }
        if let Some(title) = self.session.poll_loader(&mut self.gpu.tracer, &mut self.panel)? {
            self.window.set_title(&title);
        }
        if self.shader_watch.as_mut().is_some_and(|w| w.poll(&mut self.gpu.tracer, &mut self.panel)) {
            // What was accumulated so far came from the old shader.
            self.session.accumulation = Default::default();
            self.progressive = None;
        }
        if !self.can_draw() && !self.script.is_final_frame(false) {
            // Minimized or hidden: nothing is traced or drawn (loads still finish above).
            self.last_frame = None;
            return Ok(true);
        }

        let (mut full, actions) = self.run_ui();
        self.gpu.presenter.update_textures(&mut full.textures_delta)?;
        for action in actions {
            match action {
                PanelAction::LoadModel(source) => self.session.start_load(source, &self.params, &mut self.panel),
                PanelAction::LoadFile(path) => self.load_file(path),
                PanelAction::Open(purpose) => self.open(purpose),
                PanelAction::ScreenshotTrace => self.want_trace_shot = true,
                PanelAction::ScreenshotWindow => self.want_window_shot = true,
                PanelAction::ScreenshotExr => {
                    let path = screenshot::new_path(&screenshot::screenshot_dir(), Kind::Trace, &self.name_parts()).with_extension("exr");
                    self.panel.screenshot.status = Some(self.save_exr(&path));
                    self.notice_screenshot();
                }
                PanelAction::SavePreset { path, overwrite } => self.save_preset(&path, overwrite),
                PanelAction::LoadPreset(path) => self.load_preset(&path),
                PanelAction::Benchmark(frames) => self.benchmarks.want(frames),
                PanelAction::CancelBenchmark => self.benchmarks.stop("the benchmark was cancelled", &mut self.params, &mut self.panel.benchmark.outcome)?,
                PanelAction::Record => self.panel.perf.status = self.recorder.start(&screenshot::screenshot_dir()),
                PanelAction::StopRecording => self.panel.perf.status = self.recorder.stop(),
                PanelAction::ResetSettings => self.reset_settings(),
                PanelAction::VendorKernel(kernel) => {
                    if let Err(e) = self.gpu.tracer.set_vendor_kernel(kernel) {
                        self.panel.render.status = Some(Status::error(e.to_string()));
                    }
                }
            }
        }
        self.egui_state.handle_platform_output(&self.window, full.platform_output);
        let area = self.area();
        self.session.apply(&mut self.params, area, &mut self.gpu.tracer, &mut self.panel)?;
        self.gpu.presenter.set_vsync(self.params.vsync);
        self.benchmarks.before_frame(&mut self.params, area, &mut self.panel.benchmark.outcome)?;
        let primitives = self.egui_ctx.tessellate(full.shapes, full.pixels_per_point);

        // A frame being traced in bands keeps its parameters (accumulation waits for it).
        let params = self.session.frame_params(&self.params, area, self.progressive.is_some());
        let prepared = self.prepare_image(params)?;
        // What this frame traces (a long frame keeps the settings it began with).
        let frame_settings = prepared.trace.as_ref().map(|(p, _)| p.params.settings).or(params.map(|p| p.params.settings));
        let traced = prepared.completes;
        let final_frame = self.script.is_final_frame(traced);
        let capture = self.want_window_shot || (final_frame && self.script.screenshot_ui.is_some());
        let image_rect = fit_rect(self.gpu.tracer.resolution().unwrap_or_default(), self.image_area);
        let recorded_band = prepared.trace.as_ref().is_some_and(|(p, band)| band.pixels() != p.params.settings.width as u64 * p.params.settings.height as u64);
        let tag = BandTag { frame: self.traced_frames, last: prepared.completes };
        let show = match (prepared.show, &self.picture) {
            (Shown::Output, _) => Show::Output,
            (Shown::Picture, Some(h)) => Show::Pixels { rgba: &h.rgba, width: h.width, height: h.height },
            _ => Show::Nothing,
        };
        let request = FrameRequest { trace: prepared.trace.clone(), tag, show, image_rect, ui: &primitives, pixels_per_point: full.pixels_per_point, capture_window: capture };
        // A tracer on another device has traced already; its buffers are not the window's.
        let recording = Some(&self.gpu.tracer).filter(|_| !self.gpu.traces_elsewhere());
        let outcome = self.gpu.presenter.draw(recording, &request)?;
        if recorded_band && prepared.completes && self.params.view != ViewMode::Color {
            // The last band of a long frame of another view: its picture replaces the last.
            let image = self.gpu.tracer.read_image()?;
            self.set_picture(&image, self.params.view);
        }
        if let (true, Some(ms)) = (recorded_band, outcome.gpu_ms) {
            self.band_groups = adapt_groups(self.band_groups, ms, u32::MAX);
        }
        self.gpu.clock.poll(now);
        // A traced frame's GPU time: its bands' times added up, from a trace done before
        // this frame or recorded into an earlier one and timed now.
        let mut frame_time = None;
        if let Some(ms) = prepared.gpu_ms {
            let parts = prepared.part_ms.map_or([None; 2], |p| p.map(Some));
            frame_time = self.band_times.add(tag, ms, parts);
        }
        if let (Some(ms), Some(band)) = (outcome.gpu_ms, outcome.tag) {
            frame_time = self.band_times.add(band, ms, outcome.part_ms).or(frame_time);
        }
        if prepared.completes {
            self.traced_frames += 1;
        }
        self.note_split_times(frame_time.map(|(_, parts)| parts));
        let t = now.duration_since(self.start).as_secs_f64();
        // Before the frame is logged: its row carries the latest GPU time.
        if let Some((ms, _)) = frame_time {
            self.stats.push_gpu(t, ms);
        }
        if outcome.presented {
            if let Some(last) = self.last_frame {
                self.stats.push_frame(t, now.duration_since(last).as_secs_f64() * 1e3);
            }
            self.last_frame = Some(now);
            if traced {
                self.script.frames += 1;
                let (stats, params, session, clock) = (&self.stats, &self.params, &self.session, self.gpu.clock.latest);
                let row = || (FrameRow::new(t, stats, &frame_settings.unwrap_or_default(), session.counts().0, clock), watched(params, &session.model_label()));
                if let Some(status) = self.recorder.frame(row) {
                    self.panel.perf.status = Some(status);
                }
            }
        } else if !self.can_draw() {
            self.last_frame = None;
        }
        self.benchmarks.after_frame(t, outcome.presented && traced, frame_time.map(|(ms, _)| ms), self.gpu.clock.latest);
        let (session, ctx) = (&self.session, &self.gpu.trace_ctx);
        let workload = |p: &Params| Workload { model: session.model_label(), models: p.model_count, triangles: session.counts().0 };
        if self.benchmarks.finish(&mut self.params, &mut self.panel.benchmark.outcome, workload, || crate::bench::environment(ctx))? {
            self.script.request_exit();
        }

        if self.want_trace_shot {
            self.want_trace_shot = false;
            let path = screenshot::new_path(&screenshot::screenshot_dir(), Kind::Trace, &self.name_parts());
            self.panel.screenshot.status = Some(self.save_trace(&path));
            self.notice_screenshot();
        }
        if self.want_window_shot && outcome.presented {
            self.want_window_shot = false;
            if let Some(image) = outcome.window_image.as_ref().filter(|_| !final_frame || self.script.screenshot_ui.is_none()) {
                let path = screenshot::new_path(&screenshot::screenshot_dir(), Kind::Window, &self.name_parts());
                self.panel.screenshot.status = Some(match image {
                    Ok(img) => screenshot::status(screenshot::save_png(img, &self.settings_text(), &path), &path),
                    Err(e) => Status::error(e.clone()),
                });
                self.notice_screenshot();
            }
        }

        if final_frame && self.script.finish_attempt(outcome.presented, !self.can_draw()) {
            self.write_exit_files(outcome.window_image)?;
            self.benchmarks.check_exit()?;
            return Ok(false);
        }
        Ok(true)
    }

}
