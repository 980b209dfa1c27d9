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
//! The plots pass series of at most [`MAX_MARKS`] valid points through whole and call these
//! only for longer ones (`crate::output::series`), which they stream over without a copy.

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
    run: impl IntoIterator<Item = (f64, f64)>,
    to_pixel: impl Fn((f64, f64)) -> (f64, f64),
) -> Vec<(f64, f64)> {
    let mut thinner = LineThinner::new(to_pixel);
    for point in run {
        thinner.push(point);
    }
    thinner.finish()
}

/// The M4 reduction of a polyline fed one point at a time (no copy of the run): of each
/// group of consecutive points in one pixel column it keeps the first, the (first) lowest,
/// the (first) highest and the last, in their order.
pub struct LineThinner<F> {
    to_pixel: F,
    kept: Vec<(f64, f64)>,
    group: Option<ColumnGroup>,
}

/// The points of one pixel column kept so far, with their indices in the group.
struct ColumnGroup {
    column: f64,
    len: usize,
    first: (f64, f64),
    low: (usize, (f64, f64)),
    high: (usize, (f64, f64)),
    last: (usize, (f64, f64)),
}

impl ColumnGroup {
    fn new(column: f64, point: (f64, f64)) -> Self {
        Self {
            column,
            len: 1,
            first: point,
            low: (0, point),
            high: (0, point),
            last: (0, point),
        }
    }

    fn push(&mut self, point: (f64, f64)) {
        let i = self.len;
        if point.1 < self.low.1 .1 {
            self.low = (i, point);
        }
        if point.1 > self.high.1 .1 {
            self.high = (i, point);
        }
        self.last = (i, point);
        self.len += 1;
    }

    /// Append the kept points in their order, each once.
    fn emit(&self, kept: &mut Vec<(f64, f64)>) {
        let mut picks = [(0, self.first), self.low, self.high, self.last];
        picks.sort_unstable_by_key(|&(i, _)| i);
        let mut last = usize::MAX;
        for (i, point) in picks {
            if i != last {
                kept.push(point);
                last = i;
            }
        }
    }
}

impl<F: Fn((f64, f64)) -> (f64, f64)> LineThinner<F> {
    /// An empty run; `to_pixel` maps a point to pixel coordinates.
    pub fn new(to_pixel: F) -> Self {
        Self {
            to_pixel,
            kept: Vec::new(),
            group: None,
        }
    }

    /// The next point of the run.
    pub fn push(&mut self, point: (f64, f64)) {
        let column = (self.to_pixel)(point).0.floor();
        match &mut self.group {
            Some(group) if group.column == column => group.push(point),
            group => {
                if let Some(done) = group.replace(ColumnGroup::new(column, point)) {
                    done.emit(&mut self.kept);
                }
            }
        }
    }

    /// Whether no point was pushed since the last [`Self::finish`].
    pub fn is_empty(&self) -> bool {
        self.group.is_none()
    }

    /// The kept points of the run; the thinner starts a new run.
    pub fn finish(&mut self) -> Vec<(f64, f64)> {
        if let Some(group) = self.group.take() {
            group.emit(&mut self.kept);
        }
        std::mem::take(&mut self.kept)
    }
}

/// Cell sizes of the point binning, in pixels: 2, 4, ..., [`MAX_CELL`] (powers of two).
const CELL_SIZES: [f64; 6] = [2.0, 4.0, 8.0, 16.0, 32.0, MAX_CELL];

/// Thin a point series of more than [`MAX_MARKS`] points to at most that many markers by
/// pixel binning (see the module documentation); the input order of the kept points is
/// preserved. One pass bins every cell size at once (the kept set of each size is the one
/// a pass of its own would keep), and the smallest size that keeps at most [`MAX_MARKS`]
/// (else the largest) is returned. A size that has kept more than [`MAX_MARKS`] cannot be
/// returned and is no longer binned, and the cell of a point at size `2^(k+1)` is its cell
/// at size 2 shifted by `k` (`floor(floor(x / 2) / 2^k) = floor(x / 2^(k+1))`): one
/// division and floor per coordinate and point.
pub fn thin_points(
    points: impl IntoIterator<Item = (f64, f64)>,
    to_pixel: impl Fn((f64, f64)) -> (f64, f64),
) -> Vec<(f64, f64)> {
    let mut occupied = CELL_SIZES.map(Occupied::new);
    let mut kept: [Vec<(f64, f64)>; CELL_SIZES.len()] = Default::default();
    let last = CELL_SIZES.len() - 1;
    // Sizes below `live` have kept too many points.
    let mut live = 0;
    for point in points {
        let (x, y) = to_pixel(point);
        let (i, j) = (floor_i64(x / CELL_SIZES[0]), floor_i64(y / CELL_SIZES[0]));
        for k in live..CELL_SIZES.len() {
            if occupied[k].insert(i >> k, j >> k) {
                kept[k].push(point);
            }
        }
        if live < last && kept[live].len() > MAX_MARKS {
            live += 1;
        }
    }
    let chosen = kept
        .iter()
        .position(|k| k.len() <= MAX_MARKS)
        .unwrap_or(last);
    std::mem::take(&mut kept[chosen])
}

