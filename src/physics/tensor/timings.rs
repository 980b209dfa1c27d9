//! Wall-clock time of each phase of the 2D / 3D step, summed over the run
//! (`summary.json` `timings`, `perf/profile_step.rs`).
//!
//! The phases follow [`super::step`]: the mass and force mapping (with TLS: boxes, totals,
//! fits and quadrature), the assembly of the consistent mass `M^C` (inside the mapping
//! pass, reported apart), the consistent-mass solves (constrained copies, set-up and
//! solves of every component, acceleration and velocity), the velocity update with the
//! momentum mapping, and the particle update with the re-sort. Timing costs two
//! `Instant::now()` per phase and step; it does not change any result.

use serde::Serialize;
use std::time::Instant;

/// Seconds per phase, summed over `steps` steps.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct StepTimings {
    pub steps: usize,
    /// Mass and force mapping, without the `M^C` assembly (USL: with the momentum
    /// mapping, which comes before the solves).
    pub mass_and_force_seconds: f64,
    /// Assembly of `M^C` from the reconstructed density.
    pub assembly_seconds: f64,
    /// Consistent-mass solves (preparation, set-up, solves).
    pub mass_solve_seconds: f64,
    /// Particle velocity update and momentum mapping (MUSL; 0 with USL).
    pub velocity_and_momentum_seconds: f64,
    /// Kinematics, stress update, new cells and the counting sort (with the direct
    /// mapping's stored shapes also the next step's mass and force mapping,
    /// [`crate::mapping::tensor_next`]).
    pub particle_update_seconds: f64,
    /// Seconds a rank of a distributed run spent exchanging with the others (part of the
    /// phases above; absent from `summary.json` for one process).
    #[serde(skip_serializing_if = "is_zero")]
    pub exchange_seconds: f64,
}

fn is_zero(seconds: &f64) -> bool {
    *seconds == 0.0
}

impl StepTimings {
    /// Seconds of all phases.
    pub fn total_seconds(&self) -> f64 {
        self.mass_and_force_seconds
            + self.assembly_seconds
            + self.mass_solve_seconds
            + self.velocity_and_momentum_seconds
            + self.particle_update_seconds
    }

    /// The share of the step spent in the mass solve, `mass_solve / total` (0 before the
    /// first step).
    pub fn mass_solve_share(&self) -> f64 {
        let total = self.total_seconds();
        if total > 0.0 {
            self.mass_solve_seconds / total
        } else {
            0.0
        }
    }
}

/// A running phase clock: [`PhaseClock::lap`] returns the seconds since the last lap.
pub struct PhaseClock(Instant);

impl PhaseClock {
    pub fn start() -> Self {
        Self(Instant::now())
    }

    /// Seconds since the start or the previous lap.
    pub fn lap(&mut self) -> f64 {
        let now = Instant::now();
        let seconds = now.duration_since(self.0).as_secs_f64();
        self.0 = now;
        seconds
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shares_and_totals() {
        let t = StepTimings {
            steps: 2,
            mass_and_force_seconds: 1.0,
            assembly_seconds: 0.5,
            mass_solve_seconds: 1.5,
            velocity_and_momentum_seconds: 0.5,
            particle_update_seconds: 1.5,
            exchange_seconds: 0.0,
        };
        assert_eq!(t.total_seconds(), 5.0);
        assert!((t.mass_solve_share() - 0.3).abs() < 1e-15);
        assert_eq!(StepTimings::default().mass_solve_share(), 0.0);
    }
}
