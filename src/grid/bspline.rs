//! B-spline basis of any order `p >= 1` on an open uniform knot vector (BSMPM, SPEC §3.4).
//!
//! The knot spans are the grid cells, so bins, grid crossings and errors are counted per
//! span. There are `N_n = N_e + p` functions; on cell `e` the `p + 1` non-zero ones are
//! `N_{e..=e+p}`, evaluated together by de Boor's triangular scheme
//! ([`crate::numerics::bspline::open_uniform`]) in parametric units `u = (x - x_0) / h`,
//! with `dN/dx = (dN/du) / h`. Only `N_0` and `N_{N_n - 1}` are non-zero at the ends (value 1),
//! so Dirichlet conditions act on those two DOFs. Order 1 is the linear hat basis.

use super::{Basis, Grid, Shape, MAX_SUPPORT};
use crate::numerics::bspline::{open_uniform, open_uniform_fixed, MAX_DEGREE};

/// Highest B-spline order a [`BSplineBasis`] accepts (`p + 1 <= MAX_SUPPORT`).
pub const MAX_ORDER: usize = if MAX_SUPPORT - 1 < MAX_DEGREE {
    MAX_SUPPORT - 1
} else {
    MAX_DEGREE
};

/// B-splines of order `order` on the cells of `grid`.
#[derive(Clone, Copy, Debug)]
pub struct BSplineBasis {
    grid: Grid,
    order: usize,
}

impl BSplineBasis {
    /// `None` unless `1 <= order <= MAX_ORDER` (the configuration checks `method.order`).
    pub fn new(grid: Grid, order: usize) -> Option<Self> {
        (1..=MAX_ORDER)
            .contains(&order)
            .then_some(Self { grid, order })
    }

    /// The order `p`.
    pub fn order(&self) -> usize {
        self.order
    }
}

