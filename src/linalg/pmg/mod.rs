//! p-multigrid for B-spline mass matrices (SPEC §5, §5.2): V-cycles over the orders
//! `p, p-1, ..., 1` on the same knot spans.
//!
//! One V-cycle on level `l` (order `p - l`) for `A_l x = f`:
//!
//! ```text
//! x <- S^{nu_1}(x, f)                      pre-smoothing  (x += S (f - A_l x), smoother.rs)
//! r  = f - A_l x
//! f_{l+1} = R_l r,  x_{l+1} = 0            restriction to order p - l - 1
//! x_{l+1} <- V-cycle on level l + 1        (on the last level, order 1: the coarse solve)
//! x <- x + I_l x_{l+1}                     prolongation of the correction
//! x <- S*^{nu_2}(x, f)                     post-smoothing
//! ```
//!
//! The coarse solve is CG to `||r|| / ||f|| < 1e-4` (SPEC §5; at most 100 steps) or a
//! banded Cholesky ([`CoarseSolver`]). [`PMultigrid`] repeats V-cycles from the initial
//! guess until `||b - A x|| / ||b|| < tolerance` (the CG criterion, [`crate::linalg::cg`]);
//! one cycle is one iteration. A one-level hierarchy (order 1) is the coarse solve itself,
//! run to the outer tolerance (SPEC §5.1 counts one cycle for `p = 1`).
//!
//! [`PmgPreconditioner`] is one V-cycle from a zero guess, `z = V(r)`, for CG ([`PmgCg`]).
//! CG needs a fixed symmetric positive definite `V`, so the preconditioner requires
//! symmetric transfers (`R_l = I_l^T`), `nu_1 = nu_2` and post-smoothing with the adjoint
//! smoother `S*` (backward Gauss–Seidel after forward; Jacobi, symmetric GS and ILU(0) are
//! self-adjoint), and the smoother must converge on its own: raw damped Jacobi with
//! `omega = 2/3` does not on 2D mass matrices of order >= 2 (use
//! [`Smoother::ScaledJacobi`]). Its default coarse solve is CG to 1e-10: linear to well
//! below the outer tolerance and, unlike a banded Cholesky of the order-1 level (exact,
//! and the better choice in 1D, bandwidth 1), cheap in 2D, where that band is `n_x + 1`
//! wide. Galerkin hierarchies should use [`CoarseSolver::BandedCholesky`] (their coarse
//! operator is nearly singular in one mode, see `hierarchy.rs`, which slows CG down).
//!
//! Level operators and transfers come from a [`Hierarchy`] (re-discretised or Galerkin,
//! published or symmetric transfers; see `hierarchy.rs`). All work vectors live per level
//! and are allocated by the first solve only. The smoothers are serial sweeps, the
//! mat-vecs use [`CsrMatrix::par_mul_vec`] and every dot product is serial, so results are
//! bitwise the same for any number of threads.

mod galerkin;
mod hierarchy;
mod smoother;
#[cfg(test)]
mod tests;

pub use galerkin::GalerkinStencil;
pub use hierarchy::{CoarseOperators, Hierarchy, TransferKind};
use smoother::LevelSmoother;
pub use smoother::Smoother;

use super::cg::dot;
use super::SolveStats;
use super::{BandedCholesky, CsrMatrix, LinearSolver, Pcg, Preconditioner};
use crate::error::{Error, Result};

/// The solve on the coarsest level (order 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CoarseSolver {
    /// CG from zero to `||f - A x|| / ||f|| < tolerance` (SPEC §5: 1e-4) or
    /// `max_iterations` steps, whichever comes first. Running out of steps is not an error:
    /// CG's iterate minimises `||x - x*||_{A_c}`, which for Galerkin levels is the `A`-norm
    /// of the prolongated error, the quantity the correction needs (Galerkin coarse
    /// operators are nearly singular in the coarse zigzag mode that the L2 prolongation
    /// maps to almost zero, so the residual criterion can take thousands of steps there).
    /// Only a breakdown (`d^T A d <= 0`, NaN) is an error.
    Cg {
        tolerance: f64,
        max_iterations: usize,
    },
    /// Banded Cholesky, factored once per matrix (exact; bandwidth 1 in 1D).
    BandedCholesky,
}

