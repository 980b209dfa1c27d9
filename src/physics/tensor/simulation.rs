//! The time loop of the dimension-generic core: fixed or automatic time steps, the body
//! force of each step, and the diagnostics of `history.csv` (as in 1D: conservation errors
//! of the mapping, energies, cumulative grid crossings).
//!
//! With `time.dt = "auto"` the step is `cfl * dt_0 * c_0 / (c + |v|)_max`, recomputed
//! every [`AUTO_DT_EVERY`] steps from the current particle state: `dt_0` is the stability
//! limit of the initial configuration (see [`super::stability`]), `c_0` the initial wave
//! speed and `(c + |v|)_max` the largest `sqrt(M / rho_p) + |v_p|` now (`M = lambda + 2
//! mu`). The last step is shortened to end exactly at `time.end`.

use super::step::{TensorStepReport, TensorStepper};
use super::timings::StepTimings;
use crate::error::Result;
use crate::grid::Basis;
use crate::linalg::CsrMatrix;
use crate::mapping::tensor::TensorMapping;
use crate::mapping::tensor_direct::TensorBody;
use crate::mapping::RemedyCounts;
use crate::particles::TensorParticles;
use crate::physics::distributed::RankExchange;
use crate::physics::{HistoryRow, SolverTotals};
use rayon::prelude::*;
use std::borrow::Cow;

/// Steps between recomputations of an automatic time step.
pub const AUTO_DT_EVERY: usize = 10;

/// The body force of a problem: uniform `b(t)`, or per particle `b(X_p, t)`.
pub trait TensorBodySource<const D: usize>: Sync {
    /// `Some(b(t))` for a uniform body force.
    fn uniform(&self, t: f64) -> Option<[f64; D]>;
    /// `b(X_p, t)` at every particle (components `[a][p]`).
    fn at_particles(&self, x0: &[Vec<f64>; D], t: f64, out: &mut [Vec<f64>; D]);
}

