//! Scenario files: the stable TOML keys of DESIGN §3, `--set KEY=VALUE` overrides with
//! dotted keys, and validation.
//!
//! Parsing goes text → `toml::Table` → overrides applied → typed [`Scenario`]
//! (`deny_unknown_fields` everywhere), so an unknown key is an error naming its full dotted
//! path, whether it came from the file or from `--set`. [`Scenario::validate`] then checks
//! ranges (positive sizes, moduli, time step) and names the key and value it rejects.

use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// A complete scenario (DESIGN §3).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    pub problem: ProblemConfig,
    #[serde(default)]
    pub material: MaterialConfig,
    pub grid: GridConfig,
    pub particles: ParticlesConfig,
    #[serde(default)]
    pub method: MethodConfig,
    #[serde(default)]
    pub solver: SolverConfig,
    pub time: TimeConfig,
    #[serde(default)]
    pub output: OutputConfig,
}

/// The benchmark problems (SPEC §6).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ProblemKind {
    /// SPEC §6.2 / §6.3.
    VibratingBar,
    /// SPEC §6.4.
    ColumnCompaction,
    /// SPEC §6.6 (two-phase; not available yet).
    Consolidation,
    /// SPEC §6.5 (neo-Hookean MMS bar; not available yet).
    MmsBar,
}

/// `[problem]`: which benchmark and its own parameters.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProblemConfig {
    pub kind: ProblemKind,
    /// Length (height) of the bar / column in m; default per problem.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub length: Option<f64>,
    /// Vibrating bar: maximum initial velocity in m/s (default 0.28).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub v0: Option<f64>,
    /// Column compaction: final signed body acceleration in m/s² (default -200).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gravity: Option<f64>,
    /// What the errors are measured against: the exact solution (default) or the
    /// updated-Lagrangian FEM reference.
    #[serde(default)]
    pub reference: ReferenceKind,
    /// Nodes (DOFs) of the ULFEM reference (default 120).
    #[serde(default = "default_reference_dofs")]
    pub reference_dofs: usize,
}

/// `problem.reference`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum ReferenceKind {
    /// The problem's exact solution (none for the large-strain bar).
    #[default]
    Exact,
    /// The updated-Lagrangian FEM solution with `problem.reference_dofs` nodes (SPEC §6.3).
    Ulfem,
}

fn default_reference_dofs() -> usize {
    120
}

/// Constitutive models (SPEC §1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum MaterialModel {
    /// Small strain, linear elastic: `dsigma = E deps`.
    #[default]
    Linear,
    /// Large strain (Hill): `dsigma = (E - sigma) deps`.
    Hill,
    /// 1D neo-Hookean (not available yet).
    NeoHookean,
    /// Saturated two-phase soil (not available yet).
    TwoPhase,
}

/// `[material]`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialConfig {
    #[serde(default)]
    pub model: MaterialModel,
    /// Initial density in kg/m³.
    #[serde(default = "default_density")]
    pub density: f64,
    /// Young's modulus in Pa.
    #[serde(default = "default_youngs_modulus")]
    pub youngs_modulus: f64,
}

fn default_density() -> f64 {
    2000.0
}
fn default_youngs_modulus() -> f64 {
    7.0e6
}

impl Default for MaterialConfig {
    fn default() -> Self {
        Self {
            model: MaterialModel::default(),
            density: default_density(),
            youngs_modulus: default_youngs_modulus(),
        }
    }
}

/// `[grid]`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridConfig {
    /// Number of cells (knot spans).
    pub cells: usize,
}

/// `[particles]`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParticlesConfig {
    /// Initial particles per cell, placed at the centres of equal sub-cells.
    pub per_cell: usize,
}

/// Grid bases (SPEC §3).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum BasisKind {
    /// Piecewise-linear hat functions (standard MPM).
    #[default]
    Linear,
    Ddmpm,
    Bspline,
    Gimp,
    Cpdi,
}