/// Settings of [`PMultigrid`] (and of the V-cycle of [`PmgPreconditioner`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PmgSettings {
    pub smoother: Smoother,
    /// `nu_1`, smoothing steps before the coarse correction.
    pub pre_smooth: usize,
    /// `nu_2`, smoothing steps after it.
    pub post_smooth: usize,
    /// Stop when `||b - A x|| / ||b|| < tolerance` (unused by the preconditioner).
    pub tolerance: f64,
    pub coarse: CoarseSolver,
    /// Error after this many V-cycles.
    pub max_cycles: usize,
}

impl Default for PmgSettings {
    /// The published setting (SPEC §5.1): V(8, 8), forward Gauss–Seidel, coarse CG 1e-4,
    /// tolerance 1e-8, at most 500 cycles.
    fn default() -> Self {
        Self {
            smoother: Smoother::GaussSeidel,
            pre_smooth: 8,
            post_smooth: 8,
            tolerance: 1e-8,
            coarse: CoarseSolver::Cg {
                tolerance: 1e-4,
                max_iterations: 100,
            },
            max_cycles: 500,
        }
    }
}

impl PmgSettings {
    /// The V-cycle of the preconditioner: symmetric Gauss–Seidel, V(8, 8), coarse CG 1e-10.
    pub fn preconditioner() -> Self {
        Self {
            smoother: Smoother::SymmetricGaussSeidel,
            coarse: CoarseSolver::Cg {
                tolerance: 1e-10,
                max_iterations: 100,
            },
            max_cycles: 1,
            ..Self::default()
        }
    }
}

fn failure(reason: String) -> Error {
    Error::Solver {
        solver: "pmg".into(),
        reason,
    }
}

/// Work vectors of one level (level 0 uses the caller's `x` and `b`).
#[derive(Clone, Debug, Default)]
struct LevelWork {
    x: Vec<f64>,
    f: Vec<f64>,
    /// Residual, prolongated correction and Jacobi scratch.
    residual: Vec<f64>,
    smoothing: LevelSmoother,
}

/// The coarsest level's solvers and CG's work vectors.
#[derive(Clone, Debug, Default)]
struct CoarseState {
    cholesky: BandedCholesky,
    factored: bool,
    residual: Vec<f64>,
    direction: Vec<f64>,
    product: Vec<f64>,
}

impl CoarseState {
    fn solve(
        &mut self,
        solver: CoarseSolver,
        outer_tolerance: Option<f64>,
        a: &CsrMatrix,
        f: &[f64],
        x: &mut [f64],
    ) -> Result<()> {
        match solver {
            CoarseSolver::Cg {
                tolerance,
                max_iterations,
            } => {
                let tolerance = outer_tolerance.map_or(tolerance, |t| t.min(tolerance));
                self.conjugate_gradients(a, f, x, tolerance, max_iterations)?;
            }
            CoarseSolver::BandedCholesky => self.cholesky.solve_factored(f, x),
        }
        Ok(())
    }

    /// Plain CG from `x` (see [`CoarseSolver::Cg`]); serial dots, deterministic mat-vecs.
    fn conjugate_gradients(
        &mut self,
        a: &CsrMatrix,
        f: &[f64],
        x: &mut [f64],
        tolerance: f64,
        max_iterations: usize,
    ) -> Result<()> {
        let n = f.len();
        let f_norm = dot(f, f).sqrt();
        if f_norm == 0.0 {
            x.fill(0.0);
            return Ok(());
        }
        let (r, d, q) = (&mut self.residual, &mut self.direction, &mut self.product);
        r.resize(n, 0.0);
        d.resize(n, 0.0);
        q.resize(n, 0.0);
        residual(a, x, f, r);
        d.copy_from_slice(r);
        let mut rr = dot(r, r);
        for k in 1..=max_iterations {
            if rr.sqrt() < tolerance * f_norm {
                break;
            }
            a.par_mul_vec(d, q);
            let dq = dot(d, q);
            if !(dq > 0.0 && dq.is_finite()) {
                return Err(failure(format!(
                    "coarse CG breakdown: d^T A d = {dq:e} at iteration {k} (coarse operator \
                     not positive definite)"
                )));
            }
            let alpha = rr / dq;
            for i in 0..n {
                x[i] += alpha * d[i];
                r[i] -= alpha * q[i];
            }
            let rr_new = dot(r, r);
            let beta = rr_new / rr;
            rr = rr_new;
            for (di, ri) in d.iter_mut().zip(r.iter()) {
                *di = ri + beta * *di;
            }
        }
        Ok(())
    }
}

