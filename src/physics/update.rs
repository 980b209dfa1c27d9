//! Steps 5–8 of the 1D one-phase step (SPEC §2, docs/mpm.md): the particle kinematics,
//! the stress update, the energies and the new cell of every particle, in one parallel pass
//! over blocks of [`PARTICLES_PER_TASK`] particles,
//!
//! ```text
//! du_p = dt phi^T(x_p) v,   deps_p = dt dphi^T(x_p) v (or the mapping's own strain)
//! u_p += du_p,  x_p += du_p,  F_p *= 1 + deps_p,  sigma_p = law(sigma_p, deps_p, F_p)
//! V_p *= 1 + deps_p,  rho_p /= 1 + deps_p
//! ```
//!
//! A task takes each particle's current shape and hands the particle's new state on
//! through [`TaskShapes`]: from a [`ShapeSource`] (evaluate, or read the step's
//! [`ShapeCache`]) and nothing more, or, for the direct mapping with a shape cache, from
//! its cache slots with the next step's shape, mass and internal force mapped on the way
//! ([`crate::mapping::next`]).

use crate::error::{Error, Result};
use crate::grid::shape_cache::with_shape_source;
use crate::grid::tensor::with_fixed_support;
use crate::grid::{Basis, Evaluate, Grid, Shape, ShapeCache, ShapeSource};
use crate::mapping::next::{NextMassForce, NextTask};
use crate::numerics::sum::sum_block_partials;
use crate::particles::{CellBins, Particles};
use crate::physics::step::PARTICLES_PER_TASK;
use crate::physics::{ConstitutiveLaw, Material};
use rayon::prelude::*;

/// Particles per sub-block of an update task: the block is updated, then its new states
/// are handed on ([`TaskShapes::moved`]) in a second loop over it.
const MAPPED_BLOCK: usize = 64;

/// Where a particle-update task takes each particle's current shape from, and what it
/// does with the particle's new state (monomorphised per kind: no dispatch per particle).
pub(crate) trait TaskShapes<B: Basis>: Send {
    /// Whether [`TaskShapes::moved`] does anything (else the update skips the loop that
    /// hands the new states on, bounds checks included).
    const USES_MOVED: bool;

    /// `(phi^T v, dphi^T v)` at the task's particle `k` (particle `p` overall) at `x` in
    /// `cell` with domain half-length `half_length`, from its current shape of support
    /// `N`, against the grid velocities `velocity`; the gradient only when `gradient` (else
    /// 0). `shape` is free scratch.
    #[allow(clippy::too_many_arguments)]
    fn velocity_at<const N: usize>(
        &self,
        basis: &B,
        k: usize,
        p: usize,
        cell: usize,
        x: f64,
        half_length: f64,
        velocity: &[f64],
        gradient: bool,
        shape: &mut Shape,
    ) -> (f64, f64);

    /// Particle `k` was updated to `x` in `cell`, with volume `volume`, mass `mass` and
    /// stress `stress` (`shape` is free scratch). Called in storage order, for the
    /// particles of a block once all of them are updated, as long as none failed.
    #[allow(clippy::too_many_arguments)]
    fn moved<const N: usize>(
        &mut self,
        basis: &B,
        k: usize,
        cell: usize,
        x: f64,
        volume: f64,
        mass: f64,
        stress: f64,
        shape: &mut Shape,
    );

    /// The task's last particle was updated.
    fn finish(&mut self);
}

/// Shapes from a [`ShapeSource`]; the new states are not used.
struct FromSource<'a, S>(&'a S);

impl<S> Clone for FromSource<'_, S> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<S> Copy for FromSource<'_, S> {}

impl<B: Basis, S: ShapeSource> TaskShapes<B> for FromSource<'_, S> {
    const USES_MOVED: bool = false;

    #[inline(always)]
    fn velocity_at<const N: usize>(
        &self,
        basis: &B,
        _k: usize,
        p: usize,
        cell: usize,
        x: f64,
        half_length: f64,
        velocity: &[f64],
        gradient: bool,
        shape: &mut Shape,
    ) -> (f64, f64) {
        self.0
            .shape_of::<B, N>(basis, p, cell, x, half_length, shape);
        let slope = if gradient {
            shape.gradient_n::<N>(velocity)
        } else {
            0.0
        };
        (shape.interpolate_n::<N>(velocity), slope)
    }

    #[inline(always)]
    fn moved<const N: usize>(
        &mut self,
        _basis: &B,
        _k: usize,
        _cell: usize,
        _x: f64,
        _volume: f64,
        _mass: f64,
        _stress: f64,
        _shape: &mut Shape,
    ) {
    }

    #[inline(always)]
    fn finish(&mut self) {}
}

