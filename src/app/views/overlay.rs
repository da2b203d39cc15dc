//! What is drawn over the traced image: the numbers in its corner (HUD), a marker where
//! the light is, the split view's line with each half's GPU time, and a short notice when
//! a screenshot was written.

use std::time::{Duration, Instant};

use egui::{Color32, Pos2, Rect, RichText, Stroke, Ui};

use crate::app::panel::info::PanelInfo;
use crate::app::panel::widgets::{duration, group, mrays_text, FRAME_COLOR, GPU_COLOR};

/// How long a screenshot notice stays.
const NOTICE_TIME: Duration = Duration::from_millis(2500);

/// Colour of the light's marker (the light's own warm white).
const LIGHT_COLOR: Color32 = Color32::from_rgb(255, 230, 120);

/// The split view's line over the image and its labels (points).
pub(crate) struct SplitOverlay {
    /// The line's x, where the halves meet.
    pub(crate) x: f32,
    /// The image's top: the line spans the image.
    pub(crate) top: f32,
    /// The image's bottom, where the labels sit.
    pub(crate) bottom: f32,
    /// The left half's label ("A 12.3 ms").
    pub(crate) a: String,
    /// The right half's label ("B 20.1 ms").
    pub(crate) b: String,
    /// What B changes ("bounces 0, smooth off").
    pub(crate) b_changes: String,
}

/// A notice shown for a short while over the image.
pub(crate) struct Notice {
    text: String,
    since: Instant,
}

impl Notice {
    /// A notice starting now.
    pub(crate) fn new(text: impl Into<String>) -> Self {
        Self { text: text.into(), since: Instant::now() }
    }

    /// Still worth showing.
    pub(crate) fn is_current(&self) -> bool {
        self.since.elapsed() < NOTICE_TIME
    }
}

/// Draw the overlays over `image` (the image area, in points).
pub(crate) fn show(
    ctx: &egui::Context,
    image: Rect,
    hud: Option<&PanelInfo>,
    light: Option<Pos2>,
    split: Option<&SplitOverlay>,
    notice: Option<&Notice>,
) {
    if let Some(info) = hud {
        // Top-left of the image area: the panel never covers it. No fade-in: the numbers
        // are there in full from their first frame (and in a screenshot taken then).
        egui::Area::new(egui::Id::new("hud"))
            .fixed_pos(image.left_top() + egui::vec2(8.0, 8.0))
            .interactable(false)
            .fade_in(false)
            .show(ctx, |ui| {
                egui::Frame::new()
                    .fill(Color32::from_black_alpha(160))
                    .inner_margin(6.0)
                    .corner_radius(4.0)
                    .show(ui, |ui| hud_numbers(ui, info));
            });
    }
    if let Some(p) = light.filter(|p| image.contains(*p)) {
        // Under every area: the numbers (HUD), the notice and the Open dialog cover it,
        // not the other way round (issue #43: the ring was drawn over the numbers).
        let painter = ctx.layer_painter(egui::LayerId::background());
        painter.circle_stroke(p, 7.0, Stroke::new(2.0, Color32::BLACK));
        painter.circle_stroke(p, 6.0, Stroke::new(1.5, LIGHT_COLOR));
        // The label above the marker, or below it near the image's top edge.
        let (offset, anchor) = if p.y - image.top() < 24.0 {
            (egui::vec2(10.0, 8.0), egui::Align2::LEFT_TOP)
        } else {
            (egui::vec2(10.0, -8.0), egui::Align2::LEFT_BOTTOM)
        };
        painter.text(p + offset, anchor, "light", egui::FontId::proportional(12.0), LIGHT_COLOR);
    }
    if let Some(s) = split {
        split_line(ctx, s);
    }
    if let Some(n) = notice.filter(|n| n.is_current()) {
        egui::Area::new(egui::Id::new("notice"))
            .fixed_pos(image.left_bottom() + egui::vec2(8.0, -34.0))
            .interactable(false)
            .show(ctx, |ui| {
                egui::Frame::new()
                    .fill(Color32::from_black_alpha(180))
                    .inner_margin(6.0)
                    .corner_radius(4.0)
                    .show(ui, |ui| {
                        ui.add(
                            egui::Label::new(RichText::new(&n.text).color(Color32::WHITE))
                                .truncate(),
                        );
                    });
            });
    }
}

