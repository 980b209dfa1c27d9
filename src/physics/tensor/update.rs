//! The particle update of the dimension-generic core (steps 4–5 of
//! [`super::step`]): `x_p += dt phi^T v`, `u_p += dt phi^T v`, `L_p = sum_I v_I (x) grad
//! phi_I`, `F_p <- (I + dt L_p) F_p`, `V_p = det F_p V_p^0`, `sigma_p = law(...)`, the new
//! cells, the energies and the checks for non-finite fields, collapsed volumes and
//! particles that left the grid (`docs/dimensions.md`).
//!
//! Two drivers share the per-particle kernel [`update_particle`]: fixed chunks of
//! [`PARTICLES_PER_TASK`] particles, or the scatter tasks of the direct mapping, which then
//! also maps the next step's mass and force of each particle as it moves it
//! ([`crate::mapping::tensor_next`]: one pass over the particles less per step).

use super::material::{LinearElasticTensor, NeoHookeanTensor, TensorLaw, TensorMaterial};
use crate::grid::tensor::with_fixed_support;
use crate::grid::{Basis, TensorBasis, TensorShape, TensorShapeSource};
use crate::mapping::tensor_direct::TensorBody;
use crate::mapping::tensor_next::NextMassForce;
use crate::particles::TensorParticles;
use rayon::prelude::*;
use std::ops::Range;

/// Particles per rayon task in the particle update (without the next step's map).
const PARTICLES_PER_TASK: usize = 2048;

/// What the particle update found.
pub(super) struct Outcome {
    pub(super) crossings: usize,
    /// Particles now more than `Bins::slack` layers of cells away from their bin.
    pub(super) strays: usize,
    /// First failing particle (lowest index) and the failing field ("volume", "left" for
    /// a particle outside the grid, or the non-finite field's name).
    pub(super) failure: Option<(usize, &'static str)>,
    /// Kinetic and stored energy after the step (summed per chunk, then in chunk order).
    pub(super) energies: (f64, f64),
    /// Whether the update also mapped the next step's mass and force for every particle
    /// ([`ParticleUpdate::run_mapping_next`]).
    pub(super) mapped_next: bool,
}

/// The binning the particle update checks against: the layer of each particle's bin and
/// how far a particle may stray from it
/// ([`crate::mapping::tensor::TensorMapping::bin_slack`]).
#[derive(Clone, Copy)]
pub(super) struct Bins<'a> {
    pub(super) layer: &'a [u32],
    pub(super) slack: usize,
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

/// The mutable fields of one chunk of particles (see [`ParticleUpdate`]).
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

/// The arguments of the particle update other than the particles and the shape source.
pub(super) struct ParticleUpdate<'a, const D: usize, B: Basis> {
    pub(super) basis: &'a TensorBasis<D, B>,
    pub(super) half_length0: Option<[f64; D]>,
    pub(super) bins: Bins<'a>,
    pub(super) velocity: &'a [[f64; D]],
    pub(super) usl_acceleration: Option<&'a [[f64; D]]>,
    pub(super) dt: f64,
    pub(super) material: TensorMaterial,
}

/// Sums of one chunk (or task) of the update, added over the chunks in order.
#[derive(Default)]
struct ChunkSums {
    crossings: usize,
    strays: usize,
    failure: Option<(usize, &'static str)>,
    kinetic: f64,
    stored: f64,
}

impl<const D: usize, B: Basis> ParticleUpdate<'_, D, B> {
    /// Update `particles` in fixed chunks, the shapes taken from `source` (compiled for
    /// the basis' support and the law: one dispatch).
    pub(super) fn run<S: TensorShapeSource<D>>(
        &self,
        source: &S,
        particles: &mut TensorParticles<D>,
    ) -> Outcome {
        with_fixed_support!(self.basis, N => match self.material {
            TensorMaterial::Linear(law) => self.chunked::<LinearElasticTensor, N, S>(
                source, particles, law,
            ),
            TensorMaterial::NeoHookean(law) => self.chunked::<NeoHookeanTensor, N, S>(
                source, particles, law,
            ),
        })
    }

