//! Mouse and keyboard state between window events: the camera drag, the cursor, the
//! modifier keys. Whether the pointer is over the panel is decided from the cursor of the
//! latest cursor event against the image area of the latest frame, not from egui's view
//! of the last frame (which lags by a frame, a long time at a few fps).
//!
//! Key presses wait for the frame: whether a key is the tool's shortcut or text for an
//! egui field depends on the focus *after* the clicks before it, which egui decides only
//! when it runs. So each press is queued with its place among egui's events, and a frame
//! takes the presses up to the first click that has keys after it; egui's events after
//! that click are held back for the next frame, so the field focused by it gets them.
//! A key that moves the focus is cut after the same way (the caller says which: Ctrl+O
//! opening the Open dialog, `/` opening the dialog's path field), so the keys typed after
//! it in one burst reach the dialog and its field, not a frame that had neither.
//!
//! Pointer buttons cut frames too, so that egui sees each press and each release in a frame
//! of its own, as it would at 60 fps:
//! - a button pressed and released within one frame (an ordinary click at a few fps) is
//!   cut between the two: egui takes a press and release in one frame for a click and never
//!   for a drag, so a slider (which senses drags only) ignored a click on its track;
//! - a frame ends with a release: egui gives a drag that ends in a frame the pointer's last
//!   position in it, so a slider clicked just before another widget took that widget's
//!   position as its value.
//!
//! Each pass of egui is given the time its events arrived, not the time it runs: egui takes
//! a press and release further apart than `max_click_duration` (0.8 s) for no click and
//! measures double clicks the same way, so with passes a slow frame apart (seconds at 512²
//! on a CPU Vulkan) and a press and its release always in two, no click would count.

use std::time::Instant;

use winit::dpi::PhysicalPosition;
use winit::event::{ElementState, MouseScrollDelta};
use winit::keyboard::{KeyCode, ModifiersState};

use crate::gpu::present::PixelRect;

/// Pixels of a touchpad's smooth scroll that make one wheel notch.
const PIXELS_PER_NOTCH: f64 = 40.0;

/// What a mouse drag over the image does to the camera.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Drag {
    /// Left button: turn around the target.
    Orbit,
    /// Middle button, or Shift with the left: slide the view.
    Pan,
    /// Left button on the split view's line: move the line (the camera stays).
    Split,
}

/// A key press as winit reported it, waiting for the frame that decides who gets it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct KeyPress {
    pub(crate) code: KeyCode,
    pub(crate) shift: bool,
    pub(crate) ctrl: bool,
    /// A held key's auto-repeat.
    pub(crate) repeat: bool,
    /// How many of egui's events of the frame came before or with it.
    at: usize,
}

/// Where a frame's input is cut at an event (see [`Input::frame_keys`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Cut {
    /// No cut.
    No,
    /// After the event when typing follows it: it moves the focus, so the keys after it go
    /// to a frame whose focus it has moved.
    After,
    /// Before the event when typing comes before it: it acts before the fields run (the Open
    /// dialog's Enter reads its path field first), so the text must reach the field a frame
    /// earlier.
    Before,
}

/// Where the tool cuts the input at `event`: after Ctrl+O (the keys typed after it are the
/// Open dialog's) and, in the Open dialog with no field focused, after `/` (its path field takes
/// the focus at the end of the frame, after the field ran); before the dialog's Enter, which
/// it reads before its fields take the frame's text.
pub(crate) fn focus_cut(event: &egui::Event, dialog_open: bool, egui_wants_keys: bool) -> Cut {
    let cut = match event {
        egui::Event::Key { key: egui::Key::O, pressed: true, modifiers, .. } => {
            modifiers.ctrl && !dialog_open && !egui_wants_keys
        }
        egui::Event::Key { key: egui::Key::Slash, pressed: true, .. } => {
            dialog_open && !egui_wants_keys
        }
        egui::Event::Key { key: egui::Key::Enter, pressed: true, .. } if dialog_open => {
            return Cut::Before;
        }
        _ => false,
    };
    if cut {
        Cut::After
    } else {
        Cut::No
    }
}

/// A key press that typed a line end but that winit names no key: xdotool types "\n" as the
/// Linefeed keysym, which winit leaves unidentified, so egui saw no Enter and the Open
/// dialog's typed path waited (issue #43). It is an Enter for egui: returns the press and
/// release to add to egui's input.
pub(crate) fn line_end_as_enter(
    logical: &winit::keyboard::Key,
    text: Option<&str>,
    pressed: bool,
    modifiers: egui::Modifiers,
) -> Option<[egui::Event; 2]> {
    let unnamed = matches!(logical, winit::keyboard::Key::Unidentified(_))
        || matches!(logical, winit::keyboard::Key::Character(c) if c == "\n" || c == "\r");
    let line_end = matches!(text, Some("\n" | "\r"));
    let key = |pressed| egui::Event::Key {
        key: egui::Key::Enter,
        physical_key: None,
        pressed,
        repeat: false,
        modifiers,
    };
    (pressed && unnamed && line_end).then(|| [key(true), key(false)])
}

