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

    /// The key presses of the frame whose egui input is `events`, and where that input ends:
    /// before the first release of a button pressed earlier in `events`, after the first
    /// pointer release that anything follows, or after the first event that `moves_focus`
    /// that a key or text event follows, whichever comes first. The events after the cut
    /// are taken out of `events` and returned, to go first into the next frame's input; the
    /// presses among them wait for that frame.
    pub(crate) fn frame_keys(
        &mut self,
        events: &mut Vec<egui::Event>,
        moves_focus: impl Fn(&egui::Event) -> bool,
    ) -> (Vec<KeyPress>, Vec<egui::Event>) {
        let is_release =
            |e: &egui::Event| matches!(e, egui::Event::PointerButton { pressed: false, .. });
        let is_typing =
            |e: &egui::Event| matches!(e, egui::Event::Key { .. } | egui::Event::Text(_));
        let after_release =
            events.iter().position(is_release).map(|i| i + 1).filter(|&cut| cut < events.len());
        let after_focus_move = events
            .iter()
            .position(moves_focus)
            .map(|i| i + 1)
            .filter(|&cut| events[cut..].iter().any(is_typing));
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
        let Some(cut) =
            [after_release, after_focus_move, release_of_a_press].into_iter().flatten().min()
        else {
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
mod tests {
    use super::*;

    const IMAGE: PixelRect = PixelRect { x: 300, y: 0, width: 500, height: 400 };

    fn button(pressed: bool) -> egui::Event {
        egui::Event::PointerButton {
            pos: egui::pos2(10.0, 10.0),
            button: egui::PointerButton::Primary,
            pressed,
            modifiers: Default::default(),
        }
    }

    /// Feed `typed` (a key's code and its text) as winit and egui-winit would.
    fn type_keys(input: &mut Input, events: &mut Vec<egui::Event>, typed: &[(KeyCode, &str)]) {
        for &(code, text) in typed {
            events.push(egui::Event::Text(text.into()));
            input.key_pressed(code, false, events.len());
        }
    }

    fn no_key(_: &egui::Event) -> bool {
        false
    }

    fn key(key: egui::Key, modifiers: egui::Modifiers) -> egui::Event {
        egui::Event::Key { key, physical_key: None, pressed: true, repeat: false, modifiers }
    }

    /// Feed keys as winit and egui-winit would: the key's event, then its text if any.
    fn press_keys(
        input: &mut Input,
        events: &mut Vec<egui::Event>,
        typed: &[(KeyCode, egui::Key, egui::Modifiers, &str)],
    ) {
        for &(code, k, modifiers, text) in typed {
            events.push(key(k, modifiers));
            if !text.is_empty() {
                events.push(egui::Event::Text(text.into()));
            }
            input.key_pressed(code, false, events.len());
        }
    }

    #[test]
    fn a_key_that_moves_the_focus_keeps_its_text_and_the_keys_after_for_the_next_frame() {
        let mut input = Input::default();
        let mut events = Vec::new();
        let none = egui::Modifiers::NONE;
        let ctrl = egui::Modifiers::CTRL;
        press_keys(
            &mut input,
            &mut events,
            &[
                (KeyCode::KeyO, egui::Key::O, ctrl, ""),
                (KeyCode::Slash, egui::Key::Slash, none, "/"),
                (KeyCode::KeyT, egui::Key::T, none, "t"),
            ],
        );
        let opens_dialog = |e: &egui::Event| matches!(e, egui::Event::Key { key: egui::Key::O, modifiers, .. } if modifiers.ctrl);
        let opens_field =
            |e: &egui::Event| matches!(e, egui::Event::Key { key: egui::Key::Slash, .. });

        // Ctrl+O is this frame's; "/" and "t" wait for the frame that shows the dialog.
        let (keys, mut held) = input.frame_keys(&mut events, opens_dialog);
        assert_eq!(codes(&keys), [KeyCode::KeyO]);
        assert_eq!(events, [key(egui::Key::O, ctrl)]);
        // "/" opens the field: its text and the "t" after wait for the field's frame.
        let (keys, rest) = input.frame_keys(&mut held, opens_field);
        assert_eq!(held, [key(egui::Key::Slash, none)]);
        assert!(keys.is_empty(), "the press of / ends with its text, which waits");
        assert_eq!(
            rest,
            [egui::Event::Text("/".into()), key(egui::Key::T, none), egui::Event::Text("t".into())]
        );
        let mut rest = rest;
        let (keys, held) = input.frame_keys(&mut rest, opens_field);
        assert_eq!(codes(&keys), [KeyCode::Slash, KeyCode::KeyT]);
        assert!(held.is_empty() && rest.len() == 3);
    }

    fn codes(keys: &[KeyPress]) -> Vec<KeyCode> {
        keys.iter().map(|k| k.code).collect()
    }

    #[test]
    fn keys_typed_right_after_a_click_wait_for_the_next_frame_with_their_events() {
        let mut input = Input::default();
        let mut events = Vec::new();
        type_keys(&mut input, &mut events, &[(KeyCode::Equal, "=")]);
        events.extend([button(true), button(false)]);
        type_keys(&mut input, &mut events, &[(KeyCode::KeyM, "m"), (KeyCode::Minus, "-")]);

        let (keys, held) = input.frame_keys(&mut events, no_key);
        assert_eq!(codes(&keys), [KeyCode::Equal], "only the key before the click is this frame's");
        assert_eq!(events.len(), 2, "this frame's egui input ends with the press");
        assert_eq!(
            held,
            [button(false), egui::Event::Text("m".into()), egui::Event::Text("-".into())]
        );

        // The release ends the next frame (the field it focuses gets the keys after it)...
        let mut next = held;
        let (keys, held) = input.frame_keys(&mut next, no_key);
        assert!(keys.is_empty());
        assert_eq!(next, [button(false)]);
        assert_eq!(held, [egui::Event::Text("m".into()), egui::Event::Text("-".into())]);

        // ...and the one after starts with what was held; a key pressed meanwhile follows.
        let mut next = held;
        type_keys(&mut input, &mut next, &[(KeyCode::KeyS, "s")]);
        let (keys, held) = input.frame_keys(&mut next, no_key);
        assert_eq!(codes(&keys), [KeyCode::KeyM, KeyCode::Minus, KeyCode::KeyS]);
        assert!(held.is_empty() && next.len() == 3);
    }

    #[test]
    fn a_press_and_its_release_in_one_frame_reach_egui_in_two() {
        // A quick click on a slider's track at a few fps: egui sees the press alone (the
        // slider is dragged to the pointer), the release and what follows a frame later.
        let mut input = Input::default();
        let moved = egui::Event::PointerMoved(egui::pos2(1.0, 2.0));
        let mut events =
            vec![moved.clone(), button(true), moved.clone(), button(false), moved.clone()];
        let (keys, held) = input.frame_keys(&mut events, no_key);
        assert!(keys.is_empty());
        assert_eq!(events, [moved.clone(), button(true), moved.clone()]);
        assert_eq!(held, [button(false), moved.clone()]);
        // The release ends its frame: a slider dragged until it takes the pointer's last
        // position in that frame, which must not be where the pointer went next.
        let mut next = held;
        let (_, held) = input.frame_keys(&mut next, no_key);
        assert_eq!(next, [button(false)]);
        assert_eq!(held, std::slice::from_ref(&moved));
        // A release last in its frame is no cut, nor is the release of another button than
        // the one pressed.
        let mut events = vec![moved.clone(), button(false)];
        let (_, held) = input.frame_keys(&mut events, no_key);
        assert!(held.is_empty() && events.len() == 2);
        let other = egui::Event::PointerButton {
            pos: egui::pos2(10.0, 10.0),
            button: egui::PointerButton::Secondary,
            pressed: false,
            modifiers: Default::default(),
        };
        let mut events = vec![button(true), other];
        let (_, held) = input.frame_keys(&mut events, no_key);
        assert!(held.is_empty() && events.len() == 2);
    }

    #[test]
    fn a_click_then_a_click_elsewhere_reach_egui_in_four_frames() {
        // A slider clicked, then a text field straight after, in one frame's input: the
        // slider's last frame must not hold the move to the field.
        let mut input = Input::default();
        let at = |x: f32| egui::Event::PointerMoved(egui::pos2(x, 0.0));
        let mut pending =
            vec![at(150.0), button(true), button(false), at(180.0), button(true), button(false)];
        let mut frames = Vec::new();
        while !pending.is_empty() {
            let (_, held) = input.frame_keys(&mut pending, no_key);
            frames.push(std::mem::replace(&mut pending, held));
        }
        assert_eq!(
            frames,
            [
                vec![at(150.0), button(true)],
                vec![button(false)],
                vec![at(180.0), button(true)],
                vec![button(false)]
            ]
        );
    }

    #[test]
    fn a_press_and_the_drag_after_it_stay_in_one_frame() {
        let mut input = Input::default();
        let mut events = vec![
            button(true),
            egui::Event::PointerMoved(egui::pos2(1.0, 2.0)),
            egui::Event::PointerMoved(egui::pos2(3.0, 2.0)),
        ];
        let (_, held) = input.frame_keys(&mut events, no_key);
        assert!(held.is_empty() && events.len() == 3);
    }

    #[test]
    fn a_frame_without_a_release_before_its_end_takes_everything() {
        let mut input = Input::default();
        let mut events = vec![egui::Event::PointerMoved(egui::pos2(1.0, 2.0)), button(false)];
        let (keys, held) = input.frame_keys(&mut events, no_key);
        assert!(keys.is_empty() && held.is_empty() && events.len() == 2);

        // Keys and no click: all this frame's, in order.
        let mut events = Vec::new();
        type_keys(&mut input, &mut events, &[(KeyCode::PageUp, ""), (KeyCode::KeyC, "c")]);
        let (keys, held) = input.frame_keys(&mut events, no_key);
        assert_eq!(codes(&keys), [KeyCode::PageUp, KeyCode::KeyC]);
        assert!(held.is_empty());
    }

    #[test]
    fn each_click_with_typing_after_it_starts_a_frame_of_its_own() {
        let mut input = Input::default();
        let mut events = vec![button(true), button(false)];
        type_keys(&mut input, &mut events, &[(KeyCode::KeyA, "a")]);
        events.extend([button(true), button(false)]);
        type_keys(&mut input, &mut events, &[(KeyCode::KeyB, "b")]);

        // Each press, each release and the keys after a release get frames of their own.
        let mut frames = Vec::new();
        let mut keys_by_frame = Vec::new();
        let mut pending = events;
        while !pending.is_empty() {
            let (keys, held) = input.frame_keys(&mut pending, no_key);
            frames.push(pending.len());
            keys_by_frame.push(codes(&keys));
            pending = held;
        }
        assert_eq!(frames, [1, 1, 2, 1, 1], "press | release | a, press | release | b");
        assert_eq!(
            keys_by_frame,
            [vec![], vec![], vec![KeyCode::KeyA], vec![], vec![KeyCode::KeyB]]
        );
    }

    #[test]
    fn the_wheel_over_the_panel_does_not_zoom() {
        let mut input = Input::default();
        assert_eq!(
            input.wheel(MouseScrollDelta::LineDelta(0.0, 1.0), IMAGE),
            None,
            "no cursor yet"
        );
        input.cursor_moved(PhysicalPosition::new(100.0, 100.0));
        assert_eq!(
            input.wheel(MouseScrollDelta::LineDelta(0.0, 1.0), IMAGE),
            None,
            "over the panel"
        );
        input.cursor_moved(PhysicalPosition::new(400.0, 100.0));
        assert_eq!(input.wheel(MouseScrollDelta::LineDelta(0.0, 1.0), IMAGE), Some(1.0));
        assert_eq!(
            input.wheel(MouseScrollDelta::PixelDelta(PhysicalPosition::new(0.0, -80.0)), IMAGE),
            Some(-2.0)
        );
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
        assert_eq!(
            input.cursor_moved(PhysicalPosition::new(410.0, 95.0)),
            Some((Drag::Orbit, 10.0, -5.0))
        );
        input.drag_button(ElementState::Released, Drag::Orbit, IMAGE);
        assert_eq!(input.cursor_moved(PhysicalPosition::new(420.0, 95.0)), None);
        // Shift with the left button, or the middle button: pan.
        input.modifiers = ModifiersState::SHIFT;
        input.drag_button(ElementState::Pressed, Drag::Orbit, IMAGE);
        assert_eq!(
            input.cursor_moved(PhysicalPosition::new(421.0, 95.0)),
            Some((Drag::Pan, 1.0, 0.0))
        );
        input.modifiers = ModifiersState::empty();
        input.drag_button(ElementState::Pressed, Drag::Pan, IMAGE);
        assert_eq!(input.drag, Some(Drag::Pan));
    }
}
