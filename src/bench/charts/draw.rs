//! Drawing a `Chart` with plotters into a PNG: the title block, the log-log plot with its
//! series, markers, point labels and reference lines, and the legend beside it. Text uses
//! the embedded DejaVu Sans, registered once.

use std::path::Path;
use std::sync::Once;

use anyhow::anyhow;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};

use super::axes::{count_label, log_range, log_ticks, pixels_label, short_number, snap_125};
use super::chart::{Chart, Line, Marker, XAxis, GREY_};

/// DejaVu Sans 2.37 (Bitstream Vera licence, see assets/fonts/LICENSE-DejaVu.txt).
const FONT: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");
const FAMILY: &str = "sans-serif";

const WIDTH: u32 = 1400;
const HEIGHT: u32 = 820;
const LEGEND_WIDTH: u32 = 420;
const TITLE_HEIGHT: u32 = 78;

fn register_fonts() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        for style in [FontStyle::Normal, FontStyle::Bold] {
            // The font is a fixed, valid file; a failure here would show as missing text.
            let _ = register_font(FAMILY, style, FONT);
        }
    });
}

fn err<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow!("plotters: {e:?}")
}

pub(super) fn render(chart: &Chart, path: &Path) -> anyhow::Result<()> {
    register_fonts();
    let mut buffer = vec![255u8; (WIDTH * HEIGHT * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buffer, (WIDTH, HEIGHT)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let (top, rest) = root.split_vertically(TITLE_HEIGHT);
        top.draw_text(&chart.title, &(FAMILY, 28).into_font().color(&BLACK), (24, 12))
            .map_err(err)?;
        top.draw_text(&chart.subtitle, &(FAMILY, 16).into_font().color(&GREY_), (24, 50))
            .map_err(err)?;
        let (plot_area, legend_area) = rest.split_horizontally(WIDTH - LEGEND_WIDTH);
        draw_plot(chart, &plot_area)?;
        draw_legend(chart, &legend_area)?;
        root.present().map_err(err)?;
    }
    let image = image::RgbImage::from_raw(WIDTH, HEIGHT, buffer)
        .ok_or_else(|| anyhow!("bad image buffer"))?;
    crate::files::write_atomic(path, |out| Ok(image.write_to(out, image::ImageFormat::Png)?))?;
    Ok(())
}

fn draw_plot<DB: DrawingBackend>(
    chart: &Chart,
    area: &DrawingArea<DB, Shift>,
) -> anyhow::Result<()> {
    let xs = chart.series.iter().flat_map(|s| s.points.iter().map(|p| p.0));
    let ys = chart
        .series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.1))
        .chain(chart.hlines.iter().map(|h| h.0));
    let (x_pad, y_pad) = match chart.x_axis {
        XAxis::Count => (1.6, 1.6),
        XAxis::Pixels | XAxis::Copies => (1.35, 1.6),
    };
    let (x_lo, x_hi) = log_range(xs, x_pad);
    let (y_lo, y_hi) = log_range(ys, y_pad);
    let (y_lo, y_hi) = (snap_125(y_lo, false), snap_125(y_hi, true));
    let (x_bold, x_light) = match chart.x_axis {
        XAxis::Count => log_ticks(x_lo, x_hi),
        XAxis::Pixels | XAxis::Copies => {
            let mut v: Vec<f64> =
                chart.series.iter().flat_map(|s| s.points.iter().map(|p| p.0)).collect();
            v.sort_by(f64::total_cmp);
            v.dedup();
            (v, Vec::new())
        }
    };
    let (y_bold, y_light) = log_ticks(y_lo, y_hi);
    let x_spec = (x_lo..x_hi).log_scale().with_key_points(x_bold).with_light_points(x_light);
    let y_spec = (y_lo..y_hi).log_scale().with_key_points(y_bold).with_light_points(y_light);
    let x_axis = chart.x_axis;
    let x_format = move |v: &f64| match x_axis {
        XAxis::Count => count_label(*v),
        XAxis::Pixels => pixels_label(*v),
        XAxis::Copies => short_number(*v),
    };
    let mut ctx = ChartBuilder::on(area)
        .margin_left(12)
        .margin_right(24)
        .margin_top(12)
        .margin_bottom(8)
        .x_label_area_size(62)
        .y_label_area_size(86)
        .build_cartesian_2d(x_spec, y_spec)
        .map_err(err)?;
    ctx.configure_mesh()
        .x_desc(chart.x_desc.as_str())
        .y_desc(chart.y_desc.as_str())
        .axis_desc_style((FAMILY, 19))
        .label_style((FAMILY, 16))
        .x_label_formatter(&x_format)
        .y_label_formatter(&|v: &f64| short_number(*v))
        .bold_line_style(BLACK.mix(0.18))
        .light_line_style(BLACK.mix(0.06))
        .draw()
        .map_err(err)?;
    let label_font = (FAMILY, 15).into_font().color(&GREY_);
    for (y, label) in &chart.hlines {
        let style = GREY_.stroke_width(2);
        ctx.draw_series(DashedLineSeries::new([(x_lo, *y), (x_hi, *y)], 12, 8, style))
            .map_err(err)?;
        let width = (label.chars().count() as i32) * 8 + 12;
        ctx.draw_series(std::iter::once(
            EmptyElement::at((x_hi, *y))
                + Text::new(label.clone(), (-width, -22), label_font.clone()),
        ))
        .map_err(err)?;
    }
    for s in &chart.series {
        let points = s.sorted();
        let xy = points.iter().map(|p| (p.0, p.1));
        let style = s.color.stroke_width(2);
        match s.line {
            Line::None => {}
            Line::Solid => {
                ctx.draw_series(LineSeries::new(xy.clone(), style)).map_err(err)?;
            }
            Line::Dashed => {
                ctx.draw_series(DashedLineSeries::new(xy.clone(), 10, 6, style)).map_err(err)?;
            }
        }
        let plot = ctx.plotting_area();
        for p in &points {
            draw_marker(plot, (p.0, p.1), s.marker, s.color)?;
            if !p.2.is_empty() {
                // Below the point when a labelled neighbour (within a factor 2 in x) is higher.
                let below = points
                    .iter()
                    .any(|q| !q.2.is_empty() && q.1 > p.1 && (q.0 / p.0).abs().log2().abs() < 1.0);
                let font = (FAMILY, 15).into_font().color(&s.color);
                let offset = if below { (10, 4) } else { (10, -22) };
                plot.draw(&(EmptyElement::at((p.0, p.1)) + Text::new(p.2.clone(), offset, font)))
                    .map_err(err)?;
            }
        }
    }
    Ok(())
}

