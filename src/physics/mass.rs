//! Grid accelerations and velocities from the mass matrix (SPEC §2 steps 2 and 4, §4.1).
//!
//! ```text
//! lumped:     a_i = (f_ext_i - f_int_i) / m_i           v_i = p_i / m_i (+ dt a_i for USL)
//! consistent: M^C a = f_ext - f_int                     M^C v = p      (+ dt a for USL)
//! ```
//!
//! Each matrix is chosen separately for the acceleration (`method.acceleration_mass`) and
//! the velocity (`method.mass`). DOFs that are fixed (Dirichlet) or carry no mass
//! (`m_i <= 1e-12 max_j m_j`) are eliminated: their rows and columns of `M^C` are replaced
//! by the identity and their values set to 0, so the solve acts on the active free DOFs
//! only. The consistent solve goes through a [`LinearSolver`] (`solver.kind`), warm-started
//! from the previous step's acceleration / velocity; the second solve of a step (same
//! matrix) reuses the solver's set-up via [`LinearSolver::resolve`].

use crate::config::MassKind;
use crate::error::Result;
use crate::linalg::{CsrMatrix, LinearSolver};
use crate::mapping::GridFields;

/// DOFs whose lumped mass is below this fraction of the largest one are inactive.
pub const MIN_RELATIVE_MASS: f64 = 1e-12;

/// Solver statistics of one or more [`MassSystem`]s, for `summary.json`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SolverTotals {
    /// `"lumped"`, or the solver of the consistent systems.
    pub kind: &'static str,
    pub solves: usize,
    pub total_iterations: usize,
    pub max_iterations: usize,
}

impl SolverTotals {
    /// Totals over `systems` (the kind of the first one that solves consistent systems).
    pub fn of(systems: &[&MassSystem]) -> Self {
        let kind = systems
            .iter()
            .find(|s| s.needs_matrix())
            .map_or("lumped", |s| s.kind());
        systems.iter().fold(
            Self {
                kind,
                ..Self::default()
            },
            |t, s| Self {
                kind: t.kind,
                solves: t.solves + s.solves,
                total_iterations: t.total_iterations + s.total_iterations,
                max_iterations: t.max_iterations.max(s.max_iterations),
            },
        )
    }
}

/// The mass-matrix solves of a time stepper.
pub struct MassSystem {
    acceleration: MassKind,
    velocity: MassKind,
    solver: Box<dyn LinearSolver>,
    /// Active free DOFs.
    keep: Vec<bool>,
    /// `M^C` with the eliminated DOFs replaced by the identity.
    constrained: Option<CsrMatrix>,
    rhs: Vec<f64>,
    product: Vec<f64>,
    /// Whether the solver has already solved with this step's matrix (the second solve of
    /// a step reuses its factorisation / levels / scaling through `resolve`).
    solved_this_step: bool,
    /// Linear solves done, and their iterations.
    pub solves: usize,
    pub total_iterations: usize,
    pub max_iterations: usize,
}

impl MassSystem {
    /// Mass matrices for the acceleration and the velocity, and the solver of the
    /// consistent systems.
    pub fn new(acceleration: MassKind, velocity: MassKind, solver: Box<dyn LinearSolver>) -> Self {
        Self {
            acceleration,
            velocity,
            solver,
            keep: Vec::new(),
            constrained: None,
            rhs: Vec::new(),
            product: Vec::new(),
            solved_this_step: false,
            solves: 0,
            total_iterations: 0,
            max_iterations: 0,
        }
    }

    /// Whether a consistent mass matrix must be assembled.
    pub fn needs_matrix(&self) -> bool {
        self.acceleration == MassKind::Consistent || self.velocity == MassKind::Consistent
    }

