//! The keyboard shortcuts, written once: each entry of [`SHORTCUTS`] holds the keys the
//! panel's Keys section shows, what they do in words, and the chords and effects that
//! [`Params::apply_key`] looks up.

use winit::keyboard::{KeyCode, KeyCode as K};

use crate::app::state::{CostMetric, Params, Resolution, ViewMode};
use crate::render_settings::{Accel, BLEND, BOUNCES, MODELS};

/// Something a key asks for besides a parameter change.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum KeyAction {
    /// The parameters changed (or nothing happened).
    None,
    /// Save the traced image (F12).
    ScreenshotTrace,
    /// Save the window as seen (Shift+F12).
    ScreenshotWindow,
    /// Frame the models (F): the tool knows where they are.
    FrameModel,
    /// Start a benchmark run of the panel's frame count.
    Benchmark,
    /// Open the file dialog for a model (Ctrl+O).
    OpenModel,
    /// Stop the model load in progress, keeping the model shown (Escape).
    CancelLoad,
    /// Quit the tool (Ctrl+Q).
    Quit,
}

/// Which modifiers a chord needs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Mods {
    /// No Ctrl, Shift or not. Other Ctrl chords are the system's (Ctrl+A select all,
    /// Ctrl+C copy, Ctrl+V paste, Ctrl+S save), not the plain keys' actions: Ctrl+A
    /// missing a text field switched the tracer to brute force.
    Plain,
    /// Ctrl held, Shift or not.
    Ctrl,
    /// Shift not held, Ctrl or not.
    NoShift,
    /// Shift held, Ctrl or not.
    Shift,
}

impl Mods {
    fn allow(self, shift: bool, ctrl: bool) -> bool {
        match self {
            Mods::Plain => !ctrl,
            Mods::Ctrl => ctrl,
            Mods::NoShift => !shift,
            Mods::Shift => shift,
        }
    }
}

/// What a chord does.
#[derive(Clone, Copy)]
pub(crate) enum Effect {
    /// Ask the tool for something it does (a screenshot, a dialog).
    Ask(KeyAction),
    /// Change the parameters, knowing what else the keys need.
    Change(fn(&mut Params, &mut KeyCx)),
}

/// What a change needs besides the parameters.
pub(crate) struct KeyCx<'a> {
    /// The resolution `M` goes back to.
    previous: &'a mut Resolution,
    /// The device has the vendor's ray tracing: else A skips it, as the panel greys it out.
    vendor: bool,
}

/// Keys that do one thing under the same modifiers.
#[derive(Clone, Copy)]
pub(crate) struct Chord {
    codes: &'static [KeyCode],
    mods: Mods,
    effect: Effect,
}

const fn ask(codes: &'static [KeyCode], mods: Mods, action: KeyAction) -> Chord {
    Chord { codes, mods, effect: Effect::Ask(action) }
}

const fn change(codes: &'static [KeyCode], change: fn(&mut Params, &mut KeyCx)) -> Chord {
    Chord { codes, mods: Mods::Plain, effect: Effect::Change(change) }
}

/// One line of the panel's Keys section and the chords behind it (none for the mouse's).
pub(crate) struct Shortcut {
    /// The keys as the panel names them ("PgUp / PgDn").
    pub(crate) keys: &'static str,
    /// What they do, in words.
    pub(crate) what: &'static str,
    chords: &'static [Chord],
}

const fn entry(keys: &'static str, what: &'static str, chords: &'static [Chord]) -> Shortcut {
    Shortcut { keys, what, chords }
}

