//! Condition numbers of symmetric positive definite matrices (SPEC §5.1): the published
//! condition numbers of the B-spline mass matrices (`kappa(M)` = 7.38 ... 2.52e4) must be
//! reproduced to 3 significant digits.
//!
//! # Method
//! `kappa(A) = lambda_max / lambda_min` from the extreme eigenvalues of `A`, found by the
//! symmetric Lanczos process: from a unit vector `q_1`, build the orthonormal basis
//! `q_1 ... q_k` of the Krylov space `span{q_1, A q_1, ..., A^{k-1} q_1}` and the tridiagonal
//! `T_k = Q_k^T A Q_k` (diagonal `alpha_j = q_j^T A q_j`, off-diagonal `beta_j`). The
//! eigenvalues of `T_k` (Ritz values) lie in `[lambda_min, lambda_max]` and the extreme ones
//! converge first to the extreme eigenvalues of `A` (monotonically, by interlacing).
//!
//! * Every new Lanczos vector is orthogonalised against all earlier ones, twice (full
//!   reorthogonalisation, "twice is enough"): `k` vectors of length `n` are stored and a step
//!   costs `O(k n)` besides the operator. Without it, rounding makes copies of converged
//!   Ritz values ("ghosts") and the basis loses orthogonality.
//! * The starting vector is deterministic: all ones (a large component on the smooth
//!   eigenvectors) plus a fixed pseudo-random perturbation in `[-1/2, 1/2)`, so that it is
//!   not orthogonal to any eigenvector for structural reasons (symmetry, alternating signs).
//! * The extreme eigenvalues of `T_k` are found by bisection with Sturm counts (the number
//!   of negative pivots of the `LDL^T` factorisation of `T_k - x I` is the number of
//!   eigenvalues below `x`), bracketed by Gershgorin's discs and, from the second step on,
//!   by the previous Ritz values (interlacing). Bisection is run to the last bit.
//! * Stopping: when every extreme Ritz value wanted changed by less than `tolerance`
//!   (relative) over the last [`WINDOW`] steps, or when the Krylov space is exhausted
//!   (`beta_k ~ 0` or `k = n`: the Ritz values are then eigenvalues of `A`, exact to
//!   rounding). For a well separated extreme eigenvalue the error is then a small multiple
//!   of `tolerance`. A relative-change test cannot see stagnation, though: when the extreme
//!   eigenvalue sits in a cluster that the Krylov space has not resolved yet, the Ritz value
//!   first settles on a weighted mean of the cluster, with an error up to the cluster's
//!   relative width.
//!
//! The largest Ritz value converges fast; the smallest converges slowly when `kappa` is
//! large (the number of steps grows like `sqrt(kappa)`, and clusters are resolved late).
//! [`condition_number`] therefore accepts an exact inverse operator (a direct solve, e.g. a
//! Cholesky factor): then `lambda_min = 1 / lambda_max(A^{-1})`, from a second Lanczos run
//! on `A^{-1}` whose largest Ritz value converges as fast as that of `A`.
//!
//! Observed (tests below): the SPEC §5.1 matrices (`kappa_2D = kappa_1D^2`, 1D with the
//! banded Cholesky as inverse) agree with a dense eigensolver to 1e-14 in at most 63 + 46
//! steps. The 2D matrix of `p = 5`, `1/h = 64` itself (n = 4489): with an inverse, 59 + 35
//! steps, error 2e-11; without, 1270 steps and an error of 2.8e-6 in `lambda_min` (the
//! boundary modes of high-order B-splines come in nearly degenerate pairs, 3e-6 apart in
//! 1D, making a cluster of four at the bottom in 2D). Both are far inside the 3 digits
//! that SPEC §5.1 asks for; the inverse is faster and more accurate.
//!
//! Failures are errors, never panics: a non-positive or non-finite Ritz value (the
//! operator is not symmetric positive definite), no convergence within the step limit, an
//! empty or non-square matrix. A Ritz value `<= 0` proves that the operator is not positive
//! definite (Ritz values are Rayleigh quotients); an indefinite operator whose negative
//! eigenvalues the Krylov space has not reached yet is not detected, but [`condition_number`]
//! without an inverse runs until the smallest Ritz value has converged, which reaches them.

