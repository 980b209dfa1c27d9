//! The two-phase MUSL step (SPEC §2.1), v–w formulation on one set of particles.
//!
//! Three mapped "phases" share positions, volumes and cells:
//!
//! ```text
//! solid:        mass (1-n_p)(m_s)_p, stress sigma'_p, velocity (v_s)_p  -> m_s, M_s, f'_int, p_s
//! liquid:       mass (m_w)_p,        stress p_p                         -> m_w, M_w, f_w_int
//! liquid (bar): mass n_p (m_w)_p,    velocity (v_w)_p                   -> mbar_w, Mbar_w, pbar_w
//! ```
//! Each goes through its own instance of the mapping (direct, TLS, cubic spline, ...), so
//! a conservative reconstruction conserves both phases' mass and momentum. One step:
//!
//! ```text
//! 1. map the three phases; start velocities v_s = M_s^-1 p_s, v_w = Mbar_w^-1 pbar_w
//! 2. f_w_ext = b m_w + (g/k) Mbar_w (v_s - v_w) + liquid traction (drag)
//!    M_w a_w = f_w_ext - f_w_int                                  a_w = 0 where v_w fixed
//! 3. f_s_int = f'_int + f_w_int (total stress sigma' + p), f_s_ext = b (m_s + mbar_w) + q
//!    M_s a_s = f_s_ext - f_s_int - Mbar_w a_w                     a_s = 0 where u_s fixed
//! 4. (v_s)_p += dt phi^T a_s,  (v_w)_p += dt phi^T a_w
//! 5. MUSL: M_s v_s = p_s(updated), Mbar_w v_w = pbar_w(updated)
//! 6. p_p += dt (K_w / n_p) dphi^T ((1 - n_p) v_s + n_p v_w)
//! 7. solid kinematics and sigma'_p as in the one-phase step (SPEC §2 steps 5-8)
//! ```
//! `M` is lumped or consistent per `method.acceleration_mass` (M_w, M_s, the coupling
//! `Mbar_w a_w` and the drag) and `method.mass` (velocity solves). The permeability is a
//! material constant, so the drag is `(g/k) Mbar_w (v_s - v_w)`, mapped like the liquid
//! mass: with a consistent acceleration mass the drag matrix is consistent too (with a
//! lumped drag against a consistent `M_w`, the large pressure gradient and drag of the
//! quasi-static balance no longer cancel to high order).
//! Conservation errors are measured per phase, like the one-phase step, on the mapping at
//! the start of the step and on the MUSL mapping after the particle velocity update.

use super::material::TwoPhaseMaterial;
use crate::config::MassKind;
use crate::error::{Error, Result};
use crate::grid::{Basis, Grid, Shape};
use crate::linalg::CsrMatrix;
use crate::mapping::{GridFields, Mapping, RemedyCounts};
use crate::numerics::sum::{deterministic_sum, deterministic_sums};
use crate::particles::{CellBins, LiquidFields, Particles};
use crate::physics::step::{
    at_step, copy_into, phase_momentum_error, quadrature, sync_view, StepReport, TimeStepper,
    PARTICLES_PER_TASK,
};
use crate::physics::update::update_particles_with;
use crate::physics::velocity::update_velocities;
use crate::physics::{Body, Boundary, MassSystem, SolverTotals};
use rayon::prelude::*;

/// Boundary conditions of each phase: the solid one carries the total-stress traction, the
/// liquid one the prescribed pore pressure of a drained end (as a traction on the liquid)
/// and `v_w = 0` at an impermeable fixed end.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TwoPhaseBoundary {
    pub solid: Boundary,
    pub liquid: Boundary,
}

/// One mapped phase: its mapping instance, grid vectors and mass solves.
struct Phase<M: Mapping> {
    mapping: M,
    fields: GridFields,
    mass: MassSystem,
    /// Sum of the particle masses of the phase (constant).
    total_mass: f64,
}

