//! SVG plots (plotters, SVG backend only: no system font libraries).
//!
//! Three kinds of figure are produced, SVG files of 800 × 560 px plus the legend panel, written atomically
//! (temporary file + rename, [`write_atomic`]):
//!
//! * [`profile_plot`]: linear axes, e.g. a stress or velocity profile against position, with
//!   numerical values drawn as points and the exact solution as a line;
//! * [`loglog_plot`]: logarithmic axes, e.g. the RMS error against the cell size `h` of a
//!   convergence study;
//! * [`semilogy_plot`]: linear `x`, logarithmic `y`, e.g. the error at every particle
//!   against its position (errors of 1e-3 and 1e-10 both readable).
//!
//! Each figure has a title, axis labels, a grid, one colour (and, past ten series, marker
//! shape) per series, and a legend in a panel right of the plotting area, so that it never
//! covers data ([`crate::output::legend`]; the figure widens by the panel's width).
//! Series longer than a few thousand points are thinned to what the figure can show
//! ([`crate::output::thinning`]), so the file size does not grow with the particle count.
//! Text is written as SVG `<text>` elements and rendered by the viewer, so no font file or
//! font library is needed.
//!
//! The functions never panic on awkward data: non-finite points are skipped (a line is broken
//! there), `x` and `y` of different lengths are truncated to the shorter, a zero data range is
//! padded, and an empty figure still gets its axes. Data that cannot be placed on an axis (a
//! range wider than `f64` can represent) gives [`Error::WriteOutput`] instead.

use crate::error::{Error, Result};
use crate::output::atomic::write_atomic;
use crate::output::legend::{draw_legend, panel_width, LegendEntry, Marker, Sample};
use crate::output::series::{bounds, prepare, Prepared};
pub use crate::output::series::{Series, Style, Values};
use plotters::backend::SVGBackend;
use plotters::chart::ChartBuilder;
use plotters::coord::combinators::{BindKeyPoints, IntoLogRange};
use plotters::coord::ranged1d::{AsRangedCoord, Ranged, ValueFormatter};
use plotters::drawing::{DrawingAreaErrorKind, IntoDrawingArea};
use plotters::element::{Circle, Cross, EmptyElement, Rectangle, Text, TriangleMarker};
use plotters::series::LineSeries;
use plotters::style::{Color, IntoFont, RGBColor, BLACK, WHITE};
use std::path::Path;

/// Figure size in pixels.
const SIZE: (u32, u32) = (800, 560);

/// Series colours (Tableau 10), used in order and then cycled.
const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// Line width of [`Style::Line`] series, in pixels.
const LINE_WIDTH: u32 = 2;

/// Line width of [`Style::Reference`] series, in pixels.
const REFERENCE_WIDTH: u32 = 1;

/// Marker shapes; series `k` (counting the non-reference series) gets colour
/// `k % 10` and shape `k / 10 % 4`, so that up to 40 series of a plot all look different.
const MARKERS: [Marker; 4] = [
    Marker::Circle,
    Marker::Square,
    Marker::Triangle,
    Marker::Cross,
];

/// Marker radius of [`Style::Points`] series, in pixels.
const POINT_RADIUS: i32 = 3;

/// Multiplicative padding of a log axis range on each side.
const LOG_PAD: f64 = 1.2;

/// Below this magnitude all data on a linear axis is treated as zero (the tick computation
/// of plotters is not reliable with subnormal spans).
const TINY: f64 = 1e-250;

/// Axis labels and title.
pub struct Axes<'a> {
    /// Title above the plot (omitted if empty).
    pub title: &'a str,
    /// Label of the horizontal axis.
    pub x_label: &'a str,
    /// Label of the vertical axis.
    pub y_label: &'a str,
}

