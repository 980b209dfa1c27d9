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
//! values are 0 and their rows and columns act as those of the identity.
//!
//! **One set-up per step.** With a solver that solves restricted systems
//! ([`LinearSolver::restricts`]: `cg`, `pcg`, `kron`, `pmg_cg`) the assembled `M^C` is used
//! as it is: the solver is set up once for it with the nodes with mass as its active DOFs
//! (the massless rows act as identity rows), and every component is solved on its own
//! DOFs inside the iteration (`(P_c M P_c + I - P_c) x = P_c b`,
//! [`LinearSolver::solve_restricted`]): neither the massless nodes nor roller walls cost a
//! matrix copy, and roller walls cost no set-up per component (`pmg_cg` alone copies the
//! matrix once per step, for its smoother). For `cg`, `pcg` and `kron` the
//! iterates are bitwise those of the separately constrained systems (the projections zero
//! exactly the entries the identity rows zero). The other solvers (`direct`, `pmg`, and
//! the distributed CG) need the constrained matrix itself: components whose eliminated
//! sets are equal share one constrained copy and one set-up, and a roller wall gives its
//! component a system of its own. Either way the velocity solve of a step reuses the
//! set-up of the acceleration solve ([`LinearSolver::resolve`]), and every solve starts
//! from the component's solution of the previous step.

use super::boundary::NodeConstraints;
use crate::config::MassKind;
use crate::error::{Error, Result};
use crate::linalg::MAX_ITERATIONS;
use crate::linalg::{CsrMatrix, LinearSolver, RestrictedSystem, SolveStats};
use crate::mapping::tensor_direct::TensorGridFields;
use crate::physics::distributed::{DistributedCg, RankContext};
use crate::physics::mass::MIN_RELATIVE_MASS;
use std::borrow::Cow;
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
    /// The right-hand side of the component's solve (0 on its eliminated DOFs).
    rhs: Vec<f64>,
    acceleration: Vec<f64>,
    velocity: Vec<f64>,
    solved_this_step: bool,
}

/// The consistent-mass solves of a 2D / 3D stepper.
pub struct TensorMassSolve<const D: usize> {
    pub acceleration: MassKind,
    pub velocity: MassKind,
    components: Vec<ComponentSystem>,
    /// Whether the components are solved as restrictions of the assembled matrix with the
    /// nodes with mass (`mass_kept`) active, with component 0's solver.
    restricting: bool,
    /// The nodes with mass (the active DOFs of the shared set-up when `restricting`).
    mass_kept: Vec<bool>,
    held: Vec<[bool; D]>,
    /// Whether [`TensorMassSolve::prepare`] has run.
    prepared: bool,
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
        let solvers = (0..D).map(|_| make_solver()).collect::<Result<Vec<_>>>()?;
        // Every component's solver is of the same kind (`D >= 1`).
        let (name, restricting) = (solvers[0].name(), solvers[0].restricts());
        let components = solvers
            .into_iter()
            .map(|solver| ComponentSystem {
                solver: std::sync::Mutex::new(solver),
                keep: vec![false; dofs],
                shared_with: None,
                matrix: None,
                rhs: vec![0.0; dofs],
                acceleration: vec![0.0; dofs],
                velocity: vec![0.0; dofs],
                solved_this_step: false,
            })
            .collect();
        Ok(Self {
            acceleration,
            velocity,
            components,
            restricting,
            mass_kept: vec![false; dofs],
            held,
            prepared: false,
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

    /// Component `c`'s constrained matrix of the last step and its kept DOFs, where
    /// `assembled` is the step's assembled `M^C` (benchmarks and diagnostics: a copy where
    /// the step solved it as a restriction of `assembled`); `None` before the first step or
    /// for `c >= D`.
    pub fn constrained_system<'a>(
        &'a self,
        c: usize,
        assembled: &'a CsrMatrix,
    ) -> Option<(Cow<'a, CsrMatrix>, &'a [bool])> {
        let system = self.components.get(c)?;
        if !self.prepared {
            return None;
        }
        if self.restricting {
            let mut constrained = assembled.clone();
            constrained.constrain(&system.keep);
            return Some((Cow::Owned(constrained), &system.keep));
        }
        let owner = &self.components[system.shared_with.unwrap_or(c)];
        let matrix = owner.matrix.as_ref()?;
        if owner.keep == system.keep {
            return Some((Cow::Borrowed(matrix), &system.keep));
        }
        let mut constrained = matrix.clone();
        constrained.constrain(&system.keep);
        Some((Cow::Owned(constrained), &system.keep))
    }

    /// The number of distinct matrix copies and solver set-ups of the last step: 1 with a
    /// restricting solver or without roller walls, up to `D` otherwise.
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
        self.restricting = false;
        Ok(())
    }

