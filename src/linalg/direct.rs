//! Direct sparse Cholesky (SPEC §5, "Direct: sparse Cholesky (faer)"): `A = P^T L L^T P`
//! for a symmetric positive definite [`CsrMatrix`], with `P` the approximate minimum degree
//! fill-reducing ordering, then `x = A^{-1} b` by two triangular solves. Exact up to round
//! off, for any sparsity pattern: the reference every iterative solver of the 2D (or
//! unstructured) mass systems is checked against. In 1D the banded Cholesky
//! ([`super::BandedCholesky`]) is cheaper.
//!
//! DESIGN note: faer 0.24 sparse Cholesky: `SymbolicLlt` once per pattern, numeric `Llt`
//! per step. This module calls the layer under those two wrappers
//! (`faer::sparse::linalg::cholesky::{factorize_symbolic_cholesky, SymbolicCholesky,
//! LltRef}`) so that the parallelism is passed explicitly ([`faer::Par`], never faer's
//! global setting) and the factor values and workspace are allocated once per pattern
//! instead of once per step:
//!
//! * **symbolic analysis** (ordering, elimination tree, supernodes): computed when the
//!   pattern (`rows`, `row_start`, `col_index`) differs from the one analysed last, and
//!   reused otherwise ([`DirectCholesky::symbolic_analyses`] counts them);
//! * **numeric factorisation**: every [`LinearSolver::solve`] / [`DirectCholesky::factor`]
//!   call, into the same buffers;
//! * **solves**: [`DirectCholesky::solve_factored`] reuses one factorisation for any
//!   number of right-hand sides (condition-number estimation, inverse iteration).
//!
//! Conversion at the boundary: a symmetric CSR matrix is its own CSC transpose, so the
//! entries `col <= row` of the CSR rows are, read as CSC columns, the upper triangle that
//! faer factors (`Side::Upper`). Only that half is read; the other one is assumed to mirror
//! it (the returned residual is computed with the whole matrix, so a non-symmetric input
//! shows up there). Columns must be sorted and unique within each row, as
//! [`CsrMatrix::from_triplets`] and [`CsrMatrix::band`] build them, and every row must
//! store its diagonal.
//!
//! Failures are errors, never panics: a non-square matrix, mismatched vector lengths, an
//! invalid pattern, a non-finite entry, or a matrix that is not (numerically) positive
//! definite — the last one names the row whose pivot failed. Results are deterministic for
//! a given `Par` (fixed ordering, fixed supernode schedule).

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::{LltError, LltRegularization};
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, LltRef, SymbolicCholesky, SymmetricOrdering,
};
use faer::sparse::{FaerError, SparseColMatRef, SymbolicSparseColMat};
use faer::{Conj, MatMut, Par, Side};

use super::{CsrMatrix, LinearSolver, SolveStats};
use crate::error::{Error, Result};

/// Sparse Cholesky solver for symmetric positive definite matrices (faer backend).
pub struct DirectCholesky {
    par: Par,
    /// The CSR pattern the current symbolic analysis belongs to.
    pattern_rows: usize,
    pattern_row_start: Vec<usize>,
    pattern_col_index: Vec<usize>,
    /// Upper triangle of `A` in CSC (= the entries `col <= row` of the CSR rows).
    upper: Option<SymbolicSparseColMat<usize>>,
    /// Position in the CSR `values` of each entry of `upper`.
    upper_source: Vec<usize>,
    upper_values: Vec<f64>,
    symbolic: Option<SymbolicCholesky<usize>>,
    /// Values of the factor `L` (layout given by `symbolic`).
    l_values: Vec<f64>,
    /// Workspace of the numeric factorisation and of one-column solves.
    workspace: MemBuffer,
    /// `true` once `l_values` holds the factor of the last matrix passed to `factor`.
    factored: bool,
    symbolic_analyses: usize,
    /// `A x` for the residual of the last solve.
    product: Vec<f64>,
}

