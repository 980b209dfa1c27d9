//! Stability limit of the explicit 2D / 3D step with lumped mass: the 1D Gershgorin limit
//! `dt_a` of each axis' basis (see [`crate::physics::stability::critical_time_step`]) with
//! the P-wave modulus `M = lambda + 2 mu`, combined as `omega^2 <= sum_a omega_a^2`, so
//! `dt = 1 / sqrt(sum_a 1 / dt_a^2)`. For linear hats on a square grid this is
//! `h / (sqrt(D) c)`, `c = sqrt(M / rho)`.

use crate::grid::{Basis, TensorBasis};
use crate::particles::Particles;
use crate::physics::stability::critical_time_step;

/// The limit for `per_axis[a]` particles per cell along axis `a` at density `density`.
pub fn tensor_critical_time_step<const D: usize, B: Basis>(
    basis: &TensorBasis<D, B>,
    per_axis: [usize; D],
    density: f64,
    modulus: f64,
) -> f64 {
    let mut sum = 0.0;
    for a in 0..D {
        let grid = basis.grid.axes[a];
        let particles = Particles::at_subcell_centres(&grid, per_axis[a], density);
        let dt = critical_time_step(basis.axis(a), &particles, modulus);
        if dt.is_finite() {
            sum += 1.0 / (dt * dt);
        }
    }
    if sum > 0.0 {
        1.0 / sum.sqrt()
    } else {
        f64::INFINITY
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{LinearBasis, TensorGrid};

    #[test]
    fn linear_hats_on_a_square_grid_give_h_over_sqrt_d_c() {
        let grid = TensorGrid::new([1.0, 1.0], [10, 10]);
        let basis = TensorBasis::new(grid, LinearBasis::new);
        let dt = tensor_critical_time_step(&basis, [2, 2], 4.0, 100.0);
        let expected = 0.1 / (2f64.sqrt() * 5.0);
        assert!(
            (dt - expected).abs() < 1e-12 * expected,
            "{dt} vs {expected}"
        );
    }
}