    /// The constrained systems of this step's `matrix` and masses; `largest` is the
    /// largest nodal mass (over all ranks in a distributed run). A restricting solver
    /// needs no copy: the solves take `matrix` itself.
    pub fn prepare(&mut self, mass: &[f64], largest: f64, matrix: &CsrMatrix) {
        self.prepared = true;
        let threshold = MIN_RELATIVE_MASS * largest;
        for (kept, &m) in self.mass_kept.iter_mut().zip(mass) {
            *kept = m > threshold;
        }
        for c in 0..D {
            let (earlier, rest) = self.components.split_at_mut(c);
            let system = &mut rest[0];
            for ((keep, &kept), held) in system.keep.iter_mut().zip(&self.mass_kept).zip(&self.held)
            {
                *keep = kept && !held[c];
            }
            system.solved_this_step = false;
            system.shared_with = if self.restricting {
                (c > 0).then_some(0)
            } else {
                earlier
                    .iter()
                    .position(|e| e.shared_with.is_none() && e.keep == system.keep)
            };
            if system.shared_with.is_none() && !self.restricting {
                let constrained = system.matrix.get_or_insert_with(|| matrix.clone());
                constrained.values.copy_from_slice(&matrix.values);
                constrained.constrain(&system.keep);
            }
        }
    }

    /// `M a_c = f_c` for every component into `fields.acceleration` (consistent
    /// acceleration only; the caller divides by the lumped mass otherwise), with `matrix`
    /// the `M^C` given to [`TensorMassSolve::prepare`].
    pub fn accelerations(
        &mut self,
        fields: &mut TensorGridFields<D>,
        matrix: &CsrMatrix,
    ) -> Result<()> {
        self.solve_components(true, matrix, |i, c| fields.force[i][c])?;
        for (c, system) in self.components.iter().enumerate() {
            for (a, &x) in fields.acceleration.iter_mut().zip(&system.acceleration) {
                a[c] = x;
            }
        }
        Ok(())
    }

    /// `M v_c = p_c` for every component into `fields.velocity` (`matrix` as in
    /// [`TensorMassSolve::accelerations`]).
    pub fn velocities(
        &mut self,
        fields: &mut TensorGridFields<D>,
        matrix: &CsrMatrix,
    ) -> Result<()> {
        self.solve_components(false, matrix, |i, c| fields.momentum[i][c])?;
        for (c, system) in self.components.iter().enumerate() {
            for (v, &x) in fields.velocity.iter_mut().zip(&system.velocity) {
                v[c] = x;
            }
        }
        Ok(())
    }

    /// Solve every component `c` with right-hand side `b(i, c)` (0 on its eliminated
    /// DOFs), warm-started from its previous solution: with a restricting solver all
    /// components at once, as restrictions of `assembled`
    /// ([`LinearSolver::solve_restricted_many`], CG in lockstep); otherwise one after the
    /// other, each with the constrained copy and solver it shares.
    fn solve_components(
        &mut self,
        acceleration: bool,
        assembled: &CsrMatrix,
        b: impl Fn(usize, usize) -> f64,
    ) -> Result<()> {
        for (c, component) in self.components.iter_mut().enumerate() {
            let ComponentSystem { keep, rhs, .. } = component;
            for (i, (r, &k)) in rhs.iter_mut().zip(keep.iter()).enumerate() {
                *r = if k { b(i, c) } else { 0.0 };
            }
            let x = if acceleration {
                &mut component.acceleration
            } else {
                &mut component.velocity
            };
            for (xi, &k) in x.iter_mut().zip(&component.keep) {
                if !k || !xi.is_finite() {
                    *xi = 0.0;
                }
            }
        }
        if !self.restricting {
            return (0..D).try_for_each(|c| self.solve(c, acceleration));
        }
        let mut shared_solver = None;
        let mut set_up = false;
        let mut systems = Vec::with_capacity(D);
        for component in &mut self.components {
            let ComponentSystem {
                solver,
                keep,
                rhs,
                acceleration: a,
                velocity: v,
                solved_this_step,
                ..
            } = component;
            if shared_solver.is_none() {
                set_up = std::mem::replace(solved_this_step, true);
                shared_solver = Some(solver);
            }
            systems.push(RestrictedSystem {
                keep,
                b: rhs,
                x: if acceleration { a } else { v },
            });
        }
        let Some(solver) = shared_solver else {
            return Ok(());
        };
        let solver = solver
            .get_mut()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let stats =
            solver.solve_restricted_many(assembled, &self.mass_kept, &mut systems, set_up)?;
        for s in stats {
            self.count(s);
        }
        Ok(())
    }

    /// Solve component `c`'s constrained system (its right-hand side and guess in place)
    /// with the matrix and solver it shares.
    fn solve(&mut self, c: usize, acceleration: bool) -> Result<()> {
        let owner = self.components[c].shared_with.unwrap_or(c);
        let component = &mut self.components[c];
        let rhs = std::mem::take(&mut component.rhs);
        let mut x = std::mem::take(if acceleration {
            &mut component.acceleration
        } else {
            &mut component.velocity
        });
        let system = &mut self.components[owner];
        let solver = system
            .solver
            .get_mut()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let set_up = system.solved_this_step;
        let stats = match system.matrix.as_ref() {
            None => Err(Error::Solver {
                solver: solver.name().into(),
                reason: "no consistent mass matrix was prepared".into(),
            }),
            Some(matrix) if set_up => solver.resolve(matrix, &rhs, &mut x),
            Some(matrix) => solver.solve(matrix, &rhs, &mut x),
        };
        system.solved_this_step = true;
        let component = &mut self.components[c];
        component.rhs = rhs;
        if acceleration {
            component.acceleration = x;
        } else {
            component.velocity = x;
        }
        self.count(stats?);
        Ok(())
    }

