//! `solver.kind` → a [`LinearSolver`]: the one place where the solver configuration is
//! dispatched to concrete solver types (SPEC §5), shared by the MPM time stepper and
//! `tlsmpm solver-study`.
//!
//! The structured solvers need to know where the DOFs come from ([`SolverGeometry`]):
//! `pmg` and `pmg_cg` build their transfers between the B-spline orders `p, ..., 1` of the
//! same knot spans, and `kron` factorises the unit-density mass matrix of each direction.

use crate::config::{Smoother as ConfigSmoother, SolverConfig, SolverKind};
use crate::error::{Error, Result};
use crate::linalg::assembly::{interior, mass_1d, mass_2d, QuadraturePoint, SplineSpace};
use crate::linalg::{
    BandedCholesky, CoarseOperators, CoarseSolver, ConjugateGradient, CsrMatrix, DirectCholesky,
    GalerkinStencil, Hierarchy, Jacobi, KroneckerFactors, KroneckerPreconditioner, LinearSolver,
    PMultigrid, Pcg, PmgPreconditioner, PmgSettings, Smoother, TransferKind,
};

pub use crate::linalg::MAX_ITERATIONS;
/// Most V-cycles of a p-multigrid solve.
pub const MAX_CYCLES: usize = 2_000;

/// The spline spaces of the DOFs, fastest direction first (one for 1D, two for 2D), and
/// whether the first and last function of each direction are dropped from the matrix
/// (homogeneous Dirichlet, SPEC §5.1) or kept (the MPM grid, where eliminated DOFs are
/// identity rows).
///
/// `coarse_operators` says how p-multigrid gets its coarse levels: re-discretised unit-density
/// mass matrices (the published set-up, right for a unit-density fine matrix) or Galerkin
/// products `I^T A I` of the fine matrix handed to each solve (any density: the MPM case).
/// `density` (None: 1) is the density of the re-discretised coarse levels; the MPM step,
/// which has no density function, uses Galerkin levels instead.
#[derive(Clone, Debug)]
pub struct SolverGeometry {
    pub directions: Vec<SplineSpace>,
    pub boundary_dropped: bool,
    pub coarse_operators: CoarseOperators,
    pub density: Option<Density>,
}

/// A density at the quadrature points.
pub type Density = fn(&QuadraturePoint) -> f64;

impl SolverGeometry {
    /// Number of DOFs of the matrix.
    pub fn dofs(&self) -> usize {
        self.directions
            .iter()
            .map(|s| s.functions() - if self.boundary_dropped { 2 } else { 0 })
            .product()
    }

    /// Which DOFs of a direction with `n` functions the matrices keep.
    fn keep(&self, n: usize) -> Vec<bool> {
        if self.boundary_dropped {
            interior(n)
        } else {
            vec![true; n]
        }
    }

