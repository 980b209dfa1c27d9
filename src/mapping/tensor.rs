//! The plug point of the dimension-generic core's particle-to-grid transfers
//! (`docs/dimensions.md`, `docs/tls.md`): the direct mapping of standard MPM
//! ([`super::tensor_direct::TensorDirectMapping`]) and the conservative Taylor least
//! squares with Gauss quadrature ([`super::tensor_tls::TensorTlsMapping`]) implement
//! [`TensorMapping`]; the time stepper is generic over it (one dispatch at build time).

use super::tensor_direct::{TensorBody, TensorGridFields};
use super::tensor_next::NextMassForce;
use super::RemedyCounts;
use crate::error::Result;
use crate::grid::{Basis, TensorBasis, TensorShapeCache};
use crate::linalg::CsrMatrix;
use crate::particles::TensorParticles;
use std::sync::Arc;

/// The other ranks of a distributed run as a mapping sees them
/// (`crate::physics::distributed::RankContext` implements it; `docs/distributed.md`):
/// a reconstruction whose cell quantities reach across a slab face completes them here.
pub trait SlabCells: Send + Sync + std::fmt::Debug {
    /// Whether lexicographic cell `cell` is one of this rank's.
    fn owns_cell(&self, cell: usize) -> bool;

    /// Add the neighbours' values on the two cell layers at each slab face (the slab's
    /// boundary layer and the neighbour's first one), `width` values per cell. Afterwards
    /// the values of this rank's cells are complete.
    fn add_shared_cells(&self, values: &mut [f64], width: usize) -> Result<()>;

    /// Replace every entry of `values` by its minimum over ranks.
    fn min_over_ranks(&self, values: &mut [f64]) -> Result<()>;
}

/// Particle → grid transfers of one step.
pub trait TensorMapping<const D: usize>: Send + Sync {
    /// `method.reconstruction`.
    fn name(&self) -> &'static str;

    /// The initial half-lengths of the particle domains for particle-domain bases (GIMP),
    /// `None` for point bases: the basis at a particle is evaluated over
    /// `l_a = l0_a |F_aa|`.
    fn particle_domains(&self) -> &Option<[f64; D]>;

    /// `m_I` and `f_I = f_ext - f_int` into `fields.mass`, `fields.force`.
    fn map_mass_and_force<B: Basis>(
        &mut self,
        basis: &TensorBasis<D, B>,
        particles: &TensorParticles<D>,
        cell_start: &[usize],
        body: TensorBody<'_, D>,
        fields: &mut TensorGridFields<D>,
    ) -> Result<()>;

    /// `p_I` of the current particle velocities into `fields.momentum`.
    fn map_momentum<B: Basis>(
        &mut self,
        basis: &TensorBasis<D, B>,
        particles: &TensorParticles<D>,
        cell_start: &[usize],
        fields: &mut TensorGridFields<D>,
    ) -> Result<()>;

    /// MUSL: `v_p += dt sum_I phi_I a_I`, then `p_I` from the updated velocities. Returns
    /// `sum_p m_p v_p` (components `0..D`) and `sum_p m_p |v_p|` (last entry), summed in a
    /// fixed order.
    fn update_velocities_and_map_momentum<B: Basis>(
        &mut self,
        basis: &TensorBasis<D, B>,
        particles: &mut TensorParticles<D>,
        cell_start: &[usize],
        dt: f64,
        fields: &mut TensorGridFields<D>,
    ) -> Result<[f64; 4]>;

    /// Make the mapping one rank's part of a distributed run: it maps the particles of
    /// the cells `slab` owns and completes with the neighbours what crosses a slab face.
    /// The default suits mappings whose transfers are particle by particle (the stepper
    /// sums the shared nodes).
    fn distribute(&mut self, slab: Arc<dyn SlabCells>) -> Result<()> {
        let _ = slab;
        Ok(())
    }

    /// How many layers of cells (along the last axis) a particle may move away from the
    /// cell it was binned in before the particles must be re-sorted: 0 (the default) for
    /// mappings that need every particle in its current cell's bin of `cell_start`, more
    /// for mappings whose scatter buffers are widened to match
    /// ([`super::tensor_scatter::TensorScatter::with_slack`]) or that bin the particles
    /// themselves (TLS: per-cell index lists).
    fn bin_slack(&self) -> usize {
        0
    }

    /// The particles' shapes stored by the last [`TensorMapping::map_mass_and_force`] for
    /// the later passes of the step ([`crate::grid::tensor_shape_cache`]), when the mapping
    /// keeps them and [`TensorMapping::forget_shapes`] has not been called since (default:
    /// `None`, the passes evaluate). [`TensorMapping::map_momentum`] and
    /// [`TensorMapping::update_velocities_and_map_momentum`] read them too: between the
    /// mass and force map and `forget_shapes` the particles must not move.
    fn shapes(&self) -> Option<&TensorShapeCache<D>> {
        None
    }

    /// The scatter of the next step's mass and force, lent to this step's particle update
    /// so that it maps each particle as it moves it ([`super::tensor_next`]); `None` (the
    /// default) where the mapping's first pass cannot be done particle by particle in the
    /// update. The next [`TensorMapping::map_mass_and_force`] is skipped when the fused
    /// pass completed ([`NextMassForce::finish`]).
    fn next_mass_and_force(&mut self) -> Option<NextMassForce<'_, D>> {
        None
    }

    /// The particles are about to move (the particle update of a step): the stored shapes
    /// are stale from here until the next [`TensorMapping::map_mass_and_force`].
    fn forget_shapes(&mut self) {}

    /// Remedies of degenerate cell fits so far (reconstructions only).
    fn remedies(&self) -> RemedyCounts {
        RemedyCounts::default()
    }

    /// The consistent mass matrix of the last [`TensorMapping::map_mass_and_force`], when
    /// the mapping assembles one.
    fn consistent_mass(&self) -> Option<&CsrMatrix> {
        None
    }

    /// Seconds spent assembling the consistent mass so far (inside
    /// [`TensorMapping::map_mass_and_force`]).
    fn assembly_seconds(&self) -> f64 {
        0.0
    }
}
