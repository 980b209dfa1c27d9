//! The one-phase Euler–Cromer step (SPEC §2), MUSL (default) or USL.
//!
//! ```text
//! 1. m_i (and M^C), f_int_i by the mapping; f_ext_i = b m_i + tractions
//! 2. M a = f_ext - f_int;                          a_i = 0 on fixed DOFs
//! 3. v_p += dt sum_i phi_i(x_p) a_i
//! 4. MUSL: M v = p(updated v_p)
//!    USL:  M v = p(v_p^old), v += dt a;            v_i = 0 on fixed DOFs
//! 5. du_i = dt v_i
//! 6. u_p += phi^T du, x_p += phi^T du, deps_p = dphi^T du
//! 7. sigma_p = law(sigma_p, deps_p)
//! 8. V_p *= 1 + deps_p, rho_p /= 1 + deps_p
//! ```
//! Bases that depend on the particle configuration (DDMPM) are updated from it before
//! step 1, and particle-domain bases (GIMP, CPDI) are evaluated with `l_p = V_p / 2`;
//! then the particles are re-binned (a scan of the cell boundaries while they stay in cell
//! order, else the counting sort) and grid crossings counted. The basis is evaluated at
//! the particles once per step when that pays ([`Basis::reuse_shapes`], a
//! [`ShapeCache`] read by every pass at the same positions; with the direct mapping the
//! previous step's particle update fills it and maps step 1's `m_i` and `f_int_i` on the
//! way, [`crate::mapping::next`]), and the particle loops are compiled for the basis'
//! fixed support. The
//! conservation errors of the mapping are measured each step (SPEC §6): mass
//! `|sum_i m_i - sum_p m_p| / sum_p m_p` after step 1; momentum, with
//! `scale = sum_p m_p |v_p|`, the larger of the mapping error `|sum_i p_i - sum_p m_p v_p|`
//! (before the velocity solve) and, for a consistent mass matrix, the solve's imbalance
//! `|sum_i ((M v)_i - p_i)|` over the active free DOFs (after it). `M` is the lumped or
//! consistent matrix of [`MassSystem`].

use crate::config::Scheme;
use crate::error::{Error, Result};
use crate::grid::{Basis, Grid, ParticleQuadrature, ShapeCache};
use crate::linalg::CsrMatrix;
use crate::mapping::{GridFields, Mapping, RemedyCounts};
use crate::numerics::sum::{deterministic_sum, deterministic_sums};
use crate::particles::{CellBins, Particles};
use crate::physics::update::{update_particles_mapping_next, update_particles_with};
use crate::physics::velocity::{update_particle_velocities, MomentumOf};
use crate::physics::{Body, Boundary, MassSystem, Material, SolverTotals};

/// Particles per rayon task in particle loops: one block of [`deterministic_sums`], so
/// the bookkeeping sums folded into these loops (energies, particle momentum) are summed
/// in the same order, with the same bits, as a separate deterministic pass would.
pub(crate) const PARTICLES_PER_TASK: usize = crate::numerics::sum::BLOCK;

/// Diagnostics of one step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepReport {
    /// Relative mass error of the mapping.
    pub mass_error: f64,
    /// Relative momentum error of the mapping (`None` when all particles are at rest).
    pub momentum_error: Option<f64>,
    /// Two-phase: relative mass error of the liquid mappings (`None` for one phase).
    pub liquid_mass_error: Option<f64>,
    /// Two-phase: relative momentum error of the liquid mapping (`None` for one phase or
    /// when the liquid is at rest).
    pub liquid_momentum_error: Option<f64>,
    /// Particles that changed cell in this step.
    pub crossings: usize,
    /// Kinetic and strain energy of the particles at the end of the step, when the step
    /// computed them on the way (`None`: ask [`TimeStepper::energies`]).
    pub energies: Option<(f64, f64)>,
    /// Whether the particle update mapped the next step's shapes, mass and internal force
    /// ([`crate::mapping::next`]), which the next step then uses.
    pub mapped_ahead: bool,
}

