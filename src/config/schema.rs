//! The typed scenario sections of DESIGN §3 with their defaults and limits.

use serde::{Deserialize, Serialize};

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
    /// Boundary conditions per grid face (2D / 3D only; DESIGN §7).
    #[serde(default, skip_serializing_if = "BoundaryConfig::is_empty")]
    pub boundary: BoundaryConfig,
    /// The keys written in the file or given with `--set` (not serialised): the warnings
    /// about keys other choices make meaningless look only at these.
    #[serde(skip)]
    pub given_keys: super::GivenKeys,
}

/// The benchmark problems (SPEC §6).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ProblemKind {
    /// SPEC §6.2 / §6.3.
    VibratingBar,
    /// SPEC §6.4.
    ColumnCompaction,
    /// SPEC §6.6 (two-phase Terzaghi consolidation).
    Consolidation,
    /// SPEC §6.5 (neo-Hookean manufactured-solution bar).
    MmsBar,
    /// The axis-aligned manufactured solution of Wallstedt & Guilkey (2008) on the unit
    /// square / cube (2D / 3D only).
    AxisAlignedMms,
}

/// `[problem]`: which benchmark and its own parameters.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProblemConfig {
    pub kind: ProblemKind,
    /// Spatial dimension: 1 (default), 2 (plane strain) or 3.
    #[serde(default = "default_dim", skip_serializing_if = "is_one")]
    pub dim: usize,
    /// Length (height) of the bar / column in m; default per problem.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub length: Option<f64>,
    /// Vibrating bar: maximum initial velocity in m/s (default 0.28).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub v0: Option<f64>,
    /// Column compaction: final signed body acceleration in m/s² (default -200).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gravity: Option<f64>,
    /// MMS bar: amplitude `A` of the manufactured displacement in m (default 0.1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub amplitude: Option<f64>,
    /// Consolidation: signed load `q` on the top in Pa (default -1e4, compression).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub load: Option<f64>,
    /// Consolidation: time of the exact solution at which the run starts, in s (default
    /// 5; at 0 the column starts undrained, `p = q`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start_time: Option<f64>,
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

fn default_dim() -> usize {
    1
}

fn is_one(value: &usize) -> bool {
    *value == 1
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
    /// 1D neo-Hookean: `sigma = lambda ln(F)/F + mu (F - 1/F)` (SPEC §6.5), keys
    /// `shear_modulus`, `lame_lambda`.
    NeoHookean,
    /// Saturated two-phase soil (SPEC §1.2): solid skeleton and pore liquid on the same
    /// particles; the skeleton law is `material.skeleton`.
    TwoPhase,
}

/// `material.skeleton`: the effective-stress law of the solid skeleton of a two-phase
/// material (SPEC §1.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum SkeletonLaw {
    /// Small strain: `dsigma' = E_c deps`.
    #[default]
    Linear,
    /// Large strain (Hill): `dsigma' = (E_c - sigma') deps`.
    Hill,
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
    /// Neo-Hookean: shear modulus `mu` in Pa (required).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shear_modulus: Option<f64>,
    /// Neo-Hookean: Lamé's `lambda` in Pa (required).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lame_lambda: Option<f64>,
    /// Two-phase: porosity `n` (default 0.4).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub porosity: Option<f64>,
    /// Two-phase: density of the solid grains `rho_s` in kg/m³ (default 2600).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub density_solid: Option<f64>,
    /// Two-phase: density of the pore liquid `rho_w` in kg/m³ (default 1000).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub density_liquid: Option<f64>,
    /// Two-phase: constrained (oedometer) modulus of the skeleton `E_c` in Pa (default 1e7).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub constrained_modulus: Option<f64>,
    /// Two-phase: bulk modulus of the liquid `K_w` in Pa (default 3e8).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bulk_modulus_liquid: Option<f64>,
    /// Two-phase: Darcy permeability `k` in m/s (default 1e-5).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub permeability: Option<f64>,
    /// Two-phase: gravitational acceleration `g` in `gamma_w = rho_w g`, m/s² (default 9.81).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gravity: Option<f64>,
    /// Two-phase: the skeleton law (default linear).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub skeleton: Option<SkeletonLaw>,
    /// Linear law in 2D / 3D: Poisson's ratio `nu` in `[0, 0.5)` (default 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub poisson_ratio: Option<f64>,
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
            shear_modulus: None,
            lame_lambda: None,
            porosity: None,
            density_solid: None,
            density_liquid: None,
            constrained_modulus: None,
            bulk_modulus_liquid: None,
            permeability: None,
            gravity: None,
            skeleton: None,
            poisson_ratio: None,
        }
    }
}

