//! Consistent-mass solves of the dimension-generic core (`docs/tls.md`):
//!
//! ```text
//! M^C a_c = f_c       (method.acceleration_mass = "consistent"; default: method.mass)
//! M^C v_c = p_c       (method.mass = "consistent")
//! ```
//!
//! for every component `c`. A component's eliminated DOFs are the nodes without mass
//! (`m_I <= 1e-12 max m`) and the nodes whose component `c` a face condition holds (a
//! roller wall holds only its normal component, so each component has its own set): their
//! rows and columns are replaced by the identity and their values set to 0. Components
//! whose eliminated sets are equal (no roller walls, or rollers on no face of their axes)
//! share one constrained copy of the assembled `M^C` and one solver set-up (factorisation,
//! preconditioner); a roller wall gives its component a system of its own. The velocity
//! solve of a step reuses the set-up of the acceleration solve ([`LinearSolver::resolve`]),
//! and every solve starts from the component's solution of the previous step.

use super::boundary::NodeConstraints;
use crate::config::MassKind;
use crate::error::{Error, Result};
use crate::linalg::MAX_ITERATIONS;
use crate::linalg::{CsrMatrix, LinearSolver};
use crate::mapping::tensor_direct::TensorGridFields;
use crate::physics::distributed::{DistributedCg, RankContext};
use crate::physics::mass::MIN_RELATIVE_MASS;
use std::sync::Arc;

/// One component's system.
struct ComponentSystem {
    /// In a mutex only so that the stepper is `Sync`; reached through `get_mut`.
    solver: std::sync::Mutex<Box<dyn LinearSolver>>,
    keep: Vec<bool>,
    /// The earlier component whose matrix and solver this one uses (equal `keep`) this
    /// step; `None` when it has its own.
    shared_with: Option<usize>,
    matrix: Option<CsrMatrix>,
    acceleration: Vec<f64>,
    velocity: Vec<f64>,
    solved_this_step: bool,
}

/// The consistent-mass solves of a 2D / 3D stepper.
pub struct TensorMassSolve<const D: usize> {
    pub acceleration: MassKind,
    pub velocity: MassKind,
    components: Vec<ComponentSystem>,
    held: Vec<[bool; D]>,
    rhs: Vec<f64>,
    name: &'static str,
    /// `solver.tolerance` (for the solvers of a distributed run).
    tolerance: f64,
    pub solves: usize,
    pub total_iterations: usize,
    pub max_iterations: usize,
}