/// Log (at trace level) the keys and text of a pass, to follow where typing goes at a few
/// frames a second (`RUST_LOG=meshtracer=trace`).
pub(crate) fn trace_pass(events: &[egui::Event], dialog_open: bool, egui_wants_keys: bool) {
    if !log::log_enabled!(log::Level::Trace) {
        return;
    }
    let shown: Vec<String> = events
        .iter()
        .filter_map(|e| match e {
            egui::Event::Key { key, pressed, .. } => {
                Some(format!("{key:?}{}", if *pressed { " down" } else { " up" }))
            }
            egui::Event::Text(t) => Some(format!("{t:?}")),
            _ => None,
        })
        .collect();
    log::trace!(
        "pass (dialog {dialog_open}, egui wants keys {egui_wants_keys}): {}",
        shown.join(" ")
    );
}

/// The clock the passes' times are read from, started with the input.
struct Clock(Instant);

impl Default for Clock {
    fn default() -> Self {
        Self(Instant::now())
    }
}

/// The input state the window events leave behind.
#[derive(Default)]
pub(crate) struct Input {
    /// A drag that began over the image, moving the camera.
    pub(crate) drag: Option<Drag>,
    /// The cursor of the latest cursor event, physical pixels; None outside the window.
    pub(crate) cursor: Option<PhysicalPosition<f64>>,
    pub(crate) modifiers: ModifiersState,
    /// The window is hidden or minimized: nothing is drawn.
    pub(crate) occluded: bool,
    /// The next wheel event echoes the release of a wheel button (see [`Input::raw_button`]).
    wheel_release_echo: bool,
    /// Key presses since the last frame took its own, in order.
    keys: Vec<KeyPress>,
    /// When each of egui's pending events arrived (seconds on `clock`), in their order.
    arrivals: Vec<f64>,
    /// The time the last pass was given: passes never go back in time.
    last_pass: f64,
    clock: Clock,
}

impl Input {
    /// The cursor is over the traced image (not over the panel, not outside the window).
    pub(crate) fn over_image(&self, image_area: PixelRect) -> bool {
        self.cursor.is_some_and(|c| {
            let (x, y) = (c.x, c.y);
            x >= image_area.x as f64
                && y >= image_area.y as f64
                && x < image_area.x as f64 + image_area.width as f64
                && y < image_area.y as f64 + image_area.height as f64
        })
    }

    /// A press or release of the button that starts `kind` of drag; a drag starts only over
    /// the image (Shift turns a left-button orbit into a pan).
    pub(crate) fn drag_button(&mut self, state: ElementState, kind: Drag, image_area: PixelRect) {
        let kind = if kind == Drag::Orbit && self.modifiers.shift_key() { Drag::Pan } else { kind };
        self.drag = (state == ElementState::Pressed && self.over_image(image_area)).then_some(kind);
    }