/// Every shortcut, in the panel's order.
pub(crate) const SHORTCUTS: &[Shortcut] = &[
    entry(
        "H / F1",
        "hide or show the panel",
        &[change(&[K::KeyH, K::F1], |p, _| p.panel_visible = !p.panel_visible)],
    ),
    entry(
        "I",
        "hide or show the numbers over the image",
        &[change(&[K::KeyI], |p, _| p.hud_visible = !p.hud_visible)],
    ),
    entry(
        "F12",
        "screenshot of the traced image",
        &[ask(&[K::F12], Mods::NoShift, KeyAction::ScreenshotTrace)],
    ),
    entry(
        "Shift+F12",
        "screenshot of the window",
        &[ask(&[K::F12], Mods::Shift, KeyAction::ScreenshotWindow)],
    ),
    entry(
        "B",
        "run the benchmark (an orbit; summary in the panel)",
        &[ask(&[K::KeyB], Mods::Plain, KeyAction::Benchmark)],
    ),
    entry(
        "PgUp / PgDn",
        "bounces + / -",
        &[
            change(&[K::PageUp], |p, _| step_bounces(p, 1)),
            change(&[K::PageDown], |p, _| step_bounces(p, -1)),
        ],
    ),
    entry(
        "[ / ]",
        "blend - / +",
        &[
            change(&[K::BracketLeft], |p, _| step_blend(p, -5)),
            change(&[K::BracketRight], |p, _| step_blend(p, 5)),
        ],
    ),
    entry(
        "+ / -",
        "model count",
        &[
            change(&[K::Equal, K::NumpadAdd], |p, _| step_models(p, 1)),
            change(&[K::Minus, K::NumpadSubtract], |p, _| step_models(p, -1)),
        ],
    ),
    entry(
        "A",
        "acceleration: BVH, brute force, vendor in turn",
        &[change(&[K::KeyA], |p, cx| next_accel(p, cx.vendor))],
    ),
    entry("C", "colour / cost heat map", &[change(&[K::KeyC], |p, _| toggle_cost(p))]),
    entry(
        "M",
        "render resolution: match window / back",
        &[change(&[K::KeyM], |p, cx| match_window(p, cx.previous))],
    ),
    entry(
        "Space",
        "pause the light",
        &[change(&[K::Space], |p, _| p.light_paused = !p.light_paused)],
    ),
    entry("R", "reset the camera", &[change(&[K::KeyR], |p, _| p.reset_camera())]),
    entry("F", "frame the models", &[ask(&[K::KeyF], Mods::Plain, KeyAction::FrameModel)]),
    entry("V", "vsync on / off", &[change(&[K::KeyV], |p, _| p.vsync = !p.vsync)]),
    entry(
        "S",
        "A/B split view on / off (drag the line to move it)",
        &[change(&[K::KeyS], |p, _| p.split.enabled = !p.split.enabled)],
    ),
    entry(
        "Ctrl+O",
        "open a model: OBJ, PLY or glTF (or drop one on the window)",
        &[ask(&[K::KeyO], Mods::Ctrl, KeyAction::OpenModel)],
    ),
    entry(
        "Escape",
        "stop loading a model (the one shown stays)",
        &[ask(&[K::Escape], Mods::Plain, KeyAction::CancelLoad)],
    ),
    entry("Ctrl+Q", "quit", &[ask(&[K::KeyQ], Mods::Ctrl, KeyAction::Quit)]),
    entry("drag / wheel", "orbit / zoom the camera", &[]),
    entry("Shift+drag, middle drag", "pan the camera", &[]),
];

fn step_bounces(p: &mut Params, by: i32) {
    let s = &mut p.scene.settings;
    s.bounces = BOUNCES.clamp_u32(s.bounces.saturating_add_signed(by));
}

/// Blend moves in hundredths, so twenty steps from 0 land on 1 exactly.
fn step_blend(p: &mut Params, hundredths: i32) {
    let s = &mut p.scene.settings;
    s.blend = BLEND.clamp_f32(((s.blend * 100.0).round() + hundredths as f32) / 100.0);
}

fn step_models(p: &mut Params, by: i32) {
    p.scene.models = MODELS.clamp_u32(p.scene.models.saturating_add_signed(by));
}

