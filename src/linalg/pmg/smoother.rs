//! Smoothers of the p-multigrid V-cycle (SPEC §5): steps `x += S (f - A x)` on one level.
//!
//! ```text
//! damped Jacobi        x <- x + omega D^-1 (f - A x)                       (all rows at once)
//! scaled Jacobi        x <- x + (omega / lambda) D^-1 (f - A x),  lambda = max_i sum_j |a_ij| / a_ii
//! Gauss–Seidel         x_i <- x_i + (f_i - sum_j a_ij x_j) / a_ii,  i = 0, 1, ..., n-1
//! backward GS          the same, i = n-1, ..., 0
//! symmetric GS         one forward sweep, then one backward sweep
//! ILU(0)               x <- x + (L U)^-1 (f - A x),  L U = A on the pattern of A
//! ```
//!
//! `D = diag(A)`. The default Jacobi damping is `omega = 2/3`, the classical choice for
//! `lambda_max(D^-1 A) <= 2` (Laplacians, 1D linear mass). B-spline mass matrices have
//! `lambda_max(D^-1 M) = max row sum / diagonal` up to ~2 per direction and order (2.25 for
//! p = 1 in 2D, 4.4 for p = 3, 7.8 for p = 5): with `omega = 2/3` the smoothest modes are
//! amplified (`|1 - omega lambda| > 1`) and only the coarse correction keeps the cycle
//! convergent — as a CG preconditioner it is then indefinite. The scaled variant divides by
//! the Gershgorin bound `lambda >= lambda_max(D^-1 A)` of each level, so any
//! `0 < omega < 2` is convergent.
//!
//! ILU(0) (no fill-in: `L` unit lower, `U` upper, both on the pattern of `A`, computed per
//! level at set-up) is the cheap member of the incomplete-factorisation smoothers SPEC
//! §5.2 points to for p >= 4 (Tielen's ILUT). For symmetric `A`, `U = D L^T`, so the
//! smoother is its own adjoint. Mass matrices are not M-matrices and ILU(0) can break
//! down (nearly singular Galerkin levels do): a pivot below `1e-4 a_ii` is replaced by
//! `a_ii` (diagonal compensation), so the factors stay symmetric positive definite; the
//! factors can still grow (deep Galerkin hierarchies, p >= 4 at 1/h = 32 with variable
//! density: the smoother then diverges and the solve reports non-finite values). On a
//! constant-density tensor-product mass matrix `M_y (x) M_x` with its full tensor pattern
//! ILU(0) is the *exact* LU (`(L_y (x) L_x)(U_y (x) U_x)` fits the pattern), as in 1D
//! (banded, no fill): one ILU step then solves the system. The sweeps run over the CSR slices of `A` in place; the
//! only scratch vector (Jacobi's residual) is a level work vector, so a sweep allocates
//! nothing.
//!
//! As a preconditioner the V-cycle must be symmetric: the post-smoother is then the adjoint
//! of the pre-smoother in the `A` inner product — backward GS after forward GS; Jacobi and
//! symmetric GS are their own adjoints.

use crate::linalg::CsrMatrix;

/// How a level is smoothed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Smoother {
    /// `x += omega D^-1 (f - A x)`.
    DampedJacobi { omega: f64 },
    /// `x += (omega / lambda) D^-1 (f - A x)` with the Gershgorin bound `lambda` of
    /// `D^-1 A`; convergent for `0 < omega < 2`.
    ScaledJacobi { omega: f64 },
    /// Forward Gauss–Seidel sweeps (backward in the post-smoothing of a preconditioner).
    GaussSeidel,
    /// A forward then a backward Gauss–Seidel sweep per step (symmetric).
    SymmetricGaussSeidel,
    /// `x += (L U)^-1 (f - A x)` with the ILU(0) factors of the level.
    Ilu0,
}

impl Smoother {
    /// Damped Jacobi with `omega = 2/3`.
    pub const JACOBI: Smoother = Smoother::DampedJacobi { omega: 2.0 / 3.0 };