/// Particle-to-grid reconstructions (SPEC §4).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum ReconstructionKind {
    /// Direct particle quadrature (standard MPM).
    #[default]
    None,
    Tls,
    CubicSpline,
    Mls,
    Imls,
}

impl ReconstructionKind {
    /// The scenario value (`method.reconstruction`).
    pub fn name(self) -> &'static str {
        match self {
            Self::None => "none",
            Self::Tls => "tls",
            Self::CubicSpline => "cubic_spline",
            Self::Mls => "mls",
            Self::Imls => "imls",
        }
    }
}

/// Mass matrix used to turn forces and momenta into accelerations and velocities.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum MassKind {
    /// Row-sum lumped (diagonal).
    #[default]
    Lumped,
    Consistent,
}

/// Time-stepping schemes (SPEC §2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Scheme {
    /// Modified update-stress-last: grid velocities from the updated particle velocities.
    #[default]
    Musl,
    /// Update-stress-last: grid velocities straight from `v_i += dt a_i`.
    Usl,
}

/// `[method]`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MethodConfig {
    #[serde(default)]
    pub basis: BasisKind,
    /// B-spline order p >= 1.
    #[serde(default = "default_order")]
    pub order: usize,
    #[serde(default)]
    pub reconstruction: ReconstructionKind,
    #[serde(default)]
    pub mass: MassKind,
    #[serde(default)]
    pub scheme: Scheme,
    /// DDMPM sub-points per particle (0 = off; SPEC §3.3). Needs `reconstruction = "none"`.
    #[serde(default)]
    pub subpoints: usize,
    /// Mass matrix of the acceleration solve (SPEC §2 step 2); `method.mass` is the one of
    /// the velocity mapping (step 4). Default: see [`MethodConfig::acceleration_mass`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub acceleration_mass: Option<MassKind>,
    /// Gauss points per cell of reconstructions (0 = automatic: for TLS enough to integrate
    /// the consistent mass matrix of the quadratic reconstruction exactly, `p + 2` for basis
    /// degree `p`; for the cubic spline 2 points on each half cell, SPEC §4.2). For the
    /// cubic spline a non-zero value is the number of points per half cell.
    #[serde(default)]
    pub gauss_points: usize,
    /// Remedy for cells whose least-squares fit is degenerate.
    #[serde(default)]
    pub degenerate_cells: DegenerateRemedy,
    /// Which particles make up the conserved cell totals of a TLS fit.
    #[serde(default)]
    pub cell_totals: CellTotals,
    /// How DDMPM computes its node integrals `V_j`, `G_ji`. Default: see
    /// [`MethodConfig::node_integrals`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub node_integrals: Option<NodeIntegrals>,
}

/// `method.cell_totals`: how the conserved totals `c_e` (mass, momentum) of the
/// conservative TLS fits are split between cells (SPEC §4.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum CellTotals {
    /// Each particle counts wholly in the cell of its centre (the published method).
    Centres,
    /// Each particle counts in every cell its domain `[x_p - V_p/2, x_p + V_p/2]` overlaps,
    /// with the overlapping fraction: still exactly conservative, and continuous when a
    /// particle crosses a face (no jump of the cell masses), which keeps runs with 1–3
    /// particles per cell stable. The default.
    #[default]
    Domains,
}

/// `method.node_integrals`: the quadrature of the DDMPM node integrals (SPEC §3.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NodeIntegrals {
    /// Particle quadrature `sum_p V_p ...`, as in the original DDMPM.
    Particles,
    /// Exact integrals over the material domain (the cells holding particles, clipped to
    /// the material extent), as the Gauss quadrature of a reconstruction integrates.
    Domain,
    /// Quadrature by the `method.subpoints` sub-points of every particle (Dhakal & Zhang's
    /// sub-points, SPEC §3.3): from particle quadrature (1 sub-point) towards the exact
    /// domain integrals as the count grows.
    Subpoints,
}