impl<const D: usize> TensorMassSolve<D> {
    /// Solves with one solver per component (from `make_solver`, to `solver.tolerance` =
    /// `tolerance` where iterative) on `dofs` nodes with the face conditions `constraints`.
    pub fn new(
        acceleration: MassKind,
        velocity: MassKind,
        dofs: usize,
        constraints: &NodeConstraints<D>,
        tolerance: f64,
        mut make_solver: impl FnMut() -> Result<Box<dyn LinearSolver>>,
    ) -> Result<Self> {
        let mut held = vec![[false; D]; dofs];
        for (node, h) in &constraints.nodes {
            held[*node] = *h;
        }
        let components = (0..D)
            .map(|_| {
                Ok(ComponentSystem {
                    solver: std::sync::Mutex::new(make_solver()?),
                    keep: vec![false; dofs],
                    shared_with: None,
                    matrix: None,
                    acceleration: vec![0.0; dofs],
                    velocity: vec![0.0; dofs],
                    solved_this_step: false,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        let name = make_solver()?.name();
        Ok(Self {
            acceleration,
            velocity,
            components,
            held,
            rhs: vec![0.0; dofs],
            name,
            tolerance,
            solves: 0,
            total_iterations: 0,
            max_iterations: 0,
        })
    }

    /// `solver.kind` of the systems.
    pub fn name(&self) -> &'static str {
        self.name
    }

    /// Component `c`'s constrained matrix of the last step and its kept DOFs (benchmarks
    /// and diagnostics); `None` before the first step or for `c >= D`.
    pub fn constrained_system(&self, c: usize) -> Option<(&CsrMatrix, &[bool])> {
        let system = self.components.get(c)?;
        let owner = &self.components[system.shared_with.unwrap_or(c)];
        Some((owner.matrix.as_ref()?, &owner.keep))
    }

    /// The number of distinct constrained systems (matrix copies and solver set-ups) of
    /// the last step: 1 without roller walls, up to `D` with them.
    pub fn distinct_systems(&self) -> usize {
        self.components
            .iter()
            .filter(|s| s.shared_with.is_none())
            .count()
    }

    /// Solve over the ranks of a distributed run: `"cg"` and `"pcg"` become
    /// [`DistributedCg`]; the other kinds are refused (`docs/distributed.md`).
    pub fn distribute(&mut self, ranks: &Arc<RankContext>) -> Result<()> {
        let jacobi = match self.name {
            "cg" => false,
            "pcg" => true,
            kind => {
                return Err(Error::invalid(
                    "solver.kind",
                    format!("\"{kind}\""),
                    "a distributed run solves the consistent mass with \"cg\" or \"pcg\" \
                     (the default there): the other solvers factor or invert along the cut \
                     axis, across every slab",
                ))
            }
        };
        for system in &mut self.components {
            let solver = DistributedCg::new(ranks.clone(), jacobi, self.tolerance, MAX_ITERATIONS);
            system.solver = std::sync::Mutex::new(Box::new(solver));
        }
        Ok(())
    }

    /// The constrained systems of this step's `matrix` and masses; `largest` is the
    /// largest nodal mass (over all ranks in a distributed run).
    pub fn prepare(&mut self, mass: &[f64], largest: f64, matrix: &CsrMatrix) {
        let threshold = MIN_RELATIVE_MASS * largest;
        for c in 0..D {
            let (earlier, rest) = self.components.split_at_mut(c);
            let system = &mut rest[0];
            for ((keep, &m), held) in system.keep.iter_mut().zip(mass).zip(&self.held) {
                *keep = m > threshold && !held[c];
            }
            system.solved_this_step = false;
            system.shared_with = earlier
                .iter()
                .position(|e| e.shared_with.is_none() && e.keep == system.keep);
            if system.shared_with.is_none() {
                let constrained = system.matrix.get_or_insert_with(|| matrix.clone());
                constrained.values.copy_from_slice(&matrix.values);
                constrained.constrain(&system.keep);
            }
        }
    }

    /// `M a_c = f_c` for every component into `fields.acceleration` (consistent
    /// acceleration only; the caller divides by the lumped mass otherwise).
    pub fn accelerations(&mut self, fields: &mut TensorGridFields<D>) -> Result<()> {
        for c in 0..D {
            self.solve(c, true, |i| fields.force[i][c])?;
            let system = &self.components[c];
            for (a, &x) in fields.acceleration.iter_mut().zip(&system.acceleration) {
                a[c] = x;
            }
        }
        Ok(())
    }

    /// `M v_c = p_c` for every component into `fields.velocity`.
    pub fn velocities(&mut self, fields: &mut TensorGridFields<D>) -> Result<()> {
        for c in 0..D {
            self.solve(c, false, |i| fields.momentum[i][c])?;
            let system = &self.components[c];
            for (v, &x) in fields.velocity.iter_mut().zip(&system.velocity) {
                v[c] = x;
            }
        }
        Ok(())
    }

    /// Solve component `c`'s system with right-hand side `b(i)` (0 on eliminated DOFs),
    /// warm-started from its previous solution, with the matrix and solver it shares.
    fn solve(&mut self, c: usize, acceleration: bool, b: impl Fn(usize) -> f64) -> Result<()> {
        let owner = self.components[c].shared_with.unwrap_or(c);
        let mut x = std::mem::take(if acceleration {
            &mut self.components[c].acceleration
        } else {
            &mut self.components[c].velocity
        });
        let system = &mut self.components[owner];
        for (i, r) in self.rhs.iter_mut().enumerate() {
            *r = if system.keep[i] { b(i) } else { 0.0 };
        }
        for (xi, &keep) in x.iter_mut().zip(&system.keep) {
            if !keep || !xi.is_finite() {
                *xi = 0.0;
            }
        }
        let solver = system
            .solver
            .get_mut()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let stats = match system.matrix.as_ref() {
            None => Err(Error::Solver {
                solver: solver.name().into(),
                reason: "no consistent mass matrix was assembled".into(),
            }),
            Some(matrix) if system.solved_this_step => solver.resolve(matrix, &self.rhs, &mut x),
            Some(matrix) => solver.solve(matrix, &self.rhs, &mut x),
        };
        system.solved_this_step = true;
        let component = &mut self.components[c];
        if acceleration {
            component.acceleration = x;
        } else {
            component.velocity = x;
        }
        let stats = stats?;
        self.solves += 1;
        self.total_iterations += stats.iterations;
        self.max_iterations = self.max_iterations.max(stats.iterations);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linalg::direct::DirectCholesky;
    use crate::linalg::SolveStats;
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Arc;

    /// A direct solver that counts its set-ups (`solve`) and re-solves (`resolve`).
    struct Counting {
        inner: DirectCholesky,
        setups: Arc<AtomicUsize>,
        resolves: Arc<AtomicUsize>,
    }

    impl LinearSolver for Counting {
        fn name(&self) -> &'static str {
            "direct"
        }
        fn solve(&mut self, a: &CsrMatrix, b: &[f64], x: &mut [f64]) -> Result<SolveStats> {
            self.setups.fetch_add(1, Ordering::Relaxed);
            self.inner.solve(a, b, x)
        }
        fn resolve(&mut self, a: &CsrMatrix, b: &[f64], x: &mut [f64]) -> Result<SolveStats> {
            self.resolves.fetch_add(1, Ordering::Relaxed);
            self.inner.resolve(a, b, x)
        }
    }

    /// One step of a 2D system on 5 nodes (tridiagonal `M`), with `held` constraints:
    /// (set-ups, re-solves, distinct systems, velocities).
    fn one_step(held: &[(usize, [bool; 2])]) -> (usize, usize, usize, Vec<[f64; 2]>) {
        let n = 5;
        let mut triplets = Vec::new();
        for i in 0..n {
            triplets.push((i, i, 4.0));
            if i + 1 < n {
                triplets.push((i, i + 1, 1.0));
                triplets.push((i + 1, i, 1.0));
            }
        }
        let matrix = CsrMatrix::from_triplets(n, n, &triplets);
        let setups = Arc::new(AtomicUsize::new(0));
        let resolves = Arc::new(AtomicUsize::new(0));
        let constraints = NodeConstraints::<2> {
            nodes: held.to_vec(),
        };
        let mut solve = TensorMassSolve::<2>::new(
            MassKind::Consistent,
            MassKind::Consistent,
            n,
            &constraints,
            1e-12,
            || {
                Ok(Box::new(Counting {
                    inner: DirectCholesky::new(),
                    setups: setups.clone(),
                    resolves: resolves.clone(),
                }))
            },
        )
        .unwrap();
        let mut fields = TensorGridFields::<2>::new(n);
        for i in 0..n {
            fields.force[i] = [1.0 + i as f64, 2.0 - i as f64];
            fields.momentum[i] = [0.5 * i as f64, 1.0];
        }
        solve.prepare(&[1.0; 5], 1.0, &matrix);
        solve.accelerations(&mut fields).unwrap();
        solve.velocities(&mut fields).unwrap();
        (
            setups.load(Ordering::Relaxed),
            resolves.load(Ordering::Relaxed),
            solve.distinct_systems(),
            fields.velocity,
        )
    }

    #[test]
    fn components_with_the_same_constraints_share_one_set_up() {
        let (setups, resolves, distinct, free) = one_step(&[]);
        assert_eq!((setups, resolves, distinct), (1, 3, 1));
        // Both components held at node 0 (a fixed wall): still one system.
        let (setups, resolves, distinct, fixed) = one_step(&[(0, [true, true])]);
        assert_eq!((setups, resolves, distinct), (1, 3, 1));
        assert_eq!(fixed[0], [0.0, 0.0]);
        assert_ne!(fixed[1], free[1]);
        // A roller holds only component 0 at node 0: two systems, two set-ups.
        let (setups, resolves, distinct, roller) = one_step(&[(0, [true, false])]);
        assert_eq!((setups, resolves, distinct), (2, 2, 2));
        assert_eq!(roller[0][0], 0.0);
        // Component 1 is unconstrained there: it equals the free solve; component 0 the
        // fixed one.
        for i in 0..5 {
            assert!((roller[i][1] - free[i][1]).abs() < 1e-14);
            assert!((roller[i][0] - fixed[i][0]).abs() < 1e-14);
        }
    }
}
