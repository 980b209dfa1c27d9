//! Taylor least squares on one interval (SPEC §4.1): the quadratic Taylor basis, the
//! normal equations of a fit, and their small SPD solves with a condition check.
//!
//! On `e = [lo, hi]` with centre `x_c` and half width `dx`, and `s = (x - x_c) / dx`:
//!
//! ```text
//! psi_1 = 1,   psi_2 = s,   psi_3 = s^2 / 2 - 1/6        (int_e psi_2 = int_e psi_3 = 0)
//! ```
//!
//! so `int_e sum_i a_i psi_i = a_1 |e|` whatever `a_2, a_3` are. A *full* fit solves the
//! 3x3 normal equations `D a = r`, `D = sum_p psi(x_p) psi(x_p)^T`, `r = sum_p psi(x_p) u_p`;
//! a *conservative* fit fixes `a_1 = c / |e|` and solves the 2x2 block
//! `D[2..3, 2..3] (a_2, a_3) = r[2..3] - a_1 D[2..3, 1]`, which is least squares on the
//! residual data `u_p - a_1`. Both use the same `D` and `r`, so one pass over the points
//! of a cell serves every field.
//!
//! **Well-posedness.** A block is accepted when the points excite every fitted function:
//! with `n` points and the moments of evenly spread points `S = diag(1, 1/3, 1/45)`
//! (`S_i = (1/2) int_{-1}^{1} psi_i^2 ds`), the block is scaled to
//! `D_ij / (n sqrt(S_i S_j))` (the identity for evenly spread points); every pivot of its
//! `L D L^T` factorisation, the part of a function's scaled mean square that the previous
//! functions do not explain, must be at least [`MIN_SPREAD`] (equivalently: pivot `i` of
//! `D` itself at least `MIN_SPREAD n S_i`). Two points for three
//! unknowns, or one point near the centre for a slope, fail the test ([`solve`] returns
//! `None`) instead of producing a wild extrapolation; [`solve_reduced`] then drops `psi_3`,
//! then `psi_2`, and never fails. The test costs no more than the solve itself.

/// Smallest accepted eigenvalue of the scaled normal-equation block.
pub const MIN_SPREAD: f64 = 1e-3;

/// Smallest accepted pivot of a *repaired* fit: a cell whose own points failed the
/// [`MIN_SPREAD`] test and is fitted again with virtual points from its neighbours' faces,
/// or by order reduction (docs/reconstruction.md, "Well-posed fits").
///
/// A virtual point lies on a face, next to which a lone particle about to leave the cell
/// lies, and the slope through two points `delta` apart, extrapolated across the fitted
/// interval, amplifies their difference by about `extent / delta ~ 1 / sqrt(spread)`:
/// about 30 times with [`MIN_SPREAD`]. With that, MPM-TLS with virtual points gained
/// 5.5e3 J of kinetic energy in `consolidation_large` (76.6 J with this threshold, as with
/// order reduction), and with the adjoint strain, which feeds the force back to the
/// neighbour's particles that made the virtual point, the column's free top blew up on
/// 200 and 400 cells. `3e-3` still failed the consolidation; `1e-2` and `3e-2` gave the
/// same results.
pub const REPAIR_MIN_SPREAD: f64 = 1e-2;

/// `S_i = (1/2) int_{-1}^{1} psi_i(s)^2 ds`: the mean square of each Taylor function over
/// evenly spread points.
const EVEN_MOMENTS: [f64; 3] = [1.0, 1.0 / 3.0, 1.0 / 45.0];

/// The Taylor basis of one interval.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TaylorCell {
    pub centre: f64,
    pub half_width: f64,
    inv_half_width: f64,
}

impl TaylorCell {
    /// The basis on `[lo, hi]`, `hi > lo`.
    pub fn new(lo: f64, hi: f64) -> Self {
        let half_width = 0.5 * (hi - lo);
        Self {
            centre: 0.5 * (lo + hi),
            half_width,
            inv_half_width: 1.0 / half_width,
        }
    }

