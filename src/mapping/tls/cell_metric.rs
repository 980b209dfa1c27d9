//! The per-cell driver of the consistent particle metrics of the adjoint TLS step
//! ([`super::particle_mass`], [`super::quadratic_mass`]; docs/reconstruction.md
//! "Consistent particle metric").
//!
//! Both solve `W a = f` for the particle accelerations (or strains) `a`, with
//! `W = diag(m) + C` block diagonal over the cells of the particles' centres: each cell's
//! block is the diagonal plus a low-rank correction `C_c`, applied by the Woodbury formula
//! from data computed once per cell ([`CellMetric`]). A cell without a correction keeps the
//! lumped `a_p = f_p / m_p`.

use std::ops::Range;

use rayon::prelude::*;

/// Cells per rayon task.
const CELLS_PER_TASK: usize = 128;

/// The per-particle inputs of a metric solve (or of one cell of it): the positions `x`,
/// the diagonal `m` (particle masses or fit volumes), the right-hand side `f` and the `K`
/// pull-backs of the test fields (`P^T x`, and `P^T x^2` for the quadratic metric).
#[derive(Clone, Copy)]
pub(super) struct MetricInputs<'a, const K: usize> {
    pub x: &'a [f64],
    pub mass: &'a [f64],
    pub force: &'a [f64],
    pub pulled_back: [&'a [f64]; K],
}

impl<const K: usize> MetricInputs<'_, K> {
    /// The particles `range` only.
    fn slice(&self, range: Range<usize>) -> Self {
        MetricInputs {
            x: &self.x[range.clone()],
            mass: &self.mass[range.clone()],
            force: &self.force[range.clone()],
            pulled_back: self.pulled_back.map(|field| &field[range.clone()]),
        }
    }
}

/// One cell's correction `C_c` of the lumped metric: its Woodbury data.
pub(super) trait CellMetric<const K: usize>: Copy + Send + Sync {
    /// The data of the cell whose particles `cell` holds, `None` where the cell keeps the
    /// lumped metric.
    fn correction(cell: MetricInputs<'_, K>) -> Option<Self>;
    /// Whether the cell took less than its whole correction (scaled down, or a weaker
    /// metric's).
    fn limited(&self) -> bool;
    /// `(W_c^{-1} f)_p` for the particle `p` of `inputs` (the whole arrays), which lies in
    /// this cell.
    fn acceleration(&self, inputs: &MetricInputs<'_, K>, p: usize) -> f64;
}

/// `a = W^{-1} f` over all particles. `cell` is sorted (the particles are binned by cell);
/// cells whose particles are not contiguous fall back to the lumped metric (the arrays are
/// always sorted when mapped; the check keeps a misuse harmless). Returns the number of
/// cells of two particles or more that did not take their whole correction.
pub(super) fn metric_accelerations<M: CellMetric<K>, const K: usize>(
    cells: usize,
    cell: &[usize],
    inputs: MetricInputs<'_, K>,
    corrections: &mut Vec<Option<M>>,
    out: &mut [f64],
) -> u64 {
    corrections.clear();
    corrections.resize(cells, None);
    let sorted = cell.par_windows(2).all(|w| w[0] <= w[1]);
    let limited_cells: u64 = if sorted {
        corrections
            .par_iter_mut()
            .with_min_len(CELLS_PER_TASK)
            .enumerate()
            .map(|(c, correction)| {
                let start = cell.partition_point(|&k| k < c);
                let end = cell.partition_point(|&k| k <= c);
                *correction = M::correction(inputs.slice(start..end));
                u64::from(correction.map_or(end - start >= 2, |k| k.limited()))
            })
            .sum()
    } else {
        0
    };
    out.par_iter_mut().enumerate().for_each(|(p, a)| {
        *a = match corrections.get(cell[p]).copied().flatten() {
            Some(k) => k.acceleration(&inputs, p),
            None => inputs.force[p] / inputs.mass[p],
        };
    });
    limited_cells
}