/// Shapes from the task's cache slots, the next step's mapped on the way.
impl<B: Basis> TaskShapes<B> for NextTask<'_> {
    const USES_MOVED: bool = true;

    /// Straight from the slot (no copy of the shape through memory).
    #[inline(always)]
    fn velocity_at<const N: usize>(
        &self,
        basis: &B,
        k: usize,
        _p: usize,
        cell: usize,
        _x: f64,
        _half_length: f64,
        velocity: &[f64],
        gradient: bool,
        _shape: &mut Shape,
    ) -> (f64, f64) {
        self.current_dots::<B, N>(basis, k, cell, velocity, gradient)
    }

    #[inline(always)]
    fn moved<const N: usize>(
        &mut self,
        basis: &B,
        k: usize,
        cell: usize,
        x: f64,
        volume: f64,
        mass: f64,
        stress: f64,
        shape: &mut Shape,
    ) {
        self.map::<B, N>(basis, k, cell, x, volume, mass, stress, shape);
    }

    #[inline(always)]
    fn finish(&mut self) {
        NextTask::finish(self);
    }
}

/// What failed in a particle's update.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Failure {
    Velocity,
    Stress,
    Position,
    Volume,
    LeftGrid,
}

/// Of one block of particles: crossings, first failure, `[kinetic, strain]` energy, and
/// the block's new cells as `(first, last, non-decreasing within the block)`.
type BlockOutcome = (
    usize,
    Option<(usize, Failure)>,
    [f64; 2],
    Option<(usize, usize, bool)>,
);

/// What the particle update found: crossings, energies, failures, order.
pub(crate) struct UpdateOutcome {
    pub(crate) crossings: usize,
    /// Kinetic `sum_p m_p v_p^2 / 2` and strain energy `sum_p V_p W(sigma_p, F_p)` after
    /// the update (bitwise [`super::step::TimeStepper::energies`]; meaningless after a failure).
    pub(crate) energies: (f64, f64),
    /// First failing particle (lowest index) and what failed.
    pub(crate) failure: Option<(usize, Failure)>,
    /// Whether the particles are still sorted by their new cells, so that re-binning
    /// needs no permutation ([`CellBins::rebuild_sorted`]).
    pub(crate) sorted_by_cell: bool,
}

impl UpdateOutcome {
    /// Re-bin `particles` after the update when cells changed: a scan of the cell
    /// boundaries when they are still in cell order (always in 1D unless particles pass
    /// each other), else the counting sort.
    pub(crate) fn rebin(&self, bins: &mut CellBins, particles: &mut Particles, cells: usize) {
        if self.crossings == 0 {
            return;
        }
        if self.sorted_by_cell {
            bins.rebuild_sorted(&particles.cell, cells);
        } else {
            bins.sort(particles, cells);
        }
    }
}

impl UpdateOutcome {
    /// The error of the first failing particle, if any.
    pub(crate) fn check(&self, particles: &Particles, step: usize, time: f64) -> Result<()> {
        let Some((particle, failure)) = self.failure else {
            return Ok(());
        };
        let field = match failure {
            Failure::Velocity => "velocity",
            Failure::Stress => "stress",
            Failure::Position => "position",
            Failure::Volume => {
                return Err(Error::CollapsedVolume {
                    particle: particles.id[particle],
                    step,
                    time,
                })
            }
            Failure::LeftGrid => {
                return Err(Error::LeftGrid {
                    particle: particles.id[particle],
                    x: particles.x[particle],
                    step,
                    time,
                })
            }
        };
        Err(Error::NonFinite { field, step, time })
    }
}

