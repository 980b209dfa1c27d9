//! Binning of many particles onto a raster of at most [`super::MAX_MARKS`] cells, each drawn
//! as one rectangle coloured by the mean value of its particles.

use super::drawable;

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
