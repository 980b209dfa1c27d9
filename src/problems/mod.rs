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

pub mod axis_aligned_mms;
pub mod column_compaction;
pub mod consolidation;
pub mod mms_bar;
pub mod reference;
pub mod tensor;
pub mod terzaghi;
pub mod ulfem;
pub mod vibrating_bar;

pub use column_compaction::ColumnCompaction;
pub use consolidation::Consolidation;
pub use mms_bar::MmsBar;
pub use reference::UlfemReference;
pub use vibrating_bar::VibratingBar;

use crate::config::{ProblemKind, ReferenceKind, Scenario};
use crate::error::{Error, Result};
use crate::grid::Grid;
use crate::particles::Particles;
use crate::physics::{Boundary, Material};

/// Fields compared against exact solutions, named as in `summary.json`. For two-phase
/// problems `Displacement` and `Velocity` are the solid's and `Stress` is the total stress
/// `sigma' + p`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Field {
    Displacement,
    Velocity,
    Stress,
    /// Two-phase: liquid velocity `v_w`.
    LiquidVelocity,
    /// Two-phase: pore pressure `p` (positive in tension).
    PorePressure,
    /// Two-phase: effective stress `sigma'`.
    EffectiveStress,
}

impl Field {
    /// All one-phase fields.
    pub const ALL: [Field; 3] = [Field::Displacement, Field::Velocity, Field::Stress];

    /// All fields of a two-phase problem.
    pub const TWO_PHASE: [Field; 6] = [
        Field::Displacement,
        Field::Velocity,
        Field::Stress,
        Field::LiquidVelocity,
        Field::PorePressure,
        Field::EffectiveStress,
    ];

    /// Name in `summary.json` and `study.csv`.
    pub fn name(self) -> &'static str {
        match self {
            Field::Displacement => "displacement",
            Field::Velocity => "velocity",
            Field::Stress => "stress",
            Field::LiquidVelocity => "liquid_velocity",
            Field::PorePressure => "pore_pressure",
            Field::EffectiveStress => "effective_stress",
        }
    }

    /// Short column prefix in `particles.csv` (`u_exact`, `v_exact`, `stress_exact`,
    /// `v_w_exact`, `pore_pressure_exact`, `effective_stress_exact`).
    pub fn column(self) -> &'static str {
        match self {
            Field::Displacement => "u",
            Field::Velocity => "v",
            Field::Stress => "stress",
            Field::LiquidVelocity => "v_w",
            Field::PorePressure => "pore_pressure",
            Field::EffectiveStress => "effective_stress",
        }
    }

    /// Whether the exact value is a velocity (compared half a step back, see
    /// `output.velocity_reference`).
    pub fn is_velocity(self) -> bool {
        matches!(self, Field::Velocity | Field::LiquidVelocity)
    }

    /// The particle values of this field (`None` for liquid fields of one-phase particles).
    pub fn values(self, particles: &Particles) -> Option<std::borrow::Cow<'_, [f64]>> {
        use std::borrow::Cow;
        let liquid = particles.liquid.as_ref();
        Some(match self {
            Field::Displacement => Cow::Borrowed(&particles.u[..]),
            Field::Velocity => Cow::Borrowed(&particles.v[..]),
            Field::Stress => match liquid {
                None => Cow::Borrowed(&particles.stress[..]),
                Some(l) => Cow::Owned(
                    particles
                        .stress
                        .iter()
                        .zip(&l.pore_pressure)
                        .map(|(s, p)| s + p)
                        .collect(),
                ),
            },
            Field::LiquidVelocity => Cow::Borrowed(&liquid?.velocity[..]),
            Field::PorePressure => Cow::Borrowed(&liquid?.pore_pressure[..]),
            Field::EffectiveStress => {
                liquid?;
                Cow::Borrowed(&particles.stress[..])
            }
        })
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
    /// Boundary conditions (of the solid phase for two-phase problems: the traction is the
    /// total stress).
    fn boundary(&self) -> Boundary;
    /// Boundary conditions of the liquid phase of two-phase problems: fixed ends are
    /// impermeable (`v_w = 0`), a free end's traction is its prescribed pore pressure.
    fn liquid_boundary(&self) -> Boundary {
        self.boundary()
    }
    /// Time of the initial state (the exact solution's clock; `problem.start_time`).
    fn start_time(&self) -> f64 {
        0.0
    }
    /// Signed body acceleration at time `t` (uniform in space).
    fn body_acceleration(&self, t: f64) -> f64;
    /// Whether the body force varies in space ([`Problem::body_acceleration_at`]).
    fn body_varies_in_space(&self) -> bool {
        false
    }
    /// Signed body acceleration at material position `x0` and time `t`.
    fn body_acceleration_at(&self, x0: f64, t: f64) -> f64 {
        let _ = x0;
        self.body_acceleration(t)
    }
    /// Fields with an exact solution.
    fn exact_fields(&self) -> &'static [Field];
    /// Exact value of `field` at material position `x0` and time `t` (`None` if unknown).
    fn exact(&self, field: Field, x0: f64, t: f64) -> Option<f64>;
    /// Exact values of `field` at many material positions (NaN where unknown), evaluated
    /// in parallel on the current rayon pool (each value on its own: the same bits for any
    /// thread count).
    fn exact_profile(&self, field: Field, x0: &[f64], t: f64) -> Vec<f64> {
        use rayon::prelude::*;
        x0.par_iter()
            .with_min_len(4096)
            .map(|&x| self.exact(field, x, t).unwrap_or(f64::NAN))
            .collect()
    }
    /// Initial velocity at material position `x0`.
    fn initial_velocity(&self, x0: f64) -> f64 {
        let _ = x0;
        0.0
    }
    /// Times up to `end` at which the exact fields are largest, beside `end` itself: the
    /// size of the solution against which a run's errors are judged (an error at the end of
    /// a period of a vibration, where the exact field passes through zero, is not large
    /// because the field is small there). Default: the start time (decaying and loaded
    /// problems); empty when the exact values are only known at the end (a reference).
    fn solution_peak_times(&self, end: f64) -> Vec<f64> {
        let _ = end;
        vec![self.start_time()]
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
            if matches!(
                scenario.problem.kind,
                ProblemKind::Consolidation | ProblemKind::MmsBar
            ) {
                return Err(Error::invalid(
                    "problem.reference",
                    "\"ulfem\"",
                    "the ULFEM reference takes a uniform body force on a one-phase bar; this \
                     problem has an exact solution (\"exact\")",
                ));
            }
            let material = Material::require(&scenario.material)?;
            Ok(Box::new(UlfemReference::new(
                problem,
                scenario.problem.reference_dofs,
                scenario.material.density,
                material,
                scenario.time.dt.seconds(),
            )?))
        }
    }
}

