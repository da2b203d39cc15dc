//! The interactive tool: a winit window with a Vulkan swapchain showing the traced image,
//! and the egui tuning panel on top.
//!
//! Its parts from the bottom up; each imports only those before it (`APP_ORDER` in
//! `tests/architecture.rs`), and this file, the entry point, all of them:
//! - `status`: a line reporting to the user; `split`: the A/B split's settings;
//! - `options`: what the tool is started with (the CLI fills it); `state`: the parameters;
//!   `shortcuts`: the keys that change them;
//! - `user_files/`: model loading, the Open dialog, screenshots, remembered settings, shader
//!   reloads;
//! - `measure/`: frame-time history, GPU clock, the frame-time log and the benchmark run;
//! - `panel/`: the egui side panel, one file per section;
//! - `views/`: the cost and AOV views, and the overlay over the image (the HUD, with the
//!   panel's numbers);
//! - `tool/`: the window, GPU side and egui, one redraw per displayed frame, with its
//!   input, session (model, loader, what the tracer holds), scripted runs and bands.
//!
//! Nothing here calls Vulkan: presentation and tracing are `crate::gpu`'s.
//!
//! A scripted run (`--frames N`) starts with the light paused at `--light-angle` so that
//! `--screenshot` matches `meshtracer render` with the same flags.

pub(crate) mod measure;
pub(crate) mod options;
pub(crate) mod panel;
pub(crate) mod shortcuts;
pub(crate) mod split;
pub(crate) mod state;
pub(crate) mod status;
pub(crate) mod tool;
pub(crate) mod user_files;
pub(crate) mod views;

/// The in-window benchmark where the command line's tests name it.
#[cfg(test)]
pub(crate) use measure::benchmark;

use std::time::{Duration, Instant};

use anyhow::anyhow;
use winit::application::ApplicationHandler;
use winit::event::WindowEvent;
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::window::WindowId;

use tool::devices::headless_error;
use tool::Tool;

pub(crate) use options::parse_window_size;
pub use options::ViewOptions;
pub use split::{SplitB, SplitView};

/// Open the window and run until it is closed (or `--frames` have been shown).
pub fn run(options: &ViewOptions) -> anyhow::Result<()> {
    options.spec.validate().map_err(anyhow::Error::msg)?;
    let event_loop = EventLoop::new().map_err(|e| headless_error("cannot open a window", e))?;
    let mut app = App { args: options.clone(), error: None, tool: None };
    let ran = event_loop.run_app(&mut app);
    let result = app.finish();
    ran.map_err(|e| anyhow!("the window system failed ({e})"))?;
    result
}

struct App {
    args: ViewOptions,
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
            anyhow::bail!(
                "the Vulkan validation layer reported {} problem(s), the first: {}",
                messages.len(),
                messages[0]
            );
        }
        Ok(())
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.tool.is_some() || self.error.is_some() {
            return;
        }
        match Tool::new(event_loop, &self.args) {
            Ok(tool) => self.tool = Some(tool),
            Err(e) => self.fail(event_loop, e),
        }
    }

    fn device_event(
        &mut self,
        _event_loop: &ActiveEventLoop,
        _id: winit::event::DeviceId,
        event: winit::event::DeviceEvent,
    ) {
        if let (Some(tool), winit::event::DeviceEvent::Button { button, state }) =
            (self.tool.as_mut(), event)
        {
            tool.raw_button(button, state);
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
                // Minimized or hidden: check back now and then (model loads still finish),
                // tracing nothing meanwhile.
                event_loop.set_control_flow(ControlFlow::WaitUntil(
                    Instant::now() + Duration::from_millis(100),
                ));
                tool.window.request_redraw();
            }
        }
    }
}
