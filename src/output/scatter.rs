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

/// An sRGB colour.
pub(crate) type Rgb = (u8, u8, u8);

/// Anchor colours of matplotlib's viridis at `i / 9`, `i = 0..=9`.
const VIRIDIS: [Rgb; 10] = [
    (0x44, 0x01, 0x54),
    (0x48, 0x28, 0x78),
    (0x3e, 0x49, 0x89),
    (0x31, 0x68, 0x8e),
    (0x26, 0x82, 0x8e),
    (0x1f, 0x9e, 0x89),
    (0x35, 0xb7, 0x79),
    (0x6e, 0xce, 0x58),
    (0xb5, 0xde, 0x2b),
    (0xfd, 0xe7, 0x25),
];

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

/// A linear colour scale over `lo..hi` through viridis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ColourScale {
    /// Value drawn in the first viridis colour.
    pub(crate) lo: f64,
    /// Value drawn in the last viridis colour.
    pub(crate) hi: f64,
    /// The drawn values were all equal (or there were none) and the scale was widened.
    pub(crate) widened: bool,
}

impl ColourScale {
    /// Scale over `min..max` of the finite values; equal ends are widened symmetrically
    /// (by 5 % of the magnitude, or ±1 about zero), `min > max` (no values) gives `0..1`;
    /// `None` if `max - min` is not representable.
    pub(crate) fn new(min: f64, max: f64) -> Option<Self> {
        if min.is_nan() || max.is_nan() || min > max {
            return Some(ColourScale {
                lo: 0.0,
                hi: 1.0,
                widened: true,
            });
        }
        let magnitude = min.abs().max(max.abs());
        let (lo, hi, widened) = if magnitude < TINY || max - min <= magnitude * 1e-9 {
            let centre = 0.5 * min + 0.5 * max;
            let half = if magnitude < TINY {
                1.0
            } else {
                0.05 * magnitude
            };
            (centre - half, centre + half, true)
        } else {
            (min, max, false)
        };
        let ok = lo.is_finite() && hi.is_finite() && (hi - lo).is_finite() && lo < hi;
        ok.then_some(ColourScale { lo, hi, widened })
    }

    /// Position of `v` on the scale, clamped to `0..=1` (0 for NaN).
    pub(crate) fn fraction(&self, v: f64) -> f64 {
        let t = (0.5 * v - 0.5 * self.lo) / (0.5 * self.hi - 0.5 * self.lo);
        if t.is_nan() {
            0.0
        } else {
            t.clamp(0.0, 1.0)
        }
    }

    /// Colour of the value `v`.
    pub(crate) fn colour(&self, v: f64) -> Rgb {
        viridis(self.fraction(v))
    }
}

/// The viridis colour at `t` in `0..=1` (clamped; NaN gives the first colour), linearly
/// interpolated between the anchors of [`VIRIDIS`].
pub(crate) fn viridis(t: f64) -> Rgb {
    let [r, g, b] = viridis_exact(t).map(|c| c.round().clamp(0.0, 255.0) as u8);
    (r, g, b)
}

/// The viridis colour at `t` before rounding to 8 bits (channels in `0.0..=255.0`).
fn viridis_exact(t: f64) -> [f64; 3] {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let last = VIRIDIS.len() - 1;
    let s = t * last as f64;
    let i = (s.floor() as usize).min(last - 1);
    let f = s - i as f64;
    let (a, b) = (VIRIDIS[i], VIRIDIS[i + 1]);
    let mix = |a: u8, b: u8| f64::from(a) + f * (f64::from(b) - f64::from(a));
    [mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2)]
}

/// `#RRGGBB`.
fn hex((r, g, b): Rgb) -> String {
    format!("#{r:02X}{g:02X}{b:02X}")
}