    /// The mass matrix of B-splines of `order` on the spans of `directions` with density
    /// `density` (None: 1; `order + 2` Gauss points per span and direction), restricted
    /// like the DOFs.
    pub fn mass_matrix(&self, order: usize, density: Option<Density>) -> Result<CsrMatrix> {
        let rho: Density = density.unwrap_or(|_| 1.0);
        match self.directions.as_slice() {
            [x] => {
                let x = x.with_order(order);
                let keep = self.keep(x.functions());
                Ok(mass_1d(&x, order + 2, rho).submatrix(&keep, &keep))
            }
            [x, y] => {
                let (x, y) = (x.with_order(order), y.with_order(order));
                let (keep_x, keep_y) = (self.keep(x.functions()), self.keep(y.functions()));
                let keep: Vec<bool> = keep_y
                    .iter()
                    .flat_map(|&ky| keep_x.iter().map(move |&kx| kx && ky))
                    .collect();
                Ok(mass_2d(&x, &y, order + 2, rho).submatrix(&keep, &keep))
            }
            directions => Err(Error::invalid(
                "--dim",
                directions.len(),
                "mass matrices in 1 or 2 dimensions only",
            )),
        }
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
    Ok(match config.kind() {
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
        SolverKind::Pmg => Box::new(PMultigrid::new(
            hierarchy(geometry, TransferKind::Published)?,
            pmg_settings(config, geometry),
        )),
        SolverKind::PmgCg => {
            let settings = PmgSettings {
                max_cycles: 1,
                ..pmg_settings(config, geometry)
            };
            let preconditioner =
                PmgPreconditioner::new(hierarchy(geometry, TransferKind::Symmetric)?, settings)
                    .map_err(|err| Error::invalid("solver.kind", "\"pmg_cg\"", err.to_string()))?;
            Box::new(preconditioner.into_cg(tolerance, MAX_ITERATIONS))
        }
    })
}

/// The p-multigrid hierarchy over the orders `p, ..., 1` of `geometry`. Galerkin
/// hierarchies always use symmetric transfers (`R = I^T`); re-discretised ones use
/// `transfers` (published for the standalone V-cycle, symmetric for the preconditioner).
fn hierarchy(geometry: &SolverGeometry, transfers: TransferKind) -> Result<Hierarchy> {
    let keep = |n: usize| geometry.keep(n);
    let unit = match (geometry.directions.as_slice(), geometry.coarse_operators) {
        ([x], CoarseOperators::Rediscretised) => Hierarchy::spline_1d(x, keep, transfers)?,
        ([x, y], CoarseOperators::Rediscretised) => Hierarchy::spline_2d(x, y, keep, transfers)?,
        // 1D: the exact product is banded and the coarse Cholesky factors it cheaply; 2D:
        // its stencil widens on every level (529 entries per row on the order-1 level at
        // p = 3), so the coarse operators keep their own mass stencil (`galerkin.rs`).
        ([x], CoarseOperators::Galerkin) => {
            return Hierarchy::galerkin_spline_1d(x, keep, GalerkinStencil::Exact)
        }
        ([x, y], CoarseOperators::Galerkin) => {
            return Hierarchy::galerkin_spline_2d(x, y, keep, GalerkinStencil::Native)
        }
        (directions, _) => {
            return Err(Error::invalid(
                "solver.kind",
                "\"pmg\"",
                format!(
                    "p-multigrid needs 1 or 2 directions, got {}",
                    directions.len()
                ),
            ))
        }
    };
    let Some(density) = geometry.density else {
        return Ok(unit);
    };
    // Re-discretise every level with the density; the transfers are geometric (lumped
    // unit-density masses) and stay.
    let order = geometry.directions.first().map_or(1, |s| s.order);
    let levels = unit.levels();
    let operators = (0..levels)
        .map(|l| geometry.mass_matrix(order - l, Some(density)))
        .collect::<Result<Vec<_>>>()?;
    let missing = || Error::invalid("solver.kind", "\"pmg\"", "incomplete p-multigrid hierarchy");
    let prolongations = (0..levels - 1)
        .map(|l| unit.prolongation(l).cloned().ok_or_else(missing))
        .collect::<Result<Vec<_>>>()?;
    let restrictions = match transfers {
        TransferKind::Symmetric => None,
        TransferKind::Published => Some(
            (0..levels - 1)
                .map(|l| unit.restriction(l).cloned().ok_or_else(missing))
                .collect::<Result<Vec<_>>>()?,
        ),
    };
    Hierarchy::rediscretised(operators, prolongations, restrictions)
}

/// V-cycle settings from `[solver]`: smoother, sweeps and tolerance. The coarse solve is
/// CG to 1e-4 (SPEC §5) on re-discretised levels; Galerkin levels are nearly singular in
/// the coarse zigzag mode, so in 1D they get the exact banded Cholesky (bandwidth 1) and in
/// 2D a capped CG. `jacobi` is the damped Jacobi step scaled by the Gershgorin bound of
/// `D^-1 A` with `omega = 2` (plain `omega = 2/3` diverges in 2D for `p >= 3`, where
/// `lambda_max(D^-1 M)` reaches 4.4).
fn pmg_settings(config: &SolverConfig, geometry: &SolverGeometry) -> PmgSettings {
    let smoother = match config.smoother {
        ConfigSmoother::Jacobi => Smoother::ScaledJacobi { omega: 2.0 },
        ConfigSmoother::GaussSeidel => Smoother::GaussSeidel,
        ConfigSmoother::SymmetricGaussSeidel => Smoother::SymmetricGaussSeidel,
    };
    let coarse = match (geometry.coarse_operators, geometry.directions.len()) {
        (CoarseOperators::Galerkin, 1) => CoarseSolver::BandedCholesky,
        _ => PmgSettings::default().coarse,
    };
    PmgSettings {
        smoother,
        pre_smooth: config.pre_smooth,
        post_smooth: config.post_smooth,
        tolerance: config.tolerance,
        coarse,
        max_cycles: MAX_CYCLES,
    }
}