/// `method.degenerate_cells` (SPEC §4.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum DegenerateRemedy {
    /// Neighbour reconstructions evaluated at the shared faces as extra data points
    /// (falling back to order reduction when that is not enough).
    #[default]
    VirtualPoints,
    /// Drop `psi_3`, then `psi_2`.
    OrderReduction,
}

fn default_order() -> usize {
    2
}

impl Default for MethodConfig {
    fn default() -> Self {
        Self {
            basis: BasisKind::default(),
            order: default_order(),
            reconstruction: ReconstructionKind::default(),
            mass: MassKind::default(),
            scheme: Scheme::default(),
            subpoints: 0,
            acceleration_mass: None,
            node_integrals: None,
            cell_totals: CellTotals::default(),
            gauss_points: 0,
            degenerate_cells: DegenerateRemedy::default(),
        }
    }
}

impl MethodConfig {
    /// `method.node_integrals` if given, else particle quadrature for the direct mapping
    /// (sub-point quadrature with sub-points) and exact domain integrals for reconstructions (which replace particle quadrature
    /// by Gauss quadrature everywhere; this reproduces the published DDMPM-TLS error).
    /// With `method.subpoints > 0` the default is sub-point quadrature.
    pub fn node_integrals(&self) -> NodeIntegrals {
        self.node_integrals.unwrap_or(match self.reconstruction {
            ReconstructionKind::None if self.subpoints > 0 => NodeIntegrals::Subpoints,
            ReconstructionKind::None => NodeIntegrals::Particles,
            _ => NodeIntegrals::Domain,
        })
    }

    /// The mass matrix of the acceleration solve: `method.acceleration_mass` if given,
    /// else the same as `method.mass`.
    pub fn acceleration_mass(&self) -> MassKind {
        self.acceleration_mass.unwrap_or(self.mass)
    }
}

/// Linear solvers for the consistent mass matrix (SPEC §5).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum SolverKind {
    /// Plain conjugate gradients.
    Cg,
    /// Jacobi-preconditioned CG.
    Pcg,
    /// p-multigrid V-cycles over the B-spline orders `p, p-1, ..., 1`.
    Pmg,
    /// CG preconditioned by one symmetric p-multigrid V-cycle.
    #[serde(alias = "pmg-cg")]
    PmgCg,
    /// Sparse Cholesky (faer), symbolic factorisation reused while the pattern holds.
    Direct,
    /// Banded Cholesky: exact and `O(N p^2)` in 1D, the default.
    #[default]
    Banded,
    /// CG preconditioned by the diagonally scaled Kronecker (constant-density) inverse.
    Kron,
}

impl SolverKind {
    /// Every kind, in the order of the tables.
    pub const ALL: [SolverKind; 7] = [
        SolverKind::Cg,
        SolverKind::Pcg,
        SolverKind::Pmg,
        SolverKind::PmgCg,
        SolverKind::Direct,
        SolverKind::Banded,
        SolverKind::Kron,
    ];

    /// The scenario spelling.
    pub fn name(self) -> &'static str {
        match self {
            SolverKind::Cg => "cg",
            SolverKind::Pcg => "pcg",
            SolverKind::Pmg => "pmg",
            SolverKind::PmgCg => "pmg_cg",
            SolverKind::Direct => "direct",
            SolverKind::Banded => "banded",
            SolverKind::Kron => "kron",
        }
    }

    /// Parse a scenario spelling (`pmg-cg` is accepted for `pmg_cg`).
    pub fn parse(name: &str) -> Option<Self> {
        let name = name.trim().replace('-', "_");
        Self::ALL.into_iter().find(|k| k.name() == name)
    }
}

/// Smoothers of the p-multigrid V-cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Smoother {
    /// Damped Jacobi.
    Jacobi,
    /// Forward Gauss–Seidel.
    #[default]
    GaussSeidel,
    /// Forward then backward Gauss–Seidel.
    SymmetricGaussSeidel,
}

