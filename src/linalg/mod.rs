//! Linear algebra for mass-matrix solves (`docs/solvers.md`): a compressed-sparse-row
//! matrix, the [`LinearSolver`] trait every solver implements, B-spline mass assembly,
//! (preconditioned) conjugate gradients, p-multigrid, the Kronecker preconditioner, the
//! banded Cholesky of 1D mass matrices, the sparse Cholesky of any SPD pattern (faer) and
//! condition-number estimation by Lanczos ([`condition`]).
//!
//! Shape of the API (after faer): a solver is built once and then called every step; the
//! initial content of `x` is the starting guess (warm start from the previous step), and
//! every call returns [`SolveStats`] instead of panicking on breakdown.

pub mod assembly;
pub mod banded;
pub mod cg;
pub mod condition;
pub mod csr;
pub mod direct;
pub mod kron;
pub mod pmg;
pub mod vectors;

pub use banded::BandedCholesky;
pub use cg::{ConjugateGradient, Identity, Jacobi, JacobiCg, Pcg, Preconditioner};
pub use csr::CsrMatrix;
pub use direct::DirectCholesky;
pub use kron::{KroneckerFactors, KroneckerPreconditioner};
pub use pmg::{
    CoarseOperators, CoarseSolver, GalerkinStencil, Hierarchy, PMultigrid, PmgCg,
    PmgPreconditioner, PmgSettings, Smoother, TransferKind,
};

use crate::error::Result;

/// What a solve did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SolveStats {
    /// Iterations (CG steps, V-cycles, ...); 0 for direct solves.
    pub iterations: usize,
    /// Final `||b - A x|| / ||b||` (0 for `b = 0`).
    pub relative_residual: f64,
}

/// One of several restricted systems of the same matrix
/// ([`LinearSolver::solve_restricted_many`]): its kept DOFs, right-hand side and initial
/// guess / solution.
#[derive(Debug)]
pub struct RestrictedSystem<'a> {
    pub keep: &'a [bool],
    pub b: &'a [f64],
    pub x: &'a mut [f64],
}

/// Most iterations of an iterative solve before it is reported as a failure.
pub const MAX_ITERATIONS: usize = 10_000;

/// A solver for the symmetric positive definite systems `A x = b` of the consistent mass
/// matrix.
pub trait LinearSolver: Send {
    /// Short name, as in the scenario key `solver.kind`.
    fn name(&self) -> &'static str;

    /// Solve `a x = b`. On entry `x` holds the initial guess; on exit, the solution.
    fn solve(&mut self, a: &CsrMatrix, b: &[f64], x: &mut [f64]) -> Result<SolveStats>;

    /// Solve again with the matrix of the previous `solve`, which the caller guarantees is
    /// unchanged (the time stepper's acceleration and velocity solves share one matrix per
    /// step): solvers with a per-matrix set-up (factorisation, Galerkin levels, diagonal
    /// scaling) reuse it. The default is [`LinearSolver::solve`].
    fn resolve(&mut self, a: &CsrMatrix, b: &[f64], x: &mut [f64]) -> Result<SolveStats> {
        self.solve(a, b, x)
    }

    /// Whether the solver solves restricted systems ([`LinearSolver::solve_restricted`]) with
    /// the set-up of the unrestricted matrix. Solvers that factor or coarsen the matrix
    /// itself (`direct`, `banded`, the stand-alone `pmg`) do not: they need the constrained
    /// matrix ([`CsrMatrix::constrain`]) and a set-up of their own.
    fn restricts(&self) -> bool {
        false
    }

