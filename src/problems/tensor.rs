//! Problems of the dimension-generic core (`docs/dimensions.md`):
//!
//! * the axis-aligned manufactured solution on the unit square / cube
//!   ([`super::axis_aligned_mms`]), roller walls, per-particle body force;
//! * the 1D benchmarks (`vibrating_bar`, `column_compaction`) extruded along y (and z):
//!   the 1D set-up along x, roller walls on the other faces, a cross-section one cell wide
//!   unless `grid.cells` says more. With the linear law and Poisson's ratio 0 the 1D exact
//!   solution holds for `u_x`, `v_x`, `sigma_xx` (every other component 0), and the run
//!   reproduces the 1D run to round-off.

use super::axis_aligned_mms::AxisAlignedMms;
use super::{Field, Problem};
use crate::config::{FaceCondition, MaterialModel, ProblemKind, Scenario};
use crate::error::{Error, Result};
use crate::grid::{Grid, TensorGrid};
use crate::particles::TensorParticles;
use crate::physics::tensor::{FaceConditions, TensorBodySource};
use rayon::prelude::*;

/// What a problem is made of.
pub enum TensorProblemKind {
    /// A 1D problem extruded along the other axes.
    Extruded(Box<dyn Problem>),
    /// The axis-aligned manufactured solution.
    Mms(AxisAlignedMms),
}

/// A 2D / 3D problem.
pub struct TensorProblem<const D: usize> {
    pub kind: TensorProblemKind,
    /// Domain size per axis.
    pub length: [f64; D],
    /// Cells per axis.
    pub cells: [usize; D],
    /// Face conditions: the problem's defaults overridden by `[boundary]`.
    pub faces: FaceConditions<D>,
    /// Whether the exact solution applies (extruded problems: linear law, `nu = 0`).
    exact_applies: bool,
}

impl<const D: usize> TensorProblem<D> {
    /// The problem of `scenario` (validated for `problem.dim = D`).
    pub fn from_scenario(scenario: &Scenario) -> Result<Self> {
        let per_axis = scenario
            .grid
            .cells
            .per_axis(D, extruded(scenario.problem.kind).then_some(1))
            .ok_or_else(|| Error::invalid("grid.cells", "(array)", format!("needs {D} entries")))?;
        let cells: [usize; D] = std::array::from_fn(|a| per_axis[a]);
        let (kind, length, defaults, exact_applies) = match scenario.problem.kind {
            ProblemKind::AxisAlignedMms => {
                let m = &scenario.material;
                let (mu, lambda) = match (m.shear_modulus, m.lame_lambda) {
                    (Some(mu), Some(lambda)) => (mu, lambda),
                    _ => {
                        return Err(Error::invalid(
                            "material.model",
                            "(not neo_hookean)",
                            "problem.kind = \"axis_aligned_mms\" needs material.model = \
                             \"neo_hookean\" with shear_modulus and lame_lambda",
                        ))
                    }
                };
                let amplitude = scenario.problem.amplitude.unwrap_or(0.05);
                if !amplitude.is_finite() || amplitude.abs() >= 1.0 / std::f64::consts::PI {
                    return Err(Error::invalid(
                        "problem.amplitude",
                        crate::config::display_float(amplitude),
                        "must be finite with |A| < 1 / pi (else F_ii <= 0)",
                    ));
                }
                let side = scenario.problem.length.unwrap_or(1.0);
                if side != 1.0 {
                    return Err(Error::invalid(
                        "problem.length",
                        crate::config::display_float(side),
                        "the axis-aligned manufactured solution is on the unit square / cube",
                    ));
                }
                let youngs = mu * (3.0 * lambda + 2.0 * mu) / (lambda + mu);
                let mms = AxisAlignedMms {
                    amplitude,
                    shear_modulus: mu,
                    lame_lambda: lambda,
                    density: m.density,
                    wave_speed: (youngs / m.density).sqrt(),
                };
                let faces = [[FaceCondition::Roller; 2]; D];
                (TensorProblemKind::Mms(mms), [1.0; D], faces, true)
            }
            ProblemKind::VibratingBar | ProblemKind::ColumnCompaction => {
                if scenario.problem.amplitude.is_some() {
                    return Err(Error::invalid(
                        "problem.amplitude",
                        "(given)",
                        "only used by problem.kind = \"axis_aligned_mms\" or \"mms_bar\"",
                    ));
                }
                let problem = super::build(&one_dimensional(scenario))?;
                let h = problem.length() / cells[0] as f64;
                let length = std::array::from_fn(|a| {
                    if a == 0 {
                        problem.length()
                    } else {
                        h * cells[a] as f64
                    }
                });
                let x_max = if scenario.problem.kind == ProblemKind::VibratingBar {
                    FaceCondition::Fixed
                } else {
                    FaceCondition::Free
                };
                let mut faces = [[FaceCondition::Roller; 2]; D];
                faces[0] = [FaceCondition::Fixed, x_max];
                let linear = scenario.material.model == MaterialModel::Linear
                    && scenario.material.poisson_ratio.unwrap_or(0.0) == 0.0;
                (TensorProblemKind::Extruded(problem), length, faces, linear)
            }
            other => {
                return Err(Error::invalid(
                    "problem.kind",
                    crate::config::toml_value(&other),
                    "is 1D only (problem.dim = 1)",
                ))
            }
        };
        let mut faces = defaults;
        for (a, sides) in scenario.boundary.faces().iter().enumerate().take(D) {
            for (side, (_, condition)) in sides.iter().enumerate() {
                if let Some(c) = condition {
                    faces[a][side] = *c;
                }
            }
        }
        Ok(Self {
            kind,
            length,
            cells,
            faces,
            exact_applies,
        })
    }