/// Most smoothing sweeps per V-cycle (`pre_smooth + post_smooth`).
pub const MAX_SMOOTHING_SWEEPS: usize = 1000;

/// `[solver]`: used when `method.mass = "consistent"`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SolverConfig {
    #[serde(default)]
    pub kind: SolverKind,
    /// Relative residual `||r|| / ||r0||` at which iterative solvers stop.
    #[serde(default = "default_tolerance")]
    pub tolerance: f64,
    #[serde(default)]
    pub smoother: Smoother,
    #[serde(default = "default_smooth")]
    pub pre_smooth: usize,
    #[serde(default = "default_smooth")]
    pub post_smooth: usize,
}

fn default_tolerance() -> f64 {
    1e-8
}
fn default_smooth() -> usize {
    8
}

impl Default for SolverConfig {
    fn default() -> Self {
        Self {
            kind: SolverKind::default(),
            tolerance: default_tolerance(),
            smoother: Smoother::default(),
            pre_smooth: default_smooth(),
            post_smooth: default_smooth(),
        }
    }
}

/// `[time]`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TimeConfig {
    /// Time step in s.
    pub dt: f64,
    /// End time in s; the run takes `round(end / dt)` steps.
    pub end: f64,
}

/// At which time the exact velocity is evaluated for the error measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum VelocityReference {
    /// `t - dt/2`: Euler–Cromer particle velocities are staggered half a step behind the
    /// positions, so this removes the first-order time error (SPEC §6.2 measurement note).
    #[default]
    HalfStep,
    /// `t`, the end of the last step.
    End,
}

/// `[output]`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputConfig {
    /// Intermediate particle snapshots, evenly spread over the run (0 = final state only).
    #[serde(default)]
    pub snapshots: usize,
    /// VTK output (not available yet).
    #[serde(default)]
    pub vtk: bool,
    /// Write SVG plots.
    #[serde(default = "default_true")]
    pub plots: bool,
    /// Time at which the exact velocity is evaluated.
    #[serde(default)]
    pub velocity_reference: VelocityReference,
}

fn default_true() -> bool {
    true
}

impl Default for OutputConfig {
    fn default() -> Self {
        Self {
            snapshots: 0,
            vtk: false,
            plots: true,
            velocity_reference: VelocityReference::default(),
        }
    }
}

/// Largest particle count accepted (about 16 GB of particle arrays).
pub const MAX_PARTICLES: usize = 200_000_000;

/// Largest `method.subpoints` accepted.
pub const MAX_SUBPOINTS: usize = 65_536;

/// Largest number of time steps accepted.
pub const MAX_STEPS: usize = 10_000_000_000;

/// Read a scenario file and apply `KEY=VALUE` overrides.
pub fn load(path: &Path, overrides: &[String]) -> Result<Scenario> {
    let text = std::fs::read_to_string(path).map_err(|source| Error::ReadInput {
        path: path.to_path_buf(),
        source,
    })?;
    from_str(&text, &path.display().to_string(), overrides)
}

/// Parse scenario text (`origin` names it in messages) and apply `KEY=VALUE` overrides.
pub fn from_str(text: &str, origin: &str, overrides: &[String]) -> Result<Scenario> {
    let mut table: toml::Table = toml::from_str(text).map_err(|e| {
        let at = e.span().map_or(String::new(), |span| {
            let before = &text[..span.start.min(text.len())];
            let line = before.matches('\n').count() + 1;
            let column = before.len() - before.rfind('\n').map_or(0, |k| k + 1) + 1;
            format!(" at line {line}, column {column}")
        });
        Error::Parse {
            origin: format!("{origin}{at}"),
            message: one_line(e.message()),
        }
    })?;
    for assignment in overrides {
        apply_override(&mut table, assignment)?;
    }
    let scenario: Scenario = serde_path_to_error::deserialize(toml::Value::Table(table))
        .map_err(|e| schema_error(origin, overrides, e))?;
    Ok(scenario)
}