/// Linear-axes profile plot (e.g. stress against position, numerical points vs exact line).
///
/// Non-finite points are skipped. Writes an SVG file to `path` atomically; fails with
/// [`Error::WriteOutput`] if the data range cannot be represented or the file cannot be written.
pub fn profile_plot(path: &Path, axes: &Axes, series: &[Series]) -> Result<()> {
    let finite = |v: f64| v.is_finite();
    let extent = bounds(series, finite, finite);
    let ((x_min, x_max), (y_min, y_max)) = (extent.x, extent.y);
    let x_range = linear_range(x_min, x_max)
        .ok_or_else(|| Error::write(path, "x data range too wide to plot"))?;
    let y_range = linear_range(y_min, y_max)
        .ok_or_else(|| Error::write(path, "y data range too wide to plot"))?;
    let to_pixel = pixel_map(x_range, y_range, |v| v, |v| v);
    let data = prepare(series, &extent, finite, finite, to_pixel);
    let svg = render(
        axes,
        &data,
        (x_range.0..x_range.1, TickFormat::new(x_range, false)),
        (y_range.0..y_range.1, TickFormat::new(y_range, false)),
    )
    .map_err(|e| Error::write(path, e))?;
    write_atomic(path, svg.as_bytes())
}

/// Log-log plot (e.g. RMS error against cell size h for a convergence study); non-positive values are skipped.
///
/// Non-finite and subnormal values are skipped as well. Both axes span the data range widened
/// by a factor 1.2 on each side, extended to whole decades if it would otherwise contain no
/// power of ten. Writes an SVG file to `path` atomically; fails with [`Error::WriteOutput`] if
/// the data spans too many decades or the file cannot be written.
pub fn loglog_plot(path: &Path, axes: &Axes, series: &[Series]) -> Result<()> {
    loglog_plot_ticked(path, axes, series, &[])
}

/// [`loglog_plot`] with a labelled tick at each of `x_ticks` (e.g. every cell size of a
/// convergence study) in addition to the powers of ten.
pub fn loglog_plot_ticked(
    path: &Path,
    axes: &Axes,
    series: &[Series],
    x_ticks: &[f64],
) -> Result<()> {
    let positive = |v: f64| v.is_normal() && v > 0.0;
    let extent = bounds(series, positive, positive);
    let ((x_min, x_max), (y_min, y_max)) = (extent.x, extent.y);
    let x_range = log_range(x_min, x_max)
        .ok_or_else(|| Error::write(path, "x data spans too many decades to plot"))?;
    let y_range = log_range(y_min, y_max)
        .ok_or_else(|| Error::write(path, "y data spans too many decades to plot"))?;
    let to_pixel = pixel_map(x_range, y_range, f64::ln, f64::ln);
    let data = prepare(series, &extent, positive, positive, to_pixel);
    let (mut x_bold, mut x_light) = log_ticks(x_range);
    if !x_ticks.is_empty() {
        // Only the given ticks and the powers of ten are labelled.
        let (decades, others): (Vec<f64>, Vec<f64>) = x_bold
            .iter()
            .partition(|&&v| decade(v.log10().round() as i32) == v);
        x_light.extend(others);
        x_bold = decades;
        x_bold.extend(
            x_ticks
                .iter()
                .copied()
                .filter(|v| (x_range.0..=x_range.1).contains(v)),
        );
        x_bold.sort_by(f64::total_cmp);
        x_bold.dedup();
    }
    let (y_bold, y_light) = log_ticks(y_range);
    let svg = render(
        axes,
        &data,
        (
            (x_range.0..x_range.1)
                .log_scale()
                .with_key_points(x_bold)
                .with_light_points(x_light),
            TickFormat::new(x_range, true),
        ),
        (
            (y_range.0..y_range.1)
                .log_scale()
                .with_key_points(y_bold)
                .with_light_points(y_light),
            TickFormat::new(y_range, true),
        ),
    )
    .map_err(|e| Error::write(path, e))?;
    write_atomic(path, svg.as_bytes())
}

