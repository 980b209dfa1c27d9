//! The data of a plot: named series whose coordinates are stored slices or values computed
//! per index, and their reduction to the points a figure draws.
//!
//! A run of 1e7 particles plots its profiles and error profiles over the particles sorted
//! along the plot axis. With [`Values::Computed`] a series reads the particle arrays through
//! that order (`x_i = position[order[i]]`, `y_i = error(order[i])`) instead of holding a
//! sorted copy of each column, and `prepare` streams over the points, keeping only what
//! the figure shows ([`crate::output::thinning`]): a plot costs no memory per particle
//! beyond the order the caller sorts once. The kept points are the same, in the same
//! order, as thinning a materialised copy would keep.

use crate::output::thinning::{thin_points, LineThinner, MAX_MARKS};
use rayon::prelude::*;

/// The coordinates of one axis of a series.
#[derive(Clone, Copy)]
pub enum Values<'a> {
    /// Stored values, one per point.
    Stored(&'a [f64]),
    /// `len` values, the `i`-th computed by `at(i)` when it is needed (each value may be
    /// computed more than once: `at` must be a pure function of `i`).
    Computed {
        len: usize,
        at: &'a (dyn Fn(usize) -> f64 + Sync),
    },
}

impl Values<'_> {
    /// Number of values.
    pub fn len(&self) -> usize {
        match self {
            Values::Stored(values) => values.len(),
            Values::Computed { len, .. } => *len,
        }
    }

    /// Whether there are no values.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The `i`-th value (`i < len`).
    ///
    /// ```
    /// use tlsmpm::output::series::Values;
    /// let square = |i: usize| (i * i) as f64;
    /// let values = Values::Computed { len: 4, at: &square };
    /// assert_eq!(values.at(3), 9.0);
    /// assert_eq!(Values::from(&[1.0, 2.0][..]).at(1), 2.0);
    /// ```
    #[inline]
    pub fn at(&self, i: usize) -> f64 {
        match self {
            Values::Stored(values) => values[i],
            Values::Computed { at, .. } => at(i),
        }
    }
}

impl<'a> From<&'a [f64]> for Values<'a> {
    fn from(values: &'a [f64]) -> Self {
        Values::Stored(values)
    }
}

impl<'a> From<&'a Vec<f64>> for Values<'a> {
    fn from(values: &'a Vec<f64>) -> Self {
        Values::Stored(values)
    }
}

impl<'a, const N: usize> From<&'a [f64; N]> for Values<'a> {
    fn from(values: &'a [f64; N]) -> Self {
        Values::Stored(values)
    }
}

/// How a series is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Style {
    /// A polyline through the points, broken where a point is skipped.
    Line,
    /// An exact solution or reference: a thin dark line that takes no palette colour. Put
    /// it first so that the other series are drawn over it.
    Reference,
    /// A guide line (e.g. a slope of a convergence plot): thin, grey, its label written at
    /// its last point instead of in the legend.
    Guide,
    /// A small filled circle at each point.
    Points,
    /// A polyline with a filled circle at each point, in the same colour.
    LinePoints,
}

/// One named data series.
#[derive(Clone, Copy)]
pub struct Series<'a> {
    /// Legend text; an empty label leaves the series out of the legend.
    pub label: &'a str,
    /// Abscissae.
    pub x: Values<'a>,
    /// Ordinates; if `x` and `y` differ in length the extra values of the longer are ignored.
    pub y: Values<'a>,
    /// How the series is drawn.
    pub style: Style,
}

impl Series<'_> {
    /// The points `(x_i, y_i)`, as many as the shorter coordinate array has.
    fn points(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        (0..self.x.len().min(self.y.len())).map(|i| (self.x.at(i), self.y.at(i)))
    }
}

/// A series reduced to drawable points.
pub(crate) struct Prepared {
    /// Legend text with line breaks replaced by spaces.
    pub label: String,
    /// How the series is drawn.
    pub style: Style,
    /// Runs of consecutive valid points; a skipped point ends a run.
    pub runs: Vec<Vec<(f64, f64)>>,
}

/// The extent of the data of a plot.
pub(crate) struct Bounds {
    /// `(min, max)` of `x` over the valid points of all series; `(+inf, -inf)` without any.
    pub x: (f64, f64),
    /// The same for `y`.
    pub y: (f64, f64),
    /// Valid points of each series.
    counts: Vec<usize>,
}

/// `(x range, y range, valid points)` of one series.
type SeriesExtent = ((f64, f64), (f64, f64), usize);

/// The [`Bounds`] of the points of all series whose coordinates satisfy `valid_x` and
/// `valid_y` (one pass over each series, the series in parallel).
pub(crate) fn bounds(
    series: &[Series],
    valid_x: impl Fn(f64) -> bool + Sync,
    valid_y: impl Fn(f64) -> bool + Sync,
) -> Bounds {
    let empty = (f64::INFINITY, f64::NEG_INFINITY);
    // One task per series; then the series in order, so that the result is the one of a
    // single pass over all points.
    let per_series: Vec<SeriesExtent> = series
        .par_iter()
        .map(|s| {
            let (mut x, mut y, mut count) = (empty, empty, 0);
            for (px, py) in s.points().filter(|&(x, y)| valid_x(x) && valid_y(y)) {
                widen(&mut x, px);
                widen(&mut y, py);
                count += 1;
            }
            (x, y, count)
        })
        .collect();
    let mut bounds = Bounds {
        x: empty,
        y: empty,
        counts: Vec::with_capacity(series.len()),
    };
    for (x, y, count) in per_series {
        if count > 0 {
            widen(&mut bounds.x, x.0);
            widen(&mut bounds.x, x.1);
            widen(&mut bounds.y, y.0);
            widen(&mut bounds.y, y.1);
        }
        bounds.counts.push(count);
    }
    bounds
}