    /// `problem.kind`.
    pub fn name(&self) -> &'static str {
        match &self.kind {
            TensorProblemKind::Extruded(p) => p.name(),
            TensorProblemKind::Mms(_) => "axis_aligned_mms",
        }
    }

    /// The background grid.
    pub fn grid(&self) -> TensorGrid<D> {
        TensorGrid::new(self.length, self.cells)
    }

    /// Initial particles, `per_axis^D` per cell at the centres of equal sub-cells (see
    /// the module doc for the initial state of each problem).
    pub fn initial_particles(&self, per_axis: usize, density: f64) -> TensorParticles<D> {
        let grid = self.grid();
        let counts: [usize; D] = std::array::from_fn(|a| grid.axes[a].cells * per_axis);
        let sub: [f64; D] = std::array::from_fn(|a| grid.axes[a].h / per_axis as f64);
        let n: usize = counts.iter().product();
        let mut x0: [Vec<f64>; D] = std::array::from_fn(|_| Vec::with_capacity(n));
        for k in 0..n {
            let mut rest = k;
            for a in 0..D {
                let i = rest % counts[a];
                rest /= counts[a];
                x0[a].push((i as f64 + 0.5) * sub[a]);
            }
        }
        let volume0: f64 = sub.iter().product();
        let mut p = TensorParticles::at_rest(x0, vec![volume0; n], density, |x| {
            grid.cell_of(x).unwrap_or(0)
        });
        match &self.kind {
            TensorProblemKind::Extruded(problem) => {
                // The 1D particles (same x positions) give the initial velocity.
                let line = Grid::new(self.length[0], self.cells[0]);
                let one = problem.initial_particles(&line, per_axis, density);
                for k in 0..n {
                    let along = k % counts[0];
                    p.v[0][k] = one.v[along];
                    p.stress[0][k] = one.stress[along];
                }
            }
            TensorProblemKind::Mms(mms) => {
                for k in 0..n {
                    let x0 = p.material_position(k);
                    let u = mms.displacement(x0, 0.0);
                    let v = mms.velocity(x0, 0.0);
                    let stretch = mms.stretch(x0, 0.0);
                    let stress = mms.cauchy_stress(x0, 0.0);
                    let j: f64 = stretch.iter().product();
                    for a in 0..D {
                        p.u[a][k] = u[a];
                        p.x[a][k] = x0[a] + u[a];
                        p.v[a][k] = v[a];
                        p.deformation_gradient[a][a][k] = stretch[a];
                    }
                    for (c, s) in stress.iter().enumerate() {
                        p.stress[c][k] = *s;
                    }
                    p.volume[k] = j * p.volume0[k];
                    p.cell[k] = grid.cell_of(p.position(k)).unwrap_or(0);
                }
            }
        }
        p
    }

    /// Fields with an exact solution.
    pub fn exact_fields(&self) -> &'static [Field] {
        if !self.exact_applies {
            return &[];
        }
        match &self.kind {
            TensorProblemKind::Extruded(p) => p.exact_fields(),
            TensorProblemKind::Mms(_) => &Field::ALL,
        }
    }

    /// Exact `u`, `v` (components `0..D`) or Cauchy stress (`xx, yy, zz, xy, xz, yz`) at
    /// material position `x0` and time `t`.
    pub fn exact(&self, field: Field, x0: [f64; D], t: f64) -> [f64; 6] {
        let mut out = [0.0; 6];
        match &self.kind {
            TensorProblemKind::Extruded(p) => {
                out[0] = p.exact(field, x0[0], t).unwrap_or(f64::NAN);
            }
            TensorProblemKind::Mms(mms) => match field {
                Field::Displacement => out[..D].copy_from_slice(&mms.displacement(x0, t)),
                Field::Velocity => out[..D].copy_from_slice(&mms.velocity(x0, t)),
                _ => out = mms.cauchy_stress(x0, t),
            },
        }
        out
    }
}

