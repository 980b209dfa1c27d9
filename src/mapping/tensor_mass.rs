//! Deterministic parallel assembly of the consistent mass matrix of a tensor-product basis
//! (`docs/tls.md`):
//!
//! ```text
//! M^C_IJ = sum_g rho_hat(x_g) w_g phi_I(x_g) phi_J(x_g)
//! ```
//!
//! Node `I` couples to the nodes `J` with `|J_a - I_a| <= r` on every axis (`r` = the
//! support size per axis minus 1: `p` for B-splines of order `p`, 1 for hats). Each row is
//! accumulated as a dense *stencil* of `(2r + 1)^D` slots, slot
//! `sum_a (J_a - I_a + r) (2r + 1)^a`, over the slab tasks of
//! [`super::tensor_scatter`]: every task fills its own rows `[lo, hi)`, and the rows are
//! reduced in task order into the values of a CSR matrix whose pattern (the in-grid slots,
//! columns ascending) is built once. The result is bitwise identical for any thread
//! count.
//!
//! A cell's block is added in one call ([`StencilRows::add_block`], the block from the
//! moments of the TLS density fit), or point by point ([`StencilRows::add_outer`]) where the
//! support changes inside a cell.

use super::tensor_scatter::{scatter_tasks, ScatterTask};
use crate::grid::{Basis, TensorBasis, TensorShape};
use crate::linalg::CsrMatrix;
use rayon::prelude::*;
use std::ops::Range;

/// The rows `[lo, lo + rows)` of a task's stencil buffer.
pub struct StencilRows<'a, const D: usize> {
    pub(super) lo: usize,
    pub(super) width: usize,
    pub(super) reach: usize,
    pub(super) values: &'a mut [f64],
}

/// Most nodes of one evaluation's support that [`StencilRows::add_outer`] takes.
pub const MAX_SUPPORT_NODES: usize = 512;

impl<const D: usize> StencilRows<'_, D> {
    /// `M_IJ += block[..]` for the nodes of a tensor support with `len[a]` functions from
    /// `first[a]` per axis (at most `reach + 1`); `block` is laid out
    /// `[pair_(D-1)] ... [pair_0]`, `pair_a = i_a len_a + j_a` with `i` the row and `j`
    /// the column: an odometer over `(j_0, i_0, j_1, i_1, ...)`, `j` fastest.
    #[inline]
    pub fn add_block(
        &mut self,
        first: &[usize; D],
        len: &[usize; D],
        strides: &[usize; D],
        block: &[f64],
    ) {
        let side = 2 * self.reach + 1;
        if D == 2 || D == 3 {
            // The same additions, a contiguous run of `len[0]` slots at a time: along the
            // row axis 0, `slot = j_0 + reach - i_0 + ...` grows with `j_0`.
            let reach = self.reach;
            let (l0, l1) = (len[0], len[1]);
            let (l2, first2, stride2) = if D == 3 {
                (len[2], first[2], strides[2])
            } else {
                (1, 0, 0)
            };
            let mut k = 0;
            for i2 in 0..l2 {
                let row2 = (first2 + i2) * stride2;
                for j2 in 0..l2 {
                    let slot2 = if D == 3 {
                        (j2 + reach - i2) * side * side
                    } else {
                        0
                    };
                    for i1 in 0..l1 {
                        let row1 = row2 + (first[1] + i1) * strides[1];
                        for j1 in 0..l1 {
                            let slot1 = slot2 + (j1 + reach - i1) * side;
                            for i0 in 0..l0 {
                                let row = row1 + (first[0] + i0) * strides[0];
                                let at = (row - self.lo) * self.width + slot1 + reach - i0;
                                for (target, &value) in
                                    self.values[at..at + l0].iter_mut().zip(&block[k..k + l0])
                                {
                                    *target += value;
                                }
                                k += l0;
                            }
                        }
                    }
                }
            }
            return;
        }
        let mut slot_scale = [1usize; D];
        for a in 1..D {
            slot_scale[a] = slot_scale[a - 1] * side;
        }
        let (mut i, mut j) = ([0usize; D], [0usize; D]);
        for &value in block {
            let mut row = 0;
            let mut slot = 0;
            for a in 0..D {
                row += (first[a] + i[a]) * strides[a];
                slot += (j[a] + self.reach - i[a]) * slot_scale[a];
            }
            self.values[(row - self.lo) * self.width + slot] += value;
            for a in 0..D {
                j[a] += 1;
                if j[a] < len[a] {
                    break;
                }
                j[a] = 0;
                i[a] += 1;
                if i[a] < len[a] {
                    break;
                }
                i[a] = 0;
            }
        }
    }

    /// `M_IJ += weight phi_I phi_J` for every pair of nodes of `shape` (whose support
    /// fits the stencil: at most `reach + 1` functions per axis).
    #[inline]
    pub fn add_outer(&mut self, shape: &TensorShape<D>, strides: &[usize; D], weight: f64) {
        let side = 2 * self.reach + 1;
        let lens: [usize; D] = std::array::from_fn(|a| shape.axes[a].len);
        // The support in lexicographic order (x fastest): node, phi; the per-axis local
        // indices are the base-`lens` digits of the position in that order.
        let mut nodes = [(0usize, 0.0f64); MAX_SUPPORT_NODES];
        let mut count = 0;
        shape.for_each_node(strides, |node, phi, _| {
            if count < MAX_SUPPORT_NODES {
                nodes[count] = (node, phi);
            }
            count += 1;
        });
        let count = count.min(MAX_SUPPORT_NODES);
        let digits = |mut k: usize| -> [usize; D] {
            std::array::from_fn(|a| {
                let d = k % lens[a];
                k /= lens[a];
                d
            })
        };
        for (i, &(row, phi_i)) in nodes[..count].iter().enumerate() {
            let li = digits(i);
            let base = (row - self.lo) * self.width;
            let wi = weight * phi_i;
            for (j, &(_, phi_j)) in nodes[..count].iter().enumerate() {
                let lj = digits(j);
                let mut slot = 0;
                let mut scale = 1;
                for a in 0..D {
                    slot += (lj[a] + self.reach - li[a]) * scale;
                    scale *= side;
                }
                self.values[base + slot] += wi * phi_j;
            }
        }
    }
}

