//! Sum-factorised cell quadrature on tensor-product bases (`docs/tls.md`).
//!
//! On an axis-aligned cell box with a tensor Gauss rule of `G` points per axis, the 1D
//! functions of axis `a` at its `G` coordinates are the same for every point of the rule,
//! so the `D`-dimensional sums over the `G^D` points are contracted one axis at a time:
//!
//! ```text
//! r_i    = sum_g V_g prod_a F_a(i_a, g_a)                 (F_a = phi or dphi/dx_a)
//! M_(ij) = sum_g W_g prod_a phi_{i_a}(x_{g_a}) phi_{j_a}(x_{g_a})
//! ```
//!
//! A vector integral ([`CellQuadrature::integrate`]) costs
//! `G^D L + G^(D-1) L^2 + ... + G L^D` multiply-adds per field instead of `G^D L^D`
//! (`L` functions per axis), and the mass block ([`CellQuadrature::add_mass`])
//! `G^D L^2 + G^(D-1) L^4 + ... + G L^(2D)` instead of `G^D L^(2D)` (3D, quadratic
//! B-splines: 4 788 instead of 46 656). The basis is evaluated `G D` times per cell
//! instead of `G^D D`. Values are visited in lexicographic node order (x fastest); the
//! sums are formed in a fixed order, so results do not depend on the thread count.
//!
//! One [`CellQuadrature`] per task, reused for every cell: no allocation per cell once
//! its buffers have grown.

// Index loops: the indices enter the formulas (axes, points, functions).
#![allow(clippy::needless_range_loop)]

use super::tensor_mass::StencilRows;
use crate::grid::{Basis, Shape, TensorBasis};

/// The 1D functions of one axis at the Gauss coordinates of a cell box.
#[derive(Clone, Debug, Default)]
struct AxisPoints {
    first: usize,
    len: usize,
    /// `phi[g * len + i]`, `dphi[g * len + i]`.
    phi: Vec<f64>,
    dphi: Vec<f64>,
}

/// Which factors [`CellQuadrature::contract_axes`] contracts an axis with.
enum AxisFactors {
    /// The axis' `phi`, in place.
    Phi,
    /// The axis' `dphi`, in place.
    Dphi,
    /// The scratch buffer, filled by the caller with this many factors per coordinate.
    Buffer(usize),
}

/// Per-axis function values at the Gauss coordinates of one cell and the scratch of the
/// axis-by-axis contractions.
#[derive(Clone, Debug)]
pub struct CellQuadrature<const D: usize> {
    points: usize,
    axes: [AxisPoints; D],
    current: Vec<f64>,
    next: Vec<f64>,
    products: Vec<f64>,
    /// Scratch of [`Self::set_cell`] (zeroed once, not per cell).
    shape: Shape,
}

impl<const D: usize> Default for CellQuadrature<D> {
    fn default() -> Self {
        Self {
            points: 0,
            axes: std::array::from_fn(|_| AxisPoints::default()),
            current: Vec::new(),
            next: Vec::new(),
            products: Vec::new(),
            shape: Shape::default(),
        }
    }
}

impl<const D: usize> CellQuadrature<D> {
    /// Evaluate the functions of every axis of `basis` on cell `cell` at the coordinates
    /// `x[a][..points]`. Returns `false` if the support changes between the coordinates of
    /// an axis (the caller then integrates point by point).
    pub fn set_cell<B: Basis>(
        &mut self,
        basis: &TensorBasis<D, B>,
        cell: [usize; D],
        x: &[[f64; crate::numerics::gauss::MAX_POINTS]; D],
        points: usize,
    ) -> bool {
        self.points = points;
        let shape = &mut self.shape;
        for a in 0..D {
            let axis = &mut self.axes[a];
            axis.phi.clear();
            axis.dphi.clear();
            for g in 0..points {
                basis.axis(a).eval_particle(cell[a], x[a][g], 0.0, shape);
                if g == 0 {
                    axis.first = shape.first;
                    axis.len = shape.len;
                } else if shape.first != axis.first || shape.len != axis.len {
                    return false;
                }
                // Element by element: a handful of values, cheaper than a `memcpy` call.
                for i in 0..shape.len {
                    axis.phi.push(shape.phi[i]);
                    axis.dphi.push(shape.dphi[i]);
                }
            }
        }
        true
    }

