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
use crate::grid::basis::shape_dot;
use crate::grid::tensor::with_fixed_support;
use crate::grid::{Basis, Evaluate, Shape, ShapeSource};
use crate::numerics::sum::deterministic_sums;
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
    let n = shape.support::<N>();
    let [m_local, f_local] = local;
    // One bounds check per slice (`[offset..][..n]`), not one per function.
    let (m_local, f_local) = (&mut m_local[offset..][..n], &mut f_local[offset..][..n]);
    for k in 0..n {
        m_local[k] += m * shape.phi[k];
        f_local[k] += sv * shape.dphi[k];
    }
}

/// Add a point of momentum `mv` with shape values `phi` (the support's functions, from
/// DOF `offset` of the window on: `offset = first - window_first`) to a cell's local
/// momentum: `p_k += mv phi_k`. The one accumulation of the momentum map, here and in the
/// fused MUSL pass ([`update_velocities_and_map_momentum`]), so both sum the same bits.
#[inline(always)]
fn add_momentum(
    p_local: &mut [f64; crate::grid::MAX_SUPPORT],
    offset: usize,
    phi: &[f64],
    mv: f64,
) {
    for (p_k, phi) in p_local[offset..][..phi.len()].iter_mut().zip(phi) {
        *p_k += mv * phi;
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
                add_momentum(
                    p_local,
                    shape.first - first,
                    &shape.phi[..shape.support::<N>()],
                    mass[p] * w * v[p],
                );
            });
        },
    );
}

/// MUSL steps 3–4 of the particles themselves in one pass (`docs/performance.md`, "1D: the
/// MUSL velocity update and momentum map in one pass"), the shapes from `source`:
///
/// ```text
/// v_p += dt sum_i phi_i(x_p) a_i,     then     p_i = sum_p m_p v_p phi_i(x_p)
/// ```
/// cell by cell, each particle's velocity updated just before it is mapped. Every
/// velocity and every `p_i` is bitwise what the velocity pass followed by
/// [`map_momentum`] gives: the same shape per particle, the same particles per cell in the
/// same order, the same reduction. Returns `[sum_p m_p v_p, sum_p m_p |v_p|]` of the
/// updated velocities ([`deterministic_sums`], as the separate velocity pass sums them).
pub fn update_velocities_and_map_momentum<B: Basis, S: ShapeSource>(
    scatter: &mut CellScatter,
    basis: &B,
    source: &S,
    particles: &mut Particles,
    bins: &CellBins,
    dt: f64,
    grid: &mut GridFields,
) -> [f64; 2] {
    with_fixed_support!(basis, N => velocities_and_momentum::<B, S, N>(
        scatter, basis, source, particles, bins, dt, grid
    ))
}