impl<M: Mapping> Phase<M> {
    fn new(mapping: M, dofs: usize, bandwidth: usize, mass: MassSystem, total: f64) -> Self {
        let mut fields = GridFields::new(dofs);
        if mass.needs_matrix() {
            fields.consistent_mass = Some(CsrMatrix::band(dofs, bandwidth));
        }
        Self {
            mapping,
            fields,
            mass,
            total_mass: total,
        }
    }

    /// `|sum_i m_i - sum_p m_p| / sum_p m_p` of the last mapping.
    fn mass_error(&self) -> f64 {
        let grid_mass: f64 = self.fields.mass.iter().sum();
        (grid_mass - self.total_mass).abs() / self.total_mass
    }
}

/// The three linear solvers of a two-phase stepper (`solver.kind`).
pub struct PhaseSolvers {
    pub solid: MassSystem,
    pub liquid: MassSystem,
    pub liquid_bar: MassSystem,
}

/// The two-phase time stepper, generic over the basis and the mapping.
pub struct TwoPhaseStepper<B: Basis, M: Mapping> {
    pub grid: Grid,
    pub basis: B,
    pub material: TwoPhaseMaterial,
    pub boundary: TwoPhaseBoundary,
    pub dt: f64,
    pub bins: CellBins,
    acceleration_mass: MassKind,
    solid: Phase<M>,
    liquid: Phase<M>,
    liquid_bar: Phase<M>,
    /// The liquid phases as particle arrays for the mappings (positions copied each step).
    liquid_view: Particles,
    liquid_bar_view: Particles,
    /// `Mbar_w a_w`.
    coupling: Vec<f64>,
}

impl<B: Basis, M: Mapping + Clone> TwoPhaseStepper<B, M> {
    /// A stepper for two-phase `particles` (which must carry liquid fields), binned here.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        grid: Grid,
        basis: B,
        mapping: M,
        material: TwoPhaseMaterial,
        boundary: TwoPhaseBoundary,
        dt: f64,
        acceleration_mass: MassKind,
        solvers: PhaseSolvers,
        particles: &mut Particles,
    ) -> Result<Self> {
        let liquid = particles.liquid.as_ref().ok_or_else(missing_liquid)?;
        let total_liquid = deterministic_sum(particles.len(), |p| liquid.mass[p]);
        let total_bar = deterministic_sum(particles.len(), |p| liquid.porosity[p] * liquid.mass[p]);
        let mut bins = CellBins::default();
        bins.sort(particles, grid.cells);
        let mut basis = basis;
        if basis.depends_on_particles() {
            basis.update(quadrature(particles, &bins));
        }
        let total_solid = deterministic_sum(particles.len(), |p| particles.mass[p]);
        let (dofs, bandwidth) = (basis.num_dofs(), basis.max_window() - 1);
        Ok(Self {
            grid,
            basis,
            material,
            boundary,
            dt,
            bins,
            acceleration_mass,
            solid: Phase::new(mapping.clone(), dofs, bandwidth, solvers.solid, total_solid),
            liquid: Phase::new(
                mapping.clone(),
                dofs,
                bandwidth,
                solvers.liquid,
                total_liquid,
            ),
            liquid_bar: Phase::new(mapping, dofs, bandwidth, solvers.liquid_bar, total_bar),
            liquid_view: Particles::default(),
            liquid_bar_view: Particles::default(),
            coupling: vec![0.0; dofs],
        })
    }
}

fn missing_liquid() -> Error {
    Error::invalid(
        "material.model",
        "\"two_phase\"",
        "the particles of this problem carry no liquid fields",
    )
}