impl Default for DirectCholesky {
    fn default() -> Self {
        Self::new()
    }
}

impl std::fmt::Debug for DirectCholesky {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DirectCholesky")
            .field("par", &self.par)
            .field("rows", &self.pattern_rows)
            .field("nnz", &self.pattern_col_index.len())
            .field("factor_len", &self.l_values.len())
            .field("factored", &self.factored)
            .field("symbolic_analyses", &self.symbolic_analyses)
            .finish_non_exhaustive()
    }
}

impl DirectCholesky {
    /// A sequential solver (`Par::Seq`).
    pub fn new() -> Self {
        Self::with_par(Par::Seq)
    }

    /// A solver running faer's numeric factorisation and solves with `par`
    /// (`Par::Seq` or `Par::rayon(n)`).
    pub fn with_par(par: Par) -> Self {
        Self {
            par,
            pattern_rows: 0,
            pattern_row_start: Vec::new(),
            pattern_col_index: Vec::new(),
            upper: None,
            upper_source: Vec::new(),
            upper_values: Vec::new(),
            symbolic: None,
            l_values: Vec::new(),
            workspace: MemBuffer::new(StackReq::empty()),
            factored: false,
            symbolic_analyses: 0,
            product: Vec::new(),
        }
    }

    /// The parallelism passed to faer.
    pub fn par(&self) -> Par {
        self.par
    }

    /// How many symbolic analyses were computed (one per distinct consecutive pattern).
    pub fn symbolic_analyses(&self) -> usize {
        self.symbolic_analyses
    }

    /// Number of stored entries of the factor `L` (0 before the first analysis).
    pub fn factor_nnz(&self) -> usize {
        self.l_values.len()
    }

    /// Factor `a` (symbolic analysis only if its pattern changed), keeping the factor for
    /// [`DirectCholesky::solve_factored`].
    pub fn factor(&mut self, a: &CsrMatrix) -> Result<()> {
        self.factored = false;
        if a.rows != a.cols {
            return Err(failure(format!(
                "matrix is {}x{}, not square",
                a.rows, a.cols
            )));
        }
        if a.values.len() != a.col_index.len() {
            return Err(failure(format!(
                "invalid CSR matrix: {} values for {} column indices",
                a.values.len(),
                a.col_index.len()
            )));
        }
        if let Some(k) = a.values.iter().position(|v| !v.is_finite()) {
            let row = a.row_start.partition_point(|&s| s <= k).saturating_sub(1);
            let col = a.col_index.get(k).copied().unwrap_or(0);
            return Err(failure(format!(
                "non-finite entry {} at ({row}, {col})",
                a.values[k]
            )));
        }
        let same_pattern = self.symbolic.is_some()
            && self.pattern_rows == a.rows
            && self.pattern_row_start == a.row_start
            && self.pattern_col_index == a.col_index;
        if !same_pattern {
            self.analyse(a)?;
        }
        let (Some(upper), Some(symbolic)) = (&self.upper, &self.symbolic) else {
            return Err(failure("no symbolic analysis".into()));
        };
        for (v, &k) in self.upper_values.iter_mut().zip(&self.upper_source) {
            *v = a.values[k];
        }
        if a.rows == 0 {
            self.factored = true;
            return Ok(());
        }
        let matrix = SparseColMatRef::new(upper.as_ref(), &self.upper_values);
        let result = symbolic.factorize_numeric_llt(
            &mut self.l_values,
            matrix,
            Side::Upper,
            LltRegularization::default(),
            self.par,
            MemStack::new(&mut self.workspace),
            Default::default(),
        );
        match result {
            Ok(_) => {
                self.factored = true;
                Ok(())
            }
            Err(LltError::NonPositivePivot { index }) => {
                // `index` counts elimination steps of the permuted matrix.
                let row = symbolic
                    .perm()
                    .and_then(|p| p.arrays().0.get(index).copied())
                    .unwrap_or(index);
                Err(failure(format!(
                    "non-positive pivot at row {row} (elimination step {index} of {}): \
                     the matrix is not positive definite",
                    a.rows
                )))
            }
        }
    }

