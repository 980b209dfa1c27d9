//! Column compaction (Bardenhagen & Kober; SPEC §6.4): column `[0, H]`, bottom fixed, top
//! free, body force ramped linearly in time, `b(t) = b_max t / t_end` (quasi-static).
//! Exact stress in terms of the initial position `X` (the weight of the material above,
//! whatever the constitutive law):
//!
//! ```text
//! sigma(X, t) = rho_0 b(t) (H - X)
//! ```
//! Published set-up: `H = 50 m`, `rho_0 = 1 kg/m^3`, `E = 1e6 Pa`, `b_max = -200 m/s^2`,
//! `dt = 1e-4 s`, end `0.5 s`, 50 cells, 20 particles per cell, Hill's law.

use super::{Field, PlotAxis, Problem};
use crate::config::{require_positive, Scenario};
use crate::error::{Error, Result};
use crate::grid::Grid;
use crate::particles::Particles;
use crate::physics::Boundary;

/// The column compaction benchmark.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ColumnCompaction {
    pub length: f64,
    /// Final signed body acceleration `b_max`.
    pub gravity: f64,
    pub density: f64,
    /// Ramp duration (the end time of the run).
    pub ramp_time: f64,
}

impl ColumnCompaction {
    /// Published defaults: `H = 50 m`, `b_max = -200 m/s^2`.
    pub fn from_scenario(scenario: &Scenario) -> Result<Self> {
        let length = scenario.problem.length.unwrap_or(50.0);
        let gravity = scenario.problem.gravity.unwrap_or(-200.0);
        require_positive("problem.length", length)?;
        if !gravity.is_finite() {
            return Err(Error::invalid(
                "problem.gravity",
                crate::config::display_float(gravity),
                "must be finite",
            ));
        }
        Ok(Self {
            length,
            gravity,
            density: scenario.material.density,
            ramp_time: scenario.time.end,
        })
    }
}

impl Problem for ColumnCompaction {
    fn name(&self) -> &'static str {
        "column_compaction"
    }

    fn length(&self) -> f64 {
        self.length
    }

    fn initial_particles(&self, grid: &Grid, per_cell: usize, density: f64) -> Particles {
        Particles::at_subcell_centres(grid, per_cell, density)
    }

    fn boundary(&self) -> Boundary {
        Boundary::fixed_left_free_right()
    }

    fn body_acceleration(&self, t: f64) -> f64 {
        self.gravity * (t / self.ramp_time).min(1.0)
    }

    fn exact_fields(&self) -> &'static [Field] {
        &[Field::Stress]
    }

    fn exact(&self, field: Field, x0: f64, t: f64) -> Option<f64> {
        match field {
            Field::Stress => Some(self.density * self.body_acceleration(t) * (self.length - x0)),
            _ => None,
        }
    }

    fn plot_axis(&self) -> PlotAxis {
        PlotAxis::Initial
    }
}
