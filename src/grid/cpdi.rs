//! 1D CPDI (convected particle domain interpolation, SPEC §3.5): the particle domain
//! `[x_1, x_2]` is convected with the deformation (in 1D its corners are `x_p -+ V_p / 2`,
//! see [`super::domain`]), and the hats are interpolated linearly between the corners,
//!
//! ```text
//! phi_bar_i  = (phi_i(x_1) + phi_i(x_2)) / 2
//! dphi_bar_i = (phi_i(x_2) - phi_i(x_1)) / (x_2 - x_1)
//! ```
//!
//! (the CPDI weights of Sadeghirad et al.; they differ from GIMP's exact averages only when
//! a node lies inside the domain). Partition of unity and zero gradient sum hold exactly.

use super::domain::{clipped_domain, domain_window, hat};
use super::{Basis, Grid, LinearBasis, Shape};

/// CPDI weights on the linear grid.
#[derive(Clone, Copy, Debug)]
pub struct CpdiBasis {
    grid: Grid,
}

impl CpdiBasis {
    pub fn new(grid: Grid) -> Self {
        Self { grid }
    }
}

impl Basis for CpdiBasis {
    fn name(&self) -> &'static str {
        "cpdi"
    }

    fn num_dofs(&self) -> usize {
        self.grid.cells + 1
    }

    #[inline]
    fn cell_window(&self, cell: usize) -> (usize, usize) {
        domain_window(&self.grid, cell)
    }

    fn max_window(&self) -> usize {
        4.min(self.grid.cells + 1)
    }

    #[inline]
    fn eval(&self, cell: usize, x: f64, shape: &mut Shape) {
        LinearBasis::new(self.grid).eval(cell, x, shape);
    }

    #[inline]
    fn eval_particle(&self, cell: usize, x: f64, half_length: f64, shape: &mut Shape) {
        let Some((x1, x2)) = clipped_domain(&self.grid, x, half_length) else {
            return self.eval(cell, x, shape);
        };
        let grid = &self.grid;
        let (first, len) = domain_window(grid, cell);
        let inv_length = 1.0 / (x2 - x1);
        for k in 0..len {
            let node = first + k;
            let (n1, n2) = (hat(grid, node, x1), hat(grid, node, x2));
            shape.phi[k] = 0.5 * (n1 + n2);
            shape.dphi[k] = (n2 - n1) * inv_length;
        }
        shape.first = first;
        shape.len = len;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::GimpBasis;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn corner_interpolated_hats(cells in 1usize..20, t in 0.0f64..=1.0, l in 0.0f64..1.2) {
            let grid = Grid::new(2.0, cells);
            let basis = CpdiBasis::new(grid);
            let x = t * grid.length;
            let cell = grid.cell_of(x).unwrap();
            let mut s = Shape::default();
            basis.eval_particle(cell, x, l * grid.h, &mut s);
            let sum: f64 = s.phi[..s.len].iter().sum();
            prop_assert!((sum - 1.0).abs() < 1e-13);
            prop_assert!(s.phi[..s.len].iter().all(|&v| v >= 0.0));
            let dsum: f64 = s.dphi[..s.len].iter().sum();
            prop_assert!(dsum.abs() < 1e-12 * grid.inv_h);
            // Same gradients as GIMP (both are the domain average of dphi).
            let mut g = Shape::default();
            GimpBasis::new(grid).eval_particle(cell, x, l * grid.h, &mut g);
            for k in 0..s.len {
                prop_assert!((s.dphi[k] - g.dphi[k]).abs() < 1e-12 * grid.inv_h);
            }
        }
    }

    #[test]
    fn weights_differ_from_gimp_only_across_a_node() {
        let grid = Grid::new(1.0, 10);
        let (mut c, mut g) = (Shape::default(), Shape::default());
        // Domain [0.42, 0.48] inside cell 4: identical.
        CpdiBasis::new(grid).eval_particle(4, 0.45, 0.03, &mut c);
        GimpBasis::new(grid).eval_particle(4, 0.45, 0.03, &mut g);
        for k in 0..c.len {
            assert!((c.phi[k] - g.phi[k]).abs() < 1e-14);
        }
        // Domain [0.47, 0.53] around node 5: CPDI underestimates the peak.
        CpdiBasis::new(grid).eval_particle(5, 0.5, 0.03, &mut c);
        GimpBasis::new(grid).eval_particle(5, 0.5, 0.03, &mut g);
        let node5 = 5 - c.first;
        assert!(c.phi[node5] < g.phi[node5] - 1e-3);
    }
}