/// Object-safe view of a [`TensorStepper`] (dispatch once per step).
pub trait TensorTimeStepper<const D: usize>: Send + Sync {
    fn step(
        &mut self,
        particles: &mut TensorParticles<D>,
        body: TensorBody<'_, D>,
        dt: f64,
        step: usize,
        time: f64,
    ) -> Result<TensorStepReport>;
    /// [`TensorStepper::step_ahead`]: the step, and with `next_body` the next step's
    /// mass and force mapped in its particle update where the mapping allows it.
    fn step_ahead(
        &mut self,
        particles: &mut TensorParticles<D>,
        body: TensorBody<'_, D>,
        next_body: Option<TensorBody<'_, D>>,
        dt: f64,
        step: usize,
        time: f64,
    ) -> Result<TensorStepReport>;
    /// Whether [`TensorTimeStepper::step_ahead`] uses its `next_body`
    /// ([`TensorStepper::maps_ahead`]).
    fn maps_ahead(&mut self) -> bool;
    fn energies(&self, particles: &TensorParticles<D>) -> (f64, f64);
    /// `method.basis`.
    fn basis_name(&self) -> &'static str;
    /// `method.reconstruction` (`"none"` for the direct mapping).
    fn reconstruction_name(&self) -> &'static str;
    /// P-wave modulus of the law.
    fn wave_modulus(&self) -> f64;
    /// Remedies of degenerate reconstruction fits so far.
    fn remedies(&self) -> RemedyCounts;
    /// The mass solves so far: `solver.kind` (or `"lumped"`), solves, total and largest
    /// iteration count per solve.
    fn solver_totals(&self) -> SolverTotals;
    /// Seconds per phase of the steps so far.
    fn timings(&self) -> StepTimings;
    /// The velocity system `M^C v_c = p_c` of component `c` at the last step: the
    /// constrained consistent mass and the grid momentum (0 on eliminated DOFs). `None`
    /// with a lumped mass, before the first step or for `c >= D`.
    fn velocity_system(&self, c: usize) -> Option<(Cow<'_, CsrMatrix>, Vec<f64>)>;
    /// Make this stepper one rank of a distributed run
    /// ([`TensorStepper::distribute`]).
    fn distribute(
        &mut self,
        exchange: Box<dyn RankExchange>,
        particles: &mut TensorParticles<D>,
    ) -> Result<()>;
}

impl<const D: usize, B: Basis, M: TensorMapping<D>> TensorTimeStepper<D>
    for TensorStepper<D, B, M>
{
    fn step(
        &mut self,
        particles: &mut TensorParticles<D>,
        body: TensorBody<'_, D>,
        dt: f64,
        step: usize,
        time: f64,
    ) -> Result<TensorStepReport> {
        TensorStepper::step(self, particles, body, dt, step, time)
    }
    fn step_ahead(
        &mut self,
        particles: &mut TensorParticles<D>,
        body: TensorBody<'_, D>,
        next_body: Option<TensorBody<'_, D>>,
        dt: f64,
        step: usize,
        time: f64,
    ) -> Result<TensorStepReport> {
        TensorStepper::step_ahead(self, particles, body, next_body, dt, step, time)
    }
    fn maps_ahead(&mut self) -> bool {
        TensorStepper::maps_ahead(self)
    }
    fn energies(&self, particles: &TensorParticles<D>) -> (f64, f64) {
        TensorStepper::energies(self, particles)
    }
    fn basis_name(&self) -> &'static str {
        self.basis.name()
    }
    fn reconstruction_name(&self) -> &'static str {
        self.mapping.name()
    }
    fn wave_modulus(&self) -> f64 {
        self.material.wave_modulus()
    }
    fn remedies(&self) -> RemedyCounts {
        self.mapping.remedies()
    }
    fn solver_totals(&self) -> SolverTotals {
        match &self.mass_solve {
            Some(s) => SolverTotals {
                kind: s.name(),
                solves: s.solves,
                total_iterations: s.total_iterations,
                max_iterations: s.max_iterations,
            },
            None => SolverTotals {
                kind: "lumped",
                ..SolverTotals::default()
            },
        }
    }
    fn timings(&self) -> StepTimings {
        TensorStepper::timings(self)
    }
    fn velocity_system(&self, c: usize) -> Option<(Cow<'_, CsrMatrix>, Vec<f64>)> {
        let assembled = self.mapping.consistent_mass()?;
        let (matrix, keep) = self.mass_solve.as_ref()?.constrained_system(c, assembled)?;
        let momentum = self
            .fields
            .momentum
            .iter()
            .zip(keep)
            .map(|(p, &k)| if k { p[c] } else { 0.0 })
            .collect();
        Some((matrix, momentum))
    }
    fn distribute(
        &mut self,
        exchange: Box<dyn RankExchange>,
        particles: &mut TensorParticles<D>,
    ) -> Result<()> {
        TensorStepper::distribute(self, exchange, particles)
    }
}

/// How the time step is chosen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TimeStepping {
    Fixed(f64),
    /// `cfl` times the current stability limit estimate; `initial_limit` is the limit of
    /// the initial configuration and `initial_speed` its wave speed.
    Auto {
        cfl: f64,
        initial_limit: f64,
        initial_speed: f64,
    },
}

/// A running 2D / 3D simulation.
pub struct TensorSimulation<const D: usize> {
    pub stepper: Box<dyn TensorTimeStepper<D>>,
    pub particles: TensorParticles<D>,
    pub history: Vec<HistoryRow>,
    pub steps_done: usize,
    pub time: f64,
    pub end_time: f64,
    /// The step size of the last step.
    pub dt: f64,
    pub stepping: TimeStepping,
    pub grid_crossings: usize,
    pub max_mass_error: f64,
    pub max_momentum_error: f64,
    body_field: [Vec<f64>; D],
    /// The per-particle body force of the next step, computed for the particle update of
    /// a step that maps the next one ([`TensorStepper::step_ahead`]).
    next_body_field: [Vec<f64>; D],
    /// Whether `body_field` holds the body force of the coming step (computed as the last
    /// step's `next_body_field`, for the particles in their current order).
    body_field_current: bool,
}

