//! Moment integration of the 2D/3D TLS fits (`docs/tls.md`): the integrals of a fitted
//! Taylor polynomial against the basis functions of its cell, without visiting the Gauss
//! points of the cell.
//!
//! Every Taylor term is a product of 1D factors, one per axis, from
//! `f_0 = 1`, `f_1 = s`, `f_2 = s^2 / 2 - 1/6` (`s` the scaled coordinate of the box), and
//! a tensor-product basis function is a product of 1D functions, so on a box
//! `[lo, hi]` (whose extent along axis `a` depends only on the cell's index `i_a` along it)
//!
//! ```text
//! int_box t_k phi_I = prod_a X_a(i_a)[l_a][d_a(k)],   X_a(i)[l][d] = int_lo^hi f_d(s) phi_l dx
//! ```
//!
//! with `d_a(k)` the degree of term `k` along axis `a`; the derivative `d phi_l / dx` in
//! the place of `phi_l` gives the stress integrals. The 1D moments are computed once per
//! step and axis with the same `(p + 2)`-point Gauss rule (exact, as before: the integrand
//! has degree `p + 2` within a knot span), and per cell and field the sum over the terms
//! is contracted one axis at a time:
//!
//! ```text
//! 2D: T[i_0][d_1] = sum_(k: d_1(k) = d_1) a_k X_0[i_0][d_0(k)]
//!     r[i_1][i_0] = sum_(d_1) T[i_0][d_1] X_1[i_1][d_1]
//! ```
//!
//! 6 L + 3 L^2 multiply-adds per field in 2D, 10 L + 6 L^2 + 3 L^3 in 3D (`L` functions per
//! axis), with no basis evaluation per cell. A box whose functions change between the
//! Gauss coordinates of an axis (not the case for the bases of the core, kept as a guard)
//! is integrated point by point by the caller.

// Index loops: the indices enter the formulas (axes, functions, degrees).
#![allow(clippy::needless_range_loop)]

use crate::grid::{Basis, Shape, TensorBasis};
use crate::numerics::gauss::GaussRule;
use crate::numerics::taylor_nd::MAX_TERMS;

/// The 1D Taylor factors `1, s, s^2 / 2 - 1/6` per axis.
pub(super) const FACTORS: usize = 3;

/// The moments of one axis, per cell index along it.
#[derive(Clone, Debug, Default)]
pub(super) struct AxisMoments {
    /// Functions per cell slot (the basis' largest window).
    stride: usize,
    first: Vec<usize>,
    len: Vec<usize>,
    /// The functions are the same at every Gauss coordinate of the box.
    uniform: Vec<bool>,
    /// `phi[i * stride + l][d] = int f_d phi_l`, `dphi[..]` with `d phi_l / dx`.
    phi: Vec<[f64; FACTORS]>,
    dphi: Vec<[f64; FACTORS]>,
    /// `pairs[i * stride^2 + l len_i + m][d] = int f_d phi_l phi_m` (the consistent mass).
    pairs: Vec<[f64; FACTORS]>,
}

impl AxisMoments {
    /// The moments of axis `a` of `basis` on the boxes `[max(lo, left_i), min(hi, right_i)]`
    /// of its cells `i` (boxes of zero or negative length are skipped: their cells are
    /// inactive).
    pub(super) fn update<const D: usize, B: Basis>(
        &mut self,
        basis: &TensorBasis<D, B>,
        a: usize,
        rule: &GaussRule,
        lo: f64,
        hi: f64,
    ) {
        let grid = &basis.grid.axes[a];
        let axis = basis.axis(a);
        let cells = grid.cells;
        self.stride = axis.max_window();
        self.first.resize(cells, 0);
        self.len.resize(cells, 0);
        self.uniform.resize(cells, false);
        self.phi.resize(cells * self.stride, [0.0; FACTORS]);
        self.dphi.resize(cells * self.stride, [0.0; FACTORS]);
        let square = self.stride * self.stride;
        self.pairs.resize(cells * square, [0.0; FACTORS]);
        let mut shape = Shape::default();
        for i in 0..cells {
            let left = grid.cell_left(i);
            let right = left + grid.h;
            let (box_lo, box_hi) = (lo.max(left), hi.min(right));
            self.uniform[i] = false;
            if box_hi <= box_lo {
                continue;
            }
            // The scaled coordinate of `TaylorBox` along this axis.
            let (centre, half_width) = (0.5 * (box_lo + box_hi), 0.5 * (box_hi - box_lo));
            let inv_half_width = 1.0 / half_width;
            let phi = &mut self.phi[i * self.stride..(i + 1) * self.stride];
            let dphi = &mut self.dphi[i * self.stride..(i + 1) * self.stride];
            let pairs = &mut self.pairs[i * square..(i + 1) * square];
            phi.fill([0.0; FACTORS]);
            dphi.fill([0.0; FACTORS]);
            pairs.fill([0.0; FACTORS]);
            let mut uniform = true;
            for (g, (x, w)) in rule.mapped(box_lo, box_hi).enumerate() {
                axis.eval_particle(i, x, 0.0, &mut shape);
                if g == 0 {
                    self.first[i] = shape.first;
                    self.len[i] = shape.len;
                } else if shape.first != self.first[i] || shape.len != self.len[i] {
                    uniform = false;
                    break;
                }
                let s = (x - centre) * inv_half_width;
                let f = [w, w * s, w * (0.5 * s * s - 1.0 / 6.0)];
                let len = shape.len;
                for l in 0..len {
                    for d in 0..FACTORS {
                        phi[l][d] += f[d] * shape.phi[l];
                        dphi[l][d] += f[d] * shape.dphi[l];
                    }
                    for m in 0..len {
                        let product = shape.phi[l] * shape.phi[m];
                        for d in 0..FACTORS {
                            pairs[l * len + m][d] += f[d] * product;
                        }
                    }
                }
            }
            self.uniform[i] = uniform;
        }
    }
}