/// `[grid]`.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridConfig {
    /// Number of cells (knot spans): one count for every axis, or one per axis.
    pub cells: Cells,
}

/// `grid.cells`: an integer (the same on every axis; for problems extruded from 1D the
/// count along x, one cell across) or an array with one count per axis.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(untagged)]
pub enum Cells {
    Uniform(usize),
    PerAxis(Vec<usize>),
}

impl Cells {
    /// The count along x (the 1D count).
    pub fn along_x(&self) -> usize {
        match self {
            Cells::Uniform(n) => *n,
            Cells::PerAxis(counts) => counts.first().copied().unwrap_or(0),
        }
    }

    /// Total number of cells for `dim` axes, where `Uniform(n)` means `across` cells on the
    /// other axes when given (extruded problems) and `n` otherwise; `None` on overflow or a
    /// mis-sized array.
    pub fn per_axis(&self, dim: usize, across: Option<usize>) -> Option<Vec<usize>> {
        match self {
            Cells::Uniform(n) => Some(
                (0..dim)
                    .map(|a| if a == 0 { *n } else { across.unwrap_or(*n) })
                    .collect(),
            ),
            Cells::PerAxis(counts) => (counts.len() == dim).then(|| counts.clone()),
        }
    }
}

impl PartialEq<usize> for Cells {
    fn eq(&self, other: &usize) -> bool {
        *self == Cells::Uniform(*other)
    }
}

impl From<usize> for Cells {
    fn from(n: usize) -> Self {
        Cells::Uniform(n)
    }
}

impl<'de> Deserialize<'de> for Cells {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Visitor;
        impl<'de> serde::de::Visitor<'de> for Visitor {
            type Value = Cells;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a non-negative cell count or an array of 1 to 3 counts")
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Cells, E> {
                usize::try_from(v)
                    .map(Cells::Uniform)
                    .map_err(|_| E::custom(format!("{v} cells is too many")))
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Cells, E> {
                usize::try_from(v).map(Cells::Uniform).map_err(|_| {
                    E::invalid_value(serde::de::Unexpected::Signed(v), &"a cell count >= 0")
                })
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(
                self,
                mut seq: A,
            ) -> Result<Cells, A::Error> {
                let mut counts = Vec::new();
                while let Some(n) = seq.next_element::<usize>()? {
                    if counts.len() == 3 {
                        return Err(serde::de::Error::custom(
                            "more than 3 cell counts (one per axis)",
                        ));
                    }
                    counts.push(n);
                }
                Ok(Cells::PerAxis(counts))
            }
        }
        deserializer.deserialize_any(Visitor)
    }
}

/// A boundary condition of one grid face (2D / 3D).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FaceCondition {
    /// Every velocity component zero on the face's nodes.
    Fixed,
    /// The normal component zero, the tangential ones free.
    Roller,
    /// Traction free.
    Free,
}

/// `[boundary]`: conditions per face, the problem's defaults where absent.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoundaryConfig {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub x_min: Option<FaceCondition>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub x_max: Option<FaceCondition>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub y_min: Option<FaceCondition>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub y_max: Option<FaceCondition>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub z_min: Option<FaceCondition>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub z_max: Option<FaceCondition>,
}

