//! [`Scenario::validate`]: ranges and combinations of keys, each error naming its key and
//! value.

use super::*;
use crate::error::{Error, Result};

impl Scenario {
    /// Number of time steps, `round(end / dt)`.
    pub fn n_steps(&self) -> usize {
        (self.time.end / self.time.dt.seconds()).round() as usize
    }

    /// Cell counts per axis (`problem.dim` of them); problems extruded from 1D have one
    /// cell across unless `grid.cells` gives every axis. `None` if `grid.cells` has the
    /// wrong number of entries.
    pub fn cells_per_axis(&self) -> Option<Vec<usize>> {
        let extruded = matches!(
            self.problem.kind,
            ProblemKind::VibratingBar | ProblemKind::ColumnCompaction
        );
        self.grid
            .cells
            .per_axis(self.problem.dim, extruded.then_some(1))
    }

    /// The number of particles, `particles.per_cell` times the product of the cell counts;
    /// `None` on overflow or when the cell counts do not fit the dimension.
    pub fn particle_count(&self) -> Option<usize> {
        self.cells_per_axis()?
            .iter()
            .try_fold(self.particles.per_cell, |acc, &n| acc.checked_mul(n))
    }

    /// Range checks that do not depend on the problem; problem-specific keys are checked
    /// when the problem is built. Returns the first violation.
    pub fn validate(&self) -> Result<()> {
        self.reject_tensor_keys()?;
        if self.problem.dim != 1 {
            return self.validate_tensor();
        }
        if self.grid.cells.along_x() == 0 {
            return Err(Error::invalid("grid.cells", 0, "must be at least 1"));
        }
        if self.particles.per_cell == 0 {
            return Err(Error::invalid(
                "particles.per_cell",
                0,
                "must be at least 1",
            ));
        }
        if self.particle_count().is_none_or(|n| n > MAX_PARTICLES) {
            return Err(too_many_particles(
                self.grid.cells.along_x(),
                self.grid.cells.along_x().to_string(),
                self.particles.per_cell,
            ));
        }
        require_positive("material.density", self.material.density)?;
        require_positive("material.youngs_modulus", self.material.youngs_modulus)?;
        require_positive("time.dt", self.time.dt.seconds())?;
        require_positive("time.end", self.time.end)?;
        if self.time.end / self.time.dt.seconds() > MAX_STEPS as f64 {
            return Err(Error::invalid(
                "time.dt",
                display_float(self.time.dt.seconds()),
                format!(
                    "time.end / time.dt = {:e} steps, more than {:e}",
                    self.time.end / self.time.dt.seconds(),
                    MAX_STEPS as f64
                ),
            ));
        }
        if self.n_steps() == 0 {
            return Err(Error::invalid(
                "time.end",
                self.time.end,
                format!(
                    "shorter than half a time step (time.dt = {})",
                    self.time.dt.seconds()
                ),
            ));
        }
        require_positive("solver.tolerance", self.solver.tolerance)?;
        if let Some(length) = self.problem.length {
            require_positive("problem.length", length)?;
        }
        let max_order = crate::grid::bspline::MAX_ORDER;
        if self.method.basis == BasisKind::Bspline && !(1..=max_order).contains(&self.method.order)
        {
            return Err(Error::invalid(
                "method.order",
                self.method.order,
                format!("B-spline order must be between 1 and {max_order}"),
            ));
        }
        if self.problem.reference == ReferenceKind::Ulfem && self.problem.reference_dofs < 2 {
            return Err(Error::invalid(
                "problem.reference_dofs",
                self.problem.reference_dofs,
                "the ULFEM reference needs at least 2 nodes",
            ));
        }
        if self.problem.reference_dofs > MAX_PARTICLES {
            return Err(Error::invalid(
                "problem.reference_dofs",
                self.problem.reference_dofs,
                format!("more than {MAX_PARTICLES:e}"),
            ));
        }
        self.check_available()
    }