/// The time stepper, generic over the basis and the mapping (monomorphised kernels).
pub struct Stepper<B: Basis, M: Mapping> {
    pub grid: Grid,
    pub basis: B,
    pub mapping: M,
    pub material: Material,
    pub scheme: Scheme,
    pub boundary: Boundary,
    pub dt: f64,
    pub fields: GridFields,
    pub bins: CellBins,
    pub mass: MassSystem,
    total_mass: f64,
    /// A per-particle body force as a momentum-like phase for the mapping, and its grid
    /// vectors (allocated on first use).
    body_view: Particles,
    body_fields: Option<GridFields>,
    /// Particle strain increments of a mapping that defines its own
    /// ([`Mapping::strain_increments`]).
    strain: Vec<f64>,
    /// Particle accelerations of a mapping that defines its own
    /// ([`Mapping::particle_accelerations`]).
    particle_acceleration: Vec<f64>,
    /// The basis at the particles, evaluated once per step for the passes that need it
    /// (bases with [`Basis::reuse_shapes`]).
    shapes: Option<ShapeCache>,
    /// Whether the particle update maps the next step's shapes, mass and internal force
    /// where it can ([`crate::mapping::next`]; default `true`). The particles are bitwise
    /// the same either way; `false` gives the plain passes (for comparisons).
    pub map_ahead: bool,
    /// Whether the last step's update mapped this step's shapes, mass and internal force
    /// (`fields.mass`, `fields.internal_force`). The particles must then reach the next
    /// step as that update left them.
    mapped_ahead: bool,
}