/// The CSR pattern, slot map and task buffers of one basis.
#[derive(Clone, Debug)]
pub struct StencilAssembly<const D: usize> {
    tasks: Vec<ScatterTask>,
    /// Task buffer offsets (in rows).
    offsets: Vec<usize>,
    buffer: Vec<f64>,
    reach: usize,
    width: usize,
    /// Stencil slot of every CSR entry.
    slots: Vec<usize>,
    pub matrix: CsrMatrix,
}

impl<const D: usize> StencilAssembly<D> {
    /// The assembly for `basis`, whose evaluations have at most `reach + 1` functions per
    /// axis.
    pub fn new<B: Basis>(basis: &TensorBasis<D, B>, reach: usize) -> Self {
        let tasks = scatter_tasks(basis, 0);
        let side = 2 * reach + 1;
        let width = side.pow(D as u32);
        let mut offsets = Vec::with_capacity(tasks.len());
        let mut rows = 0;
        for t in &tasks {
            offsets.push(rows);
            rows += t.nodes.len();
        }
        let dofs = basis.dofs();
        let strides = *basis.strides();
        let n = basis.num_dofs();
        let mut row_ptr = Vec::with_capacity(n + 1);
        let mut col_idx = Vec::new();
        let mut slots = Vec::new();
        row_ptr.push(0);
        for row in 0..n {
            let index: [usize; D] = std::array::from_fn(|a| (row / strides[a]) % dofs[a]);
            // Slots in increasing slot order = increasing column (last axis slowest).
            for slot in 0..width {
                let mut rest = slot;
                let mut col = 0;
                let mut inside = true;
                for a in 0..D {
                    let offset = (rest % side) as isize - reach as isize;
                    rest /= side;
                    let j = index[a] as isize + offset;
                    inside &= j >= 0 && (j as usize) < dofs[a];
                    col += j.max(0) as usize * strides[a];
                }
                if inside {
                    col_idx.push(col);
                    slots.push(slot);
                }
            }
            row_ptr.push(col_idx.len());
        }
        let values = vec![0.0; col_idx.len()];
        Self {
            tasks,
            offsets,
            buffer: vec![0.0; rows * width],
            reach,
            width,
            slots,
            matrix: CsrMatrix {
                rows: n,
                cols: n,
                row_start: row_ptr,
                col_index: col_idx,
                values,
            },
        }
    }

    /// Assemble: `kernel(cells, rows)` adds the contributions of the task's cells through
    /// [`StencilRows::add_outer`]; the rows are then reduced into `self.matrix`.
    pub fn assemble<K>(&mut self, kernel: K)
    where
        K: Fn(Range<usize>, &mut StencilRows<'_, D>) + Sync,
    {
        let width = self.width;
        let reach = self.reach;
        let mut chunks: Vec<&mut [f64]> = Vec::with_capacity(self.tasks.len());
        let mut rest = self.buffer.as_mut_slice();
        for task in &self.tasks {
            let (chunk, tail) = rest.split_at_mut(task.nodes.len() * width);
            chunks.push(chunk);
            rest = tail;
        }
        let tasks = &self.tasks;
        chunks.into_par_iter().enumerate().for_each(|(k, values)| {
            values.fill(0.0);
            let task = &tasks[k];
            let mut rows = StencilRows {
                lo: task.nodes.start,
                width,
                reach,
                values,
            };
            kernel(task.cells.clone(), &mut rows);
        });
        // Rows in parallel; each row sums the tasks that cover it in task order.
        let (buffer, offsets, slots) = (&self.buffer, &self.offsets, &self.slots);
        let row_ptr = &self.matrix.row_start;
        let mut per_row: Vec<&mut [f64]> = Vec::with_capacity(self.matrix.rows);
        let mut rest = self.matrix.values.as_mut_slice();
        for row in 0..self.matrix.rows {
            let (head, tail) = rest.split_at_mut(row_ptr[row + 1] - row_ptr[row]);
            per_row.push(head);
            rest = tail;
        }
        per_row
            .into_par_iter()
            .with_min_len(1024)
            .enumerate()
            .for_each(|(row, values)| {
                values.fill(0.0);
                let entries = &slots[row_ptr[row]..row_ptr[row + 1]];
                // The tasks covering `row` are consecutive (node ranges ascend).
                let first = tasks.partition_point(|t| t.nodes.end <= row);
                for (k, task) in tasks.iter().enumerate().skip(first) {
                    if task.nodes.start > row {
                        break;
                    }
                    let base = (offsets[k] + row - task.nodes.start) * width;
                    if values.len() == width {
                        // A row away from the boundary holds every slot, in slot order.
                        for (v, &b) in values.iter_mut().zip(&buffer[base..base + width]) {
                            *v += b;
                        }
                    } else {
                        for (v, &slot) in values.iter_mut().zip(entries) {
                            *v += buffer[base + slot];
                        }
                    }
                }
            });
    }
}