/// p-multigrid V-cycles as a solver (`solver.kind = "pmg"`).
#[derive(Clone, Debug)]
pub struct PMultigrid {
    pub settings: PmgSettings,
    hierarchy: Hierarchy,
    work: Vec<LevelWork>,
    coarse: CoarseState,
    /// Post-smooth with the adjoint smoother (symmetric V-cycle).
    adjoint_post: bool,
    /// Whether the levels are set up for the matrix of the last solve.
    prepared: bool,
}

impl PMultigrid {
    pub fn new(hierarchy: Hierarchy, settings: PmgSettings) -> Self {
        Self {
            settings,
            hierarchy,
            work: Vec::new(),
            coarse: CoarseState::default(),
            adjoint_post: false,
            prepared: false,
        }
    }

    pub fn hierarchy(&self) -> &Hierarchy {
        &self.hierarchy
    }

    fn check_size(&self, a: &CsrMatrix) -> Result<()> {
        let n = self.hierarchy.sizes()[0];
        if a.rows != n || a.cols != n {
            return Err(failure(format!(
                "matrix is {}x{}, the finest level has {n} DOFs",
                a.rows, a.cols
            )));
        }
        Ok(())
    }

    fn allocate(&mut self) {
        let sizes = self.hierarchy.sizes();
        self.work.resize_with(sizes.len(), LevelWork::default);
        for (l, (w, &n)) in self.work.iter_mut().zip(sizes).enumerate() {
            if l > 0 {
                w.x.resize(n, 0.0);
                w.f.resize(n, 0.0);
            }
            w.residual.resize(n, 0.0);
        }
    }

    /// Prepare for the fine matrix `a`: Galerkin operators, inverse diagonals of the
    /// smoothed levels, the coarse factorisation.
    fn setup(&mut self, a: &CsrMatrix) -> Result<()> {
        self.check_size(a)?;
        self.allocate();
        let galerkin = self.hierarchy.coarse_operators() == CoarseOperators::Galerkin;
        self.hierarchy.update(a)?;
        let last = self.hierarchy.levels() - 1;
        for l in 0..last {
            let operator = level_operator(&self.hierarchy, a, l);
            self.work[l]
                .smoothing
                .update(operator, self.settings.smoother)
                .map_err(|e| failure(format!("level {l}: {e}")))?;
        }
        if self.settings.coarse == CoarseSolver::BandedCholesky
            && (galerkin || last == 0 || !self.coarse.factored)
        {
            let operator = if last == 0 {
                a
            } else {
                self.hierarchy
                    .coarse_operator(last)
                    .ok_or_else(|| failure("missing coarse operator".into()))?
            };
            self.coarse
                .cholesky
                .factor(operator)
                .map_err(|e| failure(format!("coarse factorisation: {e}")))?;
            self.coarse.factored = true;
        }
        Ok(())
    }

    /// One V-cycle on `a x = f` from the current `x` (after [`PMultigrid::setup`]).
    fn cycle(&mut self, a: &CsrMatrix, x: &mut [f64], f: &[f64], outer: Option<f64>) -> Result<()> {
        let context = Cycle {
            settings: &self.settings,
            hierarchy: &self.hierarchy,
            adjoint_post: self.adjoint_post,
            outer_tolerance: outer,
        };
        context.run(&mut self.coarse, 0, a, x, f, &mut self.work)
    }
}

/// `A_l`: the solve's matrix on level 0, the hierarchy's below (`level` must exist).
fn level_operator<'a>(hierarchy: &'a Hierarchy, a: &'a CsrMatrix, level: usize) -> &'a CsrMatrix {
    if level == 0 {
        a
    } else {
        hierarchy
            .coarse_operator(level)
            .unwrap_or_else(|| unreachable!("level {level} < levels()"))
    }
}

