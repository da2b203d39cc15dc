//! The input cutting and the camera controls' state, with events fed as winit and egui-winit
//! would.

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

fn no_key(_: &egui::Event) -> Cut {
    Cut::No
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
    let opens_dialog = |e: &egui::Event| focus_cut(e, false, false);
    let opens_field = |e: &egui::Event| focus_cut(e, true, false);

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
    assert_eq!(events.len(), 1, "its text ends this frame's egui input: the press waits");
    let mut next = held;
    let (keys, held) = input.frame_keys(&mut next, no_key);
    assert!(keys.is_empty());
    assert_eq!(next, [button(true)], "the next frame's egui input is the press");
    assert_eq!(held, [button(false), egui::Event::Text("m".into()), egui::Event::Text("-".into())]);

    // The release ends the frame after (the field it focuses gets the keys after it)...
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
fn text_typed_before_a_click_reaches_egui_a_frame_before_the_click() {
    // A name typed into the model field and Load clicked at once, at a few fps: the press
    // outside the field would take its focus before the field read the text.
    let mut input = Input::default();
    let mut events = Vec::new();
    type_keys(&mut input, &mut events, &[(KeyCode::KeyK, "k"), (KeyCode::KeyN, "n")]);
    events.extend([button(true), button(false)]);
    let (keys, held) = input.frame_keys(&mut events, no_key);
    assert_eq!(codes(&keys), [KeyCode::KeyK, KeyCode::KeyN]);
    assert_eq!(events, [egui::Event::Text("k".into()), egui::Event::Text("n".into())]);
    assert_eq!(held, [button(true), button(false)]);
    // The click then reaches egui as a press and a release a frame apart, as any quick one.
    let mut next = held;
    let (_, held) = input.frame_keys(&mut next, no_key);
    assert_eq!((next, held), (vec![button(true)], vec![button(false)]));
}

#[test]
fn a_press_and_its_release_in_one_frame_reach_egui_in_two() {
    // A quick click on a slider's track at a few fps: egui sees the press alone (the
    // slider is dragged to the pointer), the release and what follows a frame later.
    let mut input = Input::default();
    let moved = egui::Event::PointerMoved(egui::pos2(1.0, 2.0));
    let mut events = vec![moved.clone(), button(true), moved.clone(), button(false), moved.clone()];
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
    assert_eq!(frames, [1, 1, 1, 1, 1, 1], "press | release | a | press | release | b");
    assert_eq!(
        keys_by_frame,
        [vec![], vec![], vec![KeyCode::KeyA], vec![], vec![], vec![KeyCode::KeyB]]
    );
}

#[test]
fn the_wheel_over_the_panel_does_not_zoom() {
    let mut input = Input::default();
    assert_eq!(input.wheel(MouseScrollDelta::LineDelta(0.0, 1.0), IMAGE), None, "no cursor yet");
    input.cursor_moved(PhysicalPosition::new(100.0, 100.0));
    assert_eq!(input.wheel(MouseScrollDelta::LineDelta(0.0, 1.0), IMAGE), None, "over the panel");
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
    assert_eq!(input.cursor_moved(PhysicalPosition::new(421.0, 95.0)), Some((Drag::Pan, 1.0, 0.0)));
    input.modifiers = ModifiersState::empty();
    input.drag_button(ElementState::Pressed, Drag::Pan, IMAGE);
    assert_eq!(input.drag, Some(Drag::Pan));
}

/// The tool's loop at one frame every `frame` seconds: `arrivals` are events as winit
/// delivers them, with their times; the pass of the frame that starts at `k * frame` takes
/// what the last pass held and what arrived since. `show` runs each pass's egui.
fn slow_frames(
    frame: f64,
    passes: usize,
    arrivals: &[(f64, egui::Event)],
    cut_at: impl Fn(usize, &egui::Event) -> Cut,
    mut show: impl FnMut(egui::RawInput, Vec<KeyPress>),
) {
    let mut input = Input::default();
    let (mut pending, mut next) = (Vec::new(), 0);
    for k in 1..=passes {
        let now = k as f64 * frame;
        while let Some((time, event)) = arrivals.get(next).filter(|(time, _)| *time < now) {
            pending.push(event.clone());
            input.events_arrived(pending.len(), *time);
            next += 1;
        }
        let mut raw = egui::RawInput { events: std::mem::take(&mut pending), ..Default::default() };
        let (keys, held) = input.take_pass(&mut raw, now, |e| cut_at(k, e));
        pending = held;
        show(raw, keys);
    }
}

/// What a pass of the test's panel (a button over a checkbox) saw.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Seen {
    clicked: bool,
    double_clicked: bool,
    button: egui::Rect,
    checkbox: egui::Rect,
}

