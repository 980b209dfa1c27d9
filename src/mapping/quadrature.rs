//! Gauss quadrature of reconstructed fields (SPEC §4.1, §4.2): the grid vectors and the
//! consistent mass matrix of a reconstruction evaluated at Gauss points,
//!
//! ```text
//! f_int = sum_g sigma_hat(x_g) dphi(x_g) w_g
//! m     = sum_g rho_hat(x_g) w_g phi(x_g)                 (row sums of M^C)
//! M^C   = sum_g rho_hat(x_g) w_g phi(x_g) phi(x_g)^T
//! p     = sum_g (rho v)_hat(x_g) w_g phi(x_g)
//! ```
//!
//! The points lie in the *active part* of every cell that holds particles: the cell
//! clipped to the material extent `[min_p (x_p - V_p/2), max_p (x_p + V_p/2)]`. For a cell
//! inside the material this is the whole cell; in the cell at a free surface (the top of a
//! compacting column) it keeps the reconstruction from being extrapolated over empty space
//! and integrated there. Cells without particles contribute nothing (with
//! `method.cell_totals = "domains"`: cells the material extent does not overlap).

use super::scatter::add_outer;
use super::{CellScatter, GridFields};
use crate::grid::{Basis, Grid, ParticleQuadrature, Shape};
use crate::numerics::gauss::GaussRule;
use crate::particles::{CellBins, Particles};

/// The active part `[lo, hi]` of every cell (`lo == hi` when inactive).
#[derive(Clone, Debug, Default)]
pub struct CellDomains {
    pub lo: Vec<f64>,
    pub hi: Vec<f64>,
}

impl CellDomains {
    /// Recompute from the binned particles. With `require_particles`, only cells holding a
    /// particle centre are active; otherwise every cell the material extent overlaps.
    pub fn update(
        &mut self,
        grid: &Grid,
        particles: &Particles,
        bins: &CellBins,
        require_particles: bool,
    ) {
        let quadrature = ParticleQuadrature {
            x: &particles.x,
            volume: &particles.volume,
            cell_start: &bins.cell_start,
        };
        let extent = quadrature.material_extent();
        self.lo.resize(grid.cells, 0.0);
        self.hi.resize(grid.cells, 0.0);
        for cell in 0..grid.cells {
            let left = grid.cell_left(cell);
            let (lo, hi) = if require_particles {
                quadrature.active_part(grid, cell, extent)
            } else {
                let (lo, hi) = (left.max(extent.0), (left + grid.h).min(extent.1));
                (hi > lo).then_some((lo, hi))
            }
            .unwrap_or((left, left));
            self.lo[cell] = lo;
            self.hi[cell] = hi;
        }
    }

    /// Whether cell `cell` is integrated.
    #[inline]
    pub fn is_active(&self, cell: usize) -> bool {
        self.hi[cell] > self.lo[cell]
    }

    /// Length of the active part of `cell`.
    #[inline]
    pub fn length(&self, cell: usize) -> f64 {
        self.hi[cell] - self.lo[cell]
    }
}

/// A Gauss rule applied on `pieces` equal sub-intervals of each active cell part (1 for
/// TLS; 2 for the cubic-spline comparator, which integrates each half span).
#[derive(Clone, Copy, Debug)]
pub struct GaussPoints {
    pub rule: GaussRule,
    pub pieces: usize,
}

impl GaussPoints {
    /// Call `f(x_g, w_g)` for every point of `[lo, hi]`.
    #[inline]
    pub fn for_each(&self, lo: f64, hi: f64, mut f: impl FnMut(f64, f64)) {
        let step = (hi - lo) / self.pieces as f64;
        for k in 0..self.pieces {
            let a = lo + k as f64 * step;
            let b = if k + 1 == self.pieces { hi } else { a + step };
            for (x, w) in self.rule.mapped(a, b) {
                f(x, w);
            }
        }
    }
}

impl GaussPoints {
    /// Call `f(x_g, w_g, shape)` with the basis evaluated at every point of the active part
    /// of `cell` (nothing for an inactive cell).
    #[inline]
    pub fn for_each_shape<B: Basis>(
        &self,
        basis: &B,
        domains: &CellDomains,
        cell: usize,
        mut f: impl FnMut(f64, f64, &Shape),
    ) {
        if !domains.is_active(cell) {
            return;
        }
        let mut shape = Shape::default();
        self.for_each(domains.lo[cell], domains.hi[cell], |x, w| {
            basis.eval(cell, x, &mut shape);
            f(x, w, &shape);
        });
    }
}

/// `f_int`, the lumped mass and (when `fields.consistent_mass` is present) `M^C` from the
/// reconstructed `stress(cell, x)` and `density(cell, x)`.
#[allow(clippy::too_many_arguments)]
pub fn integrate_mass_and_force<B, S, R>(
    scatter: &mut CellScatter,
    basis: &B,
    domains: &CellDomains,
    points: &GaussPoints,
    stress: S,
    density: R,
    fields: &mut GridFields,
) where
    B: Basis,
    S: Fn(usize, f64) -> f64 + Sync,
    R: Fn(usize, f64) -> f64 + Sync,
{
    let cells = domains.lo.len();
    scatter.scatter_cells(
        basis,
        cells,
        [&mut fields.mass[..], &mut fields.internal_force[..]],
        |cell, first, [m_local, f_local]| {
            points.for_each_shape(basis, domains, cell, |x, w, shape| {
                let offset = shape.first - first;
                let (rw, sw) = (density(cell, x) * w, stress(cell, x) * w);
                for k in 0..shape.len {
                    m_local[offset + k] += rw * shape.phi[k];
                    f_local[offset + k] += sw * shape.dphi[k];
                }
            });
        },
    );
    if let Some(matrix) = fields.consistent_mass.as_mut() {
        scatter.scatter_matrix(basis, cells, matrix, |cell, first, local| {
            points.for_each_shape(basis, domains, cell, |x, w, shape| {
                add_outer(local, shape.first - first, shape, density(cell, x) * w);
            });
        });
    }
}

/// The momentum vector from the reconstructed `momentum(cell, x)` (= `(rho v)_hat`).
pub fn integrate_momentum<B, P>(
    scatter: &mut CellScatter,
    basis: &B,
    domains: &CellDomains,
    points: &GaussPoints,
    momentum: P,
    fields: &mut GridFields,
) where
    B: Basis,
    P: Fn(usize, f64) -> f64 + Sync,
{
    let cells = domains.lo.len();
    scatter.scatter_cells(
        basis,
        cells,
        [&mut fields.momentum[..]],
        |cell, first, [p_local]| {
            points.for_each_shape(basis, domains, cell, |x, w, shape| {
                let offset = shape.first - first;
                let pw = momentum(cell, x) * w;
                for k in 0..shape.len {
                    p_local[offset + k] += pw * shape.phi[k];
                }
            });
        },
    );
}