/// Linear `x`, logarithmic `y` (e.g. the error at every particle against its position);
/// non-positive and non-finite `y` are skipped, as in [`loglog_plot`].
pub fn semilogy_plot(path: &Path, axes: &Axes, series: &[Series]) -> Result<()> {
    let (finite, positive) = (|v: f64| v.is_finite(), |v: f64| v.is_normal() && v > 0.0);
    let extent = bounds(series, finite, positive);
    let ((x_min, x_max), (y_min, y_max)) = (extent.x, extent.y);
    let x_range = linear_range(x_min, x_max)
        .ok_or_else(|| Error::write(path, "x data range too wide to plot"))?;
    let y_range = log_range(y_min, y_max)
        .ok_or_else(|| Error::write(path, "y data spans too many decades to plot"))?;
    let to_pixel = pixel_map(x_range, y_range, |v| v, f64::ln);
    let data = prepare(series, &extent, finite, positive, to_pixel);
    let (y_bold, y_light) = log_ticks(y_range);
    let svg = render(
        axes,
        &data,
        (x_range.0..x_range.1, TickFormat::new(x_range, false)),
        (
            (y_range.0..y_range.1)
                .log_scale()
                .with_key_points(y_bold)
                .with_light_points(y_light),
            TickFormat::new(y_range, true),
        ),
    )
    .map_err(|e| Error::write(path, e))?;
    write_atomic(path, svg.as_bytes())
}

/// Approximate pixel size of the plotting area (the figure less margins and labels).
const AREA: (f64, f64) = (690.0, 445.0);

/// The map from data to pixels of the plotting area for the axis ranges, through the axis
/// scales `scale_x`, `scale_y` (identity or ln), used to thin the series.
fn pixel_map(
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
    scale_x: impl Fn(f64) -> f64 + Copy,
    scale_y: impl Fn(f64) -> f64 + Copy,
) -> impl Fn((f64, f64)) -> (f64, f64) + Copy {
    let (sx0, sx1, sy0, sy1) = (scale_x(x0), scale_x(x1), scale_y(y0), scale_y(y1));
    move |(x, y): (f64, f64)| {
        (
            (scale_x(x) - sx0) / (sx1 - sx0) * AREA.0,
            (scale_y(y) - sy0) / (sy1 - sy0) * AREA.1,
        )
    }
}

/// Axis range for a linear axis: the data range plus 5 % on each side, a zero (or tiny)
/// range padded around its value, `0..1` without data; `None` if not representable.
fn linear_range(min: f64, max: f64) -> Option<(f64, f64)> {
    if min > max {
        return Some((0.0, 1.0));
    }
    let magnitude = min.abs().max(max.abs());
    if magnitude < TINY {
        return Some((-1.0, 1.0));
    }
    let span = max - min;
    let (lo, hi) = if span <= magnitude * 1e-9 {
        let centre = 0.5 * (min + max);
        let half = 0.05 * magnitude;
        (centre - half, centre + half)
    } else {
        (min - 0.05 * span, max + 0.05 * span)
    };
    (lo.is_finite() && hi.is_finite() && (hi - lo).is_finite() && lo < hi).then_some((lo, hi))
}

/// Axis range for a log axis (positive normal data): the data range widened by [`LOG_PAD`],
/// extended to whole decades if it contains no power of ten, `1..10` without data; `None` if
/// the ratio of the ends is not representable.
fn log_range(min: f64, max: f64) -> Option<(f64, f64)> {
    if min > max {
        return Some((1.0, 10.0));
    }
    let mut lo = (min / LOG_PAD).max(f64::MIN_POSITIVE);
    let mut hi = (max * LOG_PAD).min(f64::MAX);
    if !lo.is_normal() || !hi.is_normal() {
        return None;
    }
    if decades_in((lo, hi)).is_empty() {
        let k = lo.log10().floor() as i32;
        lo = if decade(k) <= lo {
            decade(k)
        } else {
            decade(k - 1)
        }
        .max(f64::MIN_POSITIVE);
        let k = hi.log10().ceil() as i32;
        hi = if decade(k) >= hi {
            decade(k)
        } else {
            decade(k + 1)
        };
    }
    let ok = lo.is_normal() && hi.is_finite() && (hi / lo).is_finite() && lo < hi;
    ok.then_some((lo, hi))
}

