//! What a chart is made of: its series (points, line and marker style), its x axis kind
//! and reference lines; `draw.rs` turns a [`Chart`] into a PNG.

use plotters::style::RGBColor;

/// The grey of reference series and lines.
pub(super) const GREY_: RGBColor = RGBColor(110, 110, 110);

#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Marker {
    Circle,
    Square,
    Triangle,
    Diamond,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Line {
    /// Points only.
    None,
    Solid,
    Dashed,
}

#[derive(Clone, Debug)]
pub(super) struct Series {
    pub(super) label: String,
    pub(super) color: RGBColor,
    pub(super) line: Line,
    pub(super) marker: Marker,
    /// (x, y), sorted by x when drawn.
    pub(super) points: Vec<(f64, f64)>,
    /// A name written beside each point (empty: none).
    pub(super) point_labels: Vec<String>,
}

impl Series {
    pub(super) fn new(label: String, color: RGBColor, line: Line, marker: Marker) -> Self {
        Self { label, color, line, marker, points: Vec::new(), point_labels: Vec::new() }
    }

    /// Add a point unless one at the same x is there already (a row measured twice, e.g.
    /// in the scaling series and in Table 1, is drawn once).
    pub(super) fn push(&mut self, x: f64, y: f64, label: Option<String>) {
        if self.points.iter().any(|p| p.0 == x) {
            return;
        }
        self.points.push((x, y));
        if let Some(l) = label {
            self.point_labels.resize(self.points.len() - 1, String::new());
            self.point_labels.push(l);
        }
    }

    pub(super) fn sorted(&self) -> Vec<(f64, f64, String)> {
        let mut v: Vec<_> = self
            .points
            .iter()
            .enumerate()
            .map(|(i, p)| (p.0, p.1, self.point_labels.get(i).cloned().unwrap_or_default()))
            .collect();
        v.sort_by(|a, b| a.0.total_cmp(&b.0));
        v
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum XAxis {
    /// Triangle counts: decades labelled 100, 1k, 1M.
    Count,
    /// Pixels per frame: ticks at the resolutions drawn, labelled 512².
    Pixels,
    /// Model copies: ticks at the counts drawn.
    Copies,
}

pub(super) struct Chart {
    pub(super) title: String,
    pub(super) subtitle: String,
    pub(super) x_desc: String,
    pub(super) y_desc: String,
    pub(super) x_axis: XAxis,
    pub(super) series: Vec<Series>,
    /// Horizontal reference lines: (y, label).
    pub(super) hlines: Vec<(f64, String)>,
}
