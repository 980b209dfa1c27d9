//! Benchmark problems (SPEC §6) with their initial state, boundary conditions, body force
//! and exact solutions, and the ULFEM reference ([`ulfem`], [`reference`]) for problems
//! without one.
//!
//! A [`Problem`] is built from the scenario (`[problem]` keys, with per-problem defaults)
//! and answers the questions the time loop and the error measures ask. Exact fields are
//! functions of the material (initial) position `X_p`: the small-deformation bar solution
//! is the linearised one, where `x_p - X_p` would otherwise dominate the velocity error
//! (`v0 pi u / H` ~ 4e-7 against spatial errors of 1e-10), and the column compaction stress
//! is the weight of the material above `X_p`.

pub mod column_compaction;
pub mod reference;
pub mod ulfem;
pub mod vibrating_bar;

pub use column_compaction::ColumnCompaction;
pub use reference::UlfemReference;
pub use vibrating_bar::VibratingBar;

use crate::config::{ProblemKind, ReferenceKind, Scenario};
use crate::error::{Error, Result};
use crate::grid::Grid;
use crate::particles::Particles;
use crate::physics::{Boundary, Material};

/// Fields compared against exact solutions, named as in `summary.json`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Field {
    Displacement,
    Velocity,
    Stress,
}

impl Field {
    /// All one-phase fields.
    pub const ALL: [Field; 3] = [Field::Displacement, Field::Velocity, Field::Stress];

    /// Name in `summary.json` and `study.csv`.
    pub fn name(self) -> &'static str {
        match self {
            Field::Displacement => "displacement",
            Field::Velocity => "velocity",
            Field::Stress => "stress",
        }
    }

    /// Short column prefix in `particles.csv` (`u_exact`, `v_exact`, `stress_exact`).
    pub fn column(self) -> &'static str {
        match self {
            Field::Displacement => "u",
            Field::Velocity => "v",
            Field::Stress => "stress",
        }
    }
}

/// Which position the profile plot uses on its horizontal axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlotAxis {
    Current,
    Initial,
}

/// A benchmark problem.
pub trait Problem: Send + Sync {
    /// Name as in `problem.kind`.
    fn name(&self) -> &'static str;
    /// Length (height) of the domain.
    fn length(&self) -> f64;
    /// Initial particles on `grid`, `per_cell` per cell.
    fn initial_particles(&self, grid: &Grid, per_cell: usize, density: f64) -> Particles;
    /// Boundary conditions.
    fn boundary(&self) -> Boundary;
    /// Signed body acceleration at time `t`.
    fn body_acceleration(&self, t: f64) -> f64;
    /// Fields with an exact solution.
    fn exact_fields(&self) -> &'static [Field];
    /// Exact value of `field` at material position `x0` and time `t` (`None` if unknown).
    fn exact(&self, field: Field, x0: f64, t: f64) -> Option<f64>;
    /// Exact values of `field` at many material positions (NaN where unknown).
    fn exact_profile(&self, field: Field, x0: &[f64], t: f64) -> Vec<f64> {
        x0.iter()
            .map(|&x| self.exact(field, x, t).unwrap_or(f64::NAN))
            .collect()
    }
    /// Initial velocity at material position `x0`.
    fn initial_velocity(&self, x0: f64) -> f64 {
        let _ = x0;
        0.0
    }
    /// Whether the "exact" velocity is itself time-stepped like the particles' (a
    /// reference solution): then it is compared at `t`, never at `t - dt/2`.
    fn velocity_is_time_stepped(&self) -> bool {
        false
    }
    /// Legend label of the exact fields in plots.
    fn reference_label(&self) -> &'static str {
        "exact"
    }
    /// Horizontal axis of the profile plot.
    fn plot_axis(&self) -> PlotAxis {
        PlotAxis::Current
    }
}

/// Build the problem of a scenario, checking its problem-specific keys; with
/// `problem.reference = "ulfem"` it is wrapped in an [`UlfemReference`].
pub fn build(scenario: &Scenario) -> Result<Box<dyn Problem>> {
    let problem = build_exact(scenario)?;
    match scenario.problem.reference {
        ReferenceKind::Exact => Ok(problem),
        ReferenceKind::Ulfem => {
            let material = Material::require(&scenario.material)?;
            Ok(Box::new(UlfemReference::new(
                problem,
                scenario.problem.reference_dofs,
                scenario.material.density,
                material,
                scenario.time.dt,
            )?))
        }
    }
}

fn build_exact(scenario: &Scenario) -> Result<Box<dyn Problem>> {
    let p = &scenario.problem;
    let reject = |key: &str, value: Option<f64>, kind: &str| match value {
        Some(v) => Err(Error::invalid(
            key,
            crate::config::display_float(v),
            format!("not used by problem.kind = \"{kind}\""),
        )),
        None => Ok(()),
    };
    match p.kind {
        ProblemKind::VibratingBar => {
            reject("problem.gravity", p.gravity, "vibrating_bar")?;
            Ok(Box::new(VibratingBar::from_scenario(scenario)?))
        }
        ProblemKind::ColumnCompaction => {
            reject("problem.v0", p.v0, "column_compaction")?;
            Ok(Box::new(ColumnCompaction::from_scenario(scenario)?))
        }
        ProblemKind::Consolidation | ProblemKind::MmsBar => Err(Error::invalid(
            "problem.kind",
            format!("{:?}", p.kind),
            "not available in this version of tlsmpm",
        )),
    }
}
