//! Particle → grid transfers (SPEC §2 step 1 and 4, §4).
//!
//! [`Mapping`] is the plug point: the direct particle quadrature of standard MPM now,
//! TLS / cubic-spline / MLS / IMLS reconstructions and DDMPM sub-points behind the same
//! trait later. Every mapping scatters through [`scatter::CellScatter`]: per-cell local
//! buffers filled in parallel, then reduced in a fixed cell order, so grid vectors are
//! bitwise identical for any thread count.

pub mod direct;
pub mod scatter;

pub use direct::DirectMapping;
pub use scatter::CellScatter;

use crate::grid::Basis;
use crate::particles::{CellBins, Particles};

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
        }
    }
}

/// A particle → grid transfer.
pub trait Mapping: Send {
    /// Name as in the scenario key `method.reconstruction`.
    fn name(&self) -> &'static str;

    /// Map mass and internal force: fills `grid.mass` and `grid.internal_force`.
    fn map_mass_and_internal_force<B: Basis>(
        &mut self,
        basis: &B,
        particles: &Particles,
        bins: &CellBins,
        grid: &mut GridFields,
    );

    /// Map momentum from the current particle velocities: fills `grid.momentum`.
    fn map_momentum<B: Basis>(
        &mut self,
        basis: &B,
        particles: &Particles,
        bins: &CellBins,
        grid: &mut GridFields,
    );
}