    /// Update `particles` task by task of `next`'s scatter, each particle's current shape
    /// read from `next`'s cache and its next shape, mass and force mapped there with the
    /// next step's body force `next_body` ([`crate::mapping::tensor_next`]). The result is
    /// kept ([`Outcome::mapped_next`]) when no particle strayed from its bin or failed.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn run_mapping_next<'n>(
        &self,
        mut next: NextMassForce<'n, D>,
        next_body: TensorBody<'_, D>,
        cell_start: &[usize],
        particles: &mut TensorParticles<D>,
        mass_force: &mut [[f64; 4]],
    ) -> (Outcome, NextMassForce<'n, D>) {
        let outcome = with_fixed_support!(self.basis, N => match self.material {
            TensorMaterial::Linear(law) => self.mapping_next::<LinearElasticTensor, N>(
                &mut next, next_body, cell_start, particles, mass_force, law,
            ),
            TensorMaterial::NeoHookean(law) => self.mapping_next::<NeoHookeanTensor, N>(
                &mut next, next_body, cell_start, particles, mass_force, law,
            ),
        });
        (outcome, next)
    }

    fn chunked<L: TensorLaw, const N: usize, S: TensorShapeSource<D>>(
        &self,
        source: &S,
        particles: &mut TensorParticles<D>,
        law: L,
    ) -> Outcome {
        let n = particles.len();
        let ranges: Vec<Range<usize>> = (0..n)
            .step_by(PARTICLES_PER_TASK)
            .map(|s| s..(s + PARTICLES_PER_TASK).min(n))
            .collect();
        let mass = std::mem::take(&mut particles.mass);
        let volume0 = std::mem::take(&mut particles.volume0);
        let sums: Vec<ChunkSums> = chunks_of(particles, &ranges)
            .into_par_iter()
            .map(|mut c| {
                let mut sums = ChunkSums::default();
                let mut shape = TensorShape::<D>::default();
                for i in 0..c.volume.len() {
                    self.update_particle::<L, N, S>(
                        source, &law, &mut c, i, &mass, &volume0, &mut sums, &mut shape,
                    );
                }
                sums
            })
            .collect();
        particles.mass = mass;
        particles.volume0 = volume0;
        Outcome::of(sums, false)
    }

    fn mapping_next<L: TensorLaw, const N: usize>(
        &self,
        next: &mut NextMassForce<'_, D>,
        next_body: TensorBody<'_, D>,
        cell_start: &[usize],
        particles: &mut TensorParticles<D>,
        mass_force: &mut [[f64; 4]],
        law: L,
    ) -> Outcome {
        let ranges = next.task_ranges(cell_start);
        let mass = std::mem::take(&mut particles.mass);
        let volume0 = std::mem::take(&mut particles.volume0);
        let mut sums: Vec<ChunkSums> = (0..ranges.len()).map(|_| ChunkSums::default()).collect();
        let states: Vec<_> = chunks_of(particles, &ranges)
            .into_iter()
            .zip(sums.iter_mut())
            .collect();
        let (basis, live) = (self.basis, live_stress_components(D));
        next.run(
            basis,
            cell_start,
            states,
            next_body,
            mass_force,
            |(mut c, sums): (ChunkMut<'_, D>, &mut ChunkSums), _, task| {
                let (mut shape, mut next_shape) = (TensorShape::default(), TensorShape::default());
                for i in 0..c.volume.len() {
                    let Some(cell) = self.update_particle::<L, N, _>(
                        &task.slots,
                        &law,
                        &mut c,
                        i,
                        &mass,
                        &volume0,
                        sums,
                        &mut shape,
                    ) else {
                        continue;
                    };
                    let k = c.start + i;
                    let stress = &c.stress;
                    task.map::<B, N>(
                        basis,
                        k,
                        cell,
                        std::array::from_fn(|a| c.x[a][i]),
                        std::array::from_fn(|a| c.f[a][a][i]),
                        mass[k],
                        c.volume[i],
                        |s| if s < live { stress[s][i] } else { 0.0 },
                        &mut next_shape,
                    );
                }
            },
        );
        particles.mass = mass;
        particles.volume0 = volume0;
        Outcome::of(sums, true)
    }

    /// Steps 4–5 and the new cell of particle `c.start + i` (see the module doc); with
    /// `usl_acceleration` also `v_p += dt phi^T a`. Returns the particle's axis cell
    /// indices when it is in the grid, healthy and within the bin slack.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn update_particle<L: TensorLaw, const N: usize, S: TensorShapeSource<D>>(
        &self,
        source: &S,
        law: &L,
        c: &mut ChunkMut<'_, D>,
        i: usize,
        mass: &[f64],
        volume0: &[f64],
        sums: &mut ChunkSums,
        shape: &mut TensorShape<D>,
    ) -> Option<[usize; D]> {
        let (basis, bins, dt, grid) = (self.basis, self.bins, self.dt, self.basis.grid);
        let strides = *basis.strides();
        let live = live_stress_components(D);
        let k = c.start + i;
        let x: [f64; D] = std::array::from_fn(|a| c.x[a][i]);
        let f_old: [[f64; D]; D] = std::array::from_fn(|a| std::array::from_fn(|b| c.f[a][b][i]));
        let half = match self.half_length0 {
            Some(l0) => std::array::from_fn(|a| l0[a] * f_old[a][a].abs()),
            None => [0.0; D],
        };
        source.shape_of::<B, N>(basis, k, x, half, shape);
        let (v_grid, l) = shape.interpolate_with_gradient_n::<N>(&strides, self.velocity);
        if let Some(a) = self.usl_acceleration {
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
        let dl: [[f64; D]; D] = std::array::from_fn(|a| std::array::from_fn(|b| dt * l[a][b]));
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
        sums.stored += law.update_with_energy(&mut stress, &dl, &f, j, volume0[k]);
        let mut speed2 = 0.0;
        for d in 0..D {
            speed2 += c.v[d][i] * c.v[d][i];
        }
        sums.kinetic += 0.5 * mass[k] * speed2;
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
                sums.crossings += usize::from(e != c.cell[i]);
                c.cell[i] = e;
                let stray = index[D - 1].abs_diff(bins.layer[k] as usize) > bins.slack;
                sums.strays += usize::from(stray);
                (!stray).then_some(index)
            }
            (None, None) => {
                sums.failure = sums.failure.or(Some((k, "left")));
                None
            }
            (Some(b), _) => {
                sums.failure = sums.failure.or(Some((k, b)));
                None
            }
        }
    }
}

impl Outcome {
    /// The chunks' sums added in chunk order (deterministic for any thread count);
    /// `mapped_next` when the chunks mapped the next step and nobody strayed or failed.
    fn of(sums: Vec<ChunkSums>, mapped_next: bool) -> Self {
        let mut outcome = Outcome {
            crossings: 0,
            strays: 0,
            failure: None,
            energies: (0.0, 0.0),
            mapped_next: false,
        };
        for s in sums {
            outcome.crossings += s.crossings;
            outcome.strays += s.strays;
            outcome.failure = outcome.failure.or(s.failure);
            outcome.energies.0 += s.kinetic;
            outcome.energies.1 += s.stored;
        }
        outcome.mapped_next = mapped_next && outcome.strays == 0 && outcome.failure.is_none();
        outcome
    }
}