impl<B: Basis, M: Mapping> Stepper<B, M> {
    /// A stepper for `particles`, which are binned (sorted by cell) here.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        grid: Grid,
        basis: B,
        mapping: M,
        material: Material,
        scheme: Scheme,
        boundary: Boundary,
        dt: f64,
        mass: MassSystem,
        particles: &mut Particles,
    ) -> Self {
        let mut bins = CellBins::default();
        bins.sort(particles, grid.cells);
        let mut basis = basis;
        if basis.depends_on_particles() {
            basis.update(quadrature(particles, &bins));
        }
        let total_mass = deterministic_sum(particles.len(), |p| particles.mass[p]);
        let mut fields = GridFields::new(basis.num_dofs());
        if mass.needs_matrix() {
            fields.consistent_mass =
                Some(CsrMatrix::band(basis.num_dofs(), basis.max_window() - 1));
        }
        Self {
            grid,
            mapping,
            material,
            scheme,
            boundary,
            dt,
            fields,
            bins,
            mass,
            total_mass,
            body_view: Particles::default(),
            body_fields: None,
            strain: Vec::new(),
            particle_acceleration: Vec::new(),
            shapes: basis.reuse_shapes().then(ShapeCache::default),
            map_ahead: true,
            mapped_ahead: false,
            basis,
        }
    }

    /// Advance by one time step with body acceleration `body_acceleration`. `step` and
    /// `time` (end of the step) only label failures.
    pub fn step(
        &mut self,
        particles: &mut Particles,
        body: Body<'_>,
        step: usize,
        time: f64,
    ) -> Result<StepReport> {
        let dt = self.dt;
        let ends = self.basis.boundary_dofs();
        if self.basis.depends_on_particles() {
            self.basis.update(quadrature(particles, &self.bins));
        }
        // 1. Mass, internal and external force (mass and internal force already mapped by
        // the last step's update, with the shapes, when it could).
        let mapped_ahead = std::mem::replace(&mut self.mapped_ahead, false);
        if !mapped_ahead {
            if let Some(shapes) = self.shapes.as_mut() {
                shapes.fill(
                    &self.basis,
                    &particles.x,
                    &particles.cell,
                    &particles.volume,
                );
            }
            map_mass_and_force(
                &mut self.mapping,
                &self.basis,
                particles,
                &self.bins,
                &mut self.fields,
                self.shapes.as_ref(),
            );
        }
        let shapes = self.shapes.as_ref();
        let fields = &mut self.fields;
        let grid_mass: f64 = fields.mass.iter().sum();
        let mass_error = (grid_mass - self.total_mass).abs() / self.total_mass;
        match body {
            Body::Uniform(b) => {
                for (f, m) in fields.external_force.iter_mut().zip(&fields.mass) {
                    *f = b * m;
                }
            }
            Body::PerParticle(b) => {
                // int (rho b)_hat phi, mapped like a momentum (same positions, same fits).
                let density = &particles.density;
                let mass = &particles.mass;
                sync_view(&mut self.body_view, particles, |p| mass[p], None, b);
                copy_into(&mut self.body_view.density, density);
                let body_fields = self
                    .body_fields
                    .get_or_insert_with(|| GridFields::new(fields.mass.len()));
                // The view has the particles' positions and volumes: same shapes.
                map_momentum(
                    &mut self.mapping,
                    &self.basis,
                    &self.body_view,
                    &self.bins,
                    body_fields,
                    shapes,
                );
                fields.external_force.copy_from_slice(&body_fields.momentum);
            }
        }
        if self.boundary.has_tractions() {
            let surfaces = quadrature(particles, &self.bins).material_extent();
            self.boundary.add_surface_tractions(
                &self.basis,
                &self.grid,
                surfaces,
                &mut fields.external_force,
            );
        }
        if self.scheme == Scheme::Usl {
            map_momentum(
                &mut self.mapping,
                &self.basis,
                particles,
                &self.bins,
                fields,
                shapes,
            );
        }

        // 2. Accelerations.
        let fixed = self.boundary.fixed_dofs(ends);
        self.mass.prepare(fields, fixed.as_slice());
        self.mass
            .accelerations(fields)
            .map_err(|e| at_step(e, step, time))?;

        // 3.-4. Particle velocities (and, for MUSL, the momentum they carry), grid velocities.
        let momentum_error = match self.scheme {
            Scheme::Musl => {
                // One pass where the mapping fuses the two (bitwise the same), else two.
                let fused = self.mapping.update_velocities_and_map_momentum(
                    &self.basis,
                    particles,
                    &self.bins,
                    dt,
                    fields,
                    shapes,
                );
                let sums = match fused {
                    Some(sums) => sums,
                    None => {
                        let sums = update_particle_velocities(
                            &mut self.mapping,
                            &self.basis,
                            shapes,
                            particles,
                            &fields.acceleration,
                            &mut self.particle_acceleration,
                            dt,
                            MomentumOf::Updated,
                        );
                        map_momentum(
                            &mut self.mapping,
                            &self.basis,
                            particles,
                            &self.bins,
                            fields,
                            shapes,
                        );
                        sums
                    }
                };
                let imbalance = self
                    .mass
                    .velocities(fields, 0.0)
                    .map_err(|e| at_step(e, step, time))?;
                momentum_error_of(sums, fields, imbalance)
            }
            Scheme::Usl => {
                let imbalance = self
                    .mass
                    .velocities(fields, dt)
                    .map_err(|e| at_step(e, step, time))?;
                let sums = update_particle_velocities(
                    &mut self.mapping,
                    &self.basis,
                    shapes,
                    particles,
                    &fields.acceleration,
                    &mut self.particle_acceleration,
                    dt,
                    MomentumOf::Previous,
                );
                momentum_error_of(sums, fields, imbalance)
            }
        };

        // 5.-8. Kinematics and stress, dispatched once on the material law.
        let own_strain = self.mapping.strain_increments(
            &self.basis,
            particles,
            &fields.velocity,
            dt,
            &mut self.strain,
        );
        // The next step's shapes, mass and internal force on the way where the mapping's
        // are the direct particle sums at the cached shapes.
        let ahead = self.map_ahead
            && !own_strain
            && !self.basis.depends_on_particles()
            && fields.consistent_mass.is_none();
        let next = match (self.mapping.next_mass_and_force(), self.shapes.as_mut()) {
            // The cache holds this step's shapes of these particles (filled above or by the
            // last update).
            (Some(next), Some(cache)) if ahead && cache.len() == particles.len() => {
                Some((next, cache))
            }
            _ => None,
        };
        let mapping_next = next.is_some();
        let outcome = match next {
            Some((next, cache)) => update_particles_mapping_next(
                self.material,
                &self.basis,
                cache,
                next,
                &self.grid,
                particles,
                &fields.velocity,
                dt,
            ),
            None => update_particles_with(
                self.material,
                &self.basis,
                self.shapes.as_ref(),
                &self.grid,
                particles,
                &fields.velocity,
                own_strain.then_some(self.strain.as_slice()),
                dt,
            ),
        };
        outcome.check(particles, step, time)?;
        if !mass_error.is_finite() {
            return Err(Error::NonFinite {
                field: "grid mass",
                step,
                time,
            });
        }
        // Cells changed: rebuild the bins. Without crossings they are still valid.
        outcome.rebin(&mut self.bins, particles, self.grid.cells);
        if mapping_next && outcome.sorted_by_cell {
            if let (Some(next), Some(cache)) =
                (self.mapping.next_mass_and_force(), self.shapes.as_ref())
            {
                next.reduce(
                    &self.basis,
                    &self.bins,
                    cache,
                    particles,
                    &mut self.fields.mass,
                    &mut self.fields.internal_force,
                );
                self.mapped_ahead = true;
            }
        }
        Ok(StepReport {
            mass_error,
            momentum_error,
            crossings: outcome.crossings,
            energies: Some(outcome.energies),
            mapped_ahead: self.mapped_ahead,
            ..StepReport::default()
        })
    }
}