impl<B: Basis, M: Mapping> TwoPhaseStepper<B, M> {
    /// Advance by one step with body acceleration `body`; `step` and `time` (end of the
    /// step) label failures.
    pub fn step(
        &mut self,
        particles: &mut Particles,
        body: Body<'_>,
        step: usize,
        time: f64,
    ) -> Result<StepReport> {
        let Body::Uniform(body) = body else {
            return Err(Error::invalid(
                "material.model",
                "\"two_phase\"",
                "a body force that varies between particles is one-phase only",
            ));
        };
        let dt = self.dt;
        let ends = self.basis.boundary_dofs();
        if self.basis.depends_on_particles() {
            self.basis.update(quadrature(particles, &self.bins));
        }
        let basis = &self.basis;
        let bins = &self.bins;
        let (solid, liquid, bar) = (&mut self.solid, &mut self.liquid, &mut self.liquid_bar);
        {
            let fields = particles.liquid.as_ref().ok_or_else(missing_liquid)?;
            let (n, m) = (&fields.porosity, &fields.mass);
            sync_view(
                &mut self.liquid_view,
                particles,
                |p| m[p],
                Some(&fields.pore_pressure),
                &fields.velocity,
            );
            sync_view(
                &mut self.liquid_bar_view,
                particles,
                |p| n[p] * m[p],
                None,
                &fields.velocity,
            );
        }

        // 1. Mapping of the three phases, start-of-step grid velocities.
        solid
            .mapping
            .map_mass_and_internal_force(basis, particles, bins, &mut solid.fields);
        liquid.mapping.map_mass_and_internal_force(
            basis,
            &self.liquid_view,
            bins,
            &mut liquid.fields,
        );
        bar.mapping.map_mass_and_internal_force(
            basis,
            &self.liquid_bar_view,
            bins,
            &mut bar.fields,
        );
        solid
            .mapping
            .map_momentum(basis, particles, bins, &mut solid.fields);
        bar.mapping
            .map_momentum(basis, &self.liquid_bar_view, bins, &mut bar.fields);
        let mass_error = solid.mass_error();
        let liquid_mass_error = liquid.mass_error().max(bar.mass_error());
        if !(mass_error.is_finite() && liquid_mass_error.is_finite()) {
            return Err(Error::NonFinite {
                field: "grid mass",
                step,
                time,
            });
        }
        let mut momentum_error =
            phase_momentum_error(&particles.mass, &particles.v, &solid.fields, 0.0);
        let mut liquid_momentum_error = phase_momentum_error(
            &self.liquid_bar_view.mass,
            &self.liquid_bar_view.v,
            &bar.fields,
            0.0,
        );
        let fixed_solid = self.boundary.solid.fixed_dofs(ends);
        let fixed_liquid = self.boundary.liquid.fixed_dofs(ends);
        solid.mass.prepare(&solid.fields, fixed_solid.as_slice());
        liquid.mass.prepare(&liquid.fields, fixed_liquid.as_slice());
        bar.mass.prepare(&bar.fields, fixed_liquid.as_slice());
        solid
            .mass
            .velocities(&mut solid.fields, 0.0)
            .map_err(|e| at_step(e, step, time))?;
        bar.mass
            .velocities(&mut bar.fields, 0.0)
            .map_err(|e| at_step(e, step, time))?;

        // 2. Liquid: drag, body force, drained-end pressure; a_w. The drag is
        //    `(g/k) int n rho_w (v_s - v_w) phi`, with the same (lumped or consistent)
        //    mass as the acceleration.
        let drag = self.material.gravity / self.material.permeability;
        for (c, (s, w)) in self
            .coupling
            .iter_mut()
            .zip(solid.fields.velocity.iter().zip(&bar.fields.velocity))
        {
            *c = s - w;
        }
        let consistent = match self.acceleration_mass {
            MassKind::Consistent => bar.fields.consistent_mass.as_ref(),
            MassKind::Lumped => None,
        };
        // external_force = Mbar_w (v_s - v_w), then scaled and the body force added.
        apply_mass(
            consistent,
            &bar.fields.mass,
            &self.coupling,
            &mut liquid.fields.external_force,
        );
        for (f, m_w) in liquid
            .fields
            .external_force
            .iter_mut()
            .zip(&liquid.fields.mass)
        {
            *f = drag * *f + body * m_w;
        }
        let surfaces = quadrature(particles, bins).material_extent();
        self.boundary.liquid.add_surface_tractions(
            basis,
            &self.grid,
            surfaces,
            &mut liquid.fields.external_force,
        );
        liquid
            .mass
            .accelerations(&mut liquid.fields)
            .map_err(|e| at_step(e, step, time))?;

        // 3. Mixture: total-stress internal force, coupling Mbar_w a_w; a_s.
        apply_mass(
            consistent,
            &bar.fields.mass,
            &liquid.fields.acceleration,
            &mut self.coupling,
        );
        for i in 0..solid.fields.mass.len() {
            solid.fields.internal_force[i] += liquid.fields.internal_force[i];
            solid.fields.external_force[i] =
                body * (solid.fields.mass[i] + bar.fields.mass[i]) - self.coupling[i];
        }
        self.boundary.solid.add_surface_tractions(
            basis,
            &self.grid,
            surfaces,
            &mut solid.fields.external_force,
        );
        solid
            .mass
            .accelerations(&mut solid.fields)
            .map_err(|e| at_step(e, step, time))?;

        // 4. Particle velocities of both phases.
        {
            let Particles {
                x,
                cell,
                volume,
                v,
                liquid: liquid_fields,
                ..
            } = &mut *particles;
            // Non-finite solid velocities are reported by `update_particles` below.
            let _ = update_velocities(basis, x, cell, volume, v, &solid.fields.acceleration, dt);
            let fields = liquid_fields.as_mut().ok_or_else(missing_liquid)?;
            if update_velocities(
                basis,
                x,
                cell,
                volume,
                &mut fields.velocity,
                &liquid.fields.acceleration,
                dt,
            ) {
                return Err(Error::NonFinite {
                    field: "liquid velocity",
                    step,
                    time,
                });
            }
            copy_into(&mut self.liquid_bar_view.v, &fields.velocity);
        }

        // 5. MUSL grid velocities of both phases.
        solid
            .mapping
            .map_momentum(basis, particles, bins, &mut solid.fields);
        bar.mapping
            .map_momentum(basis, &self.liquid_bar_view, bins, &mut bar.fields);
        let imbalance = solid
            .mass
            .velocities(&mut solid.fields, 0.0)
            .map_err(|e| at_step(e, step, time))?;
        let liquid_imbalance = bar
            .mass
            .velocities(&mut bar.fields, 0.0)
            .map_err(|e| at_step(e, step, time))?;
        momentum_error = max_error(
            momentum_error,
            phase_momentum_error(&particles.mass, &particles.v, &solid.fields, imbalance),
        );
        liquid_momentum_error = max_error(
            liquid_momentum_error,
            phase_momentum_error(
                &self.liquid_bar_view.mass,
                &self.liquid_bar_view.v,
                &bar.fields,
                liquid_imbalance,
            ),
        );

        // 6. Pore pressure (before the particles move: same basis values as the strain).
        let bad_pressure = update_pore_pressure(
            basis,
            particles,
            &solid.fields.velocity,
            &bar.fields.velocity,
            self.material.bulk_modulus_liquid * dt,
        );
        if bad_pressure {
            return Err(Error::NonFinite {
                field: "pore pressure",
                step,
                time,
            });
        }

        // 7. Solid kinematics and effective stress.
        let outcome = update_particles_with(
            self.material.skeleton,
            basis,
            None,
            &self.grid,
            particles,
            &solid.fields.velocity,
            None,
            dt,
        );
        outcome.check(particles, step, time)?;
        outcome.rebin(&mut self.bins, particles, self.grid.cells);
        Ok(StepReport {
            mass_error,
            momentum_error,
            liquid_mass_error: Some(liquid_mass_error),
            liquid_momentum_error,
            crossings: outcome.crossings,
            // The liquid's energies are not part of the solid update.
            energies: None,
            mapped_ahead: false,
        })
    }

