//! Constitutive laws of the dimension-generic core (`docs/dimensions.md`): the Cauchy
//! stress (3x3 symmetric, order `xx, yy, zz, xy, xz, yz`) after a step, from the old stress,
//! the velocity-gradient increment `dt L` and the deformation gradient `F` after it
//! (`F <- (I + dt L) F`, `J = det F`; plane strain: `F_zz = 1`).
//!
//! * linear elastic (small strain, hypo-elastic):
//!   `sigma += lambda tr(d eps) I + 2 mu d eps`, `d eps = sym(dt L)`;
//!   with Poisson's ratio 0 (`lambda = 0`, `mu = E / 2`) `sigma_xx += E d eps_xx`, the 1D law;
//! * compressible neo-Hookean (hyperelastic):
//!   `sigma = (lambda ln J / J) I + (mu / J)(B - I)`, `B = F F^T`, stored energy per
//!   reference volume `W = mu/2 (tr B - 3) - mu ln J + lambda/2 (ln J)^2`.

use crate::particles::tensor::stress_index;

/// Lamé constants from Young's modulus and Poisson's ratio:
/// `lambda = E nu / ((1 + nu)(1 - 2 nu))`, `mu = E / (2 (1 + nu))`.
///
/// ```
/// let (lambda, mu) = tlsmpm::physics::tensor::lame(1e4, 0.0);
/// assert_eq!((lambda, mu), (0.0, 5e3));
/// ```
pub fn lame(youngs_modulus: f64, poisson_ratio: f64) -> (f64, f64) {
    let (e, nu) = (youngs_modulus, poisson_ratio);
    (
        e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)),
        e / (2.0 * (1.0 + nu)),
    )
}

/// A stress update, monomorphised into the particle loop.
pub trait TensorLaw: Copy + Send + Sync {
    /// New stress from the old one, `dt L` and `F` (after the step) with `J = det F`.
    fn update<const D: usize>(
        &self,
        stress: &mut [f64; 6],
        velocity_gradient_increment: &[[f64; D]; D],
        deformation_gradient: &[[f64; D]; D],
        jacobian: f64,
    );
    /// Stored energy of a particle of current volume `volume` and initial volume
    /// `volume0` (for `history.csv`).
    fn stored_energy<const D: usize>(
        &self,
        stress: &[f64; 6],
        deformation_gradient: &[[f64; D]; D],
        volume: f64,
        volume0: f64,
    ) -> f64;
    /// P-wave modulus `lambda + 2 mu` (the stability limit's wave speed).
    fn wave_modulus(&self) -> f64;

    /// [`TensorLaw::update`], then the particle's stored energy
    /// ([`TensorLaw::stored_energy`] at the new state), sharing what both need.
    #[inline(always)]
    fn update_with_energy<const D: usize>(
        &self,
        stress: &mut [f64; 6],
        velocity_gradient_increment: &[[f64; D]; D],
        deformation_gradient: &[[f64; D]; D],
        jacobian: f64,
        volume0: f64,
    ) -> f64 {
        self.update(
            stress,
            velocity_gradient_increment,
            deformation_gradient,
            jacobian,
        );
        self.stored_energy(stress, deformation_gradient, jacobian * volume0, volume0)
    }
}

/// Small-strain linear elasticity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinearElasticTensor {
    pub lambda: f64,
    pub mu: f64,
}

impl TensorLaw for LinearElasticTensor {
    #[inline(always)]
    fn update<const D: usize>(
        &self,
        stress: &mut [f64; 6],
        dl: &[[f64; D]; D],
        _f: &[[f64; D]; D],
        _j: f64,
    ) {
        let mut trace = 0.0;
        for (a, row) in dl.iter().enumerate() {
            trace += row[a];
        }
        for a in 0..3 {
            stress[a] += self.lambda * trace;
        }
        for a in 0..D {
            for b in a..D {
                let strain = 0.5 * (dl[a][b] + dl[b][a]);
                stress[stress_index(a, b)] += 2.0 * self.mu * strain;
            }
        }
    }

    /// `V W(sigma)` with the complementary energy
    /// `W = (sigma : sigma - lambda / (3 lambda + 2 mu) (tr sigma)^2) / (4 mu)`.
    fn stored_energy<const D: usize>(
        &self,
        s: &[f64; 6],
        _f: &[[f64; D]; D],
        volume: f64,
        _volume0: f64,
    ) -> f64 {
        let trace = s[0] + s[1] + s[2];
        let contraction = s[0] * s[0]
            + s[1] * s[1]
            + s[2] * s[2]
            + 2.0 * (s[3] * s[3] + s[4] * s[4] + s[5] * s[5]);
        let w = (contraction - self.lambda / (3.0 * self.lambda + 2.0 * self.mu) * trace * trace)
            / (4.0 * self.mu);
        volume * w
    }

    fn wave_modulus(&self) -> f64 {
        self.lambda + 2.0 * self.mu
    }
}

/// Compressible neo-Hookean hyperelasticity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NeoHookeanTensor {
    pub lambda: f64,
    pub mu: f64,
}

/// `B = F F^T` of a `D x D` gradient embedded in 3D (`F_zz = 1` below 3D), as the six
/// components `xx, yy, zz, xy, xz, yz`, and its trace.
#[inline(always)]
fn left_cauchy_green<const D: usize>(f: &[[f64; D]; D]) -> [f64; 6] {
    let mut b = [0.0; 6];
    b[2] = 1.0;
    b[1] = 1.0;
    for a in 0..D {
        for c in a..D {
            let mut sum = 0.0;
            for k in 0..D {
                sum += f[a][k] * f[c][k];
            }
            b[stress_index(a, c)] = sum;
        }
    }
    b
}

