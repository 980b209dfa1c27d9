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
//! strayed more than `TensorMapping::bin_slack` layers of cells from its bin: 0 for a
//! mapping that needs the arrays in exact cell order; the direct mapping and TLS take 1),
//! and the
//! conservation errors of the mapping: mass `|sum_I m_I - sum_p m_p| / sum_p m_p`, and per
//! momentum component `|sum_I p_I - sum_p m_p v_p| / sum_p m_p |v_p|`, the largest over
//! the components.
//!
//! [`TensorStepper::step_ahead`] also maps the next step's mass and force (step 1) inside
//! steps 4–5 where the mapping lends its scatter for it ([`crate::mapping::tensor_next`]):
//! the next step then starts at step 2.

use super::boundary::NodeConstraints;
use super::mass::TensorMassSolve;
use super::material::{TensorLaw, TensorMaterial};
use super::timings::{PhaseClock, StepTimings};
use super::update::{Bins, ParticleUpdate};
use crate::config::MassKind;
use crate::config::Scheme;
use crate::error::{Error, Result};
use crate::grid::shape_cache::with_shape_source;
use crate::grid::{Basis, EvaluateTensor, TensorBasis};
use crate::linalg::CsrMatrix;
use crate::mapping::tensor::TensorMapping;
use crate::mapping::tensor_direct::{TensorBody, TensorDirectMapping, TensorGridFields};
use crate::numerics::sum::{deterministic_sum, deterministic_sums};
use crate::particles::TensorParticles;
use crate::physics::distributed::{momentum_error_over_ranks, RankContext, RankExchange};
use rayon::prelude::*;
use std::sync::Arc;

pub use super::update::determinant;

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
    /// Whether the last step's particle update mapped this step's mass and force
    /// ([`Self::step_ahead`]).
    mapped_ahead: bool,
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
            mapped_ahead: false,
        };
        stepper.sort(particles);
        stepper
    }

    /// Counting-sort `particles` by cell and record each particle's bin layer.
    fn sort(&mut self, particles: &mut TensorParticles<D>) {
        self.mapped_ahead = false;
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
        self.step_ahead(particles, body, None, dt, step, time)
    }

    /// [`Self::step`]; with `next_body`, the body force the next step will be called
    /// with, the particle update also maps the next step's mass and force where the
    /// mapping lends its scatter for it ([`TensorMapping::next_mass_and_force`]; one pass
    /// over the particles less per step, bitwise the same grid values). The next call
    /// must then pass `next_body` as its `body`, for the same particles.
    pub fn step_ahead(
        &mut self,
        particles: &mut TensorParticles<D>,
        body: TensorBody<'_, D>,
        next_body: Option<TensorBody<'_, D>>,
        dt: f64,
        step: usize,
        time: f64,
    ) -> Result<TensorStepReport> {
        let fields = &mut self.fields;
        let mut clock = PhaseClock::start();
        let mut solve_seconds = 0.0;
        // 1. Mass and force (unless the last update mapped them).
        if !std::mem::take(&mut self.mapped_ahead) {
            self.mapping.map_mass_and_force(
                &self.basis,
                particles,
                &self.cell_start,
                body,
                fields,
            )?;
        }
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
            Some(solve) if consistent_acceleration => {
                solve.accelerations(fields, assembled_mass(&self.mapping)?)?
            }
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
                    Some(solve) if consistent_velocity => {
                        solve.velocities(fields, assembled_mass(&self.mapping)?)?
                    }
                    _ => divide_by_mass(&fields.mass, &fields.momentum, &mut fields.velocity),
                }
            }
            Scheme::Usl => {
                match &mut self.mass_solve {
                    Some(solve) if consistent_velocity => {
                        solve.velocities(fields, assembled_mass(&self.mapping)?)?
                    }
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
        let TensorGridFields {
            velocity,
            acceleration,
            mass_force,
            ..
        } = &mut *fields;
        let slack = self.mapping.bin_slack();
        let update = ParticleUpdate {
            basis: &self.basis,
            half_length0: *self.mapping.particle_domains(),
            bins: Bins {
                layer: &self.bin_layer,
                slack,
            },
            velocity,
            usl_acceleration: (self.scheme == Scheme::Usl).then_some(&acceleration[..]),
            dt,
            material: self.material,
        };
        let next = match next_body {
            Some(body) if self.ranks.is_none() => {
                self.mapping.next_mass_and_force().zip(Some(body))
            }
            _ => None,
        };
        let mut outcome = match next {
            Some((next, next_body)) => {
                let (outcome, next) = update.run_mapping_next(
                    next,
                    next_body,
                    &self.cell_start,
                    particles,
                    mass_force,
                );
                next.finish(outcome.mapped_next, fields);
                outcome
            }
            None => {
                let outcome = with_shape_source!(self.mapping.shapes(), EvaluateTensor, source => {
                    update.run(source, particles)
                });
                self.mapping.forget_shapes();
                outcome
            }
        };
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
            || if slack == 0 {
                outcome.crossings > 0
            } else {
                outcome.strays > 0
            };
        if sorted {
            self.sort(particles);
        } else {
            self.mapped_ahead = outcome.mapped_next;
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

    /// Whether [`Self::step_ahead`] maps the next step's mass and force in the particle
    /// update (the mapping lends its scatter for it, one process).
    pub fn maps_ahead(&mut self) -> bool {
        self.ranks.is_none() && self.mapping.next_mass_and_force().is_some()
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

/// The consistent mass `mapping` assembled this step (an error where it assembled none:
/// a mapping without `M^C` paired with a consistent-mass solve).
fn assembled_mass<const D: usize, M: TensorMapping<D>>(mapping: &M) -> Result<&CsrMatrix> {
    mapping.consistent_mass().ok_or_else(|| Error::Solver {
        solver: "consistent mass".into(),
        reason: "the mapping assembled no consistent mass matrix".into(),
    })
}
