//! One-dimensional constitutive laws (SPEC §1.1, §6.5), as stress updates from a strain
//! increment `deps = dphi^T du` and the deformation gradient `F` after it
//! (`F *= 1 + deps`, `V = F V_0`):
//!
//! * small strain, linear elastic: `sigma += E deps`;
//! * large strain (Hill): `sigma += (E - sigma) deps`, the rate form of
//!   `d sigma / dt = (E - sigma) dv/dx`, whose exact integral is `J = E / (E - sigma)`;
//! * neo-Hookean (hyperelastic, from `F` alone): `sigma = P = lambda ln(F)/F + mu (F - 1/F)`
//!   (in 1D the Cauchy stress `P F / J` equals `P` since `J = F`).

use crate::config::{MaterialConfig, MaterialModel};

/// A stress update `sigma_new = update(sigma, deps)`, monomorphised into particle loops.
pub trait ConstitutiveLaw: Copy + Send + Sync {
    /// New stress from the old stress, the strain increment and the deformation gradient
    /// `F` after the increment.
    fn update(&self, stress: f64, strain_increment: f64, deformation_gradient: f64) -> f64;
    /// Stored energy per unit volume at stress `stress` and deformation gradient `F`
    /// (for `history.csv`).
    fn strain_energy_density(&self, stress: f64, deformation_gradient: f64) -> f64;
    /// The modulus that sets the wave speed `c = sqrt(modulus / rho)` (stability limit).
    fn wave_modulus(&self) -> f64;
}

/// Small-strain linear elasticity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinearElastic {
    pub youngs_modulus: f64,
}

impl ConstitutiveLaw for LinearElastic {
    #[inline]
    fn update(&self, stress: f64, strain_increment: f64, _deformation_gradient: f64) -> f64 {
        stress + self.youngs_modulus * strain_increment
    }
    fn strain_energy_density(&self, stress: f64, _deformation_gradient: f64) -> f64 {
        0.5 * stress * stress / self.youngs_modulus
    }
    fn wave_modulus(&self) -> f64 {
        self.youngs_modulus
    }
}

/// Hill's large-strain law.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hill {
    pub youngs_modulus: f64,
}

impl ConstitutiveLaw for Hill {
    #[inline]
    fn update(&self, stress: f64, strain_increment: f64, _deformation_gradient: f64) -> f64 {
        stress + (self.youngs_modulus - stress) * strain_increment
    }
    /// `int sigma d(ln J)` with `J = E / (E - sigma)`: `-sigma - E ln(1 - sigma / E)`.
    fn strain_energy_density(&self, stress: f64, _deformation_gradient: f64) -> f64 {
        let e = self.youngs_modulus;
        let s = stress / e;
        if s.abs() < 1e-3 {
            // E (s^2/2 + s^3/3 + s^4/4 + ...), free of cancellation.
            e * s * s * (0.5 + s * (1.0 / 3.0 + s * (0.25 + s * 0.2)))
        } else {
            e * (-s - (-s).ln_1p())
        }
    }
    fn wave_modulus(&self) -> f64 {
        self.youngs_modulus
    }
}

/// 1D neo-Hookean hyperelasticity (SPEC §6.5).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NeoHookean {
    /// `mu`.
    pub shear_modulus: f64,
    /// `lambda`.
    pub lame_lambda: f64,
}

impl NeoHookean {
    /// `P(F) = lambda ln(F)/F + mu (F - 1/F)` (NaN for `F <= 0`).
    ///
    /// ```
    /// use tlsmpm::physics::material::NeoHookean;
    /// let law = NeoHookean { shear_modulus: 3.85e6, lame_lambda: 5.77e6 };
    /// assert_eq!(law.stress(1.0), 0.0);
    /// assert!(law.stress(1.1) > 0.0 && law.stress(0.9) < 0.0);
    /// ```
    #[inline]
    pub fn stress(&self, f: f64) -> f64 {
        if f <= 0.0 {
            return f64::NAN;
        }
        self.lame_lambda * f.ln() / f + self.shear_modulus * (f - 1.0 / f)
    }

    /// `dP/dF = lambda (1 - ln F)/F^2 + mu (1 + 1/F^2)`.
    pub fn tangent(&self, f: f64) -> f64 {
        let f2 = f * f;
        self.lame_lambda * (1.0 - f.ln()) / f2 + self.shear_modulus * (1.0 + 1.0 / f2)
    }
}

