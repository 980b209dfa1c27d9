//! The time loop: steps `t_n = t_0 + n dt`, the body force evaluated at the end of each step,
//! and the per-step diagnostics of `history.csv` (conservation errors of the mapping,
//! energies, cumulative grid crossings).

use super::step::TimeStepper;
use super::{Body, BodySource};
use crate::error::Result;
use crate::particles::Particles;

/// One row of `history.csv` (DESIGN §4).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HistoryRow {
    pub step: usize,
    pub time: f64,
    pub mass_rel_error: f64,
    /// `None` on steps where all particles are at rest.
    pub momentum_rel_error: Option<f64>,
    /// Two-phase runs: the liquid's mass error (`None` for one phase).
    pub liquid_mass_rel_error: Option<f64>,
    /// Two-phase runs: the liquid's momentum error (`None` for one phase or liquid at rest).
    pub liquid_momentum_rel_error: Option<f64>,
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
    /// Two-phase: largest liquid conservation errors (`None` for one phase).
    pub max_liquid_mass_error: Option<f64>,
    pub max_liquid_momentum_error: Option<f64>,
    /// Time at step 0 (`problem.start_time`; the exact solution's time of the initial
    /// state).
    pub start_time: f64,
    /// Per-particle body force of the current step (reused buffer).
    body_field: Vec<f64>,
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
            max_liquid_mass_error: None,
            max_liquid_momentum_error: None,
            start_time: 0.0,
            body_field: Vec::new(),
        }
    }

    /// A simulation whose initial state is at time `start_time`.
    pub fn starting_at(mut self, start_time: f64) -> Self {
        self.start_time = start_time;
        self
    }

    /// Current time `start_time + steps_done * dt`.
    pub fn time(&self) -> f64 {
        self.time_at(self.steps_done)
    }

    /// Time at the end of step `step`.
    fn time_at(&self, step: usize) -> f64 {
        self.start_time + step as f64 * self.stepper.dt()
    }

    /// Kinetic and stored energy (both phases for two-phase particles).
    pub fn energies(&self) -> (f64, f64) {
        self.stepper.energies(&self.particles)
    }

    /// Run `n_steps` steps. `body` gives the body force of each step (a closure `|t| b(t)`
    /// for a uniform one, evaluated at the end time of each step; see [`BodySource`]);
    /// `after_step(sim)` is called after every step (progress, snapshots). On failure `steps_done` and `history` stop at the last completed step;
    /// the particles hold the state of the failing step at the moment it was detected.
    pub fn run(
        &mut self,
        n_steps: usize,
        body: &dyn BodySource,
        after_step: &mut dyn FnMut(&Simulation) -> Result<()>,
    ) -> Result<()> {
        for _ in 0..n_steps {
            let step = self.steps_done + 1;
            let time = self.time_at(step);
            let report = match body.uniform(time) {
                Some(b) => self
                    .stepper
                    .step(&mut self.particles, Body::Uniform(b), step, time)?,
                None => {
                    let mut field = std::mem::take(&mut self.body_field);
                    field.resize(self.particles.len(), 0.0);
                    body.at_particles(&self.particles.x0, self.time_at(step - 1), &mut field);
                    let report = self.stepper.step(
                        &mut self.particles,
                        Body::PerParticle(&field),
                        step,
                        time,
                    );
                    self.body_field = field;
                    report?
                }
            };
            self.steps_done = step;
            self.grid_crossings += report.crossings;
            self.max_mass_error = self.max_mass_error.max(report.mass_error);
            if let Some(e) = report.momentum_error {
                self.max_momentum_error = self.max_momentum_error.max(e);
            }
            let larger = |a: Option<f64>, b: Option<f64>| match (a, b) {
                (Some(a), Some(b)) => Some(a.max(b)),
                (a, b) => a.or(b),
            };
            if report.liquid_mass_error.is_some() {
                self.max_liquid_mass_error =
                    larger(self.max_liquid_mass_error, report.liquid_mass_error).or(Some(0.0));
                self.max_liquid_momentum_error =
                    larger(self.max_liquid_momentum_error, report.liquid_momentum_error)
                        .or(Some(0.0));
            }
            let (kinetic_energy, strain_energy) =
                report.energies.unwrap_or_else(|| self.energies());
            self.history.push(HistoryRow {
                step,
                time,
                mass_rel_error: report.mass_error,
                momentum_rel_error: report.momentum_error,
                liquid_mass_rel_error: report.liquid_mass_error,
                liquid_momentum_rel_error: report.liquid_momentum_error,
                kinetic_energy,
                strain_energy,
                grid_crossings: self.grid_crossings,
            });
            after_step(self)?;
        }
        Ok(())
    }
}