    /// Reject the documented keys whose methods are not implemented in this version, with
    /// a message naming the key (never a silent fallback).
    fn check_available(&self) -> Result<()> {
        let neo_hookean = self.material.model == MaterialModel::NeoHookean;
        for (key, value) in [
            ("material.shear_modulus", self.material.shear_modulus),
            ("material.lame_lambda", self.material.lame_lambda),
        ] {
            match (neo_hookean, value) {
                (true, Some(v)) => require_positive(key, v)?,
                (true, None) => {
                    return Err(Error::invalid(
                        key,
                        "(missing)",
                        "required by material.model = \"neo_hookean\"",
                    ))
                }
                (false, Some(v)) => {
                    return Err(Error::invalid(
                        key,
                        display_float(v),
                        "only used by material.model = \"neo_hookean\"",
                    ))
                }
                (false, None) => {}
            }
        }
        // The two-phase physics and the consolidation problem go together.
        let two_phase = self.material.model == MaterialModel::TwoPhase;
        if two_phase != (self.problem.kind == ProblemKind::Consolidation) {
            return Err(if two_phase {
                Error::invalid(
                    "material.model",
                    "\"two_phase\"",
                    "only problem.kind = \"consolidation\" has a two-phase set-up",
                )
            } else {
                Error::invalid(
                    "material.model",
                    toml_value(&self.material.model),
                    "problem.kind = \"consolidation\" needs material.model = \"two_phase\"",
                )
            });
        }
        if two_phase && self.method.scheme != Scheme::Musl {
            return Err(Error::invalid(
                "method.scheme",
                "\"usl\"",
                "the two-phase step is MUSL only",
            ));
        }
        if self.method.strain == Some(StrainKind::Adjoint) {
            let reason = if two_phase {
                Some("the two-phase step supports method.strain = \"gradient\" only")
            } else if !matches!(
                self.method.reconstruction,
                ReconstructionKind::Tls | ReconstructionKind::Mls | ReconstructionKind::Imls
            ) {
                Some(
                    "the adjoint strain needs method.reconstruction = \"tls\", \"mls\" or \"imls\"",
                )
            } else {
                None
            };
            if let Some(reason) = reason {
                return Err(Error::invalid("method.strain", "\"adjoint\"", reason));
            }
        }
        if let Some(degree) = self.method.conservative_degree {
            if degree > 2 {
                return Err(Error::invalid(
                    "method.conservative_degree",
                    degree,
                    "the conservative TLS fits are of total degree 0, 1 or 2",
                ));
            }
        }
        // DDMPM sub-points (SPEC §3.3) replace the particle quadrature of the direct
        // mapping; they do not combine with a reconstruction. Any basis accepts them (the
        // published comparison pairs them with `ddmpm`).
        if self.method.subpoints != 0 && self.method.reconstruction != ReconstructionKind::None {
            return Err(Error::invalid(
                "method.subpoints",
                self.method.subpoints,
                format!(
                    "sub-points need method.reconstruction = \"none\" (got \"{}\"); set \
                     method.subpoints = 0 to use a reconstruction",
                    self.method.reconstruction.name()
                ),
            ));
        }
        if self.method.subpoints > MAX_SUBPOINTS {
            return Err(Error::invalid(
                "method.subpoints",
                self.method.subpoints,
                format!("more than {MAX_SUBPOINTS} sub-points per particle"),
            ));
        }
        if matches!(self.solver.kind(), SolverKind::Pmg | SolverKind::PmgCg) {
            let sweeps = self.solver.pre_smooth + self.solver.post_smooth;
            if sweeps == 0 || sweeps > MAX_SMOOTHING_SWEEPS {
                return Err(Error::invalid(
                    "solver.pre_smooth",
                    self.solver.pre_smooth,
                    format!(
                        "pre_smooth + post_smooth (= {sweeps}) must be between 1 and \
                         {MAX_SMOOTHING_SWEEPS} for solver.kind = \"{}\"",
                        self.solver.kind().name()
                    ),
                ));
            }
        }
        if self.solver.kind() == SolverKind::PmgCg
            && self.solver.pre_smooth != self.solver.post_smooth
        {
            return Err(Error::invalid(
                "solver.post_smooth",
                self.solver.post_smooth,
                format!(
                    "a V-cycle preconditioner must be symmetric: set post_smooth = pre_smooth \
                     (= {})",
                    self.solver.pre_smooth
                ),
            ));
        }
        if self.solver.tolerance >= 1.0 {
            return Err(Error::invalid(
                "solver.tolerance",
                self.solver.tolerance,
                "a relative residual below 1 is needed",
            ));
        }
        if self.method.gauss_points > crate::numerics::gauss::MAX_POINTS
            || self.method.gauss_points == 1
        {
            return Err(Error::invalid(
                "method.gauss_points",
                self.method.gauss_points,
                format!(
                    "must be 0 (automatic) or between 2 and {}",
                    crate::numerics::gauss::MAX_POINTS
                ),
            ));
        }
        Ok(())
    }
}

/// The error for more than [`MAX_PARTICLES`] particles, blaming the larger factor of
/// `cells` (the product of the cell counts, shown as `cells_text`) and `per_cell`.
pub(crate) fn too_many_particles(cells: usize, cells_text: String, per_cell: usize) -> Error {
    if per_cell > cells {
        Error::invalid(
            "particles.per_cell",
            per_cell,
            format!("with grid.cells = {cells_text} that is more than {MAX_PARTICLES:e} particles"),
        )
    } else {
        Error::invalid(
            "grid.cells",
            cells_text,
            format!(
                "with particles.per_cell = {per_cell} that is more than {MAX_PARTICLES:e} particles"
            ),
        )
    }
}
