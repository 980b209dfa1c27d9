//! Validation of the keys of 2D / 3D scenarios (`problem.dim = 2 | 3`, DESIGN §7) and of the
//! 2D / 3D keys in 1D scenarios. Every error names its key.

use super::*;
use crate::error::{Error, Result};

/// The integer `n` with `n^dim = count`, if any.
pub fn integer_root(count: usize, dim: usize) -> Option<usize> {
    let guess = (count as f64).powf(1.0 / dim as f64).round() as usize;
    (guess.saturating_sub(1)..=guess + 1).find(|&n| n.checked_pow(dim as u32) == Some(count))
}

impl Scenario {
    /// The 2D / 3D keys that a 1D scenario must not use.
    pub(super) fn reject_tensor_keys(&self) -> Result<()> {
        if self.problem.dim != 1 {
            return Ok(());
        }
        if let Cells::PerAxis(counts) = &self.grid.cells {
            if counts.len() != 1 {
                return Err(Error::invalid(
                    "grid.cells",
                    format!("{counts:?}"),
                    format!(
                        "{} entries, problem.dim = 1 needs one (or an integer)",
                        counts.len()
                    ),
                ));
            }
        }
        if !self.boundary.is_empty() {
            let key = self
                .boundary
                .faces()
                .iter()
                .flatten()
                .find(|(_, c)| c.is_some())
                .map_or("boundary", |(k, _)| k);
            return Err(Error::invalid(
                key,
                "(given)",
                "[boundary] faces are for problem.dim = 2 | 3; 1D problems have their own ends",
            ));
        }
        if let Some(nu) = self.material.poisson_ratio {
            return Err(Error::invalid(
                "material.poisson_ratio",
                display_float(nu),
                "only used by the linear law in 2D / 3D (problem.dim = 2 | 3)",
            ));
        }
        if self.time.dt == TimeStep::Auto {
            return Err(Error::invalid(
                "time.dt",
                "\"auto\"",
                "automatic time steps are for problem.dim = 2 | 3; give a number in 1D",
            ));
        }
        if let Some(cfl) = self.time.cfl {
            return Err(Error::invalid(
                "time.cfl",
                display_float(cfl),
                "only used with time.dt = \"auto\" (problem.dim = 2 | 3)",
            ));
        }
        if self.problem.kind == ProblemKind::AxisAlignedMms {
            return Err(Error::invalid(
                "problem.kind",
                "\"axis_aligned_mms\"",
                "the axis-aligned manufactured solution is 2D / 3D: set problem.dim = 2 or 3",
            ));
        }
        Ok(())
    }