    /// The cursor moved: returns the drag and its motion in pixels, if dragging.
    pub(crate) fn cursor_moved(
        &mut self,
        position: PhysicalPosition<f64>,
    ) -> Option<(Drag, f32, f32)> {
        let drag = match (self.drag, self.cursor) {
            (Some(kind), Some(last)) => {
                Some((kind, (position.x - last.x) as f32, (position.y - last.y) as f32))
            }
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
    pub(crate) fn raw_button(&mut self, button: u32, state: ElementState) {
        if (4..=7).contains(&button) {
            self.wheel_release_echo = state == ElementState::Released;
        }
    }

    /// A key was pressed; `egui_events` is the number of events egui's input holds after
    /// it (egui-winit has just added the press's own).
    pub(crate) fn key_pressed(&mut self, code: KeyCode, repeat: bool, egui_events: usize) {
        let (shift, ctrl) = (self.modifiers.shift_key(), self.modifiers.control_key());
        self.keys.push(KeyPress { code, shift, ctrl, repeat, at: egui_events });
    }

    /// Seconds since the input started: the clock of arrivals and of egui's passes.
    pub(crate) fn now(&self) -> f64 {
        self.clock.0.elapsed().as_secs_f64()
    }

    /// egui's pending input now holds `count` events: those not yet timed arrived at `time`
    /// (call after each window event, with [`Input::now`]).
    pub(crate) fn events_arrived(&mut self, count: usize, time: f64) {
        self.arrivals.resize(count, time);
    }

    /// Cut this frame's input `raw` as [`Input::frame_keys`] does and give it the time its
    /// last event arrived (`now` when it has none), so that egui measures the time between
    /// a press and its release, or two clicks, as the user made it, whatever the time
    /// between frames. Returns the frame's key presses and the events held for the next.
    pub(crate) fn take_pass(
        &mut self,
        raw: &mut egui::RawInput,
        now: f64,
        cut_at: impl Fn(&egui::Event) -> Cut,
    ) -> (Vec<KeyPress>, Vec<egui::Event>) {
        // Events that no window event timed (none today) arrived by now.
        self.arrivals.resize(raw.events.len(), now);
        let (keys, held) = self.frame_keys(&mut raw.events, cut_at);
        let waiting = self.arrivals.split_off(raw.events.len());
        let arrived = std::mem::replace(&mut self.arrivals, waiting);
        let time = arrived.last().copied().unwrap_or(now).max(self.last_pass);
        self.last_pass = time;
        raw.time = Some(time);
        (keys, held)
    }

    /// The key presses of the frame whose egui input is `events`, and where that input ends:
    /// before the first release of a button pressed earlier in `events`, after the first
    /// pointer release that anything follows, before the first pointer press that a key or
    /// text event comes before (a press outside a text field takes its focus before the
    /// field reads the frame's text: a name typed and Load clicked at once lost the name),
    /// after the first event cut [`Cut::After`] that a key or text event follows, or before
    /// the first event cut [`Cut::Before`] that one comes before, whichever comes first. The events after the cut are taken out of
    /// `events` and returned, to go first into the next frame's input; the presses among
    /// them wait for that frame.
    fn frame_keys(
        &mut self,
        events: &mut Vec<egui::Event>,
        cut_at: impl Fn(&egui::Event) -> Cut,
    ) -> (Vec<KeyPress>, Vec<egui::Event>) {
        let is_release =
            |e: &egui::Event| matches!(e, egui::Event::PointerButton { pressed: false, .. });
        let is_typing =
            |e: &egui::Event| matches!(e, egui::Event::Key { .. } | egui::Event::Text(_));
        let after_release =
            events.iter().position(is_release).map(|i| i + 1).filter(|&cut| cut < events.len());
        let after_focus_move = events
            .iter()
            .position(|e| cut_at(e) == Cut::After)
            .map(|i| i + 1)
            .filter(|&cut| events[cut..].iter().any(is_typing));
        let before_first_act = (1..events.len())
            .find(|&i| cut_at(&events[i]) == Cut::Before && events[..i].iter().any(is_typing));
        let is_press =
            |e: &egui::Event| matches!(e, egui::Event::PointerButton { pressed: true, .. });
        let press_after_typing =
            (1..events.len()).find(|&i| is_press(&events[i]) && events[..i].iter().any(is_typing));
        let pressed_before = |i: usize, released: egui::PointerButton| {
            events[..i].iter().any(|e| matches!(e, egui::Event::PointerButton { pressed: true, button, .. } if *button == released))
        };
        let release_of_a_press = events.iter().enumerate().find_map(|(i, e)| match e {
            egui::Event::PointerButton { pressed: false, button, .. }
                if pressed_before(i, *button) =>
            {
                Some(i)
            }
            _ => None,
        });
        let cuts = [
            after_release,
            after_focus_move,
            before_first_act,
            release_of_a_press,
            press_after_typing,
        ];
        let Some(cut) = cuts.into_iter().flatten().min() else {
            return (std::mem::take(&mut self.keys), Vec::new());
        };
        let held = events.split_off(cut);
        log::debug!(
            "{} input events after a press, a release or a focus move wait for the next frame",
            held.len()
        );
        // A press whose events end at the cut is this frame's (the key that moved the focus).
        let later = self.keys.iter().position(|k| k.at > cut).unwrap_or(self.keys.len());
        let mut waiting = self.keys.split_off(later);
        for key in &mut waiting {
            key.at -= cut;
        }
        (std::mem::replace(&mut self.keys, waiting), held)
    }

    /// Wheel notches to zoom by (positive = closer), when the wheel turned over the image.
    pub(crate) fn wheel(&mut self, delta: MouseScrollDelta, image_area: PixelRect) -> Option<f32> {
        if std::mem::take(&mut self.wheel_release_echo)
            && matches!(delta, MouseScrollDelta::LineDelta(..))
        {
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
#[path = "input_tests.rs"]
mod tests;
