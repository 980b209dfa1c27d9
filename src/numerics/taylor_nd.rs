//! Taylor least squares on a box in `D` = 1, 2, 3 dimensions (`docs/tls.md`, 2D/3D
//! section): the Taylor basis of total degree `q <= 2`, and the small SPD solves of its
//! normal equations with the scaled-pivot well-posedness test of the 1D fits
//! ([`crate::numerics::taylor`]).
//!
//! On a box with centre `c` and half widths `d_a`, with `s_a = (x_a - c_a) / d_a`, the
//! terms are, in this order,
//!
//! ```text
//! q = 0:  1
//! q = 1:  s_1, ..., s_D
//! q = 2:  for a <= b:  s_a^2 / 2 - 1/6  (a = b),   s_a s_b  (a < b)
//! ```
//!
//! (1 / 3 / 6 terms in 1D, 1 / 3 / 6 in 2D, 1 / 4 / 10 in 3D). Every term but the first has
//! zero mean over the box, so `int_box sum_i a_i T_i = a_1 |box|` whatever the other
//! coefficients are: fixing `a_1 = c / |box|` conserves the total `c` (a *conservative*
//! fit), exactly as in 1D. In 1D the terms are the 1D ones bitwise.
//!
//! **Well-posedness.** With `n` points, the pivot `k` of the `L D L^T` factorisation of the
//! fitted block must be at least `MIN_SPREAD n S_k`, where `S_k` is the mean square of term
//! `k` over evenly spread points (`1`, `1/3` for `s_a`, `1/45` for `s_a^2/2 - 1/6`, `1/9`
//! for `s_a s_b`). Points all on one line of a 2D cell, or fewer points than terms, fail
//! it; the fit then drops the degree-2 terms, then the degree-1 terms ([`fit_degree`]).

// Index loops: the indices enter the formulas (terms, axes, LDL^T rows).
#![allow(clippy::needless_range_loop)]

use super::taylor::MIN_SPREAD;

/// The most terms of a fit (total degree 2 in 3D).
pub const MAX_TERMS: usize = 10;

/// Number of Taylor terms of total degree `q` (0, 1, 2) in `d` dimensions.
///
/// ```
/// use tlsmpm::numerics::taylor_nd::terms;
/// assert_eq!([terms(1, 2), terms(2, 2), terms(3, 2), terms(3, 1)], [3, 6, 10, 4]);
/// ```
pub const fn terms(d: usize, q: usize) -> usize {
    match q {
        0 => 1,
        1 => 1 + d,
        _ => 1 + d + d * (d + 1) / 2,
    }
}

/// Mean square `S_k` of each term over evenly spread points (see the module doc).
fn even_moments<const D: usize>() -> [f64; MAX_TERMS] {
    let mut s = [0.0; MAX_TERMS];
    s[0] = 1.0;
    for v in s.iter_mut().skip(1).take(D) {
        *v = 1.0 / 3.0;
    }
    let mut k = 1 + D;
    for a in 0..D {
        for b in a..D {
            s[k] = if a == b { 1.0 / 45.0 } else { 1.0 / 9.0 };
            k += 1;
        }
    }
    s
}

/// The Taylor basis of one box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TaylorBox<const D: usize> {
    pub centre: [f64; D],
    pub half_width: [f64; D],
    inv_half_width: [f64; D],
}

impl<const D: usize> TaylorBox<D> {
    /// The basis on `[lo_a, hi_a]` per axis (`hi > lo`).
    pub fn new(lo: [f64; D], hi: [f64; D]) -> Self {
        let half_width: [f64; D] = std::array::from_fn(|a| 0.5 * (hi[a] - lo[a]));
        Self {
            centre: std::array::from_fn(|a| 0.5 * (lo[a] + hi[a])),
            half_width,
            inv_half_width: std::array::from_fn(|a| 1.0 / half_width[a]),
        }
    }

    /// The scaled coordinates `s_a(x)`.
    #[inline(always)]
    pub fn scaled(&self, x: [f64; D]) -> [f64; D] {
        std::array::from_fn(|a| (x[a] - self.centre[a]) * self.inv_half_width[a])
    }

    /// All [`terms`]`(D, 2)` terms at `x` (the rest of the array is 0).
    ///
    /// ```
    /// use tlsmpm::numerics::taylor_nd::TaylorBox;
    /// let cell = TaylorBox::new([0.0, 0.0], [2.0, 2.0]);
    /// let t = cell.terms([2.0, 1.0]);
    /// assert_eq!(&t[..6], &[1.0, 1.0, 0.0, 0.5 - 1.0 / 6.0, 0.0, -1.0 / 6.0]);
    /// ```
    #[inline(always)]
    pub fn terms(&self, x: [f64; D]) -> [f64; MAX_TERMS] {
        terms_of(self.scaled(x))
    }