    /// Add one solve's statistics to the totals.
    fn count(&mut self, stats: SolveStats) {
        self.solves += 1;
        self.total_iterations += stats.iterations;
        self.max_iterations = self.max_iterations.max(stats.iterations);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linalg::direct::DirectCholesky;
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Arc;

    /// A solver that counts its set-ups (`solve`, `solve_restricted`) and re-solves, and
    /// restricts only where `restricts` says so.
    struct Counting<S> {
        inner: S,
        restricts: bool,
        setups: Arc<AtomicUsize>,
        resolves: Arc<AtomicUsize>,
    }

    impl<S: LinearSolver> LinearSolver for Counting<S> {
        fn name(&self) -> &'static str {
            self.inner.name()
        }
        fn solve(&mut self, a: &CsrMatrix, b: &[f64], x: &mut [f64]) -> Result<SolveStats> {
            self.setups.fetch_add(1, Ordering::Relaxed);
            self.inner.solve(a, b, x)
        }
        fn resolve(&mut self, a: &CsrMatrix, b: &[f64], x: &mut [f64]) -> Result<SolveStats> {
            self.resolves.fetch_add(1, Ordering::Relaxed);
            self.inner.resolve(a, b, x)
        }
        fn restricts(&self) -> bool {
            self.restricts && self.inner.restricts()
        }
        fn solve_restricted(
            &mut self,
            a: &CsrMatrix,
            active: &[bool],
            keep: &[bool],
            b: &[f64],
            x: &mut [f64],
        ) -> Result<SolveStats> {
            self.setups.fetch_add(1, Ordering::Relaxed);
            self.inner.solve_restricted(a, active, keep, b, x)
        }
        fn resolve_restricted(
            &mut self,
            a: &CsrMatrix,
            active: &[bool],
            keep: &[bool],
            b: &[f64],
            x: &mut [f64],
        ) -> Result<SolveStats> {
            self.resolves.fetch_add(1, Ordering::Relaxed);
            self.inner.resolve_restricted(a, active, keep, b, x)
        }
    }

    /// One step of a 2D system on 5 nodes (tridiagonal `M`), with `held` constraints:
    /// (set-ups, re-solves, distinct systems, velocities).
    fn one_step(held: &[(usize, [bool; 2])]) -> (usize, usize, usize, Vec<[f64; 2]>) {
        one_step_with(held, |setups, resolves| {
            Box::new(Counting {
                inner: DirectCholesky::new(),
                restricts: false,
                setups,
                resolves,
            })
        })
    }

    /// [`one_step`] with the solvers of `make(setups, resolves)`.
    fn one_step_with(
        held: &[(usize, [bool; 2])],
        make: impl Fn(Arc<AtomicUsize>, Arc<AtomicUsize>) -> Box<dyn LinearSolver>,
    ) -> (usize, usize, usize, Vec<[f64; 2]>) {
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
            || Ok(make(setups.clone(), resolves.clone())),
        )
        .unwrap();
        let mut fields = TensorGridFields::<2>::new(n);
        for i in 0..n {
            fields.force[i] = [1.0 + i as f64, 2.0 - i as f64];
            fields.momentum[i] = [0.5 * i as f64, 1.0];
        }
        solve.prepare(&[1.0; 5], 1.0, &matrix);
        solve.accelerations(&mut fields, &matrix).unwrap();
        solve.velocities(&mut fields, &matrix).unwrap();
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

    #[test]
    fn a_restricting_solver_serves_every_component_with_one_set_up() {
        let cg = |restricts: bool| {
            move |setups, resolves| -> Box<dyn LinearSolver> {
                Box::new(Counting {
                    inner: crate::linalg::JacobiCg::with_preconditioner(
                        crate::linalg::Jacobi::default(),
                        1e-13,
                        100,
                    ),
                    restricts,
                    setups,
                    resolves,
                })
            }
        };
        // A roller at node 0 (component 0) and one at node 4 (component 1).
        let rollers = [(0, [true, false]), (4, [false, true])];
        let (setups, resolves, distinct, shared) = one_step_with(&rollers, cg(true));
        assert_eq!((setups, resolves, distinct), (1, 3, 1));
        let (setups, resolves, distinct, separate) = one_step_with(&rollers, cg(false));
        assert_eq!((setups, resolves, distinct), (2, 2, 2));
        // The restricted solves are the solves of the constrained copies, bit for bit.
        assert_eq!(shared, separate);
        assert_eq!((shared[0][0], shared[4][1]), (0.0, 0.0));
        let (_, _, _, direct) = one_step(&rollers);
        for (s, d) in shared.iter().zip(&direct) {
            for c in 0..2 {
                assert!((s[c] - d[c]).abs() < 1e-12, "{s:?} {d:?}");
            }
        }
    }
}
