//! B-splines of any degree on an open uniform knot vector (SPEC §3.4).
//!
//! In parametric units (one unit per knot span) the open uniform knot vector of `spans`
//! spans and degree `p` is
//!
//! ```text
//! U = [0, ..., 0, 1, 2, ..., spans - 1, spans, ..., spans]     (0 and spans repeated p + 1 times)
//! U_k = clamp(k - p, 0, spans),   k = 0 .. spans + 2p
//! ```
//!
//! with `spans + p` functions `N_{i,p}`. On span `e` (`e <= u < e + 1`) the non-zero
//! functions are `N_{e..=e+p, p}`. They are computed together by de Boor's triangular
//! scheme (Piegl & Tiller, Algorithm A2.2): the degree-`j` values follow from the
//! degree-`j-1` ones,
//!
//! ```text
//! N_{i,j}(u) = (u - U_i)/(U_{i+j} - U_i) N_{i,j-1} + (U_{i+j+1} - u)/(U_{i+j+1} - U_{i+1}) N_{i+1,j-1}
//! ```
//!
//! in `O(p^2)` flops and two small stack arrays, and the derivatives from the degree
//! `p - 1` values of the last level,
//!
//! ```text
//! dN_{i,p}/du = p N_{i,p-1} / (U_{i+p} - U_i) - p N_{i+1,p-1} / (U_{i+p+1} - U_{i+1}).
//! ```
//!
//! All denominators that occur on a non-empty span are at least 1, so there is no `0/0`.
//! On interior spans (all knots involved simple) the level-`j` denominators are all `j`
//! and the derivative ones `p`, and a division-free fast path is taken.
//! Knots are small integers, so they are exact in floating point.

/// Highest degree supported by [`open_uniform`] (the stack arrays hold `MAX_DEGREE + 1`).
pub const MAX_DEGREE: usize = 15;

/// Knot `U_k` of the open uniform knot vector of degree `degree` with `spans` spans.
#[inline]
fn knot(k: usize, degree: usize, spans: usize) -> f64 {
    (k.saturating_sub(degree)).min(spans) as f64
}

/// [`open_uniform`] for a degree `P` known at compile time: on interior spans the same
/// operations in the same order (so bitwise the same values), unrolled and without the
/// runtime-length copies; other spans take [`open_uniform`] itself.
///
/// ```
/// use tlsmpm::numerics::bspline::{open_uniform, open_uniform_fixed};
/// let (mut n, mut dn, mut m, mut dm) = ([0.0; 3], [0.0; 3], [0.0; 3], [0.0; 3]);
/// open_uniform(2, 8, 3, 3.3, &mut n, &mut dn);
/// open_uniform_fixed::<2>(8, 3, 3.3, &mut m, &mut dm);
/// assert_eq!((n, dn), (m, dm));
/// ```
#[inline(always)]
#[allow(clippy::needless_range_loop)] // `r` and `j` enter the formulas, as in `open_uniform`
pub fn open_uniform_fixed<const P: usize>(
    spans: usize,
    span: usize,
    u: f64,
    values: &mut [f64],
    derivatives: &mut [f64],
) {
    if !(P >= 1 && P <= MAX_DEGREE && span + 1 >= P && span + P <= spans) {
        return open_uniform(P, spans, span, u, values, derivatives);
    }
    let values = &mut values[..=P];
    let derivatives = &mut derivatives[..=P];
    let mut lower = [0.0; P];
    let t = u - super::index_as_f64(span);
    values[0] = 1.0;
    for j in 1..=P {
        if j == P {
            lower[..P].copy_from_slice(&values[..P]);
        }
        let inv_j = INVERSE[j];
        let mut saved = 0.0;
        for r in 0..j {
            let temp = values[r] * inv_j;
            values[r] = saved + (r as f64 + 1.0 - t) * temp;
            saved = (t + (j - r) as f64 - 1.0) * temp;
        }
        values[j] = saved;
    }
    for k in 0..=P {
        let below = if k >= 1 { lower[k - 1] } else { 0.0 };
        let here = if k < P { lower[k] } else { 0.0 };
        derivatives[k] = below - here;
    }
}

