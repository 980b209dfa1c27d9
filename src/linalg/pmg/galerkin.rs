//! Galerkin coarse operators of the p-multigrid hierarchy (`docs/tls.md`, "Solvers"):
//!
//! ```text
//! A_{l+1} = I_l^T A_l I_l + 1e-8 diag(I_l^T A_l I_l)            GalerkinStencil::Exact
//! A_{l+1} = S(I_l^T A_l I_l) + 1e-8 diag(S(I_l^T A_l I_l))      GalerkinStencil::Native
//! S(B)_ij = B_ij (i, j in the stencil of the order-(p-l-1) mass matrix),
//! S(B)_ii = B_ii + sum_{j outside} |B_ij|
//! ```
//!
//! recomputed from the fine matrix of every solve with the transfers masked where the fine
//! matrix has decoupled (eliminated) rows (see `hierarchy.rs` for the masking rules and the
//! shift).
//!
//! The exact product widens the stencil on every level: the lumped L2 prolongation from
//! order `q - 1` to order `q` couples a function with its neighbours up to `q - 1` spans away,
//! so `I^T A I` reaches `p + 2(q - 1)` functions per side where the re-discretised
//! order-`q - 1` mass reaches `q - 1`. In 1D that is a banded matrix the coarse Cholesky
//! factors cheaply; in 2D at `p = 3` the order-1 level stores 23^2 = 529 entries per row
//! where its own mass matrix has 9, and the coarse CG that runs on it in every V-cycle
//! costs more than all the smoothing above it (it was 98% of a 100^2 TLS step). `Native`
//! keeps only the entries in the pattern of the level's own mass matrix and adds the
//! magnitudes of the dropped ones to the diagonal. For `B` symmetric positive
//! (semi)definite, `S(B) - B = diag(|E| 1) - E` (`E` the dropped part) is positive
//! semidefinite (`x^T (diag(|E| 1) - E) x >= sum_ij |E_ij| (x_i^2 + x_j^2) / 2 - |E_ij| |x_i|
//! |x_j| >= 0`), so the coarse operator stays SPD and only over-estimates the energy of
//! the corrections that the dropped couplings carried; for a positive density every entry
//! is non-negative and `S` keeps the row sums (the coarse lumped masses).

use super::hierarchy::failure;
use crate::error::Result;
use crate::linalg::CsrMatrix;

/// Sparsity of the Galerkin coarse operators.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GalerkinStencil {
    /// The full product `I^T A I` (its pattern widens on every level).
    Exact,
    /// The product restricted to the pattern of each level's own mass matrix, dropped
    /// entries added to the diagonal by magnitude (module doc).
    Native,
}

/// Relative diagonal shift of the Galerkin coarse operators (see `hierarchy.rs`).
pub(crate) const GALERKIN_SHIFT: f64 = 1e-8;

/// Symbolic data of the Galerkin products, built for one fine pattern, and their scratch.
#[derive(Clone, Debug, Default)]
pub(super) struct GalerkinProducts {
    /// The unmasked prolongations.
    prolongations: Vec<CsrMatrix>,
    /// `parents[l]`: rows = level `l + 1` DOFs, columns = their parents on level `l`.
    parents: Vec<Option<CsrMatrix>>,
    /// `stencils[l]`: the pattern of `A_{l+1}` ([`GalerkinStencil::Native`]; values unused),
    /// `None` for the exact product.
    stencils: Vec<Option<CsrMatrix>>,
    /// Position in `R_l.values` of every entry of `I_l.values`.
    transpose_position: Vec<Vec<usize>>,
    /// `A_l I_l`.
    products: Vec<CsrMatrix>,
    /// Pattern of the fine matrix the products were built for.
    fine_row_start: Vec<usize>,
    fine_col_index: Vec<usize>,
    built: bool,
    accumulator: Vec<f64>,
    /// Columns of the current row reached by the product (native stencils only).
    reached: Vec<bool>,
    reached_columns: Vec<usize>,
    fine_decoupled: Vec<bool>,
    coarse_eliminated: Vec<bool>,
}