    /// Range checks and combinations of a 2D / 3D scenario.
    pub(super) fn validate_tensor(&self) -> Result<()> {
        let dim = self.problem.dim;
        if !(1..=3).contains(&dim) {
            return Err(Error::invalid("problem.dim", dim, "must be 1, 2 or 3"));
        }
        let one_d_only = |key: &str, value: &str, what: &str| {
            Err(Error::invalid(
                key,
                value,
                format!("{what} is 1D only (problem.dim = 1); problem.dim = {dim}"),
            ))
        };
        match self.problem.kind {
            ProblemKind::Consolidation => {
                return one_d_only("problem.kind", "\"consolidation\"", "the two-phase column")
            }
            ProblemKind::MmsBar => {
                return one_d_only(
                    "problem.kind",
                    "\"mms_bar\"",
                    "the MMS bar (use \"axis_aligned_mms\")",
                )
            }
            _ => {}
        }
        let cells = self.cells_per_axis().ok_or_else(|| {
            let n = match &self.grid.cells {
                Cells::PerAxis(c) => c.len(),
                Cells::Uniform(_) => 1,
            };
            Error::invalid(
                "grid.cells",
                format!("{:?}", self.grid.cells),
                format!("{n} entries, problem.dim = {dim} needs {dim} (or one integer for all)"),
            )
        })?;
        if let Some(pos) = cells.iter().position(|&n| n == 0) {
            return Err(Error::invalid(
                "grid.cells",
                format!("{cells:?}"),
                format!("axis {pos} has no cells; every count must be at least 1"),
            ));
        }
        let per_cell = self.particles.per_cell;
        if per_cell == 0 {
            return Err(Error::invalid(
                "particles.per_cell",
                0,
                "must be at least 1",
            ));
        }
        if integer_root(per_cell, dim).is_none() {
            let examples = if dim == 2 {
                "1, 4, 9, 16, ..."
            } else {
                "1, 8, 27, 64, ..."
            };
            return Err(Error::invalid(
                "particles.per_cell",
                per_cell,
                format!(
                    "in {dim}D the particles per cell are a perfect {} ({examples}): the same \
                     count along every axis",
                    if dim == 2 { "square" } else { "cube" }
                ),
            ));
        }
        if self.particle_count().is_none_or(|n| n > MAX_PARTICLES) {
            let cell_count = cells.iter().fold(1_usize, |acc, &n| acc.saturating_mul(n));
            return Err(super::validate::too_many_particles(
                cell_count,
                format!("{cells:?}"),
                per_cell,
            ));
        }
        match self.material.model {
            MaterialModel::Hill => return one_d_only("material.model", "\"hill\"", "Hill's law"),
            MaterialModel::TwoPhase => {
                return one_d_only("material.model", "\"two_phase\"", "the two-phase material")
            }
            MaterialModel::Linear | MaterialModel::NeoHookean => {}
        }
        if self.problem.kind == ProblemKind::AxisAlignedMms
            && self.material.model != MaterialModel::NeoHookean
        {
            return Err(Error::invalid(
                "material.model",
                "\"linear\"",
                "problem.kind = \"axis_aligned_mms\" needs material.model = \"neo_hookean\"",
            ));
        }
        if let Some(nu) = self.material.poisson_ratio {
            if self.material.model != MaterialModel::Linear {
                return Err(Error::invalid(
                    "material.poisson_ratio",
                    display_float(nu),
                    "only used by material.model = \"linear\"",
                ));
            }
            if !(0.0..0.5).contains(&nu) {
                return Err(Error::invalid(
                    "material.poisson_ratio",
                    display_float(nu),
                    "must be in [0, 0.5)",
                ));
            }
        }
        for (key, value) in [
            ("material.porosity", self.material.porosity),
            ("material.density_solid", self.material.density_solid),
            ("material.density_liquid", self.material.density_liquid),
            (
                "material.constrained_modulus",
                self.material.constrained_modulus,
            ),
            (
                "material.bulk_modulus_liquid",
                self.material.bulk_modulus_liquid,
            ),
            ("material.permeability", self.material.permeability),
            ("material.gravity", self.material.gravity),
        ] {
            if let Some(v) = value {
                return one_d_only(key, &display_float(v), "the two-phase material");
            }
        }
        match self.method.basis {
            BasisKind::Linear | BasisKind::Bspline | BasisKind::Gimp => {}
            BasisKind::Ddmpm => return one_d_only("method.basis", "\"ddmpm\"", "DDMPM"),
            BasisKind::Cpdi => return one_d_only("method.basis", "\"cpdi\"", "CPDI"),
        }
        match self.method.reconstruction {
            ReconstructionKind::None | ReconstructionKind::Tls => {}
            other => {
                return one_d_only(
                    "method.reconstruction",
                    &format!("\"{}\"", other.name()),
                    "this reconstruction",
                )
            }
        }
        if (self.method.mass == MassKind::Consistent
            || self.method.acceleration_mass == Some(MassKind::Consistent))
            && self.method.reconstruction != ReconstructionKind::Tls
        {
            return Err(Error::invalid(
                "method.mass",
                "\"consistent\"",
                "the consistent mass in 2D / 3D needs method.reconstruction = \"tls\"",
            ));
        }
        match self.solver.kind {
            Some(SolverKind::Banded) => {
                return one_d_only("solver.kind", "\"banded\"", "the banded Cholesky")
            }
            Some(kind @ (SolverKind::Pmg | SolverKind::PmgCg)) if self.problem.dim == 3 => {
                return Err(Error::invalid(
                    "solver.kind",
                    format!("\"{}\"", kind.name()),
                    "is available in 1D and 2D (use kron, cg, pcg or direct in 3D)",
                ))
            }
            _ => {}
        }
        if self.method.subpoints != 0 {
            return one_d_only(
                "method.subpoints",
                &self.method.subpoints.to_string(),
                "DDMPM sub-points",
            );
        }
        if self.method.strain == Some(StrainKind::Adjoint) {
            return one_d_only("method.strain", "\"adjoint\"", "the adjoint strain");
        }
        if self.method.momentum_limiter == Some(MomentumLimiter::KineticEnergy) {
            return one_d_only(
                "method.momentum_limiter",
                "\"kinetic_energy\"",
                "the kinetic-energy limiter",
            );
        }
        if self.method.fit_weights == Some(FitWeights::Domains) {
            return one_d_only(
                "method.fit_weights",
                "\"domains\"",
                "the domain-weighted TLS fits",
            );
        }
        if let Some(metric @ (AdjointMass::Consistent | AdjointMass::Quadratic)) =
            self.method.adjoint_mass
        {
            return one_d_only(
                "method.adjoint_mass",
                if metric == AdjointMass::Quadratic {
                    "\"quadratic\""
                } else {
                    "\"consistent\""
                },
                "the consistent particle mass of the adjoint TLS acceleration",
            );
        }
        if self.method.stress_fit == Some(StressFit::Conservative) {
            return one_d_only(
                "method.stress_fit",
                "\"conservative\"",
                "the conservative stress fit",
            );
        }
        if self.problem.reference == ReferenceKind::Ulfem {
            return one_d_only("problem.reference", "\"ulfem\"", "the ULFEM reference");
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
        require_positive("material.density", self.material.density)?;
        require_positive("material.youngs_modulus", self.material.youngs_modulus)?;
        if self.material.model == MaterialModel::NeoHookean {
            for (key, value) in [
                ("material.shear_modulus", self.material.shear_modulus),
                ("material.lame_lambda", self.material.lame_lambda),
            ] {
                match value {
                    Some(v) => require_positive(key, v)?,
                    None => {
                        return Err(Error::invalid(
                            key,
                            "(missing)",
                            "required by material.model = \"neo_hookean\"",
                        ))
                    }
                }
            }
        }
        require_positive("time.end", self.time.end)?;
        match self.time.dt {
            TimeStep::Fixed(dt) => {
                require_positive("time.dt", dt)?;
                if self.time.end / dt > MAX_STEPS as f64 {
                    return Err(Error::invalid(
                        "time.dt",
                        display_float(dt),
                        format!("more than {:e} steps", MAX_STEPS as f64),
                    ));
                }
                if (self.time.end / dt).round() < 1.0 {
                    return Err(Error::invalid(
                        "time.end",
                        display_float(self.time.end),
                        format!("shorter than half a time step (time.dt = {dt})"),
                    ));
                }
                if let Some(cfl) = self.time.cfl {
                    return Err(Error::invalid(
                        "time.cfl",
                        display_float(cfl),
                        "only used with time.dt = \"auto\"",
                    ));
                }
            }
            TimeStep::Auto => {
                let cfl = self.time.cfl.unwrap_or(0.5);
                if !(cfl > 0.0 && cfl <= 1.0) {
                    return Err(Error::invalid(
                        "time.cfl",
                        display_float(cfl),
                        "must be in (0, 1]",
                    ));
                }
            }
        }
        if let Some(length) = self.problem.length {
            require_positive("problem.length", length)?;
        }
        for (axis, sides) in self.boundary.faces().iter().enumerate().skip(dim) {
            for (key, condition) in sides {
                if condition.is_some() {
                    return Err(Error::invalid(
                        key,
                        "(given)",
                        format!("a {dim}D grid has no faces normal to axis {axis}"),
                    ));
                }
            }
        }
        if self.output.velocity_reference != VelocityReference::HalfStep {
            // Both references are supported; nothing to check.
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integer_roots() {
        assert_eq!(integer_root(16, 2), Some(4));
        assert_eq!(integer_root(27, 3), Some(3));
        assert_eq!(integer_root(12, 2), None);
        assert_eq!(integer_root(1, 3), Some(1));
        assert_eq!(integer_root(usize::MAX, 2), None);
    }
}