/// What a V-cycle reads.
struct Cycle<'a> {
    settings: &'a PmgSettings,
    hierarchy: &'a Hierarchy,
    adjoint_post: bool,
    /// The outer tolerance, for a one-level hierarchy.
    outer_tolerance: Option<f64>,
}

impl Cycle<'_> {
    /// The V-cycle on `level` (`work[0]` is this level's work).
    fn run(
        &self,
        coarse: &mut CoarseState,
        level: usize,
        a: &CsrMatrix,
        x: &mut [f64],
        f: &[f64],
        work: &mut [LevelWork],
    ) -> Result<()> {
        let Some((here, below)) = work.split_first_mut() else {
            return Err(failure("empty hierarchy".into()));
        };
        if below.is_empty() {
            let outer = if level == 0 {
                self.outer_tolerance
            } else {
                None
            };
            return coarse.solve(self.settings.coarse, outer, a, f, x);
        }
        let s = self.settings;
        s.smoother.smooth(
            s.pre_smooth,
            false,
            a,
            &here.smoothing,
            x,
            f,
            &mut here.residual,
        );
        residual(a, x, f, &mut here.residual);
        let (Some(restriction), Some(prolongation), Some(next)) = (
            self.hierarchy.restriction(level),
            self.hierarchy.prolongation(level),
            self.hierarchy.coarse_operator(level + 1),
        ) else {
            return Err(failure(format!("level {level} has no transfers")));
        };
        let mut coarse_x = std::mem::take(&mut below[0].x);
        let mut coarse_f = std::mem::take(&mut below[0].f);
        restriction.par_mul_vec(&here.residual, &mut coarse_f);
        coarse_x.fill(0.0);
        let result = self.run(coarse, level + 1, next, &mut coarse_x, &coarse_f, below);
        prolongation.par_mul_vec(&coarse_x, &mut here.residual);
        below[0].x = coarse_x;
        below[0].f = coarse_f;
        result?;
        for (xi, ci) in x.iter_mut().zip(&here.residual) {
            *xi += ci;
        }
        s.smoother.smooth(
            s.post_smooth,
            self.adjoint_post,
            a,
            &here.smoothing,
            x,
            f,
            &mut here.residual,
        );
        Ok(())
    }
}

/// `r = f - a x`.
fn residual(a: &CsrMatrix, x: &[f64], f: &[f64], r: &mut [f64]) {
    a.par_mul_vec(x, r);
    for (ri, fi) in r.iter_mut().zip(f) {
        *ri = fi - *ri;
    }
}

impl LinearSolver for PMultigrid {
    fn name(&self) -> &'static str {
        "pmg"
    }

    fn solve(&mut self, a: &CsrMatrix, b: &[f64], x: &mut [f64]) -> Result<SolveStats> {
        self.prepared = false;
        self.run(a, b, x)
    }

    fn resolve(&mut self, a: &CsrMatrix, b: &[f64], x: &mut [f64]) -> Result<SolveStats> {
        self.run(a, b, x)
    }
}

impl PMultigrid {
    /// V-cycles from `x`; the levels are set up unless `prepared` says they already are.
    fn run(&mut self, a: &CsrMatrix, b: &[f64], x: &mut [f64]) -> Result<SolveStats> {
        super::check_dimensions("pmg", a, b, x)?;
        self.check_size(a)?;
        let tolerance = self.settings.tolerance;
        let b_norm = dot(b, b).sqrt();
        if b_norm == 0.0 {
            x.fill(0.0);
            return Ok(SolveStats::default());
        }
        self.allocate();
        let r = &mut self.work[0].residual;
        residual(a, x, b, r);
        let mut relative = dot(r, r).sqrt() / b_norm;
        if !relative.is_finite() {
            return Err(failure(format!(
                "non-finite initial residual ({relative:e}): NaN in the matrix, rhs or guess"
            )));
        }
        if relative < tolerance {
            return Ok(SolveStats {
                iterations: 0,
                relative_residual: relative,
            });
        }
        if !self.prepared {
            self.setup(a)?;
            self.prepared = true;
        }
        for cycle in 1..=self.settings.max_cycles {
            self.cycle(a, x, b, Some(tolerance))?;
            let r = &mut self.work[0].residual;
            residual(a, x, b, r);
            relative = dot(r, r).sqrt() / b_norm;
            if !relative.is_finite() {
                return Err(failure(format!(
                    "non-finite residual after V-cycle {cycle} (diverged)"
                )));
            }
            if relative < tolerance {
                return Ok(SolveStats {
                    iterations: cycle,
                    relative_residual: relative,
                });
            }
        }
        Err(failure(format!(
            "no convergence to {tolerance:e} in {} V-cycles (relative residual {relative:e})",
            self.settings.max_cycles
        )))
    }
}