/// The particle update with the law of `material`, the support of the basis and the shapes
/// of `shapes` (the step's cache, or evaluated when `None`), dispatched once.
#[allow(clippy::too_many_arguments)]
pub(crate) fn update_particles_with<B: Basis>(
    material: Material,
    basis: &B,
    shapes: Option<&ShapeCache>,
    grid: &Grid,
    particles: &mut Particles,
    velocity: &[f64],
    strain: Option<&[f64]>,
    dt: f64,
) -> UpdateOutcome {
    let chunks = particles.len().div_ceil(PARTICLES_PER_TASK);
    let kinematics = Kinematics {
        basis,
        grid,
        velocity,
        strain,
        dt,
    };
    with_shape_source!(shapes, Evaluate, source => {
        let tasks = rayon::iter::repeat_n(FromSource(source), chunks);
        kinematics.dispatch(material, tasks, particles)
    })
}

/// The particle update with the gradient strain that also maps the next step: each
/// particle's current shape comes from `cache` (filled at the particles' positions), its
/// next shape replaces it there, and `next` sums the next step's mass and internal force
/// (reduce them with [`NextMassForce::reduce`] once the particles are re-binned).
#[allow(clippy::too_many_arguments)]
pub(crate) fn update_particles_mapping_next<B: Basis>(
    material: Material,
    basis: &B,
    cache: &mut ShapeCache,
    next: &mut NextMassForce,
    grid: &Grid,
    particles: &mut Particles,
    velocity: &[f64],
    dt: f64,
) -> UpdateOutcome {
    debug_assert_eq!(cache.len(), particles.len());
    let kinematics = Kinematics {
        basis,
        grid,
        velocity,
        strain: None,
        dt,
    };
    let tasks = next.tasks(basis, cache, PARTICLES_PER_TASK);
    kinematics.dispatch(material, tasks, particles)
}

/// What the particle update reads besides the particles and the shapes.
struct Kinematics<'a, B> {
    basis: &'a B,
    grid: &'a Grid,
    velocity: &'a [f64],
    /// The mapping's own strain increments, when it defines them.
    strain: Option<&'a [f64]>,
    dt: f64,
}

