//! Preconditioned conjugate gradients with warm start (SPEC §5): stop when
//! `||r_k|| / ||b|| < tolerance`. For the zero initial guess this is SPEC's
//! `||r_k|| / ||r_0||`; measuring against `||b||` (not the warm start's `r_0`) lets a good
//! initial guess from the previous step finish in few or no iterations instead of chasing
//! round-off.
//!
//! ```text
//! r_0 = b - A x_0,  z_0 = P^{-1} r_0,  d_0 = z_0
//! alpha_k = (r_k, z_k) / (d_k, A d_k),  x += alpha d,  r -= alpha A d
//! z_{k+1} = P^{-1} r_{k+1},  beta_k = (r_{k+1}, z_{k+1}) / (r_k, z_k),  d = z + beta d
//! ```
//!
//! The preconditioner `P` is a type implementing [`Preconditioner`]: the identity (plain
//! CG, [`ConjugateGradient`]), Jacobi ([`JacobiCg`]), a p-multigrid V-cycle or the scaled
//! Kronecker inverse. Products with `A` run over the rayon pool in fixed row blocks and
//! the vector operations in fixed blocks ([`super::vectors`]), so the iterates are bitwise
//! the same for any thread count.

mod iteration;

use super::{CsrMatrix, LinearSolver, RestrictedSystem, SolveStats};
use crate::error::{Error, Result};

/// `z = P^{-1} r` for a symmetric positive definite `P` approximating `A`.
pub trait Preconditioner: Send {
    /// The scenario name (`solver.kind`) of CG with this preconditioner.
    fn solver_name(&self) -> &'static str;

    /// Prepare for the matrix `a` (called at the start of every solve), or, with
    /// `active` (one entry per row of `a`, else an error), for `(P A P + I - P)`,
    /// `P = diag(active)`: the matrix [`CsrMatrix::constrain`] would build, without the
    /// copy.
    fn setup(&mut self, a: &CsrMatrix, active: Option<&[bool]>) -> Result<()>;

    /// `z = P^{-1} r`.
    fn apply(&mut self, a: &CsrMatrix, r: &[f64], z: &mut [f64]);
}

/// No preconditioning: plain CG.
#[derive(Clone, Copy, Debug, Default)]
pub struct Identity;

impl Preconditioner for Identity {
    fn solver_name(&self) -> &'static str {
        "cg"
    }
    fn setup(&mut self, _a: &CsrMatrix, _active: Option<&[bool]>) -> Result<()> {
        Ok(())
    }
    fn apply(&mut self, _a: &CsrMatrix, r: &[f64], z: &mut [f64]) {
        z.copy_from_slice(r);
    }
}

/// Jacobi (diagonal) preconditioning, `P = diag(A)`.
#[derive(Clone, Debug, Default)]
pub struct Jacobi {
    inverse_diagonal: Vec<f64>,
}

impl Preconditioner for Jacobi {
    fn solver_name(&self) -> &'static str {
        "pcg"
    }
    fn setup(&mut self, a: &CsrMatrix, active: Option<&[bool]>) -> Result<()> {
        super::check_mask("pcg", "active", a, active)?;
        a.diagonal_into(&mut self.inverse_diagonal);
        for (i, d) in self.inverse_diagonal.iter_mut().enumerate() {
            if active.is_some_and(|active| !active[i]) {
                // An identity row of the constrained matrix.
                *d = 1.0;
                continue;
            }
            if d.is_nan() || *d <= 0.0 {
                return Err(Error::Solver {
                    solver: "pcg".into(),
                    reason: format!("non-positive diagonal entry {d:e} in row {i}"),
                });
            }
            *d = 1.0 / *d;
        }
        Ok(())
    }
    fn apply(&mut self, _a: &CsrMatrix, r: &[f64], z: &mut [f64]) {
        let inverse_diagonal = &self.inverse_diagonal;
        super::vectors::update_each(z, |i, _| r[i] * inverse_diagonal[i]);
    }
}

/// Conjugate gradients preconditioned by `P`.
#[derive(Clone, Debug)]
pub struct Pcg<P> {
    pub tolerance: f64,
    pub max_iterations: usize,
    pub preconditioner: P,
    /// The vectors of each system of a solve (one, or several in lockstep).
    systems: Vec<iteration::CgVectors>,
    /// Whether the preconditioner is set up for the matrix of the last solve.
    prepared: bool,
}

