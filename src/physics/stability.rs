//! Critical time step of the explicit step for any basis.
//!
//! The Euler–Cromer (symplectic Euler) step is stable for `dt <= 2 / omega_max`, where
//! `omega_max^2` is the largest eigenvalue of `M^{-1} K` with the lumped mass
//! `m_i = sum_p m_p phi_i(x_p)` and the stiffness `K_ij = sum_p V_p E dphi_i(x_p) dphi_j(x_p)`
//! of the initial configuration (particle quadrature, the gradients the step uses). The
//! Gershgorin bound `omega_max^2 <= max_i sum_j |K_ij| / m_i` gives a limit that is safe
//! for every basis; for linear hats it is exactly `h / c` (interior and free ends alike),
//! for quadratic B-splines it includes the stiff boundary functions of the open knot vector.
//!
//! With a consistent mass matrix in the acceleration solve the limit is lower (`M^C <= M`,
//! since `M - M^C` is diagonally dominant): for linear hats `h / (sqrt(3) c)`.
//! [`critical_time_step_consistent`] estimates `omega_max^2 = lambda_max((M^C)^{-1} K)` with
//! `M^C_ij = sum_p m_p phi_i phi_j` by power iteration (banded Cholesky of `M^C`), starting
//! from the sawtooth mode that the top of the spectrum resembles.

use crate::grid::{Basis, Shape};
use crate::linalg::{BandedCholesky, CsrMatrix};
use crate::particles::Particles;

/// Power iterations of [`critical_time_step_consistent`].
const POWER_ITERATIONS: usize = 300;

/// The particle-quadrature operators of the initial configuration: stiffness
/// `K_ij = sum_p V_p E dphi_i dphi_j`, lumped mass `m_i = sum_p m_p phi_i` and consistent
/// mass `M^C_ij = sum_p m_p phi_i phi_j` (band pattern of the basis).
struct ParticleOperators {
    stiffness: CsrMatrix,
    lumped: Vec<f64>,
    consistent: CsrMatrix,
}

fn assemble<B: Basis>(basis: &B, particles: &Particles, modulus: f64) -> ParticleOperators {
    let n = basis.num_dofs();
    let bandwidth = basis.max_window() - 1;
    let mut stiffness = CsrMatrix::band(n, bandwidth);
    let mut consistent = CsrMatrix::band(n, bandwidth);
    let mut lumped = vec![0.0; n];
    let mut shape = Shape::default();
    for p in 0..particles.len() {
        basis.eval_particle(
            particles.cell[p],
            particles.x[p],
            0.5 * particles.volume[p],
            &mut shape,
        );
        let k = particles.volume[p] * modulus;
        for a in 0..shape.len {
            let i = shape.first + a;
            lumped[i] += particles.mass[p] * shape.phi[a];
            for b in 0..shape.len {
                let index = stiffness.band_index(i, shape.first + b);
                stiffness.values[index] += k * shape.dphi[a] * shape.dphi[b];
                consistent.values[index] += particles.mass[p] * shape.phi[a] * shape.phi[b];
            }
        }
    }
    ParticleOperators {
        stiffness,
        lumped,
        consistent,
    }
}

/// `2 / sqrt(max_i sum_j |K_ij| / m_i)` for `particles` (whose `cell` is current) and
/// elastic modulus `modulus`; `f64::INFINITY` if there is no stiffness at all.
pub fn critical_time_step<B: Basis>(basis: &B, particles: &Particles, modulus: f64) -> f64 {
    let ParticleOperators {
        stiffness,
        lumped: mass,
        ..
    } = assemble(basis, particles, modulus);
    let n = mass.len();
    let omega_squared = (0..n)
        .filter(|&i| mass[i] > 0.0)
        .map(|i| {
            let row: f64 = stiffness.values[stiffness.row_start[i]..stiffness.row_start[i + 1]]
                .iter()
                .map(|k| k.abs())
                .sum();
            row / mass[i]
        })
        .fold(0.0, f64::max);
    if omega_squared > 0.0 {
        2.0 / omega_squared.sqrt()
    } else {
        f64::INFINITY
    }
}

