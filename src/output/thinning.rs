//! Thinning of plot series to what the figure can show, so that a plot of 1e6 particles is
//! as small as one of 1e3 (a few hundred kB) and looks the same.
//!
//! Coordinates are first mapped to pixels of the plotting area (`to_pixel`). Then:
//!
//! * **Lines** (M4 reduction): of every run of consecutive points in one pixel column, keep
//!   the first, the lowest, the highest and the last point, in their order. The polyline
//!   drawn through the kept points covers the same pixels as the full one, and a line has
//!   at most four points per pixel column.
//! * **Points**: keep the first point of every `b x b`-pixel cell, `b = 2` and doubled
//!   until at most [`MAX_MARKS`] remain. Overlapping markers are dropped; an isolated
//!   point always stays.
//!
//! Series that already have at most [`MAX_MARKS`] points are not touched.

use std::collections::HashSet;

/// Most markers a point series keeps (and the size below which nothing is thinned).
pub const MAX_MARKS: usize = 4000;

/// Largest cell size of the point binning, in pixels.
const MAX_CELL: f64 = 64.0;

/// Pixel extent covered by the dense occupancy map of [`Occupied`] (cells of points
/// outside it go to a hash set).
const DENSE_PIXELS: f64 = 4096.0;

/// The pixel cells that already hold a kept point: a bitmap over
/// `[0, DENSE_PIXELS)^2` (one test per point, no hashing for the millions of points of a
/// large run), a hash set beyond it.
struct Occupied {
    side: i64,
    dense: Vec<bool>,
    outside: HashSet<(i64, i64)>,
}

impl Occupied {
    fn new(cell: f64) -> Self {
        let side = (DENSE_PIXELS / cell).ceil() as i64;
        Self {
            side,
            dense: vec![false; (side * side) as usize],
            outside: HashSet::new(),
        }
    }

    /// Mark cell `(i, j)`; `true` if it was free.
    fn insert(&mut self, i: i64, j: i64) -> bool {
        if (0..self.side).contains(&i) && (0..self.side).contains(&j) {
            let slot = &mut self.dense[(j * self.side + i) as usize];
            !std::mem::replace(slot, true)
        } else {
            self.outside.insert((i, j))
        }
    }
}

/// M4-thin one polyline run; `to_pixel` maps a point to pixel coordinates.
pub fn thin_line(
    run: &[(f64, f64)],
    to_pixel: impl Fn((f64, f64)) -> (f64, f64),
) -> Vec<(f64, f64)> {
    let mut kept = Vec::new();
    let mut start = 0;
    while start < run.len() {
        let column = to_pixel(run[start]).0.floor();
        let mut end = start + 1;
        while end < run.len() && to_pixel(run[end]).0.floor() == column {
            end += 1;
        }
        let group = &run[start..end];
        let (mut low, mut high) = (0, 0);
        for (i, p) in group.iter().enumerate() {
            if p.1 < group[low].1 {
                low = i;
            }
            if p.1 > group[high].1 {
                high = i;
            }
        }
        let mut picks = [0, low, high, group.len() - 1];
        picks.sort_unstable();
        let mut last = usize::MAX;
        for i in picks {
            if i != last {
                kept.push(group[i]);
                last = i;
            }
        }
        start = end;
    }
    kept
}

/// Thin a point series to at most [`MAX_MARKS`] markers by pixel binning (see the module
/// documentation); the input order of the kept points is preserved.
pub fn thin_points(
    points: &[(f64, f64)],
    to_pixel: impl Fn((f64, f64)) -> (f64, f64),
) -> Vec<(f64, f64)> {
    if points.len() <= MAX_MARKS {
        return points.to_vec();
    }
    let mut cell = 2.0;
    loop {
        let mut occupied = Occupied::new(cell);
        let kept: Vec<(f64, f64)> = points
            .iter()
            .copied()
            .filter(|&p| {
                let (x, y) = to_pixel(p);
                occupied.insert((x / cell).floor() as i64, (y / cell).floor() as i64)
            })
            .collect();
        if kept.len() <= MAX_MARKS || cell >= MAX_CELL {
            return kept;
        }
        cell *= 2.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn identity(p: (f64, f64)) -> (f64, f64) {
        p
    }

    #[test]
    fn a_line_keeps_the_extremes_of_every_pixel_column() {
        // 100 columns, 1000 points each, a spike in column 37.
        let run: Vec<(f64, f64)> = (0..100_000)
            .map(|i| {
                let x = i as f64 / 1000.0;
                let y = if i == 37_500 { 50.0 } else { (x * 0.3).sin() };
                (x, y)
            })
            .collect();
        let kept = thin_line(&run, identity);
        assert!(kept.len() <= 400, "{}", kept.len());
        assert!(kept.contains(&run[37_500]), "the spike survives");
        assert_eq!(kept.first(), run.first());
        assert_eq!(kept.last(), run.last());
        // Every column keeps its own minimum and maximum.
        for column in 0..100 {
            let group = &run[column * 1000..(column + 1) * 1000];
            let max = group.iter().map(|p| p.1).fold(f64::MIN, f64::max);
            assert!(kept
                .iter()
                .any(|p| p.0.floor() == column as f64 && p.1 == max));
        }
    }

    #[test]
    fn points_are_binned_to_at_most_max_marks_and_isolated_ones_stay() {
        // A dense cloud of 1e5 points in 700 x 450 px plus one outlier.
        let mut points: Vec<(f64, f64)> = (0..100_000)
            .map(|i| {
                let t = i as f64;
                (
                    (t * 0.618_034).fract() * 700.0,
                    (t * 0.414_214).fract() * 450.0,
                )
            })
            .collect();
        points.push((900.0, 900.0));
        let kept = thin_points(&points, identity);
        assert!(kept.len() <= MAX_MARKS, "{}", kept.len());
        assert!(kept.len() > MAX_MARKS / 8, "{}", kept.len());
        assert!(kept.contains(&(900.0, 900.0)));
        // Small series are untouched.
        assert_eq!(thin_points(&points[..10], identity), points[..10].to_vec());
    }
}