impl BoundaryConfig {
    /// The faces in the order `[axis][min, max]` with their key names.
    pub fn faces(&self) -> [[(&'static str, Option<FaceCondition>); 2]; 3] {
        [
            [
                ("boundary.x_min", self.x_min),
                ("boundary.x_max", self.x_max),
            ],
            [
                ("boundary.y_min", self.y_min),
                ("boundary.y_max", self.y_max),
            ],
            [
                ("boundary.z_min", self.z_min),
                ("boundary.z_max", self.z_max),
            ],
        ]
    }

    /// No face given.
    pub fn is_empty(&self) -> bool {
        self == &BoundaryConfig::default()
    }
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
    /// The particle strain increments (and, with TLS, accelerations) of a reconstruction.
    /// Default: see [`MethodConfig::strain`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub strain: Option<StrainKind>,
    /// Highest total degree (0..=2) of the conservative TLS fits (density, momentum).
    /// Default: see [`MethodConfig::conservative_degree`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub conservative_degree: Option<usize>,
    /// Limiter of the TLS momentum fits (1D). Default: see
    /// [`MethodConfig::momentum_limiter`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub momentum_limiter: Option<MomentumLimiter>,
    /// The TLS stress fit (1D). Default: see [`MethodConfig::stress_fit`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stress_fit: Option<StressFit>,
    /// The weights of the particles in the TLS least-squares fits (1D). Default: see
    /// [`MethodConfig::fit_weights`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fit_weights: Option<FitWeights>,
    /// The particle mass of the adjoint TLS acceleration (1D). Default: see
    /// [`MethodConfig::adjoint_mass`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub adjoint_mass: Option<AdjointMass>,
    /// How MLS / IMLS (linear basis, 1D) accelerate the particles. Default: see
    /// [`MethodConfig::particle_acceleration`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub particle_acceleration: Option<ParticleAcceleration>,
}

/// `method.particle_acceleration`: the particle velocity update of MLS / IMLS with the
/// linear basis (`src/mapping/mls/conjugate.rs`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ParticleAcceleration {
    /// `a_p = sum_i N_i(x_p) a_i` with the hats (the published method).
    Basis,
    /// The transpose of the momentum map, corrected so that every particle's column keeps
    /// its mass and first moment: the grid's and the particles' work agree exactly, so
    /// the velocity map feeds no energy into the particles (exact for linear
    /// accelerations; first-order accurate on the manufactured bar).
    Conjugate,
}

/// `method.fit_weights`: how the particles enter the least-squares fits of TLS (1D).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FitWeights {
    /// Each particle is one data point, of weight 1, in the fit of the cell of its centre
    /// (the published method).
    Points,
    /// Each particle is a data point in every cell its domain `[x_p - V_p/2, x_p + V_p/2]`
    /// overlaps, weighted by the overlapping fraction (the shares of
    /// `method.cell_totals = "domains"`): the fits then change continuously when a particle
    /// crosses a face, instead of jumping.
    Domains,
}

/// `method.adjoint_mass`: the particle mass of the adjoint TLS acceleration
/// (`method.strain = "adjoint"`, 1D), `a = W^{-1} P^T a_grid`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AdjointMass {
    /// `W = diag(m_p)`: exact for a uniform acceleration, first order in `h` for others.
    Lumped,
    /// Per cell, the particle masses plus a symmetric rank-2 term with the same row sums
    /// that makes `W` exact for linear accelerations (up to the cell's first-moment
    /// defect); momentum and the neutral frozen step are kept.
    Consistent,
    /// As `consistent`, with a symmetric rank-4 term that makes `W` exact for quadratic
    /// accelerations as well (up to a constant per cell); the linear one where a cell's
    /// particles do not determine a quadratic.
    Quadratic,
}

/// `method.stress_fit`: how TLS fits the particle stresses in a cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StressFit {
    /// Least squares on all three Taylor functions (the published method).
    Full,
    /// Conservative like density and momentum: the fitted stress integrates to the cell's
    /// share of `sum_p V_p sigma_p`. With `method.strain = "adjoint"` every particle's fit
    /// weight is then its volume, and the step conserves the physical energy.
    Conservative,
}

/// `method.momentum_limiter`: whether a TLS momentum fit may carry more kinetic energy than
/// its particles.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MomentumLimiter {
    /// The fit as solved (the published method).
    None,
    /// Blend the fit towards the cell's mean velocity times the fitted density until the
    /// reconstructed velocity carries no more kinetic energy than the cell's particles
    /// (momentum kept): the mapping to the grid then never adds kinetic energy.
    KineticEnergy,
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

