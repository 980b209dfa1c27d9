//! The saturated two-phase material of SPEC §1.2: solid grains and pore liquid, a skeleton
//! law for the effective stress and a compressible liquid that flows by Darcy's law.
//!
//! ```text
//! rho_sat = (1 - n) rho_s + n rho_w          gamma_w = rho_w g
//! c_v     = k / (gamma_w (1/E_c + n/K_w))    (consolidation coefficient)
//! drag per unit volume: (n gamma_w / k) (v_w - v_s)
//! ```

use crate::config::{display_float, MaterialConfig, MaterialModel, SkeletonLaw};
use crate::error::{Error, Result};
use crate::physics::{Hill, LinearElastic, Material};

/// Published small-deformation values (SPEC §6.6), the defaults of the keys.
const DEFAULT_POROSITY: f64 = 0.4;
const DEFAULT_DENSITY_SOLID: f64 = 2600.0;
const DEFAULT_DENSITY_LIQUID: f64 = 1000.0;
const DEFAULT_CONSTRAINED_MODULUS: f64 = 1e7;
const DEFAULT_BULK_MODULUS_LIQUID: f64 = 3e8;
const DEFAULT_PERMEABILITY: f64 = 1e-5;
const DEFAULT_GRAVITY: f64 = 9.81;

/// The two-phase material (`material.model = "two_phase"`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TwoPhaseMaterial {
    /// Initial porosity `n`.
    pub porosity: f64,
    /// Grain density `rho_s`.
    pub density_solid: f64,
    /// Liquid density `rho_w`.
    pub density_liquid: f64,
    /// Bulk modulus of the liquid `K_w`.
    pub bulk_modulus_liquid: f64,
    /// Darcy permeability `k` (m/s).
    pub permeability: f64,
    /// `g` of `gamma_w = rho_w g`.
    pub gravity: f64,
    /// Effective-stress law of the skeleton with modulus `E_c`.
    pub skeleton: Material,
}

/// The two-phase keys of `[material]`, for messages.
pub const TWO_PHASE_KEYS: [&str; 8] = [
    "porosity",
    "density_solid",
    "density_liquid",
    "constrained_modulus",
    "bulk_modulus_liquid",
    "permeability",
    "gravity",
    "skeleton",
];

impl TwoPhaseMaterial {
    /// Build from `[material]` (model `two_phase`), checking every key.
    pub fn from_config(config: &MaterialConfig) -> Result<Self> {
        if config.model != MaterialModel::TwoPhase {
            return Err(Error::invalid(
                "material.model",
                crate::config::toml_value(&config.model),
                "not a two-phase model",
            ));
        }
        let positive = |key: &str, value: Option<f64>, default: f64| {
            let value = value.unwrap_or(default);
            crate::config::require_positive(&format!("material.{key}"), value)?;
            Ok::<f64, Error>(value)
        };
        let porosity = config.porosity.unwrap_or(DEFAULT_POROSITY);
        if !(porosity > 0.0 && porosity < 1.0) {
            return Err(Error::invalid(
                "material.porosity",
                display_float(porosity),
                "must be strictly between 0 and 1",
            ));
        }
        let modulus = positive(
            "constrained_modulus",
            config.constrained_modulus,
            DEFAULT_CONSTRAINED_MODULUS,
        )?;
        let skeleton = match config.skeleton.unwrap_or_default() {
            SkeletonLaw::Linear => Material::Linear(LinearElastic {
                youngs_modulus: modulus,
            }),
            SkeletonLaw::Hill => Material::Hill(Hill {
                youngs_modulus: modulus,
            }),
        };
        Ok(Self {
            porosity,
            density_solid: positive("density_solid", config.density_solid, DEFAULT_DENSITY_SOLID)?,
            density_liquid: positive(
                "density_liquid",
                config.density_liquid,
                DEFAULT_DENSITY_LIQUID,
            )?,
            bulk_modulus_liquid: positive(
                "bulk_modulus_liquid",
                config.bulk_modulus_liquid,
                DEFAULT_BULK_MODULUS_LIQUID,
            )?,
            permeability: positive("permeability", config.permeability, DEFAULT_PERMEABILITY)?,
            gravity: positive("gravity", config.gravity, DEFAULT_GRAVITY)?,
            skeleton,
        })
    }

