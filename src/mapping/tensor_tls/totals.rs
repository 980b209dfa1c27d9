//! The cells' shares of the conserved totals of the TLS fits (`method.cell_totals`,
//! [docs/tls.md](../../../docs/tls.md)).
//!
//! With `"domains"` a particle's quantity `q_p` (mass, momentum, `m_p b_p`) is split among
//! the cells its domain box overlaps, in proportion to the overlap (a product of per-axis
//! fractions, [`split_shares`]); the total of cell `c` is
//!
//! ```text
//! Q_c = sum_(neighbour s of c, offsets from the highest down) S_(s -> c),
//! S_(s -> c) = sum_(p in s, storage order) q_p |box_p ∩ c| / |box_p|,
//! ```
//!
//! so `sum_c Q_c = sum_p q_p` to round-off. The `3^D` shares `S_(s -> .)` of each cell are
//! summed over its particles first and then gathered by the receiving cell, which fixes
//! every sum's order for any thread count. They are kept for three layers of cells (along
//! the last axis) at a time, per task of whole layers: a task recomputes the shares of the
//! layer on either side of its block rather than reading them from a table of all cells
//! (`3^D` x 32 bytes per cell, written and read back twice per step at 10⁶ particles: the
//! table cost more than the splitting). `"centres"` counts each particle in its own cell.

use super::bins::CellParticles;
use super::cells::{cell_axes, split_shares};
use crate::grid::TensorGrid;
use crate::particles::TensorParticles;
use rayon::prelude::*;

/// Cells (at least) per task: whole layers of cells along the last axis, at least
/// [`MIN_LAYERS_PER_TASK`] of them.
const CELLS_PER_TASK: usize = 16_384;
/// Fewest layers per task (each task also splits the particles of one layer either side).
const MIN_LAYERS_PER_TASK: usize = 4;

/// `totals[c] = sum_(p in c) quantity(p)` (the `"centres"` rule).
pub(super) fn centre_totals(
    bins: &CellParticles,
    quantity: impl Fn(usize) -> [f64; 4] + Sync,
    totals: &mut [[f64; 4]],
) {
    totals
        .par_iter_mut()
        .with_min_len(64)
        .enumerate()
        .for_each(|(cell, total)| {
            *total = [0.0; 4];
            for &p in bins.of(cell) {
                let q = quantity(p);
                for c in 0..4 {
                    total[c] += q[c];
                }
            }
        });
}

/// `totals[c] = Q_c` of the module docs (the `"domains"` rule): `half(p)` is the half
/// length of particle `p`'s domain box per axis.
pub(super) fn domain_totals<const D: usize>(
    grid: &TensorGrid<D>,
    particles: &TensorParticles<D>,
    bins: &CellParticles,
    half: impl Fn(usize) -> [f64; D] + Sync,
    quantity: impl Fn(usize) -> [f64; 4] + Sync,
    totals: &mut [[f64; 4]],
) {
    let k3 = 3usize.pow(D as u32);
    let per_layer = grid.cells_per_layer();
    let layers = grid.axes[D - 1].cells;
    let layers_per_task = CELLS_PER_TASK.div_ceil(per_layer).max(MIN_LAYERS_PER_TASK);
    // Share slot `k` (base-3 digits `o_a + 1`) of the cell at `-o` gives to this cell: the
    // offsets `o` and the shift of the source within its layer (no divisions per cell).
    let neighbours: Vec<([isize; D], isize)> = (0..k3)
        .map(|k| {
            let o: [isize; D] =
                std::array::from_fn(|a| (k / 3usize.pow(a as u32) % 3) as isize - 1);
            let mut shift = 0;
            let mut stride = 1;
            for a in 0..D - 1 {
                shift += o[a] * stride;
                stride *= grid.axes[a].cells as isize;
            }
            (o, shift)
        })
        .collect();
    // The shares of every cell of layer `layer` into `ring` (`k3` per cell).
    let split_layer = |layer: usize, ring: &mut [[f64; 4]]| {
        for (offset, out) in ring.chunks_exact_mut(k3).enumerate() {
            out.fill([0.0; 4]);
            let cell = layer * per_layer + offset;
            let index = cell_axes(grid, cell);
            for &p in bins.of(cell) {
                split_shares(
                    grid,
                    index,
                    particles.position(p),
                    half(p),
                    quantity(p),
                    out,
                );
            }
        }
    };
    totals[..layers * per_layer]
        .par_chunks_mut(layers_per_task * per_layer)
        .enumerate()
        .for_each_init(Vec::new, |ring, (block, block_totals)| {
            let first = block * layers_per_task;
            let last = first + block_totals.len() / per_layer;
            // Three layers of shares: layer `l` lives in slot `l % 3`.
            ring.resize(3 * per_layer * k3, [0.0; 4]);
            let slot = |layer: usize| (layer % 3) * per_layer * k3;
            for layer in first.saturating_sub(1)..(first + 1).min(layers) {
                let at = slot(layer);
                split_layer(layer, &mut ring[at..at + per_layer * k3]);
            }
            for layer in first..last {
                if layer + 1 < layers {
                    let at = slot(layer + 1);
                    split_layer(layer + 1, &mut ring[at..at + per_layer * k3]);
                }
                let layer_totals = &mut block_totals[(layer - first) * per_layer..][..per_layer];
                for (offset, total) in layer_totals.iter_mut().enumerate() {
                    let index = cell_axes(grid, layer * per_layer + offset);
                    *total = [0.0; 4];
                    // From the highest offset down: in 1D from the left neighbour, own,
                    // from the right neighbour (the 1D order).
                    for k in (0..k3).rev() {
                        let (o, shift) = &neighbours[k];
                        let inside = (0..D).all(|a| {
                            let s = index[a] as isize - o[a];
                            s >= 0 && (s as usize) < grid.axes[a].cells
                        });
                        if inside {
                            let source_layer = (layer as isize - o[D - 1]) as usize;
                            let source_offset = (offset as isize - shift) as usize;
                            let share = ring[slot(source_layer) + source_offset * k3 + k];
                            for c in 0..4 {
                                total[c] += share[c];
                            }
                        }
                    }
                }
            }
        });
}
