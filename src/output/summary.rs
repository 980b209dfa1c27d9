//! `summary.json` (DESIGN §4).

use super::write_atomic;
use crate::config::Scenario;
use crate::error::{Error, Result};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::Path;

/// Error norms per field name (`displacement`, `velocity`, `stress`).
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct Errors {
    pub rms: BTreeMap<String, f64>,
    pub rel_l2: BTreeMap<String, f64>,
}

/// Maximum conservation errors of the mapping over the run.
#[derive(Clone, Copy, Debug, Default, Serialize, PartialEq)]
pub struct Conservation {
    pub max_rel_mass_error: f64,
    pub max_rel_momentum_error: f64,
    /// Two-phase runs: the liquid phase's errors (the solid's are the two above).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub liquid_max_rel_mass_error: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub liquid_max_rel_momentum_error: Option<f64>,
}

/// Linear-solver statistics of the consistent mass solves (`kind = "lumped"` when only
/// the diagonal mass matrix is used).
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct SolverSummary {
    pub kind: String,
    pub total_iterations: usize,
    pub max_iterations: usize,
    /// Linear solves (one per velocity component and mass system per step; 0 when
    /// lumped): `total_iterations / solves` is the mean per solve.
    pub solves: usize,
}

/// Everything `summary.json` holds.
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    /// Scenario name (file stem).
    pub scenario: String,
    /// `"completed"` or `"failed"`.
    pub status: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub failure: Option<String>,
    /// The step that failed (`n_steps + 1`); `particles.csv` then holds the particle state
    /// as it was when the failure was detected, partly updated by that step, which shows
    /// where the non-finite values or the escaping particle are.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub failed_step: Option<usize>,
    pub problem: String,
    /// Spatial dimension (2D / 3D runs only; absent in 1D).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dim: Option<usize>,
    pub basis: String,
    pub reconstruction: String,
    pub n_particles: usize,
    pub n_cells: usize,
    /// Steps completed.
    pub n_steps: usize,
    /// Time reached.
    pub time: f64,
    pub threads: usize,
    pub wall_seconds: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub errors: Option<Errors>,
    pub conservation: Conservation,
    pub grid_crossings: usize,
    pub solver: SolverSummary,
    /// 2D / 3D runs: wall-clock seconds per phase of the step, summed over the run
    /// (`mass_solve_seconds / (sum of the phases)` is the share of the step in the mass
    /// solve). Timings vary from run to run; nothing else in the outputs does.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub timings: Option<crate::physics::tensor::StepTimings>,
    /// Cell fits of the reconstruction that needed a remedy (SPEC §4.1), summed over the
    /// run; all zero for the direct mapping.
    pub reconstruction_remedies: crate::mapping::RemedyCounts,
    /// Why the results of a completed run should not be trusted (relative errors above
    /// 100 %); empty when there is nothing to report.
    pub warnings: Vec<String>,
    /// The resolved scenario (file + `--set` overrides + defaults).
    pub config: Scenario,
}

impl Summary {
    /// Write as pretty JSON.
    pub fn write(&self, path: &Path) -> Result<()> {
        let text = serde_json::to_string_pretty(self).map_err(|e| Error::write(path, e))?;
        write_atomic(path, text.as_bytes())
    }
}