impl GalerkinProducts {
    /// Products for the unmasked `prolongations`, with the restrictions' positions
    /// `transpose_position` (from [`transpose_with_positions`]), the `parents` of every
    /// level and the native `stencils` (one per coarse level, or none for exact products).
    pub(super) fn new(
        prolongations: Vec<CsrMatrix>,
        parents: Vec<Option<CsrMatrix>>,
        stencils: Option<Vec<CsrMatrix>>,
        transpose_position: Vec<Vec<usize>>,
    ) -> Result<Self> {
        let stencils = match stencils {
            None => vec![None; prolongations.len()],
            Some(s) => {
                for (l, (stencil, i)) in s.iter().zip(&prolongations).enumerate() {
                    let has_diagonal = (0..stencil.rows).all(|j| {
                        stencil.col_index[stencil.row_start[j]..stencil.row_start[j + 1]]
                            .contains(&j)
                    });
                    if (stencil.rows, stencil.cols) != (i.cols, i.cols) || !has_diagonal {
                        return Err(failure(format!(
                            "level {}: the native stencil is {}x{} {} for {} DOFs",
                            l + 1,
                            stencil.rows,
                            stencil.cols,
                            if has_diagonal {
                                "with every diagonal"
                            } else {
                                "missing a diagonal"
                            },
                            i.cols
                        )));
                    }
                }
                if s.len() != prolongations.len() {
                    return Err(failure(format!(
                        "{} native stencils for {} coarse levels",
                        s.len(),
                        prolongations.len()
                    )));
                }
                s.into_iter().map(Some).collect()
            }
        };
        Ok(Self {
            prolongations,
            parents,
            stencils,
            transpose_position,
            ..Self::default()
        })
    }

    /// Mask the transfers for the decoupled rows of `a` and recompute `coarse` (`A_1,
    /// ...`) from it; rebuilds the symbolic products when the pattern of `a` changed.
    pub(super) fn update(
        &mut self,
        a: &CsrMatrix,
        coarse: &mut [CsrMatrix],
        prolongations: &mut [CsrMatrix],
        restrictions: &mut [CsrMatrix],
    ) -> Result<()> {
        if !self.built || self.fine_row_start != a.row_start || self.fine_col_index != a.col_index {
            self.build(a, coarse, restrictions);
        }
        for l in 0..prolongations.len() {
            let (done, rest) = coarse.split_at_mut(l);
            let fine = if l == 0 { a } else { &done[l - 1] };
            let coarse = &mut rest[0];
            let prolongation = &mut prolongations[l];
            let unmasked = &self.prolongations[l];
            self.fine_decoupled.clear();
            self.fine_decoupled
                .extend((0..fine.rows).map(|i| fine.row_is_decoupled(i)));
            // Coarse DOFs reached by no kept fine DOF, or with an eliminated parent.
            self.coarse_eliminated.clear();
            self.coarse_eliminated.resize(coarse.rows, true);
            for i in (0..fine.rows).filter(|&i| !self.fine_decoupled[i]) {
                for k in unmasked.row_start[i]..unmasked.row_start[i + 1] {
                    if unmasked.values[k] != 0.0 {
                        self.coarse_eliminated[unmasked.col_index[k]] = false;
                    }
                }
            }
            if let Some(parents) = &self.parents[l] {
                for j in 0..parents.rows {
                    let range = parents.row_start[j]..parents.row_start[j + 1];
                    if parents.col_index[range]
                        .iter()
                        .any(|&i| self.fine_decoupled[i])
                    {
                        self.coarse_eliminated[j] = true;
                    }
                }
            }
            for i in 0..fine.rows {
                for k in prolongation.row_start[i]..prolongation.row_start[i + 1] {
                    let keep =
                        !self.fine_decoupled[i] && !self.coarse_eliminated[unmasked.col_index[k]];
                    prolongation.values[k] = if keep { unmasked.values[k] } else { 0.0 };
                }
            }
            let restriction = &mut restrictions[l];
            for (&position, &v) in self.transpose_position[l].iter().zip(&prolongation.values) {
                restriction.values[position] = v;
            }
            multiply_into(
                fine,
                prolongation,
                &mut self.products[l],
                &mut self.accumulator,
            );
            if self.stencils[l].is_some() {
                multiply_into_lumped(
                    restriction,
                    &self.products[l],
                    coarse,
                    &mut self.accumulator,
                    &mut self.reached,
                    &mut self.reached_columns,
                );
            } else {
                multiply_into(
                    restriction,
                    &self.products[l],
                    coarse,
                    &mut self.accumulator,
                );
            }
            for j in 0..coarse.rows {
                for k in coarse.row_start[j]..coarse.row_start[j + 1] {
                    if coarse.col_index[k] == j {
                        coarse.values[k] *= 1.0 + GALERKIN_SHIFT;
                    }
                }
            }
            for (j, _) in self
                .coarse_eliminated
                .iter()
                .enumerate()
                .filter(|(_, &e)| e)
            {
                // Row and column j of I^T A I vanish: make it an identity row (the
                // eliminated coarse DOF has no kept fine DOF, so nothing was lumped here).
                let range = coarse.row_start[j]..coarse.row_start[j + 1];
                let diagonal = coarse.col_index[range.clone()]
                    .iter()
                    .position(|&c| c == j)
                    .ok_or_else(|| {
                        failure(format!(
                            "level {} DOF {j} is eliminated and its Galerkin row stores no \
                             diagonal",
                            l + 1
                        ))
                    })?;
                coarse.values[range.start + diagonal] = 1.0;
            }
        }
        Ok(())
    }

