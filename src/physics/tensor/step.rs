//! The Euler–Cromer step of the dimension-generic core, MUSL (default) or USL, lumped mass
//! (`docs/dimensions.md`):
//!
//! ```text
//! 1. m_I, f_I = f_ext - f_int                  (direct mapping)
//! 2. a_I = f_I / m_I;                          held components of face nodes = 0
//! 3. MUSL: v_p += dt phi^T a, p_I = sum_p m_p v_p phi_I (one fused pass); v_I = p_I / m_I
//!    USL:  v_I = p_I(v_p^old) / m_I + dt a_I;  v_p += dt phi^T a (in the last pass)
//!    held components of v_I = 0
//! 4. x_p += dt phi^T v, u_p += dt phi^T v, L_p = sum_I v_I (x) grad phi_I
//! 5. F_p <- (I + dt L_p) F_p, V_p = det F_p V_p^0, sigma_p = law(...) (the density
//!    rho_p = m_p / V_p is derived where it is needed, not stored)
//! ```
//! then the new cells, the counting sort when the mapping's bins went stale (a particle
//! changed cell for per-cell fits; strayed more than `TensorMapping::bin_slack` layers of
//! cells from its bin for the direct mapping), and the
//! conservation errors of the mapping: mass `|sum_I m_I - sum_p m_p| / sum_p m_p`, and per
//! momentum component `|sum_I p_I - sum_p m_p v_p| / sum_p m_p |v_p|`, the largest over
//! the components.

use super::boundary::NodeConstraints;
use super::mass::TensorMassSolve;
use super::material::{LinearElasticTensor, NeoHookeanTensor, TensorLaw, TensorMaterial};
use super::timings::{PhaseClock, StepTimings};
use crate::config::MassKind;
use crate::config::Scheme;
use crate::error::{Error, Result};
use crate::grid::shape_cache::with_shape_source;
use crate::grid::tensor::with_fixed_support;
use crate::grid::{Basis, EvaluateTensor, TensorBasis, TensorShape, TensorShapeSource};
use crate::mapping::tensor::TensorMapping;
use crate::mapping::tensor_direct::{TensorBody, TensorDirectMapping, TensorGridFields};
use crate::numerics::sum::{deterministic_sum, deterministic_sums};
use crate::particles::TensorParticles;
use crate::physics::distributed::{momentum_error_over_ranks, RankContext, RankExchange};
use rayon::prelude::*;
use std::sync::Arc;

/// Particles per rayon task in the particle update.
const PARTICLES_PER_TASK: usize = 2048;

/// Diagnostics of one step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TensorStepReport {
    pub mass_error: f64,
    /// `None` when all particles are at rest.
    pub momentum_error: Option<f64>,
    pub crossings: usize,
    /// Whether the particles were re-sorted by cell after the step.
    pub sorted: bool,
    /// Kinetic energy `sum_p m_p |v_p|^2 / 2` and stored energy after the step.
    pub energies: (f64, f64),
}

/// The 2D / 3D stepper, generic over the dimension, the 1D basis of each axis and the
/// mapping.
pub struct TensorStepper<const D: usize, B: Basis, M: TensorMapping<D> = TensorDirectMapping<D>> {
    pub basis: TensorBasis<D, B>,
    pub mapping: M,
    pub material: TensorMaterial,
    pub scheme: Scheme,
    pub constraints: NodeConstraints<D>,
    pub fields: TensorGridFields<D>,
    pub cell_start: Vec<usize>,
    /// Consistent-mass solves (`None`: lumped).
    pub mass_solve: Option<TensorMassSolve<D>>,
    /// Seconds per phase so far (`assembly_seconds` is read from the mapping).
    timings: StepTimings,
    order: Vec<usize>,
    /// Last-axis cell index of each particle at the last sort (its bin's layer).
    bin_layer: Vec<u32>,
    total_mass: f64,
    /// This rank's part of a distributed run (`None`: one process).
    ranks: Option<Arc<RankContext>>,
}

