//! GIMP (generalized interpolation material point, SPEC §3.5): the linear hats averaged over
//! the particle domain `[x_1, x_2] = [x_p - l_p, x_p + l_p]` (see [`super::domain`]),
//!
//! ```text
//! phi_bar_i  = (1 / (x_2 - x_1)) int_{x_1}^{x_2} phi_i dx        (exact, by linear pieces)
//! dphi_bar_i = (phi_i(x_2) - phi_i(x_1)) / (x_2 - x_1)
//! ```
//!
//! The averaged functions are a non-negative partition of unity and their gradients sum to
//! zero. A point evaluation ([`super::Basis::eval`]) is the plain linear hat.

use super::domain::{hat_at, DomainBasis, DomainWeight, NodeSpan};
use super::Grid;

/// The exact domain average of the hat.
#[derive(Clone, Copy, Debug, Default)]
pub struct GimpAverage;

impl DomainWeight for GimpAverage {
    const NAME: &'static str = "gimp";

    #[inline]
    fn weight(
        grid: &Grid,
        span: NodeSpan,
        x1: f64,
        x2: f64,
        inv_length: f64,
        _hat1: f64,
        _hat2: f64,
    ) -> f64 {
        // The hat is linear between the nodes X_{node-1}, X_node, X_{node+1}: on each piece
        // of [x1, x2] between them its mean is its midpoint value. Summing pieces avoids the
        // cancellation of an antiderivative difference on short domains.
        let mut start = x1;
        let mut integral = 0.0;
        for end in [span.left, span.node, span.right, x2] {
            if end > start && end <= x2 {
                integral += hat_at(grid, span.node, 0.5 * (start + end)) * (end - start);
                start = end;
            }
        }
        integral * inv_length
    }

    /// One piece, `[x1, x2]`: the loop above without its branches (`0 + y = y` for the
    /// non-negative `y`), the same bits.
    #[inline(always)]
    fn inside_weight(
        grid: &Grid,
        span: NodeSpan,
        x1: f64,
        x2: f64,
        inv_length: f64,
        _hat1: f64,
        _hat2: f64,
    ) -> f64 {
        hat_at(grid, span.node, 0.5 * (x1 + x2)) * (x2 - x1) * inv_length
    }
}

/// GIMP weights on the linear grid.
pub type GimpBasis = DomainBasis<GimpAverage>;

#[cfg(test)]
mod tests {
    use super::super::domain::clipped_domain;
    use super::*;
    use crate::grid::domain::hat;
    use crate::grid::{Basis, Shape};
    use proptest::prelude::*;

    proptest! {
        /// Partition of unity, non-negativity, gradients summing to zero, exact gradient of
        /// a linear field, and agreement with a midpoint-rule average of the hats.
        #[test]
        fn averaged_hats(cells in 1usize..20, t in 0.0f64..=1.0, l in 0.0f64..1.2) {
            let grid = Grid::new(2.0, cells);
            let basis = GimpBasis::new(grid);
            let x = t * grid.length;
            let cell = grid.cell_of(x).unwrap();
            let half = l * grid.h;
            let mut s = Shape::default();
            basis.eval_particle(cell, x, half, &mut s);
            let sum: f64 = s.phi[..s.len].iter().sum();
            prop_assert!((sum - 1.0).abs() < 1e-13, "{}", sum);
            prop_assert!(s.phi[..s.len].iter().all(|&v| v >= -1e-15));
            let dsum: f64 = s.dphi[..s.len].iter().sum();
            prop_assert!(dsum.abs() < 1e-12 * grid.inv_h);
            let g: f64 = (0..s.len).map(|k| s.dphi[k] * 3.0 * grid.cell_left(s.first + k)).sum();
            prop_assert!((g - 3.0).abs() < 1e-10, "{}", g);
            if let Some((x1, x2)) = clipped_domain(&grid, x, half) {
                let n = 4000;
                let dx = (x2 - x1) / n as f64;
                for k in 0..s.len {
                    let avg: f64 = (0..n)
                        .map(|m| hat(&grid, s.first + k, x1 + (m as f64 + 0.5) * dx))
                        .sum::<f64>() / n as f64;
                    prop_assert!((avg - s.phi[k]).abs() < 1e-6, "{} vs {}", avg, s.phi[k]);
                }
            }
        }
    }
}