    /// Name for `summary.json`: `"lumped"`, or the solver of the consistent systems.
    pub fn kind(&self) -> &'static str {
        if self.needs_matrix() {
            self.solver.name()
        } else {
            "lumped"
        }
    }

    /// Mark the active free DOFs and build the constrained matrix for this step's mapped
    /// `fields`; `fixed` lists the Dirichlet DOFs.
    pub fn prepare(&mut self, fields: &GridFields, fixed: &[usize]) {
        let largest = fields.mass.iter().copied().fold(0.0, f64::max);
        let threshold = MIN_RELATIVE_MASS * largest;
        self.keep.clear();
        self.keep.extend(fields.mass.iter().map(|&m| m > threshold));
        for &i in fixed {
            self.keep[i] = false;
        }
        self.solved_this_step = false;
        if let Some(matrix) = &fields.consistent_mass {
            let constrained = self.constrained.get_or_insert_with(|| matrix.clone());
            constrained.values.copy_from_slice(&matrix.values);
            constrained.constrain(&self.keep);
        }
    }

    /// Step 2: `fields.acceleration` from the forces.
    pub fn accelerations(&mut self, fields: &mut GridFields) -> Result<()> {
        let n = fields.mass.len();
        match self.acceleration {
            MassKind::Lumped => {
                for i in 0..n {
                    fields.acceleration[i] = if self.keep[i] {
                        (fields.external_force[i] - fields.internal_force[i]) / fields.mass[i]
                    } else {
                        0.0
                    };
                }
            }
            MassKind::Consistent => {
                self.rhs.clear();
                self.rhs.extend((0..n).map(|i| {
                    if self.keep[i] {
                        fields.external_force[i] - fields.internal_force[i]
                    } else {
                        0.0
                    }
                }));
                self.solve_consistent(&mut fields.acceleration)?;
            }
        }
        Ok(())
    }

    /// Step 4: `fields.velocity = M^{-1} p + dt_accel a` (0 on eliminated DOFs). Returns
    /// how far the solve leaves the momentum of the active free DOFs from the mapped one,
    /// `|sum_i ((M v)_i - p_i)|` over those DOFs (0 for the lumped matrix).
    pub fn velocities(&mut self, fields: &mut GridFields, dt_accel: f64) -> Result<f64> {
        let n = fields.mass.len();
        match self.velocity {
            MassKind::Lumped => {
                for i in 0..n {
                    fields.velocity[i] = if self.keep[i] {
                        fields.momentum[i] / fields.mass[i] + dt_accel * fields.acceleration[i]
                    } else {
                        0.0
                    };
                }
                Ok(0.0)
            }
            MassKind::Consistent => {
                self.rhs.clear();
                self.rhs.extend((0..n).map(|i| {
                    if self.keep[i] {
                        fields.momentum[i]
                    } else {
                        0.0
                    }
                }));
                self.solve_consistent(&mut fields.velocity)?;
                let mut imbalance = 0.0;
                if let Some(matrix) = &fields.consistent_mass {
                    self.product.resize(n, 0.0);
                    matrix.mul_vec(&fields.velocity, &mut self.product);
                    for i in 0..n {
                        if self.keep[i] {
                            imbalance += self.product[i] - fields.momentum[i];
                        }
                    }
                }
                for i in 0..n {
                    if self.keep[i] {
                        fields.velocity[i] += dt_accel * fields.acceleration[i];
                    }
                }
                Ok(imbalance.abs())
            }
        }
    }

    /// Solve the constrained system with `self.rhs`; `x` holds the warm start on entry.
    fn solve_consistent(&mut self, x: &mut [f64]) -> Result<()> {
        let matrix = self
            .constrained
            .as_ref()
            .ok_or_else(|| crate::error::Error::Solver {
                solver: self.solver.name().into(),
                reason: "no consistent mass matrix was assembled".into(),
            })?;
        for (xi, &keep) in x.iter_mut().zip(&self.keep) {
            if !keep || !xi.is_finite() {
                *xi = 0.0;
            }
        }
        let stats = if self.solved_this_step {
            self.solver.resolve(matrix, &self.rhs, x)?
        } else {
            self.solver.solve(matrix, &self.rhs, x)?
        };
        self.solved_this_step = true;
        self.solves += 1;
        self.total_iterations += stats.iterations;
        self.max_iterations = self.max_iterations.max(stats.iterations);
        Ok(())
    }
}