    /// Kinetic energy `sum_p ((m_s)_p v_s^2 + n_p (m_w)_p v_w^2) / 2` and stored energy
    /// `sum_p V_p (W(sigma'_p) + n_p p_p^2 / (2 K_w))`.
    pub fn energies(&self, particles: &Particles) -> (f64, f64) {
        let Some(liquid) = particles.liquid.as_ref() else {
            return (0.0, 0.0);
        };
        let skeleton = self.material.skeleton;
        let k_w = self.material.bulk_modulus_liquid;
        let [kinetic, stored] = deterministic_sums(particles.len(), |p| {
            let (n, v_w, pressure) = (
                liquid.porosity[p],
                liquid.velocity[p],
                liquid.pore_pressure[p],
            );
            [
                0.5 * (particles.mass[p] * particles.v[p] * particles.v[p]
                    + n * liquid.mass[p] * v_w * v_w),
                particles.volume[p]
                    * (skeleton.strain_energy_density(
                        particles.stress[p],
                        particles.deformation_gradient[p],
                    ) + 0.5 * n * pressure * pressure / k_w),
            ]
        });
        (kinetic, stored)
    }
}

/// `out = M x` with the consistent matrix `M` when given, else with the lumped `m`.
fn apply_mass(consistent: Option<&CsrMatrix>, lumped: &[f64], x: &[f64], out: &mut [f64]) {
    match consistent {
        Some(matrix) => matrix.mul_vec(x, out),
        None => {
            for (o, (m, x)) in out.iter_mut().zip(lumped.iter().zip(x)) {
                *o = m * x;
            }
        }
    }
}