/// Shape `(nx, ny)` of a raster of at most `max_cells` cells over a box of `width` × `height`
/// pixels: cells as square as possible (`nx / ny` close to `width / height`) and, where the
/// box allows, at least `min_cell` pixels across. A zero extent gets one cell across.
pub(crate) fn raster_shape(
    width: f64,
    height: f64,
    max_cells: usize,
    min_cell: f64,
) -> (usize, usize) {
    let max_cells = max_cells.max(1);
    let cap = |extent: f64| {
        if extent > 0.0 && min_cell > 0.0 {
            ((extent / min_cell).floor() as usize).clamp(1, max_cells)
        } else if extent > 0.0 {
            max_cells
        } else {
            1
        }
    };
    let (nx_cap, ny_cap) = (cap(width), cap(height));
    let positive = |v: f64| v > 0.0 && v.is_finite();
    match (positive(width), positive(height)) {
        (false, false) => (1, 1),
        (true, false) => (nx_cap, 1),
        (false, true) => (1, ny_cap),
        (true, true) => {
            let ratio = width / height;
            let nx = ((max_cells as f64 * ratio).sqrt().round() as usize)
                .clamp(1, max_cells)
                .min(nx_cap);
            let ny = ((nx as f64 / ratio).round() as usize)
                .clamp(1, max_cells / nx)
                .min(ny_cap);
            (nx, ny)
        }
    }
}

/// Particles binned onto a regular raster.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Raster {
    /// Cells across.
    pub(crate) nx: usize,
    /// Cells up.
    pub(crate) ny: usize,
    /// Particles per cell, index `j * nx + i` (`i` along x, `j` along y from the low end).
    pub(crate) count: Vec<usize>,
    /// Mean value per cell, same index; NaN for an empty cell.
    pub(crate) mean: Vec<f64>,
}

impl Raster {
    /// Mean value of cell `(i, j)`, `None` if it is empty or outside the raster.
    pub(crate) fn cell_mean(&self, i: usize, j: usize) -> Option<f64> {
        if i >= self.nx || j >= self.ny {
            return None;
        }
        let c = j * self.nx + i;
        (self.count[c] > 0).then_some(self.mean[c])
    }
}

/// Bin the particles with finite position and value onto `nx` × `ny` equal cells over
/// `x_range` × `y_range` (a zero-width range puts every particle in the first cell along it;
/// particles outside go to the nearest edge cell) and average the values per cell.
pub(crate) fn bin_mean(
    x: &[f64],
    y: &[f64],
    value: &[f64],
    x_range: (f64, f64),
    y_range: (f64, f64),
    nx: usize,
    ny: usize,
) -> Raster {
    let (nx, ny) = (nx.max(1), ny.max(1));
    let cells = nx.saturating_mul(ny);
    let mut count = vec![0usize; cells];
    let mut mean = vec![f64::NAN; cells];
    // Cell index along one axis; `as usize` saturates (negative and NaN give 0).
    let index = |v: f64, (lo, hi): (f64, f64), n: usize| -> usize {
        let width = hi - lo;
        if width > 0.0 && width.is_finite() {
            (((v - lo) / width * n as f64) as usize).min(n - 1)
        } else {
            0
        }
    };
    for ((&x, &y), &v) in x.iter().zip(y).zip(value) {
        if !drawable(x, y, v) {
            continue;
        }
        let c = index(y, y_range, ny) * nx + index(x, x_range, nx);
        count[c] += 1;
        let n = count[c] as f64;
        // Running mean, written so that it cannot overflow for finite values.
        let m = if count[c] == 1 { 0.0 } else { mean[c] };
        mean[c] = m + (v / n - m / n);
    }
    Raster {
        nx,
        ny,
        count,
        mean,
    }
}

/// Tick positions and their labels (an empty label: tick without text).
#[derive(Clone, Debug)]
struct Ticks {
    values: Vec<f64>,
    labels: Vec<String>,
    /// Distance between neighbouring ticks.
    step: f64,
}

impl Ticks {
    /// Widest label, estimated in pixels.
    fn label_width(&self) -> f64 {
        let chars = self
            .labels
            .iter()
            .map(|l| l.chars().count())
            .max()
            .unwrap_or(0);
        text_width(chars, LABEL_SIZE)
    }
}

/// Estimated width in pixels of `chars` characters at font size `size`.
fn text_width(chars: usize, size: f64) -> f64 {
    chars as f64 * CHAR_WIDTH * size
}

/// `10^k`, correctly rounded.
fn decade(k: i32) -> f64 {
    format!("1e{k}").parse().unwrap_or_else(|_| 10f64.powi(k))
}