/// Values and `u`-derivatives of the `degree + 1` non-zero B-splines at parameter `u` of
/// span `span` (`span <= u <= span + 1`; the right end `u = spans` belongs to the last
/// span). `values[k]`, `derivatives[k]` belong to function `span + k`, `k = 0..=degree`.
///
/// ```
/// use tlsmpm::numerics::bspline::open_uniform;
/// let (mut n, mut dn) = ([0.0; 3], [0.0; 3]);
/// // Quadratic B-splines on 4 spans, interior span 1 at its midpoint.
/// open_uniform(2, 4, 1, 1.5, &mut n, &mut dn);
/// assert!((n[0] - 0.125).abs() < 1e-15 && (n[1] - 0.75).abs() < 1e-15);
/// assert!((n.iter().sum::<f64>() - 1.0).abs() < 1e-15);
/// assert!(dn.iter().sum::<f64>().abs() < 1e-15);
/// ```
///
/// # Panics
/// If `degree > MAX_DEGREE`, `span >= spans` or the slices are shorter than `degree + 1`
/// (programming errors: callers validate the order at configuration time).
#[inline]
pub fn open_uniform(
    degree: usize,
    spans: usize,
    span: usize,
    u: f64,
    values: &mut [f64],
    derivatives: &mut [f64],
) {
    assert!(degree <= MAX_DEGREE && span < spans);
    let p = degree;
    let values = &mut values[..=p];
    let derivatives = &mut derivatives[..=p];
    let mut lower = [0.0; MAX_DEGREE + 1];
    // Interior spans, where every knot involved (span + 1 - p ..= span + p) is a simple
    // uniform knot: all triangle denominators at level j equal j, and those of the
    // derivatives equal p, so no division and no knot lookup is needed.
    if span + 1 >= p && span + p <= spans {
        let t = u - span as f64;
        values[0] = 1.0;
        for j in 1..=p {
            if j == p {
                lower[..p].copy_from_slice(&values[..p]);
            }
            let inv_j = INVERSE[j];
            let mut saved = 0.0;
            for (r, value) in values[..j].iter_mut().enumerate() {
                // left[j - r] = t + j - r - 1, right[r + 1] = r + 1 - t.
                let temp = *value * inv_j;
                *value = saved + (r as f64 + 1.0 - t) * temp;
                saved = (t + (j - r) as f64 - 1.0) * temp;
            }
            values[j] = saved;
        }
        if p == 0 {
            derivatives[0] = 0.0;
            return;
        }
        for (k, d) in derivatives.iter_mut().enumerate() {
            let below = if k >= 1 { lower[k - 1] } else { 0.0 };
            let here = if k < p { lower[k] } else { 0.0 };
            *d = below - here;
        }
        return;
    }
    // Knot index of the span: U_i = span, U_{i+1} = span + 1.
    let i = span + p;
    let mut left = [0.0; MAX_DEGREE + 1];
    let mut right = [0.0; MAX_DEGREE + 1];
    values[0] = 1.0;
    for j in 1..=p {
        if j == p {
            lower[..p].copy_from_slice(&values[..p]);
        }
        left[j] = u - knot(i + 1 - j, p, spans);
        right[j] = knot(i + j, p, spans) - u;
        let mut saved = 0.0;
        for r in 0..j {
            let temp = values[r] / (right[r + 1] + left[j - r]);
            values[r] = saved + right[r + 1] * temp;
            saved = left[j - r] * temp;
        }
        values[j] = saved;
    }
    if p == 0 {
        derivatives[0] = 0.0;
        return;
    }
    // lower[m] = N_{i-p+1+m, p-1}, m = 0..p-1; function k of the span is N_{i-p+k, p}.
    let degree_f = p as f64;
    for (k, d) in derivatives.iter_mut().enumerate() {
        let mut dk = 0.0;
        if k >= 1 {
            let den = knot(i + k, p, spans) - knot(i + k - p, p, spans);
            dk += lower[k - 1] / den;
        }
        if k < p {
            let den = knot(i + k + 1, p, spans) - knot(i + k + 1 - p, p, spans);
            dk -= lower[k] / den;
        }
        *d = degree_f * dk;
    }
}

/// `1 / j` for the uniform triangle levels.
const INVERSE: [f64; MAX_DEGREE + 1] = {
    let mut inv = [0.0; MAX_DEGREE + 1];
    let mut j = 1;
    while j <= MAX_DEGREE {
        inv[j] = 1.0 / j as f64;
        j += 1;
    }
    inv
};

#[cfg(test)]
mod tests {