/// The moments of one cell: per axis its first function, count and tables.
pub(super) struct CellMoments<'a, const D: usize> {
    first: [usize; D],
    len: [usize; D],
    phi: [&'a [[f64; FACTORS]]; D],
    dphi: [&'a [[f64; FACTORS]]; D],
    pairs: [&'a [[f64; FACTORS]]; D],
}

impl<'a, const D: usize> CellMoments<'a, D> {
    /// The cell with axis indices `index`; `None` if an axis is not uniform over its box.
    #[inline]
    pub(super) fn new(axes: &'a [AxisMoments; D], index: [usize; D]) -> Option<Self> {
        let mut out = Self {
            first: [0; D],
            len: [0; D],
            phi: [&[]; D],
            dphi: [&[]; D],
            pairs: [&[]; D],
        };
        for a in 0..D {
            let m = &axes[a];
            let i = index[a];
            if !m.uniform[i] {
                return None;
            }
            out.first[a] = m.first[i];
            out.len[a] = m.len[i];
            let slot = i * m.stride..i * m.stride + m.len[i];
            out.phi[a] = &m.phi[slot.clone()];
            out.dphi[a] = &m.dphi[slot];
            let square = m.stride * m.stride;
            out.pairs[a] = &m.pairs[i * square..i * square + m.len[i] * m.len[i]];
        }
        Some(out)
    }

    /// Number of nodes of the cell (`prod_a len_a`).
    #[inline]
    pub(super) fn nodes(&self) -> usize {
        self.len.iter().product()
    }

    /// `out[n] = int_box (sum_k a_k t_k) F_n`, `F = prod_a phi` with `dphi` on the axis
    /// `derivative`, for the nodes `n` of the cell in lexicographic order (x fastest);
    /// `out` holds at least [`Self::nodes`] values, `scratch` at least
    /// [`scratch_len`]`(max_a len_a)`.
    /// `N` > 0: every axis has `N` functions (the fixed support of the basis), and the
    /// contraction runs with fixed loop lengths.
    #[inline]
    pub(super) fn contract<const N: usize>(
        &self,
        a: &[f64; MAX_TERMS],
        derivative: Option<usize>,
        scratch: &mut [f64],
        out: &mut [f64],
    ) {
        let tables: [&[[f64; FACTORS]]; D] = std::array::from_fn(|axis| {
            if derivative == Some(axis) {
                self.dphi[axis]
            } else {
                self.phi[axis]
            }
        });
        if N > 0 && D == 2 && self.len[0] == N && self.len[1] == N {
            contract_fixed_2d::<N>(a, tables[0], tables[1], out);
        } else {
            contract_tables(a, tables, scratch, out);
        }
    }

    /// `out = M_cell`, `M_(IJ) = int_box (sum_k a_k t_k) phi_I phi_J` laid out
    /// `[pair_(D-1)] ... [pair_0]`, `pair_a = i_a len_a + j_a` (`j` fastest): at least
    /// `nodes^2` values; `scratch` at least [`scratch_len`]`(max_a len_a^2)`.
    #[inline]
    pub(super) fn contract_mass(&self, a: &[f64; MAX_TERMS], scratch: &mut [f64], out: &mut [f64]) {
        contract_tables(a, self.pairs, scratch, out);
    }

    /// The first function and the number of functions per axis.
    #[inline]
    pub(super) fn support(&self) -> ([usize; D], [usize; D]) {
        (self.first, self.len)
    }

    /// `visit(k, node)` for the nodes of the cell in the order of [`Self::contract`]'s
    /// output.
    #[inline]
    pub(super) fn for_each_node(&self, strides: &[usize; D], mut visit: impl FnMut(usize, usize)) {
        let mut index = [0usize; D];
        for k in 0..self.nodes() {
            let mut node = 0;
            for a in 0..D {
                node += (self.first[a] + index[a]) * strides[a];
            }
            visit(k, node);
            for a in 0..D {
                index[a] += 1;
                if index[a] < self.len[a] {
                    break;
                }
                index[a] = 0;
            }
        }
    }
}

/// `out[n] = sum_k a_k prod_a tables[a][n_a][d_a(k)]` for the entries `n` of the tables'
/// product, axis 0 fastest, contracted one axis at a time (see the module doc).
#[inline]
fn contract_tables<const D: usize>(
    a: &[f64; MAX_TERMS],
    tables: [&[[f64; FACTORS]]; D],
    scratch: &mut [f64],
    out: &mut [f64],
) {
    match D {
        1 => {
            for (o, x) in out.iter_mut().zip(tables[0]) {
                *o = a[0] * x[0] + a[1] * x[1] + a[2] * x[2];
            }
        }
        2 => {
            // Terms: 1, s0, s1, f2(s0), s0 s1, f2(s1).
            let (x_table, y_table) = (tables[0], tables[1]);
            let l0 = x_table.len();
            let partial = &mut scratch[..3 * l0];
            for (t, x) in partial.chunks_exact_mut(3).zip(x_table) {
                t[0] = a[0] * x[0] + a[1] * x[1] + a[3] * x[2];
                t[1] = a[2] * x[0] + a[4] * x[1];
                t[2] = a[5] * x[0];
            }
            for (row, y) in out.chunks_exact_mut(l0).zip(y_table) {
                for (o, t) in row.iter_mut().zip(partial.chunks_exact(3)) {
                    *o = t[0] * y[0] + t[1] * y[1] + t[2] * y[2];
                }
            }
        }
        _ => {
            // Terms: 1, s0, s1, s2, f2(s0), s0 s1, s0 s2, f2(s1), s1 s2, f2(s2).
            let (x_table, y_table, z_table) = (tables[0], tables[1], tables[2]);
            let (l0, l1) = (x_table.len(), y_table.len());
            let (first, second) = scratch.split_at_mut(6 * l0);
            // first[i0][(d1, d2)]: (0,0), (1,0), (2,0), (0,1), (1,1), (0,2).
            for (t, x) in first.chunks_exact_mut(6).zip(x_table) {
                t[0] = a[0] * x[0] + a[1] * x[1] + a[4] * x[2];
                t[1] = a[2] * x[0] + a[5] * x[1];
                t[2] = a[7] * x[0];
                t[3] = a[3] * x[0] + a[6] * x[1];
                t[4] = a[8] * x[0];
                t[5] = a[9] * x[0];
            }
            // second[i1][i0][d2]
            let second = &mut second[..3 * l0 * l1];
            for (plane, y) in second.chunks_exact_mut(3 * l0).zip(y_table) {
                for (s, t) in plane.chunks_exact_mut(3).zip(first.chunks_exact(6)) {
                    s[0] = t[0] * y[0] + t[1] * y[1] + t[2] * y[2];
                    s[1] = t[3] * y[0] + t[4] * y[1];
                    s[2] = t[5] * y[0];
                }
            }
            for (block, z) in out.chunks_exact_mut(l0 * l1).zip(z_table) {
                for (o, s) in block.iter_mut().zip(second.chunks_exact(3)) {
                    *o = s[0] * z[0] + s[1] * z[1] + s[2] * z[2];
                }
            }
        }
    }
}

/// [`contract_tables`] in 2D with `L` functions per axis: fixed loop lengths, the partial
/// sums in registers.
#[inline(always)]
fn contract_fixed_2d<const L: usize>(
    a: &[f64; MAX_TERMS],
    x_table: &[[f64; FACTORS]],
    y_table: &[[f64; FACTORS]],
    out: &mut [f64],
) {
    let x_table = &x_table[..L];
    let y_table = &y_table[..L];
    let partial: [[f64; 3]; L] = std::array::from_fn(|i| {
        let x = x_table[i];
        [
            a[0] * x[0] + a[1] * x[1] + a[3] * x[2],
            a[2] * x[0] + a[4] * x[1],
            a[5] * x[0],
        ]
    });
    for (row, y) in out[..L * L].chunks_exact_mut(L).zip(y_table) {
        for (o, t) in row.iter_mut().zip(&partial) {
            *o = t[0] * y[0] + t[1] * y[1] + t[2] * y[2];
        }
    }
}

/// Scratch length [`CellMoments::contract`] needs for `len` functions per axis.
pub(super) fn scratch_len(len: usize) -> usize {
    6 * len * (1 + len)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{BSplineBasis, LinearBasis, TensorGrid, TensorShape};
    use crate::numerics::taylor_nd::TaylorBox;

    /// A 5^D grid of B-splines of `order` with the material extent [0.03, 0.9] on every
    /// axis (cell 0 is clipped on the left), its axis moments and the box of `cell`.
    struct Fixture<const D: usize> {
        basis: TensorBasis<D, BSplineBasis>,
        rule: GaussRule,
        axes: [AxisMoments; D],
        lo: [f64; D],
        hi: [f64; D],
    }

    impl<const D: usize> Fixture<D> {
        fn new(order: usize, cell: [usize; D]) -> Self {
            let grid = TensorGrid::<D>::new([1.0; D], [5; D]);
            let basis = TensorBasis::new(grid, |g| BSplineBasis::new(g, order).unwrap());
            let rule = GaussRule::new(order + 2).unwrap();
            let (lo_ext, hi_ext) = (0.03, 0.9);
            let mut axes: [AxisMoments; D] = std::array::from_fn(|_| AxisMoments::default());
            for a in 0..D {
                axes[a].update(&basis, a, &rule, lo_ext, hi_ext);
            }
            let left = |a: usize| grid.axes[a].cell_left(cell[a]);
            Self {
                lo: std::array::from_fn(|a| left(a).max(lo_ext)),
                hi: std::array::from_fn(|a| (left(a) + grid.axes[a].h).min(hi_ext)),
                basis,
                rule,
                axes,
            }
        }

        /// `visit(x_g, w_g)` over the tensor Gauss rule of the box.
        fn for_each_point(&self, mut visit: impl FnMut([f64; D], f64)) {
            let mapped: Vec<Vec<(f64, f64)>> = (0..D)
                .map(|a| self.rule.mapped(self.lo[a], self.hi[a]).collect())
                .collect();
            let n = self.rule.len;
            for g in 0..n.pow(D as u32) {
                let mut rest = g;
                let mut x = [0.0; D];
                let mut w = 1.0;
                for a in 0..D {
                    let (xa, wa) = mapped[a][rest % n];
                    rest /= n;
                    x[a] = xa;
                    w *= wa;
                }
                visit(x, w);
            }
        }
    }

    /// The contraction of the moments equals the point-by-point Gauss sums of the fitted
    /// polynomial against the basis (values and every derivative axis), in 1D, 2D and 3D,
    /// with a box clipped in a boundary cell.
    #[test]
    fn moments_equal_the_point_by_point_gauss_sums() {
        for order in 1..=3 {
            check::<1>(order, [1]);
            check::<2>(order, [0, 3]);
            check::<3>(order, [2, 0, 4]);
        }
    }

    fn check<const D: usize>(order: usize, cell: [usize; D]) {
        let fixture = Fixture::<D>::new(order, cell);
        let (basis, axes) = (&fixture.basis, &fixture.axes);
        let taylor = TaylorBox::new(fixture.lo, fixture.hi);
        let mut coefficients = [0.0; MAX_TERMS];
        for (k, c) in coefficients.iter_mut().enumerate() {
            *c = 1.0 + 0.37 * k as f64 - 0.05 * (k * k) as f64;
        }
        let moments = CellMoments::new(axes, cell).unwrap();
        let strides = *basis.strides();
        let mut scratch = vec![0.0; scratch_len(order + 1)];
        let mut out = vec![0.0; moments.nodes()];
        let mut derivatives = vec![None];
        derivatives.extend((0..D).map(Some));
        for derivative in derivatives {
            moments.contract::<0>(&coefficients, derivative, &mut scratch, &mut out);
            if D == 2 {
                // The fixed-size kernel gives the same sums.
                let mut fixed = vec![0.0; out.len()];
                match order {
                    1 => moments.contract::<2>(&coefficients, derivative, &mut scratch, &mut fixed),
                    2 => moments.contract::<3>(&coefficients, derivative, &mut scratch, &mut fixed),
                    _ => moments.contract::<4>(&coefficients, derivative, &mut scratch, &mut fixed),
                }
                assert_eq!(fixed, out);
            }
            let mut fast = std::collections::BTreeMap::new();
            moments.for_each_node(&strides, |k, node| {
                fast.insert(node, out[k]);
            });
            // Point by point over the tensor rule.
            let mut slow = std::collections::BTreeMap::<usize, f64>::new();
            let mut shape = TensorShape::<D>::default();
            fixture.for_each_point(|x, w| {
                let t = taylor.terms(x);
                let value: f64 = (0..MAX_TERMS).map(|k| coefficients[k] * t[k]).sum::<f64>() * w;
                basis.eval_particle(cell, x, [0.0; D], &mut shape);
                shape.for_each_node(&strides, |node, phi, grad| {
                    *slow.entry(node).or_default() += value * derivative.map_or(phi, |a| grad[a]);
                });
            });
            assert_eq!(fast.len(), (order + 1).pow(D as u32));
            for (node, r) in &fast {
                let s = slow[node];
                assert!(
                    (r - s).abs() <= 1e-13 * (1.0 + s.abs()),
                    "D = {D}, p = {order}, {derivative:?}, node {node}: {r} against {s}"
                );
            }
        }
    }

    /// The mass block of the moments equals `sum_g rho_hat w_g phi_I phi_J` point by point.
    #[test]
    fn mass_block_equals_the_point_by_point_gauss_sums() {
        for order in 1..=3 {
            check_mass::<2>(order, [0, 3]);
            check_mass::<3>(order, [2, 0, 4]);
        }
    }

    fn check_mass<const D: usize>(order: usize, cell: [usize; D]) {
        let fixture = Fixture::<D>::new(order, cell);
        let (basis, axes) = (&fixture.basis, &fixture.axes);
        let taylor = TaylorBox::new(fixture.lo, fixture.hi);
        let mut density = [0.0; MAX_TERMS];
        for (k, c) in density.iter_mut().enumerate() {
            *c = 2.0 - 0.11 * k as f64;
        }
        let moments = CellMoments::new(axes, cell).unwrap();
        let n = moments.nodes();
        let len = order + 1;
        let mut scratch = vec![0.0; scratch_len(len * len)];
        let mut block = vec![0.0; n * n];
        moments.contract_mass(&density, &mut scratch, &mut block);
        // Block entry of local nodes (row i, column j): pair_a = i_a len + j_a.
        let digits = |mut k: usize| -> [usize; D] {
            std::array::from_fn(|_| {
                let d = k % len;
                k /= len;
                d
            })
        };
        let mut slow = vec![0.0; n * n];
        let mut shape = TensorShape::<D>::default();
        fixture.for_each_point(|x, w| {
            let t = taylor.terms(x);
            let rho: f64 = (0..MAX_TERMS).map(|k| density[k] * t[k]).sum::<f64>() * w;
            basis.eval_particle(cell, x, [0.0; D], &mut shape);
            let mut phi = vec![0.0; n];
            let mut k = 0;
            shape.for_each_node(basis.strides(), |_, value, _| {
                phi[k] = value;
                k += 1;
            });
            for (i, &phi_i) in phi.iter().enumerate() {
                for (j, &phi_j) in phi.iter().enumerate() {
                    let (di, dj) = (digits(i), digits(j));
                    let mut pair = 0;
                    for a in (0..D).rev() {
                        pair = pair * len * len + di[a] * len + dj[a];
                    }
                    slow[pair] += rho * phi_i * phi_j;
                }
            }
        });
        let scale = slow.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (k, (f, s)) in block.iter().zip(&slow).enumerate() {
            assert!(
                (f - s).abs() <= 1e-13 * scale,
                "D = {D}, p = {order}, entry {k}: {f} against {s}"
            );
        }
    }

    /// Linear bases are uniform over every cell box; a box outside the extent is skipped.
    #[test]
    fn linear_axes_are_uniform_and_empty_boxes_are_skipped() {
        let grid = TensorGrid::<2>::new([1.0; 2], [4, 4]);
        let basis = TensorBasis::new(grid, LinearBasis::new);
        let rule = GaussRule::new(3).unwrap();
        let mut axis = AxisMoments::default();
        axis.update(&basis, 0, &rule, 0.1, 0.6);
        assert_eq!(axis.uniform, vec![true, true, true, false]);
        // int_box phi_0 + phi_1 = |box| for the constant factor.
        let total: f64 = axis.phi[0..2].iter().map(|m| m[0]).sum();
        assert!((total - 0.15).abs() < 1e-15, "{total}");
    }
}
