//! Step 3 of the one-phase step ([`super::step`]): the particle velocities from the grid
//! accelerations, `v_p += dt sum_i phi_i(x_p) a_i` (or `dt a_p` with a mapping's own
//! particle accelerations), with the momentum sums of the mapping's conservation check,
//! `[sum_p m_p v_p, sum_p m_p |v_p|]`, folded into the same pass (fixed blocks of particles,
//! bitwise [`deterministic_sums`](crate::numerics::sum::deterministic_sums)). With the direct mapping the MUSL step fuses this pass
//! with the momentum map instead ([`crate::mapping::Mapping::update_velocities_and_map_momentum`]).

use super::step::PARTICLES_PER_TASK;
use crate::grid::shape_cache::with_shape_source;
use crate::grid::tensor::with_fixed_support;
use crate::grid::{Basis, Evaluate, Shape, ShapeCache, ShapeSource};
use crate::mapping::Mapping;
use crate::numerics::sum::sum_block_partials;
use crate::particles::Particles;
use rayon::prelude::*;

/// Which particle velocities the momentum sums of [`update_particle_velocities`] take.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum MomentumOf {
    /// The updated velocities (MUSL: the momentum the second mapping carries).
    Updated,
    /// The velocities before the update (USL: the momentum mapped in step 1).
    Previous,
}

/// Step 3: `v_p += dt phi^T(x_p) a` for the solid velocities `particles.v` (or `dt a_p`
/// with the mapping's own particle accelerations, [`Mapping::particle_accelerations`],
/// computed into `particle_acceleration`), returning `[sum_p m_p v_p, sum_p m_p |v_p|]` of
/// the velocities `momentum_of` names (the conservation check of the mapping, folded into
/// this pass; bitwise a separate [`deterministic_sums`](crate::numerics::sum::deterministic_sums)).
#[allow(clippy::too_many_arguments)]
pub(crate) fn update_particle_velocities<B: Basis, M: Mapping>(
    mapping: &mut M,
    basis: &B,
    shapes: Option<&ShapeCache>,
    particles: &mut Particles,
    acceleration: &[f64],
    particle_acceleration: &mut Vec<f64>,
    dt: f64,
    momentum_of: MomentumOf,
) -> [f64; 2] {
    if mapping.particle_accelerations(basis, particles, acceleration, particle_acceleration) {
        return add_particle_accelerations(
            &mut particles.v,
            &particles.mass,
            particle_acceleration,
            dt,
            momentum_of,
        );
    }
    let Particles {
        x,
        cell,
        volume,
        v,
        mass,
        ..
    } = particles;
    // Non-finite solid velocities are reported by `update_particles`.
    let momentum = Some((&mass[..], momentum_of));
    let (_, sums) = with_shape_source!(shapes, Evaluate, source => with_fixed_support!(basis, N => {
        update_velocities_n::<B, _, N>(basis, source, x, cell, volume, v, acceleration, dt, momentum)
    }));
    sums
}

/// `v_p += dt a_p` with per-particle accelerations, returning the momentum sums of
/// [`update_velocities_n`] (same blocks, same order).
fn add_particle_accelerations(
    velocity: &mut [f64],
    mass: &[f64],
    acceleration: &[f64],
    dt: f64,
    momentum_of: MomentumOf,
) -> [f64; 2] {
    let blocks: Vec<[f64; 2]> = velocity
        .par_chunks_mut(PARTICLES_PER_TASK)
        .enumerate()
        .map(|(chunk, v)| {
            let start = chunk * PARTICLES_PER_TASK;
            let mut sums = [0.0; 2];
            for (k, v) in v.iter_mut().enumerate() {
                let p = start + k;
                let previous = *v;
                *v += dt * acceleration[p];
                let counted = match momentum_of {
                    MomentumOf::Updated => *v,
                    MomentumOf::Previous => previous,
                };
                sums[0] += mass[p] * counted;
                sums[1] += mass[p] * counted.abs();
            }
            sums
        })
        .collect();
    sum_block_partials(&blocks)
}

/// `velocity_p += dt phi^T(x_p) a` for particles at `x` in `cell` with volumes `volume`
/// (any phase's particle velocities). Returns whether a velocity became non-finite.
pub(crate) fn update_velocities<B: Basis>(
    basis: &B,
    x: &[f64],
    cell: &[usize],
    volume: &[f64],
    velocity: &mut [f64],
    acceleration: &[f64],
    dt: f64,
) -> bool {
    with_fixed_support!(basis, N => update_velocities_n::<B, Evaluate, N>(
        basis, &Evaluate, x, cell, volume, velocity, acceleration, dt, None
    ))
    .0
}

/// [`update_velocities`] with the shapes from `source` and loops compiled for `N`
/// functions per particle ([`Basis::eval_particle_n`]), also returning
/// `[sum_p m_p v_p, sum_p m_p |v_p|]` over the velocities `momentum_of` names when masses
/// are given (zeros otherwise), summed per task block as [`deterministic_sums`](crate::numerics::sum::deterministic_sums) would.
#[allow(clippy::too_many_arguments)]
fn update_velocities_n<B: Basis, S: ShapeSource, const N: usize>(
    basis: &B,
    source: &S,
    x: &[f64],
    cell: &[usize],
    volume: &[f64],
    velocity: &mut [f64],
    acceleration: &[f64],
    dt: f64,
    momentum: Option<(&[f64], MomentumOf)>,
) -> (bool, [f64; 2]) {
    let blocks: Vec<(bool, [f64; 2])> = velocity
        .par_chunks_mut(PARTICLES_PER_TASK)
        .enumerate()
        .map(|(chunk, v)| {
            let start = chunk * PARTICLES_PER_TASK;
            // The fields cut to the chunk's range: one bound for all the indexing (as in
            // the particle update).
            let n = v.len();
            let (x, cell, volume) = (&x[start..][..n], &cell[start..][..n], &volume[start..][..n]);
            let momentum = momentum.map(|(mass, of)| (&mass[start..][..n], of));
            let mut shape = Shape::default();
            let mut bad = false;
            let mut sums = [0.0; 2];
            for (k, v) in v.iter_mut().enumerate() {
                let p = start + k;
                source.shape_of::<B, N>(basis, p, cell[k], x[k], 0.5 * volume[k], &mut shape);
                let previous = *v;
                *v += dt * shape.interpolate_n::<N>(acceleration);
                bad |= !v.is_finite();
                if let Some((mass, momentum_of)) = momentum {
                    let counted = match momentum_of {
                        MomentumOf::Updated => *v,
                        MomentumOf::Previous => previous,
                    };
                    sums[0] += mass[k] * counted;
                    sums[1] += mass[k] * counted.abs();
                }
            }
            (bad, sums)
        })
        .collect();
    let bad = blocks.iter().any(|b| b.0);
    let sums: Vec<[f64; 2]> = blocks.iter().map(|b| b.1).collect();
    (bad, sum_block_partials(&sums))
}