fn build_exact(scenario: &Scenario) -> Result<Box<dyn Problem>> {
    let p = &scenario.problem;
    let kind = match p.kind {
        ProblemKind::VibratingBar => "vibrating_bar",
        ProblemKind::ColumnCompaction => "column_compaction",
        ProblemKind::Consolidation => "consolidation",
        ProblemKind::MmsBar => "mms_bar",
        ProblemKind::AxisAlignedMms => {
            return Err(Error::invalid(
                "problem.kind",
                "\"axis_aligned_mms\"",
                "the axis-aligned manufactured solution is 2D / 3D: set problem.dim = 2 or 3",
            ))
        }
    };
    // Keys of other problems would be silently ignored: reject them.
    let reject = |key: &str, value: Option<f64>| match value {
        Some(v) => Err(Error::invalid(
            key,
            crate::config::display_float(v),
            format!("not used by problem.kind = \"{kind}\""),
        )),
        None => Ok(()),
    };
    let one_phase = matches!(
        p.kind,
        ProblemKind::VibratingBar | ProblemKind::ColumnCompaction
    );
    if p.kind != ProblemKind::MmsBar {
        reject("problem.amplitude", p.amplitude)?;
    }
    if one_phase {
        reject("problem.load", p.load)?;
        reject("problem.start_time", p.start_time)?;
    }
    match p.kind {
        ProblemKind::VibratingBar => {
            reject("problem.gravity", p.gravity)?;
            Ok(Box::new(VibratingBar::from_scenario(scenario)?))
        }
        ProblemKind::ColumnCompaction => {
            reject("problem.v0", p.v0)?;
            Ok(Box::new(ColumnCompaction::from_scenario(scenario)?))
        }
        ProblemKind::Consolidation => {
            reject("problem.v0", p.v0)?;
            reject("problem.gravity", p.gravity)?;
            Ok(Box::new(Consolidation::from_scenario(scenario)?))
        }
        ProblemKind::MmsBar => {
            reject("problem.v0", p.v0)?;
            reject("problem.gravity", p.gravity)?;
            reject("problem.load", p.load)?;
            reject("problem.start_time", p.start_time)?;
            Ok(Box::new(MmsBar::from_scenario(scenario)?))
        }
        ProblemKind::AxisAlignedMms => unreachable!("rejected above"),
    }
}

/// A problem as the body-force source of the time loop: uniform problems give `b(t)`,
/// the others `b(X_p, t)` at every particle (in parallel, order independent).
pub struct ProblemBody<'a>(pub &'a dyn Problem);

impl crate::physics::BodySource for ProblemBody<'_> {
    fn uniform(&self, t: f64) -> Option<f64> {
        (!self.0.body_varies_in_space()).then(|| self.0.body_acceleration(t))
    }

    fn at_particles(&self, x0: &[f64], t: f64, out: &mut [f64]) {
        use rayon::prelude::*;
        out.par_iter_mut()
            .zip(x0.par_iter())
            .with_min_len(4096)
            .for_each(|(b, &x)| *b = self.0.body_acceleration_at(x, t));
    }
}
