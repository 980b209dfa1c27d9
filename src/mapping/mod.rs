//! Particle → grid transfers (SPEC §2 step 1 and 4, §4).
//!
//! [`Mapping`] is the plug point: the direct particle quadrature of standard MPM
//! ([`DirectMapping`]), the conservative Taylor-least-squares reconstruction with Gauss
//! quadrature ([`TlsMapping`]), the non-conservative global cubic-spline comparator
//! ([`CubicSplineMapping`]), moving least squares and improved MLS at Gauss points
//! ([`MlsMapping`], SPEC §4.3) and DDMPM sub-points ([`SubpointMapping`], SPEC §3.3: the
//! direct quadrature over `N` points per particle domain). Every mapping scatters through [`scatter::CellScatter`]:
//! per-cell local buffers filled in parallel, then reduced in a fixed cell order, so grid
//! vectors and the consistent mass matrix are bitwise identical for any thread count.

pub mod cubic_spline;
pub mod direct;
pub mod mls;
pub mod next;
pub mod points;
pub mod quadrature;
pub mod scatter;
#[cfg(test)]
pub(crate) mod spectrum;
pub mod subpoints;
pub mod tensor;
pub mod tensor_direct;
pub mod tensor_kernels;
pub mod tensor_mass;
pub mod tensor_next;
pub mod tensor_scatter;
pub mod tensor_tls;
#[cfg(test)]
pub(crate) mod test_layouts;
pub mod tls;

pub use cubic_spline::CubicSplineMapping;
pub use direct::DirectMapping;
pub use mls::{MlsKind, MlsMapping};
pub use scatter::CellScatter;
pub use subpoints::SubpointMapping;
pub use tls::TlsMapping;

use crate::grid::{Basis, ShapeCache};
use crate::linalg::CsrMatrix;
use crate::particles::{CellBins, Particles};
use serde::Serialize;

/// Grid vectors of one step, all of length `N_n`.
#[derive(Clone, Debug, Default)]
pub struct GridFields {
    /// Lumped (row-sum) mass `m_i`.
    pub mass: Vec<f64>,
    /// Internal force `f_int_i = int sigma dphi_i`.
    pub internal_force: Vec<f64>,
    /// External force (body force and tractions).
    pub external_force: Vec<f64>,
    /// Momentum `p_i = int rho v phi_i`.
    pub momentum: Vec<f64>,
    /// Acceleration `a_i`.
    pub acceleration: Vec<f64>,
    /// Velocity `v_i`.
    pub velocity: Vec<f64>,
    /// Consistent mass matrix `M^C_ij = int rho phi_i phi_j` (band pattern of the basis),
    /// assembled by the mapping when present; `mass` holds its row sums.
    pub consistent_mass: Option<CsrMatrix>,
}

impl GridFields {
    /// Zeroed grid vectors for `dofs` DOFs.
    pub fn new(dofs: usize) -> Self {
        Self {
            mass: vec![0.0; dofs],
            internal_force: vec![0.0; dofs],
            external_force: vec![0.0; dofs],
            momentum: vec![0.0; dofs],
            acceleration: vec![0.0; dofs],
            velocity: vec![0.0; dofs],
            consistent_mass: None,
        }
    }
}

/// How often a reconstruction needed a remedy, counted over cell fits (SPEC §4.1): every
/// step fits stress, density and momentum once per active cell.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct RemedyCounts {
    /// Cell fits whose normal equations were singular or ill conditioned.
    pub degenerate_fits: u64,
    /// Of those, fits repaired by virtual points from neighbouring cells.
    pub virtual_point_fits: u64,
    /// Of those, fits that dropped Taylor terms (order reduction).
    pub order_reduced_fits: u64,
    /// Density fits scaled towards the cell mean to stay non-negative at the Gauss points.
    pub density_limited_fits: u64,
    /// Particles whose adjoint strain (MLS / IMLS, `method.strain = "adjoint"`) had too
    /// small a fit volume and used the basis gradient instead.
    pub strain_fallbacks: u64,
    /// Momentum fits blended towards the cell's mean velocity to carry no more kinetic
    /// energy than their particles (`method.momentum_limiter = "kinetic_energy"`; not
    /// written when zero).
    #[serde(skip_serializing_if = "is_zero")]
    pub momentum_limited_fits: u64,
    /// Cells of two particles or more, summed over the strain and acceleration passes of
    /// every step, whose consistent particle metric (TLS, `method.adjoint_mass =
    /// "consistent"`) was scaled towards the lumped one to stay within 1% of it (not
    /// written when zero).
    #[serde(skip_serializing_if = "is_zero")]
    pub limited_consistent_cells: u64,
}

fn is_zero(count: &u64) -> bool {
    *count == 0
}

impl RemedyCounts {
    /// `n` degenerate fits, each repaired by order reduction.
    pub fn order_reduced(n: u64) -> Self {
        Self {
            degenerate_fits: n,
            order_reduced_fits: n,
            ..Self::default()
        }
    }
}

/// Counts summed over cells (integers: the same total in any order, for any thread count).
impl std::iter::Sum for RemedyCounts {
    fn sum<I: Iterator<Item = Self>>(iter: I) -> Self {
        iter.fold(Self::default(), |mut total, counts| {
            total += counts;
            total
        })
    }
}

