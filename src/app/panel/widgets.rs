//! What every panel section draws with: the collapsible section that remembers whether it
//! is open, the status line, digit grouping and the panel's colours. A leaf: it knows no
//! section.

use std::collections::BTreeMap;

use egui::{Color32, RichText, Ui};

/// Colour of the GPU-time line and text.
pub(crate) const GPU_COLOR: Color32 = Color32::from_rgb(255, 150, 60);
/// Colour of the frame-time line and text.
pub(crate) const FRAME_COLOR: Color32 = Color32::from_rgb(90, 170, 255);
/// Colour of a status line that reports a failure.
const ERROR_COLOR: Color32 = Color32::from_rgb(255, 110, 100);

/// What [`status_line`] draws (the sections name it here, beside the line).
pub(crate) use crate::app::status::Status;

/// A status line, red for a failure, wrapped to the panel's width.
pub(crate) fn status_line(ui: &mut Ui, s: &Status) {
    let text = RichText::new(&s.text).small();
    ui.add(egui::Label::new(if s.error { text.color(ERROR_COLOR) } else { text }).wrap());
}

/// 1234567 -> "1 234 567".
pub(crate) fn group(n: u64) -> String {
    let s = n.to_string();
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if i > 0 && (s.len() - i) % 3 == 0 {
            out.push(' ');
        }
        out.push(c);
    }
    out
}

/// Mrays/s for the HUD and the panel alike, to two or three significant digits ("0.42",
/// "3.14", "41.2", "512"), "-" before a frame of today's settings was timed.
pub(crate) fn mrays_text(mrays: Option<f64>) -> String {
    match mrays {
        None => "-".into(),
        Some(v) if v < 10.0 => format!("{v:.2}"),
        Some(v) if v < 100.0 => format!("{v:.1}"),
        Some(v) => format!("{v:.0}"),
    }
}

/// Seconds as "12 s" or "3 min".
pub(crate) fn duration(s: f64) -> String {
    if s < 90.0 {
        format!("{s:.0} s")
    } else {
        format!("{:.0} min", s / 60.0)
    }
}

/// The id under which the panel keeps its [`Sections`] in egui's memory.
fn sections_id() -> egui::Id {
    egui::Id::new("meshtracer remembered sections")
}

/// Which panel sections are open, as the panel draws them (kept in egui's memory so that
/// every section can take part without being handed it).
#[derive(Clone, Debug, Default)]
pub(crate) struct Sections {
    /// Title to open.
    pub(crate) open: BTreeMap<String, bool>,
    /// "Reset settings" was pressed: sections not drawn since go back to their defaults.
    pub(crate) reset: bool,
}

impl Sections {
    /// The sections of `ctx`.
    pub(crate) fn get(ctx: &egui::Context) -> Sections {
        ctx.data(|d| d.get_temp::<Sections>(sections_id())).unwrap_or_default()
    }

    /// Replace the sections of `ctx`.
    pub(crate) fn set(ctx: &egui::Context, sections: Sections) {
        ctx.data_mut(|d| d.insert_temp(sections_id(), sections));
    }
}

/// A collapsible panel section titled `title` that opens as it was last left (or as
/// `default_open` says the first time), and remembers whether it is open.
pub(crate) fn section<R>(
    ui: &mut Ui,
    title: &str,
    default_open: bool,
    add: impl FnOnce(&mut Ui) -> R,
) -> Option<R> {
    let id = sections_id();
    let (remembered, reset) = ui
        .ctx()
        .data(|d| d.get_temp::<Sections>(id).map(|s| (s.open.get(title).copied(), s.reset)))
        .unwrap_or((None, false));
    let mut header =
        egui::CollapsingHeader::new(title).default_open(remembered.unwrap_or(default_open));
    // After a reset the map is empty: each section is put back once, then left to the user.
    if reset && remembered.is_none() {
        header = header.open(Some(default_open));
    }
    let response = header.show(ui, add);
    let open = response.openness > 0.5;
    ui.ctx().data_mut(|d| {
        d.get_temp_mut_or_default::<Sections>(id).open.insert(title.to_string(), open);
    });
    response.body_returned
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn digits_are_grouped() {
        assert_eq!(group(0), "0");
        assert_eq!(group(999), "999");
        assert_eq!(group(1000), "1 000");
        assert_eq!(group(1234567), "1 234 567");
    }

    #[test]
    fn mrays_keep_two_significant_digits_below_one() {
        // #43: the HUD said "0 Mrays/s" where the panel said 0.4.
        assert_eq!(mrays_text(Some(0.4)), "0.40");
        assert_eq!(mrays_text(Some(0.042)), "0.04");
        assert_eq!(mrays_text(Some(41.23)), "41.2");
        assert_eq!(mrays_text(Some(512.4)), "512");
        assert_eq!(mrays_text(None), "-");
    }
}
