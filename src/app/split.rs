//! The A/B split view: a vertical line over the image, the columns left of it traced with
//! the current settings (A) and those right of it with a second set (B) that differs from
//! A in the parameters the user picks. Both halves are one frame of one view, traced by two
//! dispatches over column ranges (see `gpu::FrameTrace`), each timed on its own.
//!
//! What the whole scene shares (model, copies, box, camera, light, resolution, view) is
//! never part of B. Presets and screenshots' settings carry A only.

use crate::gpu::dispatch::GROUP;
use crate::gpu::{FrameTrace, SplitTrace};
use crate::render_settings::{Accel, Range, RenderSettings, BLEND, BOUNCES, SPP};
use crate::tracer::frame::FrameParams;

/// How close to the line (physical pixels) a left press grabs it instead of orbiting.
pub(crate) const GRAB_PIXELS: f64 = 8.0;

/// The parameters in which B differs from A: each None follows A.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SplitB {
    /// BVH, brute force or the vendor's ray tracing.
    pub accel: Option<Accel>,
    /// Mirror bounces (0..=8).
    pub bounces: Option<u32>,
    /// Reflection blend ratio (0..=1).
    pub blend: Option<f32>,
    /// Camera samples per pixel (1..=64).
    pub spp: Option<u32>,
    /// Adaptive sampling.
    pub adaptive: Option<bool>,
    /// Smooth shading.
    pub smooth: Option<bool>,
    /// `map_Kd` textures.
    pub textures: Option<bool>,
    /// Misses see the environment (A's, or the generated sky when A has none).
    pub environment: Option<bool>,
}

/// The names `--split-b` takes, in the order [`SplitB::describe`] lists them.
pub(crate) const KEYS: [&str; 8] =
    ["accel", "bounces", "blend", "spp", "adaptive", "smooth", "textures", "env"];

impl SplitB {
    /// B's settings: A's with the differing parameters replaced.
    pub(crate) fn settings(&self, a: &RenderSettings) -> RenderSettings {
        RenderSettings {
            accel: self.accel.unwrap_or(a.accel),
            bounces: self.bounces.unwrap_or(a.bounces),
            blend: self.blend.unwrap_or(a.blend),
            spp: self.spp.unwrap_or(a.spp),
            adaptive: self.adaptive.unwrap_or(a.adaptive),
            smooth: self.smooth.unwrap_or(a.smooth),
            textures: self.textures.unwrap_or(a.textures),
            ..*a
        }
    }

    /// Whether B's misses see the environment, A's being `a`.
    pub(crate) fn environment(&self, a: bool) -> bool {
        self.environment.unwrap_or(a)
    }

    /// B asks for an environment whatever A has (the sky is uploaded when A has none).
    pub(crate) fn wants_environment(&self) -> bool {
        self.environment == Some(true)
    }

    /// Parse `--split-b`: comma-separated `name=value` pairs, e.g. `bounces=0,smooth=off`.
    /// The error is one line naming the pair and what was expected.
    pub(crate) fn parse(text: &str) -> Result<Self, String> {
        let mut b = SplitB::default();
        for pair in text.split(',').map(str::trim).filter(|p| !p.is_empty()) {
            let (name, value) = pair.split_once('=').ok_or_else(|| {
                format!("--split-b '{pair}' is not name=value (names: {})", KEYS.join(", "))
            })?;
            let (name, value) = (name.trim().to_ascii_lowercase(), value.trim());
            let number = |range: Range| match value.parse::<u32>() {
                Ok(v) if range.contains(v as f64) => Ok(v),
                _ => Err(format!("--split-b {name}={value}: expected a whole number in {range}")),
            };
            match name.as_str() {
                "accel" => b.accel = Some(value.parse().map_err(|e| format!("--split-b: {e}"))?),
                "bounces" => b.bounces = Some(number(BOUNCES)?),
                "spp" => b.spp = Some(number(SPP)?),
                "blend" => match value.parse::<f32>() {
                    Ok(v) if BLEND.contains(v as f64) => b.blend = Some(v),
                    _ => {
                        return Err(format!(
                            "--split-b blend={value}: expected a number in {BLEND}"
                        ))
                    }
                },
                "adaptive" | "smooth" | "textures" | "env" => {
                    let on = match value.to_ascii_lowercase().as_str() {
                        "on" | "true" | "yes" | "1" => true,
                        "off" | "false" | "no" | "0" => false,
                        _ => return Err(format!("--split-b {name}={value}: expected on or off")),
                    };
                    match name.as_str() {
                        "adaptive" => b.adaptive = Some(on),
                        "smooth" => b.smooth = Some(on),
                        "textures" => b.textures = Some(on),
                        _ => b.environment = Some(on),
                    }
                }
                _ => {
                    return Err(format!(
                        "--split-b: unknown parameter '{name}' (names: {})",
                        KEYS.join(", ")
                    ))
                }
            }
        }
        Ok(b)
    }

