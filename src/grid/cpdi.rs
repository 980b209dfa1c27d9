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

use super::domain::{DomainBasis, DomainWeight, NodeSpan};
use super::Grid;

/// The corner average of the hat.
#[derive(Clone, Copy, Debug, Default)]
pub struct CpdiCorners;

impl DomainWeight for CpdiCorners {
    const NAME: &'static str = "cpdi";

    #[inline]
    fn weight(
        _grid: &Grid,
        _span: NodeSpan,
        _x1: f64,
        _x2: f64,
        _inv_length: f64,
        hat1: f64,
        hat2: f64,
    ) -> f64 {
        0.5 * (hat1 + hat2)
    }
}

/// CPDI weights on the linear grid.
pub type CpdiBasis = DomainBasis<CpdiCorners>;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{Basis, GimpBasis, Shape};
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