/// The compact numbers drawn over a corner of the image (the HUD): visible at any window
/// size, whether the panel is shown or scrolled.
fn hud_numbers(ui: &mut Ui, info: &PanelInfo) {
    // The GPU time only for a frame of today's settings (not the last BVH frame's while
    // brute-force bands run, nor the old resolution's after a change).
    let gpu_now = info.stats.gpu_now(&info.settings);
    let gpu = gpu_now.map(|(ms, _)| ms);
    let frame = info.stats.frame.current();
    let ms = |v: Option<f64>| v.map_or("-".into(), |v| format!("{v:.2}"));
    let lines = [
        format!("{:.1} fps", info.stats.fps()),
        format!("GPU {} ms", ms(gpu)),
        format!("frame {} ms", ms(frame)),
        format!("{} Mrays/s", mrays_text(gpu_now.map(|(_, mrays)| mrays))),
        format!("{} triangles", group(info.triangles)),
    ];
    let banded = info.progress.map(|(p, left)| match left {
        Some(s) => format!("tracing in bands: {:.0}%, {} left", p * 100.0, duration(s)),
        None => format!("tracing in bands: {:.0}%", p * 100.0),
    });
    for (i, line) in lines.iter().chain(banded.iter()).enumerate() {
        let color = match i {
            1 => GPU_COLOR,
            2 => FRAME_COLOR,
            _ => Color32::from_gray(230),
        };
        ui.add(
            egui::Label::new(RichText::new(line).monospace().color(color))
                .wrap_mode(egui::TextWrapMode::Extend),
        );
    }
}

/// The split line (white on a dark edge, seen on any image) and the halves' labels beside
/// it at the image's bottom, A to the left and B (with what it changes) to the right.
fn split_line(ctx: &egui::Context, s: &SplitOverlay) {
    let painter =
        ctx.layer_painter(egui::LayerId::new(egui::Order::Foreground, egui::Id::new("split line")));
    let (top, bottom) = (Pos2::new(s.x, s.top), Pos2::new(s.x, s.bottom));
    painter.line_segment([top, bottom], Stroke::new(3.0, Color32::from_black_alpha(200)));
    painter.line_segment([top, bottom], Stroke::new(1.0, Color32::WHITE));
    let font = egui::FontId::proportional(13.0);
    let y = s.bottom - 8.0;
    for (text, anchor, dx) in [
        (s.a.clone(), egui::Align2::RIGHT_BOTTOM, -6.0),
        (format!("{}\n{}", s.b, s.b_changes), egui::Align2::LEFT_BOTTOM, 6.0),
    ] {
        let galley = painter.layout_no_wrap(text, font.clone(), Color32::WHITE);
        let rect = anchor.anchor_size(Pos2::new(s.x + dx, y), galley.size());
        painter.rect_filled(rect.expand(3.0), 3.0, Color32::from_black_alpha(170));
        painter.galley(rect.min, galley, Color32::WHITE);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue #43: the light's ring was drawn over the numbers over the image. It is painted
    /// under every area there (the numbers, the notice), here the notice's.
    #[test]
    fn the_light_marker_is_painted_under_the_areas_over_the_image() {
        let ctx = egui::Context::default();
        let image = Rect::from_min_size(egui::pos2(300.0, 0.0), egui::vec2(500.0, 500.0));
        let notice = Notice::new("wrote a screenshot with a long name");
        let light = image.left_bottom() + egui::vec2(20.0, -26.0);
        let mut shapes = Vec::new();
        for _ in 0..2 {
            let mut out = ctx.run_ui(egui::RawInput::default(), |ui| {
                show(ui.ctx(), image, None, Some(light), None, Some(&notice));
            });
            // No renderer here: the font texture's upload is dropped on purpose.
            out.textures_delta.clear();
            shapes = out.shapes;
        }
        let at = |f: &dyn Fn(&egui::Shape) -> bool| shapes.iter().position(|c| f(&c.shape));
        let ring = at(&|s| matches!(s, egui::Shape::Circle(_))).expect("the light's ring");
        let text = at(&|s| matches!(s, egui::Shape::Text(t) if t.galley.text().contains("wrote")))
            .expect("the notice");
        assert!(ring < text, "the ring ({ring}) is painted after the notice ({text})");
    }
}