impl Basis for BSplineBasis {
    fn name(&self) -> &'static str {
        "bspline"
    }

    fn num_dofs(&self) -> usize {
        self.grid.cells + self.order
    }

    #[inline]
    fn cell_window(&self, cell: usize) -> (usize, usize) {
        (cell, self.order + 1)
    }

    fn max_window(&self) -> usize {
        self.order + 1
    }

    #[inline(always)]
    fn eval(&self, cell: usize, x: f64, shape: &mut Shape) {
        let u = (x - self.grid.origin) * self.grid.inv_h;
        let p = self.order;
        let (spans, phi, dphi) = (self.grid.cells, &mut shape.phi, &mut shape.dphi);
        // Orders 1-3 unrolled (bitwise the same values as the general evaluation).
        match p {
            1 => open_uniform_fixed::<1>(spans, cell, u, phi, dphi),
            2 => open_uniform_fixed::<2>(spans, cell, u, phi, dphi),
            3 => open_uniform_fixed::<3>(spans, cell, u, phi, dphi),
            _ => open_uniform(p, spans, cell, u, phi, dphi),
        }
        for d in &mut shape.dphi[..=p] {
            *d *= self.grid.inv_h;
        }
        shape.first = cell;
        shape.len = p + 1;
    }

    #[inline(always)]
    fn eval_particle(&self, cell: usize, x: f64, _half_length: f64, shape: &mut Shape) {
        self.eval(cell, x, shape);
    }

    /// [`Basis::eval`] with the order fixed at compile time (`N = p + 1` functions): no
    /// run-time dispatch on the order, derivative scaling over exactly `N` entries.
    #[inline(always)]
    fn eval_particle_n<const N: usize>(
        &self,
        cell: usize,
        x: f64,
        _half_length: f64,
        shape: &mut Shape,
    ) {
        if N == 0 || N != self.order + 1 {
            return self.eval(cell, x, shape);
        }
        let u = (x - self.grid.origin) * self.grid.inv_h;
        let (spans, phi, dphi) = (self.grid.cells, &mut shape.phi, &mut shape.dphi);
        match N {
            2 => open_uniform_fixed::<1>(spans, cell, u, phi, dphi),
            3 => open_uniform_fixed::<2>(spans, cell, u, phi, dphi),
            4 => open_uniform_fixed::<3>(spans, cell, u, phi, dphi),
            _ => open_uniform(N - 1, spans, cell, u, phi, dphi),
        }
        for d in &mut shape.dphi[..N] {
            *d *= self.grid.inv_h;
        }
        shape.first = cell;
        shape.len = N;
    }

    fn fixed_support(&self) -> Option<usize> {
        Some(self.order + 1)
    }

    /// From order 2 on, de Boor's triangle costs more than reading `2 (p + 1)` values
    /// back; order 1 is the linear hat.
    fn reuse_shapes(&self) -> bool {
        self.order >= 2
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::LinearBasis;
    use proptest::prelude::*;

    #[test]
    fn orders_outside_the_supported_range_are_refused() {
        let grid = Grid::new(1.0, 4);
        assert!(BSplineBasis::new(grid, 0).is_none());
        assert!(BSplineBasis::new(grid, MAX_ORDER + 1).is_none());
        assert!(BSplineBasis::new(grid, MAX_ORDER).is_some());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]
        /// Partition of unity, non-negativity, zero derivative sum, derivative against
        /// central finite differences in physical units, for p = 1..6 and random points.
        #[test]
        fn basis_invariants(p in 1usize..=6, cells in 1usize..20, t in 0.0f64..=1.0,
                            length in 0.1f64..10.0) {
            let grid = Grid::new(length, cells);
            let basis = BSplineBasis::new(grid, p).unwrap();
            let x = t * length;
            let cell = grid.cell_of(x).unwrap();
            let mut s = Shape::default();
            basis.eval(cell, x, &mut s);
            prop_assert_eq!(s.len, p + 1);
            prop_assert!(s.first + s.len <= basis.num_dofs());
            let sum: f64 = s.phi[..s.len].iter().sum();
            prop_assert!((sum - 1.0).abs() < 1e-14);
            prop_assert!(s.phi[..s.len].iter().all(|&v| v >= 0.0));
            let dsum: f64 = s.dphi[..s.len].iter().sum();
            prop_assert!(dsum.abs() < 1e-11 * grid.inv_h);
            let eps = 1e-6 * grid.h;
            let xl = grid.cell_left(cell);
            if x - xl > 2.0 * eps && xl + grid.h - x > 2.0 * eps {
                let (mut a, mut b) = (Shape::default(), Shape::default());
                basis.eval(cell, x + eps, &mut a);
                basis.eval(cell, x - eps, &mut b);
                for k in 0..s.len {
                    let fd = (a.phi[k] - b.phi[k]) / (2.0 * eps);
                    prop_assert!((s.dphi[k] - fd).abs() < 1e-5 * grid.inv_h,
                        "k {}: {} vs {}", k, s.dphi[k], fd);
                }
            }
        }

        /// Order 1 is the linear hat basis.
        #[test]
        fn order_one_is_linear(cells in 1usize..30, t in 0.0f64..=1.0) {
            let grid = Grid::new(2.0, cells);
            let (b, l) = (BSplineBasis::new(grid, 1).unwrap(), LinearBasis::new(grid));
            let x = t * 2.0;
            let cell = grid.cell_of(x).unwrap();
            let (mut sb, mut sl) = (Shape::default(), Shape::default());
            b.eval(cell, x, &mut sb);
            l.eval(cell, x, &mut sl);
            prop_assert_eq!((sb.first, sb.len), (sl.first, sl.len));
            for k in 0..2 {
                prop_assert!((sb.phi[k] - sl.phi[k]).abs() < 1e-14);
                prop_assert!((sb.dphi[k] - sl.dphi[k]).abs() < 1e-14 * grid.inv_h);
            }
        }
    }
}
