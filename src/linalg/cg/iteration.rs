//! The CG iteration of [`Pcg`] (module doc of `cg`), for one system or for several systems
//! of the same matrix in lockstep.
//!
//! In lockstep every iteration computes the products `A d_s` of all systems `s` not yet
//! converged in one pass over `A` ([`CsrMatrix::par_mul_vecs`]): the matrix,
//! the largest array of the solve, is read once for all of them. Each system keeps its own
//! scalars and vectors and runs the operations of its own solve in the same order, so its
//! iterates are bitwise those of [`Pcg::run_one`] on it alone; a system stops at its own
//! convergence while the others go on.

use super::{Pcg, Preconditioner};
use crate::error::{Error, Result};
use crate::linalg::vectors::{cg_step, dot, new_direction, project, project_dot, residual};
use crate::linalg::{check_dimensions, check_mask, CsrMatrix, RestrictedSystem, SolveStats};

/// The vectors of one system's iteration.
#[derive(Clone, Debug, Default)]
pub(super) struct CgVectors {
    residual: Vec<f64>,
    preconditioned: Vec<f64>,
    direction: Vec<f64>,
    product: Vec<f64>,
}

/// One system: kept DOFs (all without), right-hand side, guess and solution.
struct System<'a> {
    keep: Option<&'a [bool]>,
    b: &'a [f64],
    x: &'a mut [f64],
}

/// The scalars of one system's iteration; `done` once it has converged.
#[derive(Clone, Copy, Debug, Default)]
struct Progress {
    b_norm: f64,
    rz: f64,
    relative: f64,
    done: Option<SolveStats>,
}

/// `outputs[s] = A inputs[s]`: one product alone, or several in one pass over `a`.
fn products(a: &CsrMatrix, inputs: &[&[f64]], outputs: &mut [&mut [f64]]) {
    match (inputs, outputs) {
        ([], _) => {}
        ([x], [y]) => a.par_mul_vec(x, y),
        (inputs, outputs) => a.par_mul_vecs(inputs, outputs),
    }
}

impl<P: Preconditioner> Pcg<P> {
    /// CG from `x`, restricted to the DOFs with `keep[i]` when `restriction = (active,
    /// keep)` is given (the others are set to 0 and stay there); the preconditioner is set
    /// up for `a` (with its `active` DOFs) unless `prepared` says it already is.
    pub(super) fn run_one(
        &mut self,
        a: &CsrMatrix,
        restriction: Option<(&[bool], &[bool])>,
        b: &[f64],
        x: &mut [f64],
    ) -> Result<SolveStats> {
        let (active, keep) = (restriction.map(|r| r.0), restriction.map(|r| r.1));
        let stats = self.run_systems(a, active, &mut [System { keep, b, x }])?;
        Ok(stats[0])
    }