/// The cell size along x of a 2D / 3D scenario (for convergence studies).
pub fn cell_size_x(scenario: &Scenario) -> Result<f64> {
    let cells = scenario.grid.cells.along_x().max(1) as f64;
    if extruded(scenario.problem.kind) {
        Ok(super::build(&one_dimensional(scenario))?.length() / cells)
    } else {
        Ok(scenario.problem.length.unwrap_or(1.0) / cells)
    }
}

/// Problems extruded from 1D (one cell across by default).
pub fn extruded(kind: ProblemKind) -> bool {
    matches!(
        kind,
        ProblemKind::VibratingBar | ProblemKind::ColumnCompaction
    )
}

/// The 1D scenario of an extruded one (`dim = 1`, the x cell count, no 2D keys).
fn one_dimensional(scenario: &Scenario) -> Scenario {
    let mut one = scenario.clone();
    one.problem.dim = 1;
    one.grid.cells = scenario.grid.cells.along_x().into();
    one.material.poisson_ratio = None;
    one.boundary = Default::default();
    one
}

impl<const D: usize> TensorBodySource<D> for TensorProblem<D> {
    fn uniform(&self, t: f64) -> Option<[f64; D]> {
        match &self.kind {
            TensorProblemKind::Extruded(p) => {
                let mut b = [0.0; D];
                b[0] = p.body_acceleration(t);
                Some(b)
            }
            TensorProblemKind::Mms(_) => None,
        }
    }

    fn at_particles(&self, x0: &[Vec<f64>; D], t: f64, out: &mut [Vec<f64>; D]) {
        let TensorProblemKind::Mms(mms) = &self.kind else {
            for o in out.iter_mut() {
                o.fill(0.0);
            }
            return;
        };
        let n = x0[0].len();
        let values: Vec<[f64; D]> = (0..n)
            .into_par_iter()
            .with_min_len(4096)
            .map(|k| mms.body_force(std::array::from_fn(|a| x0[a][k]), t))
            .collect();
        for (a, o) in out.iter_mut().enumerate() {
            for (o, v) in o.iter_mut().zip(&values) {
                *o = v[a];
            }
        }
    }
}
