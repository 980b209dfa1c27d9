//! The legend of the line and point plots ([`crate::output::plot`]): a panel to the right
//! of the plotting area, so that it never covers data, one row per labelled series with its
//! line sample or marker in the series' colour and shape.
//!
//! The panel is as wide as the longest label needs (at about 7.5 px per character of the
//! 14 px font, capped at [`MAX_WIDTH`] px) and the figure grows by that width, so the
//! plotting area keeps its size whatever the labels.

use plotters::backend::SVGBackend;
use plotters::coord::Shift;
use plotters::drawing::{DrawingArea, DrawingAreaErrorKind};
use plotters::element::{Circle, Cross, PathElement, Rectangle, Text, TriangleMarker};
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{Color, IntoFont, RGBColor, BLACK, WHITE};

/// Marker shapes of point series.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Marker {
    Circle,
    Square,
    Triangle,
    Cross,
}

/// How a legend row shows its series.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Sample {
    /// A short line of the given width.
    Line(u32),
    /// A marker.
    Marker(Marker),
}

/// One legend row.
#[derive(Clone, Debug)]
pub(crate) struct LegendEntry {
    pub label: String,
    pub colour: RGBColor,
    pub sample: Sample,
}

/// Widest legend panel, in pixels (longer labels run past the figure's right edge).
pub(crate) const MAX_WIDTH: u32 = 420;

/// Label font size in pixels.
const FONT: u32 = 14;
/// Height of one row in pixels.
const ROW: i32 = 20;
/// Width reserved for the line sample or marker in front of a label.
const SAMPLE_WIDTH: i32 = 30;
/// Inner padding of the panel box and gap to the plotting area.
const PAD: i32 = 10;
/// Approximate advance of one character of the label font (a sans-serif font at 14 px
/// averages about 7 px per character; a little more keeps long labels inside).
const CHAR_WIDTH: f64 = 7.5;

/// Width of the legend panel for `entries` (0 when there are none).
pub(crate) fn panel_width(entries: &[LegendEntry]) -> u32 {
    let chars = entries
        .iter()
        .map(|e| e.label.chars().count())
        .max()
        .unwrap_or(0);
    if entries.is_empty() {
        return 0;
    }
    let width = PAD + 2 * PAD + SAMPLE_WIDTH + (CHAR_WIDTH * chars as f64).ceil() as i32 + PAD;
    (width.max(0) as u32).min(MAX_WIDTH)
}

/// Draw the legend into `panel` (its own pixel coordinates), the box's top at `top`.
pub(crate) fn draw_legend(
    panel: &DrawingArea<SVGBackend<'_>, Shift>,
    entries: &[LegendEntry],
    top: i32,
) -> Result<(), DrawingAreaErrorKind<std::io::Error>> {
    if entries.is_empty() {
        return Ok(());
    }
    let (width, height) = panel.dim_in_pixel();
    // Rows shrink (to no less than 12 px) when many series would run past the bottom.
    let available = height as i32 - top - PAD;
    let row = (available / entries.len() as i32).clamp(12, ROW);
    let left = PAD;
    let right = width as i32 - 2;
    let bottom = top + row * entries.len() as i32 + PAD;
    panel.draw(&Rectangle::new(
        [(left, top), (right, bottom)],
        WHITE.filled(),
    ))?;
    panel.draw(&Rectangle::new([(left, top), (right, bottom)], BLACK))?;
    let font = ("sans-serif", FONT).into_font();
    for (k, entry) in entries.iter().enumerate() {
        let y = top + PAD / 2 + row * k as i32 + row / 2;
        let x = left + PAD;
        let colour = entry.colour;
        let r = 3;
        match entry.sample {
            Sample::Line(w) => panel.draw(&PathElement::new(
                vec![(x, y), (x + 20, y)],
                colour.stroke_width(w),
            ))?,
            Sample::Marker(Marker::Circle) => {
                panel.draw(&Circle::new((x + 10, y), r, colour.filled()))?
            }
            Sample::Marker(Marker::Square) => panel.draw(&Rectangle::new(
                [(x + 10 - r, y - r), (x + 10 + r, y + r)],
                colour.filled(),
            ))?,
            Sample::Marker(Marker::Triangle) => {
                panel.draw(&TriangleMarker::new((x + 10, y), r + 1, colour.filled()))?
            }
            Sample::Marker(Marker::Cross) => {
                panel.draw(&Cross::new((x + 10, y), r, colour.stroke_width(2)))?
            }
        }
        panel.draw(&Text::new(
            entry.label.clone(),
            (x + SAMPLE_WIDTH, y),
            font.clone()
                .color(&BLACK)
                .pos(Pos::new(HPos::Left, VPos::Center)),
        ))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entry(label: &str) -> LegendEntry {
        LegendEntry {
            label: label.into(),
            colour: BLACK,
            sample: Sample::Line(2),
        }
    }

    #[test]
    fn the_panel_fits_the_longest_label_up_to_a_cap() {
        assert_eq!(panel_width(&[]), 0);
        let short = panel_width(&[entry("MPM")]);
        let long = panel_width(&[entry("MPM"), entry("BSMPM-TLS-USL consistent")]);
        assert!(short < long, "{short} {long}");
        // 24 characters at 7.5 px plus the sample and padding.
        assert!(long as f64 >= 24.0 * CHAR_WIDTH + SAMPLE_WIDTH as f64);
        assert_eq!(panel_width(&[entry(&"x".repeat(500))]), MAX_WIDTH);
    }
}
