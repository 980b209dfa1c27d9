//! The particle store (structure of arrays) and its per-cell bins.
//!
//! One `Vec<f64>` per field (DESIGN §1). After every position update the particles are
//! counting-sorted by cell ([`bins::CellBins`]) so that particle-to-grid loops run cell by
//! cell over contiguous ranges; `id` keeps each particle's original index for output.

pub mod bins;
pub mod records;
pub mod tensor;

pub use bins::{counting_order, CellBins};
pub use tensor::TensorParticles;

/// Pore-liquid fields of two-phase particles (SPEC §2.1), in the storage order of the
/// solid fields. The solid phase lives in [`Particles`] itself: `mass` is the constant
/// solid mass `(1 - n_p) rho_s V_p^0`, `v` the solid velocity, `stress` the effective
/// stress `sigma'_p`, `density` the partial solid density `mass / V_p`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LiquidFields {
    /// Porosity `n_p` (constant: the masses below are constant, SPEC §2.1).
    pub porosity: Vec<f64>,
    /// Constant liquid mass `(m_w)_p = rho_w V_p^0` (the liquid-phase mass is
    /// `n_p (m_w)_p`).
    pub mass: Vec<f64>,
    /// Liquid velocity `(v_w)_p`.
    pub velocity: Vec<f64>,
    /// Pore pressure `p_p`, positive in tension like stress.
    pub pore_pressure: Vec<f64>,
}

impl LiquidFields {
    /// Liquid at rest with pressure `pore_pressure` for `n` particles.
    pub fn uniform(n: usize, porosity: f64, mass: &[f64], pore_pressure: f64) -> Self {
        Self {
            porosity: vec![porosity; n],
            mass: mass.to_vec(),
            velocity: vec![0.0; n],
            pore_pressure: vec![pore_pressure; n],
        }
    }
}

/// Particle fields, one array per field; the liquid fields of two-phase particles only
/// when the material is two-phase.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Particles {
    /// Original index (stable across re-sorting).
    pub id: Vec<usize>,
    /// Initial (material) position `X_p`.
    pub x0: Vec<f64>,
    /// Current position `x_p`.
    pub x: Vec<f64>,
    /// Displacement `u_p`.
    pub u: Vec<f64>,
    /// Velocity `v_p`.
    pub v: Vec<f64>,
    /// Cauchy stress `sigma_p`.
    pub stress: Vec<f64>,
    /// Volume (length in 1D) `V_p`.
    pub volume: Vec<f64>,
    /// Density `rho_p`.
    pub density: Vec<f64>,
    /// Constant mass `m_p`.
    pub mass: Vec<f64>,
    /// Deformation gradient `F_p` (1D stretch, `V_p = F_p V_p^0`).
    pub deformation_gradient: Vec<f64>,
    /// Current cell of each particle.
    pub cell: Vec<usize>,
    /// Pore-liquid fields (two-phase materials only).
    pub liquid: Option<LiquidFields>,
}

impl Particles {
    /// Number of particles.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// `true` when there are no particles.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Particles at the centres of `per_cell` equal sub-cells of every cell of `grid`,
    /// with density `density`, at rest and stress free.
    pub fn at_subcell_centres(grid: &crate::grid::Grid, per_cell: usize, density: f64) -> Self {
        let n = grid.cells * per_cell;
        let sub = grid.h / per_cell as f64;
        let x0: Vec<f64> = (0..n)
            .map(|k| grid.origin + (k as f64 + 0.5) * sub)
            .collect();
        Self {
            id: (0..n).collect(),
            x: x0.clone(),
            u: vec![0.0; n],
            v: vec![0.0; n],
            stress: vec![0.0; n],
            volume: vec![sub; n],
            density: vec![density; n],
            mass: vec![density * sub; n],
            deformation_gradient: vec![1.0; n],
            cell: (0..n).map(|k| k / per_cell).collect(),
            x0,
            liquid: None,
        }
    }

    /// Apply a permutation: new particle `k` is old particle `order[k]`.
    pub fn permute(&mut self, order: &[usize], scratch: &mut Vec<f64>) {
        for field in [
            &mut self.x0,
            &mut self.x,
            &mut self.u,
            &mut self.v,
            &mut self.stress,
            &mut self.volume,
            &mut self.density,
            &mut self.mass,
            &mut self.deformation_gradient,
        ]
        .into_iter()
        .chain(self.liquid.iter_mut().flat_map(|l| {
            [
                &mut l.porosity,
                &mut l.mass,
                &mut l.velocity,
                &mut l.pore_pressure,
            ]
        })) {
            scratch.clear();
            scratch.extend(order.iter().map(|&k| field[k]));
            std::mem::swap(field, scratch);
        }
        let id: Vec<usize> = order.iter().map(|&k| self.id[k]).collect();
        self.id = id;
        let cell: Vec<usize> = order.iter().map(|&k| self.cell[k]).collect();
        self.cell = cell;
    }
}