impl<const D: usize, B: Basis, M: TensorMapping<D>> TensorStepper<D, B, M> {
    /// A stepper for `particles`, which are sorted by cell here.
    pub fn new(
        basis: TensorBasis<D, B>,
        mapping: M,
        material: TensorMaterial,
        scheme: Scheme,
        constraints: NodeConstraints<D>,
        particles: &mut TensorParticles<D>,
    ) -> Self {
        let mut stepper = Self {
            fields: TensorGridFields::new(basis.num_dofs()),
            basis,
            mapping,
            material,
            scheme,
            constraints,
            cell_start: Vec::new(),
            mass_solve: None,
            timings: StepTimings::default(),
            order: Vec::new(),
            bin_layer: Vec::new(),
            total_mass: deterministic_sum(particles.len(), |p| particles.mass[p]),
            ranks: None,
        };
        stepper.sort(particles);
        stepper
    }

    /// Counting-sort `particles` by cell and record each particle's bin layer.
    fn sort(&mut self, particles: &mut TensorParticles<D>) {
        let cells = self.basis.grid.num_cells();
        particles.sort_by_cell(cells, &mut self.cell_start, &mut self.order);
        let per_layer = self.basis.grid.cells_per_layer();
        self.bin_layer.clear();
        self.bin_layer.extend(
            particles
                .cell
                .iter()
                .map(|&c| u32::try_from(c / per_layer).unwrap_or(u32::MAX)),
        );
    }

    /// Make this stepper one rank of a distributed run: keep only the particles of the
    /// rank's slab and exchange with the other ranks every step
    /// ([`crate::physics::distributed`]). Every rank must call this with the same
    /// particles. MUSL only, for now; the consistent mass with `"cg"` / `"pcg"`.
    pub fn distribute(
        &mut self,
        exchange: Box<dyn RankExchange>,
        particles: &mut TensorParticles<D>,
    ) -> Result<()> {
        if self.scheme != Scheme::Musl {
            return Err(Error::invalid(
                "method.scheme",
                "\"usl\"",
                "a distributed run steps with MUSL only (for now)",
            ));
        }
        let context = Arc::new(RankContext::new(&self.basis, exchange)?);
        self.mapping.distribute(context.clone())?;
        if let Some(solve) = &mut self.mass_solve {
            solve.distribute(&context)?;
        }
        context.keep_own(particles);
        let own_mass = deterministic_sum(particles.len(), |p| particles.mass[p]);
        self.total_mass = context.sum(&[own_mass])?[0];
        self.ranks = Some(context);
        self.sort(particles);
        Ok(())
    }

    /// Solve with the consistent mass (the mapping must assemble it).
    pub fn with_mass_solve(mut self, mass_solve: TensorMassSolve<D>) -> Self {
        self.mass_solve = Some(mass_solve);
        self
    }

