//! Conjugate gradients for the consistent mass over the ranks of a distributed run
//! (`docs/distributed.md`): the same iteration as [`crate::linalg::cg`], with
//!
//! ```text
//! q = M d      each rank multiplies by the rows its cells assembled, then adds the
//!              neighbours' partial rows on the shared node layers (RankContext::add_shared)
//! (u, v)       sum over the node layers each rank owns, then summed over ranks in rank order
//! z = D^-1 r   Jacobi: the diagonal completed like a product (local per node)
//! ```
//!
//! Every rank sees the same global scalars (`alpha`, `beta`, the residual), so all stop
//! at the same iteration and shared nodes hold bit-identical values on both ranks. The
//! preconditioners that are not local per node do not carry over: the Kronecker inverse
//! solves with the 1D mass along the cut axis, which couples every slab, and the
//! p-multigrid and direct solves factor the whole matrix; a distributed run refuses them.

use super::RankContext;
use crate::error::{Error, Result};
use crate::linalg::{check_dimensions, CsrMatrix, LinearSolver, SolveStats};
use rayon::prelude::*;
use std::ops::Range;
use std::sync::Arc;

/// CG (`"cg"`) or Jacobi-preconditioned CG (`"pcg"`) over ranks; stops when
/// `||r|| / ||b|| < tolerance` (norms over all ranks' owned nodes).
pub struct DistributedCg {
    ranks: Arc<RankContext>,
    /// The rank's touched nodes: the only rows it multiplies and entries it updates
    /// (elsewhere every vector of the iteration stays 0).
    touched: Vec<Range<usize>>,
    jacobi: bool,
    tolerance: f64,
    max_iterations: usize,
    inverse_diagonal: Vec<f64>,
    residual: Vec<f64>,
    preconditioned: Vec<f64>,
    direction: Vec<f64>,
    product: Vec<f64>,
}

impl DistributedCg {
    /// CG over `ranks` (Jacobi-preconditioned if `jacobi`) to `tolerance` in at most
    /// `max_iterations` steps.
    pub fn new(
        ranks: Arc<RankContext>,
        jacobi: bool,
        tolerance: f64,
        max_iterations: usize,
    ) -> Self {
        Self {
            touched: ranks.touched_nodes().collect(),
            ranks,
            jacobi,
            tolerance,
            max_iterations,
            inverse_diagonal: Vec::new(),
            residual: Vec::new(),
            preconditioned: Vec::new(),
            direction: Vec::new(),
            product: Vec::new(),
        }
    }

    fn failure(&self, reason: String) -> Error {
        Error::Solver {
            solver: self.name().into(),
            reason: format!("{reason} (distributed over {} ranks)", self.ranks.ranks()),
        }
    }

    /// `D^-1` of the completed diagonal of `a`.
    fn setup(&mut self, a: &CsrMatrix) -> Result<()> {
        if !self.jacobi {
            return Ok(());
        }
        a.diagonal_into(&mut self.inverse_diagonal);
        self.ranks.add_shared(&mut self.inverse_diagonal, 1)?;
        // Every rank must agree before any returns, or the others wait in the next sum.
        let bad = self
            .inverse_diagonal
            .iter()
            .position(|d| d.is_nan() || *d <= 0.0);
        if self.ranks.any_failed(bad.is_some())? {
            return Err(self.failure(match bad {
                Some(i) => format!(
                    "non-positive diagonal entry {:e} in row {i}",
                    self.inverse_diagonal[i]
                ),
                None => "non-positive diagonal entry on another rank".into(),
            }));
        }
        for d in &mut self.inverse_diagonal {
            *d = 1.0 / *d;
        }
        Ok(())
    }

    /// `q = A d` on the touched rows (the others stay 0), completed on the shared node
    /// layers. One run (a cut along the last axis) is split in row blocks over the pool;
    /// many short runs (a strided cut) go one run per task.
    fn multiply(&self, a: &CsrMatrix, d: &[f64], q: &mut [f64]) -> Result<()> {
        match self.touched.as_slice() {
            [run] => a.par_mul_vec_rows(d, &mut q[run.clone()], run.start),
            runs => {
                let mut pieces = Vec::with_capacity(runs.len());
                let mut rest = &mut q[..];
                let mut offset = 0;
                for run in runs {
                    let (_, tail) = rest.split_at_mut(run.start - offset);
                    let (piece, tail) = tail.split_at_mut(run.len());
                    pieces.push((run.start, piece));
                    rest = tail;
                    offset = run.end;
                }
                pieces.into_par_iter().for_each(|(first, piece)| {
                    for (offset, qi) in piece.iter_mut().enumerate() {
                        *qi = a.row_times(first + offset, d);
                    }
                });
            }
        }
        self.ranks.add_shared(q, 1)
    }