/// Plain CG.
pub type ConjugateGradient = Pcg<Identity>;
/// Jacobi-preconditioned CG (`solver.kind = "pcg"`).
pub type JacobiCg = Pcg<Jacobi>;

impl ConjugateGradient {
    /// Plain CG to `||r|| / ||b|| < tolerance` in at most `max_iterations` steps.
    pub fn new(tolerance: f64, max_iterations: usize) -> Self {
        Pcg::with_preconditioner(Identity, tolerance, max_iterations)
    }
}

impl<P: Preconditioner> Pcg<P> {
    /// CG preconditioned by `preconditioner`.
    pub fn with_preconditioner(preconditioner: P, tolerance: f64, max_iterations: usize) -> Self {
        Self {
            tolerance,
            max_iterations,
            preconditioner,
            systems: Vec::new(),
            prepared: false,
        }
    }

    fn failure(&self, reason: String) -> Error {
        Error::Solver {
            solver: self.preconditioner.solver_name().into(),
            reason,
        }
    }
}

pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

impl<P: Preconditioner> LinearSolver for Pcg<P> {
    fn name(&self) -> &'static str {
        self.preconditioner.solver_name()
    }

    fn solve(&mut self, a: &CsrMatrix, b: &[f64], x: &mut [f64]) -> Result<SolveStats> {
        self.prepared = false;
        self.run_one(a, None, b, x)
    }

    fn resolve(&mut self, a: &CsrMatrix, b: &[f64], x: &mut [f64]) -> Result<SolveStats> {
        self.run_one(a, None, b, x)
    }

    /// CG on the kept DOFs: the residual, the preconditioned residual and every product
    /// `A d` are projected (`P = diag(keep)`), so the iterates never leave `range(P)` and
    /// the preconditioner acts as `P M^{-1} P`, symmetric positive definite there.
    fn restricts(&self) -> bool {
        true
    }

    fn solve_restricted(
        &mut self,
        a: &CsrMatrix,
        active: &[bool],
        keep: &[bool],
        b: &[f64],
        x: &mut [f64],
    ) -> Result<SolveStats> {
        self.prepared = false;
        self.run_one(a, Some((active, keep)), b, x)
    }

    fn resolve_restricted(
        &mut self,
        a: &CsrMatrix,
        active: &[bool],
        keep: &[bool],
        b: &[f64],
        x: &mut [f64],
    ) -> Result<SolveStats> {
        self.run_one(a, Some((active, keep)), b, x)
    }

    /// The systems in lockstep: one pass over `a` per iteration computes `A d` for every
    /// system not yet converged; each system's iterates are bitwise those of its own solve.
    fn solve_restricted_many(
        &mut self,
        a: &CsrMatrix,
        active: &[bool],
        systems: &mut [RestrictedSystem<'_>],
        resolve: bool,
    ) -> Result<Vec<SolveStats>> {
        if !resolve {
            self.prepared = false;
        }
        self.run_restricted(a, active, systems)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn laplacian(n: usize) -> CsrMatrix {
        let mut t = Vec::new();
        for i in 0..n {
            t.push((i, i, 2.0));
            if i + 1 < n {
                t.push((i, i + 1, -1.0));
                t.push((i + 1, i, -1.0));
            }
        }
        CsrMatrix::from_triplets(n, n, &t)
    }

    #[test]
    fn solves_spd_system_within_n_iterations() {
        let n = 50;
        let a = laplacian(n);
        let exact: Vec<f64> = (0..n).map(|i| (i as f64 * 0.3).sin()).collect();
        let mut b = vec![0.0; n];
        a.mul_vec(&exact, &mut b);
        let mut x = vec![0.0; n];
        let stats = ConjugateGradient::new(1e-12, 1000)
            .solve(&a, &b, &mut x)
            .unwrap();
        assert!(stats.iterations <= n + 1, "{stats:?}");
        assert!(stats.relative_residual < 1e-12);
        let err = x
            .iter()
            .zip(&exact)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-9, "{err}");
        // Warm start from the solution: converged at once.
        let stats = ConjugateGradient::new(1e-8, 1000)
            .solve(&a, &b, &mut x)
            .unwrap();
        assert_eq!(stats.iterations, 0, "{stats:?}");
        // A zero right-hand side has the zero solution.
        let stats = ConjugateGradient::new(1e-8, 1000)
            .solve(&a, &vec![0.0; n], &mut x)
            .unwrap();
        assert_eq!(stats.iterations, 0);
        assert!(x.iter().all(|&v| v == 0.0));
    }

    #[test]
    fn jacobi_preconditioning_cuts_iterations_on_a_badly_scaled_system() {
        let n = 200;
        let mut a = laplacian(n);
        // Add 2 I and scale rows and columns by s_i in 1..1e3: D A D.
        let scale: Vec<f64> = (0..n)
            .map(|i| 10f64.powf(3.0 * i as f64 / n as f64))
            .collect();
        for i in 0..n {
            for k in a.row_start[i]..a.row_start[i + 1] {
                let j = a.col_index[k];
                if i == j {
                    a.values[k] += 2.0;
                }
                a.values[k] *= scale[i] * scale[j];
            }
        }
        let b = vec![1.0; n];
        let mut x = vec![0.0; n];
        let plain = ConjugateGradient::new(1e-8, 10_000)
            .solve(&a, &b, &mut x)
            .unwrap();
        let mut y = vec![0.0; n];
        let mut pcg = JacobiCg::with_preconditioner(Jacobi::default(), 1e-8, 10_000);
        let jacobi = pcg.solve(&a, &b, &mut y).unwrap();
        assert_eq!(pcg.name(), "pcg");
        assert!(
            jacobi.iterations * 3 < plain.iterations,
            "{jacobi:?} {plain:?}"
        );
        let mut r = vec![0.0; n];
        a.mul_vec(&y, &mut r);
        let res: f64 = r
            .iter()
            .zip(&b)
            .map(|(p, q)| (p - q) * (p - q))
            .sum::<f64>();
        assert!(res.sqrt() / (n as f64).sqrt() < 1e-8);
    }

    /// A symmetric positive definite matrix with non-negative entries (a mass matrix's
    /// sign pattern), 5-point stencil on an `n x n` grid.
    fn mass_like(n: usize) -> CsrMatrix {
        let mut t = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let row = j * n + i;
                t.push((row, row, 4.0 + 0.1 * (row % 7) as f64));
                if i + 1 < n {
                    t.push((row, row + 1, 0.5 + 0.01 * (row % 3) as f64));
                    t.push((row + 1, row, 0.5 + 0.01 * (row % 3) as f64));
                }
                if j + 1 < n {
                    t.push((row, row + n, 0.3));
                    t.push((row + n, row, 0.3));
                }
            }
        }
        CsrMatrix::from_triplets(n * n, n * n, &t)
    }

    #[test]
    fn a_restricted_solve_is_the_solve_of_the_constrained_matrix_bit_for_bit() {
        let n = 9;
        let a = mass_like(n);
        // Hold the first column of the grid and a few scattered DOFs.
        let keep: Vec<bool> = (0..n * n).map(|i| i % n != 0 && i % 11 != 5).collect();
        let mut constrained = a.clone();
        constrained.constrain(&keep);
        let b: Vec<f64> = (0..n * n)
            .map(|i| {
                if keep[i] {
                    (i as f64 * 0.37).cos()
                } else {
                    0.0
                }
            })
            .collect();
        let guess: Vec<f64> = (0..n * n).map(|i| 0.1 * (i as f64).sin()).collect();
        let mut expected: Vec<f64> = guess
            .iter()
            .zip(&keep)
            .map(|(&g, &k)| if k { g } else { 0.0 })
            .collect();
        let mut restricted = guess.clone();
        let mut separate = JacobiCg::with_preconditioner(Jacobi::default(), 1e-12, 1000);
        let mut shared = JacobiCg::with_preconditioner(Jacobi::default(), 1e-12, 1000);
        assert!(shared.restricts());
        let want = separate.solve(&constrained, &b, &mut expected).unwrap();
        // The shared solver is set up for the unconstrained matrix first (every DOF active).
        let all = vec![true; n * n];
        shared
            .solve_restricted(&a, &all, &all, &b, &mut vec![0.0; n * n])
            .unwrap();
        let got = shared
            .resolve_restricted(&a, &all, &keep, &b, &mut restricted)
            .unwrap();
        assert_eq!(got, want);
        assert_eq!(restricted, expected);
        assert!(restricted.iter().zip(&keep).all(|(&x, &k)| k || x == 0.0));
        // A restriction of the wrong length is an error, not a panic.
        let err = shared.solve_restricted(&a, &all, &keep[1..], &b, &mut restricted);
        assert!(matches!(err, Err(Error::Solver { .. })));
        let err = shared.solve_restricted(&a, &all[1..], &keep, &b, &mut restricted);
        assert!(matches!(err, Err(Error::Solver { .. })));
        // So is a preconditioner set up with an active mask of the wrong length.
        let err = Jacobi::default().setup(&a, Some(&all[1..]));
        assert!(matches!(err, Err(Error::Solver { .. })));
    }

    #[test]
    fn systems_in_lockstep_are_their_own_solves_bit_for_bit() {
        let n = 10;
        let a = mass_like(n);
        let active: Vec<bool> = (0..n * n).map(|i| i % 17 != 3).collect();
        // Different kept sets (rollers), a zero right-hand side, and a guess that already
        // solves its system, so the systems converge after different iteration counts.
        let keeps: Vec<Vec<bool>> = (0..4)
            .map(|s| (0..n * n).map(|i| active[i] && i % n != s).collect())
            .collect();
        let rhs: Vec<Vec<f64>> = (0..4)
            .map(|s| {
                (0..n * n)
                    .map(|i| match s {
                        2 => 0.0,
                        _ if keeps[s][i] => (i as f64 * (0.3 + 0.2 * s as f64)).cos(),
                        _ => 0.0,
                    })
                    .collect()
            })
            .collect();
        let mut converged = vec![0.0; n * n];
        JacobiCg::with_preconditioner(Jacobi::default(), 1e-14, 1000)
            .solve_restricted(&a, &active, &keeps[3], &rhs[3], &mut converged)
            .unwrap();
        let guesses: Vec<Vec<f64>> = (0..4)
            .map(|s| match s {
                3 => converged.clone(),
                _ => (0..n * n)
                    .map(|i| 0.01 * (i as f64 + s as f64).sin())
                    .collect(),
            })
            .collect();
        for resolve in [false, true] {
            let make = || JacobiCg::with_preconditioner(Jacobi::default(), 1e-10, 1000);
            let (mut one_by_one, mut lockstep) = (make(), make());
            if resolve {
                // Set up beforehand, as by an earlier solve of the step.
                let mut scratch = guesses[0].clone();
                one_by_one
                    .solve_restricted(&a, &active, &keeps[0], &rhs[0], &mut scratch)
                    .unwrap();
                let mut scratch = guesses[0].clone();
                lockstep
                    .solve_restricted(&a, &active, &keeps[0], &rhs[0], &mut scratch)
                    .unwrap();
            }
            let mut expected = guesses.clone();
            let mut want = Vec::new();
            for (s, x) in expected.iter_mut().enumerate() {
                want.push(
                    if s == 0 && !resolve {
                        one_by_one.solve_restricted(&a, &active, &keeps[s], &rhs[s], x)
                    } else {
                        one_by_one.resolve_restricted(&a, &active, &keeps[s], &rhs[s], x)
                    }
                    .unwrap(),
                );
            }
            let mut got_x = guesses.clone();
            let mut systems: Vec<RestrictedSystem<'_>> = got_x
                .iter_mut()
                .enumerate()
                .map(|(s, x)| RestrictedSystem {
                    keep: &keeps[s],
                    b: &rhs[s],
                    x,
                })
                .collect();
            let got = lockstep
                .solve_restricted_many(&a, &active, &mut systems, resolve)
                .unwrap();
            assert_eq!(got, want);
            assert_eq!(got_x, expected);
            let iterations: Vec<usize> = got.iter().map(|s| s.iterations).collect();
            assert_eq!(iterations[2..], [0, 0]);
            assert!(iterations[0] > 3 && iterations[1] > 3, "{iterations:?}");
        }
    }

    #[test]
    fn indefinite_matrix_is_reported_not_panicked() {
        let a = CsrMatrix::from_triplets(2, 2, &[(0, 0, 1.0), (1, 1, -1.0)]);
        let mut x = vec![0.0; 2];
        let err = ConjugateGradient::new(1e-10, 10).solve(&a, &[0.0, 1.0], &mut x);
        assert!(matches!(err, Err(Error::Solver { .. })));
    }
}