/// Step 1 by `mapping`, with the step's shapes at the particles when there are.
fn map_mass_and_force<B: Basis, M: Mapping>(
    mapping: &mut M,
    basis: &B,
    particles: &Particles,
    bins: &CellBins,
    fields: &mut GridFields,
    shapes: Option<&ShapeCache>,
) {
    match shapes {
        Some(shapes) => {
            mapping.map_mass_and_internal_force_reusing(basis, particles, bins, fields, shapes)
        }
        None => mapping.map_mass_and_internal_force(basis, particles, bins, fields),
    }
}

/// The momentum mapping by `mapping`, with the step's shapes when there are.
fn map_momentum<B: Basis, M: Mapping>(
    mapping: &mut M,
    basis: &B,
    particles: &Particles,
    bins: &CellBins,
    fields: &mut GridFields,
    shapes: Option<&ShapeCache>,
) {
    match shapes {
        Some(shapes) => mapping.map_momentum_reusing(basis, particles, bins, fields, shapes),
        None => mapping.map_momentum(basis, particles, bins, fields),
    }
}

/// Fill `view` with the positions of `particles` and a phase (a liquid, or a body-force
/// density) with masses
/// `mass(p)`, stresses `stress` (0 if `None`) and velocities `velocity`, reusing its
/// buffers.
pub(crate) fn sync_view(
    view: &mut Particles,
    particles: &Particles,
    mass: impl Fn(usize) -> f64,
    stress: Option<&[f64]>,
    velocity: &[f64],
) {
    let n = particles.len();
    copy_into(&mut view.x, &particles.x);
    copy_into(&mut view.volume, &particles.volume);
    view.cell.clear();
    view.cell.extend_from_slice(&particles.cell);
    view.mass.clear();
    view.mass.extend((0..n).map(&mass));
    view.density.clear();
    view.density
        .extend((0..n).map(|p| mass(p) / particles.volume[p]));
    match stress {
        Some(s) => copy_into(&mut view.stress, s),
        None => {
            view.stress.clear();
            view.stress.resize(n, 0.0);
        }
    }
    copy_into(&mut view.v, velocity);
}

pub(crate) fn copy_into(target: &mut Vec<f64>, source: &[f64]) {
    target.clear();
    target.extend_from_slice(source);
}

/// The particles as the quadrature rule of configuration-dependent bases.
pub(crate) fn quadrature<'a>(
    particles: &'a Particles,
    bins: &'a CellBins,
) -> ParticleQuadrature<'a> {
    ParticleQuadrature {
        x: &particles.x,
        volume: &particles.volume,
        cell_start: &bins.cell_start,
    }
}

