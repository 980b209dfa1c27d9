//! The particle store (structure of arrays) and its per-cell bins.
//!
//! One `Vec<f64>` per field (DESIGN §1). After every position update the particles are
//! counting-sorted by cell ([`bins::CellBins`]) so that particle-to-grid loops run cell by
//! cell over contiguous ranges; `id` keeps each particle's original index for output.

pub mod bins;

pub use bins::CellBins;

/// One-phase particle fields, one array per field.
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
    /// Current cell of each particle.
    pub cell: Vec<usize>,
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
            cell: (0..n).map(|k| k / per_cell).collect(),
            x0,
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
        ] {
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
