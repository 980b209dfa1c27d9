//! Banded Cholesky (SPEC §5): the direct solver of 1D mass matrices, `O(N p^2)` to factor
//! and `O(N p)` to solve for bandwidth `p`, the speed limit every iterative solver is
//! compared with.
//!
//! The factor `L` (`A = L L^T`) is stored by rows in a dense band: `band[i][k]` is
//! `L[i][i - p + k]`, `k = 0..=p`. The matrix is read from CSR (any pattern inside the
//! band); entries outside the band are an error, never silently dropped.

use super::{CsrMatrix, LinearSolver, SolveStats};
use crate::error::{Error, Result};

/// Direct solver for symmetric positive definite banded matrices.
#[derive(Clone, Debug, Default)]
pub struct BandedCholesky {
    bandwidth: usize,
    factor: Vec<f64>,
    /// Whether `factor` holds the factor of the last matrix given to [`BandedCholesky::factor`].
    factored: bool,
    /// `A x` for the residual of the last solve.
    product: Vec<f64>,
}

impl BandedCholesky {
    pub fn new() -> Self {
        Self::default()
    }

    /// Factor `a` (lower half read, upper assumed symmetric).
    pub fn factor(&mut self, a: &CsrMatrix) -> Result<()> {
        self.factored = false;
        let n = a.rows;
        if a.cols != n {
            return Err(failure(format!(
                "matrix is {}x{}, not square",
                a.rows, a.cols
            )));
        }
        let mut p = 0;
        for i in 0..n {
            for &j in &a.col_index[a.row_start[i]..a.row_start[i + 1]] {
                p = p.max(i.abs_diff(j));
            }
        }
        let width = p + 1;
        self.bandwidth = p;
        self.factor.clear();
        self.factor.resize(n * width, 0.0);
        let l = &mut self.factor;
        for i in 0..n {
            for k in a.row_start[i]..a.row_start[i + 1] {
                let j = a.col_index[k];
                if j <= i {
                    l[i * width + (j + p - i)] = a.values[k];
                }
            }
        }
        for i in 0..n {
            let first = i.saturating_sub(p);
            for j in first..=i {
                // L[i][j] = (A[i][j] - sum_k L[i][k] L[j][k]) / L[j][j], k in max(first_i, first_j)..j
                let mut s = l[i * width + (j + p - i)];
                let k0 = first.max(j.saturating_sub(p));
                for k in k0..j {
                    s -= l[i * width + (k + p - i)] * l[j * width + (k + p - j)];
                }
                if j == i {
                    if s.is_nan() || s <= 0.0 {
                        return Err(failure(format!(
                            "non-positive pivot {s:e} at row {i}: the matrix is not positive definite"
                        )));
                    }
                    l[i * width + p] = s.sqrt();
                } else {
                    l[i * width + (j + p - i)] = s / l[j * width + p];
                }
            }
        }
        self.factored = true;
        Ok(())
    }

    /// Solve with the current factor: `x = A^{-1} b`.
    pub fn solve_factored(&self, b: &[f64], x: &mut [f64]) {
        let p = self.bandwidth;
        let width = p + 1;
        let n = b.len();
        let l = &self.factor;
        for i in 0..n {
            let mut s = b[i];
            for k in i.saturating_sub(p)..i {
                s -= l[i * width + (k + p - i)] * x[k];
            }
            x[i] = s / l[i * width + p];
        }
        for i in (0..n).rev() {
            let mut s = x[i];
            for k in i + 1..(i + p + 1).min(n) {
                s -= l[k * width + (i + p - k)] * x[k];
            }
            x[i] = s / l[i * width + p];
        }
    }

    /// [`BandedCholesky::solve_factored`] on `LANES` lines of length `n` at once: `b` and
    /// `x` hold `LANES * n` values, line after line. The lines' substitutions run
    /// interleaved, so their dependency chains (a division per unknown) overlap; each
    /// line's operations are those of its own solve in the same order, so each line is
    /// bitwise [`BandedCholesky::solve_factored`]'s.
    pub fn solve_factored_lines<const LANES: usize>(&self, b: &[f64], x: &mut [f64]) {
        let p = self.bandwidth;
        let width = p + 1;
        let n = b.len() / LANES;
        let l = &self.factor;
        for i in 0..n {
            let mut s = [0.0; LANES];
            for (lane, s) in s.iter_mut().enumerate() {
                *s = b[lane * n + i];
            }
            for k in i.saturating_sub(p)..i {
                let lik = l[i * width + (k + p - i)];
                for (lane, s) in s.iter_mut().enumerate() {
                    *s -= lik * x[lane * n + k];
                }
            }
            let diagonal = l[i * width + p];
            for (lane, s) in s.iter().enumerate() {
                x[lane * n + i] = s / diagonal;
            }
        }
        for i in (0..n).rev() {
            let mut s = [0.0; LANES];
            for (lane, s) in s.iter_mut().enumerate() {
                *s = x[lane * n + i];
            }
            for k in i + 1..(i + p + 1).min(n) {
                let lki = l[k * width + (i + p - k)];
                for (lane, s) in s.iter_mut().enumerate() {
                    *s -= lki * x[lane * n + k];
                }
            }
            let diagonal = l[i * width + p];
            for (lane, s) in s.iter().enumerate() {
                x[lane * n + i] = s / diagonal;
            }
        }
    }
}

