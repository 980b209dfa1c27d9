//! Deterministic parallel scatter to grid DOFs.
//!
//! Each cell owns a local buffer of `F x width` values (its DOF window, see
//! [`Basis::cell_window`]). Cells are filled in parallel (rayon), each by a sequential loop
//! over its sorted particles; the buffers are then added into the grid vectors cell by
//! cell in increasing order. No atomics, no races, and the floating-point sums happen in the
//! same order whatever the number of threads.

use crate::grid::{Basis, Shape, MAX_SUPPORT};
use crate::linalg::CsrMatrix;
use crate::particles::CellBins;
use rayon::prelude::*;

/// Cells per rayon task: keeps the task overhead small for few particles per cell.
const CELLS_PER_TASK: usize = 64;

/// A cell's local matrix: `local[r * MAX_SUPPORT + c]` couples DOFs `window_first + r` and
/// `window_first + c`.
pub type LocalMatrix = [f64; MAX_SUPPORT * MAX_SUPPORT];

/// Add `weight phi phi^T` of `shape` to a cell's local matrix; `offset` is
/// `shape.first - window_first`.
#[inline]
pub fn add_outer(local: &mut LocalMatrix, offset: usize, shape: &Shape, weight: f64) {
    let phi = &shape.phi[..shape.len];
    for (r, &phi_r) in phi.iter().enumerate() {
        let start = (offset + r) * MAX_SUPPORT + offset;
        let a = weight * phi_r;
        for (entry, &phi_c) in local[start..start + shape.len].iter_mut().zip(phi) {
            *entry += a * phi_c;
        }
    }
}

/// A cell's local accumulators: `local[f][k]` is field `f` at DOF `window_first + k`.
pub type Local<const F: usize> = [[f64; MAX_SUPPORT]; F];

/// Reusable per-cell buffers.
#[derive(Clone, Debug, Default)]
pub struct CellScatter {
    buffer: Vec<f64>,
}

impl CellScatter {
    /// Scatter `F` fields. `kernel(cell, window_first, local)` accumulates the cell's
    /// contributions into `local` (zeroed on entry); the reduced result is written (not
    /// added) into `outputs[f]`, each of length `basis.num_dofs()`.
    pub fn scatter<B, K, const F: usize>(
        &mut self,
        basis: &B,
        bins: &CellBins,
        outputs: [&mut [f64]; F],
        kernel: K,
    ) where
        B: Basis,
        K: Fn(usize, usize, &mut Local<F>) + Sync,
    {
        self.scatter_cells(basis, bins.cells(), outputs, kernel);
    }

    /// [`CellScatter::scatter`] over `cells` cells (for kernels that loop over Gauss
    /// points instead of binned particles).
    pub fn scatter_cells<B, K, const F: usize>(
        &mut self,
        basis: &B,
        cells: usize,
        outputs: [&mut [f64]; F],
        kernel: K,
    ) where
        B: Basis,
        K: Fn(usize, usize, &mut Local<F>) + Sync,
    {
        let width = basis.max_window();
        let stride = F * width;
        self.fill_cells(basis, cells, stride, |cell, first, chunk| {
            let mut local = [[0.0; MAX_SUPPORT]; F];
            kernel(cell, first, &mut local);
            for (row, out) in local.iter().zip(chunk.chunks_exact_mut(width)) {
                out.copy_from_slice(&row[..width]);
            }
        });
        self.reduce_into(basis, width, outputs);
    }