fn panel(ctx: &egui::Context, raw: egui::RawInput, checked: &mut bool) -> Seen {
    let nothing = egui::Rect::NOTHING;
    let mut seen =
        Seen { clicked: false, double_clicked: false, button: nothing, checkbox: nothing };
    // No renderer here: the font texture's upload is dropped on purpose.
    ctx.run_ui(raw, |ui| {
        let button = ui.button("smooth");
        seen.checkbox = ui.checkbox(checked, "accumulate").rect;
        seen.clicked = button.clicked();
        seen.double_clicked = button.double_clicked();
        seen.button = button.rect;
    })
    .textures_delta
    .clear();
    seen
}

fn press_at(pos: egui::Pos2, pressed: bool) -> egui::Event {
    egui::Event::PointerButton {
        pos,
        button: egui::PointerButton::Primary,
        pressed,
        modifiers: Default::default(),
    }
}

/// A context that has laid the panel out once (at time 0), and where its widgets are.
fn laid_out() -> (egui::Context, Seen) {
    let ctx = egui::Context::default();
    let raw = egui::RawInput { time: Some(0.0), ..Default::default() };
    let seen = panel(&ctx, raw, &mut false);
    (ctx, seen)
}

#[test]
fn a_click_counts_when_frames_take_two_seconds() {
    // A 0.1 s click on the checkbox, then one on the button, during 2 s frames: each press
    // and release reach egui in passes 2 s apart, but at the times they arrived.
    let (ctx, at) = laid_out();
    let (check, button) = (at.checkbox.center(), at.button.center());
    let arrivals = [
        (0.5, egui::Event::PointerMoved(check)),
        (0.5, press_at(check, true)),
        (0.6, press_at(check, false)),
        (2.5, egui::Event::PointerMoved(button)),
        (2.5, press_at(button, true)),
        (2.6, press_at(button, false)),
    ];
    let (mut checked, mut seen) = (false, Vec::new());
    slow_frames(
        2.0,
        6,
        &arrivals,
        |_, _| Cut::No,
        |raw, _| {
            seen.push((raw.time, panel(&ctx, raw, &mut checked).clicked));
        },
    );
    assert!(checked, "the click on the checkbox was lost");
    let clicks: Vec<_> = seen.iter().map(|s| s.1).collect();
    assert_eq!(clicks, [false, false, false, true, false, false], "the button's click was lost");
    let times: Vec<_> = seen.iter().map(|s| s.0.unwrap()).collect();
    assert_eq!(times, [0.5, 0.6, 2.5, 2.6, 10.0, 12.0], "each pass has its events' time");
}

#[test]
fn a_double_click_counts_when_frames_take_two_seconds() {
    let (ctx, at) = laid_out();
    let b = at.button.center();
    let arrivals = [
        (0.5, press_at(b, true)),
        (0.55, press_at(b, false)),
        (0.7, press_at(b, true)),
        (0.75, press_at(b, false)),
    ];
    let mut double = Vec::new();
    slow_frames(
        2.0,
        5,
        &arrivals,
        |_, _| Cut::No,
        |raw, _| {
            double.push(panel(&ctx, raw, &mut false).double_clicked);
        },
    );
    assert_eq!(double, [false, false, false, true, false], "the double click was lost");
}