fn one_line(message: &str) -> String {
    message.split_whitespace().collect::<Vec<_>>().join(" ")
}

fn schema_error(
    origin: &str,
    overrides: &[String],
    e: serde_path_to_error::Error<toml::de::Error>,
) -> Error {
    let path = e.path().to_string();
    let message = one_line(e.inner().message());
    if let Some(rest) = message.strip_prefix("unknown field `") {
        let (field, hint) = rest.split_once('`').unwrap_or((rest, ""));
        let key = if path == "." || path.is_empty() {
            field.to_string()
        } else {
            // serde_path_to_error reports the path of the enclosing table.
            let parent = path.trim_end_matches(&format!(".{field}"));
            let parent = parent.trim_end_matches(field);
            if parent.is_empty() || parent == "." {
                field.to_string()
            } else {
                format!("{}.{field}", parent.trim_end_matches('.'))
            }
        };
        let expected = hint.trim_start_matches(',').trim();
        let from_set = overrides.iter().any(|o| {
            let set_key = o.split('=').next().unwrap_or("").trim();
            set_key == key || set_key.starts_with(&format!("{key}."))
        });
        let source = if from_set {
            "given with --set".to_string()
        } else {
            format!("in {origin}")
        };
        let hint = if expected.is_empty() {
            format!(" {source}")
        } else {
            format!(" {source} ({expected})")
        };
        return Error::UnknownKey { key, hint };
    }
    if let Some(rest) = message.strip_prefix("missing field `") {
        let field = rest.split('`').next().unwrap_or(rest);
        let key = if path == "." || path.is_empty() {
            field.to_string()
        } else {
            format!("{path}.{field}")
        };
        return Error::Parse {
            origin: origin.to_string(),
            message: format!("missing key `{key}`"),
        };
    }
    Error::Parse {
        origin: origin.to_string(),
        message: format!("`{path}`: {message}"),
    }
}

/// Apply one `KEY=VALUE` override; `VALUE` is read as a TOML value (number, boolean,
/// quoted string, array) and, failing that, as a bare string (`method.basis=bspline`).
pub fn apply_override(table: &mut toml::Table, assignment: &str) -> Result<()> {
    let (key, raw) = assignment
        .split_once('=')
        .ok_or_else(|| Error::invalid("--set", assignment, "expected KEY=VALUE"))?;
    let key = key.trim();
    let raw = raw.trim();
    if key.is_empty() || key.split('.').any(str::is_empty) {
        return Err(Error::invalid("--set", assignment, "empty key"));
    }
    let value = match toml::from_str::<toml::Table>(&format!("value = {raw}")) {
        Ok(mut parsed) => parsed
            .remove("value")
            .unwrap_or_else(|| toml::Value::String(raw.to_string())),
        Err(_) => toml::Value::String(raw.to_string()),
    };
    let mut parts: Vec<&str> = key.split('.').collect();
    let last = parts.pop().unwrap_or(key);
    let mut current = table;
    let mut walked = String::new();
    for part in parts {
        if !walked.is_empty() {
            walked.push('.');
        }
        walked.push_str(part);
        let entry = current
            .entry(part.to_string())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        current = entry
            .as_table_mut()
            .ok_or_else(|| Error::invalid(key, raw, format!("`{walked}` is not a table")))?;
    }
    current.insert(last.to_string(), value);
    Ok(())
}

/// A float as a user would write it: plain for moderate magnitudes, scientific otherwise.
///
/// ```
/// use tlsmpm::config::display_float;
/// assert_eq!(display_float(-1.0), "-1");
/// assert_eq!(display_float(1e-300), "1e-300");
/// assert_eq!(display_float(f64::NAN), "NaN");
/// ```
pub fn display_float(value: f64) -> String {
    let magnitude = value.abs();
    if value == 0.0 || !value.is_finite() || (1e-3..1e6).contains(&magnitude) {
        format!("{value}")
    } else {
        format!("{value:e}")
    }
}