    /// Advance `particles` by `dt` with body force `body`; `step` and `time` label
    /// failures.
    pub fn step(
        &mut self,
        particles: &mut TensorParticles<D>,
        body: TensorBody<'_, D>,
        dt: f64,
        step: usize,
        time: f64,
    ) -> Result<TensorStepReport> {
        let fields = &mut self.fields;
        let mut clock = PhaseClock::start();
        let mut solve_seconds = 0.0;
        // 1. Mass and force.
        self.mapping
            .map_mass_and_force(&self.basis, particles, &self.cell_start, body, fields)?;
        // The largest nodal mass sets the consistent mass's small-mass threshold.
        let largest_of = |mass: &[f64]| match self.mass_solve {
            Some(_) => mass.iter().copied().fold(0.0, f64::max),
            None => 0.0,
        };
        let (grid_mass, largest_mass) = match &self.ranks {
            None => (fields.mass.iter().sum::<f64>(), largest_of(&fields.mass)),
            Some(ranks) => {
                ranks.add_shared(&mut fields.mass, 1)?;
                ranks.add_shared(fields.force.as_flattened_mut(), D)?;
                let owned = ranks.sum_over_owned_nodes(|i| fields.mass[i]);
                ranks.sum_and_max(owned, largest_of(&fields.mass))?
            }
        };
        let mass_error = (grid_mass - self.total_mass).abs() / self.total_mass;
        if !mass_error.is_finite() {
            return Err(Error::NonFinite {
                field: "grid mass",
                step,
                time,
            });
        }
        let mut momentum_error = None;
        if self.scheme == Scheme::Usl {
            self.mapping
                .map_momentum(&self.basis, particles, &self.cell_start, fields)?;
            momentum_error = particle_momentum_error(particles, &fields.momentum);
        }
        self.timings.mass_and_force_seconds += clock.lap();
        if let (Some(solve), Some(matrix)) = (&mut self.mass_solve, self.mapping.consistent_mass())
        {
            solve.prepare(&fields.mass, largest_mass, matrix);
        }
        let (consistent_acceleration, consistent_velocity) = match &self.mass_solve {
            Some(s) => (
                s.acceleration == MassKind::Consistent,
                s.velocity == MassKind::Consistent,
            ),
            None => (false, false),
        };
        // 2. Accelerations.
        match &mut self.mass_solve {
            Some(solve) if consistent_acceleration => solve.accelerations(fields)?,
            _ => divide_by_mass(&fields.mass, &fields.force, &mut fields.acceleration),
        }
        self.constraints.apply(&mut fields.acceleration);
        solve_seconds += clock.lap();
        // 3. Grid velocities.
        let mut musl_momentum = None;
        match self.scheme {
            Scheme::Musl => {
                musl_momentum = Some(self.mapping.update_velocities_and_map_momentum(
                    &self.basis,
                    particles,
                    &self.cell_start,
                    dt,
                    fields,
                )?);
                if let Some(ranks) = &self.ranks {
                    ranks.add_shared(fields.momentum.as_flattened_mut(), D)?;
                }
                self.timings.velocity_and_momentum_seconds += clock.lap();
                match &mut self.mass_solve {
                    Some(solve) if consistent_velocity => solve.velocities(fields)?,
                    _ => divide_by_mass(&fields.mass, &fields.momentum, &mut fields.velocity),
                }
            }
            Scheme::Usl => {
                match &mut self.mass_solve {
                    Some(solve) if consistent_velocity => solve.velocities(fields)?,
                    _ => divide_by_mass(&fields.mass, &fields.momentum, &mut fields.velocity),
                }
                for (v, a) in fields.velocity.iter_mut().zip(&fields.acceleration) {
                    for c in 0..D {
                        v[c] += dt * a[c];
                    }
                }
            }
        }
        self.constraints.apply(&mut fields.velocity);
        solve_seconds += clock.lap();
        if let Some([mx, my, mz, scale]) = musl_momentum {
            momentum_error = match &self.ranks {
                None => momentum_error_of(&fields.momentum, [mx, my, mz], scale),
                Some(ranks) => {
                    momentum_error_over_ranks(ranks, &fields.momentum, [mx, my, mz], scale)?
                }
            };
        }
        // 4.-5. Kinematics and stress.
        let usl_acceleration = (self.scheme == Scheme::Usl).then_some(&fields.acceleration[..]);
        let (basis, half0, velocity) = (
            &self.basis,
            self.mapping.particle_domains(),
            &fields.velocity,
        );
        let bins = Bins {
            layer: &self.bin_layer,
            slack: self.mapping.bin_slack(),
        };
        let update = ParticleUpdate {
            basis,
            half_length0: half0,
            bins,
            velocity,
            usl_acceleration,
            dt,
            material: self.material,
        };
        let outcome = with_shape_source!(self.mapping.shapes(), EvaluateTensor, source => {
            update.run(source, particles)
        });
        self.mapping.forget_shapes();
        let mut outcome = outcome;
        let mut migrated = 0;
        if let Some(ranks) = &self.ranks {
            // One collective after the update: failures, diagnostics and slab jumps.
            let failed = outcome.failure.is_some();
            let jumped = if failed {
                None
            } else {
                ranks.plan_migration(particles)
            };
            let local = [
                f64::from(u8::from(failed)),
                outcome.energies.0,
                outcome.energies.1,
                outcome.crossings as f64,
                f64::from(u8::from(jumped.is_some())),
            ];
            let total = ranks.sum(&local)?;
            if total[0] > 0.0 && !failed {
                return Err(Error::Distributed {
                    reason: format!("another rank failed at step {step} (t = {time:e} s)"),
                });
            }
            if !failed {
                if total[4] > 0.0 {
                    return Err(Error::Distributed {
                        reason: match jumped {
                            Some(id) => format!(
                                "particle {id} crossed a whole slab at step {step} \
                                 (t = {time:e} s): the time step is too large"
                            ),
                            None => format!(
                                "a particle of another rank crossed a whole slab at step \
                                 {step} (t = {time:e} s)"
                            ),
                        },
                    });
                }
                outcome.energies = (total[1], total[2]);
                outcome.crossings = total[3] as usize;
                migrated = ranks.migrate(particles)?;
            }
        }
        if let Some((particle, field)) = outcome.failure {
            return Err(match field {
                "volume" => Error::CollapsedVolume {
                    particle: particles.id[particle],
                    step,
                    time,
                },
                "left" => Error::LeftGrid {
                    particle: particles.id[particle],
                    x: particles.x[0][particle],
                    step,
                    time,
                },
                field => Error::NonFinite { field, step, time },
            });
        }
        let sorted = migrated > 0
            || if bins.slack == 0 {
                outcome.crossings > 0
            } else {
                outcome.strays > 0
            };
        if sorted {
            self.sort(particles);
        }
        self.timings.particle_update_seconds += clock.lap();
        self.timings.mass_solve_seconds += solve_seconds;
        self.timings.steps += 1;
        Ok(TensorStepReport {
            mass_error,
            momentum_error,
            crossings: outcome.crossings,
            sorted,
            energies: outcome.energies,
        })
    }

