//! Scatter plots of particles coloured by a field, as SVG of bounded size.
//!
//! [`scatter_plot`] draws the particles of a 2D domain at their positions `(x, y)`, coloured by
//! a value through the viridis colour map, with a colour bar to the right of (never over) the
//! data. Both axes have the same scale, so the domain keeps its physical shape.
//!
//! * Up to [`MAX_MARKS`] particles, each particle is one small filled square.
//! * Beyond that the particles are binned onto a regular raster of at most [`MAX_MARKS`] cells
//!   whose shape follows the aspect of the particles' bounding box (square cells, at least
//!   2 px across), and each non-empty cell is drawn as one filled rectangle coloured by the
//!   mean value of its particles; the caption says so. The file size is therefore bounded
//!   (about 300 kB) however many particles there are.
//!
//! Particles with a non-finite coordinate or value are skipped and counted in the caption. The
//! colour scale spans the minimum to the maximum of the drawn values (widened symmetrically if
//! they are all equal). The SVG is written by hand, in the style of the plotters figures of
//! [`crate::output::plot`] (sans-serif `<text>` elements, rendered by the viewer: no font
//! library is needed), and atomically ([`write_atomic`]).
//!
//! Never panics: `x`, `y` and `value` of different lengths give [`Error::InvalidValue`];
//! positions or values spanning a range wider than `f64` can represent give
//! [`Error::WriteOutput`]; empty, all-NaN or single-point data give a valid, mostly empty
//! figure.

use crate::error::{Error, Result};
use crate::output::atomic::write_atomic;
use std::fmt::Write as _;
use std::path::Path;

/// The most marks a scatter plot draws.
pub const MAX_MARKS: usize = 4096;

/// Labels of a scatter plot.
pub struct ScatterAxes<'a> {
    /// Title above the plot (omitted if empty).
    pub title: &'a str,
    /// Label of the horizontal axis.
    pub x_label: &'a str,
    /// Label of the vertical axis.
    pub y_label: &'a str,
    /// Label of the colour bar (the plotted field, with its unit).
    pub colour_label: &'a str,
}

mod colour;
mod raster;
#[cfg(test)]
mod tests;
mod ticks;

use colour::*;
use raster::*;
use ticks::*;

/// Largest width of the plotting area, in pixels.
const MAX_PLOT_W: f64 = 600.0;
/// Largest height of the plotting area, in pixels.
const MAX_PLOT_H: f64 = 520.0;
/// Smallest height of the colour bar (and of the band holding the plot), in pixels.
const MIN_BAND_H: f64 = 260.0;
/// Each axis spans at least this fraction of the other, so that a thin strip of particles
/// still gets a readable plot (with empty space around the strip).
const MIN_EXTENT: f64 = 0.15;
/// Padding around the particles on each side, as a fraction of the larger extent.
const PAD: f64 = 0.05;
/// Outer margin of the figure, in pixels.
const MARGIN: f64 = 15.0;
/// Font sizes, in pixels (those of [`crate::output::plot`]).
const TITLE_SIZE: f64 = 22.0;
const CAPTION_SIZE: f64 = 13.0;
const DESC_SIZE: f64 = 16.0;
const LABEL_SIZE: f64 = 13.0;
/// Average advance of one character in em, for layout estimates.
const CHAR_WIDTH: f64 = 0.62;
/// Length of a tick mark, in pixels.
const TICK_LEN: f64 = 5.0;
/// Gap between the plotting area and the colour bar, in pixels.
const BAR_GAP: f64 = 30.0;
/// Width of the colour bar, in pixels.
const BAR_WIDTH: f64 = 18.0;
/// The least number of labelled values on the colour bar.
const BAR_TICKS: usize = 5;
/// Smallest side of a raster cell (and of a drawn rectangle), in pixels.
const MIN_CELL_PX: f64 = 2.0;
/// Side of a particle's square mark is `MARK_FILL * sqrt(area per particle)`, clamped to
/// [`MIN_MARK_PX`]..[`MAX_MARK_PX`].
const MARK_FILL: f64 = 0.7;
const MIN_MARK_PX: f64 = 2.0;
const MAX_MARK_PX: f64 = 8.0;
/// Below this magnitude, data is treated as zero.
const TINY: f64 = 1e-250;