    /// `[psi_1, psi_2, psi_3](x)`.
    ///
    /// ```
    /// use tlsmpm::numerics::taylor::TaylorCell;
    /// let cell = TaylorCell::new(0.0, 2.0);
    /// assert_eq!(cell.psi(2.0), [1.0, 1.0, 0.5 - 1.0 / 6.0]);
    /// ```
    #[inline]
    pub fn psi(&self, x: f64) -> [f64; 3] {
        let s = (x - self.centre) * self.inv_half_width;
        [1.0, s, 0.5 * s * s - 1.0 / 6.0]
    }

    /// `sum_i a_i psi_i(x)`.
    #[inline]
    pub fn eval(&self, a: &[f64; 3], x: f64) -> f64 {
        let psi = self.psi(x);
        a[0] + a[1] * psi[1] + a[2] * psi[2]
    }
}

/// The symmetric normal matrix `D = sum w psi psi^T` of one interval (upper triangle used).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NormalMatrix {
    pub d: [[f64; 3]; 3],
    /// Points added.
    pub count: usize,
    /// Sum of the weights of the points added (`count` when every weight is 1): the
    /// well-posedness test of [`solve`] scales with it.
    pub weight: f64,
}

impl NormalMatrix {
    /// Add the point with basis values `psi` (weight 1).
    #[inline]
    pub fn add(&mut self, psi: &[f64; 3]) {
        self.add_weighted(psi, 1.0);
    }

    /// Add the point with basis values `psi` and weight `w > 0` (its right-hand side then
    /// takes `w psi value`, [`add_rhs`] with `w value`).
    ///
    /// ```
    /// use tlsmpm::numerics::taylor::NormalMatrix;
    /// let (mut once, mut twice) = (NormalMatrix::default(), NormalMatrix::default());
    /// once.add_weighted(&[1.0, 0.5, 0.0], 2.0);
    /// twice.add(&[1.0, 0.5, 0.0]);
    /// twice.add(&[1.0, 0.5, 0.0]);
    /// assert_eq!(once.d, twice.d);
    /// assert_eq!(once.weight, twice.weight);
    /// ```
    #[inline]
    pub fn add_weighted(&mut self, psi: &[f64; 3], w: f64) {
        for i in 0..3 {
            for j in i..3 {
                self.d[i][j] += w * psi[i] * psi[j];
            }
        }
        self.count += 1;
        self.weight += w;
    }
}

/// Add `psi * value` to a right-hand side.
#[inline]
pub fn add_rhs(rhs: &mut [f64; 3], psi: &[f64; 3], value: f64) {
    for i in 0..3 {
        rhs[i] += psi[i] * value;
    }
}

/// Which coefficients are unknown.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FitKind {
    /// All of `a_1..a_terms`.
    Full,
    /// `a_1` fixed to the given value; `a_2..a_terms` fitted.
    Conservative(f64),
}

/// Fit the first `terms` (1..=3) Taylor functions; `None` if the normal-equation block is
/// not well posed (see the module doc). Unused coefficients are 0.
pub fn solve(
    normal: &NormalMatrix,
    rhs: &[f64; 3],
    kind: FitKind,
    terms: usize,
) -> Option<[f64; 3]> {
    solve_with_spread(normal, rhs, kind, terms, MIN_SPREAD)
}