    /// Seconds per phase of the steps so far.
    pub fn timings(&self) -> StepTimings {
        let assembly = self.mapping.assembly_seconds();
        StepTimings {
            mass_and_force_seconds: (self.timings.mass_and_force_seconds - assembly).max(0.0),
            assembly_seconds: assembly,
            exchange_seconds: self
                .ranks
                .as_ref()
                .map_or(0.0, |ranks| ranks.exchange_seconds()),
            ..self.timings
        }
    }

    /// Kinetic energy `sum_p m_p |v_p|^2 / 2` and stored energy of the particles.
    pub fn energies(&self, particles: &TensorParticles<D>) -> (f64, f64) {
        let p = particles;
        let material = self.material;
        let [kinetic, stored] = deterministic_sums(p.len(), |k| {
            let speed2: f64 = (0..D).map(|a| p.v[a][k] * p.v[a][k]).sum();
            let stress: [f64; 6] = std::array::from_fn(|c| p.stress[c][k]);
            let f: [[f64; D]; D] =
                std::array::from_fn(|a| std::array::from_fn(|b| p.deformation_gradient[a][b][k]));
            let stored = match material {
                TensorMaterial::Linear(l) => {
                    l.stored_energy(&stress, &f, p.volume[k], p.volume0[k])
                }
                TensorMaterial::NeoHookean(l) => {
                    l.stored_energy(&stress, &f, p.volume[k], p.volume0[k])
                }
            };
            [0.5 * p.mass[k] * speed2, stored]
        });
        match &self.ranks {
            None => (kinetic, stored),
            Some(ranks) => match ranks.sum(&[kinetic, stored]) {
                Ok(total) => (total[0], total[1]),
                Err(_) => (f64::NAN, f64::NAN),
            },
        }
    }
}

/// `out_I = g_I / m_I` where `m_I > 0`, else 0.
fn divide_by_mass<const D: usize>(mass: &[f64], g: &[[f64; D]], out: &mut [[f64; D]]) {
    out.par_iter_mut()
        .with_min_len(4096)
        .zip(mass.par_iter().zip(g.par_iter()))
        .for_each(|(o, (&m, g))| {
            *o = if m > 0.0 {
                std::array::from_fn(|c| g[c] / m)
            } else {
                [0.0; D]
            };
        });
}

/// `max_c |sum_I p_I,c - sum_p m_p v_p,c| / sum_p m_p |v_p|` (`None` at rest).
fn particle_momentum_error<const D: usize>(
    particles: &TensorParticles<D>,
    grid_momentum: &[[f64; D]],
) -> Option<f64> {
    let (particle, scale) = particle_momentum(particles);
    momentum_error_of(grid_momentum, particle, scale)
}