    /// `sum_i a_i T_i(x)`.
    #[inline(always)]
    pub fn eval(&self, a: &[f64], x: [f64; D]) -> f64 {
        let t = self.terms(x);
        let mut value = a[0];
        for k in 1..terms(D, 2) {
            value += a[k] * t[k];
        }
        value
    }
}

/// The terms at scaled coordinates `s`.
#[inline(always)]
pub fn terms_of<const D: usize>(s: [f64; D]) -> [f64; MAX_TERMS] {
    let mut t = [0.0; MAX_TERMS];
    t[0] = 1.0;
    t[1..=D].copy_from_slice(&s);
    let mut k = 1 + D;
    for a in 0..D {
        for b in a..D {
            t[k] = if a == b {
                0.5 * s[a] * s[a] - 1.0 / 6.0
            } else {
                s[a] * s[b]
            };
            k += 1;
        }
    }
    t
}

/// The symmetric normal matrix `sum_p T(x_p) T(x_p)^T` of one box (upper triangle of the
/// first [`terms`]`(D, 2)` rows used) and the number of points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NormalMatrix<const D: usize> {
    pub d: [[f64; MAX_TERMS]; MAX_TERMS],
    pub count: usize,
}

impl<const D: usize> Default for NormalMatrix<D> {
    fn default() -> Self {
        Self {
            d: [[0.0; MAX_TERMS]; MAX_TERMS],
            count: 0,
        }
    }
}

impl<const D: usize> NormalMatrix<D> {
    /// Add the point with terms `t`.
    #[inline(always)]
    pub fn add(&mut self, t: &[f64; MAX_TERMS]) {
        let n = terms(D, 2);
        for i in 0..n {
            for j in i..n {
                self.d[i][j] += t[i] * t[j];
            }
        }
        self.count += 1;
    }
}

/// Add `t * value` to a right-hand side.
#[inline(always)]
pub fn add_rhs<const D: usize>(rhs: &mut [f64; MAX_TERMS], t: &[f64; MAX_TERMS], value: f64) {
    for i in 0..terms(D, 2) {
        rhs[i] += t[i] * value;
    }
}

/// The `L D L^T` factor of the block `first..terms` of a normal matrix (`first` = 0 for a
/// full fit, 1 for a conservative one).
#[derive(Clone, Copy, Debug)]
pub struct Factor {
    first: usize,
    terms: usize,
    /// The strictly lower triangle of `L`, row by row: `L[i][k]` at `i (i - 1) / 2 + k`.
    l: [f64; PACKED],
    inv_d: [f64; MAX_TERMS],
}

/// Entries of the strictly lower triangle of a `MAX_TERMS` square.
const PACKED: usize = MAX_TERMS * (MAX_TERMS - 1) / 2;

/// Position of `L[i][k]`, `k < i`, in [`Factor::l`].
#[inline(always)]
fn packed(i: usize, k: usize) -> usize {
    i * (i - 1) / 2 + k
}

impl Default for Factor {
    /// An empty factor (no terms: every coefficient 0), to be filled by [`fit_degree`].
    fn default() -> Self {
        Self {
            first: 0,
            terms: 0,
            l: [0.0; PACKED],
            inv_d: [0.0; MAX_TERMS],
        }
    }
}

impl Factor {
    /// Taylor terms the fit uses.
    pub fn terms(&self) -> usize {
        self.terms
    }

    /// The coefficients `a` of the fit to the right-hand side `rhs`; for a conservative
    /// factor `a_1 = a1` is fixed and `normal` gives the coupling `D[1.., 0]`. Unfitted
    /// coefficients are 0.
    #[inline]
    pub fn solve<const D: usize>(
        &self,
        normal: &NormalMatrix<D>,
        rhs: &[f64; MAX_TERMS],
        a1: f64,
    ) -> [f64; MAX_TERMS] {
        let mut a = [0.0; MAX_TERMS];
        let (first, n) = (self.first, self.terms - self.first);
        if first == 1 {
            a[0] = a1;
        }
        // Solved in place in the fitted coefficients (no copy afterwards).
        let x = &mut a[first..];
        for i in 0..n {
            let fixed = if first == 1 {
                a1 * normal.d[0][1 + i]
            } else {
                0.0
            };
            let mut s = rhs[first + i] - fixed;
            for k in 0..i {
                s -= self.l[packed(i, k)] * x[k];
            }
            x[i] = s;
        }
        for i in 0..n {
            x[i] *= self.inv_d[i];
        }
        for i in (0..n).rev() {
            let mut s = x[i];
            for k in i + 1..n {
                s -= self.l[packed(k, i)] * x[k];
            }
            x[i] = s;
        }
        a
    }
}