/// [`solve`] with the smallest accepted scaled pivot `spread` instead of [`MIN_SPREAD`]
/// (for example [`REPAIR_MIN_SPREAD`]).
///
/// ```
/// use tlsmpm::numerics::taylor::{
///     add_rhs, solve_with_spread, FitKind, NormalMatrix, TaylorCell, MIN_SPREAD,
///     REPAIR_MIN_SPREAD,
/// };
/// // Two points 4% of the cell apart near its left face: a slope through them is
/// // accepted by the plain test and refused by the repair test.
/// let cell = TaylorCell::new(0.0, 1.0);
/// let mut normal = NormalMatrix::default();
/// let mut rhs = [0.0; 3];
/// for (x, u) in [(0.0, 1.0), (0.04, 2.0)] {
///     let psi = cell.psi(x);
///     normal.add(&psi);
///     add_rhs(&mut rhs, &psi, u);
/// }
/// assert!(solve_with_spread(&normal, &rhs, FitKind::Full, 2, MIN_SPREAD).is_some());
/// assert!(solve_with_spread(&normal, &rhs, FitKind::Full, 2, REPAIR_MIN_SPREAD).is_none());
/// ```
pub fn solve_with_spread(
    normal: &NormalMatrix,
    rhs: &[f64; 3],
    kind: FitKind,
    terms: usize,
    spread: f64,
) -> Option<[f64; 3]> {
    let mut a = [0.0; 3];
    let first = match kind {
        FitKind::Full => 0,
        FitKind::Conservative(a1) => {
            a[0] = a1;
            1
        }
    };
    let n = terms.saturating_sub(first);
    if n == 0 {
        return Some(a);
    }
    // The block D[first..terms, first..terms], its right-hand side r - a_1 D[.., 1], and
    // the pivot thresholds: a pivot of the scaled block W D W (W = diag(1/sqrt(n S_i))) is
    // the pivot of D divided by n S_i, so no scaling is needed.
    let count = normal.weight.max(1.0);
    let mut m = [[0.0; 3]; 3];
    let mut b = [0.0; 3];
    let mut threshold = [0.0; 3];
    for i in 0..n {
        for (j, entry) in m[i].iter_mut().enumerate().take(n) {
            let (r, c) = (first + i.min(j), first + i.max(j));
            *entry = normal.d[r][c];
        }
        let fixed = if first == 1 {
            a[0] * normal.d[0][1 + i]
        } else {
            0.0
        };
        b[i] = rhs[first + i] - fixed;
        threshold[i] = spread * count * EVEN_MOMENTS[first + i];
    }
    // Fixed sizes, so that the factorisation loops unroll.
    let x = match n {
        1 => solve_ldl::<1>(&m, &b, &threshold)?,
        2 => solve_ldl::<2>(&m, &b, &threshold)?,
        _ => solve_ldl::<3>(&m, &b, &threshold)?,
    };
    a[first..first + n].copy_from_slice(&x[..n]);
    Some(a)
}

/// [`solve`] with `terms = 3`, dropping `psi_3` and then `psi_2` until the block is well
/// conditioned (order reduction, SPEC §4.1). Returns the coefficients and the number of
/// terms used. With no usable point the fit is the constant `a_1` (0 for a full fit).
pub fn solve_reduced(normal: &NormalMatrix, rhs: &[f64; 3], kind: FitKind) -> ([f64; 3], usize) {
    solve_reduced_from(normal, rhs, kind, 3)
}

/// [`solve_reduced`] starting from `terms` (1..=3) functions instead of 3: the fit of
/// total degree at most `terms - 1` (`method.conservative_degree`).
///
/// ```
/// use tlsmpm::numerics::taylor::{solve_reduced_from, FitKind, NormalMatrix, TaylorCell};
/// let cell = TaylorCell::new(0.0, 1.0);
/// let mut normal = NormalMatrix::default();
/// let mut rhs = [0.0; 3];
/// for x in [0.1, 0.4, 0.6, 0.9] {
///     let psi = cell.psi(x);
///     normal.add(&psi);
///     tlsmpm::numerics::taylor::add_rhs(&mut rhs, &psi, x * x);
/// }
/// let (a, terms) = solve_reduced_from(&normal, &rhs, FitKind::Conservative(1.0 / 3.0), 2);
/// assert_eq!((terms, a[2]), (2, 0.0));
/// ```
pub fn solve_reduced_from(
    normal: &NormalMatrix,
    rhs: &[f64; 3],
    kind: FitKind,
    terms: usize,
) -> ([f64; 3], usize) {
    solve_reduced_with_spread(normal, rhs, kind, terms, MIN_SPREAD)
}