/// `Err` naming `key` unless `value` is finite and strictly positive.
pub fn require_positive(key: &str, value: f64) -> Result<()> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(Error::invalid(
            key,
            value,
            "must be a positive finite number",
        ))
    }
}

impl Scenario {
    /// Number of time steps, `round(end / dt)`.
    pub fn n_steps(&self) -> usize {
        (self.time.end / self.time.dt).round() as usize
    }

    /// Range checks that do not depend on the problem; problem-specific keys are checked
    /// when the problem is built. Returns the first violation.
    pub fn validate(&self) -> Result<()> {
        if self.grid.cells == 0 {
            return Err(Error::invalid("grid.cells", 0, "must be at least 1"));
        }
        if self.particles.per_cell == 0 {
            return Err(Error::invalid(
                "particles.per_cell",
                0,
                "must be at least 1",
            ));
        }
        let particles = self.grid.cells.checked_mul(self.particles.per_cell);
        if particles.is_none_or(|n| n > MAX_PARTICLES) {
            return Err(Error::invalid(
                "grid.cells",
                self.grid.cells,
                format!(
                    "with particles.per_cell = {} that is more than {MAX_PARTICLES:e} particles",
                    self.particles.per_cell
                ),
            ));
        }
        require_positive("material.density", self.material.density)?;
        require_positive("material.youngs_modulus", self.material.youngs_modulus)?;
        require_positive("time.dt", self.time.dt)?;
        require_positive("time.end", self.time.end)?;
        if self.time.end / self.time.dt > MAX_STEPS as f64 {
            return Err(Error::invalid(
                "time.dt",
                display_float(self.time.dt),
                format!(
                    "time.end / time.dt = {:e} steps, more than {:e}",
                    self.time.end / self.time.dt,
                    MAX_STEPS as f64
                ),
            ));
        }
        if self.n_steps() == 0 {
            return Err(Error::invalid(
                "time.end",
                self.time.end,
                format!("shorter than half a time step (time.dt = {})", self.time.dt),
            ));
        }
        require_positive("solver.tolerance", self.solver.tolerance)?;
        if let Some(length) = self.problem.length {
            require_positive("problem.length", length)?;
        }
        let max_order = crate::grid::bspline::MAX_ORDER;
        if self.method.basis == BasisKind::Bspline && !(1..=max_order).contains(&self.method.order)
        {
            return Err(Error::invalid(
                "method.order",
                self.method.order,
                format!("B-spline order must be between 1 and {max_order}"),
            ));
        }
        if self.problem.reference == ReferenceKind::Ulfem && self.problem.reference_dofs < 2 {
            return Err(Error::invalid(
                "problem.reference_dofs",
                self.problem.reference_dofs,
                "the ULFEM reference needs at least 2 nodes",
            ));
        }
        if self.problem.reference_dofs > MAX_PARTICLES {
            return Err(Error::invalid(
                "problem.reference_dofs",
                self.problem.reference_dofs,
                format!("more than {MAX_PARTICLES:e}"),
            ));
        }
        self.check_available()
    }