fn failure(reason: String) -> Error {
    Error::Solver {
        solver: "banded".into(),
        reason,
    }
}

impl LinearSolver for BandedCholesky {
    fn name(&self) -> &'static str {
        "banded"
    }

    fn solve(&mut self, a: &CsrMatrix, b: &[f64], x: &mut [f64]) -> Result<SolveStats> {
        super::check_dimensions("banded", a, b, x)?;
        self.factor(a)?;
        self.resolve(a, b, x)
    }

    fn resolve(&mut self, a: &CsrMatrix, b: &[f64], x: &mut [f64]) -> Result<SolveStats> {
        super::check_dimensions("banded", a, b, x)?;
        if !self.factored || self.factor.len() != a.rows * (self.bandwidth + 1) {
            return self.solve(a, b, x);
        }
        self.solve_factored(b, x);
        Ok(SolveStats {
            iterations: 0,
            relative_residual: super::relative_residual(a, x, b, &mut self.product),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_a_banded_spd_system_to_round_off() {
        let n = 40;
        let p = 3;
        let mut a = CsrMatrix::band(n, p);
        for i in 0..n {
            for j in i.saturating_sub(p)..=(i + p).min(n - 1) {
                let k = a.band_index(i, j);
                a.values[k] = if i == j {
                    4.0 + i as f64 * 0.01
                } else {
                    1.0 / (1.0 + i.abs_diff(j) as f64 + (i + j) as f64 * 0.01)
                };
            }
        }
        let exact: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).cos()).collect();
        let mut b = vec![0.0; n];
        a.mul_vec(&exact, &mut b);
        let mut x = vec![0.0; n];
        let stats = BandedCholesky::new().solve(&a, &b, &mut x).unwrap();
        assert!(stats.relative_residual < 1e-15, "{stats:?}");
        for (xi, ei) in x.iter().zip(&exact) {
            assert!((xi - ei).abs() < 1e-13);
        }
        // Constrained rows become identity rows.
        let mut keep = vec![true; n];
        keep[0] = false;
        a.constrain(&keep);
        b[0] = 0.0;
        BandedCholesky::new().solve(&a, &b, &mut x).unwrap();
        assert_eq!(x[0], 0.0);
    }

    #[test]
    fn resolve_reuses_the_factor_of_the_last_solve() {
        let mut a = CsrMatrix::band(5, 1);
        for i in 0..5usize {
            for j in i.saturating_sub(1)..=(i + 1).min(4) {
                let k = a.band_index(i, j);
                a.values[k] = if i == j { 4.0 } else { 1.0 };
            }
        }
        let b = [1.0, 2.0, 3.0, 4.0, 5.0];
        let mut solver = BandedCholesky::new();
        let (mut first, mut again) = ([0.0; 5], [0.0; 5]);
        solver.solve(&a, &b, &mut first).unwrap();
        // `resolve` trusts the caller: it solves with the stored factor of `a`, not with
        // the (here deliberately different) matrix it is handed.
        let mut scaled = a.clone();
        scaled.values.iter_mut().for_each(|v| *v *= 2.0);
        solver.resolve(&scaled, &b, &mut again).unwrap();
        assert_eq!(first, again);
        // `solve` refactors.
        solver.solve(&scaled, &b, &mut again).unwrap();
        for (x, y) in first.iter().zip(&again) {
            assert!((x - 2.0 * y).abs() < 1e-14);
        }
    }

    #[test]
    fn indefinite_matrix_is_an_error() {
        let a =
            CsrMatrix::from_triplets(2, 2, &[(0, 0, 1.0), (0, 1, 2.0), (1, 0, 2.0), (1, 1, 1.0)]);
        let mut x = vec![0.0; 2];
        let err = BandedCholesky::new()
            .solve(&a, &[1.0, 1.0], &mut x)
            .unwrap_err();
        assert!(err.to_string().contains("not positive definite"), "{err}");
    }

    #[test]
    fn lines_solved_together_are_each_line_solved_alone_bit_for_bit() {
        let space = crate::linalg::assembly::SplineSpace::new(3, 9, 1.0).unwrap();
        let m = crate::linalg::assembly::mass_1d(&space, 4, |q| 1.0 + q.x[0] * q.x[0]);
        let mut factor = BandedCholesky::new();
        factor.factor(&m).unwrap();
        let n = m.rows;
        let b: Vec<f64> = (0..4 * n).map(|i| (i as f64 * 0.37).sin()).collect();
        let mut together = vec![0.0; 4 * n];
        factor.solve_factored_lines::<4>(&b, &mut together);
        for (line, x) in together.chunks(n).enumerate() {
            let mut alone = vec![0.0; n];
            factor.solve_factored(&b[line * n..(line + 1) * n], &mut alone);
            assert_eq!(x, &alone[..]);
        }
    }
}