impl TensorLaw for NeoHookeanTensor {
    #[inline(always)]
    fn update<const D: usize>(
        &self,
        stress: &mut [f64; 6],
        _dl: &[[f64; D]; D],
        f: &[[f64; D]; D],
        j: f64,
    ) {
        let b = left_cauchy_green(f);
        let inv_j = 1.0 / j;
        let pressure = self.lambda * j.ln() * inv_j;
        let mu_j = self.mu * inv_j;
        for a in 0..3 {
            stress[a] = pressure + mu_j * (b[a] - 1.0);
        }
        for a in 3..6 {
            stress[a] = mu_j * b[a];
        }
    }

    /// One `B` and one `ln J` for the stress and the energy.
    #[inline(always)]
    fn update_with_energy<const D: usize>(
        &self,
        stress: &mut [f64; 6],
        _dl: &[[f64; D]; D],
        f: &[[f64; D]; D],
        j: f64,
        volume0: f64,
    ) -> f64 {
        let b = left_cauchy_green(f);
        let inv_j = 1.0 / j;
        let ln_j = j.ln();
        let pressure = self.lambda * ln_j * inv_j;
        let mu_j = self.mu * inv_j;
        for a in 0..3 {
            stress[a] = pressure + mu_j * (b[a] - 1.0);
        }
        for a in 3..6 {
            stress[a] = mu_j * b[a];
        }
        let w = 0.5 * self.mu * (b[0] + b[1] + b[2] - 3.0) - self.mu * ln_j
            + 0.5 * self.lambda * ln_j * ln_j;
        volume0 * w
    }

    fn stored_energy<const D: usize>(
        &self,
        _s: &[f64; 6],
        f: &[[f64; D]; D],
        volume: f64,
        volume0: f64,
    ) -> f64 {
        let b = left_cauchy_green(f);
        let ln_j = (volume / volume0).ln();
        let w = 0.5 * self.mu * (b[0] + b[1] + b[2] - 3.0) - self.mu * ln_j
            + 0.5 * self.lambda * ln_j * ln_j;
        volume0 * w
    }

    fn wave_modulus(&self) -> f64 {
        self.lambda + 2.0 * self.mu
    }
}

/// The law of a 2D / 3D run, dispatched once per step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TensorMaterial {
    Linear(LinearElasticTensor),
    NeoHookean(NeoHookeanTensor),
}

impl TensorMaterial {
    /// P-wave modulus `lambda + 2 mu`.
    pub fn wave_modulus(&self) -> f64 {
        match self {
            TensorMaterial::Linear(l) => l.wave_modulus(),
            TensorMaterial::NeoHookean(l) => l.wave_modulus(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_law_with_zero_poisson_ratio_is_the_1d_law() {
        let (lambda, mu) = lame(7e6, 0.0);
        let law = LinearElasticTensor { lambda, mu };
        let mut s = [0.0; 6];
        let dl = [[1e-4, 0.0], [0.0, 0.0]];
        law.update(&mut s, &dl, &[[1.0, 0.0], [0.0, 1.0]], 1.0);
        assert_eq!(s, [7e6 * 1e-4, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let energy = law.stored_energy(&s, &[[1.0, 0.0], [0.0, 1.0]], 2.0, 2.0);
        assert!((energy - 2.0 * 0.5 * s[0] * s[0] / 7e6).abs() < 1e-12 * energy);
    }

    #[test]
    fn linear_law_plane_strain_has_the_lateral_stress() {
        let (lambda, mu) = lame(1e4, 0.3);
        let law = LinearElasticTensor { lambda, mu };
        let mut s = [0.0; 6];
        law.update(
            &mut s,
            &[[1e-3, 2e-3], [0.0, 0.0]],
            &[[1.0, 0.0], [0.0, 1.0]],
            1.0,
        );
        assert!((s[0] - (lambda + 2.0 * mu) * 1e-3).abs() < 1e-12);
        assert!((s[1] - lambda * 1e-3).abs() < 1e-12);
        assert!((s[2] - lambda * 1e-3).abs() < 1e-12);
        assert!((s[3] - mu * 2e-3).abs() < 1e-12);
    }

    #[test]
    fn neo_hookean_stress_is_the_derivative_of_its_energy() {
        // Uniaxial stretch in 3D: sigma_xx = (1/J) dW/dF_xx * F_xx, by central differences.
        let law = NeoHookeanTensor {
            lambda: 5.7e3,
            mu: 3.8e3,
        };
        let energy = |fxx: f64| {
            let f = [[fxx, 0.0, 0.0], [0.0, 1.1, 0.0], [0.0, 0.0, 0.95]];
            let j = fxx * 1.1 * 0.95;
            law.stored_energy(&[0.0; 6], &f, j, 1.0)
        };
        let fxx = 1.2;
        let h = 1e-5;
        let dw = (energy(fxx + h) - energy(fxx - h)) / (2.0 * h);
        let f = [[fxx, 0.0, 0.0], [0.0, 1.1, 0.0], [0.0, 0.0, 0.95]];
        let j = fxx * 1.1 * 0.95;
        let mut s = [0.0; 6];
        law.update(&mut s, &[[0.0; 3]; 3], &f, j);
        assert!(
            (s[0] - dw * fxx / j).abs() < 1e-6 * s[0].abs(),
            "{} vs {}",
            s[0],
            dw * fxx / j
        );
        // Undeformed: stress free.
        let mut s = [1.0; 6];
        law.update(&mut s, &[[0.0; 2]; 2], &[[1.0, 0.0], [0.0, 1.0]], 1.0);
        assert_eq!(s, [0.0; 6]);
    }
}