    /// Contract `values` (`width` fields per point, points x fastest) over every axis in
    /// turn into `self.current`: `factors(a, axis, buffer)` names axis `a`'s factors, laid
    /// out `[g * count + k]` for output `k` at coordinate `g`: the axis' own `phi` or
    /// `dphi` (`count = len`, read in place), or `buffer` after filling it. The result is
    /// laid out `[k_{D-1}] ... [k_0][field]`.
    fn contract_axes(
        &mut self,
        values: &[f64],
        width: usize,
        mut factors: impl FnMut(usize, &AxisPoints, &mut Vec<f64>) -> AxisFactors,
    ) {
        let g_count = self.points;
        // source: [outer = G^(D-1-a)][g_a][inner] (`values` for the first axis, then the
        // previous contraction in `current`)
        let mut inner = width;
        let mut outer = values.len() / width;
        for a in 0..D {
            outer /= g_count;
            let axis = &self.axes[a];
            let (table, count): (&[f64], usize) = match factors(a, axis, &mut self.products) {
                AxisFactors::Phi => (&axis.phi, axis.len),
                AxisFactors::Dphi => (&axis.dphi, axis.len),
                AxisFactors::Buffer(count) => (&self.products, count),
            };
            let source = if a == 0 { values } else { &self.current };
            contract(source, &mut self.next, outer, g_count, inner, table, count);
            std::mem::swap(&mut self.current, &mut self.next);
            inner *= count;
        }
    }

    /// `visit(node, r_node)` with `r_node[k] = sum_g values[g * width + k] prod_a F_a`, for
    /// every node of the cell's support in lexicographic order; `F_a` is `dphi` on the
    /// axis `derivative` and `phi` on the others. `values` holds `width` fields per point,
    /// points x fastest.
    pub fn integrate(
        &mut self,
        values: &[f64],
        width: usize,
        derivative: Option<usize>,
        strides: &[usize; D],
        mut visit: impl FnMut(usize, &[f64]),
    ) {
        self.contract_axes(values, width, |a, _, _| {
            if derivative == Some(a) {
                AxisFactors::Dphi
            } else {
                AxisFactors::Phi
            }
        });
        // current: [i_{D-1}] ... [i_0][field]
        let mut index = [0usize; D];
        for block in self.current.chunks_exact(width) {
            let mut node = 0;
            for a in 0..D {
                node += (self.axes[a].first + index[a]) * strides[a];
            }
            visit(node, block);
            for a in 0..D {
                index[a] += 1;
                if index[a] < self.axes[a].len {
                    break;
                }
                index[a] = 0;
            }
        }
    }

    /// `rows += M_cell`, `M_(ij) = sum_g weights[g] prod_a phi_{i_a} phi_{j_a}`, the
    /// weights `w_g rho_hat(x_g)` of the `points^D` Gauss points (x fastest).
    pub fn add_mass(
        &mut self,
        rows: &mut StencilRows<'_, D>,
        strides: &[usize; D],
        weights: &[f64],
    ) {
        self.contract_axes(weights, 1, |_, axis, products| {
            // products[g * l^2 + i l + j] = phi_i(x_g) phi_j(x_g)
            let l = axis.len;
            products.clear();
            for phi in axis.phi.chunks_exact(l) {
                for &phi_i in phi {
                    for &phi_j in phi {
                        products.push(phi_i * phi_j);
                    }
                }
            }
            AxisFactors::Buffer(l * l)
        });
        // current: [pair_{D-1}] ... [pair_0], pair_a = i_a L_a + j_a: an odometer over
        // (j_0, i_0, j_1, i_1, ...), j fastest.
        let side = 2 * rows.reach + 1;
        let mut slot_scale = [1usize; D];
        for a in 1..D {
            slot_scale[a] = slot_scale[a - 1] * side;
        }
        let (mut i, mut j) = ([0usize; D], [0usize; D]);
        for &value in &self.current {
            let mut row = 0;
            let mut slot = 0;
            for a in 0..D {
                row += (self.axes[a].first + i[a]) * strides[a];
                slot += (j[a] + rows.reach - i[a]) * slot_scale[a];
            }
            rows.values[(row - rows.lo) * rows.width + slot] += value;
            for a in 0..D {
                j[a] += 1;
                if j[a] < self.axes[a].len {
                    break;
                }
                j[a] = 0;
                i[a] += 1;
                if i[a] < self.axes[a].len {
                    break;
                }
                i[a] = 0;
            }
        }
    }
}

/// `next[o][k][r] = sum_g factors[g * count + k] current[o][g][r]` for `o < outer`,
/// `k < count`, `r < inner` (`g` summed in increasing order from 0, in a register: one
/// store per output). The point and function counts of the B-spline orders 1–4
/// (`G = p + 2` Gauss points, `p + 1` functions per axis) run as fixed-size kernels; the
/// sums are the same, term by term and in the same order, as the general loop's.
fn contract(
    current: &[f64],
    next: &mut Vec<f64>,
    outer: usize,
    g_count: usize,
    inner: usize,
    factors: &[f64],
    count: usize,
) {
    next.clear();
    next.resize(outer * count * inner, 0.0);
    let current = &current[..outer * g_count * inner];
    let factors = &factors[..g_count * count];
    match (g_count, count) {
        (3, 2) => contract_fixed::<3, 2>(current, next, inner, factors),
        (4, 3) => contract_fixed::<4, 3>(current, next, inner, factors),
        (5, 4) => contract_fixed::<5, 4>(current, next, inner, factors),
        (6, 5) => contract_fixed::<6, 5>(current, next, inner, factors),
        _ => {
            let blocks = current.chunks_exact(g_count * inner);
            for (block, out) in blocks.zip(next.chunks_exact_mut(count * inner)) {
                for (k, out_k) in out.chunks_exact_mut(inner).enumerate() {
                    for (r, o) in out_k.iter_mut().enumerate() {
                        let mut t = 0.0;
                        for g in 0..g_count {
                            t += factors[g * count + k] * block[g * inner + r];
                        }
                        *o = t;
                    }
                }
            }
        }
    }
}