    /// What B changes, short ("bounces 0, smooth off"), or "same as A".
    pub(crate) fn describe(&self) -> String {
        let on = |v: bool| if v { "on" } else { "off" };
        let parts: Vec<String> = [
            self.accel.map(|a| format!("{a}")),
            self.bounces.map(|v| format!("bounces {v}")),
            self.blend.map(|v| format!("blend {v:.2}")),
            self.spp.map(|v| format!("spp {v}")),
            self.adaptive.map(|v| format!("adaptive {}", on(v))),
            self.smooth.map(|v| format!("smooth {}", on(v))),
            self.textures.map(|v| format!("textures {}", on(v))),
            self.environment.map(|v| format!("env {}", on(v))),
        ]
        .into_iter()
        .flatten()
        .collect();
        if parts.is_empty() {
            "same as A".into()
        } else {
            parts.join(", ")
        }
    }
}

/// The split view's state: whether it is on, where the line is, and B.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplitView {
    /// The split is shown (S, the panel's checkbox).
    pub enabled: bool,
    /// The line's place as a share of the image width, in [0, 1]; the halves meet at the
    /// nearest work-group column ([`SplitView::column`]).
    pub position: f32,
    /// What the right half changes.
    pub b: SplitB,
}

impl Default for SplitView {
    fn default() -> Self {
        Self { enabled: false, position: 0.5, b: SplitB::default() }
    }
}

impl SplitView {
    /// The first column traced with B in an image `width` pixels wide: the line's place
    /// snapped to a multiple of the work-group width (dispatches start there), at most the
    /// width.
    pub(crate) fn column(&self, width: u32) -> u32 {
        let x = self.position.clamp(0.0, 1.0) as f64 * width as f64;
        let column = (x / GROUP.width as f64).round() as u32 * GROUP.width;
        column.min(width)
    }

    /// Move the line to `x`, a share of the image width (clamped to the image).
    pub(crate) fn move_to(&mut self, x: f32) {
        if x.is_finite() {
            self.position = x.clamp(0.0, 1.0);
        }
    }

    /// The frame to trace: `a` all over, or A left of the line and B right of it.
    pub(crate) fn frame(&self, a: FrameParams) -> FrameTrace {
        if !self.enabled {
            return FrameTrace::whole(a);
        }
        let settings = self.b.settings(&a.settings);
        let b = FrameParams { settings, environment: self.b.environment(a.environment), ..a };
        FrameTrace {
            params: a,
            split: Some(SplitTrace { column: self.column(a.settings.width), params: b }),
        }
    }

