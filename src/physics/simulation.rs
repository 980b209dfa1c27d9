//! The time loop: steps `t_n = n dt`, the body force evaluated at the end of each step,
//! and the per-step diagnostics of `history.csv` (conservation errors of the mapping,
//! energies, cumulative grid crossings).

use super::step::TimeStepper;
use crate::error::Result;
use crate::numerics::sum::deterministic_sums;
use crate::particles::Particles;

/// One row of `history.csv` (DESIGN §4).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HistoryRow {
    pub step: usize,
    pub time: f64,
    pub mass_rel_error: f64,
    /// `None` on steps where all particles are at rest.
    pub momentum_rel_error: Option<f64>,
    pub kinetic_energy: f64,
    pub strain_energy: f64,
    /// Cumulative grid crossings up to and including this step.
    pub grid_crossings: usize,
}

/// A running simulation: stepper, particles and what has been recorded.
pub struct Simulation {
    pub stepper: Box<dyn TimeStepper>,
    pub particles: Particles,
    pub history: Vec<HistoryRow>,
    /// Steps completed.
    pub steps_done: usize,
    pub grid_crossings: usize,
    pub max_mass_error: f64,
    pub max_momentum_error: f64,
}

impl Simulation {
    pub fn new(stepper: Box<dyn TimeStepper>, particles: Particles) -> Self {
        Self {
            stepper,
            particles,
            history: Vec::new(),
            steps_done: 0,
            grid_crossings: 0,
            max_mass_error: 0.0,
            max_momentum_error: 0.0,
        }
    }

    /// Current time `steps_done * dt`.
    pub fn time(&self) -> f64 {
        self.steps_done as f64 * self.stepper.dt()
    }

    /// Kinetic energy `sum_p m_p v_p^2 / 2` and strain energy `sum_p V_p W(sigma_p)`.
    pub fn energies(&self) -> (f64, f64) {
        let p = &self.particles;
        let material = *self.stepper.material();
        let [kinetic, strain] = deterministic_sums(p.len(), |k| {
            [
                0.5 * p.mass[k] * p.v[k] * p.v[k],
                p.volume[k] * material.strain_energy_density(p.stress[k]),
            ]
        });
        (kinetic, strain)
    }

    /// Run `n_steps` steps. `body(t)` is the signed body acceleration at time `t` (applied
    /// at the end time of each step); `after_step(sim)` is called after every step (progress,
    /// snapshots). On failure `steps_done` and `history` stop at the last completed step;
    /// the particles hold the state of the failing step at the moment it was detected.
    pub fn run(
        &mut self,
        n_steps: usize,
        body: &dyn Fn(f64) -> f64,
        after_step: &mut dyn FnMut(&Simulation) -> Result<()>,
    ) -> Result<()> {
        let dt = self.stepper.dt();
        for _ in 0..n_steps {
            let step = self.steps_done + 1;
            let time = step as f64 * dt;
            let report = self
                .stepper
                .step(&mut self.particles, body(time), step, time)?;
            self.steps_done = step;
            self.grid_crossings += report.crossings;
            self.max_mass_error = self.max_mass_error.max(report.mass_error);
            if let Some(e) = report.momentum_error {
                self.max_momentum_error = self.max_momentum_error.max(e);
            }
            let (kinetic_energy, strain_energy) = self.energies();
            self.history.push(HistoryRow {
                step,
                time,
                mass_rel_error: report.mass_error,
                momentum_rel_error: report.momentum_error,
                kinetic_energy,
                strain_energy,
                grid_crossings: self.grid_crossings,
            });
            after_step(self)?;
        }
        Ok(())
    }
}