    /// [`CellScatter::scatter`] that also updates a per-particle field of the particles it
    /// maps: `kernel(cell, window_first, particles, values, local)` gets the cell's particle
    /// range `particles` (`bins.range(cell)`, particles stored in cell order) and `values`,
    /// the part of `field` at those particles, to change before it maps them. Cells are
    /// filled in fixed groups of [`CELLS_PER_TASK`], each cell's local buffer and the
    /// reduction exactly as in [`CellScatter::scatter`]: the same sums, bit for bit.
    pub fn scatter_updating<B, K, const F: usize>(
        &mut self,
        basis: &B,
        bins: &CellBins,
        field: &mut [f64],
        outputs: [&mut [f64]; F],
        kernel: K,
    ) where
        B: Basis,
        K: Fn(usize, usize, std::ops::Range<usize>, &mut [f64], &mut Local<F>) + Sync,
    {
        let cells = bins.cells();
        let width = basis.max_window();
        let stride = F * width;
        self.buffer.clear();
        self.buffer.resize(cells * stride, 0.0);
        // The field cut at the first particle of each group of cells.
        let mut groups = Vec::with_capacity(cells.div_ceil(CELLS_PER_TASK));
        let mut rest = field;
        let mut start = 0;
        for group_start in (0..cells).step_by(CELLS_PER_TASK) {
            let end = bins.cell_start[(group_start + CELLS_PER_TASK).min(cells)];
            let (head, tail) = std::mem::take(&mut rest).split_at_mut(end - start);
            groups.push((start, head));
            (rest, start) = (tail, end);
        }
        self.buffer
            .par_chunks_mut(CELLS_PER_TASK * stride)
            .zip(groups)
            .enumerate()
            .for_each(|(group, (buffer, (group_first, values)))| {
                for (c, chunk) in buffer.chunks_exact_mut(stride).enumerate() {
                    let cell = group * CELLS_PER_TASK + c;
                    let particles = bins.range(cell);
                    let own = particles.start - group_first..particles.end - group_first;
                    let mut local = [[0.0; MAX_SUPPORT]; F];
                    kernel(
                        cell,
                        basis.cell_window(cell).0,
                        particles,
                        &mut values[own],
                        &mut local,
                    );
                    for (row, out) in local.iter().zip(chunk.chunks_exact_mut(width)) {
                        out.copy_from_slice(&row[..width]);
                    }
                }
            });
        self.reduce_into(basis, width, outputs);
    }

    /// Write the sum of the cells' buffers (chunks of `F x width`) into `outputs`, cell by
    /// cell in increasing order.
    fn reduce_into<B: Basis, const F: usize>(
        &self,
        basis: &B,
        width: usize,
        mut outputs: [&mut [f64]; F],
    ) {
        for out in outputs.iter_mut() {
            out.fill(0.0);
        }
        for (cell, chunk) in self.buffer.chunks_exact(F * width).enumerate() {
            let (first, len) = basis.cell_window(cell);
            for (out, local) in outputs.iter_mut().zip(chunk.chunks_exact(width)) {
                for (o, l) in out[first..first + len].iter_mut().zip(&local[..len]) {
                    *o += l;
                }
            }
        }
    }

    /// Scatter a symmetric matrix with the band pattern of the basis
    /// ([`CsrMatrix::band`] with bandwidth `max_window - 1`). `kernel(cell, window_first,
    /// local)` fills the cell's local matrix (zeroed on entry); the cells are added into
    /// `matrix.values` (overwritten) in increasing cell order, whatever the thread count.
    pub fn scatter_matrix<B, K>(
        &mut self,
        basis: &B,
        cells: usize,
        matrix: &mut CsrMatrix,
        kernel: K,
    ) where
        B: Basis,
        K: Fn(usize, usize, &mut LocalMatrix) + Sync,
    {
        let width = basis.max_window();
        let stride = width * width;
        self.fill_cells(basis, cells, stride, |cell, first, chunk| {
            let mut local = [0.0; MAX_SUPPORT * MAX_SUPPORT];
            kernel(cell, first, &mut local);
            for (r, out) in chunk.chunks_exact_mut(width).enumerate() {
                out.copy_from_slice(&local[r * MAX_SUPPORT..r * MAX_SUPPORT + width]);
            }
        });
        matrix.values.fill(0.0);
        for (cell, chunk) in self.buffer.chunks_exact(stride).enumerate() {
            let (first, len) = basis.cell_window(cell);
            for r in 0..len {
                let row = first + r;
                let start = matrix.band_index(row, first);
                for (value, local) in matrix.values[start..start + len]
                    .iter_mut()
                    .zip(&chunk[r * width..r * width + len])
                {
                    *value += local;
                }
            }
        }
    }

    /// Resize the buffer to `cells` chunks of `stride` values and fill chunk `cell` by
    /// `fill(cell, window_first, chunk)`, in parallel.
    fn fill_cells<B, G>(&mut self, basis: &B, cells: usize, stride: usize, fill: G)
    where
        B: Basis,
        G: Fn(usize, usize, &mut [f64]) + Sync,
    {
        self.buffer.clear();
        self.buffer.resize(cells * stride, 0.0);
        self.buffer
            .par_chunks_mut(stride)
            .with_min_len(CELLS_PER_TASK)
            .enumerate()
            .for_each(|(cell, chunk)| fill(cell, basis.cell_window(cell).0, chunk));
    }
}