/// Plot points `(x[k], y[k])` coloured by `value[k]` (a colour bar at the right, outside the
/// data), write SVG to `path` atomically ([`write_atomic`]).
///
/// At most [`MAX_MARKS`] marks are drawn: more particles are binned onto a raster and drawn
/// as one rectangle per non-empty cell, coloured by the mean value of its particles. Particles
/// with a non-finite coordinate or value are skipped. Fails with [`Error::InvalidValue`] if
/// the slices differ in length, and with [`Error::WriteOutput`] if the positions or values
/// span a range too wide to plot or the file cannot be written.
pub fn scatter_plot(
    path: &Path,
    axes: &ScatterAxes<'_>,
    x: &[f64],
    y: &[f64],
    value: &[f64],
) -> Result<()> {
    if x.len() != y.len() || x.len() != value.len() {
        return Err(Error::invalid(
            "scatter_plot",
            format!("{} x, {} y, {} values", x.len(), y.len(), value.len()),
            "x, y and value must have the same length",
        ));
    }
    let stats = Stats::of(x, y, value);
    let (x_range, y_range) = axis_ranges(stats.bounds())
        .ok_or_else(|| Error::write(path, "particle positions span a range too wide to plot"))?;
    let scale = ColourScale::new(stats.v_min, stats.v_max)
        .ok_or_else(|| Error::write(path, "values span a range too wide to plot"))?;
    let svg = render(axes, &stats, (x, y, value), (x_range, y_range), &scale);
    write_atomic(path, svg.as_bytes())
}

/// Whether a particle is drawn: finite position and value.
fn drawable(x: f64, y: f64, v: f64) -> bool {
    x.is_finite() && y.is_finite() && v.is_finite()
}

/// Counts and ranges of the drawable particles.
#[derive(Clone, Copy, Debug)]
struct Stats {
    /// All particles.
    total: usize,
    /// Particles with finite position and value.
    drawn: usize,
    x_min: f64,
    x_max: f64,
    y_min: f64,
    y_max: f64,
    v_min: f64,
    v_max: f64,
}

impl Stats {
    /// One pass over the particles (slices of equal length).
    fn of(x: &[f64], y: &[f64], value: &[f64]) -> Self {
        let mut s = Stats {
            total: x.len(),
            drawn: 0,
            x_min: f64::INFINITY,
            x_max: f64::NEG_INFINITY,
            y_min: f64::INFINITY,
            y_max: f64::NEG_INFINITY,
            v_min: f64::INFINITY,
            v_max: f64::NEG_INFINITY,
        };
        for ((&x, &y), &v) in x.iter().zip(y).zip(value) {
            if !drawable(x, y, v) {
                continue;
            }
            s.drawn += 1;
            s.x_min = s.x_min.min(x);
            s.x_max = s.x_max.max(x);
            s.y_min = s.y_min.min(y);
            s.y_max = s.y_max.max(y);
            s.v_min = s.v_min.min(v);
            s.v_max = s.v_max.max(v);
        }
        s
    }

    /// Bounding box of the drawn particles, `None` if there are none.
    fn bounds(&self) -> Option<((f64, f64), (f64, f64))> {
        (self.drawn > 0).then_some(((self.x_min, self.x_max), (self.y_min, self.y_max)))
    }
}

/// Axis ranges with equal scale for a bounding box: the box padded by [`PAD`] of its larger
/// extent on each side, each axis at least [`MIN_EXTENT`] of the other, a zero-size box padded
/// around its centre, `0..1` squared without data; `None` if not representable.
fn axis_ranges(bounds: Option<((f64, f64), (f64, f64))>) -> Option<((f64, f64), (f64, f64))> {
    let Some(((x0, x1), (y0, y1))) = bounds else {
        return Some(((0.0, 1.0), (0.0, 1.0)));
    };
    let magnitude = x0.abs().max(x1.abs()).max(y0.abs()).max(y1.abs());
    let (sx, sy) = (x1 - x0, y1 - y0);
    if !sx.is_finite() || !sy.is_finite() {
        return None;
    }
    let span = sx.max(sy);
    let (ex, ey) = if magnitude < TINY {
        (2.0, 2.0)
    } else if span <= magnitude * 1e-9 {
        (0.1 * magnitude, 0.1 * magnitude)
    } else {
        (sx.max(MIN_EXTENT * span), sy.max(MIN_EXTENT * span))
    };
    let pad = PAD * ex.max(ey);
    let around = |lo: f64, hi: f64, extent: f64| {
        let centre = 0.5 * lo + 0.5 * hi;
        let half = 0.5 * extent + pad;
        let (a, b) = (centre - half, centre + half);
        (a.is_finite() && b.is_finite() && (b - a).is_finite() && a < b).then_some((a, b))
    };
    Some((around(x0, x1, ex)?, around(y0, y1, ey)?))
}