/// `2 / omega_max` of the consistent-mass system of `particles`, `omega_max^2` the
/// Rayleigh quotient after [`POWER_ITERATIONS`] power iterations on `(M^C)^{-1} K` (an
/// estimate from below of the largest eigenvalue); DOFs without mass are left out.
/// `f64::INFINITY` if there is no stiffness, or if `M^C` cannot be factored.
pub fn critical_time_step_consistent<B: Basis>(
    basis: &B,
    particles: &Particles,
    modulus: f64,
) -> f64 {
    let ParticleOperators {
        mut stiffness,
        consistent: mut mass,
        ..
    } = assemble(basis, particles, modulus);
    let n = mass.rows;
    let active: Vec<bool> = mass.diagonal().iter().map(|&m| m > 0.0).collect();
    mass.constrain(&active);
    for i in 0..n {
        for k in stiffness.row_start[i]..stiffness.row_start[i + 1] {
            if !active[i] || !active[stiffness.col_index[k]] {
                stiffness.values[k] = 0.0;
            }
        }
    }
    let mut solver = BandedCholesky::new();
    if solver.factor(&mass).is_err() {
        return f64::INFINITY;
    }
    let mut x: Vec<f64> = (0..n)
        .map(|i| {
            if !active[i] {
                0.0
            } else if i % 2 == 0 {
                1.0
            } else {
                -1.0
            }
        })
        .collect();
    let (mut kx, mut z) = (vec![0.0; n], vec![0.0; n]);
    let mut lambda = 0.0;
    for _ in 0..POWER_ITERATIONS {
        stiffness.mul_vec(&x, &mut kx);
        let x_k_x: f64 = x.iter().zip(&kx).map(|(a, b)| a * b).sum();
        mass.mul_vec(&x, &mut z);
        let x_m_x: f64 = x.iter().zip(&z).map(|(a, b)| a * b).sum();
        if x_m_x.is_nan() || x_m_x <= 0.0 {
            break;
        }
        lambda = x_k_x / x_m_x;
        solver.solve_factored(&kx, &mut z);
        let norm = z.iter().map(|v| v * v).sum::<f64>().sqrt();
        if !norm.is_finite() || norm <= 0.0 {
            break;
        }
        for (xi, zi) in x.iter_mut().zip(&z) {
            *xi = zi / norm;
        }
    }
    if lambda > 0.0 {
        2.0 / lambda.sqrt()
    } else {
        f64::INFINITY
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{BSplineBasis, Grid, LinearBasis};

    #[test]
    fn linear_hats_give_h_over_c() {
        let grid = Grid::new(50.0, 50);
        let particles = Particles::at_subcell_centres(&grid, 20, 1.0);
        let dt = critical_time_step(&LinearBasis::new(grid), &particles, 1e6);
        assert!((dt - 1e-3).abs() < 1e-12, "{dt}");
    }

    #[test]
    fn consistent_linear_hats_give_h_over_sqrt3_c() {
        let grid = Grid::new(50.0, 50);
        let particles = Particles::at_subcell_centres(&grid, 20, 1.0);
        let dt = critical_time_step_consistent(&LinearBasis::new(grid), &particles, 1e6);
        let exact = 1e-3 / 3f64.sqrt();
        // Free ends make the top mode slightly stiffer than the interior sawtooth.
        assert!(dt <= exact * 1.001 && dt > 0.95 * exact, "{dt} vs {exact}");
        // Below the lumped limit for every order.
        let grid = Grid::new(1.0, 20);
        let particles = Particles::at_subcell_centres(&grid, 8, 1.0);
        for p in 1..=4 {
            let basis = BSplineBasis::new(grid, p).unwrap();
            let consistent = critical_time_step_consistent(&basis, &particles, 1.0);
            let lumped = critical_time_step(&basis, &particles, 1.0);
            assert!(consistent < lumped, "p {p}: {consistent} vs {lumped}");
        }
    }

    #[test]
    fn higher_orders_are_bounded_and_shrink() {
        // The Gershgorin limit is below the true one (a safe bound) but of the same size.
        let grid = Grid::new(1.0, 20);
        let particles = Particles::at_subcell_centres(&grid, 8, 1.0);
        let mut previous = f64::INFINITY;
        for p in 1..=5 {
            let basis = BSplineBasis::new(grid, p).unwrap();
            let dt = critical_time_step(&basis, &particles, 1.0);
            assert!(
                dt > 0.2 * grid.h && dt <= 1.0 * grid.h + 1e-12,
                "p {p}: {dt}"
            );
            assert!(dt <= previous * 1.0001, "p {p}");
            previous = dt;
        }
    }
}