impl<const D: usize> TensorSimulation<D> {
    pub fn new(
        stepper: Box<dyn TensorTimeStepper<D>>,
        particles: TensorParticles<D>,
        stepping: TimeStepping,
        end_time: f64,
    ) -> Self {
        Self {
            stepper,
            particles,
            history: Vec::new(),
            steps_done: 0,
            time: 0.0,
            end_time,
            dt: match stepping {
                TimeStepping::Fixed(dt) => dt,
                TimeStepping::Auto { .. } => 0.0,
            },
            stepping,
            grid_crossings: 0,
            max_mass_error: 0.0,
            max_momentum_error: 0.0,
            body_field: std::array::from_fn(|_| Vec::new()),
            next_body_field: std::array::from_fn(|_| Vec::new()),
            body_field_current: false,
        }
    }

    /// Make this simulation one rank of a distributed run over `exchange`'s ranks: keep
    /// the particles of the rank's slab ([`TensorStepper::distribute`]). Every rank must
    /// have built the same simulation. A fixed time step only: every rank must take the
    /// same steps.
    pub fn distribute(&mut self, exchange: Box<dyn RankExchange>) -> Result<()> {
        if !matches!(self.stepping, TimeStepping::Fixed(_)) {
            return Err(crate::error::Error::invalid(
                "time.dt",
                "\"auto\"",
                "a distributed run needs a fixed time step (for now)",
            ));
        }
        self.stepper.distribute(exchange, &mut self.particles)
    }

    /// Number of steps of a fixed step, `round(end / dt)`; `None` for automatic steps.
    pub fn fixed_steps(&self) -> Option<usize> {
        match self.stepping {
            TimeStepping::Fixed(dt) => Some((self.end_time / dt).round() as usize),
            TimeStepping::Auto { .. } => None,
        }
    }

    /// The automatic step from the current state (see the module doc).
    fn auto_dt(&self, cfl: f64, initial_limit: f64, initial_speed: f64) -> f64 {
        let p = &self.particles;
        let modulus = self.stepper.wave_modulus();
        // A maximum: the same for any order of evaluation, so parallel and deterministic.
        let fastest = (0..p.len())
            .into_par_iter()
            .with_min_len(4096)
            .map(|k| {
                let speed2: f64 = (0..D).map(|a| p.v[a][k] * p.v[a][k]).sum();
                (modulus / p.density(k)).sqrt() + speed2.sqrt()
            })
            .reduce(|| 0.0, f64::max);
        let dt = cfl * initial_limit * initial_speed / fastest.max(initial_speed * 1e-12);
        dt.min(self.end_time - self.time)
    }

    /// The end time of the step after step `step` (which ends at `end_time` with step
    /// size `dt`), when it is known before step `step` is taken: `None` after the last
    /// step and before a recomputation of an automatic step size.
    fn next_end_time(&self, step: usize, end_time: f64, dt: f64) -> Option<f64> {
        match self.stepping {
            TimeStepping::Fixed(dt) => {
                let steps = self.fixed_steps()?;
                (step < steps).then(|| (step + 1) as f64 * dt)
            }
            TimeStepping::Auto { .. } => {
                let more = end_time < self.end_time * (1.0 - 1e-12);
                let same_dt = !step.is_multiple_of(AUTO_DT_EVERY);
                (more && same_dt).then(|| end_time + dt.min(self.end_time - end_time))
            }
        }
    }

    /// Whether the run has reached its end time (or its fixed number of steps).
    pub fn finished(&self) -> bool {
        match self.fixed_steps() {
            Some(n) => self.steps_done >= n,
            None => self.time >= self.end_time * (1.0 - 1e-12),
        }
    }