/// Size in pixels of a plotting area with equal scales for axis spans `xr` and `yr` (both
/// positive): as large as fits in [`MAX_PLOT_W`] × [`MAX_PLOT_H`].
fn plot_size(xr: f64, yr: f64) -> (f64, f64) {
    let k = (MAX_PLOT_W / xr).min(MAX_PLOT_H / yr);
    (xr * k, yr * k)
}

/// Text with the XML special characters escaped and line breaks as spaces.
fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            '\n' | '\r' => out.push(' '),
            c if c.is_control() => {}
            c => out.push(c),
        }
    }
    out
}

/// Coordinate rounded to 0.1 px (so that shared raster edges are written identically).
fn round1(v: f64) -> f64 {
    (v * 10.0).round() / 10.0
}

/// The caption line under the title: how many particles, how they are drawn, skipped ones,
/// and the range of the values.
fn caption(stats: &Stats, raster: Option<(usize, usize)>, scale: &ColourScale) -> String {
    let mut s = match raster {
        _ if stats.drawn == 0 => "no particles to draw".to_string(),
        Some((nx, ny)) => format!(
            "{} particles binned to a {nx} × {ny} raster, mean per bin",
            stats.drawn
        ),
        None if stats.drawn == 1 => "1 particle".to_string(),
        None => format!("{} particles", stats.drawn),
    };
    let skipped = stats.total - stats.drawn;
    if skipped > 0 {
        let _ = write!(s, "; {skipped} skipped (non-finite)");
    }
    if stats.drawn > 0 {
        if scale.widened {
            let _ = write!(s, "; all values = {}", short_number(stats.v_min));
        } else {
            let _ = write!(
                s,
                "; values in [{}, {}]",
                short_number(stats.v_min),
                short_number(stats.v_max)
            );
        }
    }
    s
}