/// `max_c |sum_I p_I,c - particle_c| / scale` (`None` when `scale` is 0).
fn momentum_error_of<const D: usize>(
    grid_momentum: &[[f64; D]],
    particle: [f64; 3],
    scale: f64,
) -> Option<f64> {
    let mut error: f64 = 0.0;
    for c in 0..D {
        let grid: f64 = grid_momentum.iter().map(|g| g[c]).sum();
        error = error.max((grid - particle[c]).abs());
    }
    (scale > 0.0).then_some(error / scale)
}

/// `sum_p m_p v_p` (components 0..D of the array) and `sum_p m_p |v_p|`.
fn particle_momentum<const D: usize>(p: &TensorParticles<D>) -> ([f64; 3], f64) {
    let [mx, my, mz, scale] = deterministic_sums(p.len(), |k| {
        let m = p.mass[k];
        let mut out = [0.0; 4];
        let mut speed2 = 0.0;
        for a in 0..D {
            out[a] = m * p.v[a][k];
            speed2 += p.v[a][k] * p.v[a][k];
        }
        out[3] = m * speed2.sqrt();
        out
    });
    ([mx, my, mz], scale)
}

struct Outcome {
    crossings: usize,
    /// Particles now more than `Bins::slack` layers of cells away from their bin.
    strays: usize,
    /// First failing particle (lowest index) and the failing field ("volume", "left" for
    /// a particle outside the grid, or the non-finite field's name).
    failure: Option<(usize, &'static str)>,
    /// Kinetic and stored energy after the step (summed per chunk, then in chunk order).
    energies: (f64, f64),
}

/// The binning the particle update checks against: the layer of each particle's bin and
/// how far a particle may stray from it ([`TensorMapping::bin_slack`]).
#[derive(Clone, Copy)]
struct Bins<'a> {
    layer: &'a [u32],
    slack: usize,
}

/// Number of stored stress components a `D`-dimensional law can make non-zero: `xz` and
/// `yz` (the last two) stay zero below 3D and are neither read nor written there.
const fn live_stress_components(d: usize) -> usize {
    if d < 3 {
        4
    } else {
        6
    }
}

/// `det F` of a `D x D` matrix.
#[inline(always)]
pub fn determinant<const D: usize>(f: &[[f64; D]; D]) -> f64 {
    match D {
        1 => f[0][0],
        2 => f[0][0] * f[1][1] - f[0][1] * f[1][0],
        _ => {
            f[0][0] * (f[1][1] * f[2][2] - f[1][2] * f[2][1])
                - f[0][1] * (f[1][0] * f[2][2] - f[1][2] * f[2][0])
                + f[0][2] * (f[1][0] * f[2][1] - f[1][1] * f[2][0])
        }
    }
}