    /// Run to the end time. `body` gives the body force; `after_step(sim)` runs after every
    /// step and may stop the run early by returning `Ok(false)`. On failure `steps_done`
    /// and `history` stop at the last completed step.
    pub fn run(
        &mut self,
        body: &dyn TensorBodySource<D>,
        after_step: &mut dyn FnMut(&TensorSimulation<D>) -> Result<bool>,
    ) -> Result<()> {
        while !self.finished() {
            let step = self.steps_done + 1;
            let dt = match self.stepping {
                TimeStepping::Fixed(dt) => dt,
                TimeStepping::Auto {
                    cfl,
                    initial_limit,
                    initial_speed,
                } => {
                    if self.steps_done.is_multiple_of(AUTO_DT_EVERY) || self.dt == 0.0 {
                        self.auto_dt(cfl, initial_limit, initial_speed)
                    } else {
                        self.dt.min(self.end_time - self.time)
                    }
                }
            };
            let start_time = self.time;
            let end_time = match self.stepping {
                TimeStepping::Fixed(dt) => step as f64 * dt,
                TimeStepping::Auto { .. } => start_time + dt,
            };
            // The end of the next step where it is known now (for its body force).
            let next_end = self.next_end_time(step, end_time, dt);
            let ahead = next_end.is_some() && self.stepper.maps_ahead();
            let report = match body.uniform(end_time) {
                Some(b) => {
                    let next = next_end
                        .filter(|_| ahead)
                        .and_then(|t| body.uniform(t))
                        .map(TensorBody::Uniform);
                    self.stepper.step_ahead(
                        &mut self.particles,
                        TensorBody::Uniform(b),
                        next,
                        dt,
                        step,
                        end_time,
                    )?
                }
                None => {
                    let empty = || std::array::from_fn(|_| Vec::new());
                    let mut field = std::mem::replace(&mut self.body_field, empty());
                    let mut next = std::mem::replace(&mut self.next_body_field, empty());
                    let n = self.particles.len();
                    if !std::mem::take(&mut self.body_field_current) {
                        for f in field.iter_mut() {
                            f.resize(n, 0.0);
                        }
                        body.at_particles(&self.particles.x0, start_time, &mut field);
                    }
                    if ahead {
                        for f in next.iter_mut() {
                            f.resize(n, 0.0);
                        }
                        // The next step starts at this one's end.
                        body.at_particles(&self.particles.x0, end_time, &mut next);
                    }
                    let report = self.stepper.step_ahead(
                        &mut self.particles,
                        TensorBody::PerParticle(&field),
                        ahead.then_some(TensorBody::PerParticle(&next)),
                        dt,
                        step,
                        end_time,
                    );
                    // A re-sort reorders the particles: the next field is stale then.
                    let keep_next = ahead && matches!(&report, Ok(r) if !r.sorted);
                    if keep_next {
                        (self.body_field, self.next_body_field) = (next, field);
                        self.body_field_current = true;
                    } else {
                        (self.body_field, self.next_body_field) = (field, next);
                    }
                    report?
                }
            };
            self.dt = dt;
            self.time = end_time;
            self.steps_done = step;
            self.grid_crossings += report.crossings;
            self.max_mass_error = self.max_mass_error.max(report.mass_error);
            if let Some(e) = report.momentum_error {
                self.max_momentum_error = self.max_momentum_error.max(e);
            }
            let (kinetic_energy, strain_energy) = report.energies;
            self.history.push(HistoryRow {
                step,
                time: end_time,
                mass_rel_error: report.mass_error,
                momentum_rel_error: report.momentum_error,
                liquid_mass_rel_error: None,
                liquid_momentum_rel_error: None,
                kinetic_energy,
                strain_energy,
                grid_crossings: self.grid_crossings,
            });
            if !after_step(self)? {
                break;
            }
        }
        Ok(())
    }
}
