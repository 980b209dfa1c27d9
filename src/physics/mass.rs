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
                let imbalance = match &fields.consistent_mass {
                    Some(matrix) => momentum_imbalance(
                        matrix,
                        &fields.mass,
                        &self.keep,
                        &fields.velocity,
                        &fields.momentum,
                    ),
                    None => 0.0,
                };
                for i in 0..n {
                    if self.keep[i] {
                        fields.velocity[i] += dt_accel * fields.acceleration[i];
                    }
                }
                Ok(imbalance)
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

/// `|sum_{i keep} ((M v)_i - p_i)|`, the momentum the consistent solve leaves unbalanced
/// on the active free DOFs, without the product `M v`. The rows of `M` sum to the lumped
/// mass (`sum_J M_IJ = sum_q rho w phi_I sum_J phi_J = m_I`, partition of unity at the
/// same points) and `M` is symmetric, so the sum of all rows of `M v` is `sum_J m_J v_J`;
/// the rows of the eliminated DOFs (few: the fixed ones and those without mass) are
/// subtracted explicitly:
///
/// ```text
/// sum_{i keep} (M v)_i = sum_J m_J v_J - sum_{i not keep} sum_J M_iJ v_J
/// ```
/// Exact in exact arithmetic for any `v`; in floating point it differs from the product
/// form by round-off of the same size. `O(n)` plus the eliminated rows, instead of a pass
/// over every stored entry.
pub(crate) fn momentum_imbalance(
    matrix: &CsrMatrix,
    mass: &[f64],
    keep: &[bool],
    velocity: &[f64],
    momentum: &[f64],
) -> f64 {
    let mut imbalance = 0.0;
    for i in 0..mass.len() {
        imbalance += mass[i] * velocity[i];
        if keep[i] {
            imbalance -= momentum[i];
        } else {
            let range = matrix.row_start[i]..matrix.row_start[i + 1];
            for (&j, &m) in matrix.col_index[range.clone()]
                .iter()
                .zip(&matrix.values[range])
            {
                imbalance -= m * velocity[j];
            }
        }
    }
    imbalance.abs()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{BSplineBasis, Basis, Grid, LinearBasis, Shape};
    use proptest::prelude::*;

    /// `M = sum_q w_q phi(x_q) phi(x_q)^T` and `m = sum_q w_q phi(x_q)` of `basis` at the
    /// points `(x_q, w_q)`: the way every 1D mapping builds its pair.
    fn mass_pair<B: Basis>(basis: &B, grid: &Grid, points: &[(f64, f64)]) -> (CsrMatrix, Vec<f64>) {
        let n = basis.num_dofs();
        let (mut triplets, mut lumped) = (Vec::new(), vec![0.0; n]);
        let mut shape = Shape::default();
        for &(x, w) in points {
            let cell = grid.cell_of(x).unwrap_or(grid.cells - 1);
            basis.eval(cell, x, &mut shape);
            for a in 0..shape.len {
                lumped[shape.first + a] += w * shape.phi[a];
                for b in 0..shape.len {
                    let value = w * shape.phi[a] * shape.phi[b];
                    triplets.push((shape.first + a, shape.first + b, value));
                }
            }
        }
        (CsrMatrix::from_triplets(n, n, &triplets), lumped)
    }

    /// The same imbalance with the product `M v`.
    fn product_imbalance(m: &CsrMatrix, keep: &[bool], v: &[f64], p: &[f64]) -> f64 {
        let mut product = vec![0.0; v.len()];
        m.mul_vec(v, &mut product);
        (0..v.len())
            .filter(|&i| keep[i])
            .map(|i| product[i] - p[i])
            .sum::<f64>()
            .abs()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// Without the product, the imbalance equals `|sum_{keep} (M v - p)|` for any `v`
        /// (not only a solution), any set of eliminated DOFs and every basis.
        #[test]
        fn imbalance_without_the_product_equals_the_product_form(
            cells in 2usize..9, order in 1usize..5,
            points in prop::collection::vec((0.0f64..1.0, 0.1f64..2.0), 1..60),
            values in prop::collection::vec(-1.0f64..1.0, 16),
            dropped in prop::collection::vec(any::<bool>(), 16)) {
            let grid = Grid::new(1.0, cells);
            let check = |m: &CsrMatrix, lumped: &[f64]| -> Result<(), TestCaseError> {
                let n = lumped.len();
                let keep: Vec<bool> = (0..n).map(|i| lumped[i] > 0.0 && !dropped[i % 16]).collect();
                let v: Vec<f64> = (0..n).map(|i| values[i % 16]).collect();
                let p: Vec<f64> = (0..n).map(|i| 0.5 * values[(i + 5) % 16] * lumped[i]).collect();
                let scale: f64 = (0..n).map(|i| lumped[i] * v[i].abs() + p[i].abs()).sum();
                let ours = momentum_imbalance(m, lumped, &keep, &v, &p);
                let reference = product_imbalance(m, &keep, &v, &p);
                prop_assert!((ours - reference).abs() <= 1e-13 * scale, "{} vs {}", ours, reference);
                Ok(())
            };
            let (m, lumped) = mass_pair(&LinearBasis::new(grid), &grid, &points);
            check(&m, &lumped)?;
            if let Some(basis) = BSplineBasis::new(grid, order) {
                let (m, lumped) = mass_pair(&basis, &grid, &points);
                check(&m, &lumped)?;
            }
        }
    }

    /// The check is not blind: a velocity off the solution by `delta` on one kept DOF
    /// shows an imbalance of `delta` times that DOF's lumped mass.
    #[test]
    fn imbalance_sees_an_unbalanced_velocity() {
        let grid = Grid::new(1.0, 4);
        let basis = BSplineBasis::new(grid, 2).unwrap_or_else(|| unreachable!());
        let points: Vec<(f64, f64)> = (0..16).map(|q| ((q as f64 + 0.5) / 16.0, 0.25)).collect();
        let (m, lumped) = mass_pair(&basis, &grid, &points);
        let n = lumped.len();
        let keep: Vec<bool> = (0..n).map(|i| i > 0).collect();
        let v: Vec<f64> = (0..n).map(|i| if i > 0 { 1.0 } else { 0.0 }).collect();
        let mut p = vec![0.0; n];
        m.mul_vec(&v, &mut p);
        assert!(momentum_imbalance(&m, &lumped, &keep, &v, &p) < 1e-14);
        let mut off = v.clone();
        off[2] += 1e-3;
        let expected = 1e-3
            * (0..n)
                .filter(|&i| keep[i])
                .map(|i| m.to_dense()[i][2])
                .sum::<f64>();
        let got = momentum_imbalance(&m, &lumped, &keep, &off, &p);
        assert!((got - expected).abs() < 1e-15, "{got} vs {expected}");
    }
}