    /// Patterns of `A_l I_l` and of `A_{l+1}` (`I_l^T A_l I_l`, or the native stencil) for
    /// the pattern of `a` (values are overwritten by the numeric pass).
    fn build(&mut self, a: &CsrMatrix, coarse: &mut [CsrMatrix], restrictions: &[CsrMatrix]) {
        self.products.clear();
        for l in 0..self.prolongations.len() {
            let fine = if l == 0 { a } else { &coarse[l - 1] };
            let product = fine.matmul(&self.prolongations[l]);
            coarse[l] = match &self.stencils[l] {
                Some(stencil) => stencil.clone(),
                None => restrictions[l].matmul(&product),
            };
            self.products.push(product);
        }
        self.fine_row_start.clone_from(&a.row_start);
        self.fine_col_index.clone_from(&a.col_index);
        self.built = true;
    }
}

/// `out = a b` into the fixed pattern of `out` (built by [`CsrMatrix::matmul`] from the
/// same patterns); `accumulator` is scratch of `out.cols` entries, left zero.
fn multiply_into(a: &CsrMatrix, b: &CsrMatrix, out: &mut CsrMatrix, accumulator: &mut Vec<f64>) {
    accumulator.resize(out.cols, 0.0);
    for i in 0..a.rows {
        for k in a.row_start[i]..a.row_start[i + 1] {
            let (l, v) = (a.col_index[k], a.values[k]);
            for m in b.row_start[l]..b.row_start[l + 1] {
                accumulator[b.col_index[m]] += v * b.values[m];
            }
        }
        for k in out.row_start[i]..out.row_start[i + 1] {
            let j = out.col_index[k];
            out.values[k] = accumulator[j];
            accumulator[j] = 0.0;
        }
    }
}

/// `out = S(a b)` into the pattern of `out`, which need not hold all of `a b` but stores
/// every diagonal: the entries of `a b` outside it are added to the diagonal by magnitude
/// (module doc). Scratch: `accumulator` and `reached` of `out.cols` entries (left zero and
/// false) and the column list `reached_columns`. Deterministic: every row is summed in the
/// order of the loops.
fn multiply_into_lumped(
    a: &CsrMatrix,
    b: &CsrMatrix,
    out: &mut CsrMatrix,
    accumulator: &mut Vec<f64>,
    reached: &mut Vec<bool>,
    reached_columns: &mut Vec<usize>,
) {
    accumulator.resize(out.cols, 0.0);
    reached.resize(out.cols, false);
    for i in 0..a.rows {
        reached_columns.clear();
        for k in a.row_start[i]..a.row_start[i + 1] {
            let (l, v) = (a.col_index[k], a.values[k]);
            for m in b.row_start[l]..b.row_start[l + 1] {
                let j = b.col_index[m];
                if !reached[j] {
                    reached[j] = true;
                    reached_columns.push(j);
                }
                accumulator[j] += v * b.values[m];
            }
        }
        let mut diagonal = None;
        for k in out.row_start[i]..out.row_start[i + 1] {
            let j = out.col_index[k];
            out.values[k] = accumulator[j];
            accumulator[j] = 0.0;
            reached[j] = false;
            if j == i {
                diagonal = Some(k);
            }
        }
        let mut dropped = 0.0;
        for &j in reached_columns.iter() {
            if reached[j] {
                dropped += accumulator[j].abs();
                accumulator[j] = 0.0;
                reached[j] = false;
            }
        }
        if let Some(k) = diagonal {
            out.values[k] += dropped;
        }
    }
}

/// `m^T` and, for every entry `k` of `m`, its position in the transpose's values.
pub(super) fn transpose_with_positions(m: &CsrMatrix) -> (CsrMatrix, Vec<usize>) {
    let mut row_start = vec![0usize; m.cols + 1];
    for &j in &m.col_index {
        row_start[j + 1] += 1;
    }
    for j in 0..m.cols {
        row_start[j + 1] += row_start[j];
    }
    let mut next = row_start.clone();
    let mut col_index = vec![0; m.nnz()];
    let mut values = vec![0.0; m.nnz()];
    let mut position = Vec::with_capacity(m.nnz());
    for i in 0..m.rows {
        for k in m.row_start[i]..m.row_start[i + 1] {
            let j = m.col_index[k];
            let at = next[j];
            col_index[at] = i;
            values[at] = m.values[k];
            position.push(at);
            next[j] += 1;
        }
    }
    let transpose = CsrMatrix {
        rows: m.cols,
        cols: m.rows,
        row_start,
        col_index,
        values,
    };
    (transpose, position)
}