/// The mutable fields of one chunk of particles (see [`update_particles`]).
struct ChunkMut<'a, const D: usize> {
    start: usize,
    x: [&'a mut [f64]; D],
    u: [&'a mut [f64]; D],
    v: [&'a mut [f64]; D],
    stress: [&'a mut [f64]; 6],
    f: [[&'a mut [f64]; D]; D],
    volume: &'a mut [f64],
    cell: &'a mut [usize],
}

/// Split `field` into consecutive chunks of the lengths of `ranges` (which tile it).
fn split<'a, T>(field: &'a mut [T], ranges: &[std::ops::Range<usize>]) -> Vec<&'a mut [T]> {
    let mut chunks = Vec::with_capacity(ranges.len());
    let mut rest = field;
    for r in ranges {
        let (head, tail) = std::mem::take(&mut rest).split_at_mut(r.len());
        chunks.push(head);
        rest = tail;
    }
    chunks
}

/// [`split`] for each of `N` component arrays, regrouped per chunk.
fn split_array<'a, const N: usize>(
    fields: &'a mut [Vec<f64>; N],
    ranges: &[std::ops::Range<usize>],
) -> Vec<[&'a mut [f64]; N]> {
    let mut per_field: Vec<std::vec::IntoIter<&'a mut [f64]>> = fields
        .iter_mut()
        .map(|f| split(f, ranges).into_iter())
        .collect();
    (0..ranges.len())
        .map(|_| std::array::from_fn(|a| per_field[a].next().unwrap_or_default()))
        .collect()
}

fn chunks_of<'a, const D: usize>(
    p: &'a mut TensorParticles<D>,
    ranges: &[std::ops::Range<usize>],
) -> Vec<ChunkMut<'a, D>> {
    let mut x = split_array(&mut p.x, ranges).into_iter();
    let mut u = split_array(&mut p.u, ranges).into_iter();
    let mut v = split_array(&mut p.v, ranges).into_iter();
    let mut stress = split_array(&mut p.stress, ranges).into_iter();
    let mut f_rows: Vec<std::vec::IntoIter<[&'a mut [f64]; D]>> = p
        .deformation_gradient
        .iter_mut()
        .map(|row| split_array(row, ranges).into_iter())
        .collect();
    let mut volume = split(&mut p.volume, ranges).into_iter();
    let mut cell = split(&mut p.cell, ranges).into_iter();
    ranges
        .iter()
        .map(|r| ChunkMut {
            start: r.start,
            x: x.next()
                .unwrap_or_else(|| std::array::from_fn(|_| Default::default())),
            u: u.next()
                .unwrap_or_else(|| std::array::from_fn(|_| Default::default())),
            v: v.next()
                .unwrap_or_else(|| std::array::from_fn(|_| Default::default())),
            stress: stress
                .next()
                .unwrap_or_else(|| std::array::from_fn(|_| Default::default())),
            f: std::array::from_fn(|a| {
                f_rows[a]
                    .next()
                    .unwrap_or_else(|| std::array::from_fn(|_| Default::default()))
            }),
            volume: volume.next().unwrap_or_default(),
            cell: cell.next().unwrap_or_default(),
        })
        .collect()
}

/// The arguments of [`update_particles`] other than the particles and the shape source.
struct ParticleUpdate<'a, const D: usize, B: Basis> {
    basis: &'a TensorBasis<D, B>,
    half_length0: &'a Option<[f64; D]>,
    bins: Bins<'a>,
    velocity: &'a [[f64; D]],
    usl_acceleration: Option<&'a [[f64; D]]>,
    dt: f64,
    material: TensorMaterial,
}

impl<const D: usize, B: Basis> ParticleUpdate<'_, D, B> {
    /// [`update_particles`] compiled for the basis' support and the law (one dispatch).
    fn run<S: TensorShapeSource<D>>(
        &self,
        source: &S,
        particles: &mut TensorParticles<D>,
    ) -> Outcome {
        let u = self;
        with_fixed_support!(u.basis, N => match u.material {
            TensorMaterial::Linear(law) => update_particles::<D, B, LinearElasticTensor, N, S>(
                u, source, particles, law,
            ),
            TensorMaterial::NeoHookean(law) => update_particles::<D, B, NeoHookeanTensor, N, S>(
                u, source, particles, law,
            ),
        })
    }
}