#[test]
fn pass_times_never_go_back() {
    // A pass without events takes the time it runs; events that arrived before it (none
    // can, but a clock may step) are not given an earlier time.
    let mut input = Input::default();
    let mut raw = egui::RawInput::default();
    input.take_pass(&mut raw, 3.0, no_key);
    assert_eq!(raw.time, Some(3.0));
    let mut raw = egui::RawInput { events: vec![button(true)], ..Default::default() };
    input.events_arrived(1, 2.0);
    input.take_pass(&mut raw, 4.0, no_key);
    assert_eq!(raw.time, Some(3.0));
}

#[test]
fn ctrl_o_a_path_and_enter_in_one_burst_reach_the_dialog_in_four_frames() {
    // All typed within one slow frame: Ctrl+O opens the dialog, `/` its path field, the
    // text must be in the field before the dialog reads Enter (it does so before its
    // fields run), so Enter comes a frame after the text.
    let none = egui::Modifiers::NONE;
    let mut input = Input::default();
    let mut events = Vec::new();
    press_keys(
        &mut input,
        &mut events,
        &[
            (KeyCode::KeyO, egui::Key::O, egui::Modifiers::CTRL, ""),
            (KeyCode::Slash, egui::Key::Slash, none, "/"),
            (KeyCode::KeyT, egui::Key::T, none, "t"),
            (KeyCode::Enter, egui::Key::Enter, none, ""),
        ],
    );
    let mut frames = Vec::new();
    let mut keys_by_frame = Vec::new();
    let mut dialog_open = false;
    while !events.is_empty() {
        let (keys, held) = input.frame_keys(&mut events, |e| focus_cut(e, dialog_open, false));
        dialog_open |= keys.iter().any(|k| k.code == KeyCode::KeyO);
        frames.push(std::mem::replace(&mut events, held));
        keys_by_frame.push(codes(&keys));
    }
    assert_eq!(
        frames,
        [
            vec![key(egui::Key::O, egui::Modifiers::CTRL)],
            vec![key(egui::Key::Slash, none)],
            vec![
                egui::Event::Text("/".into()),
                key(egui::Key::T, none),
                egui::Event::Text("t".into())
            ],
            vec![key(egui::Key::Enter, none)],
        ]
    );
    assert_eq!(
        keys_by_frame,
        [vec![KeyCode::KeyO], vec![], vec![KeyCode::Slash, KeyCode::KeyT], vec![KeyCode::Enter]]
    );
    // Enter with nothing typed before it in its frame is not cut, nor outside the dialog.
    let mut events = vec![key(egui::Key::Enter, none)];
    assert!(input.frame_keys(&mut events, |e| focus_cut(e, true, false)).1.is_empty());
    let mut events = vec![egui::Event::Text("t".into()), key(egui::Key::Enter, none)];
    assert!(input.frame_keys(&mut events, |e| focus_cut(e, false, false)).1.is_empty());
}

/// Issue #43, point 4: `xdotool type "path\n"` types its line end as the Linefeed keysym,
/// which winit names no key; it is an Enter for egui (the Open dialog's typed path opens).
#[test]
fn a_typed_line_end_that_winit_names_no_key_is_an_enter() {
    use winit::keyboard::{Key, NativeKey};
    let none = egui::Modifiers::NONE;
    let linefeed = Key::Unidentified(NativeKey::Xkb(0xff0a));
    let enter = line_end_as_enter(&linefeed, Some("\n"), true, none).expect("an Enter");
    assert!(matches!(enter[0], egui::Event::Key { key: egui::Key::Enter, pressed: true, .. }));
    assert!(matches!(enter[1], egui::Event::Key { key: egui::Key::Enter, pressed: false, .. }));
    // Its release adds nothing; a real Return is egui-winit's own Enter, and letters are text.
    assert!(line_end_as_enter(&linefeed, Some("\n"), false, none).is_none());
    let ret = Key::Named(winit::keyboard::NamedKey::Enter);
    assert!(line_end_as_enter(&ret, Some("\r"), true, none).is_none());
    assert!(line_end_as_enter(&Key::Character("a".into()), Some("a"), true, none).is_none());
}
