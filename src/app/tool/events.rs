//! Window events: the mouse drives the camera (or the split line), keys wait for the frame
//! that decides whether they are shortcuts, files dropped on the window load.

use winit::event::{ElementState, KeyEvent, MouseButton, WindowEvent};
use winit::keyboard::PhysicalKey;

use crate::app::shortcuts::KeyAction;
use crate::app::state::fit_rect;
use crate::app::tool::input::{self, Drag, KeyPress};
use crate::app::tool::Tool;
use crate::app::user_files::open_dialog::Purpose;
use crate::gpu::present::PixelRect;

impl Tool {
    /// A raw mouse button from winit's device events (see [`Input::raw_button`]).
    pub(crate) fn raw_button(&mut self, button: u32, state: winit::event::ElementState) {
        self.input.raw_button(button, state);
    }

    /// Handle one window event; Ok(false) quits.
    pub(crate) fn window_event(&mut self, event: &WindowEvent) -> anyhow::Result<bool> {
        // Its `consumed` is not used: for a key it comes from the focus before the clicks
        // that egui has not run yet (keys wait for the frame, `Input::frame_keys`).
        let _ = self.ui.egui_state.on_window_event(&self.window, event);
        if let WindowEvent::KeyboardInput { event: key, is_synthetic: false, .. } = event {
            let m = self.input.modifiers;
            let (ctrl, shift, alt) = (m.control_key(), m.shift_key(), m.alt_key());
            let modifiers = egui::Modifiers { alt, ctrl, shift, mac_cmd: false, command: ctrl };
            let pressed = key.state == ElementState::Pressed;
            if let Some(enter) =
                input::line_end_as_enter(&key.logical_key, key.text.as_deref(), pressed, modifiers)
            {
                self.ui.egui_state.egui_input_mut().events.extend(enter);
            }
        }
        let (count, now) = (self.ui.egui_state.egui_input().events.len(), self.input.now());
        self.input.events_arrived(count, now);
        match event {
            WindowEvent::CloseRequested => self.script.request_exit(),
            WindowEvent::Resized(size) => self.gpu.presenter.resize(size.width, size.height),
            WindowEvent::Occluded(occluded) => self.input.occluded = *occluded,
            WindowEvent::ModifiersChanged(m) => self.input.modifiers = m.state(),
            WindowEvent::RedrawRequested => return self.redraw(),
            // Synthetic presses (keys held while the window gains focus) are not the user's.
            // A press waits for the frame, which decides whether it is a shortcut (`input.rs`).
            WindowEvent::KeyboardInput {
                event:
                    KeyEvent {
                        physical_key: PhysicalKey::Code(code),
                        state: ElementState::Pressed,
                        repeat,
                        ..
                    },
                is_synthetic: false,
                ..
            } => {
                self.input.key_pressed(
                    *code,
                    *repeat,
                    self.ui.egui_state.egui_input().events.len(),
                );
            }
            WindowEvent::MouseInput { state, button: MouseButton::Left, .. } => {
                // A press on the split line moves the line, not the camera.
                let kind = if self.on_split_line() { Drag::Split } else { Drag::Orbit };
                self.input.drag_button(*state, kind, self.camera_area());
            }
            WindowEvent::MouseInput { state, button: MouseButton::Middle, .. } => {
                self.input.drag_button(*state, Drag::Pan, self.camera_area())
            }
            WindowEvent::CursorMoved { position, .. } => match self.input.cursor_moved(*position) {
                Some((Drag::Orbit, dx, dy)) => self.params.drag_camera(dx, dy),
                Some((Drag::Split, _, _)) => self.move_split(),
                Some((Drag::Pan, dx, dy)) => {
                    // Pixels of the image as shown: the scene follows the cursor.
                    let shown = fit_rect(
                        self.gpu.tracer.resolution().unwrap_or([1, 1]),
                        self.ui.image_area,
                    );
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
            WindowEvent::HoveredFile(_) => self.ui.panel.model.hovering_file = true,
            WindowEvent::HoveredFileCancelled => self.ui.panel.model.hovering_file = false,
            WindowEvent::DroppedFile(path) => {
                self.ui.panel.model.hovering_file = false;
                self.load_file(path.clone());
            }
            _ => {}
        }
        Ok(true)
    }

    /// Load a model file dropped on the window or picked in the Open dialog (one path for both).
    pub(super) fn load_file(&mut self, path: std::path::PathBuf) {
        self.ui.panel.model.path = path.display().to_string();
        self.session.start_load(
            crate::scene::paper::ModelSource::File(path),
            &mut self.params,
            &mut self.ui.panel,
        );
    }

    /// Stop the model load in progress (Escape, the panel's Cancel).
    pub(super) fn cancel_load(&mut self) {
        self.session.cancel_load(&mut self.ui.panel);
    }

    /// Show the Open dialog for `purpose`, in the folder of the model or preset in use.
    pub(super) fn open(&mut self, purpose: Purpose) {
        let near = match purpose {
            Purpose::Model => match self.session.model.as_ref().map(|m| &m.source) {
                Some(crate::scene::paper::ModelSource::File(p)) => Some(p.clone()),
                _ => None,
            },
            Purpose::Preset => self.ui.panel.presets.recent.first().cloned(),
            Purpose::Environment => match &self.params.environment_file {
                Some(crate::scene::EnvironmentSource::File(p)) => Some(p.clone()),
                _ => None,
            },
        };
        self.ui.open_dialog.open(purpose, near.as_deref());
    }

    /// Where a mouse press or the wheel moves the camera: the image, unless the Open dialog
    /// covers it (then nowhere).
    fn camera_area(&self) -> PixelRect {
        if self.ui.open_dialog.is_open() {
            PixelRect::default()
        } else {
            self.ui.image_area
        }
    }

    /// Act on a key press that egui did not want.
    pub(super) fn shortcut(&mut self, key: KeyPress) {
        let (accel, vendor) =
            (self.params.scene.settings.accel, self.gpu.tracer.vendor_kernel().is_ok());
        let previous = &mut self.previous_resolution;
        let action = self.params.apply_key(key.code, key.shift, key.ctrl, previous, vendor);
        if self.params.scene.settings.accel != accel {
            // A chose another: a line about the vendor's fallback to the BVH no longer holds.
            self.ui.panel.render.accel_chosen();
        }
        match action {
            KeyAction::None => {}
            // A held key steps a parameter again and again; it does not repeat actions.
            _ if key.repeat => {}
            KeyAction::ScreenshotTrace => self.captures.want_trace_shot = true,
            KeyAction::ScreenshotWindow => self.captures.want_window_shot = true,
            KeyAction::FrameModel => self.frame_model(),
            KeyAction::Benchmark => self.timing.benchmarks.want(self.ui.panel.benchmark.frames),
            KeyAction::OpenModel => self.open(Purpose::Model),
            KeyAction::CancelLoad => self.cancel_load(),
            KeyAction::Quit => self.script.request_exit(),
        }
    }

    /// Point the camera at the models in view from where it looks now (F).
    fn frame_model(&mut self) {
        if let Some(model) = &self.session.model {
            let b = model.scene.model_bounds();
            if !b.is_empty() {
                self.params.frame_model(b.center(), b.extent().length() * 0.5);
            }
        }
    }
}