    /// Solve `A x = b` with the factor of the last successful [`DirectCholesky::factor`].
    pub fn solve_factored(&mut self, b: &[f64], x: &mut [f64]) -> Result<()> {
        let Some(symbolic) = self.symbolic.as_ref().filter(|_| self.factored) else {
            return Err(failure(
                "no factorisation to solve with: call `factor` first (or it failed)".into(),
            ));
        };
        let n = self.pattern_rows;
        if b.len() != n || x.len() != n {
            return Err(failure(format!(
                "dimension mismatch: factor {n}x{n}, rhs {}, x {}",
                b.len(),
                x.len()
            )));
        }
        x.copy_from_slice(b);
        if n == 0 {
            return Ok(());
        }
        LltRef::new(symbolic, &self.l_values).solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(x, n, 1),
            self.par,
            MemStack::new(&mut self.workspace),
        );
        Ok(())
    }

    /// Symbolic analysis of the pattern of `a` (square, `values` checked by the caller).
    fn analyse(&mut self, a: &CsrMatrix) -> Result<()> {
        self.symbolic = None;
        self.upper = None;
        self.pattern_rows = 0;
        self.pattern_row_start.clear();
        self.pattern_col_index.clear();
        let n = a.rows;
        check_pattern(a)?;

        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::new();
        self.upper_source.clear();
        col_ptr.push(0);
        for i in 0..n {
            let range = a.row_start[i]..a.row_start[i + 1];
            for (k, &j) in range.clone().zip(&a.col_index[range]) {
                if j > i {
                    break;
                }
                row_idx.push(j);
                self.upper_source.push(k);
            }
            if row_idx.last() != Some(&i) {
                return Err(failure(format!(
                    "row {i} stores no diagonal entry: the matrix cannot be positive definite"
                )));
            }
            col_ptr.push(row_idx.len());
        }
        // Sorted, unique, in range: the invariants `new_checked` asserts hold.
        let upper = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
        self.upper_values.clear();
        self.upper_values.resize(self.upper_source.len(), 0.0);

        let symbolic = factorize_symbolic_cholesky(
            upper.as_ref(),
            Side::Upper,
            SymmetricOrdering::Amd,
            Default::default(),
        )
        .map_err(|e| faer_failure("symbolic analysis", e))?;
        let workspace = StackReq::any_of(&[
            symbolic.factorize_numeric_llt_scratch::<f64>(self.par, Default::default()),
            symbolic.solve_in_place_scratch::<f64>(1, self.par),
        ]);
        self.workspace = MemBuffer::try_new(workspace)
            .map_err(|_| faer_failure("workspace allocation", FaerError::OutOfMemory))?;
        self.l_values.clear();
        self.l_values.resize(symbolic.len_val(), 0.0);

        self.upper = Some(upper);
        self.symbolic = Some(symbolic);
        self.pattern_rows = n;
        self.pattern_row_start.extend_from_slice(&a.row_start);
        self.pattern_col_index.extend_from_slice(&a.col_index);
        self.symbolic_analyses += 1;
        Ok(())
    }
}

/// Check the CSR invariants the conversion relies on: `row_start` monotone from 0 to
/// `nnz`, columns in range, strictly increasing within each row.
fn check_pattern(a: &CsrMatrix) -> Result<()> {
    let nnz = a.col_index.len();
    if a.row_start.len() != a.rows + 1
        || a.row_start.first() != Some(&0)
        || a.row_start.last() != Some(&nnz)
        || a.row_start.windows(2).any(|w| w[0] > w[1])
    {
        return Err(failure(format!(
            "invalid CSR matrix: row_start must rise from 0 to nnz = {nnz} in {} entries",
            a.rows + 1
        )));
    }
    for i in 0..a.rows {
        let cols = &a.col_index[a.row_start[i]..a.row_start[i + 1]];
        if cols.windows(2).any(|w| w[0] >= w[1]) || cols.last().is_some_and(|&j| j >= a.cols) {
            return Err(failure(format!(
                "invalid CSR matrix: the columns of row {i} are not sorted, unique and below {}",
                a.cols
            )));
        }
    }
    Ok(())
}

