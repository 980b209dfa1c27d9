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
//! rows and columns are replaced by the identity and their values set to 0. Each component
//! has its own constrained copy of the one assembled `M^C` and its own solver; the
//! velocity solve of a step reuses the set-up of the acceleration solve
//! ([`LinearSolver::resolve`]) and both start from the previous step's solution.

use super::boundary::NodeConstraints;
use crate::config::MassKind;
use crate::error::{Error, Result};
use crate::linalg::{CsrMatrix, LinearSolver};
use crate::mapping::tensor_direct::TensorGridFields;
use crate::physics::mass::MIN_RELATIVE_MASS;

/// One component's system.
struct ComponentSystem {
    /// In a mutex only so that the stepper is `Sync`; reached through `get_mut`.
    solver: std::sync::Mutex<Box<dyn LinearSolver>>,
    keep: Vec<bool>,
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
    pub solves: usize,
    pub total_iterations: usize,
    pub max_iterations: usize,
}

impl<const D: usize> TensorMassSolve<D> {
    /// Solves with one solver per component (from `make_solver`) on `dofs` nodes with the
    /// face conditions `constraints`.
    pub fn new(
        acceleration: MassKind,
        velocity: MassKind,
        dofs: usize,
        constraints: &NodeConstraints<D>,
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
        Some((system.matrix.as_ref()?, &system.keep))
    }

    /// The constrained systems of this step's `matrix` and masses.
    pub fn prepare(&mut self, mass: &[f64], matrix: &CsrMatrix) {
        let largest = mass.iter().copied().fold(0.0, f64::max);
        let threshold = MIN_RELATIVE_MASS * largest;
        for (c, system) in self.components.iter_mut().enumerate() {
            for ((keep, &m), held) in system.keep.iter_mut().zip(mass).zip(&self.held) {
                *keep = m > threshold && !held[c];
            }
            let constrained = system.matrix.get_or_insert_with(|| matrix.clone());
            constrained.values.copy_from_slice(&matrix.values);
            constrained.constrain(&system.keep);
            system.solved_this_step = false;
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
    /// warm-started from the previous solution.
    fn solve(&mut self, c: usize, acceleration: bool, b: impl Fn(usize) -> f64) -> Result<()> {
        let system = &mut self.components[c];
        let solver = system
            .solver
            .get_mut()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        for (i, r) in self.rhs.iter_mut().enumerate() {
            *r = if system.keep[i] { b(i) } else { 0.0 };
        }
        let matrix = system.matrix.as_ref().ok_or_else(|| Error::Solver {
            solver: solver.name().into(),
            reason: "no consistent mass matrix was assembled".into(),
        })?;
        let x = if acceleration {
            &mut system.acceleration
        } else {
            &mut system.velocity
        };
        for (xi, &keep) in x.iter_mut().zip(&system.keep) {
            if !keep || !xi.is_finite() {
                *xi = 0.0;
            }
        }
        let stats = if system.solved_this_step {
            solver.resolve(matrix, &self.rhs, x)?
        } else {
            solver.solve(matrix, &self.rhs, x)?
        };
        system.solved_this_step = true;
        self.solves += 1;
        self.total_iterations += stats.iterations;
        self.max_iterations = self.max_iterations.max(stats.iterations);
        Ok(())
    }
}