/// `method.strain`: how the particle strain increments are computed from the grid
/// velocities.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StrainKind {
    /// The basis gradient at the particle, `deps_p = dt sum_i dphi_i(x_p) v_i` (standard
    /// MPM; the IMLS paper's eq. 37).
    Gradient,
    /// TLS, MLS and IMLS (one-phase, 1D): the strain work-conjugate to the internal force
    /// of the fitted stress, the fit-weighted mean of the Gauss-point velocity gradients
    /// (see `mapping::mls::adjoint`, `mapping::tls::adjoint`); with TLS also the particle
    /// acceleration adjoint to the momentum fit. Neutrally stable where `gradient` has a
    /// growing mode.
    Adjoint,
}

impl StrainKind {
    /// The key value.
    pub fn name(self) -> &'static str {
        match self {
            Self::Gradient => "gradient",
            Self::Adjoint => "adjoint",
        }
    }
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
            strain: None,
            conservative_degree: None,
            momentum_limiter: None,
            stress_fit: None,
            fit_weights: None,
            adjoint_mass: None,
            particle_acceleration: None,
        }
    }
}

impl MethodConfig {
    /// `method.conservative_degree` if given, else 2 in 1D (the published quadratic fit
    /// `a_1 + a_2 psi_2 + a_3 psi_3`) and 1 in 2D / 3D (`{1, s_x, s_y[, s_z]}`: a
    /// conservative quadratic there would add transverse terms `s_a^2 / 2 - 1/6` whose
    /// particle mean is not their cell mean, see `docs/tls.md`).
    pub fn conservative_degree(&self, dim: usize) -> usize {
        self.conservative_degree
            .unwrap_or(if dim > 1 { 1 } else { 2 })
    }

    /// `method.strain` if given, else `adjoint` for one-phase MLS / IMLS and for one-phase
    /// TLS in 1D (`dim` is `problem.dim`), and `gradient` otherwise: the two-phase step and
    /// the 2D / 3D step support `gradient` only.
    ///
    /// ```
    /// use tlsmpm::config::{MethodConfig, ReconstructionKind, StrainKind};
    /// let tls = MethodConfig { reconstruction: ReconstructionKind::Tls, ..Default::default() };
    /// assert_eq!(tls.strain(1, false), StrainKind::Adjoint);
    /// assert_eq!(tls.strain(1, true), StrainKind::Gradient);
    /// assert_eq!(tls.strain(2, false), StrainKind::Gradient);
    /// ```
    pub fn strain(&self, dim: usize, two_phase: bool) -> StrainKind {
        self.strain.unwrap_or(match self.reconstruction {
            ReconstructionKind::Mls | ReconstructionKind::Imls if !two_phase => StrainKind::Adjoint,
            ReconstructionKind::Tls if dim == 1 && !two_phase => StrainKind::Adjoint,
            _ => StrainKind::Gradient,
        })
    }

    /// Whether a TLS run takes the adjoint strain (given or by default): the TLS defaults
    /// of [`MethodConfig::fit_weights`] and [`MethodConfig::adjoint_mass`] follow it.
    fn adjoint_tls(&self, dim: usize, two_phase: bool) -> bool {
        self.reconstruction == ReconstructionKind::Tls
            && self.strain(dim, two_phase) == StrainKind::Adjoint
    }

    /// `method.stress_fit` if given, else a full fit (the published TLS).
    pub fn stress_fit(&self) -> StressFit {
        self.stress_fit.unwrap_or(StressFit::Full)
    }

    /// `method.particle_acceleration` if given, else the basis values at the particle.
    pub fn particle_acceleration(&self) -> ParticleAcceleration {
        self.particle_acceleration
            .unwrap_or(ParticleAcceleration::Basis)
    }

    /// `method.fit_weights` if given, else `domains` for TLS with the adjoint strain (the
    /// 1D one-phase default) and one point per particle in the cell of its centre
    /// otherwise (the published TLS fits, which `method.strain = "gradient"` selects).
    pub fn fit_weights(&self, dim: usize, two_phase: bool) -> FitWeights {
        self.fit_weights
            .unwrap_or(if self.adjoint_tls(dim, two_phase) {
                FitWeights::Domains
            } else {
                FitWeights::Points
            })
    }