    /// [`Pcg::run_one`] on every system of `systems`, in lockstep.
    pub(super) fn run_restricted(
        &mut self,
        a: &CsrMatrix,
        active: &[bool],
        systems: &mut [RestrictedSystem<'_>],
    ) -> Result<Vec<SolveStats>> {
        let mut systems: Vec<System<'_>> = systems
            .iter_mut()
            .map(|s| System {
                keep: Some(s.keep),
                b: s.b,
                x: &mut *s.x,
            })
            .collect();
        self.run_systems(a, Some(active), &mut systems)
    }

    fn run_systems(
        &mut self,
        a: &CsrMatrix,
        active: Option<&[bool]>,
        systems: &mut [System<'_>],
    ) -> Result<Vec<SolveStats>> {
        let n = a.rows;
        let name = self.preconditioner.solver_name();
        check_mask(name, "active", a, active)?;
        for system in systems.iter() {
            check_dimensions(name, a, system.b, system.x)?;
            check_mask(name, "kept", a, system.keep)?;
        }
        let count = systems.len();
        self.systems.resize_with(count, CgVectors::default);
        let mut progress = vec![Progress::default(); count];
        for ((system, vectors), state) in
            systems.iter_mut().zip(&mut self.systems).zip(&mut progress)
        {
            project(system.x, system.keep);
            state.b_norm = match system.keep {
                None => dot(system.b, system.b).sqrt(),
                Some(keep) => system
                    .b
                    .iter()
                    .zip(keep)
                    .map(|(bi, &k)| if k { bi * bi } else { 0.0 })
                    .sum::<f64>()
                    .sqrt(),
            };
            if state.b_norm == 0.0 {
                system.x.fill(0.0);
                state.done = Some(SolveStats::default());
                continue;
            }
            for v in [
                &mut vectors.residual,
                &mut vectors.preconditioned,
                &mut vectors.direction,
                &mut vectors.product,
            ] {
                v.resize(n, 0.0);
            }
        }
        // r = b - A x.
        {
            let inputs: Vec<&[f64]> = systems
                .iter()
                .zip(&progress)
                .filter(|(_, state)| state.done.is_none())
                .map(|(system, _)| &*system.x)
                .collect();
            let mut outputs: Vec<&mut [f64]> = self
                .systems
                .iter_mut()
                .zip(&progress)
                .filter(|(_, state)| state.done.is_none())
                .map(|(vectors, _)| &mut vectors.product[..])
                .collect();
            products(a, &inputs, &mut outputs);
        }
        for ((system, vectors), state) in systems.iter().zip(&mut self.systems).zip(&mut progress) {
            if state.done.is_some() {
                continue;
            }
            let rr = residual(
                &mut vectors.residual,
                system.b,
                &vectors.product,
                system.keep,
            );
            state.relative = rr.sqrt() / state.b_norm;
            if state.relative < self.tolerance {
                state.done = Some(SolveStats {
                    iterations: 0,
                    relative_residual: state.relative,
                });
            }
        }
        if progress.iter().all(|state| state.done.is_some()) {
            return Ok(progress
                .iter()
                .map(|state| state.done.unwrap_or_default())
                .collect());
        }
        if !self.prepared {
            self.preconditioner.setup(a, active)?;
            self.prepared = true;
        }
        for ((system, vectors), state) in systems.iter().zip(&mut self.systems).zip(&mut progress) {
            if state.done.is_some() {
                continue;
            }
            let CgVectors {
                residual: r,
                preconditioned: z,
                direction: d,
                ..
            } = vectors;
            self.preconditioner.apply(a, r, z);
            state.rz = project_dot(z, system.keep, r);
            d.copy_from_slice(z);
        }
        for k in 1..=self.max_iterations {
            {
                let (inputs, mut outputs): (Vec<&[f64]>, Vec<&mut [f64]>) = self
                    .systems
                    .iter_mut()
                    .zip(&progress)
                    .filter(|(_, state)| state.done.is_none())
                    .map(|(v, _)| (&v.direction[..], &mut v.product[..]))
                    .unzip();
                if inputs.is_empty() {
                    break;
                }
                products(a, &inputs, &mut outputs);
            }
            for ((system, vectors), state) in
                systems.iter_mut().zip(&mut self.systems).zip(&mut progress)
            {
                if state.done.is_some() {
                    continue;
                }
                let CgVectors {
                    residual: r,
                    preconditioned: z,
                    direction: d,
                    product: q,
                } = vectors;
                let x = &mut *system.x;
                let dq = project_dot(q, system.keep, d);
                let rz = state.rz;
                if dq.is_nan() || dq <= 0.0 || rz.is_nan() || rz <= 0.0 {
                    let name = self.preconditioner.solver_name();
                    return Err(Error::Solver {
                        solver: name.into(),
                        reason: format!(
                            "non-positive curvature d^T A d = {dq:e} or r^T P^-1 r = {rz:e} at \
                             iteration {k} (matrix or preconditioner not positive definite)"
                        ),
                    });
                }
                let alpha = rz / dq;
                state.relative = cg_step(x, r, d, q, alpha).sqrt() / state.b_norm;
                if state.relative < self.tolerance {
                    state.done = Some(SolveStats {
                        iterations: k,
                        relative_residual: state.relative,
                    });
                    continue;
                }
                self.preconditioner.apply(a, r, z);
                let rz_new = project_dot(z, system.keep, r);
                let beta = rz_new / rz;
                state.rz = rz_new;
                new_direction(d, z, beta);
            }
        }
        match progress.iter().find(|state| state.done.is_none()) {
            Some(state) => Err(self.failure(format!(
                "no convergence to {:e} in {} iterations (relative residual {:e})",
                self.tolerance, self.max_iterations, state.relative
            ))),
            None => Ok(progress
                .iter()
                .map(|state| state.done.unwrap_or_default())
                .collect()),
        }
    }
}
