//! Particle quadrature at points (SPEC §2 steps 1 and 4, §3.3): the grid vectors and the
//! consistent mass matrix as sums over quadrature points that carry a fraction `w` of a
//! particle (the particles themselves, `w = 1`, for standard MPM; `N` sub-points each,
//! `w = 1/N`, for DDMPM with sub-points):
//!
//! ```text
//! m_i     = sum_points w m_p phi_i(x)
//! f_int_i = sum_points sigma_p dphi_i(x) w V_p
//! p_i     = sum_points w m_p v_p phi_i(x)
//! M^C_ij  = sum_points w m_p phi_i(x) phi_j(x)
//! ```
//!
//! A [`PointSet`] lists the points lying in each cell; the functions here take the basis
//! there (`Basis::eval_particle` with half-length `w V_p / 2`, or for the particles
//! themselves the step's [`crate::grid::ShapeCache`]), in loops compiled for the basis'
//! fixed support, and scatter through [`CellScatter`], so every point mapping is
//! deterministic for any thread count.

use super::scatter::{add_outer, Local};
use super::{CellScatter, GridFields};
use crate::grid::tensor::with_fixed_support;
use crate::grid::{Basis, Evaluate, Shape, ShapeSource};
use crate::particles::{CellBins, Particles};

/// Quadrature points of a particle mapping, found cell by cell.
pub trait PointSet: Sync {
    /// The fraction `w` of its particle that each point carries.
    fn weight(&self) -> f64;

    /// Call `f(p, x)` for every point of particle `p` at `x` that lies in `cell`, in a
    /// fixed order.
    fn for_each_in<F: FnMut(usize, f64)>(&self, cell: usize, f: F);

    /// The basis (support `N`) at point `p` of cell `cell` at `x` with half-length
    /// `half_length`. Default: evaluate it.
    #[inline(always)]
    fn shape_at<B: Basis, const N: usize>(
        &self,
        basis: &B,
        p: usize,
        cell: usize,
        x: f64,
        half_length: f64,
        shape: &mut Shape,
    ) {
        Evaluate.shape_of::<B, N>(basis, p, cell, x, half_length, shape);
    }
}

/// The particles themselves, one point each (standard MPM), with their shapes from
/// `source` (evaluated, or read back from the step's [`crate::grid::ShapeCache`]).
pub struct ParticlePoints<'a, S: ShapeSource = Evaluate> {
    x: &'a [f64],
    bins: &'a CellBins,
    source: &'a S,
}

impl<'a> ParticlePoints<'a> {
    pub fn new(particles: &'a Particles, bins: &'a CellBins) -> Self {
        Self::with_source(particles, bins, &Evaluate)
    }
}

impl<'a, S: ShapeSource> ParticlePoints<'a, S> {
    /// The particles with their shapes from `source`.
    pub fn with_source(particles: &'a Particles, bins: &'a CellBins, source: &'a S) -> Self {
        Self {
            x: &particles.x,
            bins,
            source,
        }
    }
}

impl<S: ShapeSource> PointSet for ParticlePoints<'_, S> {
    #[inline]
    fn weight(&self) -> f64 {
        1.0
    }

    #[inline]
    fn for_each_in<F: FnMut(usize, f64)>(&self, cell: usize, mut f: F) {
        for p in self.bins.range(cell) {
            f(p, self.x[p]);
        }
    }

    #[inline(always)]
    fn shape_at<B: Basis, const N: usize>(
        &self,
        basis: &B,
        p: usize,
        cell: usize,
        x: f64,
        half_length: f64,
        shape: &mut Shape,
    ) {
        self.source
            .shape_of::<B, N>(basis, p, cell, x, half_length, shape);
    }
}

/// `m`, `f_int` and (when present) `M^C` by quadrature at `points`.
pub fn map_mass_and_force<B: Basis, P: PointSet>(
    scatter: &mut CellScatter,
    basis: &B,
    points: &P,
    particles: &Particles,
    bins: &CellBins,
    grid: &mut GridFields,
) {
    with_fixed_support!(basis, N => scatter_mass_and_force::<B, P, N>(
        scatter, basis, points, particles, bins, grid
    ));
}