    /// `steps` smoothing steps on `a x = f`; `adjoint` selects the adjoint smoother (the
    /// post-smoother of a symmetric V-cycle). `diagonal` holds `1 / a_ii` and the Gershgorin
    /// bound, `scratch` is a vector of the level's size.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn smooth(
        self,
        steps: usize,
        adjoint: bool,
        a: &CsrMatrix,
        diagonal: &LevelSmoother,
        x: &mut [f64],
        f: &[f64],
        scratch: &mut [f64],
    ) {
        let inverse_diagonal = &diagonal.inverse[..];
        for _ in 0..steps {
            match self {
                Smoother::DampedJacobi { omega } => {
                    jacobi_step(a, inverse_diagonal, omega, x, f, scratch)
                }
                Smoother::ScaledJacobi { omega } => {
                    let omega = omega / diagonal.gershgorin;
                    jacobi_step(a, inverse_diagonal, omega, x, f, scratch)
                }
                Smoother::GaussSeidel if adjoint => backward_sweep(a, inverse_diagonal, x, f),
                Smoother::GaussSeidel => forward_sweep(a, inverse_diagonal, x, f),
                Smoother::SymmetricGaussSeidel => {
                    forward_sweep(a, inverse_diagonal, x, f);
                    backward_sweep(a, inverse_diagonal, x, f);
                }
                Smoother::Ilu0 => {
                    a.par_mul_vec(x, scratch);
                    for (ri, fi) in scratch.iter_mut().zip(f) {
                        *ri = fi - *ri;
                    }
                    diagonal.ilu.solve_in_place(scratch);
                    for (xi, di) in x.iter_mut().zip(scratch.iter()) {
                        *xi += di;
                    }
                }
            }
        }
    }
}

/// `f_i - sum_j a_ij x_j` for row `i`.
#[inline]
fn row_residual(a: &CsrMatrix, i: usize, x: &[f64], f: &[f64]) -> f64 {
    let range = a.row_start[i]..a.row_start[i + 1];
    let mut s = f[i];
    for (&j, &v) in a.col_index[range.clone()].iter().zip(&a.values[range]) {
        s -= v * x[j];
    }
    s
}

/// One damped Jacobi step; `residual` is overwritten.
fn jacobi_step(
    a: &CsrMatrix,
    inverse_diagonal: &[f64],
    omega: f64,
    x: &mut [f64],
    f: &[f64],
    residual: &mut [f64],
) {
    a.par_mul_vec(x, residual);
    for (((xi, ri), fi), di) in x
        .iter_mut()
        .zip(residual.iter())
        .zip(f)
        .zip(inverse_diagonal)
    {
        *xi += omega * di * (fi - ri);
    }
}

/// One forward Gauss–Seidel sweep, rows `0..n`.
fn forward_sweep(a: &CsrMatrix, inverse_diagonal: &[f64], x: &mut [f64], f: &[f64]) {
    for i in 0..a.rows {
        x[i] += row_residual(a, i, x, f) * inverse_diagonal[i];
    }
}

/// One backward Gauss–Seidel sweep, rows `n-1..=0`.
fn backward_sweep(a: &CsrMatrix, inverse_diagonal: &[f64], x: &mut [f64], f: &[f64]) {
    for i in (0..a.rows).rev() {
        x[i] += row_residual(a, i, x, f) * inverse_diagonal[i];
    }
}

/// What the smoothers need of a level's diagonal.
#[derive(Clone, Debug, Default)]
pub(crate) struct LevelSmoother {
    /// `1 / a_ii`.
    pub inverse: Vec<f64>,
    /// `max_i sum_j |a_ij| / a_ii >= lambda_max(D^-1 A)`.
    pub gershgorin: f64,
    /// ILU(0) factors (set up for [`Smoother::Ilu0`] only).
    pub ilu: Ilu0,
}

impl LevelSmoother {
    /// Recompute for `a` and `smoother` (no allocation after the first call with a
    /// pattern); an error message naming the row if a diagonal entry or ILU pivot is
    /// missing, non-positive or not finite.
    pub(crate) fn update(&mut self, a: &CsrMatrix, smoother: Smoother) -> Result<(), String> {
        self.inverse.resize(a.rows, 0.0);
        self.gershgorin = 0.0;
        for (i, d) in self.inverse.iter_mut().enumerate() {
            let range = a.row_start[i]..a.row_start[i + 1];
            let (mut diagonal, mut absolute_sum) = (0.0, 0.0);
            for (&j, &v) in a.col_index[range.clone()].iter().zip(&a.values[range]) {
                if j == i {
                    diagonal = v;
                }
                absolute_sum += v.abs();
            }
            if !(diagonal > 0.0 && diagonal.is_finite()) {
                return Err(format!(
                    "diagonal entry {diagonal:e} in row {i} is not positive (matrix not SPD)"
                ));
            }
            *d = 1.0 / diagonal;
            self.gershgorin = f64::max(self.gershgorin, absolute_sum / diagonal);
        }
        if smoother == Smoother::Ilu0 {
            self.ilu.factor(a)?;
        }
        Ok(())
    }
}