/// `max(|sum_i p_i - sum_p m_p v_p|, imbalance) / sum_p m_p |v_p|` (see the module doc)
/// of a phase with particle masses `m` and velocities `v`.
pub(crate) fn phase_momentum_error(
    m: &[f64],
    v: &[f64],
    fields: &GridFields,
    imbalance: f64,
) -> Option<f64> {
    let sums = deterministic_sums(m.len(), |p| [m[p] * v[p], m[p] * v[p].abs()]);
    momentum_error_of(sums, fields, imbalance)
}

/// The momentum error from the particle sums `[sum_p m_p v_p, sum_p m_p |v_p|]`.
fn momentum_error_of(
    [particle_momentum, scale]: [f64; 2],
    fields: &GridFields,
    imbalance: f64,
) -> Option<f64> {
    let grid_momentum: f64 = fields.momentum.iter().sum();
    (scale > 0.0).then(|| (grid_momentum - particle_momentum).abs().max(imbalance) / scale)
}

/// A solver failure labelled with the step it happened in.
pub(crate) fn at_step(error: Error, step: usize, time: f64) -> Error {
    match error {
        Error::Solver { solver, reason } => Error::Solver {
            solver,
            reason: format!("{reason} (step {step}, t = {time:e} s)"),
        },
        other => other,
    }
}

/// Object-safe view of a [`Stepper`]: the time loop dispatches once per step through this
/// trait, the kernels inside are monomorphised for the basis and mapping.
pub trait TimeStepper: Send {
    /// One step; see [`Stepper::step`].
    fn step(
        &mut self,
        particles: &mut Particles,
        body: Body<'_>,
        step: usize,
        time: f64,
    ) -> Result<StepReport>;
    /// Time step size.
    fn dt(&self) -> f64;
    /// The background grid.
    fn grid(&self) -> &Grid;
    /// Kinetic and stored (strain) energy of `particles`.
    fn energies(&self, particles: &Particles) -> (f64, f64);
    /// Names of the basis and mapping (`method.basis`, `method.reconstruction`).
    fn method_names(&self) -> (&'static str, &'static str);
    /// The mass-matrix solves so far.
    fn solver_totals(&self) -> SolverTotals;
    /// Remedies of the reconstruction so far.
    fn remedies(&self) -> RemedyCounts;
    /// Let the particle update map the next step's shapes, mass and internal force where
    /// the method allows it (`true`, the default), or keep the plain passes (`false`).
    /// The particles are bitwise the same either way. Default: nothing to switch.
    fn set_map_ahead(&mut self, on: bool) {
        let _ = on;
    }
}

impl<B: Basis, M: Mapping> TimeStepper for Stepper<B, M> {
    fn step(
        &mut self,
        particles: &mut Particles,
        body: Body<'_>,
        step: usize,
        time: f64,
    ) -> Result<StepReport> {
        Stepper::step(self, particles, body, step, time)
    }
    fn dt(&self) -> f64 {
        self.dt
    }
    fn grid(&self) -> &Grid {
        &self.grid
    }
    /// Kinetic energy `sum_p m_p v_p^2 / 2` and strain energy `sum_p V_p W(sigma_p)`.
    fn energies(&self, particles: &Particles) -> (f64, f64) {
        let p = particles;
        let material = self.material;
        let [kinetic, strain] = deterministic_sums(p.len(), |k| {
            [
                0.5 * p.mass[k] * p.v[k] * p.v[k],
                p.volume[k]
                    * material.strain_energy_density(p.stress[k], p.deformation_gradient[k]),
            ]
        });
        (kinetic, strain)
    }
    fn method_names(&self) -> (&'static str, &'static str) {
        (self.basis.name(), self.mapping.name())
    }
    fn solver_totals(&self) -> SolverTotals {
        SolverTotals::of(&[&self.mass])
    }
    fn remedies(&self) -> RemedyCounts {
        self.mapping.remedies()
    }
    fn set_map_ahead(&mut self, on: bool) {
        self.map_ahead = on;
        if !on {
            self.mapped_ahead = false;
        }
    }
}