    /// Reject the documented keys whose methods are not implemented in this version, with
    /// a message naming the key (never a silent fallback).
    fn check_available(&self) -> Result<()> {
        let not_yet = |key: &str, value: &str| {
            Err(Error::invalid(
                key,
                format!("\"{value}\""),
                "not available in this version of tlsmpm",
            ))
        };
        match self.problem.kind {
            ProblemKind::Consolidation => return not_yet("problem.kind", "consolidation"),
            ProblemKind::MmsBar => return not_yet("problem.kind", "mms_bar"),
            _ => {}
        }
        match self.material.model {
            MaterialModel::NeoHookean => return not_yet("material.model", "neo_hookean"),
            MaterialModel::TwoPhase => return not_yet("material.model", "two_phase"),
            _ => {}
        }
        // DDMPM sub-points (SPEC §3.3) replace the particle quadrature of the direct
        // mapping; they do not combine with a reconstruction. Any basis accepts them (the
        // published comparison pairs them with `ddmpm`).
        if self.method.subpoints != 0 && self.method.reconstruction != ReconstructionKind::None {
            return Err(Error::invalid(
                "method.subpoints",
                self.method.subpoints,
                format!(
                    "sub-points need method.reconstruction = \"none\" (got \"{}\"); set \
                     method.subpoints = 0 to use a reconstruction",
                    self.method.reconstruction.name()
                ),
            ));
        }
        if self.method.subpoints > MAX_SUBPOINTS {
            return Err(Error::invalid(
                "method.subpoints",
                self.method.subpoints,
                format!("more than {MAX_SUBPOINTS} sub-points per particle"),
            ));
        }
        match self.method.reconstruction {
            ReconstructionKind::None
            | ReconstructionKind::Tls
            | ReconstructionKind::CubicSpline => {}
            ReconstructionKind::Mls => return not_yet("method.reconstruction", "mls"),
            ReconstructionKind::Imls => return not_yet("method.reconstruction", "imls"),
        }
        if matches!(self.solver.kind, SolverKind::Pmg | SolverKind::PmgCg) {
            let sweeps = self.solver.pre_smooth + self.solver.post_smooth;
            if sweeps == 0 || sweeps > MAX_SMOOTHING_SWEEPS {
                return Err(Error::invalid(
                    "solver.pre_smooth",
                    self.solver.pre_smooth,
                    format!(
                        "pre_smooth + post_smooth (= {sweeps}) must be between 1 and \
                         {MAX_SMOOTHING_SWEEPS} for solver.kind = \"{}\"",
                        self.solver.kind.name()
                    ),
                ));
            }
        }
        if self.solver.kind == SolverKind::PmgCg
            && self.solver.pre_smooth != self.solver.post_smooth
        {
            return Err(Error::invalid(
                "solver.post_smooth",
                self.solver.post_smooth,
                format!(
                    "a V-cycle preconditioner must be symmetric: set post_smooth = pre_smooth \
                     (= {})",
                    self.solver.pre_smooth
                ),
            ));
        }
        if self.solver.tolerance >= 1.0 {
            return Err(Error::invalid(
                "solver.tolerance",
                self.solver.tolerance,
                "a relative residual below 1 is needed",
            ));
        }
        if self.method.gauss_points > crate::numerics::gauss::MAX_POINTS
            || self.method.gauss_points == 1
        {
            return Err(Error::invalid(
                "method.gauss_points",
                self.method.gauss_points,
                format!(
                    "must be 0 (automatic) or between 2 and {}",
                    crate::numerics::gauss::MAX_POINTS
                ),
            ));
        }
        if self.output.vtk {
            return Err(Error::invalid(
                "output.vtk",
                true,
                "VTK output is not available in this version of tlsmpm",
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const BAR: &str = r#"
[problem]
kind = "vibrating_bar"
[grid]
cells = 20
[particles]
per_cell = 12
[time]
dt = 1e-7
end = 1.9e-6
"#;

    #[test]
    fn defaults_and_steps() {
        let s = from_str(BAR, "bar", &[]).unwrap();
        assert_eq!(s.grid.cells, 20);
        assert_eq!(s.material.model, MaterialModel::Linear);
        assert_eq!(s.method.scheme, Scheme::Musl);
        assert_eq!(s.n_steps(), 19);
        s.validate().unwrap();
    }

    #[test]
    fn overrides_use_dotted_keys_and_toml_values() {
        let o = [
            "grid.cells=40".to_string(),
            "method.scheme=usl".to_string(),
            "time.dt=1e-8".to_string(),
            "problem.v0=1".to_string(),
        ];
        let s = from_str(BAR, "bar", &o).unwrap();
        assert_eq!(s.grid.cells, 40);
        assert_eq!(s.method.scheme, Scheme::Usl);
        assert_eq!(s.time.dt, 1e-8);
        assert_eq!(s.problem.v0, Some(1.0));
    }

    #[test]
    fn unknown_keys_name_their_dotted_path() {
        let err = from_str(BAR, "bar", &["grid.celss=3".to_string()]).unwrap_err();
        assert!(
            matches!(&err, Error::UnknownKey { key, .. } if key == "grid.celss"),
            "{err}"
        );
        assert!(err.to_string().contains("--set"), "{err}");
        let err = from_str(BAR, "bar", &["solvr.kind=cg".to_string()]).unwrap_err();
        assert!(
            matches!(&err, Error::UnknownKey { key, .. } if key == "solvr"),
            "{err}"
        );
        let text = format!("{BAR}\n[material]\nyoung = 3.0\n");
        let err = from_str(&text, "bar", &[]).unwrap_err();
        assert!(
            matches!(&err, Error::UnknownKey { key, .. } if key == "material.young"),
            "{err}"
        );
    }

    #[test]
    fn invalid_values_name_the_key() {
        for (set, key) in [
            ("grid.cells=0", "grid.cells"),
            ("particles.per_cell=0", "particles.per_cell"),
            ("material.density=-1", "material.density"),
            ("material.youngs_modulus=0", "material.youngs_modulus"),
            ("time.dt=0", "time.dt"),
            ("time.dt=nan", "time.dt"),
            ("time.dt=1e-300", "time.dt"),
            ("grid.cells=1000000000000", "grid.cells"),
            ("particles.per_cell=4611686018427387904", "grid.cells"),
            (
                "particles.per_cell=18446744073709551615",
                "particles.per_cell",
            ),
        ] {
            let err = from_str(BAR, "bar", &[set.to_string()])
                .and_then(|s| s.validate())
                .unwrap_err();
            assert!(err.to_string().contains(key), "{set}: {err}");
            assert!(err.is_input_error());
        }
    }

    #[test]
    fn subpoints_need_the_direct_mapping() {
        let with = |sets: &[&str]| {
            let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
            from_str(BAR, "bar", &sets).and_then(|s| s.validate())
        };
        with(&["method.basis=ddmpm", "method.subpoints=4"]).unwrap();
        with(&["method.subpoints=1", "method.mass=consistent"]).unwrap();
        for reconstruction in ["tls", "cubic_spline"] {
            let err = with(&[
                "method.subpoints=4",
                &format!("method.reconstruction={reconstruction}"),
            ])
            .unwrap_err();
            let text = err.to_string();
            assert!(text.contains("method.subpoints"), "{text}");
            assert!(text.contains(reconstruction), "{text}");
            assert!(err.is_input_error());
        }
        let err = with(&["method.subpoints=1000000"]).unwrap_err();
        assert!(err.to_string().contains("method.subpoints"), "{err}");
    }

    #[test]
    fn wrong_types_and_bad_overrides_are_errors() {
        let err = from_str(BAR, "bar", &["grid.cells=-5".to_string()]).unwrap_err();
        assert!(err.to_string().contains("grid.cells"), "{err}");
        let err = from_str(BAR, "bar", &["grid.cells".to_string()]).unwrap_err();
        assert!(err.to_string().contains("KEY=VALUE"), "{err}");
        let err = from_str(BAR, "bar", &["grid.cells.x=1".to_string()]).unwrap_err();
        assert!(err.to_string().contains("not a table"), "{err}");
        let err = from_str("[grid]\ncells = 3\n[problem\nkind=1", "bad", &[]).unwrap_err();
        assert!(matches!(err, Error::Parse { .. }));
        assert!(err.to_string().contains("line 3"), "{err}");
    }
}