fn failure(reason: String) -> Error {
    Error::Solver {
        solver: "direct".into(),
        reason,
    }
}

fn faer_failure(stage: &str, e: FaerError) -> Error {
    failure(format!("faer {stage} failed: {e:?}"))
}

impl LinearSolver for DirectCholesky {
    fn name(&self) -> &'static str {
        "direct"
    }

    fn solve(&mut self, a: &CsrMatrix, b: &[f64], x: &mut [f64]) -> Result<SolveStats> {
        super::check_dimensions("direct", a, b, x)?;
        self.factor(a)?;
        self.resolve(a, b, x)
    }

    fn resolve(&mut self, a: &CsrMatrix, b: &[f64], x: &mut [f64]) -> Result<SolveStats> {
        super::check_dimensions("direct", a, b, x)?;
        if !self.factored || self.pattern_rows != a.rows {
            return self.solve(a, b, x);
        }
        self.solve_factored(b, x)?;
        let relative_residual = super::relative_residual(a, x, b, &mut self.product);
        if !relative_residual.is_finite() {
            return Err(failure(format!(
                "non-finite residual {relative_residual}: the factor over- or underflowed"
            )));
        }
        Ok(SolveStats {
            iterations: 0,
            relative_residual,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::sparse::linalg::cholesky::SymbolicCholeskyRaw;

    /// The 2D 5-point Laplacian on an `m x m` grid (Dirichlet boundary outside), scaled by
    /// `scale` and shifted by `shift` on the diagonal.
    fn laplacian(m: usize, scale: f64, shift: f64) -> CsrMatrix {
        let id = |i: usize, j: usize| i * m + j;
        let mut t = Vec::new();
        for i in 0..m {
            for j in 0..m {
                let p = id(i, j);
                t.push((p, p, scale * 4.0 + shift));
                if i > 0 {
                    t.push((p, id(i - 1, j), -scale));
                }
                if i + 1 < m {
                    t.push((p, id(i + 1, j), -scale));
                }
                if j > 0 {
                    t.push((p, id(i, j - 1), -scale));
                }
                if j + 1 < m {
                    t.push((p, id(i, j + 1), -scale));
                }
            }
        }
        CsrMatrix::from_triplets(m * m, m * m, &t)
    }

    /// An SPD (strictly diagonally dominant) matrix with the `(2 r + 1)^2`-point stencil of
    /// a tensor-product B-spline mass matrix of order `r` on an `m x m` grid.
    fn wide_stencil(m: usize, r: usize) -> CsrMatrix {
        let mut t = Vec::new();
        for i in 0..m {
            for j in 0..m {
                for k in i.saturating_sub(r)..(i + r + 1).min(m) {
                    for l in j.saturating_sub(r)..(j + r + 1).min(m) {
                        let v = if (k, l) == (i, j) {
                            1.0 + (2 * r + 1).pow(2) as f64
                        } else {
                            -1.0
                        };
                        t.push((i * m + j, k * m + l, v));
                    }
                }
            }
        }
        CsrMatrix::from_triplets(m * m, m * m, &t)
    }

    fn known_solution(n: usize) -> Vec<f64> {
        (0..n).map(|i| 1.0 + (0.37 * i as f64).sin()).collect()
    }

    fn rhs(a: &CsrMatrix, x: &[f64]) -> Vec<f64> {
        let mut b = vec![0.0; a.rows];
        a.mul_vec(x, &mut b);
        b
    }

    fn max_error(x: &[f64], exact: &[f64]) -> f64 {
        x.iter()
            .zip(exact)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max)
    }

    fn reason(e: Error) -> String {
        match e {
            Error::Solver { solver, reason } => {
                assert_eq!(solver, "direct");
                reason
            }
            other => panic!("unexpected error {other}"),
        }
    }

    #[test]
    fn solves_the_2d_laplacian_to_round_off() {
        let a = laplacian(20, 1.0, 0.0);
        let exact = known_solution(a.rows);
        let b = rhs(&a, &exact);
        let mut solver = DirectCholesky::new();
        assert_eq!(solver.name(), "direct");
        let mut x = vec![0.0; a.rows];
        let stats = solver.solve(&a, &b, &mut x).unwrap();
        assert_eq!(stats.iterations, 0);
        assert!(stats.relative_residual < 1e-12, "{stats:?}");
        assert!(max_error(&x, &exact) < 1e-11, "{}", max_error(&x, &exact));
        assert_eq!(solver.symbolic_analyses(), 1);
        assert!(solver.factor_nnz() >= a.values.len().div_ceil(2));
    }

    #[test]
    fn zero_rhs_gives_zero_solution_and_residual() {
        let a = laplacian(5, 1.0, 0.0);
        let mut x = vec![1.0; a.rows];
        let stats = DirectCholesky::new()
            .solve(&a, &vec![0.0; a.rows], &mut x)
            .unwrap();
        assert_eq!(stats.relative_residual, 0.0);
        assert!(x.iter().all(|&v| v == 0.0));
    }

    #[test]
    fn symbolic_analysis_is_reused_while_the_pattern_is_unchanged() {
        let mut solver = DirectCholesky::new();
        let a1 = laplacian(12, 1.0, 0.0);
        let exact = known_solution(a1.rows);
        let mut x = vec![0.0; a1.rows];
        solver.solve(&a1, &rhs(&a1, &exact), &mut x).unwrap();
        assert_eq!(solver.symbolic_analyses(), 1);

        // Same pattern, new values (a mass-like shifted operator): numeric refactorisation.
        let a2 = laplacian(12, 0.25, 3.0);
        assert_eq!(a2.row_start, a1.row_start);
        assert_eq!(a2.col_index, a1.col_index);
        let stats = solver.solve(&a2, &rhs(&a2, &exact), &mut x).unwrap();
        assert_eq!(solver.symbolic_analyses(), 1);
        assert!(stats.relative_residual < 1e-12, "{stats:?}");
        assert!(max_error(&x, &exact) < 1e-12);

        // A different pattern: a new analysis.
        let a3 = laplacian(9, 1.0, 0.5);
        let exact3 = known_solution(a3.rows);
        let mut x3 = vec![0.0; a3.rows];
        let stats = solver.solve(&a3, &rhs(&a3, &exact3), &mut x3).unwrap();
        assert_eq!(solver.symbolic_analyses(), 2);
        assert!(stats.relative_residual < 1e-12, "{stats:?}");
        assert!(max_error(&x3, &exact3) < 1e-11);

        // Same size, different pattern (an extra coupling): also a new analysis.
        let mut t = Vec::new();
        for i in 0..a3.rows {
            for k in a3.row_start[i]..a3.row_start[i + 1] {
                t.push((i, a3.col_index[k], a3.values[k]));
            }
        }
        t.push((0, a3.rows - 1, 0.1));
        t.push((a3.rows - 1, 0, 0.1));
        let a4 = CsrMatrix::from_triplets(a3.rows, a3.rows, &t);
        let stats = solver.solve(&a4, &rhs(&a4, &exact3), &mut x3).unwrap();
        assert_eq!(solver.symbolic_analyses(), 3);
        assert!(stats.relative_residual < 1e-12, "{stats:?}");
    }

    #[test]
    fn one_factorisation_serves_many_right_hand_sides() {
        let a = laplacian(10, 1.0, 0.1);
        let mut solver = DirectCholesky::new();
        solver.factor(&a).unwrap();
        for shift in 0..4 {
            let exact: Vec<f64> = (0..a.rows).map(|i| (i + shift) as f64 * 0.1).collect();
            let mut x = vec![0.0; a.rows];
            solver.solve_factored(&rhs(&a, &exact), &mut x).unwrap();
            assert!(max_error(&x, &exact) < 1e-12);
        }
        assert_eq!(solver.symbolic_analyses(), 1);
    }

    #[test]
    fn indefinite_matrix_is_an_error_not_a_panic() {
        let mut a = laplacian(6, 1.0, 0.0);
        // Shift the whole spectrum (eigenvalues in (0, 8)) to straddle zero.
        for i in 0..a.rows {
            for k in a.row_start[i]..a.row_start[i + 1] {
                if a.col_index[k] == i {
                    a.values[k] -= 4.0;
                }
            }
        }
        let b = vec![1.0; a.rows];
        let mut x = vec![0.0; a.rows];
        let mut solver = DirectCholesky::new();
        let message = reason(solver.solve(&a, &b, &mut x).unwrap_err());
        assert!(message.contains("not positive definite"), "{message}");
        assert!(message.contains("pivot at row"), "{message}");
        // No factor is left behind to solve with ...
        let message = reason(solver.solve_factored(&b, &mut x).unwrap_err());
        assert!(message.contains("call `factor` first"), "{message}");
        // ... and the solver recovers with the next (SPD) matrix of the same pattern.
        let spd = laplacian(6, 1.0, 0.0);
        let stats = solver.solve(&spd, &b, &mut x).unwrap();
        assert!(stats.relative_residual < 1e-12);
        assert_eq!(solver.symbolic_analyses(), 1);

        let small =
            CsrMatrix::from_triplets(2, 2, &[(0, 0, 1.0), (0, 1, 2.0), (1, 0, 2.0), (1, 1, 1.0)]);
        let message = reason(
            solver
                .solve(&small, &[1.0, 1.0], &mut [0.0, 0.0])
                .unwrap_err(),
        );
        assert!(message.contains("not positive definite"), "{message}");
    }

    #[test]
    fn bad_input_is_an_error_not_a_panic() {
        let a = laplacian(3, 1.0, 0.0);
        let mut solver = DirectCholesky::new();
        let message = reason(solver.solve(&a, &[1.0; 8], &mut [0.0; 9]).unwrap_err());
        assert!(message.contains("dimension mismatch"), "{message}");
        let message = reason(solver.solve(&a, &[1.0; 9], &mut [0.0; 10]).unwrap_err());
        assert!(message.contains("dimension mismatch"), "{message}");

        let rect = CsrMatrix::from_triplets(2, 3, &[(0, 0, 1.0), (1, 1, 1.0)]);
        let message = reason(solver.factor(&rect).unwrap_err());
        assert!(message.contains("not square"), "{message}");

        let no_diagonal = CsrMatrix::from_triplets(2, 2, &[(0, 0, 1.0), (1, 0, 0.5)]);
        let message = reason(solver.factor(&no_diagonal).unwrap_err());
        assert!(message.contains("row 1 stores no diagonal"), "{message}");

        let mut nan = a.clone();
        nan.values[4] = f64::NAN;
        let message = reason(solver.factor(&nan).unwrap_err());
        assert!(
            message.contains("non-finite entry NaN at (1, "),
            "{message}"
        );

        let mut broken = a.clone();
        broken.row_start[2] = 100;
        let message = reason(solver.factor(&broken).unwrap_err());
        assert!(message.contains("invalid CSR"), "{message}");
        let mut unsorted = a.clone();
        unsorted.col_index.swap(0, 1);
        let message = reason(solver.factor(&unsorted).unwrap_err());
        assert!(message.contains("row 0"), "{message}");

        solver.factor(&a).unwrap();
        let message = reason(solver.solve_factored(&[1.0; 9], &mut [0.0; 3]).unwrap_err());
        assert!(message.contains("dimension mismatch"), "{message}");

        let empty = CsrMatrix::from_triplets(0, 0, &[]);
        let stats = solver.solve(&empty, &[], &mut []).unwrap();
        assert_eq!(stats.relative_residual, 0.0);
    }

    #[test]
    fn eliminated_dofs_with_identity_rows_solve() {
        let m = 12;
        let mut a = laplacian(m, 1.0, 0.0);
        // Eliminate the grid boundary (homogeneous Dirichlet DOFs).
        let keep: Vec<bool> = (0..m * m)
            .map(|p| {
                let (i, j) = (p / m, p % m);
                i > 0 && j > 0 && i + 1 < m && j + 1 < m
            })
            .collect();
        a.constrain(&keep);
        let exact: Vec<f64> = known_solution(a.rows)
            .into_iter()
            .zip(&keep)
            .map(|(v, &k)| if k { v } else { 0.0 })
            .collect();
        let b = rhs(&a, &exact);
        let mut x = vec![0.0; a.rows];
        let stats = DirectCholesky::new().solve(&a, &b, &mut x).unwrap();
        assert!(stats.relative_residual < 1e-12, "{stats:?}");
        assert!(max_error(&x, &exact) < 1e-12);
        for (p, &k) in keep.iter().enumerate() {
            if !k {
                assert_eq!(x[p], 0.0);
            }
        }
    }

    #[test]
    fn results_are_deterministic_for_a_given_par() {
        let a = wide_stencil(40, 3);
        let b = rhs(&a, &known_solution(a.rows));
        let run = |par: Par| {
            let mut x = vec![0.0; a.rows];
            let mut solver = DirectCholesky::with_par(par);
            solver.solve(&a, &b, &mut x).unwrap();
            // Large enough for faer's supernodal (blocked, parallel) factorisation.
            let raw = solver.symbolic.as_ref().map(|s| s.raw());
            assert!(matches!(raw, Some(SymbolicCholeskyRaw::Supernodal(_))));
            x
        };
        let seq = run(Par::Seq);
        assert_eq!(seq, run(Par::Seq));
        let par = run(Par::rayon(2));
        assert_eq!(par, run(Par::rayon(2)));
        println!("seq == rayon(2) bitwise: {}", par == seq);
        assert!(max_error(&par, &seq) < 1e-12);
    }

    /// Timing of factor + solve for the 256 x 256 5-point Laplacian:
    /// `cargo test --release --lib linalg::direct -- --ignored --nocapture`.
    #[test]
    #[ignore]
    fn timing_laplacian_256() {
        let a = laplacian(256, 1.0, 0.0);
        let exact = known_solution(a.rows);
        let b = rhs(&a, &exact);
        for par in [Par::Seq, Par::rayon(0)] {
            let mut solver = DirectCholesky::with_par(par);
            let mut x = vec![0.0; a.rows];
            let start = std::time::Instant::now();
            solver.factor(&a).unwrap();
            let raw = solver.symbolic.as_ref().map(|s| s.raw());
            println!(
                "{par:?}: first factor (symbolic + numeric) {:.2} ms, supernodal: {}",
                start.elapsed().as_secs_f64() * 1e3,
                matches!(raw, Some(SymbolicCholeskyRaw::Supernodal(_)))
            );
            for call in 0..3 {
                let start = std::time::Instant::now();
                let stats = solver.solve(&a, &b, &mut x).unwrap();
                let total = start.elapsed();
                let start = std::time::Instant::now();
                solver.solve_factored(&b, &mut x).unwrap();
                let solve = start.elapsed();
                println!(
                    "{par:?} call {call}: solve (numeric factor + solve + residual) {:.2} ms (solve_factored alone {:.2} ms), \
                     n = {}, nnz(A) = {}, nnz(L) = {}, analyses = {}, residual {:.1e}",
                    total.as_secs_f64() * 1e3,
                    solve.as_secs_f64() * 1e3,
                    a.rows,
                    a.values.len(),
                    solver.factor_nnz(),
                    solver.symbolic_analyses(),
                    stats.relative_residual
                );
            }
        }
    }
}