/// `x.floor() as i64` (saturating, NaN to 0) without the library call `floor` is on
/// targets without SSE4.1: truncate, and step down where that rounded up.
#[inline]
fn floor_i64(x: f64) -> i64 {
    let truncated = x as i64;
    if truncated as f64 > x {
        truncated.saturating_sub(1)
    } else {
        truncated
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
        let kept = thin_line(run.iter().copied(), identity);
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
        let kept = thin_points(points.iter().copied(), identity);
        assert!(kept.len() <= MAX_MARKS, "{}", kept.len());
        assert!(kept.len() > MAX_MARKS / 8, "{}", kept.len());
        assert!(kept.contains(&(900.0, 900.0)));
    }

    #[test]
    fn floor_i64_is_floor_then_saturating_cast() {
        let special = [
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            2.5,
            -2.5,
            1e300,
            -1e300,
            9.3e18,
            -9.3e18,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            4503599627370495.5,
            -4503599627370495.5,
            9007199254740993.0,
        ];
        let mut state = 12345u64;
        let random = (0..100_000).map(|_| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            f64::from_bits(state)
        });
        for x in special.into_iter().chain(random) {
            assert_eq!(floor_i64(x), x.floor() as i64, "{x:e}");
        }
    }

    /// The slice M4 reduction as first written: find each column group, then pick.
    fn thin_line_by_groups(run: &[(f64, f64)]) -> Vec<(f64, f64)> {
        let mut kept = Vec::new();
        let mut start = 0;
        while start < run.len() {
            let column = run[start].0.floor();
            let mut end = start + 1;
            while end < run.len() && run[end].0.floor() == column {
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
            picks.iter().enumerate().for_each(|(k, &i)| {
                if k == 0 || picks[k - 1] != i {
                    kept.push(group[i]);
                }
            });
            start = end;
        }
        kept
    }

    /// Point binning as first written: one pass per cell size, doubling until small enough.
    fn thin_points_by_passes(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
        let mut cell = 2.0;
        loop {
            let mut occupied = Occupied::new(cell);
            let kept: Vec<(f64, f64)> = points
                .iter()
                .copied()
                .filter(|&(x, y)| {
                    occupied.insert((x / cell).floor() as i64, (y / cell).floor() as i64)
                })
                .collect();
            if kept.len() <= MAX_MARKS || cell >= MAX_CELL {
                return kept;
            }
            cell *= 2.0;
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(32))]
        /// The streaming thinners keep exactly the points (and order) of the slice
        /// versions: lines with repeated columns and ties, point clouds from sparse
        /// (thinned at 2 px) to dense (thinned at 64 px) and with points off the bitmap.
        #[test]
        fn streaming_thinning_equals_the_slice_versions(
            seed in 0u64..1_000_000, n in 4001usize..60_000, spread in 0usize..4) {
            let mut state = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let mut next = move || {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (state >> 11) as f64 / (1u64 << 53) as f64
            };
            let extent = [40.0, 300.0, 700.0, 5000.0][spread];
            let cloud: Vec<(f64, f64)> = (0..n).map(|_| (next() * extent, (next() * 450.0).round() / 2.0)).collect();
            proptest::prop_assert_eq!(thin_points(cloud.iter().copied(), identity), thin_points_by_passes(&cloud));
            let mut line: Vec<(f64, f64)> = cloud.clone();
            line.sort_by(|a, b| a.0.total_cmp(&b.0));
            proptest::prop_assert_eq!(thin_line(line.iter().copied(), identity), thin_line_by_groups(&line));
        }
    }
}
