//! Mouse and keyboard state between window events: the camera drag, the cursor, the
//! modifier keys. Whether the pointer is over the panel is decided from the cursor of the
//! latest cursor event against the image area of the latest frame, not from egui's view
//! of the last frame (which lags by a frame, a long time at a few fps).

use winit::dpi::PhysicalPosition;
use winit::event::{ElementState, MouseScrollDelta};
use winit::keyboard::ModifiersState;

use crate::gpu::present::PixelRect;

/// Pixels of a touchpad's smooth scroll that make one wheel notch.
const PIXELS_PER_NOTCH: f64 = 40.0;

/// What a mouse drag over the image does to the camera.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Drag {
    /// Left button: turn around the target.
    Orbit,
    /// Middle button, or Shift with the left: slide the view.
    Pan,
    /// Left button on the split view's line: move the line (the camera stays).
    Split,
}

/// The input state the window events leave behind.
#[derive(Default)]
pub struct Input {
    /// A drag that began over the image, moving the camera.
    pub drag: Option<Drag>,
    /// The cursor of the latest cursor event, physical pixels; None outside the window.
    pub cursor: Option<PhysicalPosition<f64>>,
    pub modifiers: ModifiersState,
    /// The window is hidden or minimized: nothing is drawn.
    pub occluded: bool,
    /// The next wheel event echoes the release of a wheel button (see [`Input::raw_button`]).
    wheel_release_echo: bool,
}

impl Input {
    /// The cursor is over the traced image (not over the panel, not outside the window).
    pub fn over_image(&self, image_area: PixelRect) -> bool {
        self.cursor.is_some_and(|c| {
            let (x, y) = (c.x, c.y);
            x >= image_area.x as f64 && y >= image_area.y as f64 && x < image_area.x as f64 + image_area.width as f64 && y < image_area.y as f64 + image_area.height as f64
        })
    }

    /// A press or release of the button that starts `kind` of drag; a drag starts only over
    /// the image (Shift turns a left-button orbit into a pan).
    pub fn drag_button(&mut self, state: ElementState, kind: Drag, image_area: PixelRect) {
        let kind = if kind == Drag::Orbit && self.modifiers.shift_key() { Drag::Pan } else { kind };
        self.drag = (state == ElementState::Pressed && self.over_image(image_area)).then_some(kind);
    }

    /// The cursor moved: returns the drag and its motion in pixels, if dragging.
    pub fn cursor_moved(&mut self, position: PhysicalPosition<f64>) -> Option<(Drag, f32, f32)> {
        let drag = match (self.drag, self.cursor) {
            (Some(kind), Some(last)) => Some((kind, (position.x - last.x) as f32, (position.y - last.y) as f32)),
            _ => None,
        };
        self.cursor = Some(position);
        drag
    }

    /// A raw button event (winit's device events). X11 reports a wheel notch from a device
    /// without smooth-scroll axes (and from XTEST, as xdotool sends) as a press and a release
    /// of button 4-7, and winit turns both into a wheel event: one notch, two steps. The raw
    /// release comes just before its echo, so that echo is dropped. Smooth-scrolling mice send
    /// no raw wheel buttons (theirs are flagged emulated and not reported), nor does Wayland.
    pub fn raw_button(&mut self, button: u32, state: ElementState) {
        if (4..=7).contains(&button) {
            self.wheel_release_echo = state == ElementState::Released;
        }
    }

    /// Wheel notches to zoom by (positive = closer), when the wheel turned over the image.
    pub fn wheel(&mut self, delta: MouseScrollDelta, image_area: PixelRect) -> Option<f32> {
        if std::mem::take(&mut self.wheel_release_echo) && matches!(delta, MouseScrollDelta::LineDelta(..)) {
            return None;
        }
        if !self.over_image(image_area) {
            return None;
        }
        Some(match delta {
            MouseScrollDelta::LineDelta(_, y) => y,
            MouseScrollDelta::PixelDelta(p) => (p.y / PIXELS_PER_NOTCH) as f32,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const IMAGE: PixelRect = PixelRect { x: 300, y: 0, width: 500, height: 400 };

    #[test]
    fn the_wheel_over_the_panel_does_not_zoom() {
        let mut input = Input::default();
        assert_eq!(input.wheel(MouseScrollDelta::LineDelta(0.0, 1.0), IMAGE), None, "no cursor yet");
        input.cursor_moved(PhysicalPosition::new(100.0, 100.0));
        assert_eq!(input.wheel(MouseScrollDelta::LineDelta(0.0, 1.0), IMAGE), None, "over the panel");
        input.cursor_moved(PhysicalPosition::new(400.0, 100.0));
        assert_eq!(input.wheel(MouseScrollDelta::LineDelta(0.0, 1.0), IMAGE), Some(1.0));
        assert_eq!(input.wheel(MouseScrollDelta::PixelDelta(PhysicalPosition::new(0.0, -80.0)), IMAGE), Some(-2.0));
    }

    #[test]
    fn a_wheel_buttons_release_echo_is_one_notch_not_two() {
        let mut input = Input::default();
        input.cursor_moved(PhysicalPosition::new(400.0, 100.0));
        // X11 without smooth scrolling: raw press, wheel, raw release, wheel (the echo).
        let mut steps = 0.0;
        for _ in 0..3 {
            input.raw_button(4, ElementState::Pressed);
            steps += input.wheel(MouseScrollDelta::LineDelta(0.0, 1.0), IMAGE).unwrap_or(0.0);
            input.raw_button(4, ElementState::Released);
            steps += input.wheel(MouseScrollDelta::LineDelta(0.0, 1.0), IMAGE).unwrap_or(0.0);
        }
        assert_eq!(steps, 3.0);
        // Smooth scrolling (and Wayland): wheel events alone, each a notch.
        assert_eq!(input.wheel(MouseScrollDelta::LineDelta(0.0, 1.0), IMAGE), Some(1.0));
        assert_eq!(input.wheel(MouseScrollDelta::LineDelta(0.0, 1.0), IMAGE), Some(1.0));
        // Other buttons leave the wheel alone.
        input.raw_button(1, ElementState::Released);
        assert_eq!(input.wheel(MouseScrollDelta::LineDelta(0.0, -1.0), IMAGE), Some(-1.0));
    }

    #[test]
    fn drags_start_over_the_image_only() {
        let mut input = Input::default();
        input.cursor_moved(PhysicalPosition::new(100.0, 100.0));
        input.drag_button(ElementState::Pressed, Drag::Orbit, IMAGE);
        assert_eq!(input.drag, None);
        input.cursor_moved(PhysicalPosition::new(400.0, 100.0));
        input.drag_button(ElementState::Pressed, Drag::Orbit, IMAGE);
        assert_eq!(input.cursor_moved(PhysicalPosition::new(410.0, 95.0)), Some((Drag::Orbit, 10.0, -5.0)));
        input.drag_button(ElementState::Released, Drag::Orbit, IMAGE);
        assert_eq!(input.cursor_moved(PhysicalPosition::new(420.0, 95.0)), None);
        // Shift with the left button, or the middle button: pan.
        input.modifiers = ModifiersState::SHIFT;
        input.drag_button(ElementState::Pressed, Drag::Orbit, IMAGE);
        assert_eq!(input.cursor_moved(PhysicalPosition::new(421.0, 95.0)), Some((Drag::Pan, 1.0, 0.0)));
        input.modifiers = ModifiersState::empty();
        input.drag_button(ElementState::Pressed, Drag::Pan, IMAGE);
        assert_eq!(input.drag, Some(Drag::Pan));
    }
}
