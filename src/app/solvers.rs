//! `solver.kind` → a [`LinearSolver`]: the one place where the solver configuration is
//! dispatched to concrete solver types (SPEC §5), shared by the MPM time stepper and
//! `tlsmpm solver-study`.
//!
//! The structured solvers need to know where the DOFs come from ([`SolverGeometry`]):
//! `pmg` and `pmg_cg` build their transfers between the B-spline orders `p, ..., 1` of the
//! same knot spans, and `kron` factorises the unit-density mass matrix of each direction.

use crate::config::{SolverConfig, SolverKind};
use crate::error::{Error, Result};
use crate::linalg::assembly::{interior, mass_1d, SplineSpace};
use crate::linalg::{
    BandedCholesky, ConjugateGradient, CsrMatrix, DirectCholesky, Jacobi, KroneckerFactors,
    KroneckerPreconditioner, LinearSolver, Pcg,
};

/// Most iterations of an iterative solve before it is reported as a failure.
pub const MAX_ITERATIONS: usize = 10_000;

/// The spline spaces of the DOFs, fastest direction first (one for 1D, two for 2D), and
/// whether the first and last function of each direction are dropped from the matrix
/// (homogeneous Dirichlet, SPEC §5.1) or kept (the MPM grid, where eliminated DOFs are
/// identity rows).
#[derive(Clone, Debug, PartialEq)]
pub struct SolverGeometry {
    pub directions: Vec<SplineSpace>,
    pub boundary_dropped: bool,
}

impl SolverGeometry {
    /// Number of DOFs of the matrix.
    pub fn dofs(&self) -> usize {
        self.directions
            .iter()
            .map(|s| s.functions() - if self.boundary_dropped { 2 } else { 0 })
            .product()
    }

    /// The unit-density 1D mass matrix of each direction, restricted like the DOFs.
    pub fn unit_masses(&self) -> Vec<CsrMatrix> {
        self.directions
            .iter()
            .map(|space| {
                let mass = mass_1d(space, space.order + 1, |_| 1.0);
                if self.boundary_dropped {
                    let keep = interior(space.functions());
                    mass.submatrix(&keep, &keep)
                } else {
                    mass
                }
            })
            .collect()
    }
}

/// The solver of `config.kind` for matrices on `geometry`.
pub fn build_solver(
    config: &SolverConfig,
    geometry: &SolverGeometry,
) -> Result<Box<dyn LinearSolver>> {
    let tolerance = config.tolerance;
    Ok(match config.kind {
        SolverKind::Banded => Box::new(BandedCholesky::new()),
        // Sequential factorisation: faer's parallel supernodal path need not be bitwise
        // reproducible across thread counts.
        SolverKind::Direct => Box::new(DirectCholesky::new()),
        SolverKind::Cg => Box::new(ConjugateGradient::new(tolerance, MAX_ITERATIONS)),
        SolverKind::Pcg => Box::new(Pcg::with_preconditioner(
            Jacobi::default(),
            tolerance,
            MAX_ITERATIONS,
        )),
        SolverKind::Kron => {
            let factors = KroneckerFactors::new(&geometry.unit_masses())?;
            Box::new(Pcg::with_preconditioner(
                KroneckerPreconditioner::new(factors),
                tolerance,
                MAX_ITERATIONS,
            ))
        }
        other => {
            return Err(Error::invalid(
                "solver.kind",
                format!("\"{}\"", other.name()),
                "not available in this version of tlsmpm",
            ))
        }
    })
}