/// Factor the block `first..terms` of `normal`; `None` if a pivot fails the
/// well-posedness test (see the module doc) or is not a number.
pub fn factor<const D: usize>(
    normal: &NormalMatrix<D>,
    first: usize,
    terms: usize,
) -> Option<Factor> {
    let mut f = Factor::default();
    let passed = factor_prefix(normal, first, terms, &mut f);
    (passed == terms.saturating_sub(first)).then_some(f)
}

/// Factor the block `first..terms` of `normal` row by row up to the first pivot that
/// fails the test, into `f` (in place: a factor is 57 numbers, and moving it out of the
/// per-cell fits cost a `memmove` per fit); returns the number of rows that passed. The
/// factor of a leading block is the leading block of the factor, so the rows that passed
/// are the factor of every smaller degree (bitwise: row `i` uses only rows `< i`). Only the
/// entries of the rows that passed are read later, so `f`'s other entries are not cleared.
fn factor_prefix<const D: usize>(
    normal: &NormalMatrix<D>,
    first: usize,
    terms: usize,
    f: &mut Factor,
) -> usize {
    let moments = even_moments::<D>();
    let count = normal.count.max(1) as f64;
    let n = terms.saturating_sub(first);
    f.first = first;
    f.terms = terms;
    let mut d = [0.0; MAX_TERMS];
    let entry = |i: usize, j: usize| {
        let (r, c) = (first + i.min(j), first + i.max(j));
        normal.d[r][c]
    };
    for i in 0..n {
        for j in 0..i {
            let mut s = entry(i, j);
            for k in 0..j {
                s -= f.l[packed(i, k)] * f.l[packed(j, k)] * d[k];
            }
            f.l[packed(i, j)] = s * f.inv_d[j];
        }
        let mut pivot = entry(i, i);
        for k in 0..i {
            pivot -= f.l[packed(i, k)] * f.l[packed(i, k)] * d[k];
        }
        if pivot.is_nan() || pivot < MIN_SPREAD * count * moments[first + i] {
            return i;
        }
        d[i] = pivot;
        f.inv_d[i] = 1.0 / pivot;
    }
    n
}