/// [`map_mass_and_force`] with loops compiled for `N` functions per point
/// ([`Basis::eval_particle_n`]).
fn scatter_mass_and_force<B: Basis, P: PointSet, const N: usize>(
    scatter: &mut CellScatter,
    basis: &B,
    points: &P,
    particles: &Particles,
    bins: &CellBins,
    grid: &mut GridFields,
) {
    let w = points.weight();
    let (mass, stress, volume) = (&particles.mass, &particles.stress, &particles.volume);
    scatter.scatter(
        basis,
        bins,
        [&mut grid.mass[..], &mut grid.internal_force[..]],
        |cell, first, local| {
            let mut shape = Shape::default();
            points.for_each_in(cell, |p, x| {
                let v = volume[p] * w;
                points.shape_at::<B, N>(basis, p, cell, x, 0.5 * v, &mut shape);
                let (m, sv) = (mass[p] * w, stress[p] * v);
                add_mass_and_force::<N>(local, shape.first - first, &shape, m, sv);
            });
        },
    );
    if let Some(matrix) = grid.consistent_mass.as_mut() {
        scatter.scatter_matrix(basis, bins.cells(), matrix, |cell, first, local| {
            let mut shape = Shape::default();
            points.for_each_in(cell, |p, x| {
                points.shape_at::<B, N>(basis, p, cell, x, 0.5 * (volume[p] * w), &mut shape);
                add_outer(local, shape.first - first, &shape, mass[p] * w);
            });
        });
    }
}

/// Add a point of mass `m` and stress times volume `sv` with shape `shape` (support `N`,
/// or `shape.len` when `N = 0`) to a cell's local mass and internal force, `offset =
/// shape.first - window_first`: `m_k += m phi_k`, `f_k += sv dphi_k`. The one
/// accumulation of the direct mass and force map, here and in the particle update that
/// maps the next step ([`super::next`]), so both sum the same bits.
#[inline(always)]
pub(crate) fn add_mass_and_force<const N: usize>(
    local: &mut Local<2>,
    offset: usize,
    shape: &Shape,
    m: f64,
    sv: f64,
) {
    let [m_local, f_local] = local;
    for k in 0..shape.support::<N>() {
        m_local[offset + k] += m * shape.phi[k];
        f_local[offset + k] += sv * shape.dphi[k];
    }
}

/// `p` by quadrature at `points` from the current particle velocities.
pub fn map_momentum<B: Basis, P: PointSet>(
    scatter: &mut CellScatter,
    basis: &B,
    points: &P,
    particles: &Particles,
    bins: &CellBins,
    grid: &mut GridFields,
) {
    with_fixed_support!(basis, N => scatter_momentum::<B, P, N>(
        scatter, basis, points, particles, bins, grid
    ));
}

/// [`map_momentum`] with loops compiled for `N` functions per point.
fn scatter_momentum<B: Basis, P: PointSet, const N: usize>(
    scatter: &mut CellScatter,
    basis: &B,
    points: &P,
    particles: &Particles,
    bins: &CellBins,
    grid: &mut GridFields,
) {
    let w = points.weight();
    let (mass, v, volume) = (&particles.mass, &particles.v, &particles.volume);
    scatter.scatter(
        basis,
        bins,
        [&mut grid.momentum[..]],
        |cell, first, [p_local]| {
            let mut shape = Shape::default();
            points.for_each_in(cell, |p, x| {
                points.shape_at::<B, N>(basis, p, cell, x, 0.5 * (volume[p] * w), &mut shape);
                let offset = shape.first - first;
                let mv = mass[p] * w * v[p];
                for k in 0..shape.support::<N>() {
                    p_local[offset + k] += mv * shape.phi[k];
                }
            });
        },
    );
}