use super::CsrMatrix;
use crate::error::{Error, Result};

/// Steps over which the extreme Ritz values must have settled.
pub const WINDOW: usize = 5;

/// Default relative tolerance of [`condition_number`] on the extreme eigenvalues.
pub const DEFAULT_TOLERANCE: f64 = 1e-10;

/// Default limit on the Lanczos steps of one run of [`condition_number`] (memory: that many
/// vectors of length `n`).
pub const DEFAULT_MAX_STEPS: usize = 2000;

/// `beta_k <= BREAKDOWN * ||T_k||` ends the process: the Krylov space is invariant.
const BREAKDOWN: f64 = 1e-12;

/// An exact inverse operator: `solve(b, x)` overwrites `x` with `A^{-1} b` (both of length
/// `n`), e.g. a closure around [`super::BandedCholesky::solve_factored`].
pub type InverseOperator<'a> = &'a mut dyn FnMut(&[f64], &mut [f64]);

/// Extreme eigenvalues and condition number of a symmetric positive definite matrix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConditionEstimate {
    pub lambda_min: f64,
    pub lambda_max: f64,
    /// `lambda_max / lambda_min`.
    pub condition_number: f64,
    /// Lanczos steps on `A` (operator applications).
    pub steps: usize,
    /// Lanczos steps on `A^{-1}` (solves); 0 when no inverse was given.
    pub inverse_steps: usize,
}

/// Smallest and largest eigenvalue of the symmetric positive definite operator `apply`
/// (`apply(x, y)` must overwrite `y` with `A x`; both slices have length `n`) by Lanczos
/// with full reorthogonalisation: `(lambda_min, lambda_max, steps)`, after at most
/// `min(n, max_steps)` steps.
///
/// Stops when both extreme Ritz values changed by less than `tolerance` (relative) over the
/// last [`WINDOW`] steps, or when the Krylov space is exhausted (then the values are exact to
/// rounding). Errors (`Error::Solver { solver: "lanczos", .. }`) for `n = 0`, `max_steps = 0`,
/// a tolerance that is not positive, a non-finite operator output, a Ritz value `<= 0` (not
/// positive definite), or no convergence within `max_steps`.
///
/// ```
/// use tlsmpm::linalg::condition::lanczos_extreme_eigenvalues;
/// let diagonal = [3.0, 1.0, 2.0, 5.0];
/// let apply = |x: &[f64], y: &mut [f64]| {
///     for ((yi, xi), d) in y.iter_mut().zip(x).zip(&diagonal) {
///         *yi = d * xi;
///     }
/// };
/// let (min, max, steps) = lanczos_extreme_eigenvalues(4, apply, 100, 1e-12).unwrap();
/// assert!((min - 1.0).abs() < 1e-12 && (max - 5.0).abs() < 1e-12 && steps <= 4);
/// ```
pub fn lanczos_extreme_eigenvalues(
    n: usize,
    mut apply: impl FnMut(&[f64], &mut [f64]),
    max_steps: usize,
    tolerance: f64,
) -> Result<(f64, f64, usize)> {
    let run = lanczos(n, &mut apply, max_steps, tolerance, Wanted::Both)?;
    Ok((run.min, run.max, run.steps))
}