    /// The per-half GPU times as the overlay writes them ("A 12.3 ms | B 20.1 ms").
    pub(crate) fn times_text(ms: crate::gpu::PartTimes) -> String {
        let t = |m: Option<f64>| m.map_or("–".into(), |m| format!("{m:.1} ms"));
        format!("A {} | B {}", t(ms[0]), t(ms[1]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(width: u32) -> FrameParams {
        let scene = crate::scene::paper::paper_scene(
            crate::scene::primitives::geosphere(0),
            1,
            Default::default(),
        );
        FrameParams::new(&scene, RenderSettings { width, height: 16, ..Default::default() })
    }

    /// Wherever the line is, the two parts cover every column exactly once, and B starts
    /// on a work-group boundary (or the image's edge).
    #[test]
    fn the_halves_cover_each_column_once_and_b_starts_on_a_group() {
        for width in [1, 7, 8, 64, 100, 129, 257] {
            for i in 0..=40 {
                let split = SplitView {
                    enabled: true,
                    position: i as f32 / 40.0,
                    b: SplitB { bounces: Some(0), ..Default::default() },
                };
                let frame = split.frame(params(width));
                let column = frame.split.unwrap().column;
                assert!(column % GROUP.width == 0 || column == width, "{width}: {column}");
                assert!(
                    ((i as f32 / 40.0) * width as f32 - column as f32).abs()
                        <= GROUP.width as f32 / 2.0 + 1.0,
                    "snapped to the nearest group"
                );
                let mut seen = vec![0; width as usize];
                for (part, p, columns) in frame.parts() {
                    assert_eq!(p.settings.bounces, if part == 0 { 2 } else { 0 });
                    columns.for_each(|c| seen[c as usize] += 1);
                }
                assert!(seen.iter().all(|&n| n == 1), "{width} at {i}/40: {seen:?}");
            }
        }
        // Off: one part, the whole width, A's settings.
        let off = SplitView::default().frame(params(50));
        assert_eq!(off.parts().len(), 1);
        assert_eq!(off.parts()[0].2, 0..50);
    }

    #[test]
    fn b_differs_only_where_asked() {
        let a = RenderSettings { bounces: 3, smooth: true, spp: 4, ..Default::default() };
        let b = SplitB { bounces: Some(0), smooth: Some(false), ..Default::default() };
        assert_eq!(b.settings(&a), RenderSettings { bounces: 0, smooth: false, ..a });
        assert_eq!(SplitB::default().settings(&a), a);
        assert!(b.environment(true) && !SplitB { environment: Some(false), ..b }.environment(true));
        let mut split = SplitView {
            enabled: true,
            b: SplitB { environment: Some(true), ..b },
            ..Default::default()
        };
        let frame = split.frame(params(64));
        assert!(frame.split.unwrap().params.environment && !frame.params.environment);
        split.move_to(f32::NAN);
        split.move_to(3.0);
        assert_eq!(split.position, 1.0);
        assert_eq!(split.column(64), 64);
    }

    #[test]
    fn split_b_parses_and_errors_are_one_line() {
        let b = SplitB::parse("bounces=0, smooth=off,accel=brute,spp=4,env=on,blend=0.25").unwrap();
        assert_eq!(b.bounces, Some(0));
        assert_eq!(b.smooth, Some(false));
        assert_eq!(b.accel, Some(Accel::Brute));
        assert_eq!((b.spp, b.environment, b.blend), (Some(4), Some(true), Some(0.25)));
        assert_eq!(b.describe(), "brute, bounces 0, blend 0.25, spp 4, smooth off, env on");
        assert_eq!(SplitB::parse("").unwrap().describe(), "same as A");
        for (bad, says) in [
            ("bounces", "name=value"),
            ("bounces=9", "0..=8"),
            ("spp=0", "1..=64"),
            ("smooth=maybe", "on or off"),
            ("colour=red", "unknown"),
            ("accel=kd", "brute, bvh"),
            ("blend=2", "0..=1"),
        ] {
            let e = SplitB::parse(bad).unwrap_err();
            assert!(e.contains(says) && !e.contains('\n'), "{bad}: {e}");
        }
    }
}