/// [`contract`] for `G` points and `C` functions.
#[inline(always)]
fn contract_fixed<const G: usize, const C: usize>(
    current: &[f64],
    next: &mut [f64],
    inner: usize,
    factors: &[f64],
) {
    let columns: [[f64; G]; C] =
        std::array::from_fn(|k| std::array::from_fn(|g| factors[g * C + k]));
    for (block, out) in current
        .chunks_exact(G * inner)
        .zip(next.chunks_exact_mut(C * inner))
    {
        for (column, out_k) in columns.iter().zip(out.chunks_exact_mut(inner)) {
            for (r, o) in out_k.iter_mut().enumerate() {
                let mut t = 0.0;
                for g in 0..G {
                    t += column[g] * block[g * inner + r];
                }
                *o = t;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{BSplineBasis, TensorGrid, TensorShape};
    use crate::numerics::gauss::{GaussRule, MAX_POINTS};

    /// Sum factorisation equals the point-by-point sums (3D, quadratic B-splines, a
    /// clipped box in a boundary cell).
    #[test]
    fn integrals_equal_the_point_by_point_sums() {
        // (order, Gauss points): the fixed-size kernels (p + 2 points) and the general loop.
        for (order, rule_points) in [(2, 4), (1, 3), (2, 3), (5, 7)] {
            integrals_match(order, rule_points);
        }
    }

    fn integrals_match(order: usize, rule_points: usize) {
        let grid = TensorGrid::<3>::new([1.0; 3], [6, 7, 8]);
        let basis = TensorBasis::new(grid, |g| BSplineBasis::new(g, order).unwrap());
        let cell = [0, 2, 3];
        let rule = GaussRule::new(rule_points).unwrap();
        let mut x = [[0.0; MAX_POINTS]; 3];
        let mut w = [[0.0; MAX_POINTS]; 3];
        for a in 0..3 {
            let left = grid.axes[a].cell_left(cell[a]);
            let (lo, hi) = (left + 0.1 * grid.axes[a].h, left + 0.8 * grid.axes[a].h);
            for (g, (xg, wg)) in rule.mapped(lo, hi).enumerate() {
                x[a][g] = xg;
                w[a][g] = wg;
            }
        }
        let n = rule.len;
        let value = |p: [f64; 3]| 1.0 + p[0] - 2.0 * p[1] * p[2] + p[2] * p[2];
        let mut values = Vec::new();
        let mut points = Vec::new();
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    let p = [x[0][i], x[1][j], x[2][k]];
                    let weight = w[0][i] * w[1][j] * w[2][k];
                    values.extend([value(p) * weight, -weight]);
                    points.push((p, weight));
                }
            }
        }
        let strides = *basis.strides();
        let mut quadrature = CellQuadrature::<3>::default();
        assert!(quadrature.set_cell(&basis, cell, &x, n));
        for derivative in [None, Some(0), Some(1), Some(2)] {
            let mut fast = std::collections::BTreeMap::new();
            quadrature.integrate(&values, 2, derivative, &strides, |node, r| {
                fast.insert(node, [r[0], r[1]]);
            });
            let mut slow = std::collections::BTreeMap::<usize, [f64; 2]>::new();
            let mut shape = TensorShape::<3>::default();
            for &(p, weight) in &points {
                basis.eval_particle(cell, p, [0.0; 3], &mut shape);
                shape.for_each_node(&strides, |node, phi, grad| {
                    let f = derivative.map_or(phi, |a| grad[a]);
                    let e = slow.entry(node).or_default();
                    e[0] += value(p) * weight * f;
                    e[1] -= weight * f;
                });
            }
            assert_eq!(fast.len(), (order + 1).pow(3));
            assert_eq!(fast.len(), slow.len());
            for (node, r) in &fast {
                let s = slow[node];
                for k in 0..2 {
                    assert!(
                        (r[k] - s[k]).abs() <= 1e-14 * (1.0 + s[k].abs()),
                        "p = {order}, {rule_points} points, {node}: {r:?} {s:?}"
                    );
                }
            }
        }
    }
}