    fn precondition(&mut self) {
        let (r, z) = (&self.residual, &mut self.preconditioned);
        for run in &self.touched {
            if self.jacobi {
                for i in run.clone() {
                    z[i] = r[i] * self.inverse_diagonal[i];
                }
            } else {
                z[run.clone()].copy_from_slice(&r[run.clone()]);
            }
        }
    }

    /// The dot products `(u_k, v_k)` over all ranks' owned nodes, in one exchange.
    fn dots<const K: usize>(&self, pairs: [(&[f64], &[f64]); K]) -> Result<[f64; K]> {
        let local = pairs.map(|(u, v)| self.ranks.sum_over_owned_nodes(|i| u[i] * v[i]));
        let total = self.ranks.sum(&local)?;
        Ok(std::array::from_fn(|k| total[k]))
    }

    fn run(&mut self, a: &CsrMatrix, b: &[f64], x: &mut [f64]) -> Result<SolveStats> {
        let n = b.len();
        check_dimensions(self.name(), a, b, x)?;
        let [bb] = self.dots([(b, b)])?;
        let b_norm = bb.sqrt();
        if b_norm == 0.0 {
            x.fill(0.0);
            return Ok(SolveStats::default());
        }
        for v in [
            &mut self.residual,
            &mut self.preconditioned,
            &mut self.direction,
            &mut self.product,
        ] {
            v.resize(n, 0.0);
        }
        let mut product = std::mem::take(&mut self.product);
        self.multiply(a, x, &mut product)?;
        // Outside the touched nodes b, x and every vector stay 0.
        for ((r, bi), q) in self.residual.iter_mut().zip(b).zip(&product) {
            *r = bi - q;
        }
        self.precondition();
        let [rr, mut rz] = self.dots([
            (&self.residual, &self.residual),
            (&self.residual, &self.preconditioned),
        ])?;
        let mut relative = rr.sqrt() / b_norm;
        if relative < self.tolerance {
            self.product = product;
            return Ok(SolveStats {
                iterations: 0,
                relative_residual: relative,
            });
        }
        self.direction.copy_from_slice(&self.preconditioned);
        let outcome = (|| {
            for k in 1..=self.max_iterations {
                self.multiply(a, &self.direction, &mut product)?;
                let [dq] = self.dots([(&self.direction, &product)])?;
                if dq.is_nan() || dq <= 0.0 || rz.is_nan() || rz <= 0.0 {
                    return Err(self.failure(format!(
                        "non-positive curvature d^T A d = {dq:e} or r^T P^-1 r = {rz:e} at \
                         iteration {k} (matrix or preconditioner not positive definite)"
                    )));
                }
                let alpha = rz / dq;
                for run in &self.touched {
                    for i in run.clone() {
                        x[i] += alpha * self.direction[i];
                        self.residual[i] -= alpha * product[i];
                    }
                }
                self.precondition();
                let [rr, rz_new] = self.dots([
                    (&self.residual, &self.residual),
                    (&self.residual, &self.preconditioned),
                ])?;
                relative = rr.sqrt() / b_norm;
                if relative < self.tolerance {
                    return Ok(SolveStats {
                        iterations: k,
                        relative_residual: relative,
                    });
                }
                let beta = rz_new / rz;
                rz = rz_new;
                for run in &self.touched {
                    for i in run.clone() {
                        self.direction[i] = self.preconditioned[i] + beta * self.direction[i];
                    }
                }
            }
            Err(self.failure(format!(
                "no convergence to {:e} in {} iterations (relative residual {relative:e})",
                self.tolerance, self.max_iterations
            )))
        })();
        self.product = product;
        outcome
    }
}

impl LinearSolver for DistributedCg {
    fn name(&self) -> &'static str {
        if self.jacobi {
            "pcg"
        } else {
            "cg"
        }
    }

    fn solve(&mut self, a: &CsrMatrix, b: &[f64], x: &mut [f64]) -> Result<SolveStats> {
        self.setup(a)?;
        self.run(a, b, x)
    }

    fn resolve(&mut self, a: &CsrMatrix, b: &[f64], x: &mut [f64]) -> Result<SolveStats> {
        if self.jacobi && self.inverse_diagonal.len() != a.rows {
            self.setup(a)?;
        }
        self.run(a, b, x)
    }
}