/// Round ticks (multiples of 1, 2, 2.5 or 5 × 10^k) over `lo..hi` (finite, `lo < hi`): the
/// widest step that gives at least `min_count` ticks, or `min_count` evenly spaced values.
fn nice_ticks(lo: f64, hi: f64, min_count: usize) -> Ticks {
    let min_count = min_count.max(2);
    let span = hi - lo;
    let top = if span > 0.0 && span.is_finite() {
        span.log10().floor() as i32 + 1
    } else {
        0
    };
    for k in (top - 40..=top).rev() {
        for m in [5.0, 2.5, 2.0, 1.0] {
            let step = m * decade(k);
            if !(step > 0.0 && step.is_finite()) {
                continue;
            }
            let i0 = (lo / step - 1e-9).ceil();
            let i1 = (hi / step + 1e-9).floor();
            if !(i0.abs() < 1e15 && i1.abs() < 1e15) {
                continue;
            }
            let count = i1 - i0 + 1.0;
            if count >= min_count as f64 && count <= 1000.0 {
                let values: Vec<f64> = (i0 as i64..=i1 as i64)
                    .map(|i| (i as f64 * step).clamp(lo, hi))
                    .collect();
                let largest = values.iter().fold(0.0f64, |a, v| a.max(v.abs()));
                let scientific = !(1e-3..1e5).contains(&largest);
                let labels = values
                    .iter()
                    .map(|&v| tick_label(v, step, m == 2.5, k, scientific))
                    .collect();
                return Ticks {
                    values,
                    labels,
                    step,
                };
            }
        }
    }
    let n = min_count;
    let step = span / (n - 1) as f64;
    let values: Vec<f64> = (0..n)
        .map(|i| if i + 1 == n { hi } else { lo + i as f64 * step })
        .collect();
    let labels = values.iter().map(|&v| short_number(v)).collect();
    Ticks {
        values,
        labels,
        step,
    }
}

/// Label of a tick at `v` on an axis with ticks every `step` = m × 10^`k` (`quarter`: m = 2.5).
fn tick_label(v: f64, step: f64, quarter: bool, k: i32, scientific: bool) -> String {
    let extra = i32::from(quarter);
    let digits = ((-k).max(0) + if k <= 0 { extra } else { 0 }).clamp(0, 15) as usize;
    if v.abs() < step * 1e-6 {
        return if scientific {
            "0".into()
        } else {
            format!("{:.digits$}", 0.0)
        };
    }
    if scientific {
        let exponent = format!("{v:e}")
            .split_once('e')
            .and_then(|(_, e)| e.parse::<i32>().ok())
            .unwrap_or(0);
        let digits = (exponent - k + extra).clamp(0, 15) as usize;
        let s = format!("{v:.digits$e}");
        return match s.split_once('e') {
            Some((mantissa, exp)) => format!("{}e{exp}", trim_zeros(mantissa)),
            None => s,
        };
    }
    let s = format!("{v:.digits$}");
    if s.trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        format!("{:.digits$}", 0.0)
    } else {
        s
    }
}

/// A number in at most four significant digits (scientific outside `[1e-3, 1e5)`).
fn short_number(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let a = v.abs();
    if !(1e-3..1e5).contains(&a) {
        let s = format!("{v:.3e}");
        return match s.split_once('e') {
            Some((mantissa, exp)) => format!("{}e{exp}", trim_zeros(mantissa)),
            None => s,
        };
    }
    let digits = (3 - a.log10().floor() as i32).clamp(0, 6) as usize;
    let s = format!("{v:.digits$}");
    trim_zeros(&s).to_string()
}

/// `"1.500"` → `"1.5"`, `"2.000"` → `"2"`; strings without a decimal point are unchanged.
fn trim_zeros(s: &str) -> &str {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.')
    } else {
        s
    }
}

