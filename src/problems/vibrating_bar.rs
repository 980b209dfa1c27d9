//! Vibrating bar (SPEC §6.2, §6.3): bar `[0, H]`, both ends fixed, no body force,
//! `u(x,0) = 0`, `sigma(x,0) = 0`, `v(x,0) = v0 sin(pi x / H)`. With `c = sqrt(E / rho)`,
//! `w = pi c / H`, the small-strain solution is
//!
//! ```text
//! u(x,t)     = v0 / w sin(w t) sin(pi x / H)
//! v(x,t)     = v0 cos(w t) sin(pi x / H)
//! sigma(x,t) = v0 sqrt(E rho) sin(w t) cos(pi x / H)
//! ```
//! (amplitude `v0 sqrt(E rho)`, SPEC §7 errata). The large-strain (Hill) bar has no
//! exact solution: its errors need the ULFEM reference.

use super::{Field, Problem};
use crate::config::{require_positive, MaterialModel, Scenario};
use crate::error::Result;
use crate::grid::Grid;
use crate::particles::Particles;
use crate::physics::Boundary;
use std::f64::consts::PI;

/// The vibrating bar benchmark.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VibratingBar {
    pub length: f64,
    pub v0: f64,
    pub density: f64,
    pub youngs_modulus: f64,
    /// Whether the small-strain exact solution applies (linear material).
    pub small_strain: bool,
}

impl VibratingBar {
    /// Published defaults: `H = 1 m`, `v0 = 0.28 m/s`.
    pub fn from_scenario(scenario: &Scenario) -> Result<Self> {
        let length = scenario.problem.length.unwrap_or(1.0);
        let v0 = scenario.problem.v0.unwrap_or(0.28);
        require_positive("problem.length", length)?;
        if !v0.is_finite() {
            return Err(crate::error::Error::invalid(
                "problem.v0",
                crate::config::display_float(v0),
                "must be finite",
            ));
        }
        Ok(Self {
            length,
            v0,
            density: scenario.material.density,
            youngs_modulus: scenario.material.youngs_modulus,
            small_strain: scenario.material.model == MaterialModel::Linear,
        })
    }

    /// Angular frequency `w = pi c / H`.
    pub fn omega(&self) -> f64 {
        PI * (self.youngs_modulus / self.density).sqrt() / self.length
    }
}

impl Problem for VibratingBar {
    fn name(&self) -> &'static str {
        "vibrating_bar"
    }

    fn length(&self) -> f64 {
        self.length
    }

    fn initial_particles(&self, grid: &Grid, per_cell: usize, density: f64) -> Particles {
        let mut particles = Particles::at_subcell_centres(grid, per_cell, density);
        for (v, &x) in particles.v.iter_mut().zip(&particles.x0) {
            *v = self.initial_velocity(x);
        }
        particles
    }

    fn initial_velocity(&self, x0: f64) -> f64 {
        self.v0 * (PI * x0 / self.length).sin()
    }

    fn boundary(&self) -> Boundary {
        Boundary::fixed_both()
    }

    fn body_acceleration(&self, _t: f64) -> f64 {
        0.0
    }

    fn exact_fields(&self) -> &'static [Field] {
        if self.small_strain {
            &Field::ALL
        } else {
            &[]
        }
    }

    fn exact(&self, field: Field, x0: f64, t: f64) -> Option<f64> {
        if !self.small_strain {
            return None;
        }
        let w = self.omega();
        let k = PI / self.length;
        Some(match field {
            Field::Displacement => self.v0 / w * (w * t).sin() * (k * x0).sin(),
            Field::Velocity => self.v0 * (w * t).cos() * (k * x0).sin(),
            Field::Stress => {
                self.v0
                    * (self.youngs_modulus * self.density).sqrt()
                    * (w * t).sin()
                    * (k * x0).cos()
            }
            Field::LiquidVelocity | Field::PorePressure | Field::EffectiveStress => return None,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_solution_satisfies_the_wave_equation() {
        let bar = VibratingBar {
            length: 1.0,
            v0: 0.28,
            density: 2000.0,
            youngs_modulus: 7e6,
            small_strain: true,
        };
        let (x, t, hx, ht) = (0.3, 1.3e-3, 1e-4, 1e-6);
        let f = |field, x, t| bar.exact(field, x, t).unwrap();
        // rho dv/dt = dsigma/dx, dsigma/dt = E dv/dx, v = du/dt.
        let dv_dt = (f(Field::Velocity, x, t + ht) - f(Field::Velocity, x, t - ht)) / (2.0 * ht);
        let ds_dx = (f(Field::Stress, x + hx, t) - f(Field::Stress, x - hx, t)) / (2.0 * hx);
        assert!((bar.density * dv_dt - ds_dx).abs() < 1e-5 * ds_dx.abs());
        let ds_dt = (f(Field::Stress, x, t + ht) - f(Field::Stress, x, t - ht)) / (2.0 * ht);
        let dv_dx = (f(Field::Velocity, x + hx, t) - f(Field::Velocity, x - hx, t)) / (2.0 * hx);
        assert!((ds_dt - bar.youngs_modulus * dv_dx).abs() < 1e-5 * ds_dt.abs());
        let du_dt =
            (f(Field::Displacement, x, t + ht) - f(Field::Displacement, x, t - ht)) / (2.0 * ht);
        assert!((du_dt - f(Field::Velocity, x, t)).abs() < 1e-6);
        // Fixed ends.
        assert!(f(Field::Displacement, 0.0, t).abs() < 1e-15);
        assert!(f(Field::Displacement, 1.0, t).abs() < 1e-12);
    }
}