    /// `method.adjoint_mass` if given, else the quadratic particle metric for TLS with the
    /// adjoint strain (the 1D one-phase default) and the particle masses otherwise.
    pub fn adjoint_mass(&self, dim: usize, two_phase: bool) -> AdjointMass {
        self.adjoint_mass
            .unwrap_or(if self.adjoint_tls(dim, two_phase) {
                AdjointMass::Quadratic
            } else {
                AdjointMass::Lumped
            })
    }

    /// `method.momentum_limiter` if given, else none (the published TLS fits).
    pub fn momentum_limiter(&self) -> MomentumLimiter {
        self.momentum_limiter.unwrap_or(MomentumLimiter::None)
    }

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
    /// `None`: the default of the dimension ([`SolverConfig::kind`]); written back as the
    /// 1D default `"banded"` when not given, as before.
    #[serde(default, serialize_with = "serialize_kind")]
    pub kind: Option<SolverKind>,
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

fn serialize_kind<S: serde::Serializer>(
    kind: &Option<SolverKind>,
    serializer: S,
) -> std::result::Result<S::Ok, S::Error> {
    kind.unwrap_or_default().serialize(serializer)
}

/// The solver of 2D / 3D consistent-mass runs when `solver.kind` is not given: the
/// fastest measured inside a run (`docs/tls.md`), `kron` in 2D and in 3D.
pub fn tensor_default_solver(_dim: usize) -> SolverKind {
    SolverKind::Kron
}

impl SolverConfig {
    /// `solver.kind` in 1D (default `banded`).
    pub fn kind(&self) -> SolverKind {
        self.kind.unwrap_or_default()
    }

    /// `solver.kind` in 2D / 3D (default [`tensor_default_solver`]).
    pub fn tensor_kind(&self, dim: usize) -> SolverKind {
        self.kind.unwrap_or_else(|| tensor_default_solver(dim))
    }
}
fn default_smooth() -> usize {
    8
}

impl Default for SolverConfig {
    fn default() -> Self {
        Self {
            kind: None,
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
    /// Time step in s, or `"auto"` (2D / 3D): `cfl` times the stability limit of the
    /// current particle state, recomputed every `cfl_every` steps.
    pub dt: TimeStep,
    /// End time in s; a fixed step takes `round(end / dt)` steps.
    pub end: f64,
    /// CFL number of `dt = "auto"` (default 0.5).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cfl: Option<f64>,
}

/// `time.dt`: a number of seconds or `"auto"`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TimeStep {
    Fixed(f64),
    Auto,
}

impl TimeStep {
    /// The fixed step in s; NaN for `"auto"` (which validation allows only where the
    /// time loop computes the step itself).
    pub fn seconds(self) -> f64 {
        match self {
            TimeStep::Fixed(dt) => dt,
            TimeStep::Auto => f64::NAN,
        }
    }
}

impl From<f64> for TimeStep {
    fn from(dt: f64) -> Self {
        TimeStep::Fixed(dt)
    }
}

impl PartialEq<f64> for TimeStep {
    fn eq(&self, other: &f64) -> bool {
        *self == TimeStep::Fixed(*other)
    }
}

impl Serialize for TimeStep {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        match self {
            TimeStep::Fixed(dt) => serializer.serialize_f64(*dt),
            TimeStep::Auto => serializer.serialize_str("auto"),
        }
    }
}

impl<'de> Deserialize<'de> for TimeStep {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Visitor;
        impl serde::de::Visitor<'_> for Visitor {
            type Value = TimeStep;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a time step in seconds or \"auto\"")
            }
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<TimeStep, E> {
                Ok(TimeStep::Fixed(v))
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<TimeStep, E> {
                Ok(TimeStep::Fixed(v as f64))
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<TimeStep, E> {
                Ok(TimeStep::Fixed(v as f64))
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<TimeStep, E> {
                match v {
                    "auto" => Ok(TimeStep::Auto),
                    other => Err(E::invalid_value(
                        serde::de::Unexpected::Str(other),
                        &"a number or \"auto\"",
                    )),
                }
            }
        }
        deserializer.deserialize_any(Visitor)
    }
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
    /// VTU particle files and a `.pvd` series (initial state, snapshots, final state).
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
