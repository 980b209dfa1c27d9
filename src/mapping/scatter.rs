//! Deterministic parallel scatter to grid DOFs.
//!
//! Each cell owns a local buffer of `F x width` values (its DOF window, see
//! [`Basis::cell_window`]). Cells are filled in parallel (rayon), each by a sequential loop
//! over its sorted particles; the buffers are then added into the grid vectors cell by
//! cell in increasing order. No atomics, no races, and the floating-point sums happen in the
//! same order whatever the number of threads.

use crate::grid::{Basis, MAX_SUPPORT};
use crate::particles::CellBins;
use rayon::prelude::*;

/// Cells per rayon task: keeps the task overhead small for few particles per cell.
const CELLS_PER_TASK: usize = 64;

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
        mut outputs: [&mut [f64]; F],
        kernel: K,
    ) where
        B: Basis,
        K: Fn(usize, usize, &mut Local<F>) + Sync,
    {
        let cells = bins.cells();
        let width = basis.max_window();
        let stride = F * width;
        self.buffer.clear();
        self.buffer.resize(cells * stride, 0.0);
        self.buffer
            .par_chunks_mut(stride)
            .with_min_len(CELLS_PER_TASK)
            .enumerate()
            .for_each(|(cell, chunk)| {
                let mut local = [[0.0; MAX_SUPPORT]; F];
                let (first, _) = basis.cell_window(cell);
                kernel(cell, first, &mut local);
                for (row, out) in local.iter().zip(chunk.chunks_exact_mut(width)) {
                    out.copy_from_slice(&row[..width]);
                }
            });
        for out in outputs.iter_mut() {
            out.fill(0.0);
        }
        for (cell, chunk) in self.buffer.chunks_exact(stride).enumerate() {
            let (first, len) = basis.cell_window(cell);
            for (out, local) in outputs.iter_mut().zip(chunk.chunks_exact(width)) {
                for (o, l) in out[first..first + len].iter_mut().zip(&local[..len]) {
                    *o += l;
                }
            }
        }
    }
}