    /// Reject two-phase keys given to a one-phase material (they would be ignored).
    pub fn reject_keys(config: &MaterialConfig) -> Result<()> {
        let given = [
            config.porosity.is_some(),
            config.density_solid.is_some(),
            config.density_liquid.is_some(),
            config.constrained_modulus.is_some(),
            config.bulk_modulus_liquid.is_some(),
            config.permeability.is_some(),
            config.gravity.is_some(),
            config.skeleton.is_some(),
        ];
        match given.iter().position(|&g| g) {
            Some(k) => Err(Error::invalid(
                &format!("material.{}", TWO_PHASE_KEYS[k]),
                "(set)",
                format!(
                    "only used by material.model = \"two_phase\" (model is {:?})",
                    config.model
                ),
            )),
            None => Ok(()),
        }
    }

    /// Constrained modulus `E_c` of the skeleton.
    pub fn constrained_modulus(&self) -> f64 {
        self.skeleton.wave_modulus()
    }

    /// `gamma_w = rho_w g`.
    pub fn unit_weight_liquid(&self) -> f64 {
        self.density_liquid * self.gravity
    }

    /// `rho_sat = (1 - n) rho_s + n rho_w`.
    pub fn saturated_density(&self) -> f64 {
        (1.0 - self.porosity) * self.density_solid + self.porosity * self.density_liquid
    }

    /// `c_v = k / (gamma_w (1/E_c + n/K_w))`.
    pub fn consolidation_coefficient(&self) -> f64 {
        self.permeability
            / (self.unit_weight_liquid()
                * (1.0 / self.constrained_modulus() + self.porosity / self.bulk_modulus_liquid))
    }

    /// Fastest wave speed of the mixture: the largest of the undrained P wave
    /// `sqrt((E_c + K_w/n) / rho_sat)`, the skeleton wave `sqrt(E_c / ((1-n) rho_s))` and
    /// the liquid wave `sqrt(K_w / (n rho_w))`.
    pub fn max_wave_speed(&self) -> f64 {
        let n = self.porosity;
        let e = self.constrained_modulus();
        let k = self.bulk_modulus_liquid / n;
        let undrained = ((e + k) / self.saturated_density()).sqrt();
        let skeleton = (e / ((1.0 - n) * self.density_solid)).sqrt();
        let liquid = (k / self.density_liquid).sqrt();
        undrained.max(skeleton).max(liquid)
    }

    /// The explicit drag limit `2 / r`: the slip `v_w - v_s` relaxes at the rate
    /// `r = (n g / k) (1 + n rho_w / ((1 - n) rho_s))` (the liquid is pulled towards the
    /// solid at `n g / k`, the solid towards the liquid by the reaction on its lighter
    /// mass).
    pub fn drag_time_step(&self) -> f64 {
        let n = self.porosity;
        let rate = n * self.gravity / self.permeability
            * (1.0 + n * self.density_liquid / ((1.0 - n) * self.density_solid));
        2.0 / rate
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config() -> MaterialConfig {
        MaterialConfig {
            model: MaterialModel::TwoPhase,
            ..MaterialConfig::default()
        }
    }

    #[test]
    fn defaults_are_the_published_small_deformation_values() {
        let m = TwoPhaseMaterial::from_config(&config()).unwrap();
        assert_eq!(m.saturated_density(), 0.6 * 2600.0 + 0.4 * 1000.0);
        // c_v = 1e-5 / (9810 (1e-7 + 0.4 / 3e8)) = 1.0060e-2.
        let cv = m.consolidation_coefficient();
        assert!(
            (cv - 1e-5 / (9810.0 * (1e-7 + 0.4 / 3e8))).abs() < 1e-16,
            "{cv}"
        );
        assert!((cv - 1.006e-2).abs() < 1e-5, "{cv}");
        // The liquid wave sqrt(K_w / (n rho_w)) = 866 m/s is the fastest.
        assert!((m.max_wave_speed() - (3e8f64 / 400.0).sqrt()).abs() < 1e-9);
    }

    #[test]
    fn bad_keys_are_named() {
        let mut c = config();
        c.porosity = Some(1.0);
        let e = TwoPhaseMaterial::from_config(&c).unwrap_err().to_string();
        assert!(e.contains("material.porosity"), "{e}");
        let mut c = config();
        c.permeability = Some(-1.0);
        let e = TwoPhaseMaterial::from_config(&c).unwrap_err().to_string();
        assert!(e.contains("material.permeability"), "{e}");
        let one_phase = MaterialConfig {
            bulk_modulus_liquid: Some(1e9),
            ..MaterialConfig::default()
        };
        let e = TwoPhaseMaterial::reject_keys(&one_phase)
            .unwrap_err()
            .to_string();
        assert!(e.contains("material.bulk_modulus_liquid"), "{e}");
    }
}