/// Ticks of an axis over `range` drawn `length` pixels long: as many as fit (2 to 8 labelled
/// values, about one per 100 px) without overlapping labels; labels are thinned if even the
/// fewest overlap.
fn axis_ticks((lo, hi): (f64, f64), length: f64, vertical: bool) -> Ticks {
    let fits = |t: &Ticks, stride: usize| {
        let spacing = length * t.step * stride as f64 / (hi - lo);
        let need = if vertical {
            LABEL_SIZE + 4.0
        } else {
            t.label_width() + 12.0
        };
        spacing >= need
    };
    let target = ((length / 100.0).floor() as usize).clamp(2, 8);
    for min_count in (2..=target).rev() {
        let t = nice_ticks(lo, hi, min_count);
        if fits(&t, 1) {
            return t;
        }
    }
    let mut t = nice_ticks(lo, hi, 2);
    let stride = (1..t.values.len().max(1))
        .find(|&s| fits(&t, s))
        .unwrap_or(t.values.len().max(1));
    for (i, label) in t.labels.iter_mut().enumerate() {
        if i % stride != 0 {
            label.clear();
        }
    }
    t
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

#[cfg(test)]
mod tests {
    use super::*;

    fn axes() -> ScatterAxes<'static> {
        ScatterAxes {
            title: "Stress at t = 0.5 s",
            x_label: "x [m]",
            y_label: "y [m]",
            colour_label: "σxx [Pa]",
        }
    }

    /// Deterministic uniform numbers in `[0, 1)` (xorshift64*).
    struct Rng(u64);

    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// The `<rect` elements of the marks group.
    fn marks(svg: &str) -> usize {
        let start = svg.find(r#"<g id="marks""#).expect("marks group");
        let end = start + svg[start..].find("</g>").expect("end of marks");
        svg[start..end].matches("<rect").count()
    }

    fn assert_valid(svg: &str, what: &str) {
        assert!(svg.starts_with("<svg"), "{what}");
        assert!(svg.trim_end().ends_with("</svg>"), "{what}");
        assert!(!svg.contains("NaN") && !svg.contains("inf"), "{what}");
    }

    fn no_tmp_left(dir: &Path) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let name = entry.unwrap().file_name().to_string_lossy().into_owned();
            assert!(!name.ends_with(".tmp"), "temporary file left: {name}");
        }
    }

    #[test]
    fn hundred_particles_one_mark_each() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("scatter.svg");
        let (mut x, mut y, mut v) = (Vec::new(), Vec::new(), Vec::new());
        for i in 0..10 {
            for j in 0..10 {
                x.push(0.1 * f64::from(i) + 0.05);
                y.push(0.05 * f64::from(j) + 0.025);
                v.push(f64::from(i * j));
            }
        }
        scatter_plot(&path, &axes(), &x, &y, &v).unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        assert_valid(&svg, "100");
        assert_eq!(marks(&svg), 100);
        assert!(svg.matches("<rect").count() <= 100 + 4);
        for text in [
            "Stress at t = 0.5 s",
            "x [m]",
            "y [m]",
            "σxx [Pa]",
            "100 particles",
        ] {
            assert!(svg.contains(text), "{text}");
        }
        // Extreme colours present: v = 0 and v = 81 are the ends of the scale.
        assert!(svg.contains(&hex(VIRIDIS[0])));
        assert!(svg.contains(&hex(VIRIDIS[9])));
        assert!(!svg.contains("binned"));
        no_tmp_left(dir.path());
    }

    #[test]
    fn million_particles_are_binned_into_a_small_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("million.svg");
        let n = 1_000_000;
        let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
        let x: Vec<f64> = (0..n).map(|_| 2.0 * rng.next()).collect();
        let y: Vec<f64> = (0..n).map(|_| rng.next()).collect();
        let v: Vec<f64> = x.iter().zip(&y).map(|(x, y)| (3.0 * x).sin() * y).collect();
        scatter_plot(&path, &axes(), &x, &y, &v).unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        let size = svg.len();
        eprintln!("1e6 particles: {size} bytes, {} marks", marks(&svg));
        assert_valid(&svg, "1e6");
        assert!(size < 1_000_000, "{size} bytes");
        let m = marks(&svg);
        assert!(m <= MAX_MARKS, "{m} marks");
        assert!(m >= MAX_MARKS / 2, "{m} marks");
        assert!(svg.contains("1000000 particles binned to a "), "caption");
        assert!(svg.contains("mean per bin"));
        no_tmp_left(dir.path());
    }

    #[test]
    fn viridis_is_monotone_with_the_right_ends() {
        assert_eq!(viridis(0.0), (68, 1, 84));
        assert_eq!(viridis(1.0), (253, 231, 37));
        assert_eq!(viridis(-3.0), viridis(0.0));
        assert_eq!(viridis(7.0), viridis(1.0));
        assert_eq!(viridis(f64::NAN), viridis(0.0));
        // The sum r + g + b strictly increases from the low to the high end; after
        // rounding to 8 bits it may dip by a rounding step at most.
        let exact_sum = |t: f64| viridis_exact(t).iter().sum::<f64>();
        let sum = |c: Rgb| u32::from(c.0) + u32::from(c.1) + u32::from(c.2);
        for i in 1..=1000 {
            let (t0, t1) = (f64::from(i - 1) / 1000.0, f64::from(i) / 1000.0);
            assert!(exact_sum(t1) > exact_sum(t0), "{t1}");
            assert!(sum(viridis(t1)) + 2 >= sum(viridis(t0)), "{t1}");
        }
        for i in 1..=20 {
            let (t0, t1) = (f64::from(i - 1) / 20.0, f64::from(i) / 20.0);
            assert!(sum(viridis(t1)) > sum(viridis(t0)), "{t1}");
        }
        // Strictly increasing between the anchors.
        for i in 1..VIRIDIS.len() {
            assert!(sum(VIRIDIS[i]) > sum(VIRIDIS[i - 1]));
        }
        let scale = ColourScale::new(-2.0, 6.0).unwrap();
        assert_eq!(scale.colour(-2.0), VIRIDIS[0]);
        assert_eq!(scale.colour(6.0), VIRIDIS[9]);
        assert_eq!(scale.colour(2.0), viridis(0.5));
        assert_eq!(scale.colour(100.0), VIRIDIS[9]);
    }

    #[test]
    fn binned_mean_is_exact_for_a_tiny_case() {
        // Two particles in cell (0, 0) with values 1 and 3, one in cell (1, 1) with 5.
        let x = [0.1, 0.2, 0.9, f64::NAN];
        let y = [0.1, 0.3, 0.8, 0.5];
        let v = [1.0, 3.0, 5.0, 100.0];
        let raster = bin_mean(&x, &y, &v, (0.0, 1.0), (0.0, 1.0), 2, 2);
        assert_eq!(raster.count, vec![2, 0, 0, 1]);
        assert_eq!(raster.cell_mean(0, 0), Some(2.0));
        assert_eq!(raster.cell_mean(1, 0), None);
        assert_eq!(raster.cell_mean(0, 1), None);
        assert_eq!(raster.cell_mean(1, 1), Some(5.0));
        assert_eq!(raster.cell_mean(2, 0), None);
        let scale = ColourScale::new(1.0, 3.0).unwrap();
        assert_eq!(scale.colour(2.0), viridis(0.5));
        // Huge values do not overflow the mean.
        let raster = bin_mean(
            &[0.0, 0.0],
            &[0.0, 0.0],
            &[f64::MAX, f64::MAX],
            (0.0, 0.0),
            (0.0, 0.0),
            1,
            1,
        );
        assert_eq!(raster.cell_mean(0, 0), Some(f64::MAX));
    }

    #[test]
    fn binned_plot_colours_cells_by_their_mean() {
        // MAX_MARKS + 2 particles: most with value 0 at a corner, two with 1 and 3 in the
        // opposite corner, one with 4 in the middle (the scale is 0..4, mean 2 → centre).
        let mut x = vec![0.0; MAX_MARKS - 1];
        let mut y = vec![0.0; MAX_MARKS - 1];
        let mut v = vec![0.0; MAX_MARKS - 1];
        x.extend([1.0, 1.0, 0.5]);
        y.extend([1.0, 1.0, 0.5]);
        v.extend([1.0, 3.0, 4.0]);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("binned.svg");
        scatter_plot(&path, &axes(), &x, &y, &v).unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        assert_valid(&svg, "binned");
        assert_eq!(marks(&svg), 3);
        let colour = hex(ColourScale::new(0.0, 4.0).unwrap().colour(2.0));
        assert_eq!(colour, hex(viridis(0.5)));
        assert!(svg.contains(&format!(r#"fill="{colour}""#)), "{colour}");
        assert!(svg.contains(&format!("{} particles binned to a ", MAX_MARKS + 2)));
    }

    #[test]
    fn raster_matches_the_aspect_and_stays_within_the_limit() {
        for (w, h) in [
            (600.0, 300.0),
            (300.0, 600.0),
            (500.0, 500.0),
            (600.0, 90.0),
            (3.0, 500.0),
        ] {
            let (nx, ny) = raster_shape(w, h, MAX_MARKS, MIN_CELL_PX);
            assert!(nx * ny <= MAX_MARKS, "{w} {h}: {nx} {ny}");
            let (cw, ch) = (w / nx as f64, h / ny as f64);
            assert!(cw >= MIN_CELL_PX - 1e-9 || nx == 1, "{w} {h}");
            assert!((cw / ch - 1.0).abs() < 0.3 || nx == 1, "{w} {h}: {cw} {ch}");
        }
        assert_eq!(raster_shape(600.0, 300.0, MAX_MARKS, MIN_CELL_PX), (91, 45));
        assert_eq!(raster_shape(500.0, 500.0, MAX_MARKS, MIN_CELL_PX), (64, 64));
        assert_eq!(raster_shape(0.0, 0.0, MAX_MARKS, MIN_CELL_PX), (1, 1));
        assert_eq!(raster_shape(600.0, 0.0, MAX_MARKS, MIN_CELL_PX), (300, 1));
        assert_eq!(raster_shape(0.0, 50.0, MAX_MARKS, MIN_CELL_PX), (1, 25));
        assert_eq!(
            raster_shape(f64::NAN, 50.0, MAX_MARKS, MIN_CELL_PX),
            (1, 25)
        );
    }

    #[test]
    fn axes_have_equal_scale() {
        let ((x0, x1), (y0, y1)) = axis_ranges(Some(((0.0, 2.0), (0.0, 1.0)))).unwrap();
        assert!(x0 < 0.0 && x1 > 2.0 && y0 < 0.0 && y1 > 1.0);
        // Equal padding on all sides.
        assert!(((x1 - 2.0) - (y1 - 1.0)).abs() < 1e-12);
        let (pw, ph) = plot_size(x1 - x0, y1 - y0);
        assert!((pw / ph - (x1 - x0) / (y1 - y0)).abs() < 1e-12);
        assert!(pw <= MAX_PLOT_W + 1e-9 && ph <= MAX_PLOT_H + 1e-9);
        // A thin strip keeps a readable height.
        let (_, (y0, y1)) = axis_ranges(Some(((0.0, 1.0), (0.0, 1e-4)))).unwrap();
        assert!(y1 - y0 >= MIN_EXTENT);
        // Identical points, zero, huge.
        assert!(axis_ranges(Some(((3.0, 3.0), (3.0, 3.0)))).is_some());
        assert!(axis_ranges(Some(((0.0, 0.0), (0.0, 0.0)))).is_some());
        assert!(axis_ranges(Some(((-1e308, 1e308), (0.0, 0.0)))).is_none());
    }

    #[test]
    fn colour_bar_has_at_least_five_distinct_ticks() {
        for (lo, hi) in [
            (0.0, 1.0),
            (0.13, 0.87),
            (-3.3e6, 1.2e5),
            (1e-7, 3e-7),
            (999.999, 1000.001),
            (-1.0, -0.9999999),
            (5.0, 5.0),
            (0.0, 0.0),
            (1e-300, 2e-300),
        ] {
            let scale = ColourScale::new(lo, hi).unwrap();
            let ticks = nice_ticks(scale.lo, scale.hi, BAR_TICKS);
            assert!(ticks.values.len() >= BAR_TICKS, "{lo} {hi}: {ticks:?}");
            let mut labels = ticks.labels.clone();
            labels.dedup();
            assert_eq!(labels.len(), ticks.labels.len(), "{lo} {hi}: {ticks:?}");
            for v in &ticks.values {
                assert!((scale.lo..=scale.hi).contains(v), "{lo} {hi}: {ticks:?}");
            }
        }
        let t = nice_ticks(0.0, 1.0, 5);
        assert_eq!(t.labels, ["0.00", "0.25", "0.50", "0.75", "1.00"]);
        let t = nice_ticks(0.0, 1.0, 6);
        assert_eq!(t.labels, ["0.0", "0.2", "0.4", "0.6", "0.8", "1.0"]);
        let t = nice_ticks(0.0, 1e6, 5);
        assert_eq!(t.labels, ["0", "2.5e5", "5e5", "7.5e5", "1e6"]);
        let t = nice_ticks(0.0, 10.0, 3);
        assert_eq!(t.labels, ["0", "5", "10"]);
        let t = nice_ticks(-0.5, 0.5, 4);
        assert_eq!(t.labels, ["-0.50", "-0.25", "0.00", "0.25", "0.50"]);
        assert!(ColourScale::new(-1e308, 1e308).is_none());
    }

    #[test]
    fn degenerate_inputs_do_not_panic() {
        let dir = tempfile::tempdir().unwrap();
        let nan = vec![f64::NAN; 5];
        let same = vec![2.0; 5];
        let ramp: Vec<f64> = (0..5).map(f64::from).collect();
        let mixed = vec![1.0, f64::INFINITY, f64::NAN, -2.0, 0.5];
        let huge = vec![-1e308, 1e308, 0.0, 1.0, 2.0];
        let tiny = vec![1e-320, 2e-320, 0.0, 3e-320, 0.0];
        let long_line: Vec<f64> = (0..5000).map(|i| f64::from(i) * 1e-3).collect();
        let long_same = vec![7.0; 5000];
        let empty: Vec<f64> = Vec::new();
        type Case<'a> = (&'a str, &'a [f64], &'a [f64], &'a [f64]);
        let cases: Vec<Case> = vec![
            ("empty", &empty, &empty, &empty),
            ("all nan values", &ramp, &ramp, &nan),
            ("all nan positions", &nan, &nan, &ramp),
            ("identical points", &same, &same, &ramp),
            ("identical points and values", &same, &same, &same),
            ("single point", &ramp[..1], &ramp[..1], &ramp[..1]),
            ("vertical line", &same, &ramp, &ramp),
            ("some non-finite", &ramp, &ramp, &mixed),
            ("huge values", &ramp, &ramp, &huge),
            ("huge positions", &huge, &ramp, &ramp),
            ("subnormal", &tiny, &tiny, &tiny),
            ("binned horizontal line", &long_line, &long_same, &long_line),
            ("binned identical", &long_same, &long_same, &long_line),
            ("binned constant", &long_line, &long_line, &long_same),
        ];
        let blank = ScatterAxes {
            title: "",
            x_label: "",
            y_label: "",
            colour_label: "",
        };
        let weird = ScatterAxes {
            title: "a <b> & \"c\"\nd",
            x_label: "x\u{7}",
            y_label: "",
            colour_label: "'v'",
        };
        let all_axes = [axes(), blank, weird];
        for (i, (name, x, y, v)) in cases.iter().enumerate() {
            for (j, labels) in all_axes.iter().enumerate() {
                let path = dir.path().join(format!("case{i}_{j}.svg"));
                match scatter_plot(&path, labels, x, y, v) {
                    Ok(()) => {
                        let svg = std::fs::read_to_string(&path).unwrap();
                        assert_valid(&svg, name);
                        assert!(marks(&svg) <= MAX_MARKS, "{name}");
                    }
                    Err(Error::WriteOutput { path: p, reason }) => {
                        assert_eq!(p, path, "{name}");
                        assert!(name.starts_with("huge"), "{name}: {reason}");
                    }
                    Err(e) => panic!("{name}: unexpected error {e}"),
                }
            }
        }
        let svg = std::fs::read_to_string(dir.path().join("case7_0.svg")).unwrap();
        assert!(svg.contains("3 particles; 2 skipped (non-finite)"), "{svg}");
        let svg = std::fs::read_to_string(dir.path().join("case2_0.svg")).unwrap();
        assert!(svg.contains("no particles to draw; 5 skipped"));
        let svg = std::fs::read_to_string(dir.path().join("case2_2.svg")).unwrap();
        assert!(svg.contains("a &lt;b&gt; &amp; &quot;c&quot; d"));
        let svg = std::fs::read_to_string(dir.path().join("case11_0.svg")).unwrap();
        assert!(svg.contains("binned to a "));
        no_tmp_left(dir.path());
    }

    #[test]
    fn mismatched_lengths_are_an_input_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.svg");
        let err = scatter_plot(&path, &axes(), &[1.0, 2.0], &[1.0], &[1.0, 2.0]).unwrap_err();
        assert!(matches!(err, Error::InvalidValue { .. }), "{err}");
        assert!(err.to_string().contains("same length"), "{err}");
        let err = scatter_plot(&path, &axes(), &[1.0], &[1.0], &[]).unwrap_err();
        assert!(matches!(err, Error::InvalidValue { .. }), "{err}");
        assert!(!path.exists());
    }

    #[test]
    fn unwritable_path_is_a_clean_error() {
        let path = Path::new("/nonexistent-dir/scatter.svg");
        let err = scatter_plot(path, &axes(), &[1.0], &[1.0], &[1.0]).unwrap_err();
        assert!(matches!(err, Error::WriteOutput { .. }));
        assert!(err.to_string().contains("/nonexistent-dir/scatter.svg"));
    }
}