/// A marker centred on `at`.
fn draw_marker<DB, CT>(
    area: &DrawingArea<DB, CT>,
    at: CT::From,
    marker: Marker,
    color: RGBColor,
) -> anyhow::Result<()>
where
    DB: DrawingBackend,
    CT: plotters::coord::CoordTranslate,
    CT::From: Clone,
{
    let fill = color.filled();
    let outline = WHITE.stroke_width(1);
    match marker {
        Marker::Circle => {
            area.draw(&(EmptyElement::at(at.clone()) + Circle::new((0, 0), 6, fill)))
                .map_err(err)?;
            area.draw(&(EmptyElement::at(at) + Circle::new((0, 0), 6, outline))).map_err(err)?;
        }
        Marker::Square => {
            area.draw(&(EmptyElement::at(at.clone()) + Rectangle::new([(-5, -5), (5, 5)], fill)))
                .map_err(err)?;
            area.draw(&(EmptyElement::at(at) + Rectangle::new([(-5, -5), (5, 5)], outline)))
                .map_err(err)?;
        }
        Marker::Triangle => {
            area.draw(&(EmptyElement::at(at) + Polygon::new(vec![(0, -8), (-7, 5), (7, 5)], fill)))
                .map_err(err)?;
        }
        Marker::Diamond => {
            area.draw(
                &(EmptyElement::at(at)
                    + Polygon::new(vec![(0, -8), (7, 0), (0, 8), (-7, 0)], fill)),
            )
            .map_err(err)?;
        }
    }
    Ok(())
}

/// Words of `text` in lines of at most `width` characters.
fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines = vec![String::new()];
    for word in text.split(' ') {
        let last = lines.last_mut().unwrap();
        if !last.is_empty() && last.chars().count() + 1 + word.chars().count() > width {
            lines.push(word.to_string());
        } else {
            if !last.is_empty() {
                last.push(' ');
            }
            last.push_str(word);
        }
    }
    lines
}

fn draw_legend<DB: DrawingBackend>(
    chart: &Chart,
    area: &DrawingArea<DB, Shift>,
) -> anyhow::Result<()> {
    let font = (FAMILY, 16).into_font().color(&BLACK);
    let line_height = 20;
    let mut y = 22;
    area.draw_text("Legend", &(FAMILY, 18).into_font().color(&GREY_), (16, y)).map_err(err)?;
    y += 32;
    for s in &chart.series {
        let mid = y + 9;
        let style = s.color.stroke_width(2);
        match s.line {
            Line::None => {}
            Line::Solid => {
                area.draw(&PathElement::new(vec![(14, mid), (62, mid)], style)).map_err(err)?
            }
            Line::Dashed => area
                .draw(&plotters::element::DashedPathElement::new(
                    vec![(14, mid), (62, mid)],
                    8,
                    5,
                    style,
                ))
                .map_err(err)?,
        }
        draw_marker(area, (38, mid), s.marker, s.color)?;
        let lines = wrap(&s.label, 38);
        for (i, l) in lines.iter().enumerate() {
            area.draw_text(l, &font, (74, y + i as i32 * line_height)).map_err(err)?;
        }
        y += lines.len() as i32 * line_height + 12;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wraps_on_words() {
        assert_eq!(
            wrap("ours, BVH: torus knots, 1024², 2 bounces", 20),
            vec!["ours, BVH: torus", "knots, 1024², 2", "bounces"]
        );
    }
}