/// One symmetric V-cycle from a zero guess as the preconditioner of CG
/// (`solver.kind = "pmg_cg"`).
#[derive(Clone, Debug)]
pub struct PmgPreconditioner {
    multigrid: PMultigrid,
    failure: Option<String>,
    /// The constrained copy of the fine matrix when set up with an `active` mask (the
    /// V-cycle smooths with the fine matrix itself); `None` without one.
    constrained: Option<CsrMatrix>,
}

/// CG preconditioned by a p-multigrid V-cycle.
pub type PmgCg = Pcg<PmgPreconditioner>;

impl PmgPreconditioner {
    /// Checks that the V-cycle is symmetric: `R_l = I_l^T` and `nu_1 = nu_2`.
    pub fn new(hierarchy: Hierarchy, settings: PmgSettings) -> Result<Self> {
        if hierarchy.transfers() != TransferKind::Symmetric {
            return Err(failure(
                "a CG preconditioner needs symmetric transfers (R = I^T), not the published \
                 restriction"
                    .into(),
            ));
        }
        if settings.pre_smooth != settings.post_smooth {
            return Err(failure(format!(
                "a CG preconditioner needs as many pre- as post-smoothing steps, got {} and {}",
                settings.pre_smooth, settings.post_smooth
            )));
        }
        let mut multigrid = PMultigrid::new(hierarchy, settings);
        multigrid.adjoint_post = true;
        Ok(Self {
            multigrid,
            failure: None,
            constrained: None,
        })
    }

    /// `Pcg` with this preconditioner.
    pub fn into_cg(self, tolerance: f64, max_iterations: usize) -> PmgCg {
        Pcg::with_preconditioner(self, tolerance, max_iterations)
    }

    pub fn multigrid(&self) -> &PMultigrid {
        &self.multigrid
    }

    /// Why the last application failed (its output was NaN, so CG stopped).
    pub fn last_failure(&self) -> Option<&str> {
        self.failure.as_deref()
    }
}

impl Preconditioner for PmgPreconditioner {
    fn solver_name(&self) -> &'static str {
        "pmg_cg"
    }

    /// With `active`, the V-cycle needs the constrained fine matrix itself: it is copied
    /// here, once per set-up.
    fn setup(&mut self, a: &CsrMatrix, active: Option<&[bool]>) -> Result<()> {
        super::check_mask("pmg_cg", "active", a, active)?;
        self.failure = None;
        let fine = match active {
            Some(active) => {
                let constrained = self.constrained.get_or_insert_with(|| a.clone());
                constrained.clone_from(a);
                constrained.constrain(active);
                &*constrained
            }
            None => {
                self.constrained = None;
                a
            }
        };
        self.multigrid.setup(fine).map_err(|e| match e {
            Error::Solver { reason, .. } => Error::Solver {
                solver: "pmg_cg".into(),
                reason,
            },
            other => other,
        })
    }

    /// `z = V(r)` (with the constrained copy of the set-up where there is one); a failed
    /// coarse solve makes `z` NaN, which CG reports as a breakdown.
    fn apply(&mut self, a: &CsrMatrix, r: &[f64], z: &mut [f64]) {
        z.fill(0.0);
        let fine = self.constrained.as_ref().unwrap_or(a);
        if let Err(e) = self.multigrid.cycle(fine, z, r, None) {
            self.failure = Some(e.to_string());
            z.fill(f64::NAN);
        }
    }
}