impl ConstitutiveLaw for NeoHookean {
    #[inline]
    fn update(&self, _stress: f64, _strain_increment: f64, deformation_gradient: f64) -> f64 {
        self.stress(deformation_gradient)
    }
    /// `W(F) = mu/2 (F^2 - 1 - 2 ln F) + lambda/2 (ln F)^2`, whose derivative is `P`.
    fn strain_energy_density(&self, _stress: f64, deformation_gradient: f64) -> f64 {
        let f = deformation_gradient;
        let ln_f = f.ln();
        0.5 * self.shear_modulus * (f * f - 1.0 - 2.0 * ln_f) + 0.5 * self.lame_lambda * ln_f * ln_f
    }
    /// The tangent at `F = 1`, `lambda + 2 mu` (the P-wave modulus).
    fn wave_modulus(&self) -> f64 {
        self.tangent(1.0)
    }
}

/// The one-phase materials, dispatched once per step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Material {
    Linear(LinearElastic),
    Hill(Hill),
    NeoHookean(NeoHookean),
}

impl Material {
    /// Build from `[material]`; only the one-phase elastic models are accepted (validated
    /// earlier by [`crate::config::Scenario::validate`]).
    pub fn from_config(config: &MaterialConfig) -> Option<Self> {
        match config.model {
            MaterialModel::Linear => Some(Material::Linear(LinearElastic {
                youngs_modulus: config.youngs_modulus,
            })),
            MaterialModel::Hill => Some(Material::Hill(Hill {
                youngs_modulus: config.youngs_modulus,
            })),
            MaterialModel::NeoHookean => Some(Material::NeoHookean(NeoHookean {
                shear_modulus: config.shear_modulus?,
                lame_lambda: config.lame_lambda?,
            })),
            MaterialModel::TwoPhase => None,
        }
    }

    /// [`Material::from_config`], or an input error naming `material.model` for models that
    /// are not one-phase elastic laws.
    pub fn require(config: &MaterialConfig) -> crate::error::Result<Self> {
        Self::from_config(config).ok_or_else(|| {
            crate::error::Error::invalid(
                "material.model",
                crate::config::toml_value(&config.model),
                "not a one-phase elastic model",
            )
        })
    }

    /// The modulus of the wave speed.
    pub fn wave_modulus(&self) -> f64 {
        match self {
            Material::Linear(l) => l.wave_modulus(),
            Material::Hill(l) => l.wave_modulus(),
            Material::NeoHookean(l) => l.wave_modulus(),
        }
    }

    /// Stored energy per unit volume.
    pub fn strain_energy_density(&self, stress: f64, deformation_gradient: f64) -> f64 {
        match self {
            Material::Linear(l) => l.strain_energy_density(stress, deformation_gradient),
            Material::Hill(l) => l.strain_energy_density(stress, deformation_gradient),
            Material::NeoHookean(l) => l.strain_energy_density(stress, deformation_gradient),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hill_integrates_to_its_closed_form() {
        // Uniaxial stretch J in N equal log-strain increments: sigma -> E (1 - 1/J).
        let law = Hill {
            youngs_modulus: 1e6,
        };
        let j: f64 = 0.8;
        let n = 200_000;
        let deps = (j.ln() / n as f64).exp() - 1.0;
        let mut sigma = 0.0;
        for _ in 0..n {
            sigma = law.update(sigma, deps, 1.0);
        }
        let exact = 1e6 * (1.0 - 1.0 / j);
        assert!(
            (sigma - exact).abs() < 1e-3 * exact.abs(),
            "{sigma} vs {exact}"
        );
        for sigma in [-1e4, -1e-3, 1e-6, 2e3] {
            let w = law.strain_energy_density(sigma, 1.0);
            assert!(
                w > 0.0 && (w - sigma * sigma / 2e6).abs() < 0.02 * w,
                "{sigma}: {w}"
            );
        }
    }

    #[test]
    fn linear_is_linear() {
        let law = LinearElastic {
            youngs_modulus: 7e6,
        };
        assert_eq!(law.update(1.0, 1e-6, 1.0), 1.0 + 7.0);
        assert_eq!(law.strain_energy_density(7e6 * 1e-3, 1.0), 0.5 * 7e6 * 1e-6);
    }

    #[test]
    fn neo_hookean_stress_is_the_derivative_of_its_energy() {
        let law = NeoHookean {
            shear_modulus: 3.85e6,
            lame_lambda: 5.77e6,
        };
        for f in [0.4, 0.8, 1.0, 1.3, 1.7] {
            let h = 1e-6;
            let dw = (law.strain_energy_density(0.0, f + h)
                - law.strain_energy_density(0.0, f - h))
                / (2.0 * h);
            assert!((dw - law.stress(f)).abs() < 1e-6 * law.tangent(f), "{f}");
            let dp = (law.stress(f + h) - law.stress(f - h)) / (2.0 * h);
            assert!((dp - law.tangent(f)).abs() < 1e-6 * law.tangent(f), "{f}");
        }
        assert_eq!(law.wave_modulus(), 5.77e6 + 2.0 * 3.85e6);
        assert!(law.stress(0.0).is_nan() && law.stress(-1.0).is_nan());
    }
}