/// The larger of two optional errors.
fn max_error(a: Option<f64>, b: Option<f64>) -> Option<f64> {
    match (a, b) {
        (Some(a), Some(b)) => Some(a.max(b)),
        (a, b) => a.or(b),
    }
}

/// Step 6: `p_p += dt K_w / n_p dphi^T ((1 - n_p) v_s + n_p v_w)`, with `dt_k = dt K_w`.
/// Returns whether a pressure became non-finite.
fn update_pore_pressure<B: Basis>(
    basis: &B,
    particles: &mut Particles,
    solid_velocity: &[f64],
    liquid_velocity: &[f64],
    dt_k: f64,
) -> bool {
    let Particles {
        x,
        cell,
        volume,
        liquid,
        ..
    } = particles;
    let Some(LiquidFields {
        porosity,
        pore_pressure,
        ..
    }) = liquid.as_mut()
    else {
        return false;
    };
    pore_pressure
        .par_chunks_mut(PARTICLES_PER_TASK)
        .enumerate()
        .map(|(chunk, pressure)| {
            let start = chunk * PARTICLES_PER_TASK;
            let mut shape = Shape::default();
            let mut bad = false;
            for (k, p_p) in pressure.iter_mut().enumerate() {
                let p = start + k;
                basis.eval_particle(cell[p], x[p], 0.5 * volume[p], &mut shape);
                let n = porosity[p];
                let rate = (1.0 - n) * shape.gradient(solid_velocity)
                    + n * shape.gradient(liquid_velocity);
                *p_p += dt_k / n * rate;
                bad |= !p_p.is_finite();
            }
            bad
        })
        .reduce(|| false, |a, b| a || b)
}

impl<B: Basis + 'static, M: Mapping + 'static> TimeStepper for TwoPhaseStepper<B, M> {
    fn step(
        &mut self,
        particles: &mut Particles,
        body: Body<'_>,
        step: usize,
        time: f64,
    ) -> Result<StepReport> {
        TwoPhaseStepper::step(self, particles, body, step, time)
    }
    fn dt(&self) -> f64 {
        self.dt
    }
    fn grid(&self) -> &Grid {
        &self.grid
    }
    fn energies(&self, particles: &Particles) -> (f64, f64) {
        TwoPhaseStepper::energies(self, particles)
    }
    fn method_names(&self) -> (&'static str, &'static str) {
        (self.basis.name(), self.solid.mapping.name())
    }
    fn solver_totals(&self) -> SolverTotals {
        SolverTotals::of(&[&self.solid.mass, &self.liquid.mass, &self.liquid_bar.mass])
    }
    fn remedies(&self) -> RemedyCounts {
        let mut total = self.solid.mapping.remedies();
        total += self.liquid.mapping.remedies();
        total += self.liquid_bar.mapping.remedies();
        total
    }
}