/// Condition number of the symmetric positive definite matrix `a` with the default step
/// limit and tolerance ([`DEFAULT_MAX_STEPS`], [`DEFAULT_TOLERANCE`]); see
/// [`condition_number_with`].
///
/// ```
/// use tlsmpm::linalg::{condition::condition_number, BandedCholesky, CsrMatrix};
/// // 1D Laplacian tridiag(-1, 2, -1), n = 50: kappa = cot^2(pi / (2 (n + 1))).
/// let n = 50;
/// let mut triplets = Vec::new();
/// for i in 0..n {
///     triplets.push((i, i, 2.0));
///     if i + 1 < n {
///         triplets.push((i, i + 1, -1.0));
///         triplets.push((i + 1, i, -1.0));
///     }
/// }
/// let a = CsrMatrix::from_triplets(n, n, &triplets);
/// let mut cholesky = BandedCholesky::new();
/// cholesky.factor(&a).unwrap();
/// let mut inverse = |b: &[f64], x: &mut [f64]| cholesky.solve_factored(b, x);
/// let estimate = condition_number(&a, Some(&mut inverse)).unwrap();
/// let exact = 1.0 / (std::f64::consts::PI / (2.0 * (n as f64 + 1.0))).tan().powi(2);
/// assert!((estimate.condition_number / exact - 1.0).abs() < 1e-8);
/// ```
pub fn condition_number(
    a: &CsrMatrix,
    inverse: Option<InverseOperator<'_>>,
) -> Result<ConditionEstimate> {
    condition_number_with(a, inverse, DEFAULT_MAX_STEPS, DEFAULT_TOLERANCE)
}

/// Condition number `lambda_max / lambda_min` of the symmetric positive definite matrix
/// `a`, with at most `max_steps` Lanczos steps per run and relative tolerance `tolerance`
/// on the extreme eigenvalues.
///
/// * `lambda_max`: largest Ritz value of Lanczos on `a` (converges fast).
/// * `lambda_min`: with `inverse = Some(solve)`, where `solve(b, x)` overwrites `x` with
///   `A^{-1} b` exactly (a direct solve, e.g. [`super::BandedCholesky::solve_factored`]
///   after `factor`), `1 / lambda_max(A^{-1})` from a second Lanczos run on `A^{-1}` (fast);
///   the smaller of that and the smallest Ritz value of the first run is kept (both are
///   upper bounds of `lambda_min`). With `None`, the smallest Ritz value of Lanczos on `a`,
///   run until it has converged too: about `sqrt(kappa)` times more steps, so give an
///   inverse when `kappa` is large (`> 1e3`, say) or `a` is big.
///
/// An inexact inverse (an iterative solve to a loose tolerance) gives a `lambda_min` only
/// as accurate as the solve.
pub fn condition_number_with(
    a: &CsrMatrix,
    inverse: Option<InverseOperator<'_>>,
    max_steps: usize,
    tolerance: f64,
) -> Result<ConditionEstimate> {
    if a.rows != a.cols {
        return Err(failure(format!(
            "matrix is {}x{}, not square",
            a.rows, a.cols
        )));
    }
    let n = a.rows;
    let mut apply = |x: &[f64], y: &mut [f64]| a.mul_vec(x, y);
    let wanted = if inverse.is_some() {
        Wanted::Largest
    } else {
        Wanted::Both
    };
    let direct = lanczos(n, &mut apply, max_steps, tolerance, wanted)?;
    let lambda_max = direct.max;
    let (lambda_min, inverse_steps) = match inverse {
        Some(solve) => {
            let run = lanczos(n, solve, max_steps, tolerance, Wanted::Largest)?;
            ((1.0 / run.max).min(direct.min), run.steps)
        }
        None => (direct.min, 0),
    };
    Ok(ConditionEstimate {
        lambda_min,
        lambda_max,
        condition_number: lambda_max / lambda_min,
        steps: direct.steps,
        inverse_steps,
    })
}

/// Which extreme Ritz values must converge.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Wanted {
    Largest,
    Both,
}

/// Outcome of one Lanczos run.
#[derive(Clone, Copy, Debug)]
struct Run {
    min: f64,
    max: f64,
    steps: usize,
}

fn failure(reason: String) -> Error {
    Error::Solver {
        solver: "lanczos".into(),
        reason,
    }
}