/// `10^k`, correctly rounded.
fn decade(k: i32) -> f64 {
    format!("1e{k}").parse().unwrap_or_else(|_| 10f64.powi(k))
}

/// Exponents `k` with `10^k` in `lo..=hi` (both positive and finite).
fn decades_in((lo, hi): (f64, f64)) -> Vec<i32> {
    let k0 = lo.log10().floor() as i32 - 1;
    let k1 = hi.log10().ceil() as i32 + 1;
    (k0..=k1)
        .filter(|&k| (lo..=hi).contains(&decade(k)))
        .collect()
}

/// Tick positions (bold, with labels; light, grid only) of a log axis over `lo..hi`:
/// 1-2-5 sequence if the axis spans at most two decades, powers of ten with 2..9 multiples as
/// light lines up to twelve decades, and every n-th power of ten beyond.
fn log_ticks((lo, hi): (f64, f64)) -> (Vec<f64>, Vec<f64>) {
    let decades = decades_in((lo, hi));
    let (mut bold, mut light) = (Vec::new(), Vec::new());
    if decades.len() > 12 {
        let step = decades.len().div_ceil(10);
        for (i, &k) in decades.iter().enumerate() {
            if i % step == 0 {
                bold.push(decade(k));
            } else {
                light.push(decade(k));
            }
        }
        return (bold, light);
    }
    let k0 = lo.log10().floor() as i32 - 1;
    let k1 = hi.log10().ceil() as i32 + 1;
    for k in k0..=k1 {
        for m in 1..=9u8 {
            let v = f64::from(m) * decade(k);
            if !(lo..=hi).contains(&v) {
                continue;
            }
            let is_bold = m == 1 || (decades.len() <= 2 && (m == 2 || m == 5));
            if is_bold {
                bold.push(v);
            } else {
                light.push(v);
            }
        }
    }
    (bold, light)
}

/// How the tick labels of one axis are written.
#[derive(Clone, Copy, Debug)]
struct TickFormat {
    /// Scientific notation (`2.5e-4`) for every label of the axis, else plain decimals.
    scientific: bool,
    /// Values smaller in magnitude than this are written as `0` (round-off in tick positions
    /// of a linear axis through zero).
    zero_below: f64,
}

impl TickFormat {
    /// Format for an axis over `lo..hi`: scientific unless all magnitudes are in
    /// `[1e-3, 1e5)` (a linear axis may also contain zero).
    fn new((lo, hi): (f64, f64), log: bool) -> Self {
        let largest = lo.abs().max(hi.abs());
        let smallest = if log { lo.abs().min(hi.abs()) } else { largest };
        TickFormat {
            scientific: largest >= 1e5 || smallest < 1e-3,
            zero_below: if log { 0.0 } else { largest * 1e-9 },
        }
    }

    /// The label of the tick at `v`.
    fn label(&self, v: f64) -> String {
        if v.abs() <= self.zero_below || v == 0.0 {
            return "0".into();
        }
        if !v.is_finite() {
            return format!("{v}");
        }
        if self.scientific {
            let s = format!("{v:.4e}");
            return match s.split_once('e') {
                Some((mantissa, exp)) => {
                    let mantissa = trim_zeros(mantissa);
                    format!("{mantissa}e{exp}")
                }
                None => s,
            };
        }
        // Six significant digits, trailing zeros removed.
        let decimals = (5 - v.abs().log10().floor() as i32).clamp(0, 10) as usize;
        let s = format!("{v:.decimals$}");
        let s = trim_zeros(&s);
        if s == "-0" {
            "0".into()
        } else {
            s.to_string()
        }
    }
}