    /// Solve the system of `a` restricted to the DOFs with `keep[i]`, the others held at 0:
    ///
    /// ```text
    /// (P A P + I - P) x = P b,    P = diag(keep),
    /// ```
    ///
    /// the system [`CsrMatrix::constrain`] builds, without the constrained copy. The set-up
    /// (preconditioner) is that of the matrix with the DOFs `active` kept,
    /// `(Q A Q + I - Q)`, `Q = diag(active)`, `keep` a subset of `active`: several
    /// restrictions of one matrix (the velocity components of a step with roller walls, each
    /// holding its own DOFs) share one set-up for `a` and its `active` DOFs (the nodes with
    /// mass), and `a` itself is never copied. Where [`LinearSolver::restricts`] is false
    /// this returns an error naming the solver.
    fn solve_restricted(
        &mut self,
        a: &CsrMatrix,
        active: &[bool],
        keep: &[bool],
        b: &[f64],
        x: &mut [f64],
    ) -> Result<SolveStats> {
        let _ = (a, active, keep, b, x);
        Err(crate::error::Error::Solver {
            solver: self.name().into(),
            reason: "this solver does not solve restricted systems".into(),
        })
    }

    /// [`LinearSolver::solve_restricted`] with the set-up of the previous restricted solve
    /// of `a` with the same `active` DOFs, as [`LinearSolver::resolve`].
    fn resolve_restricted(
        &mut self,
        a: &CsrMatrix,
        active: &[bool],
        keep: &[bool],
        b: &[f64],
        x: &mut [f64],
    ) -> Result<SolveStats> {
        self.solve_restricted(a, active, keep, b, x)
    }

    /// The restricted systems `systems` of one `a` and its `active` DOFs, as
    /// [`LinearSolver::solve_restricted`] on the first and
    /// [`LinearSolver::resolve_restricted`] on the others (on all of them when `resolve`),
    /// bit for bit, with each system's statistics in order. CG overrides it to run the
    /// systems in lockstep, reading `a` once per iteration for all of them.
    fn solve_restricted_many(
        &mut self,
        a: &CsrMatrix,
        active: &[bool],
        systems: &mut [RestrictedSystem<'_>],
        resolve: bool,
    ) -> Result<Vec<SolveStats>> {
        let mut stats = Vec::with_capacity(systems.len());
        for (s, system) in systems.iter_mut().enumerate() {
            stats.push(if s == 0 && !resolve {
                self.solve_restricted(a, active, system.keep, system.b, system.x)?
            } else {
                self.resolve_restricted(a, active, system.keep, system.b, system.x)?
            });
        }
        Ok(stats)
    }
}

/// `Err(Error::Solver)` naming `solver` unless `a` is square and `b`, `x` have its size.
pub(crate) fn check_dimensions(solver: &str, a: &CsrMatrix, b: &[f64], x: &[f64]) -> Result<()> {
    if a.rows == a.cols && b.len() == a.rows && x.len() == a.rows {
        return Ok(());
    }
    Err(crate::error::Error::Solver {
        solver: solver.into(),
        reason: format!(
            "dimension mismatch: matrix {}x{}, rhs {}, x {}",
            a.rows,
            a.cols,
            b.len(),
            x.len()
        ),
    })
}

/// `Err(Error::Solver)` naming `solver` unless the DOF mask `mask` (where given; `what`
/// names it: "active", "kept") has one entry per row of `a`.
pub(crate) fn check_mask(
    solver: &str,
    what: &str,
    a: &CsrMatrix,
    mask: Option<&[bool]>,
) -> Result<()> {
    match mask {
        Some(mask) if mask.len() != a.rows => Err(crate::error::Error::Solver {
            solver: solver.into(),
            reason: format!(
                "{what} mask of length {} for a matrix of {} rows",
                mask.len(),
                a.rows
            ),
        }),
        _ => Ok(()),
    }
}

/// `||b - A x|| / ||b||` (0 for `b = 0`), with `product` as scratch for `A x`: the residual a
/// direct solve reports.
pub(crate) fn relative_residual(
    a: &CsrMatrix,
    x: &[f64],
    b: &[f64],
    product: &mut Vec<f64>,
) -> f64 {
    product.resize(b.len(), 0.0);
    a.par_mul_vec(x, product);
    let (mut rr, mut bb) = (0.0, 0.0);
    for (ri, bi) in product.iter().zip(b) {
        rr += (bi - ri) * (bi - ri);
        bb += bi * bi;
    }
    if bb > 0.0 {
        (rr / bb).sqrt()
    } else {
        0.0
    }
}