fn dot(x: &[f64], y: &[f64]) -> f64 {
    x.iter().zip(y).map(|(a, b)| a * b).sum()
}

/// Deterministic starting vector: `1 + u_i`, `u_i` in `[-1/2, 1/2)` from a SplitMix64 hash
/// of `i`.
fn start_vector(n: usize) -> Vec<f64> {
    (0..n as u64)
        .map(|i| {
            let mut z = i.wrapping_add(1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^= z >> 31;
            let u = (z >> 11) as f64 / (1u64 << 53) as f64;
            0.5 + u
        })
        .collect()
}

/// Lanczos with full reorthogonalisation; see the module documentation.
fn lanczos(
    n: usize,
    apply: &mut dyn FnMut(&[f64], &mut [f64]),
    max_steps: usize,
    tolerance: f64,
    wanted: Wanted,
) -> Result<Run> {
    if n == 0 {
        return Err(failure("empty operator (n = 0): no eigenvalues".into()));
    }
    if max_steps == 0 {
        return Err(failure("max_steps = 0".into()));
    }
    if tolerance.is_nan() || tolerance <= 0.0 {
        return Err(failure(format!("tolerance {tolerance:e} is not positive")));
    }
    let limit = n.min(max_steps);
    let mut basis = start_vector(n);
    let norm = dot(&basis, &basis).sqrt();
    basis.iter_mut().for_each(|v| *v /= norm);
    let mut alphas: Vec<f64> = Vec::new();
    let mut betas: Vec<f64> = Vec::new();
    let mut history: Vec<(f64, f64)> = Vec::new();
    let mut w = vec![0.0; n];
    for j in 0..limit {
        let steps = j + 1;
        let q = &basis[j * n..steps * n];
        w.iter_mut().for_each(|v| *v = 0.0);
        apply(q, &mut w);
        if w.iter().any(|v| !v.is_finite()) {
            return Err(failure(format!(
                "non-finite operator output at step {steps}"
            )));
        }
        let alpha = dot(q, &w);
        for (wi, qi) in w.iter_mut().zip(q) {
            *wi -= alpha * qi;
        }
        if j > 0 {
            let beta = betas[j - 1];
            for (wi, pi) in w.iter_mut().zip(&basis[(j - 1) * n..j * n]) {
                *wi -= beta * pi;
            }
        }
        // Full reorthogonalisation, twice.
        for _ in 0..2 {
            for qi in basis.chunks_exact(n) {
                let c = dot(qi, &w);
                for (wk, qk) in w.iter_mut().zip(qi) {
                    *wk -= c * qk;
                }
            }
        }
        let beta = dot(&w, &w).sqrt();
        alphas.push(alpha);
        let previous = history.last().copied();
        let (min, max) = extreme_eigenvalues(&alphas, &betas, previous);
        if !(min.is_finite() && max.is_finite()) {
            return Err(failure(format!("non-finite Ritz value at step {steps}")));
        }
        if min <= 0.0 {
            return Err(failure(format!(
                "Ritz value {min:e} <= 0 at step {steps}: the operator is not positive definite"
            )));
        }
        history.push((min, max));
        let exhausted = steps == n || beta <= BREAKDOWN * max;
        if exhausted {
            return Ok(Run { min, max, steps });
        }
        if history.len() > WINDOW {
            let (old_min, old_max) = history[history.len() - 1 - WINDOW];
            let max_settled = (max - old_max).abs() <= tolerance * max;
            let min_settled = (min - old_min).abs() <= tolerance * min;
            if max_settled && (wanted == Wanted::Largest || min_settled) {
                return Ok(Run { min, max, steps });
            }
        }
        if steps == limit {
            return Err(failure(format!(
                "extreme Ritz values not settled to {tolerance:e} after {steps} steps \
                 (lambda_min ~ {min:e}, lambda_max ~ {max:e}); raise max_steps or give an \
                 exact inverse"
            )));
        }
        betas.push(beta);
        basis.extend(w.iter().map(|v| v / beta));
    }
    // `limit >= 1` and every iteration returns at `steps == limit`.
    Err(failure("no Lanczos step taken".into()))
}

/// Number of eigenvalues of the symmetric tridiagonal `(alphas, betas)` below `x` (Sturm
/// count: negative pivots of `LDL^T` of `T - x I`); `pivmin` replaces zero pivots.
fn count_below(alphas: &[f64], betas: &[f64], x: f64, pivmin: f64) -> usize {
    let mut count = 0;
    let mut d = 1.0;
    for (i, &a) in alphas.iter().enumerate() {
        let coupling = if i == 0 {
            0.0
        } else {
            betas[i - 1] * betas[i - 1] / d
        };
        d = a - x - coupling;
        if d.abs() < pivmin {
            d = -pivmin;
        }
        if d < 0.0 {
            count += 1;
        }
    }
    count
}

/// Smallest and largest eigenvalue of the symmetric tridiagonal with diagonal `alphas` and
/// off-diagonal `betas[..alphas.len() - 1]`, by bisection to the last bit. `previous`: the
/// extremes of the leading block one size smaller (interlacing brackets them).
fn extreme_eigenvalues(alphas: &[f64], betas: &[f64], previous: Option<(f64, f64)>) -> (f64, f64) {
    let m = alphas.len();
    let betas = &betas[..m - 1];
    let (mut low, mut high) = (f64::INFINITY, f64::NEG_INFINITY);
    let mut largest_beta2: f64 = 1.0;
    for (i, &a) in alphas.iter().enumerate() {
        let left = if i > 0 { betas[i - 1].abs() } else { 0.0 };
        let right = if i + 1 < m { betas[i].abs() } else { 0.0 };
        low = low.min(a - left - right);
        high = high.max(a + left + right);
        largest_beta2 = largest_beta2.max(left * left);
    }
    if !(low.is_finite() && high.is_finite()) {
        return (f64::NAN, f64::NAN);
    }
    let pivmin = f64::MIN_POSITIVE * largest_beta2;
    let pad = 4.0 * f64::EPSILON * low.abs().max(high.abs()) + pivmin;
    let (low, high) = (low - pad, high + pad);
    let count = |x: f64| count_below(alphas, betas, x, pivmin);
    // Smallest: count(lo) < 1 <= count(hi). Largest: count(lo) < m <= count(hi).
    let (mut min_hi, mut max_lo) = (high, low);
    if let Some((previous_min, previous_max)) = previous {
        if count(previous_min) >= 1 {
            min_hi = previous_min;
        }
        if count(previous_max) < m {
            max_lo = previous_max;
        }
    }
    let bisect = |mut lo: f64, mut hi: f64, target: usize| loop {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            return hi;
        }
        if count(mid) >= target {
            hi = mid;
        } else {
            lo = mid;
        }
    };
    (bisect(low, min_hi, 1), bisect(max_lo, high, m))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linalg::BandedCholesky;
    use crate::numerics::bspline::open_uniform;
    use crate::numerics::gauss::GaussRule;
    use std::f64::consts::PI;

    fn tridiagonal(n: usize, diagonal: f64, off: f64) -> CsrMatrix {
        let mut triplets = Vec::new();
        for i in 0..n {
            triplets.push((i, i, diagonal));
            if i + 1 < n {
                triplets.push((i, i + 1, off));
                triplets.push((i + 1, i, off));
            }
        }
        CsrMatrix::from_triplets(n, n, &triplets)
    }

    fn estimate_with_cholesky(a: &CsrMatrix) -> ConditionEstimate {
        let mut cholesky = BandedCholesky::new();
        cholesky.factor(a).unwrap();
        let mut inverse = |b: &[f64], x: &mut [f64]| cholesky.solve_factored(b, x);
        condition_number(a, Some(&mut inverse)).unwrap()
    }

    /// 1D mass matrix of the degree-`p` B-splines on `spans` open uniform spans of [0, 1],
    /// first and last function dropped (homogeneous Dirichlet), by Gauss quadrature.
    fn bspline_mass(p: usize, spans: usize) -> CsrMatrix {
        let h = 1.0 / spans as f64;
        let rule = GaussRule::new(p + 1).unwrap();
        let functions = spans + p;
        let mut triplets = Vec::new();
        let (mut values, mut derivatives) = (vec![0.0; p + 1], vec![0.0; p + 1]);
        for e in 0..spans {
            for (u, weight) in rule.mapped(e as f64, e as f64 + 1.0) {
                open_uniform(p, spans, e, u, &mut values, &mut derivatives);
                for a in 0..=p {
                    for b in 0..=p {
                        let (i, j) = (e + a, e + b);
                        if i == 0 || j == 0 || i == functions - 1 || j == functions - 1 {
                            continue;
                        }
                        triplets.push((i - 1, j - 1, weight * h * values[a] * values[b]));
                    }
                }
            }
        }
        CsrMatrix::from_triplets(functions - 2, functions - 2, &triplets)
    }

    /// `a (x) a` in CSR (lexicographic ordering).
    fn kronecker(a: &CsrMatrix) -> CsrMatrix {
        let n = a.rows;
        let mut triplets = Vec::new();
        for i1 in 0..n {
            for k1 in a.row_start[i1]..a.row_start[i1 + 1] {
                for i2 in 0..n {
                    for k2 in a.row_start[i2]..a.row_start[i2 + 1] {
                        triplets.push((
                            i1 * n + i2,
                            a.col_index[k1] * n + a.col_index[k2],
                            a.values[k1] * a.values[k2],
                        ));
                    }
                }
            }
        }
        CsrMatrix::from_triplets(n * n, n * n, &triplets)
    }

    #[test]
    fn diagonal_matrix_extremes_are_exact() {
        let n = 500;
        let scale = 0.37;
        let diagonal: Vec<f64> = (1..=n).map(|k| scale * k as f64).collect();
        let apply = |x: &[f64], y: &mut [f64]| {
            for ((yi, xi), d) in y.iter_mut().zip(x).zip(&diagonal) {
                *yi = d * xi;
            }
        };
        let (min, max, steps) = lanczos_extreme_eigenvalues(n, apply, n, 1e-14).unwrap();
        assert!((min / scale - 1.0).abs() < 1e-10, "min {min}");
        assert!((max / (scale * n as f64) - 1.0).abs() < 1e-10, "max {max}");
        assert!(steps <= n);
        // Through the CSR entry point, with and without an inverse.
        let triplets: Vec<_> = diagonal
            .iter()
            .enumerate()
            .map(|(i, &d)| (i, i, d))
            .collect();
        let a = CsrMatrix::from_triplets(n, n, &triplets);
        let plain = condition_number_with(&a, None, n, 1e-14).unwrap();
        assert!((plain.condition_number / n as f64 - 1.0).abs() < 1e-10);
        let with_inverse = estimate_with_cholesky(&a);
        assert!((with_inverse.condition_number / n as f64 - 1.0).abs() < 1e-9);
    }

    #[test]
    fn laplacian_condition_number() {
        let n = 200;
        let a = tridiagonal(n, 2.0, -1.0);
        let eigenvalue = |k: usize| 2.0 - 2.0 * (k as f64 * PI / (n as f64 + 1.0)).cos();
        let exact = eigenvalue(n) / eigenvalue(1);
        let estimate = estimate_with_cholesky(&a);
        let error = (estimate.condition_number / exact - 1.0).abs();
        assert!(
            error < 1e-6,
            "kappa {} vs {exact}: {error:e}",
            estimate.condition_number
        );
        assert!((estimate.lambda_min / eigenvalue(1) - 1.0).abs() < 1e-6);
        assert!((estimate.lambda_max / eigenvalue(n) - 1.0).abs() < 1e-6);
        // The top of the Laplacian spectrum is dense: lambda_max needs the whole space here,
        // while the inverse run (lambda_min well separated in A^{-1}) is quick.
        assert!(estimate.steps <= n && estimate.inverse_steps < n / 4);
    }

    #[test]
    fn linear_hat_mass_matrix_reproduces_spec_table() {
        let spans = 8;
        let h = 1.0 / spans as f64;
        let a = tridiagonal(spans - 1, 4.0 * h / 6.0, h / 6.0);
        let eigenvalue = |k: usize| h / 6.0 * (4.0 + 2.0 * (k as f64 * PI / spans as f64).cos());
        let exact_1d = eigenvalue(1) / eigenvalue(spans - 1);
        let estimate = estimate_with_cholesky(&a);
        assert!((estimate.condition_number / exact_1d - 1.0).abs() < 1e-10);
        let kappa_2d = estimate.condition_number.powi(2);
        assert!((kappa_2d - 7.38).abs() < 0.005, "kappa_2D = {kappa_2d}");
        // The same from quadrature of the degree-1 B-splines.
        let quadrature = estimate_with_cholesky(&bspline_mass(1, spans));
        assert!((quadrature.condition_number / exact_1d - 1.0).abs() < 1e-10);
    }

    /// Exact extreme eigenvalues of a small symmetric matrix (dense, nalgebra).
    fn dense_extremes(a: &CsrMatrix) -> (f64, f64) {
        let mut dense = nalgebra::DMatrix::<f64>::zeros(a.rows, a.cols);
        for i in 0..a.rows {
            for k in a.row_start[i]..a.row_start[i + 1] {
                dense[(i, a.col_index[k])] = a.values[k];
            }
        }
        let eigenvalues = dense.symmetric_eigen().eigenvalues;
        (eigenvalues.min(), eigenvalues.max())
    }

    /// SPEC §5.1 table, all orders and meshes: `kappa_2D = kappa_1D^2`, checked against a
    /// dense eigensolver to 1e-9 and against the published values. 14 of the 20 cells agree
    /// to 3 digits; the other 6 differ by at most 0.73% (exact values: p = 2, 1/h = 16:
    /// 55.18 vs 55.1; p = 3, 16: 425.1 vs 424; p = 4, 8: 3765 vs 3770; p = 5, 8: 3.288e4 vs
    /// 3.30e4; p = 5, 16: 2.629e4 vs 2.61e4; p = 5, 32: 2.512e4 vs 2.52e4). Neither `p`
    /// instead of `p + 1` Gauss points nor keeping the boundary functions explains them.
    #[test]
    fn bspline_mass_matrices_reproduce_spec_table() {
        let table: [[f64; 4]; 5] = [
            [7.38, 8.55, 8.89, 8.97],
            [52.1, 55.1, 56.0, 56.2],
            [440.0, 424.0, 420.0, 422.0],
            [3.77e3, 3.36e3, 3.29e3, 3.30e3],
            [3.30e4, 2.61e4, 2.52e4, 2.52e4],
        ];
        let mut three_digits = 0;
        for (p, row) in (1..=5).zip(table) {
            for (spans, published) in [8, 16, 32, 64].into_iter().zip(row) {
                let a = bspline_mass(p, spans);
                let estimate = estimate_with_cholesky(&a);
                let (min, max) = dense_extremes(&a);
                let cell = format!("p = {p}, 1/h = {spans}");
                assert!((estimate.lambda_min / min - 1.0).abs() < 1e-9, "{cell}");
                assert!((estimate.lambda_max / max - 1.0).abs() < 1e-9, "{cell}");
                let kappa_2d = estimate.condition_number.powi(2);
                assert!(
                    (kappa_2d / published - 1.0).abs() < 0.0075,
                    "{cell}: {kappa_2d} vs {published}"
                );
                let unit = 10f64.powi(published.log10().floor() as i32 - 2);
                if (kappa_2d - published).abs() <= 0.5 * unit {
                    three_digits += 1;
                }
            }
        }
        assert_eq!(three_digits, 14);
    }

    /// n = 4489 (p = 5, 1/h = 64, the 2D matrix itself). With the banded inverse: 59 + 35
    /// steps, relative error 2e-11. Without: 1270 steps (about 10 s), and the smallest Ritz
    /// value stagnates 2.8e-6 above `lambda_min` (a cluster of four eigenvalues within 6e-6
    /// from the two nearly degenerate 1D boundary modes), whatever the tolerance.
    #[test]
    #[ignore = "about 10 s; run with --ignored"]
    fn large_tensor_product_matrix() {
        let m1 = bspline_mass(5, 64);
        let exact = estimate_with_cholesky(&m1).condition_number.powi(2);
        let m2 = kronecker(&m1);
        assert_eq!(m2.rows, 4489);
        let with_inverse = estimate_with_cholesky(&m2);
        assert!((with_inverse.condition_number / exact - 1.0).abs() < 1e-9);
        assert!(with_inverse.steps + with_inverse.inverse_steps < 200);
        let plain = condition_number(&m2, None).unwrap();
        assert!((plain.condition_number / exact - 1.0).abs() < 1e-5);
        assert!((plain.lambda_max / with_inverse.lambda_max - 1.0).abs() < 1e-10);
    }

    /// The 2D tensor-product matrix itself (p = 2, 1/h = 8, n = 64) without an inverse.
    #[test]
    fn tensor_product_matrix_without_inverse() {
        let m1 = bspline_mass(2, 8);
        let kappa_1d = estimate_with_cholesky(&m1).condition_number;
        let m2 = kronecker(&m1);
        let plain = condition_number(&m2, None).unwrap();
        assert!((plain.condition_number / kappa_1d.powi(2) - 1.0).abs() < 1e-8);
        assert!((plain.condition_number - 52.1).abs() < 0.05);
    }

    #[test]
    fn indefinite_matrix_is_an_error() {
        let a = tridiagonal(50, 1.0, -1.0); // eigenvalues 1 - 2 cos(k pi / 51) < 0 for small k
        match condition_number(&a, None) {
            Err(Error::Solver { solver, reason }) => {
                assert_eq!(solver, "lanczos");
                assert!(reason.contains("not positive definite"), "{reason}");
            }
            other => panic!("expected a solver error, got {other:?}"),
        }
        let negative = CsrMatrix::from_triplets(1, 1, &[(0, 0, -2.0)]);
        assert!(condition_number(&negative, None).is_err());
        let nan = CsrMatrix::from_triplets(2, 2, &[(0, 0, f64::NAN), (1, 1, 1.0)]);
        assert!(condition_number(&nan, None).is_err());
    }

    #[test]
    fn small_and_degenerate_sizes() {
        let one = CsrMatrix::from_triplets(1, 1, &[(0, 0, 3.0)]);
        let estimate = condition_number(&one, None).unwrap();
        assert_eq!((estimate.lambda_min, estimate.lambda_max), (3.0, 3.0));
        assert_eq!((estimate.condition_number, estimate.steps), (1.0, 1));
        let empty = CsrMatrix::from_triplets(0, 0, &[]);
        assert!(condition_number(&empty, None).is_err());
        let rectangular = CsrMatrix::from_triplets(2, 3, &[(0, 0, 1.0)]);
        assert!(condition_number(&rectangular, None).is_err());
        // A multiple of the identity: the Krylov space is exhausted after one step.
        let identity = tridiagonal(10, 2.0, 0.0);
        let estimate = condition_number(&identity, None).unwrap();
        assert_eq!(estimate.steps, 1);
        assert!((estimate.condition_number - 1.0).abs() < 1e-14);
        // Too few steps allowed: an error, not a silent estimate.
        let a = tridiagonal(100, 2.0, -1.0);
        assert!(condition_number_with(&a, None, 10, 1e-10).is_err());
        assert!(condition_number_with(&a, None, 100, 0.0).is_err());
    }
}