/// Extend `range` to hold `v` (never NaN here): plain comparisons, so that of equal values
/// (+0 and -0) the first one stays.
#[inline]
fn widen(range: &mut (f64, f64), v: f64) {
    if v < range.0 {
        range.0 = v;
    }
    if v > range.1 {
        range.1 = v;
    }
}

/// The valid points of every series, split into runs at the invalid ones; a series of more
/// than [`MAX_MARKS`] valid points (counted in `bounds`) is thinned on the way to what the
/// figure shows (lines by pixel column, points by pixel cell; `to_pixel` maps a point to
/// pixel coordinates of the plotting area), without being stored whole.
pub(crate) fn prepare(
    series: &[Series],
    bounds: &Bounds,
    valid_x: impl Fn(f64) -> bool + Copy + Sync,
    valid_y: impl Fn(f64) -> bool + Copy + Sync,
    to_pixel: impl Fn((f64, f64)) -> (f64, f64) + Copy + Sync,
) -> Vec<Prepared> {
    let valid = move |&(x, y): &(f64, f64)| valid_x(x) && valid_y(y);
    // One task per series (each is prepared on its own; the order is kept).
    series
        .par_iter()
        .zip(&bounds.counts)
        .map(|(s, &count)| {
            let runs = if count <= MAX_MARKS {
                runs_of(s.points(), valid, &mut Vec::new())
            } else {
                match s.style {
                    Style::Points => vec![thin_points(s.points().filter(valid), to_pixel)],
                    Style::Line | Style::LinePoints | Style::Reference | Style::Guide => {
                        runs_of(s.points(), valid, &mut LineThinner::new(to_pixel))
                    }
                }
            };
            Prepared {
                label: s.label.replace(['\n', '\r'], " "),
                style: s.style,
                runs,
            }
        })
        .collect()
}

/// Collects one run of points at a time: all of them, or a line's thinned points.
trait RunBuilder {
    fn push(&mut self, point: (f64, f64));
    fn is_empty(&self) -> bool;
    /// The run so far; the builder starts a new one.
    fn finish(&mut self) -> Vec<(f64, f64)>;
}

impl RunBuilder for Vec<(f64, f64)> {
    fn push(&mut self, point: (f64, f64)) {
        Vec::push(self, point);
    }
    fn is_empty(&self) -> bool {
        <[_]>::is_empty(self)
    }
    fn finish(&mut self) -> Vec<(f64, f64)> {
        std::mem::take(self)
    }
}

impl<F: Fn((f64, f64)) -> (f64, f64)> RunBuilder for LineThinner<F> {
    fn push(&mut self, point: (f64, f64)) {
        LineThinner::push(self, point);
    }
    fn is_empty(&self) -> bool {
        LineThinner::is_empty(self)
    }
    fn finish(&mut self) -> Vec<(f64, f64)> {
        LineThinner::finish(self)
    }
}

/// The runs of consecutive `valid` points of `points`, each collected by `builder`.
fn runs_of(
    points: impl Iterator<Item = (f64, f64)>,
    valid: impl Fn(&(f64, f64)) -> bool,
    builder: &mut impl RunBuilder,
) -> Vec<Vec<(f64, f64)>> {
    let mut runs = Vec::new();
    for point in points {
        if valid(&point) {
            builder.push(point);
        } else if !builder.is_empty() {
            runs.push(builder.finish());
        }
    }
    if !builder.is_empty() {
        runs.push(builder.finish());
    }
    runs
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Per-series bounds combined in order equal one pass over all points; empty and
    /// all-invalid series count 0 and do not widen the range; counts skip invalid points.
    #[test]
    fn bounds_and_counts_equal_a_single_pass() {
        let xs: [&[f64]; 4] = [
            &[],
            &[3.0, 1.0, 2.0, 7.0],
            &[f64::NAN, -4.0, 0.5],
            &[f64::NAN],
        ];
        let ys: [&[f64]; 4] = [&[], &[1.0, -2.0, 9.0], &[5.0, 6.0, f64::INFINITY], &[1.0]];
        let series: Vec<Series> = xs
            .iter()
            .zip(&ys)
            .map(|(x, y)| Series {
                label: "",
                x: Values::Stored(x),
                y: Values::Stored(y),
                style: Style::Points,
            })
            .collect();
        let finite = |v: f64| v.is_finite();
        let b = bounds(&series, finite, finite);
        // Valid points: (3,1) (1,-2) (2,9) and (-4,6).
        assert_eq!(b.x, (-4.0, 3.0));
        assert_eq!(b.y, (-2.0, 9.0));
        assert_eq!(b.counts, vec![0, 3, 1, 0]);
        let none = bounds(&series[..1], finite, finite);
        assert_eq!(none.x, (f64::INFINITY, f64::NEG_INFINITY));
    }

    /// Computed values are read through their function, truncated to the shorter axis.
    #[test]
    fn computed_series_read_through_the_order() {
        let position = [0.3, 0.1, 0.2];
        let order = [1usize, 2, 0];
        let x = |i: usize| position[order[i]];
        let series = Series {
            label: "",
            x: Values::Computed { len: 3, at: &x },
            y: Values::Stored(&[1.0, 2.0]),
            style: Style::Line,
        };
        assert_eq!(
            series.points().collect::<Vec<_>>(),
            vec![(0.1, 1.0), (0.2, 2.0)]
        );
    }
}