/// `"1.500"` → `"1.5"`, `"2.000"` → `"2"`; strings without a decimal point are unchanged.
fn trim_zeros(s: &str) -> &str {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.')
    } else {
        s
    }
}

/// Draw the figure into an SVG string.
fn render<XS, YS>(
    axes: &Axes,
    data: &[Prepared],
    (x_spec, x_format): (XS, TickFormat),
    (y_spec, y_format): (YS, TickFormat),
) -> std::result::Result<String, DrawingAreaErrorKind<std::io::Error>>
where
    XS: AsRangedCoord<Value = f64>,
    YS: AsRangedCoord<Value = f64>,
    XS::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
    YS::CoordDescType: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    // Colours, markers and legend rows first: the legend's width sets the figure's.
    let mut coloured = 0;
    let looks: Vec<(RGBColor, Marker, u32)> = data
        .iter()
        .map(|series| match series.style {
            Style::Reference => (RGBColor(40, 40, 40), Marker::Circle, REFERENCE_WIDTH),
            Style::Guide => (RGBColor(150, 150, 150), Marker::Circle, REFERENCE_WIDTH),
            _ => {
                let k = coloured;
                coloured += 1;
                (
                    PALETTE[k % PALETTE.len()],
                    MARKERS[(k / PALETTE.len()) % MARKERS.len()],
                    LINE_WIDTH,
                )
            }
        })
        .collect();
    let entries: Vec<LegendEntry> = data
        .iter()
        .zip(&looks)
        .filter(|(s, _)| !s.label.is_empty() && s.style != Style::Guide)
        .map(|(s, &(colour, marker, width))| LegendEntry {
            label: s.label.clone(),
            colour,
            sample: match s.style {
                Style::Line | Style::Reference | Style::Guide => Sample::Line(width),
                Style::Points | Style::LinePoints => Sample::Marker(marker),
            },
        })
        .collect();
    let legend_width = panel_width(&entries);
    let mut svg = String::new();
    {
        let root =
            SVGBackend::with_string(&mut svg, (SIZE.0 + legend_width, SIZE.1)).into_drawing_area();
        root.fill(&WHITE)?;
        let (plot_area, legend_area) = root.split_horizontally(SIZE.0);
        let mut builder = ChartBuilder::on(&plot_area);
        builder
            .margin(15)
            .x_label_area_size(50)
            .y_label_area_size(80);
        if !axes.title.is_empty() {
            builder.caption(axes.title, ("sans-serif", 22).into_font());
        }
        let mut chart = builder.build_cartesian_2d(x_spec, y_spec)?;
        let x_tick = |v: &f64| x_format.label(*v);
        let y_tick = |v: &f64| y_format.label(*v);
        chart
            .configure_mesh()
            .x_desc(axes.x_label)
            .y_desc(axes.y_label)
            .x_label_formatter(&x_tick)
            .y_label_formatter(&y_tick)
            .axis_desc_style(("sans-serif", 16).into_font())
            .label_style(("sans-serif", 13).into_font())
            .light_line_style(BLACK.mix(0.06))
            .bold_line_style(BLACK.mix(0.2))
            .draw()?;

        for (series, &(colour, marker, width)) in data.iter().zip(&looks) {
            let line = matches!(
                series.style,
                Style::Line | Style::LinePoints | Style::Reference | Style::Guide
            );
            for run in &series.runs {
                if line && run.len() > 1 {
                    chart.draw_series(LineSeries::new(
                        run.iter().copied(),
                        colour.stroke_width(width),
                    ))?;
                }
                // Points, marked lines, and isolated points of a line, as markers.
                if matches!(series.style, Style::Points | Style::LinePoints) || run.len() == 1 {
                    let r = POINT_RADIUS;
                    match marker {
                        Marker::Circle => chart
                            .draw_series(run.iter().map(|&p| Circle::new(p, r, colour.filled())))?,
                        Marker::Square => chart.draw_series(run.iter().map(|&p| {
                            EmptyElement::at(p)
                                + Rectangle::new([(-r, -r), (r, r)], colour.filled())
                        }))?,
                        Marker::Triangle => chart.draw_series(
                            run.iter()
                                .map(|&p| TriangleMarker::new(p, r + 1, colour.filled())),
                        )?,
                        Marker::Cross => chart.draw_series(
                            run.iter()
                                .map(|&p| Cross::new(p, r, colour.stroke_width(2))),
                        )?,
                    };
                }
            }
            if series.style == Style::Guide {
                if let Some(&end) = series.runs.last().and_then(|run| run.last()) {
                    chart.draw_series(std::iter::once(
                        EmptyElement::at(end)
                            + Text::new(
                                series.label.clone(),
                                (4, -14),
                                ("sans-serif", 13).into_font().color(&colour),
                            ),
                    ))?;
                }
            }
        }
        // The legend box starts level with the top of the plotting area.
        let top = chart.plotting_area().get_pixel_range().1.start;
        draw_legend(&legend_area, &entries, top)?;
        root.present()?;
    }
    Ok(svg)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn axes() -> Axes<'static> {
        Axes {
            title: "Stress at t = 0.5 s",
            x_label: "x [m]",
            y_label: "stress [Pa]",
        }
    }

    /// Names of the files in `dir`.
    fn files(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    fn no_tmp_left(dir: &Path) {
        for name in files(dir) {
            assert!(!name.ends_with(".tmp"), "temporary file left: {name}");
        }
    }

    #[test]
    fn profile_plot_writes_svg_with_title_and_legend() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("profile.svg");
        let x: Vec<f64> = (0..50).map(|i| i as f64 / 49.0).collect();
        let exact: Vec<f64> = x.iter().map(|x| (std::f64::consts::PI * x).sin()).collect();
        let numeric: Vec<f64> = exact.iter().map(|s| s * 1.01).collect();
        let series = [
            Series {
                label: "MPM & <TLS>",
                x: (&x).into(),
                y: (&numeric).into(),
                style: Style::Points,
            },
            Series {
                label: "exact",
                x: (&x).into(),
                y: (&exact).into(),
                style: Style::Line,
            },
        ];
        profile_plot(&path, &axes(), &series).unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        assert!(svg.starts_with("<svg"), "{}", &svg[..80.min(svg.len())]);
        assert!(svg.trim_end().ends_with("</svg>"));
        assert!(svg.contains("Stress at t = 0.5 s"));
        assert!(svg.contains("MPM &amp; &lt;TLS&gt;"));
        assert!(svg.contains("exact"));
        assert!(svg.contains("x [m]"));
        assert!(svg.contains("stress [Pa]"));
        assert!(svg.contains("<text"));
        assert!(svg.contains("<polyline"));
        assert!(svg.contains("<circle"));
        // Two distinct palette colours.
        assert!(svg.contains("#1F77B4"));
        assert!(svg.contains("#FF7F0E"));
        assert_eq!(files(dir.path()), vec!["profile.svg".to_string()]);
    }

    #[test]
    fn loglog_plot_writes_svg_and_skips_non_positive() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("convergence.svg");
        let h = [0.0, 1.0 / 8.0, 1.0 / 16.0, 1.0 / 32.0, 1.0 / 64.0, -1.0];
        let err: Vec<f64> = h.iter().map(|h| 0.3 * h * h).collect();
        let reference: Vec<f64> = h.iter().map(|h| 0.5 * h * h).collect();
        let series = [
            Series {
                label: "RMS error",
                x: (&h).into(),
                y: (&err).into(),
                style: Style::Points,
            },
            Series {
                label: "O(h^2)",
                x: (&h).into(),
                y: (&reference).into(),
                style: Style::Line,
            },
        ];
        let axes = Axes {
            title: "Convergence",
            x_label: "h [m]",
            y_label: "RMS error",
        };
        loglog_plot(&path, &axes, &series).unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        assert!(svg.starts_with("<svg"));
        assert!(svg.contains("Convergence"));
        assert!(svg.contains("RMS error"));
        assert!(svg.contains("O(h^2)"));
        // 4 valid points of the first series, drawn as circles.
        assert!(svg.matches("<circle").count() >= 4);
        no_tmp_left(dir.path());
    }

    #[test]
    fn degenerate_inputs_do_not_panic() {
        let dir = tempfile::tempdir().unwrap();
        let nan = [f64::NAN, f64::NAN, f64::INFINITY];
        let same_x = [2.0, 2.0, 2.0];
        let ys = [1.0, 3.0, 2.0];
        let one = [5.0];
        let long = [1.0, 2.0, 3.0, 4.0, 5.0];
        let zeros = [0.0, 0.0];
        let tiny = [1e-320, 2e-320];
        let huge = [-1e308, 1e308];
        let gap = [1.0, f64::NAN, 3.0, 4.0];
        let cases: Vec<(&str, Vec<Series>)> = vec![
            ("no series", vec![]),
            (
                "empty series",
                vec![Series {
                    label: "empty",
                    x: (&[]).into(),
                    y: (&[]).into(),
                    style: Style::Line,
                }],
            ),
            (
                "all nan",
                vec![Series {
                    label: "nan",
                    x: (&nan).into(),
                    y: (&nan).into(),
                    style: Style::Points,
                }],
            ),
            (
                "zero x range",
                vec![Series {
                    label: "same x",
                    x: (&same_x).into(),
                    y: (&ys).into(),
                    style: Style::Line,
                }],
            ),
            (
                "zero x and y range",
                vec![Series {
                    label: "same",
                    x: (&same_x).into(),
                    y: (&same_x).into(),
                    style: Style::Points,
                }],
            ),
            (
                "mismatched lengths",
                vec![Series {
                    label: "mismatch",
                    x: (&long).into(),
                    y: (&ys).into(),
                    style: Style::Line,
                }],
            ),
            (
                "single point",
                vec![Series {
                    label: "one",
                    x: (&one).into(),
                    y: (&one).into(),
                    style: Style::Line,
                }],
            ),
            (
                "all zero",
                vec![Series {
                    label: "",
                    x: (&zeros).into(),
                    y: (&zeros).into(),
                    style: Style::Line,
                }],
            ),
            (
                "subnormal",
                vec![Series {
                    label: "tiny",
                    x: (&tiny).into(),
                    y: (&tiny).into(),
                    style: Style::Points,
                }],
            ),
            (
                "huge",
                vec![Series {
                    label: "huge",
                    x: (&huge).into(),
                    y: (&huge).into(),
                    style: Style::Line,
                }],
            ),
            (
                "gap",
                vec![Series {
                    label: "multi\nline",
                    x: (&gap).into(),
                    y: (&long).into(),
                    style: Style::Line,
                }],
            ),
        ];
        let all_axes = [
            axes(),
            Axes {
                title: "",
                x_label: "",
                y_label: "",
            },
        ];
        for (i, (name, series)) in cases.iter().enumerate() {
            for (j, axes) in all_axes.iter().enumerate() {
                let lin = dir.path().join(format!("lin{i}_{j}.svg"));
                let log = dir.path().join(format!("log{i}_{j}.svg"));
                for (path, result) in [
                    (&lin, profile_plot(&lin, axes, series)),
                    (&log, loglog_plot(&log, axes, series)),
                ] {
                    match result {
                        Ok(()) => {
                            let svg = std::fs::read_to_string(path).unwrap();
                            assert!(svg.starts_with("<svg"), "{name}");
                            assert!(svg.trim_end().ends_with("</svg>"), "{name}");
                        }
                        Err(Error::WriteOutput { path: p, reason }) => {
                            assert_eq!(&p, path, "{name}");
                            assert!(!reason.is_empty(), "{name}");
                        }
                        Err(e) => panic!("{name}: unexpected error {e}"),
                    }
                }
            }
        }
        // Only the huge case may fail (range wider than f64 on the linear axis).
        assert!(profile_plot(&dir.path().join("h.svg"), &axes(), &cases[9].1).is_err());
        no_tmp_left(dir.path());
    }

    #[test]
    fn log_plot_with_huge_decade_span_is_an_error_or_ok() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("wide.svg");
        let x = [f64::MIN_POSITIVE, f64::MAX];
        let series = [Series {
            label: "wide",
            x: (&x).into(),
            y: (&x).into(),
            style: Style::Points,
        }];
        let result = loglog_plot(&path, &axes(), &series);
        assert!(matches!(result, Err(Error::WriteOutput { .. })));
        let x = [1e-150, 1e150];
        let series = [Series {
            label: "wide",
            x: (&x).into(),
            y: (&x).into(),
            style: Style::Line,
        }];
        loglog_plot(&path, &axes(), &series).unwrap();
        no_tmp_left(dir.path());
    }

    #[test]
    fn unwritable_path_is_a_clean_error() {
        let path = Path::new("/nonexistent-dir/plot.svg");
        let series = [Series {
            label: "a",
            x: (&[1.0, 2.0]).into(),
            y: (&[1.0, 2.0]).into(),
            style: Style::Line,
        }];
        let err = profile_plot(path, &axes(), &series).unwrap_err();
        assert!(matches!(err, Error::WriteOutput { .. }));
        assert!(err.to_string().contains("/nonexistent-dir/plot.svg"));
    }

    #[test]
    fn tick_labels_are_short() {
        let plain = TickFormat::new((-2.0, 1500.0), false);
        assert_eq!(plain.label(0.0), "0");
        assert_eq!(plain.label(-0.0), "0");
        assert_eq!(plain.label(1e-13), "0");
        assert_eq!(plain.label(0.30000000000000004), "0.3");
        assert_eq!(plain.label(1500.0), "1500");
        assert_eq!(plain.label(-2.5), "-2.5");
        let sci = TickFormat::new((-1.2e5, 0.0), false);
        assert_eq!(sci.label(-1e5), "-1e5");
        assert_eq!(sci.label(-25000.0), "-2.5e4");
        assert_eq!(sci.label(1e-12), "0");
        let log = TickFormat::new((1e-5, 0.1), true);
        assert_eq!(log.label(1e-5), "1e-5");
        assert_eq!(log.label(0.01), "1e-2");
        let log = TickFormat::new((0.01, 0.1), true);
        assert_eq!(log.label(0.02), "0.02");
    }

    #[test]
    fn log_axes_always_have_labelled_ticks() {
        for (min, max) in [
            (0.04, 0.05),
            (0.05, 0.05),
            (1e-3, 1e3),
            (1e-150, 1e150),
            (3.0, 7.0),
        ] {
            let range = log_range(min, max).unwrap();
            assert!(range.0 <= min && range.1 >= max, "{min} {max}: {range:?}");
            let (bold, light) = log_ticks(range);
            assert!(bold.len() >= 2, "{min} {max}: {bold:?}");
            assert!(bold.len() <= 13, "{min} {max}: {bold:?}");
            for v in bold.iter().chain(&light) {
                assert!((range.0..=range.1).contains(v));
            }
        }
        let (bold, _) = log_ticks(log_range(0.04, 0.05).unwrap());
        assert_eq!(bold.len(), 4); // 0.01, 0.02, 0.05, 0.1
    }
}