/// Steps 4–5 and the new cells (see the module doc); with `usl_acceleration` also
/// `v_p += dt phi^T a`. Parallel over fixed chunks of particles, each task writing only
/// its own chunk.
fn update_particles<const D: usize, B: Basis, L: TensorLaw, const N: usize, S>(
    update: &ParticleUpdate<'_, D, B>,
    source: &S,
    particles: &mut TensorParticles<D>,
    law: L,
) -> Outcome
where
    S: TensorShapeSource<D>,
{
    let ParticleUpdate {
        basis,
        half_length0,
        bins,
        velocity,
        usl_acceleration,
        dt,
        ..
    } = *update;
    let live = live_stress_components(D);
    let n = particles.len();
    let strides = *basis.strides();
    let grid = basis.grid;
    let ranges: Vec<std::ops::Range<usize>> = (0..n)
        .step_by(PARTICLES_PER_TASK)
        .map(|s| s..(s + PARTICLES_PER_TASK).min(n))
        .collect();
    let mass = std::mem::take(&mut particles.mass);
    let volume0 = std::mem::take(&mut particles.volume0);
    let chunks = chunks_of(particles, &ranges);
    #[allow(clippy::type_complexity)]
    let results: Vec<(usize, usize, Option<(usize, &'static str)>, f64, f64)> = chunks
        .into_par_iter()
        .map(|c| {
            let mut shape = TensorShape::<D>::default();
            let (mut crossings, mut strays) = (0, 0);
            let mut failure = None;
            let (mut kinetic, mut stored) = (0.0, 0.0);
            for i in 0..c.volume.len() {
                let k = c.start + i;
                let x: [f64; D] = std::array::from_fn(|a| c.x[a][i]);
                let f_old: [[f64; D]; D] =
                    std::array::from_fn(|a| std::array::from_fn(|b| c.f[a][b][i]));
                let half = match half_length0 {
                    Some(l0) => std::array::from_fn(|a| l0[a] * f_old[a][a].abs()),
                    None => [0.0; D],
                };
                source.shape_of::<B, N>(basis, k, x, half, &mut shape);
                let (v_grid, l) = shape.interpolate_with_gradient_n::<N>(&strides, velocity);
                if let Some(a) = usl_acceleration {
                    let dv = shape.interpolate_n::<N>(&strides, a);
                    for d in 0..D {
                        c.v[d][i] += dt * dv[d];
                    }
                }
                let mut new_x = [0.0; D];
                for d in 0..D {
                    let du = dt * v_grid[d];
                    c.u[d][i] += du;
                    c.x[d][i] += du;
                    new_x[d] = c.x[d][i];
                }
                // F <- (I + dt L) F.
                let dl: [[f64; D]; D] =
                    std::array::from_fn(|a| std::array::from_fn(|b| dt * l[a][b]));
                let mut f = f_old;
                for a in 0..D {
                    for b in 0..D {
                        let mut sum = f_old[a][b];
                        for e in 0..D {
                            sum += dl[a][e] * f_old[e][b];
                        }
                        f[a][b] = sum;
                        c.f[a][b][i] = sum;
                    }
                }
                let j = determinant(&f);
                let volume = j * volume0[k];
                c.volume[i] = volume;
                let mut stress: [f64; 6] =
                    std::array::from_fn(|s| if s < live { c.stress[s][i] } else { 0.0 });
                stored += law.update_with_energy(&mut stress, &dl, &f, j, volume0[k]);
                let mut speed2 = 0.0;
                for d in 0..D {
                    speed2 += c.v[d][i] * c.v[d][i];
                }
                kinetic += 0.5 * mass[k] * speed2;
                let mut finite = true;
                for (s, value) in stress.iter().enumerate().take(live) {
                    c.stress[s][i] = *value;
                    finite &= value.is_finite();
                }
                let bad = if !(0..D).all(|d| c.v[d][i].is_finite()) {
                    Some("velocity")
                } else if j.is_nan() || j <= 0.0 {
                    Some("volume")
                } else if !finite {
                    Some("stress")
                } else if !new_x.iter().all(|x| x.is_finite()) {
                    Some("position")
                } else {
                    None
                };
                match (bad, grid.axis_cells_of(new_x)) {
                    (None, Some(index)) => {
                        let e = grid.cell_index(index);
                        crossings += usize::from(e != c.cell[i]);
                        c.cell[i] = e;
                        let layer = index[D - 1].abs_diff(bins.layer[k] as usize);
                        strays += usize::from(layer > bins.slack);
                    }
                    (None, None) => failure = failure.or(Some((k, "left"))),
                    (Some(b), _) => failure = failure.or(Some((k, b))),
                }
            }
            (crossings, strays, failure, kinetic, stored)
        })
        .collect();
    particles.mass = mass;
    particles.volume0 = volume0;
    let mut outcome = Outcome {
        crossings: 0,
        strays: 0,
        failure: None,
        energies: (0.0, 0.0),
    };
    // In chunk order: deterministic for any thread count.
    for (c, s, f, kinetic, stored) in results {
        outcome.crossings += c;
        outcome.strays += s;
        outcome.failure = outcome.failure.or(f);
        outcome.energies.0 += kinetic;
        outcome.energies.1 += stored;
    }
    outcome
}