/// Relative size below which an ILU(0) pivot is replaced by the matrix diagonal.
const ILU_PIVOT_FLOOR: f64 = 1e-4;

/// ILU(0) factors `L U ~ A` stored in one matrix with the pattern of `A`: the strictly
/// lower part is `L` (unit diagonal implied), the rest `U`.
#[derive(Clone, Debug, Default)]
pub(crate) struct Ilu0 {
    factors: Option<CsrMatrix>,
    /// Position of the diagonal entry of every row in `values`.
    diagonal: Vec<usize>,
    /// `position[j]`: index of column `j` in the current row, `usize::MAX` if absent.
    position: Vec<usize>,
}

impl Ilu0 {
    /// `a_ik /= u_kk; a_ij -= a_ik u_kj` for `k < i`, `j > k` on the pattern (IKJ order).
    fn factor(&mut self, a: &CsrMatrix) -> Result<(), String> {
        let factors = match &mut self.factors {
            Some(f) if f.same_pattern(a) => {
                f.values.copy_from_slice(&a.values);
                f
            }
            slot => {
                self.diagonal.clear();
                for i in 0..a.rows {
                    let range = a.row_start[i]..a.row_start[i + 1];
                    let at = a.col_index[range.clone()]
                        .iter()
                        .position(|&j| j == i)
                        .ok_or_else(|| format!("row {i} stores no diagonal entry"))?;
                    self.diagonal.push(range.start + at);
                }
                self.position.clear();
                self.position.resize(a.cols, usize::MAX);
                slot.insert(a.clone())
            }
        };
        let (row_start, col_index) = (&factors.row_start, &factors.col_index);
        let values = &mut factors.values;
        for i in 0..factors.rows {
            let range = row_start[i]..row_start[i + 1];
            for k in range.clone() {
                self.position[col_index[k]] = k;
            }
            for m in range.clone() {
                let k = col_index[m];
                if k >= i {
                    break;
                }
                let lik = values[m] / values[self.diagonal[k]];
                values[m] = lik;
                for n in self.diagonal[k] + 1..row_start[k + 1] {
                    let at = self.position[col_index[n]];
                    if at != usize::MAX {
                        values[at] -= lik * values[n];
                    }
                }
            }
            for k in range.clone() {
                self.position[col_index[k]] = usize::MAX;
            }
            if let Some(v) = values[range].iter().find(|v| !v.is_finite()) {
                return Err(format!(
                    "ILU(0) factor entry {v:e} in row {i}: the incomplete factorisation is \
                     unstable on this matrix"
                ));
            }
            let d = self.diagonal[i];
            if !(values[d] > ILU_PIVOT_FLOOR * a.values[d] && values[d].is_finite()) {
                values[d] = a.values[d];
            }
        }
        Ok(())
    }

