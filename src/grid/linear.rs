//! Piecewise-linear hat functions (standard MPM, SPEC §3.1): on cell `e = [x_e, x_e + h]`,
//! `phi_e = (x_e + h - x) / h`, `phi_{e+1} = (x - x_e) / h`, gradients `-1/h`, `+1/h`
//! (discontinuous at nodes: the grid-crossing error).

use super::{Basis, Grid, Shape};

/// Linear hat basis on a uniform grid: `N_n = N_e + 1` nodes.
#[derive(Clone, Copy, Debug)]
pub struct LinearBasis {
    grid: Grid,
}

impl LinearBasis {
    pub fn new(grid: Grid) -> Self {
        Self { grid }
    }
}

impl Basis for LinearBasis {
    fn name(&self) -> &'static str {
        "linear"
    }

    fn num_dofs(&self) -> usize {
        self.grid.cells + 1
    }

    #[inline]
    fn cell_window(&self, cell: usize) -> (usize, usize) {
        (cell, 2)
    }

    fn max_window(&self) -> usize {
        2
    }

    #[inline(always)]
    fn eval(&self, cell: usize, x: f64, shape: &mut Shape) {
        let xi = (x - self.grid.cell_left(cell)) * self.grid.inv_h;
        shape.first = cell;
        shape.len = 2;
        shape.phi[0] = 1.0 - xi;
        shape.phi[1] = xi;
        shape.dphi[0] = -self.grid.inv_h;
        shape.dphi[1] = self.grid.inv_h;
    }

    #[inline(always)]
    fn eval_particle(&self, cell: usize, x: f64, _half_length: f64, shape: &mut Shape) {
        self.eval(cell, x, shape);
    }

    fn fixed_support(&self) -> Option<usize> {
        Some(2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn partition_of_unity_and_gradients(cells in 1usize..50, t in 0.0f64..1.0) {
            let grid = Grid::new(2.5, cells);
            let basis = LinearBasis::new(grid);
            let x = t * grid.length;
            let cell = grid.cell_of(x).unwrap();
            let mut s = Shape::default();
            basis.eval(cell, x, &mut s);
            let sum: f64 = s.phi[..s.len].iter().sum();
            let dsum: f64 = s.dphi[..s.len].iter().sum();
            prop_assert!((sum - 1.0).abs() < 1e-14);
            prop_assert!(dsum.abs() < 1e-12 / grid.h);
            prop_assert!(s.phi[..s.len].iter().all(|&p| p >= -1e-14));
            // Linear fields are reproduced exactly, with exact gradients.
            let nodes: Vec<f64> = (0..=cells).map(|i| 3.0 * grid.cell_left(i) - 1.0).collect();
            prop_assert!((s.interpolate(&nodes) - (3.0 * x - 1.0)).abs() < 1e-12);
            prop_assert!((s.gradient(&nodes) - 3.0).abs() < 1e-9);
        }
    }
}