    #[test]
    fn fixed_orders_give_the_bits_of_the_general_evaluation() {
        fn check<const P: usize>() {
            for spans in [P, P + 1, 2 * P + 3, 17] {
                for step in 0..=200 {
                    let u = spans as f64 * step as f64 / 200.0;
                    let span = (u as usize).min(spans - 1);
                    let (mut n, mut dn, mut m, mut dm) =
                        ([0.0; 16], [0.0; 16], [0.0; 16], [0.0; 16]);
                    open_uniform(P, spans, span, u, &mut n, &mut dn);
                    open_uniform_fixed::<P>(spans, span, u, &mut m, &mut dm);
                    let bits = |a: &[f64]| a.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(&n[..=P]), bits(&m[..=P]), "P {P} spans {spans} u {u}");
                    assert_eq!(
                        bits(&dn[..=P]),
                        bits(&dm[..=P]),
                        "P {P} spans {spans} u {u}"
                    );
                }
            }
        }
        check::<1>();
        check::<2>();
        check::<3>();
    }

    use super::*;
    use proptest::prelude::*;

    /// The naive Cox–de Boor recursion on the degree-`p` knot vector (0/0 := 0), the
    /// reference for the triangular scheme.
    fn naive(i: usize, j: usize, p: usize, spans: usize, u: f64) -> f64 {
        let k = |m: usize| knot(m, p, spans);
        if j == 0 {
            let (a, b) = (k(i), k(i + 1));
            let inside = (a <= u && u < b) || (u == spans as f64 && b == spans as f64 && a < b);
            return if inside { 1.0 } else { 0.0 };
        }
        let mut value = 0.0;
        let d1 = k(i + j) - k(i);
        if d1 > 0.0 {
            value += (u - k(i)) / d1 * naive(i, j - 1, p, spans, u);
        }
        let d2 = k(i + j + 1) - k(i + 1);
        if d2 > 0.0 {
            value += (k(i + j + 1) - u) / d2 * naive(i + 1, j - 1, p, spans, u);
        }
        value
    }

    #[test]
    fn degree_zero_is_the_span_indicator() {
        let (mut n, mut dn) = ([0.0; 1], [0.0; 1]);
        open_uniform(0, 3, 1, 1.4, &mut n, &mut dn);
        assert_eq!((n[0], dn[0]), (1.0, 0.0));
        assert_eq!(naive(1, 0, 0, 3, 1.4), 1.0);
    }

    #[test]
    fn open_knot_vector_interpolates_the_ends() {
        for p in 1..=6 {
            let spans = 7;
            let (mut n, mut dn) = ([0.0; 16], [0.0; 16]);
            open_uniform(p, spans, 0, 0.0, &mut n, &mut dn);
            assert_eq!(n[0], 1.0, "p = {p}");
            open_uniform(p, spans, spans - 1, spans as f64, &mut n, &mut dn);
            assert!((n[p] - 1.0).abs() < 1e-15, "p = {p}: {}", n[p]);
            // End slopes of an open B-spline: -p / U_{p+1} at u = 0.
            open_uniform(p, spans, 0, 0.0, &mut n, &mut dn);
            assert!((dn[0] + p as f64).abs() < 1e-12, "p = {p}: {}", dn[0]);
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(400))]
        #[test]
        fn matches_cox_de_boor_and_basic_properties(
            p in 1usize..=6, spans in 1usize..12, t in 0.0f64..=1.0,
        ) {
            let u = t * spans as f64;
            let span = (u as usize).min(spans - 1);
            let (mut n, mut dn) = ([0.0; 16], [0.0; 16]);
            open_uniform(p, spans, span, u, &mut n, &mut dn);
            // Partition of unity, non-negativity, derivatives sum to zero.
            let sum: f64 = n[..=p].iter().sum();
            prop_assert!((sum - 1.0).abs() < 1e-14, "sum {sum}");
            prop_assert!(n[..=p].iter().all(|&v| v >= 0.0));
            let dsum: f64 = dn[..=p].iter().sum();
            prop_assert!(dsum.abs() < 1e-12 * (p * p) as f64, "dsum {dsum}");
            // Agreement with the naive recursion, function by function.
            for (k, value) in n[..=p].iter().enumerate() {
                let reference = naive(span + k, p, p, spans, u);
                prop_assert!((value - reference).abs() < 1e-14, "k {k}: {value} vs {reference}");
            }
            // Derivative against central differences of the naive recursion, away from
            // knots (where derivatives of degree-1 splines jump).
            let eps = 1e-6;
            let frac = u - span as f64;
            if frac > 2.0 * eps && frac < 1.0 - 2.0 * eps {
                for (k, derivative) in dn[..=p].iter().enumerate() {
                    let fd = (naive(span + k, p, p, spans, u + eps)
                        - naive(span + k, p, p, spans, u - eps)) / (2.0 * eps);
                    prop_assert!((derivative - fd).abs() < 1e-6 * (1.0 + fd.abs()),
                        "k {k}: {derivative} vs {fd}");
                }
            }
        }
    }
}