impl<B: Basis> Kinematics<'_, B> {
    /// [`Kinematics::update`] dispatched on the law and the support.
    fn dispatch<T, I>(
        &self,
        material: Material,
        tasks: I,
        particles: &mut Particles,
    ) -> UpdateOutcome
    where
        T: TaskShapes<B>,
        I: IndexedParallelIterator<Item = T>,
    {
        with_fixed_support!(self.basis, N => match material {
            Material::Linear(law) => self.update::<T, I, _, N>(tasks, particles, law),
            Material::Hill(law) => self.update::<T, I, _, N>(tasks, particles, law),
            Material::NeoHookean(law) => self.update::<T, I, _, N>(tasks, particles, law),
        })
    }

    /// Steps 5–8 and the new cell of every particle, block `b` of [`PARTICLES_PER_TASK`]
    /// particles by the `b`-th of `tasks`. The strain increments are `dt dphi^T(x_p) v`, or
    /// `strain` when the mapping defines its own. Loops compiled for `N` functions per
    /// particle ([`Basis::eval_particle_n`]).
    fn update<T, I, L, const N: usize>(
        &self,
        tasks: I,
        particles: &mut Particles,
        law: L,
    ) -> UpdateOutcome
    where
        T: TaskShapes<B>,
        I: IndexedParallelIterator<Item = T>,
        L: ConstitutiveLaw,
    {
        let &Kinematics {
            basis,
            grid,
            velocity,
            strain,
            dt,
        } = self;
        let (v, mass) = (&particles.v, &particles.mass);
        let chunks = (
            particles.x.par_chunks_mut(PARTICLES_PER_TASK),
            particles.u.par_chunks_mut(PARTICLES_PER_TASK),
            particles.stress.par_chunks_mut(PARTICLES_PER_TASK),
            particles.volume.par_chunks_mut(PARTICLES_PER_TASK),
            particles.density.par_chunks_mut(PARTICLES_PER_TASK),
            particles.cell.par_chunks_mut(PARTICLES_PER_TASK),
            particles
                .deformation_gradient
                .par_chunks_mut(PARTICLES_PER_TASK),
        );
        let blocks: Vec<BlockOutcome> = chunks
            .into_par_iter()
            .zip(tasks)
            .enumerate()
            .map(
                |(chunk, ((x, u, stress, volume, density, cell, f), mut task))| {
                    let start = chunk * PARTICLES_PER_TASK;
                    // Every field cut to the chunk's length: one bound for all the indexing.
                    let n = x.len();
                    let (u, stress, volume) = (&mut u[..n], &mut stress[..n], &mut volume[..n]);
                    let (density, cell, f) = (&mut density[..n], &mut cell[..n], &mut f[..n]);
                    let (v, mass) = (&v[start..][..n], &mass[start..][..n]);
                    let mut shape = Shape::default();
                    let mut crossings = 0usize;
                    let mut failure = None;
                    let mut energies = [0.0; 2];
                    for block in (0..x.len()).step_by(MAPPED_BLOCK) {
                        let block = block..(block + MAPPED_BLOCK).min(x.len());
                        for k in block.clone() {
                            let p = start + k;
                            let half_length = 0.5 * volume[k];
                            let (interpolated, slope) = task.velocity_at::<N>(
                                basis,
                                k,
                                p,
                                cell[k],
                                x[k],
                                half_length,
                                velocity,
                                strain.is_none(),
                                &mut shape,
                            );
                            let du = dt * interpolated;
                            let deps = match strain {
                                Some(strain) => strain[p],
                                None => dt * slope,
                            };
                            u[k] += du;
                            x[k] += du;
                            f[k] *= 1.0 + deps;
                            stress[k] = law.update(stress[k], deps, f[k]);
                            volume[k] *= 1.0 + deps;
                            density[k] /= 1.0 + deps;
                            let vk = v[k];
                            energies[0] += 0.5 * mass[k] * vk * vk;
                            energies[1] += volume[k] * law.strain_energy_density(stress[k], f[k]);
                            // A collapsed particle (F <= 0) is named as such, before the NaN stress a
                            // hyperelastic law gives it.
                            let bad = if !v[k].is_finite() {
                                Some(Failure::Velocity)
                            } else if f[k] <= 0.0 || volume[k] <= 0.0 {
                                Some(Failure::Volume)
                            } else if !stress[k].is_finite() {
                                Some(Failure::Stress)
                            } else if !x[k].is_finite() {
                                Some(Failure::Position)
                            } else if volume[k].is_nan() {
                                Some(Failure::Volume)
                            } else {
                                None
                            };
                            match grid.cell_of(x[k]) {
                                Some(c) if bad.is_none() => {
                                    crossings += usize::from(c != cell[k]);
                                    cell[k] = c;
                                }
                                None if bad.is_none() => {
                                    failure = failure.or(Some((p, Failure::LeftGrid)));
                                }
                                _ => failure = failure.or(bad.map(|b| (p, b))),
                            }
                        }
                        // The block's new states, still in L1, handed on in a loop of its own:
                        // independent evaluations that overlap, not the tail of each particle's
                        // chain of dependent updates. After a failure the step fails and nothing
                        // handed on is used.
                        if T::USES_MOVED && failure.is_none() {
                            for k in block {
                                let (mass, stress) = (mass[k], stress[k]);
                                task.moved::<N>(
                                    basis, k, cell[k], x[k], volume[k], mass, stress, &mut shape,
                                );
                            }
                        }
                    }
                    task.finish();
                    let cells = cell.first().zip(cell.last()).map(|(&first, &last)| {
                        // Without a crossing the block keeps its (sorted) cells.
                        let sorted = crossings == 0 || cell.windows(2).all(|w| w[0] <= w[1]);
                        (first, last, sorted)
                    });
                    (crossings, failure, energies, cells)
                },
            )
            .collect();
        // Blocks in particle order: the first failure is the lowest index.
        let crossings = blocks.iter().map(|b| b.0).sum();
        let failure = blocks.iter().find_map(|b| b.1);
        let energies: Vec<[f64; 2]> = blocks.iter().map(|b| b.2).collect();
        let [kinetic, strain] = sum_block_partials(&energies);
        let ranges: Vec<(usize, usize, bool)> = blocks.iter().filter_map(|b| b.3).collect();
        let sorted_by_cell =
            ranges.iter().all(|r| r.2) && ranges.windows(2).all(|w| w[0].1 <= w[1].0);
        UpdateOutcome {
            crossings,
            failure,
            energies: (kinetic, strain),
            sorted_by_cell,
        }
    }
}