/// Draw the figure into an SVG string.
fn render(
    axes: &ScatterAxes<'_>,
    stats: &Stats,
    (x, y, value): (&[f64], &[f64], &[f64]),
    (x_range, y_range): ((f64, f64), (f64, f64)),
    scale: &ColourScale,
) -> String {
    // Layout.
    let (xr, yr) = (x_range.1 - x_range.0, y_range.1 - y_range.0);
    let (pw, ph) = plot_size(xr, yr);
    let k = pw / xr;
    let x_ticks = axis_ticks(x_range, pw, false);
    let y_ticks = axis_ticks(y_range, ph, true);
    let bar_ticks = nice_ticks(scale.lo, scale.hi, BAR_TICKS);
    let band = ph.max(MIN_BAND_H);
    let title_h = if axes.title.is_empty() {
        0.0
    } else {
        TITLE_SIZE + 8.0
    };
    let top = MARGIN + title_h + CAPTION_SIZE + 16.0;
    let y_desc_w = if axes.y_label.is_empty() {
        0.0
    } else {
        DESC_SIZE + 10.0
    };
    let binned = stats.drawn > MAX_MARKS;
    let raster_shape_px = if binned {
        let bw = (stats.x_max - stats.x_min) * k;
        let bh = (stats.y_max - stats.y_min) * k;
        Some(raster_shape(bw, bh, MAX_MARKS, MIN_CELL_PX))
    } else {
        None
    };
    let caption = caption(stats, raster_shape_px, scale);
    // Horizontal layout, from the left edge of the content: y label, y tick labels, plot,
    // colour bar, its tick labels, its label. The content is centred if the title or the
    // caption is wider.
    let plot_left = y_desc_w + y_ticks.label_width() + 6.0 + TICK_LEN;
    let bar_from_plot = pw + BAR_GAP;
    let bar_labels_from_bar = BAR_WIDTH + TICK_LEN + 4.0;
    let colour_desc_from_bar_labels = bar_ticks.label_width() + 10.0 + 0.8 * DESC_SIZE;
    let content = plot_left
        + bar_from_plot
        + bar_labels_from_bar
        + colour_desc_from_bar_labels
        + if axes.colour_label.is_empty() {
            0.0
        } else {
            0.3 * DESC_SIZE
        };
    let width = (content + 2.0 * MARGIN)
        .max(text_width(axes.title.chars().count(), TITLE_SIZE) + 2.0 * MARGIN)
        .max(text_width(caption.chars().count(), CAPTION_SIZE) + 2.0 * MARGIN)
        .ceil();
    let content_left = (0.5 * (width - content)).floor();
    let left = content_left + plot_left;
    let (x0, y0) = (left, top + 0.5 * (band - ph));
    let bar_x = left + bar_from_plot;
    let bar_label_x = bar_x + bar_labels_from_bar;
    let colour_desc_x = bar_label_x + colour_desc_from_bar_labels;
    let x_label_base = y0 + ph + TICK_LEN + 4.0 + LABEL_SIZE;
    let x_desc_base = x_label_base + 10.0 + DESC_SIZE;
    let height = ((top + band).max(x_desc_base + 5.0) + MARGIN).ceil();
    let to_px = |px: f64, py: f64| (x0 + (px - x_range.0) * k, y0 + (y_range.1 - py) * k);

    let mut svg = String::with_capacity(if binned {
        300_000
    } else {
        4096 + 64 * stats.drawn
    });
    let _ = write!(
        svg,
        r#"<svg width="{width}" height="{height}" viewBox="0 0 {width} {height}" xmlns="http://www.w3.org/2000/svg" font-family="sans-serif">"#
    );
    svg.push('\n');
    let _ = writeln!(
        svg,
        r##"<rect x="0" y="0" width="{width}" height="{height}" fill="#FFFFFF"/>"##
    );
    let _ = writeln!(
        svg,
        r#"<defs><linearGradient id="viridis" x1="0" y1="1" x2="0" y2="0">"#
    );
    for (i, &c) in VIRIDIS.iter().enumerate() {
        let offset = i as f64 / (VIRIDIS.len() - 1) as f64;
        let _ = writeln!(
            svg,
            r#"<stop offset="{offset:.4}" stop-color="{}"/>"#,
            hex(c)
        );
    }
    let _ = writeln!(svg, "</linearGradient></defs>");

    // Title and caption.
    let mut line_y = MARGIN;
    if !axes.title.is_empty() {
        line_y += TITLE_SIZE;
        let _ = writeln!(
            svg,
            r#"<text x="{:.1}" y="{line_y:.1}" font-size="{TITLE_SIZE}" text-anchor="middle">{}</text>"#,
            0.5 * width,
            escape(axes.title)
        );
        line_y += 8.0;
    }
    line_y += CAPTION_SIZE;
    let _ = writeln!(
        svg,
        r##"<text x="{:.1}" y="{line_y:.1}" font-size="{CAPTION_SIZE}" text-anchor="middle" fill="#444444">{}</text>"##,
        0.5 * width,
        escape(&caption)
    );

    // Grid lines.
    let mut grid = String::new();
    for &v in &x_ticks.values {
        let (px, _) = to_px(v, y_range.0);
        let _ = write!(grid, "M{:.1} {:.1}V{:.1}", px, y0, y0 + ph);
    }
    for &v in &y_ticks.values {
        let (_, py) = to_px(x_range.0, v);
        let _ = write!(grid, "M{:.1} {:.1}H{:.1}", x0, py, x0 + pw);
    }
    let _ = writeln!(
        svg,
        r##"<path d="{grid}" stroke="#000000" stroke-opacity="0.1" fill="none"/>"##
    );

    // Marks.
    if let Some((nx, ny)) = raster_shape_px {
        let raster = bin_mean(
            x,
            y,
            value,
            (stats.x_min, stats.x_max),
            (stats.y_min, stats.y_max),
            nx,
            ny,
        );
        let (bx0, by1) = to_px(stats.x_min, stats.y_min);
        let cw = (stats.x_max - stats.x_min) * k / nx as f64;
        let ch = (stats.y_max - stats.y_min) * k / ny as f64;
        // Cell edges along one axis, widened about the centre to MIN_CELL_PX.
        let edges = |start: f64, size: f64, i: usize| {
            let (a, b) = (start + i as f64 * size, start + (i + 1) as f64 * size);
            if b - a < MIN_CELL_PX {
                let c = 0.5 * (a + b);
                (round1(c - 0.5 * MIN_CELL_PX), round1(c + 0.5 * MIN_CELL_PX))
            } else {
                (round1(a), round1(b))
            }
        };
        let _ = writeln!(svg, r#"<g id="marks" shape-rendering="crispEdges">"#);
        for j in 0..ny {
            // Rows grow upwards from the bottom edge of the bounding box.
            let (ya, yb) = edges(-by1, ch, j);
            for i in 0..nx {
                let Some(mean) = raster.cell_mean(i, j) else {
                    continue;
                };
                let (xa, xb) = edges(bx0, cw, i);
                let _ = writeln!(
                    svg,
                    r#"<rect x="{xa:.1}" y="{:.1}" width="{:.1}" height="{:.1}" fill="{}"/>"#,
                    -yb,
                    xb - xa,
                    yb - ya,
                    hex(scale.colour(mean))
                );
            }
        }
    } else {
        let side = if stats.drawn > 0 {
            (MARK_FILL * (pw * ph / stats.drawn as f64).sqrt()).clamp(MIN_MARK_PX, MAX_MARK_PX)
        } else {
            MIN_MARK_PX
        };
        let _ = writeln!(svg, r#"<g id="marks">"#);
        for ((&px, &py), &v) in x.iter().zip(y).zip(value) {
            if !drawable(px, py, v) {
                continue;
            }
            let (sx, sy) = to_px(px, py);
            let _ = writeln!(
                svg,
                r#"<rect x="{:.1}" y="{:.1}" width="{side:.1}" height="{side:.1}" fill="{}"/>"#,
                sx - 0.5 * side,
                sy - 0.5 * side,
                hex(scale.colour(v))
            );
        }
    }
    let _ = writeln!(svg, "</g>");

    // Frame, ticks and tick labels of the axes.
    let _ = writeln!(
        svg,
        r##"<rect x="{x0:.1}" y="{y0:.1}" width="{pw:.1}" height="{ph:.1}" fill="none" stroke="#000000"/>"##
    );
    let mut ticks = String::new();
    let mut labels = String::new();
    for (&v, label) in x_ticks.values.iter().zip(&x_ticks.labels) {
        let (px, _) = to_px(v, y_range.0);
        let _ = write!(ticks, "M{:.1} {:.1}v{TICK_LEN}", px, y0 + ph);
        if !label.is_empty() {
            let _ = writeln!(
                labels,
                r#"<text x="{px:.1}" y="{x_label_base:.1}" font-size="{LABEL_SIZE}" text-anchor="middle">{}</text>"#,
                escape(label)
            );
        }
    }
    for (&v, label) in y_ticks.values.iter().zip(&y_ticks.labels) {
        let (_, py) = to_px(x_range.0, v);
        let _ = write!(ticks, "M{:.1} {:.1}h-{TICK_LEN}", x0, py);
        if !label.is_empty() {
            let _ = writeln!(
                labels,
                r#"<text x="{:.1}" y="{py:.1}" dy="0.35em" font-size="{LABEL_SIZE}" text-anchor="end">{}</text>"#,
                x0 - TICK_LEN - 4.0,
                escape(label)
            );
        }
    }

    // Colour bar, with its ticks on the right.
    let _ = writeln!(
        svg,
        r##"<rect x="{bar_x:.1}" y="{top:.1}" width="{BAR_WIDTH}" height="{band:.1}" fill="url(#viridis)" stroke="#000000"/>"##
    );
    for (&v, label) in bar_ticks.values.iter().zip(&bar_ticks.labels) {
        let py = top + band * (1.0 - scale.fraction(v));
        let _ = write!(ticks, "M{:.1} {:.1}h{TICK_LEN}", bar_x + BAR_WIDTH, py);
        if !label.is_empty() {
            let _ = writeln!(
                labels,
                r#"<text x="{bar_label_x:.1}" y="{py:.1}" dy="0.35em" font-size="{LABEL_SIZE}" text-anchor="start">{}</text>"#,
                escape(label)
            );
        }
    }
    let _ = writeln!(svg, r##"<path d="{ticks}" stroke="#000000" fill="none"/>"##);
    svg.push_str(&labels);

    // Axis and colour bar descriptions.
    if !axes.x_label.is_empty() {
        let _ = writeln!(
            svg,
            r#"<text x="{:.1}" y="{x_desc_base:.1}" font-size="{DESC_SIZE}" text-anchor="middle">{}</text>"#,
            x0 + 0.5 * pw,
            escape(axes.x_label)
        );
    }
    let vertical_text = |svg: &mut String, cx: f64, cy: f64, text: &str| {
        let _ = writeln!(
            svg,
            r#"<text x="{cx:.1}" y="{cy:.1}" font-size="{DESC_SIZE}" text-anchor="middle" transform="rotate(-90 {cx:.1} {cy:.1})">{}</text>"#,
            escape(text)
        );
    };
    if !axes.y_label.is_empty() {
        vertical_text(
            &mut svg,
            content_left + 0.8 * DESC_SIZE,
            y0 + 0.5 * ph,
            axes.y_label,
        );
    }
    if !axes.colour_label.is_empty() {
        vertical_text(&mut svg, colour_desc_x, top + 0.5 * band, axes.colour_label);
    }
    svg.push_str("</svg>\n");
    svg
}