/// [`update_velocities_and_map_momentum`] with loops compiled for `N` functions per
/// particle.
fn velocities_and_momentum<B: Basis, S: ShapeSource, const N: usize>(
    scatter: &mut CellScatter,
    basis: &B,
    source: &S,
    particles: &mut Particles,
    bins: &CellBins,
    dt: f64,
    grid: &mut GridFields,
) -> [f64; 2] {
    // The particles' own weight, as `ParticlePoints` gives it to `scatter_momentum`.
    let w = 1.0;
    let Particles {
        x, volume, mass, v, ..
    } = particles;
    let (x, volume, mass) = (&x[..], &volume[..], &mass[..]);
    let GridFields {
        acceleration,
        momentum,
        ..
    } = grid;
    let acceleration = &acceleration[..];
    scatter.scatter_updating(
        basis,
        bins,
        v,
        [&mut momentum[..]],
        |cell, first, cell_particles, velocity, [p_local]| {
            let mut shape = Shape::default();
            for (p, v) in cell_particles.zip(velocity.iter_mut()) {
                let half_length = 0.5 * (volume[p] * w);
                source.with_values::<B, N, _>(
                    basis,
                    p,
                    cell,
                    x[p],
                    half_length,
                    &mut shape,
                    |at, phi| {
                        *v += dt * shape_dot(phi, &acceleration[at..][..phi.len()]);
                        add_momentum(p_local, at - first, phi, mass[p] * w * *v);
                    },
                );
            }
        },
    );
    deterministic_sums(mass.len(), |p| [mass[p] * v[p], mass[p] * v[p].abs()])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{BSplineBasis, CpdiBasis, GimpBasis, Grid, LinearBasis, ShapeCache};
    use crate::mapping::test_layouts::scattered_particles;
    use crate::mapping::{DirectMapping, Mapping};
    use proptest::prelude::*;

    /// The fused pass against the velocity update followed by the momentum map, both with
    /// evaluated shapes and with the shapes read from a cache: velocities, `p_i` and the
    /// momentum sums bit for bit.
    fn check<B: Basis>(basis: &B, particles: &Particles, bins: &CellBins, acceleration: &[f64]) {
        let dt = 1.7e-3;
        let mut two_passes = particles.clone();
        with_fixed_support!(basis, N => {
            let mut shape = Shape::default();
            for p in 0..two_passes.len() {
                let (cell, x) = (two_passes.cell[p], two_passes.x[p]);
                let half_length = 0.5 * two_passes.volume[p];
                Evaluate.shape_of::<B, N>(basis, p, cell, x, half_length, &mut shape);
                two_passes.v[p] += dt * shape.interpolate_n::<N>(acceleration);
            }
        });
        let mut expected = GridFields::new(basis.num_dofs());
        DirectMapping::default().map_momentum(basis, &two_passes, bins, &mut expected);
        let (mass, v) = (&two_passes.mass, &two_passes.v);
        let expected_sums =
            deterministic_sums(mass.len(), |p| [mass[p] * v[p], mass[p] * v[p].abs()]);
        let mut cache = ShapeCache::default();
        cache.fill(basis, &particles.x, &particles.cell, &particles.volume);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        for shapes in [None, Some(&cache)] {
            let mut fused = particles.clone();
            let mut fields = GridFields::new(basis.num_dofs());
            fields.acceleration.copy_from_slice(acceleration);
            fields.momentum.fill(f64::NAN);
            let sums = DirectMapping::default()
                .update_velocities_and_map_momentum(
                    basis,
                    &mut fused,
                    bins,
                    dt,
                    &mut fields,
                    shapes,
                )
                .unwrap();
            assert_eq!(bits(&fused.v), bits(&two_passes.v));
            assert_eq!(bits(&fields.momentum), bits(&expected.momentum));
            assert_eq!(bits(&sums), bits(&expected_sums));
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]
        /// Several groups of cells (up to 300 cells, groups of 64), empty cells, cells
        /// with many particles, every fixed-support basis.
        #[test]
        fn the_fused_musl_pass_is_the_two_passes_bit_for_bit(
            cells in 3usize..300,
            t in proptest::collection::vec(0.0f64..=1.0, 1..900),
            order in 2usize..5,
        ) {
            let grid = Grid::new(2.0, cells);
            let (particles, bins) = scattered_particles(&grid, &t);
            let acceleration = |dofs: usize| -> Vec<f64> {
                (0..dofs).map(|i| (i as f64 * 1.7).sin() * 50.0).collect()
            };
            let linear = LinearBasis::new(grid);
            check(&linear, &particles, &bins, &acceleration(linear.num_dofs()));
            let bspline = BSplineBasis::new(grid, order).unwrap();
            check(&bspline, &particles, &bins, &acceleration(bspline.num_dofs()));
            let cpdi = CpdiBasis::new(grid);
            check(&cpdi, &particles, &bins, &acceleration(cpdi.num_dofs()));
            let gimp = GimpBasis::new(grid);
            check(&gimp, &particles, &bins, &acceleration(gimp.num_dofs()));
        }
    }
}
