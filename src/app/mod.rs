//! The interactive tool: a winit window with a Vulkan swapchain showing the traced image,
//! and the egui tuning panel on top.
//!
//! - [`state`]: the parameters and the keyboard shortcuts;
//! - [`renderer`]: recording and presenting frames (trace, blit, egui);
//! - [`panel`]: the egui panel; [`frame_stats`]: the frame-time history it plots;
//! - [`model_loader`]: loading .obj files on a worker thread;
//! - [`screenshot`]: screenshot names and files; [`cost_view`]: the cost heat map.
//!
//! A scripted run (`--frames N`) starts with the light paused at `--light-angle` so that
//! `--screenshot` matches `meshtracer render` with the same flags.

pub mod cost_view;
pub mod frame_stats;
pub mod model_loader;
pub mod panel;
pub mod renderer;
pub mod screenshot;
pub mod state;

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{anyhow, Context as _};
use ash::vk;
use raw_window_handle::{HasDisplayHandle, HasWindowHandle};
use winit::application::ApplicationHandler;
use winit::dpi::{LogicalSize, PhysicalPosition};
use winit::event::{ElementState, KeyEvent, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{ModifiersState, PhysicalKey};
use winit::window::{Window, WindowId};

use crate::cli::args::ViewArgs;
use crate::gpu::{ContextOptions, GpuContext, GpuError};
use crate::scene::paper::{instances, ModelSource};
use crate::scene::{EnvironmentSource, Scene};
use crate::tracer::frame::{Aov, FrameParams};
use crate::tracer::packed::PackedScene;
use model_loader::{LoadedModel, ModelLoader, Poll};
use panel::{PanelAction, PanelInfo, PanelState, Status};
use renderer::{FrameRequest, Renderer};
use screenshot::{Kind, NameParts};
use state::{fit_rect, KeyAction, Params, PixelRect, Resolution, ViewMode};

/// The hint every "cannot open the tool" error carries.
pub const HEADLESS_HINT: &str = "use `meshtracer render -o out.png` on a headless machine";

/// Open the window and run until it is closed (or `--frames` have been shown).
pub fn run(args: &ViewArgs) -> anyhow::Result<()> {
    let window_size = state::parse_window_size(&args.window).map_err(anyhow::Error::msg)?;
    args.scene.settings(Aov::Color).validate().map_err(anyhow::Error::msg)?;
    let event_loop = EventLoop::new().map_err(|e| headless_error("cannot open a window", e))?;
    let mut app = App { args: args.clone(), window_size, error: None, tool: None };
    let ran = event_loop.run_app(&mut app);
    let result = app.finish();
    ran.map_err(|e| anyhow!("the window system failed ({e})"))?;
    result
}

struct App {
    args: ViewArgs,
    window_size: [u32; 2],
    error: Option<anyhow::Error>,
    tool: Option<Tool>,
}

impl App {
    fn fail(&mut self, event_loop: &ActiveEventLoop, e: anyhow::Error) {
        if self.error.is_none() {
            self.error = Some(e);
        }
        event_loop.exit();
    }

    /// Tear down in order and turn validation messages into an error.
    fn finish(&mut self) -> anyhow::Result<()> {
        let messages = self.tool.take().map(Tool::shut_down).unwrap_or_default();
        if let Some(e) = self.error.take() {
            return Err(e);
        }
        if !messages.is_empty() {
            anyhow::bail!("the Vulkan validation layer reported {} problem(s), the first: {}", messages.len(), messages[0]);
        }
        Ok(())
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.tool.is_some() || self.error.is_some() {
            return;
        }
        match Tool::new(event_loop, &self.args, self.window_size) {
            Ok(tool) => self.tool = Some(tool),
            Err(e) => self.fail(event_loop, e),
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let Some(tool) = self.tool.as_mut() else { return };
        match tool.window_event(&event) {
            Ok(true) => {}
            Ok(false) => event_loop.exit(),
            Err(e) => self.fail(event_loop, e),
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        if let Some(tool) = &self.tool {
            if tool.can_draw() {
                event_loop.set_control_flow(ControlFlow::Poll);
                tool.window.request_redraw();
            } else {
                // Minimized or hidden: check back now and then (model loads still finish).
                event_loop.set_control_flow(ControlFlow::WaitUntil(Instant::now() + Duration::from_millis(50)));
                tool.window.request_redraw();
            }
        }
    }
}

/// The current model on the CPU side.
struct Model {
    source: ModelSource,
    scene: Scene,
    /// Geometry arrays emptied after upload; the mesh table stays for instance rebuilds.
    packed: PackedScene,
}

/// What has been pushed to the GPU, to notice parameter changes.
#[derive(Default, PartialEq)]
struct Applied {
    model_count: u32,
    resolution: [u32; 2],
    environment: Option<EnvironmentSource>,
    mirror_box: bool,
}

/// Most ray-triangle tests per frame the tool lets brute force ask for in its single
/// dispatch (about a second on an H100); `render` and `bench` split bigger frames instead.
const MAX_INTERACTIVE_BRUTE_TESTS: f64 = 5.0e10;

/// Progressive accumulation: the frame last traced (with `frame_index` 0) and how many
/// frames have been averaged into the output since anything changed.
#[derive(Default)]
struct Accumulation {
    last: Option<FrameParams>,
    frames: u32,
}

/// Exiting: the frame to capture and the files to write.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Exit {
    Running,
    /// Draw one more frame (capturing the window if asked), write the files, quit.
    Requested,
}

struct Tool {
    // Declared first: dropped before the window its surface belongs to.
    renderer: Renderer,
    ctx: Arc<GpuContext>,
    egui_state: egui_winit::State,
    egui_ctx: egui::Context,
    window: Arc<Window>,
    args: ViewArgs,
    params: Params,
    /// The resolution `M` returns to.
    previous_resolution: Resolution,
    applied: Applied,
    accumulation: Accumulation,
    model: Option<Model>,
    loader: ModelLoader,
    stats: frame_stats::FrameStats,
    panel: PanelState,
    heat: Option<(f32, f32, f32)>,
    start: Instant,
    last_frame: Option<Instant>,
    /// Frames presented with a traced scene (what `--frames` counts).
    frames: u64,
    dragging: bool,
    cursor: Option<PhysicalPosition<f64>>,
    modifiers: ModifiersState,
    occluded: bool,
    image_area: PixelRect,
    want_trace_shot: bool,
    want_window_shot: bool,
    exit: Exit,
    exit_attempts: u32,
}

fn headless_error(what: &str, e: impl std::fmt::Display) -> anyhow::Error {
    anyhow!("{what} ({}); {HEADLESS_HINT}", os_message(&e.to_string()))
}

/// winit's OS errors read "os error at path/to/file.rs:123: message": keep the message.
fn os_message(s: &str) -> String {
    let message = match s.find("os error at ") {
        Some(i) => s[i + "os error at ".len()..].split_once(": ").map_or(s, |(_, m)| m),
        None => s,
    };
    message.trim().trim_end_matches('.').replace('\n', " ")
}

impl Tool {
    fn new(event_loop: &ActiveEventLoop, args: &ViewArgs, size: [u32; 2]) -> anyhow::Result<Self> {
        let attributes = Window::default_attributes()
            .with_title(format!("meshtracer — {}", args.scene.model_source().label()))
            .with_inner_size(LogicalSize::new(size[0], size[1]));
        let window = Arc::new(event_loop.create_window(attributes).map_err(|e| headless_error("cannot open a window", e))?);
        let display = window.display_handle().map_err(|e| headless_error("no display handle", e))?.as_raw();
        let window_handle = window.window_handle().map_err(|e| headless_error("no window handle", e))?.as_raw();
        let extensions = ash_window::enumerate_required_extensions(display).map_err(|e| headless_error("this window system has no Vulkan surface support", e))?;
        // Spelled with `..Default::default()` so options added later keep their defaults.
        #[allow(clippy::needless_update)]
        let options = ContextOptions {
            validation: args.validation,
            instance_extensions: extensions.to_vec(),
            presentation: true,
            device_index: args.scene.device,
            ..Default::default()
        };
        let make_surface = |entry: &ash::Entry, instance: &ash::Instance| {
            // SAFETY: the handles belong to `window`, which outlives the surface (the
            // renderer that owns the surface is dropped first).
            unsafe { ash_window::create_surface(entry, instance, display, window_handle, None) }.map_err(|r| GpuError::vk("creating the window surface", r))
        };
        let (ctx, surface) = GpuContext::with_surface(&options, Some(&make_surface)).map_err(|e| headless_error("no Vulkan device for the window", e))?;
        let surface = surface.context("no surface was created")?;
        let params = Params::from_args(args);
        let physical = window.inner_size();
        let renderer = Renderer::new(&ctx, surface, vk::Extent2D { width: physical.width, height: physical.height }, params.vsync)?;

        let egui_ctx = egui::Context::default();
        egui_ctx.set_theme(egui::ThemePreference::Dark);
        let max_texture = unsafe { ctx.instance.get_physical_device_properties(ctx.physical_device) }.limits.max_image_dimension2_d as usize;
        let egui_state = egui_winit::State::new(egui_ctx.clone(), egui::ViewportId::ROOT, &window, Some(window.scale_factor() as f32), None, Some(max_texture));

        let mut loader = ModelLoader::default();
        loader.start(args.scene.model_source(), params.model_count, params.light);
        let previous_resolution = if params.resolution == Resolution::MatchWindow { Resolution::Square(512) } else { params.resolution };
        Ok(Self {
            renderer,
            ctx,
            egui_state,
            egui_ctx,
            window,
            args: args.clone(),
            previous_resolution,
            params,
            applied: Applied::default(),
            accumulation: Accumulation::default(),
            model: None,
            loader,
            stats: Default::default(),
            panel: PanelState::default(),
            heat: None,
            start: Instant::now(),
            last_frame: None,
            frames: 0,
            dragging: false,
            cursor: None,
            modifiers: ModifiersState::empty(),
            occluded: false,
            image_area: PixelRect::default(),
            want_trace_shot: false,
            want_window_shot: false,
            exit: Exit::Running,
            exit_attempts: 0,
        })
    }

    fn can_draw(&self) -> bool {
        let size = self.window.inner_size();
        size.width > 0 && size.height > 0 && !self.occluded
    }

    /// Free everything in order; returns the validation messages seen.
    fn shut_down(self) -> Vec<String> {
        let Tool { renderer, ctx, egui_state, window, .. } = self;
        let _ = ctx.wait_idle();
        drop(renderer);
        drop(egui_state);
        drop(window);
        ctx.validation_messages()
    }

    /// Handle one window event; Ok(false) quits.
    fn window_event(&mut self, event: &WindowEvent) -> anyhow::Result<bool> {
        let response = self.egui_state.on_window_event(&self.window, event);
        match event {
            WindowEvent::CloseRequested => self.request_exit(),
            WindowEvent::Resized(size) => self.renderer.resize(size.width, size.height),
            WindowEvent::Occluded(occluded) => self.occluded = *occluded,
            WindowEvent::ModifiersChanged(m) => self.modifiers = m.state(),
            WindowEvent::RedrawRequested => return self.redraw(),
            WindowEvent::KeyboardInput { event: KeyEvent { physical_key: PhysicalKey::Code(code), state: ElementState::Pressed, .. }, .. } if !response.consumed => {
                match self.params.apply_key(*code, self.modifiers.shift_key(), self.modifiers.control_key(), &mut self.previous_resolution) {
                    KeyAction::None => {}
                    KeyAction::ScreenshotTrace => self.want_trace_shot = true,
                    KeyAction::ScreenshotWindow => self.want_window_shot = true,
                    KeyAction::Quit => self.request_exit(),
                }
            }
            WindowEvent::MouseInput { state, button: MouseButton::Left, .. } => {
                self.dragging = *state == ElementState::Pressed && !response.consumed && !self.egui_ctx.is_pointer_over_egui();
            }
            WindowEvent::CursorMoved { position, .. } => {
                if let (true, Some(last)) = (self.dragging, self.cursor) {
                    self.params.drag_camera((position.x - last.x) as f32, (position.y - last.y) as f32);
                }
                self.cursor = Some(*position);
            }
            WindowEvent::CursorLeft { .. } => self.cursor = None,
            WindowEvent::MouseWheel { delta, .. } if !response.consumed && !self.egui_ctx.is_pointer_over_egui() => {
                let steps = match delta {
                    MouseScrollDelta::LineDelta(_, y) => *y,
                    MouseScrollDelta::PixelDelta(p) => p.y as f32 / 40.0,
                };
                self.params.zoom_camera(steps);
            }
            WindowEvent::HoveredFile(_) => self.panel.hovering_file = true,
            WindowEvent::HoveredFileCancelled => self.panel.hovering_file = false,
            WindowEvent::DroppedFile(path) => {
                self.panel.hovering_file = false;
                self.panel.path = path.display().to_string();
                self.start_load(ModelSource::File(path.clone()));
            }
            _ => {}
        }
        Ok(true)
    }

    fn request_exit(&mut self) {
        self.exit = Exit::Requested;
    }

    fn start_load(&mut self, source: ModelSource) {
        self.panel.model_status = None;
        self.loader.start(source, self.params.model_count, self.params.light);
    }

    /// Take a finished load: upload it, or keep the old model and say why not.
    fn poll_loader(&mut self) -> anyhow::Result<()> {
        let result = match self.loader.poll() {
            Poll::Idle | Poll::Busy => return Ok(()),
            Poll::Done(result) => *result,
        };
        let first = self.model.is_none();
        match result.and_then(|loaded| self.install(loaded).map_err(|e| format!("{e:#}"))) {
            Ok(()) => Ok(()),
            // With no model to fall back on, the run cannot go on.
            Err(e) if first => Err(anyhow!("{e}")),
            Err(e) => {
                self.panel.model_status = Some(Status::error(format!("{e}; keeping {}", self.model.as_ref().map_or(String::new(), |m| m.source.label()))));
                Ok(())
            }
        }
    }

    fn install(&mut self, loaded: LoadedModel) -> anyhow::Result<()> {
        let LoadedModel { source, scene, mut packed, warnings, seconds } = loaded;
        self.renderer.set_scene(&packed)?;
        packed.triangles = Vec::new();
        packed.shading = Vec::new();
        packed.nodes = Vec::new();
        let text = format!("loaded {} ({} triangles) in {seconds:.2} s", source.label(), panel::group(scene.meshes[0].triangle_count() as u64));
        self.panel.model_status = Some(match warnings.first() {
            Some(w) => Status::ok(format!("{text}; {} warning(s), the first: {w}", warnings.len())),
            None => Status::ok(text),
        });
        self.window.set_title(&format!("meshtracer — {}", source.label()));
        // Force the instance list (model count, mirror box) to be rebuilt by apply_params.
        self.applied.model_count = 0;
        // The new scene has no environment yet: apply_params uploads the chosen one.
        self.applied.environment = None;
        self.accumulation = Accumulation::default();
        self.model = Some(Model { source, scene, packed });
        Ok(())
    }

    /// Push parameter changes to the GPU side (each takes effect this frame).
    fn apply_params(&mut self) -> anyhow::Result<()> {
        let area = [self.image_area.width, self.image_area.height];
        let [w, h] = self.params.render_size(area);
        if self.applied.resolution != [w, h] {
            match self.renderer.set_resolution(w, h) {
                Ok(()) => {
                    self.applied.resolution = [w, h];
                    self.panel.render_status = None;
                }
                Err(e) => {
                    // Too big for this device: say so and go back to what worked.
                    let old = self.applied.resolution;
                    self.panel.render_status = Some(Status::error(format!("{w} x {h} failed: {e:#}")));
                    self.params.resolution = Resolution::Custom;
                    self.params.custom = if old == [0, 0] { [256, 256] } else { old };
                    let [ow, oh] = self.params.custom;
                    self.renderer.set_resolution(ow, oh)?;
                    self.applied.resolution = [ow, oh];
                }
            }
        }
        if let Some(model) = &mut self.model {
            if self.applied.model_count != self.params.model_count || self.applied.mirror_box != self.params.mirror_box {
                model.scene.instances = instances(self.params.model_count);
                if !self.params.mirror_box {
                    model.scene.instances.retain(|i| i.mesh == 0);
                }
                self.applied.mirror_box = self.params.mirror_box;
                model.packed.set_instances(&model.scene.instances);
                self.renderer.set_instances(&model.packed.instances)?;
                self.applied.model_count = self.params.model_count;
                self.accumulation = Accumulation::default();
            }
            if self.applied.environment != self.params.environment {
                model.packed.set_environment(self.params.environment.as_ref());
                if let Some(w) = model.packed.warnings.pop() {
                    self.panel.render_status = Some(Status::error(w));
                }
                model.scene.environment = self.params.environment.clone();
                self.renderer.set_environment(&model.packed)?;
                self.applied.environment = self.params.environment.clone();
                self.accumulation = Accumulation::default();
            }
        }
        // Brute force records one dispatch per frame: refuse it where that dispatch would run
        // for about a second or more on a fast GPU (and so risk the driver's watchdog).
        if self.params.accel == crate::tracer::Accel::Brute {
            let triangles = self.model.as_ref().map_or(0, |m| m.scene.triangle_count()) as f64;
            let tests = self.params.settings([w, h]).max_rays() as f64 * triangles;
            if tests > MAX_INTERACTIVE_BRUTE_TESTS {
                self.params.accel = crate::tracer::Accel::Bvh;
                self.panel.render_status = Some(Status::error(format!(
                    "brute force would test {tests:.1e} ray-triangle pairs per frame (seconds per frame); staying on the BVH"
                )));
            }
        }
        self.renderer.set_vsync(self.params.vsync);
        Ok(())
    }

    fn name_parts(&self) -> NameParts {
        let [width, height] = self.applied.resolution;
        NameParts {
            model: self.model.as_ref().map_or("none".into(), |m| m.source.label()),
            models: self.params.model_count,
            width,
            height,
            bounces: self.params.bounces,
            blend: self.params.blend,
        }
    }

    fn frame_params(&mut self) -> Option<FrameParams> {
        let model = self.model.as_mut()?;
        model.scene.camera = self.params.camera;
        model.scene.light.position = self.params.light_position();
        let mut params = FrameParams::new(&model.scene, self.params.settings([self.image_area.width, self.image_area.height]));
        // Average frames while nothing changes; any change starts afresh.
        let acc = &mut self.accumulation;
        let still = self.params.accumulate && params.settings.aov == crate::tracer::Aov::Color && acc.last == Some(params);
        acc.frames = if still { acc.frames.saturating_add(1).min(1 << 20) } else { 1 };
        acc.last = Some(params);
        params.frame_index = acc.frames - 1;
        Some(params)
    }

    /// Run egui for this frame; returns its output and the image area.
    fn run_ui(&mut self) -> (egui::FullOutput, Vec<PanelAction>) {
        let raw = self.egui_state.take_egui_input(&self.window);
        let mut actions = Vec::new();
        let mut central = egui::Rect::NOTHING;
        let settings = self.params.settings([self.image_area.width, self.image_area.height]);
        let present_modes = self.renderer.present_modes().to_vec();
        let screenshot_dir = screenshot::screenshot_dir();
        let dir_text = std::fs::canonicalize(&screenshot_dir).unwrap_or(screenshot_dir).display().to_string();
        let (triangles, vertices) = self.model.as_ref().map_or((0, 0), |m| (m.scene.triangle_count() as u64, m.scene.vertex_count() as u64));
        let device = format!(
            "{} ({}){}",
            self.ctx.info.name,
            self.ctx.info.device_type,
            if self.ctx.validation_enabled() { ", validation on" } else { "" }
        );
        let info = PanelInfo {
            device: &device,
            model: self.model.as_ref().map(|m| &m.source),
            triangles,
            vertices,
            render_size: [settings.width, settings.height],
            rays: settings.max_rays(),
            loading: self.loader.status(),
            present_mode: format!("{:?}", self.renderer.present_mode()),
            vsync_off_available: present_modes.iter().any(|m| *m != vk::PresentModeKHR::FIFO && *m != vk::PresentModeKHR::FIFO_RELAXED),
            heat: self.heat,
            accumulated_frames: self.accumulation.frames,
            screenshot_dir: dir_text,
            stats: &self.stats,
        };
        let params = &mut self.params;
        let panel_state = &mut self.panel;
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

    fn redraw(&mut self) -> anyhow::Result<bool> {
        let now = Instant::now();
        if let Some(last) = self.last_frame {
            // Capped so a stall (a model upload) does not make the light jump.
            self.params.advance_light(now.duration_since(last).as_secs_f32().min(1.0));
        }
        self.poll_loader()?;

        let (mut full, actions) = self.run_ui();
        self.renderer.update_textures(&mut full.textures_delta)?;
        for action in actions {
            match action {
                PanelAction::LoadModel(source) => self.start_load(source),
                PanelAction::ScreenshotTrace => self.want_trace_shot = true,
                PanelAction::ScreenshotWindow => self.want_window_shot = true,
            }
        }
        self.egui_state.handle_platform_output(&self.window, full.platform_output);
        self.apply_params()?;
        let primitives = self.egui_ctx.tessellate(full.shapes, full.pixels_per_point);

        let params = self.frame_params();
        let scripted_last = self.args.frames.is_some_and(|n| self.frames + 1 >= n) && params.is_some();
        let final_frame = scripted_last || self.exit == Exit::Requested;
        let capture = self.want_window_shot || (final_frame && self.args.screenshot_ui.is_some());
        let image = self.applied.resolution;
        let request = FrameRequest {
            params,
            cost: match self.params.view {
                ViewMode::Cost(m) => Some(m),
                ViewMode::Color => None,
            },
            image_rect: fit_rect(image, self.image_area),
            ui: &primitives,
            pixels_per_point: full.pixels_per_point,
            capture_window: capture,
        };
        let outcome = self.renderer.draw(&request)?;
        let traced = request.params.is_some();
        let t = now.duration_since(self.start).as_secs_f64();
        if outcome.presented {
            if let Some(last) = self.last_frame {
                self.stats.push_frame(t, now.duration_since(last).as_secs_f64() * 1e3);
            }
            self.last_frame = Some(now);
            if traced {
                self.frames += 1;
            }
        } else if !self.can_draw() {
            self.last_frame = None;
        }
        if let Some(ms) = outcome.gpu_ms {
            self.stats.push_gpu(t, ms);
        }
        if outcome.presented {
            self.heat = outcome.heat;
        }

        if self.want_trace_shot {
            self.want_trace_shot = false;
            let path = screenshot::new_path(&screenshot::screenshot_dir(), Kind::Trace, &self.name_parts());
            self.panel.screenshot_status = Some(self.save_trace(&path));
        }
        if self.want_window_shot && outcome.presented {
            self.want_window_shot = false;
            if let Some(image) = outcome.window_image.as_ref().filter(|_| !final_frame || self.args.screenshot_ui.is_none()) {
                let path = screenshot::new_path(&screenshot::screenshot_dir(), Kind::Window, &self.name_parts());
                self.panel.screenshot_status = Some(match image {
                    Ok(img) => to_status(screenshot::save_png(img, &path), &path),
                    Err(e) => Status::error(e.clone()),
                });
            }
        }

        if final_frame {
            // A skipped frame (swapchain out of date) is retried a few times.
            if outcome.presented || !self.can_draw() || self.exit_attempts >= 10 {
                self.write_exit_files(outcome.window_image)?;
                return Ok(false);
            }
            self.exit_attempts += 1;
        }
        Ok(true)
    }

    fn save_trace(&self, path: &Path) -> Status {
        match self.renderer.read_trace() {
            Ok(Some(img)) => to_status(screenshot::save_png(&img, path), path),
            Ok(None) => Status::error("nothing traced yet: no screenshot written"),
            Err(e) => Status::error(format!("reading the traced image failed: {e:#}")),
        }
    }

    /// `--screenshot` / `--screenshot-ui` at exit; failures end the run with an error.
    fn write_exit_files(&self, window_image: Option<Result<image::RgbaImage, String>>) -> anyhow::Result<()> {
        if let Some(path) = &self.args.screenshot {
            let img = self.renderer.read_trace()?.context("--screenshot: nothing was traced before exit")?;
            screenshot::save_png(&img, path).map_err(anyhow::Error::msg)?;
            println!("wrote {}", path.display());
        }
        if let Some(path) = &self.args.screenshot_ui {
            let img = window_image
                .context("--screenshot-ui: the window was not drawn at exit (minimized?)")?
                .map_err(|e| anyhow!("--screenshot-ui: {e}"))?;
            screenshot::save_png(&img, path).map_err(anyhow::Error::msg)?;
            println!("wrote {}", path.display());
        }
        Ok(())
    }
}

fn to_status(result: Result<(), String>, path: &Path) -> Status {
    match result {
        Ok(()) => {
            let shown: PathBuf = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
            Status::ok(format!("wrote {}", shown.display()))
        }
        Err(e) => Status::error(e),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn winit_errors_lose_their_source_location() {
        let e = "os error at /home/x/winit-0.30.13/src/platform_impl/linux/mod.rs:788: Failed to open connection to X server";
        assert_eq!(os_message(e), "Failed to open connection to X server");
        assert_eq!(os_message("plain."), "plain");
        let full = headless_error("cannot open a window", e).to_string();
        assert_eq!(full, format!("cannot open a window (Failed to open connection to X server); {HEADLESS_HINT}"));
    }
}