/// The factor of the highest degree `q <= max_degree` whose block passes the test, for a
/// full (`conservative = false`) or conservative fit, from one factorisation of the
/// largest block. A conservative fit of degree 0 has nothing to fit and always succeeds; a
/// full fit without points falls back to an empty factor (all coefficients 0).
///
/// The factor goes into `f`, which may be reused from an earlier fit (the per-cell fits keep
/// one per task): what the earlier fit left there is never read. Returns the degree.
#[inline]
pub fn fit_degree<const D: usize>(
    normal: &NormalMatrix<D>,
    conservative: bool,
    max_degree: usize,
    f: &mut Factor,
) -> usize {
    let first = usize::from(conservative);
    let passed = factor_prefix(normal, first, terms(D, max_degree), f);
    for q in (0..=max_degree).rev() {
        if terms(D, q) - first <= passed {
            f.terms = terms(D, q);
            return q;
        }
    }
    f.terms = first;
    0
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// [`fit_degree`] into a fresh factor.
    fn fitted<const D: usize>(
        normal: &NormalMatrix<D>,
        conservative: bool,
        max_degree: usize,
    ) -> (Factor, usize) {
        let mut f = Factor::default();
        let q = fit_degree(normal, conservative, max_degree, &mut f);
        (f, q)
    }

    fn polynomial<const D: usize>(cell: &TaylorBox<D>, coefficients: &[f64], x: [f64; D]) -> f64 {
        cell.eval(coefficients, x)
    }

    #[test]
    fn every_term_but_the_first_has_zero_mean_over_the_box() {
        // Gauss–Legendre 3-point rule per axis integrates degree 2 exactly.
        let rule = crate::numerics::gauss::GaussRule::new(3).unwrap();
        let cell = TaylorBox::new([0.5, -1.0, 2.0], [1.5, 0.0, 2.5]);
        let mut mean = [0.0; MAX_TERMS];
        for (x, wx) in rule.mapped(0.5, 1.5) {
            for (y, wy) in rule.mapped(-1.0, 0.0) {
                for (z, wz) in rule.mapped(2.0, 2.5) {
                    let t = cell.terms([x, y, z]);
                    for k in 0..10 {
                        mean[k] += wx * wy * wz * t[k];
                    }
                }
            }
        }
        assert!((mean[0] - 0.5).abs() < 1e-15);
        for m in &mean[1..10] {
            assert!(m.abs() < 1e-15, "{mean:?}");
        }
    }

    #[test]
    fn one_dimensional_terms_are_the_1d_taylor_functions() {
        let box1 = TaylorBox::<1>::new([0.3], [0.7]);
        let cell = crate::numerics::taylor::TaylorCell::new(0.3, 0.7);
        for x in [0.3, 0.41, 0.5, 0.69] {
            assert_eq!(&box1.terms([x])[..3], &cell.psi(x)[..]);
        }
    }

    #[test]
    fn points_on_one_line_reduce_the_degree() {
        let cell = TaylorBox::new([0.0, 0.0], [1.0, 1.0]);
        let mut normal = NormalMatrix::<2>::default();
        for x in [0.1, 0.3, 0.5, 0.7, 0.9, 0.95, 0.2] {
            normal.add(&cell.terms([x, 0.5]));
        }
        // All at y = 0.5: no y information, even for the linear terms.
        assert_eq!(fitted(&normal, false, 2).1, 0);
        assert_eq!(fitted(&normal, true, 2).1, 0);
        let mut normal = NormalMatrix::<2>::default();
        for (x, y) in [(0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75)] {
            normal.add(&cell.terms([x, y]));
        }
        // Four points: linear but not quadratic.
        assert_eq!(fitted(&normal, false, 2).1, 1);
        assert_eq!(fitted(&normal, true, 2).1, 1);
    }

    proptest! {
        /// A fit of a polynomial of the fitted degree reproduces it (full and
        /// conservative with the exact mean), with enough well spread points.
        #[test]
        fn fits_reproduce_quadratics(
            c in proptest::collection::vec(-2.0f64..2.0, 10),
            jitter in proptest::collection::vec(-0.1f64..0.1, 81),
        ) {
            let cell = TaylorBox::new([1.0, 2.0, 0.0], [1.5, 3.0, 0.25]);
            let mut normal = NormalMatrix::<3>::default();
            let mut rhs = [0.0; MAX_TERMS];
            let mut k = 0;
            for i in 0..3 {
                for j in 0..3 {
                    for l in 0..3 {
                        let s = [
                            -0.6 + 0.6 * i as f64 + jitter[k],
                            -0.6 + 0.6 * j as f64 + jitter[k + 1],
                            -0.6 + 0.6 * l as f64 + jitter[k + 2],
                        ];
                        k += 3;
                        let x = std::array::from_fn(|a| cell.centre[a] + s[a] * cell.half_width[a]);
                        let t = cell.terms(x);
                        normal.add(&t);
                        add_rhs::<3>(&mut rhs, &t, polynomial(&cell, &c, x));
                    }
                }
            }
            let (full, q) = fitted(&normal, false, 2);
            prop_assert_eq!(q, 2);
            let a = full.solve(&normal, &rhs, 0.0);
            for i in 0..10 {
                prop_assert!((a[i] - c[i]).abs() < 1e-9, "full {i}: {} vs {}", a[i], c[i]);
            }
            let (cons, q) = fitted(&normal, true, 2);
            prop_assert_eq!(q, 2);
            let a = cons.solve(&normal, &rhs, c[0]);
            for i in 0..10 {
                prop_assert!((a[i] - c[i]).abs() < 1e-9, "conservative {i}");
            }
        }

        /// A factor reused from a full quadratic fit gives bit for bit the fit of a fresh
        /// one for the next cell, also when that cell is degenerate (1-3 points, or all
        /// on one line) and its degree drops.
        #[test]
        fn a_reused_factor_fits_as_a_fresh_one(
            spread in proptest::collection::vec((-1.0f64..1.0, -1.0f64..1.0), 6..20),
            next in proptest::collection::vec((-1.0f64..1.0, -1.0f64..1.0), 1..8),
            on_line in proptest::bool::ANY,
            values in proptest::collection::vec(-2.0f64..2.0, 8),
        ) {
            let cell = TaylorBox::new([0.0, 0.0], [1.0, 1.0]);
            let point = |(s, r): (f64, f64)| [0.5 + 0.5 * s, 0.5 + 0.5 * r];
            let mut first = NormalMatrix::<2>::default();
            for &p in &spread {
                first.add(&cell.terms(point(p)));
            }
            let mut normal = NormalMatrix::<2>::default();
            let mut rhs = [0.0; MAX_TERMS];
            for (i, &(s, r)) in next.iter().enumerate() {
                let x = point((s, if on_line { 0.3 } else { r }));
                let t = cell.terms(x);
                normal.add(&t);
                add_rhs::<2>(&mut rhs, &t, values[i]);
            }
            for conservative in [false, true] {
                let mut reused = Factor::default();
                fit_degree(&first, conservative, 2, &mut reused);
                let q_reused = fit_degree(&normal, conservative, 2, &mut reused);
                let (fresh, q_fresh) = fitted(&normal, conservative, 2);
                prop_assert_eq!(q_reused, q_fresh);
                let a = reused.solve(&normal, &rhs, 0.7);
                let b = fresh.solve(&normal, &rhs, 0.7);
                for i in 0..MAX_TERMS {
                    prop_assert_eq!(a[i].to_bits(), b[i].to_bits(), "coefficient {}", i);
                }
            }
        }
    }
}