impl std::ops::AddAssign for RemedyCounts {
    fn add_assign(&mut self, other: Self) {
        self.degenerate_fits += other.degenerate_fits;
        self.virtual_point_fits += other.virtual_point_fits;
        self.order_reduced_fits += other.order_reduced_fits;
        self.density_limited_fits += other.density_limited_fits;
        self.momentum_limited_fits += other.momentum_limited_fits;
        self.strain_fallbacks += other.strain_fallbacks;
        self.limited_consistent_cells += other.limited_consistent_cells;
    }
}

/// A particle → grid transfer.
pub trait Mapping: Send {
    /// Name as in the scenario key `method.reconstruction` (`"subpoints"` for
    /// [`SubpointMapping`], whose key is `method.subpoints` with reconstruction `"none"`).
    fn name(&self) -> &'static str;

    /// Map mass and internal force: fills `grid.mass` (row sums) and
    /// `grid.internal_force`, and `grid.consistent_mass` when it is present.
    fn map_mass_and_internal_force<B: Basis>(
        &mut self,
        basis: &B,
        particles: &Particles,
        bins: &CellBins,
        grid: &mut GridFields,
    );

    /// Map momentum from the current particle velocities: fills `grid.momentum`. Called
    /// after [`Mapping::map_mass_and_internal_force`] in the same step (same positions).
    fn map_momentum<B: Basis>(
        &mut self,
        basis: &B,
        particles: &Particles,
        bins: &CellBins,
        grid: &mut GridFields,
    );

    /// [`Mapping::map_mass_and_internal_force`] in a step that evaluated the basis once at
    /// the particles' current positions and domains (`shapes`). A mapping that evaluates
    /// the basis at the particles reads the values from there (bitwise the same); the
    /// default ignores `shapes`.
    fn map_mass_and_internal_force_reusing<B: Basis>(
        &mut self,
        basis: &B,
        particles: &Particles,
        bins: &CellBins,
        grid: &mut GridFields,
        shapes: &ShapeCache,
    ) {
        let _ = shapes;
        self.map_mass_and_internal_force(basis, particles, bins, grid);
    }

    /// [`Mapping::map_momentum`] with the step's shapes at the particles (see
    /// [`Mapping::map_mass_and_internal_force_reusing`]). Default: ignores `shapes`.
    fn map_momentum_reusing<B: Basis>(
        &mut self,
        basis: &B,
        particles: &Particles,
        bins: &CellBins,
        grid: &mut GridFields,
        shapes: &ShapeCache,
    ) {
        let _ = shapes;
        self.map_momentum(basis, particles, bins, grid);
    }

    /// Particle strain increments `deps_p` from the grid velocities `velocity` over `dt`,
    /// for a mapping that defines the strain conjugate to its own internal force (the
    /// adjoint strain of [`MlsMapping`]). Called after [`Mapping::map_momentum`] in the
    /// same step (same positions). Returns `false`, leaving `deps` alone, when the basis
    /// gradient at the particle, `deps_p = dt sum_i dphi_i(x_p) v_i`, is to be used (the
    /// default).
    fn strain_increments<B: Basis>(
        &mut self,
        _basis: &B,
        _particles: &Particles,
        _velocity: &[f64],
        _dt: f64,
        _deps: &mut Vec<f64>,
    ) -> bool {
        false
    }

    /// Particle accelerations `a_p` from the grid accelerations `acceleration`, for a
    /// mapping whose particle velocity update is the transpose of its own momentum map,
    /// `a_p = (1/m_p) d/dv_p sum_i a_i p_i(v)` (the adjoint TLS, `method.strain =
    /// "adjoint"`). Called after [`Mapping::map_momentum`] at the same positions. Returns
    /// `false`, leaving `out` alone, when `a_p = sum_i phi_i(x_p) a_i` is to be used (the
    /// default).
    fn particle_accelerations<B: Basis>(
        &mut self,
        _basis: &B,
        _particles: &Particles,
        _acceleration: &[f64],
        _out: &mut Vec<f64>,
    ) -> bool {
        false
    }

    /// MUSL steps 3–4 in one pass, for a mapping whose momentum is the direct particle sum
    /// `p_i = sum_p m_p v_p phi_i(x_p)` and whose particle acceleration is
    /// `sum_i phi_i(x_p) a_i`: `v_p += dt phi^T a` from `grid.acceleration`, then
    /// `grid.momentum` from the updated velocities, with the step's `shapes` when there are
    /// ([`points::update_velocities_and_map_momentum`]). Returns `[sum_p m_p v_p, sum_p m_p
    /// |v_p|]` of the updated velocities, or `None` (the default) when the mapping does not
    /// fuse the two, leaving everything alone: the stepper then updates the velocities and
    /// calls [`Mapping::map_momentum`].
    #[allow(clippy::too_many_arguments)]
    fn update_velocities_and_map_momentum<B: Basis>(
        &mut self,
        _basis: &B,
        _particles: &mut Particles,
        _bins: &CellBins,
        _dt: f64,
        _grid: &mut GridFields,
        _shapes: Option<&ShapeCache>,
    ) -> Option<[f64; 2]> {
        None
    }

    /// The sums of the next step's mass and internal force, lent to the particle update so
    /// that it maps them on the way ([`next`]); `None` (the default) for a mapping whose
    /// mass and force are not the direct particle sums at the particles' shapes.
    fn next_mass_and_force(&mut self) -> Option<&mut next::NextMassForce> {
        None
    }

    /// Remedies applied since the mapping was created (none for direct quadrature).
    fn remedies(&self) -> RemedyCounts {
        RemedyCounts::default()
    }
}