/// [`solve_reduced_from`] with the smallest accepted scaled pivot `spread` at every order.
pub fn solve_reduced_with_spread(
    normal: &NormalMatrix,
    rhs: &[f64; 3],
    kind: FitKind,
    terms: usize,
    spread: f64,
) -> ([f64; 3], usize) {
    for terms in (1..=terms.min(3)).rev() {
        if let Some(a) = solve_with_spread(normal, rhs, kind, terms, spread) {
            return (a, terms);
        }
    }
    let a1 = match kind {
        FitKind::Full => 0.0,
        FitKind::Conservative(a1) => a1,
    };
    ([a1, 0.0, 0.0], 1)
}

/// Solve the `N x N` (N <= 3) SPD system `m x = b` by `L D L^T` (no square roots); `None`
/// if a pivot `d_i` is below `threshold[i]` or not a number.
#[inline]
fn solve_ldl<const N: usize>(
    m: &[[f64; 3]; 3],
    b: &[f64; 3],
    threshold: &[f64; 3],
) -> Option<[f64; 3]> {
    let mut l = [[0.0; 3]; 3];
    let mut d = [0.0; 3];
    let mut inv_d = [0.0; 3];
    for i in 0..N {
        for j in 0..i {
            let mut s = m[i][j];
            for k in 0..j {
                s -= l[i][k] * l[j][k] * d[k];
            }
            l[i][j] = s * inv_d[j];
        }
        let mut pivot = m[i][i];
        for k in 0..i {
            pivot -= l[i][k] * l[i][k] * d[k];
        }
        if pivot.is_nan() || pivot < threshold[i] {
            return None;
        }
        d[i] = pivot;
        inv_d[i] = 1.0 / pivot;
    }
    let mut x = [0.0; 3];
    for i in 0..N {
        let mut s = b[i];
        for k in 0..i {
            s -= l[i][k] * x[k];
        }
        x[i] = s;
    }
    for i in 0..N {
        x[i] *= inv_d[i];
    }
    for i in (0..N).rev() {
        let mut s = x[i];
        for k in i + 1..N {
            s -= l[k][i] * x[k];
        }
        x[i] = s;
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn normal_of(cell: &TaylorCell, points: &[(f64, f64)]) -> (NormalMatrix, [f64; 3]) {
        let mut normal = NormalMatrix::default();
        let mut rhs = [0.0; 3];
        for &(x, u) in points {
            let psi = cell.psi(x);
            normal.add(&psi);
            add_rhs(&mut rhs, &psi, u);
        }
        (normal, rhs)
    }

    #[test]
    fn taylor_functions_beyond_the_first_integrate_to_zero() {
        let cell = TaylorCell::new(1.0, 4.0);
        let rule = crate::numerics::gauss::GaussRule::new(2).unwrap();
        let integrals = rule.mapped(1.0, 4.0).fold([0.0; 3], |mut acc, (x, w)| {
            for (a, p) in acc.iter_mut().zip(cell.psi(x)) {
                *a += w * p;
            }
            acc
        });
        assert!((integrals[0] - 3.0).abs() < 1e-14);
        assert!(
            integrals[1].abs() < 1e-14 && integrals[2].abs() < 1e-14,
            "{integrals:?}"
        );
    }

    #[test]
    fn two_points_are_degenerate_for_three_terms_and_reduce_to_a_line() {
        let cell = TaylorCell::new(0.0, 1.0);
        let (normal, rhs) = normal_of(&cell, &[(0.2, 1.0), (0.7, 2.0)]);
        assert!(solve(&normal, &rhs, FitKind::Full, 3).is_none());
        let (a, terms) = solve_reduced(&normal, &rhs, FitKind::Full);
        assert_eq!(terms, 2);
        assert!((cell.eval(&a, 0.2) - 1.0).abs() < 1e-12);
        assert!((cell.eval(&a, 0.7) - 2.0).abs() < 1e-12);
        // No point at all: the conservative fit keeps a_1.
        let (a, terms) = solve_reduced(
            &NormalMatrix::default(),
            &[0.0; 3],
            FitKind::Conservative(3.0),
        );
        assert_eq!((a, terms), ([3.0, 0.0, 0.0], 1));
        // One point near the centre cannot carry a slope: a conservative fit stays constant
        // instead of extrapolating (value - a_1) / s over the cell.
        let (normal, rhs) = normal_of(&cell, &[(0.505, 7.0)]);
        let (a, terms) = solve_reduced(&normal, &rhs, FitKind::Conservative(2.0));
        assert_eq!((a, terms), ([2.0, 0.0, 0.0], 1));
        // Near the face it can.
        let (normal, rhs) = normal_of(&cell, &[(0.95, 7.0)]);
        let (a, terms) = solve_reduced(&normal, &rhs, FitKind::Conservative(2.0));
        assert_eq!(terms, 2);
        assert!((cell.eval(&a, 0.95) - 7.0).abs() < 1e-12);
    }

    #[test]
    fn evenly_spread_points_have_unit_scaled_moments() {
        // The midpoint rule with many points approximates the even moments.
        let cell = TaylorCell::new(-1.0, 1.0);
        let n = 2000;
        let points: Vec<(f64, f64)> = (0..n)
            .map(|k| (-1.0 + (k as f64 + 0.5) * 2.0 / n as f64, 0.0))
            .collect();
        let (normal, _) = normal_of(&cell, &points);
        for (i, moment) in EVEN_MOMENTS.iter().enumerate() {
            let scaled = normal.d[i][i] / (n as f64 * moment);
            assert!((scaled - 1.0).abs() < 1e-5, "{i}: {scaled}");
        }
    }

    proptest! {
        /// A quadratic is reproduced exactly by the full fit from 3+ distinct points, and
        /// the conservative fit with `a_1` = its cell mean reproduces it too.
        #[test]
        fn quadratics_are_reproduced(lo in -5.0f64..5.0, width in 0.1f64..3.0,
                                     c in prop::array::uniform3(-2.0f64..2.0),
                                     t in prop::collection::vec(0.0f64..1.0, 3..12)) {
            let hi = lo + width;
            let cell = TaylorCell::new(lo, hi);
            let f = |x: f64| c[0] + c[1] * x + c[2] * x * x;
            let mut xs: Vec<f64> = t.iter().map(|t| lo + t * width).collect();
            xs.sort_by(f64::total_cmp);
            xs.dedup_by(|a, b| (*a - *b).abs() < 1e-3 * width);
            prop_assume!(xs.len() >= 3);
            let spread = xs[xs.len() - 1] - xs[0];
            prop_assume!(spread > 0.2 * width);
            let points: Vec<(f64, f64)> = xs.iter().map(|&x| (x, f(x))).collect();
            let (normal, rhs) = normal_of(&cell, &points);
            if let Some(a) = solve(&normal, &rhs, FitKind::Full, 3) {
                for x in [lo, 0.5 * (lo + hi), hi] {
                    prop_assert!((cell.eval(&a, x) - f(x)).abs() < 1e-8 * (1.0 + f(x).abs()));
                }
                // Cell mean of the quadratic.
                let mean = c[0] + c[1] * 0.5 * (lo + hi) + c[2] * (hi.powi(3) - lo.powi(3)) / (3.0 * width);
                let b = solve(&normal, &rhs, FitKind::Conservative(mean), 3).unwrap();
                prop_assert_eq!(b[0], mean);
                for x in [lo, hi] {
                    prop_assert!((cell.eval(&b, x) - f(x)).abs() < 1e-8 * (1.0 + f(x).abs()));
                }
            }
        }
    }
}
