//! Two-phase consolidation (Terzaghi; Al-Kafaji; SPEC §6.6): a saturated column `[0, H]`
//! with an impermeable fixed bottom and a drained top loaded by `q`, no body force.
//!
//! ```text
//! solid:  u_s(0) = 0                 total stress sigma(H) = sigma'(H) + p(H) = q
//! liquid: v_w(0) = 0 (impermeable)   p(H) = 0 (drained: zero traction on the liquid)
//! ```
//! The run starts at `t_0 = problem.start_time` from the exact state at `t_0` (default 5 s,
//! since the `t = 0` data are incompatible; at `t_0 = 0` the column starts undrained,
//! `p = q`, `sigma' = 0`). Exact fields are those of [`Terzaghi`] at the particles'
//! positions at `t_0` (the small-deformation solution; in a large-deformation run they are
//! only the small-strain comparison). The plots use that initial position.
//!
//! Published set-ups: small deformation `H = 1 m`, `n = 0.4`, `rho_w = 1000`,
//! `rho_s = 2600 kg/m^3`, `E_c = 1e7 Pa`, `K_w = 3e8 Pa`, `k = 1e-5 m/s`, `q = -1e4 Pa`,
//! `dt = 1e-10 s` for `2e-9 s` from `t_0 = 5 s`; large deformation `E_c = 1e6`,
//! `K_w = 3e7`, `q = -5e5 Pa`, 0.4 s from `t_0 = 0`, Hill skeleton.

use super::terzaghi::{Terzaghi, TerzaghiProfiles};
use super::{Field, PlotAxis, Problem};
use crate::config::{display_float, require_positive, Scenario};
use crate::error::{Error, Result};
use crate::grid::Grid;
use crate::particles::{LiquidFields, Particles};
use crate::physics::two_phase::TwoPhaseMaterial;
use crate::physics::Boundary;

/// Default load `q` in Pa (compression).
const DEFAULT_LOAD: f64 = -1e4;
/// Default start time in s.
const DEFAULT_START_TIME: f64 = 5.0;

/// The consolidation benchmark.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Consolidation {
    pub material: TwoPhaseMaterial,
    pub start_time: f64,
    pub terzaghi: Terzaghi,
}

impl Consolidation {
    /// From `[problem]` (`length`, `load`, `start_time`) and the two-phase `[material]`.
    pub fn from_scenario(scenario: &Scenario) -> Result<Self> {
        let p = &scenario.problem;
        let material = TwoPhaseMaterial::from_config(&scenario.material)?;
        let length = p.length.unwrap_or(1.0);
        require_positive("problem.length", length)?;
        let load = p.load.unwrap_or(DEFAULT_LOAD);
        if !load.is_finite() {
            return Err(Error::invalid(
                "problem.load",
                display_float(load),
                "must be finite",
            ));
        }
        let start_time = p.start_time.unwrap_or(DEFAULT_START_TIME);
        if !(start_time.is_finite() && start_time >= 0.0) {
            return Err(Error::invalid(
                "problem.start_time",
                display_float(start_time),
                "must be a finite time >= 0",
            ));
        }
        Ok(Self {
            material,
            start_time,
            terzaghi: Terzaghi {
                height: length,
                load,
                porosity: material.porosity,
                constrained_modulus: material.constrained_modulus(),
                bulk_modulus_liquid: material.bulk_modulus_liquid,
                permeability: material.permeability,
                unit_weight_liquid: material.unit_weight_liquid(),
            },
        })
    }

    /// The particle values of `field` from a set of exact profiles.
    fn pick(profiles: TerzaghiProfiles, field: Field) -> Vec<f64> {
        match field {
            Field::Displacement => profiles.displacement,
            Field::Velocity => profiles.solid_velocity,
            Field::LiquidVelocity => profiles.liquid_velocity,
            Field::PorePressure => profiles.pore_pressure,
            Field::EffectiveStress => profiles.effective_stress,
            Field::Stress => profiles
                .effective_stress
                .iter()
                .zip(&profiles.pore_pressure)
                .map(|(s, p)| s + p)
                .collect(),
        }
    }
}

impl Problem for Consolidation {
    fn name(&self) -> &'static str {
        "consolidation"
    }

    fn length(&self) -> f64 {
        self.terzaghi.height
    }

    /// Particles at sub-cell centres carrying the exact state at `t_0`: solid mass
    /// `(1 - n) rho_s V_p`, liquid mass `rho_w V_p`, `u_s, v_s, sigma'` and `v_w, p`.
    fn initial_particles(&self, grid: &Grid, per_cell: usize, _density: f64) -> Particles {
        let m = &self.material;
        let solid_density = (1.0 - m.porosity) * m.density_solid;
        let mut particles = Particles::at_subcell_centres(grid, per_cell, solid_density);
        let exact = self.terzaghi.profiles(&particles.x0, self.start_time);
        let liquid_mass: Vec<f64> = particles
            .volume
            .iter()
            .map(|v| m.density_liquid * v)
            .collect();
        let mut liquid = LiquidFields::uniform(particles.len(), m.porosity, &liquid_mass, 0.0);
        liquid.velocity = exact.liquid_velocity;
        liquid.pore_pressure = exact.pore_pressure;
        particles.u = exact.displacement;
        particles.v = exact.solid_velocity;
        particles.stress = exact.effective_stress;
        particles.liquid = Some(liquid);
        particles
    }

    /// Bottom fixed; the total-stress traction `q` on the top.
    fn boundary(&self) -> Boundary {
        Boundary {
            fixed_left: true,
            traction_right: self.terzaghi.load,
            ..Boundary::default()
        }
    }

    /// Bottom impermeable; the top drained (`p = 0`, no traction on the liquid).
    fn liquid_boundary(&self) -> Boundary {
        Boundary::fixed_left_free_right()
    }

    fn start_time(&self) -> f64 {
        self.start_time
    }

    fn body_acceleration(&self, _t: f64) -> f64 {
        0.0
    }

    fn exact_fields(&self) -> &'static [Field] {
        &Field::TWO_PHASE
    }

    fn exact(&self, field: Field, x0: f64, t: f64) -> Option<f64> {
        Some(self.exact_profile(field, &[x0], t)[0])
    }

    fn exact_profile(&self, field: Field, x0: &[f64], t: f64) -> Vec<f64> {
        Self::pick(self.terzaghi.profiles(x0, t), field)
    }

    fn plot_axis(&self) -> PlotAxis {
        PlotAxis::Initial
    }

    fn reference_label(&self) -> &'static str {
        "Terzaghi"
    }
}