    /// `r <- (L U)^-1 r`: forward then backward substitution in place.
    fn solve_in_place(&self, r: &mut [f64]) {
        let Some(f) = &self.factors else {
            return;
        };
        for i in 0..f.rows {
            let mut s = r[i];
            for m in f.row_start[i]..self.diagonal[i] {
                s -= f.values[m] * r[f.col_index[m]];
            }
            r[i] = s;
        }
        for i in (0..f.rows).rev() {
            let d = self.diagonal[i];
            let mut s = r[i];
            for m in d + 1..f.row_start[i + 1] {
                s -= f.values[m] * r[f.col_index[m]];
            }
            r[i] = s / f.values[d];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spd(n: usize) -> CsrMatrix {
        let mut t = Vec::new();
        for i in 0..n {
            t.push((i, i, 4.0));
            if i + 1 < n {
                t.push((i, i + 1, 1.0));
                t.push((i + 1, i, 1.0));
            }
        }
        CsrMatrix::from_triplets(n, n, &t)
    }

    fn error_norm(a: &CsrMatrix, x: &[f64], f: &[f64]) -> f64 {
        (0..a.rows)
            .map(|i| row_residual(a, i, x, f).powi(2))
            .sum::<f64>()
            .sqrt()
    }

    #[test]
    fn every_smoother_reduces_the_residual_and_fixes_the_solution() {
        let n = 30;
        let a = spd(n);
        let mut diagonal = LevelSmoother::default();
        diagonal.update(&a, Smoother::Ilu0).unwrap();
        assert_eq!(diagonal.gershgorin, 1.5);
        let exact: Vec<f64> = (0..n).map(|i| (i as f64).sin()).collect();
        let mut f = vec![0.0; n];
        a.mul_vec(&exact, &mut f);
        let mut scratch = vec![0.0; n];
        for smoother in [
            Smoother::JACOBI,
            Smoother::ScaledJacobi { omega: 1.0 },
            Smoother::GaussSeidel,
            Smoother::SymmetricGaussSeidel,
            Smoother::Ilu0,
        ] {
            for adjoint in [false, true] {
                let mut x = vec![0.0; n];
                let before = error_norm(&a, &x, &f);
                smoother.smooth(5, adjoint, &a, &diagonal, &mut x, &f, &mut scratch);
                let after = error_norm(&a, &x, &f);
                assert!(after < 0.1 * before, "{smoother:?} {before} {after}");
                // The exact solution is a fixed point.
                let mut y = exact.clone();
                smoother.smooth(2, adjoint, &a, &diagonal, &mut y, &f, &mut scratch);
                for (yi, ei) in y.iter().zip(&exact) {
                    assert!((yi - ei).abs() < 1e-14);
                }
            }
        }
    }

    #[test]
    fn backward_sweep_is_the_forward_sweep_of_the_reversed_system() {
        let n = 7;
        let mut a = spd(n);
        // Make it non-Toeplitz so the direction matters.
        for (k, v) in a.values.iter_mut().enumerate() {
            *v += 0.01 * k as f64;
        }
        let f: Vec<f64> = (0..n).map(|i| 1.0 + i as f64).collect();
        let mut diagonal = LevelSmoother::default();
        diagonal.update(&a, Smoother::Ilu0).unwrap();
        let inverse = diagonal.inverse;
        let mut x = vec![0.0; n];
        backward_sweep(&a, &inverse, &mut x, &f);
        // Reverse rows and columns, sweep forward, reverse back.
        let mut t = Vec::new();
        for i in 0..n {
            for k in a.row_start[i]..a.row_start[i + 1] {
                t.push((n - 1 - i, n - 1 - a.col_index[k], a.values[k]));
            }
        }
        let r = CsrMatrix::from_triplets(n, n, &t);
        let mut reversed = LevelSmoother::default();
        reversed.update(&r, Smoother::GaussSeidel).unwrap();
        let inverse_r = reversed.inverse;
        let fr: Vec<f64> = f.iter().rev().copied().collect();
        let mut y = vec![0.0; n];
        forward_sweep(&r, &inverse_r, &mut y, &fr);
        y.reverse();
        assert_eq!(x, y);
        // The last row is solved exactly by the first step of a backward sweep, so it
        // differs from the forward sweep's value.
        let mut z = vec![0.0; n];
        forward_sweep(&a, &inverse, &mut z, &f);
        assert_ne!(x[n - 1], z[n - 1]);
    }

    #[test]
    fn ilu0_of_a_tridiagonal_matrix_is_its_exact_lu() {
        // No fill-in: one ILU(0) step solves the system.
        let n = 12;
        let a = spd(n);
        let mut smoothing = LevelSmoother::default();
        smoothing.update(&a, Smoother::Ilu0).unwrap();
        let f: Vec<f64> = (0..n).map(|i| (i as f64).cos()).collect();
        let (mut x, mut scratch) = (vec![0.0; n], vec![0.0; n]);
        Smoother::Ilu0.smooth(1, false, &a, &smoothing, &mut x, &f, &mut scratch);
        assert!(error_norm(&a, &x, &f) < 1e-14);
        // Same pattern, new values: refactored in place.
        let mut b = a.clone();
        b.values.iter_mut().for_each(|v| *v *= 2.0);
        smoothing.update(&b, Smoother::Ilu0).unwrap();
        x.fill(0.0);
        Smoother::Ilu0.smooth(1, false, &b, &smoothing, &mut x, &f, &mut scratch);
        assert!(error_norm(&b, &x, &f) < 1e-14);
    }

    #[test]
    fn non_positive_diagonal_is_reported() {
        let a = CsrMatrix::from_triplets(2, 2, &[(0, 0, 1.0), (1, 0, 1.0)]);
        let err = LevelSmoother::default()
            .update(&a, Smoother::GaussSeidel)
            .unwrap_err();
        assert!(err.contains("row 1"), "{err}");
    }
}