/// BVH, brute force, vendor, and round; the vendor's only where the device has its ray
/// tracing (the panel greys it out otherwise, and choosing it would only fall back to the
/// BVH with a red line).
fn next_accel(p: &mut Params, vendor: bool) {
    let accel = &mut p.scene.settings.accel;
    let n = Accel::ALL.len();
    let start = Accel::ALL.iter().position(|a| a == accel).map_or(0, |i| i + 1);
    let mut order = (0..n).map(|k| Accel::ALL[(start + k) % n]);
    *accel = order.find(|&a| a != Accel::Vendor || vendor).unwrap_or(Accel::Bvh);
    p.fit_cost_metric();
}

fn toggle_cost(p: &mut Params) {
    p.view = match p.view {
        ViewMode::Cost(_) => ViewMode::Color,
        _ => ViewMode::Cost(CostMetric::Nodes),
    };
    p.fit_cost_metric();
}

fn match_window(p: &mut Params, previous: &mut Resolution) {
    if p.resolution == Resolution::MatchWindow {
        p.resolution = *previous;
    } else {
        *previous = p.resolution;
        p.resolution = Resolution::MatchWindow;
    }
}

impl Params {
    /// Apply a key press (egui did not want the keyboard): the first chord of
    /// [`SHORTCUTS`] that takes it. `previous` remembers the resolution to go back to when
    /// `M` leaves "match window"; `vendor` says whether the device has the vendor's ray
    /// tracing, which A offers only then.
    pub(crate) fn apply_key(
        &mut self,
        key: KeyCode,
        shift: bool,
        ctrl: bool,
        previous: &mut Resolution,
        vendor: bool,
    ) -> KeyAction {
        let chord = SHORTCUTS
            .iter()
            .flat_map(|s| s.chords)
            .find(|c| c.codes.contains(&key) && c.mods.allow(shift, ctrl));
        match chord.map(|c| c.effect) {
            Some(Effect::Ask(action)) => action,
            Some(Effect::Change(change)) => {
                change(self, &mut KeyCx { previous, vendor });
                KeyAction::None
            }
            None => KeyAction::None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::app::state::tests::params;
    use crate::render_settings::RenderSettings;

    #[test]
    fn keys_change_parameters_within_range() {
        let mut p =
            params(|s| s.settings = RenderSettings { bounces: 8, blend: 1.0, ..s.settings });
        let mut prev = p.resolution;
        p.apply_key(KeyCode::PageUp, false, false, &mut prev, true);
        assert_eq!(p.scene.settings.bounces, 8);
        p.apply_key(KeyCode::PageDown, false, false, &mut prev, true);
        assert_eq!(p.scene.settings.bounces, 7);
        p.apply_key(KeyCode::BracketRight, false, false, &mut prev, true);
        assert_eq!(p.scene.settings.blend, 1.0);
        p.apply_key(KeyCode::BracketLeft, false, false, &mut prev, true);
        assert!((p.scene.settings.blend - 0.95).abs() < 1e-6);
        assert_eq!(
            p.apply_key(KeyCode::F12, false, false, &mut prev, true),
            KeyAction::ScreenshotTrace
        );
        assert_eq!(
            p.apply_key(KeyCode::F12, true, false, &mut prev, true),
            KeyAction::ScreenshotWindow
        );
        assert_eq!(p.apply_key(KeyCode::KeyQ, false, true, &mut prev, true), KeyAction::Quit);
        let start = p.resolution;
        p.apply_key(KeyCode::KeyM, false, false, &mut prev, true);
        assert_eq!(p.resolution, Resolution::MatchWindow);
        p.apply_key(KeyCode::KeyM, false, false, &mut prev, true);
        assert_eq!(p.resolution, start);
        for _ in 0..40 {
            p.apply_key(KeyCode::Minus, false, false, &mut prev, true);
        }
        assert_eq!(p.scene.models, 1);
    }
    #[test]
    fn ctrl_chords_other_than_quit_and_open_leave_everything_alone() {
        let mut p = params(|_| {});
        let mut prev = p.resolution;
        let before = format!(
            "{:?}",
            (&p.scene, p.view, p.vsync, p.split.enabled, p.resolution, p.panel_visible)
        );
        for key in [
            KeyCode::KeyA,
            KeyCode::KeyC,
            KeyCode::KeyV,
            KeyCode::KeyS,
            KeyCode::KeyM,
            KeyCode::KeyR,
            KeyCode::KeyB,
            KeyCode::KeyH,
            KeyCode::Equal,
        ] {
            assert_eq!(
                p.apply_key(key, false, true, &mut prev, true),
                KeyAction::None,
                "Ctrl+{key:?}"
            );
        }
        assert_eq!(
            format!(
                "{:?}",
                (&p.scene, p.view, p.vsync, p.split.enabled, p.resolution, p.panel_visible)
            ),
            before
        );
        assert_eq!(p.apply_key(KeyCode::KeyO, false, true, &mut prev, true), KeyAction::OpenModel);
        // Without Ctrl, A is the acceleration's key.
        p.apply_key(KeyCode::KeyA, false, false, &mut prev, true);
        assert_ne!(format!("{:?}", &p.scene), format!("{:?}", params(|_| {}).scene));
    }

    #[test]
    fn escape_asks_to_stop_a_load() {
        let mut p = params(|_| {});
        let mut previous = Resolution::Square(512);
        assert_eq!(
            p.apply_key(KeyCode::Escape, false, false, &mut previous, true),
            KeyAction::CancelLoad
        );
    }

    #[test]
    fn a_cycles_past_the_vendors_option_where_the_device_has_none() {
        // It chose the greyed-out option, which fell back to the BVH with a red line (#43).
        let mut p = params(|_| {});
        let mut prev = p.resolution;
        let mut seen = Vec::new();
        for vendor in [false, true] {
            p.scene.settings.accel = Accel::Bvh;
            for _ in 0..3 {
                p.apply_key(KeyCode::KeyA, false, false, &mut prev, vendor);
                seen.push(p.scene.settings.accel);
            }
        }
        use Accel::{Brute, Bvh, Vendor};
        assert_eq!(seen, [Brute, Bvh, Brute, Brute, Vendor, Bvh]);
        // From the vendor's (a preset asked for it) the next is the BVH either way.
        p.scene.settings.accel = Vendor;
        p.apply_key(KeyCode::KeyA, false, false, &mut prev, false);
        assert_eq!(p.scene.settings.accel, Bvh);
    }

    #[test]
    fn brute_force_cost_view_counts_triangles() {
        let mut p = params(|_| {});
        let mut prev = p.resolution;
        p.apply_key(KeyCode::KeyC, false, false, &mut prev, true);
        assert_eq!(p.view, ViewMode::Cost(CostMetric::Nodes));
        p.apply_key(KeyCode::KeyA, false, false, &mut prev, true);
        assert_eq!(
            p.view,
            ViewMode::Cost(CostMetric::Triangles),
            "nodes are all zero without a BVH"
        );
    }

    #[test]
    fn every_chord_is_reached_and_every_key_line_has_its_chords() {
        // A chord shadowed by an earlier entry's would never run.
        let chords: Vec<&Chord> = SHORTCUTS.iter().flat_map(|s| s.chords).collect();
        for (i, chord) in chords.iter().enumerate() {
            let shift = chord.mods == Mods::Shift;
            let ctrl = chord.mods == Mods::Ctrl;
            for code in chord.codes {
                let first =
                    chords.iter().position(|c| c.codes.contains(code) && c.mods.allow(shift, ctrl));
                assert_eq!(first, Some(i), "{code:?} with {:?}", chord.mods);
            }
        }
        for s in SHORTCUTS {
            let mouse = s.keys.contains("drag");
            assert_eq!(s.chords.is_empty(), mouse, "{}", s.keys);
        }
    }
}
