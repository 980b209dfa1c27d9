//! Per-cell helpers of the 2D/3D TLS mapping ([`super`]): box volumes and cell axes, the
//! density limiter and the split of a particle's totals between the cells its domain
//! overlaps (`docs/tls.md`).

// Index loops: the indices enter the formulas (terms, axes).
#![allow(clippy::needless_range_loop)]

use super::BoxRule;
use crate::grid::TensorGrid;
use crate::grid::{Basis, TensorBasis};
use crate::numerics::gauss::GaussRule;
use crate::numerics::taylor_nd::{terms, TaylorBox, MAX_TERMS};

/// `sum_k a_k t_k` over the terms of total degree 2.
#[inline(always)]
pub(super) fn dot<const D: usize>(a: &[f64; MAX_TERMS], t: &[f64; MAX_TERMS]) -> f64 {
    let mut value = a[0];
    for k in 1..terms(D, 2) {
        value += a[k] * t[k];
    }
    value
}

/// Term `k` of total degree 2 is `s_a^2 / 2 - 1/6` (not a product `s_a s_b` or of degree
/// below 2).
#[inline]
pub(super) fn is_square_term<const D: usize>(k: usize) -> bool {
    // After 1 and the D linear terms: (a, b) for a <= b, row by row.
    let mut next = 1 + D;
    for a in 0..D {
        if k == next {
            return true;
        }
        next += D - a;
    }
    false
}

/// The largest number of functions per axis of any cell of `basis`.
#[inline]
pub(super) fn max_len<const D: usize, B: Basis>(basis: &TensorBasis<D, B>) -> usize {
    (0..D)
        .map(|a| basis.axis(a).max_window())
        .max()
        .unwrap_or(1)
}

/// `prod_a (hi_a - lo_a)`.
#[inline]
pub(super) fn box_volume<const D: usize>(lo: &[f64; D], hi: &[f64; D]) -> f64 {
    let mut v = hi[0] - lo[0];
    for a in 1..D {
        v *= hi[a] - lo[a];
    }
    v
}

/// Axis indices of lexicographic cell `cell`.
#[inline]
pub(super) fn cell_axes<const D: usize>(grid: &TensorGrid<D>, cell: usize) -> [usize; D] {
    let mut rest = cell;
    std::array::from_fn(|a| {
        let n = grid.axes[a].cells;
        let i = rest % n;
        rest /= n;
        i
    })
}

/// Scale the non-constant coefficients of a density fit towards its mean where it is
/// negative at a point of `rule` mapped onto the box `[lo, hi]`; 1 if it did.
pub(super) fn limit_density<const D: usize>(
    taylor: &TaylorBox<D>,
    rule: &GaussRule,
    (lo, hi): ([f64; D], [f64; D]),
    a: &mut [f64; MAX_TERMS],
) -> u64 {
    if a[0] <= 0.0 {
        return 0;
    }
    // On the box |s_a| <= 1, |s_a s_b| <= 1 and |s_a^2 / 2 - 1/6| <= 1/3: if the fit's
    // lower bound there clears the round-off of evaluating it, no Gauss point is negative
    // (the same answer as the loop below, without it).
    let mut spread = 0.0;
    for k in 1..terms(D, 2) {
        let largest = if is_square_term::<D>(k) {
            1.0 / 3.0
        } else {
            1.0
        };
        spread += a[k].abs() * largest;
    }
    if a[0] - spread > 1e-12 * (a[0] + spread) {
        return 0;
    }
    let mut lowest = f64::INFINITY;
    BoxRule::new(rule, lo, hi).for_each(|x, _| {
        let value = dot::<D>(a, &taylor.terms(x));
        lowest = if value < lowest { value } else { lowest };
    });
    if lowest >= 0.0 {
        return 0;
    }
    let theta = a[0] / (a[0] - lowest);
    for c in a.iter_mut().skip(1) {
        *c *= theta;
    }
    1
}

/// Add the shares of `q` of a particle at `x` with half-lengths `half` in the cell with
/// axis indices `index` to `out[k]` (`k`: base-3 offset digits `o_a + 1`): along each axis
/// the 1D rule (the domain `x_a +- min(l_a, h_a)` clipped to the grid, split in
/// proportion to its overlap with the left neighbour, the cell and the right neighbour:
/// fractions `lambda_a = (left, 1 - left - right, right)`), and the part given to offset
/// `o` is `q prod_a lambda_a(o_a)`, so the parts add up to `q` to round-off.
pub(super) fn split_shares<const D: usize>(
    grid: &TensorGrid<D>,
    index: [usize; D],
    x: [f64; D],
    half: [f64; D],
    q: [f64; 4],
    out: &mut [[f64; 4]],
) {
    let centre: usize = (0..D).map(|a| 3usize.pow(a as u32)).sum();
    let mut fractions = [[0.0, 1.0, 0.0]; D];
    let mut inside = true;
    for a in 0..D {
        let g = &grid.axes[a];
        let left = g.cell_left(index[a]);
        let right = left + g.h;
        if x[a] - half[a] >= left && x[a] + half[a] <= right {
            continue;
        }
        inside = false;
        let l = half[a].min(g.h);
        let (lo, hi) = (
            (x[a] - l).max(g.origin),
            (x[a] + l).min(g.origin + g.length),
        );
        let per_length = 1.0 / (hi - lo);
        let to_left = (left - lo).max(0.0) * per_length;
        let to_right = (hi - right).max(0.0) * per_length;
        fractions[a] = [to_left, 1.0 - to_left - to_right, to_right];
    }
    if inside {
        // The domain lies in the cell: the whole of `q` stays there.
        for c in 0..4 {
            out[centre][c] += q[c];
        }
        return;
    }
    for (k, o) in out.iter_mut().enumerate().take(3usize.pow(D as u32)) {
        let mut rest = k;
        let mut weight = 1.0;
        for a in 0..D {
            weight *= fractions[a][rest % 3];
            rest /= 3;
        }
        if weight != 0.0 {
            for c in 0..4 {
                o[c] += q[c] * weight;
            }
        }
    }
}
