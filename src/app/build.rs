//! Scenario → [`Simulation`]: validation, the stability check, and the dispatch from
//! scenario keys to monomorphised steppers (`Stepper<LinearBasis, DirectMapping>`,
//! `Stepper<BSplineBasis, DirectMapping>`, `Stepper<DdmpmBasis, SubpointMapping>`, ...):
//! the only place that matches on `method.basis`, `method.reconstruction` and
//! `method.subpoints`.

use crate::app::solvers::{build_solver, SolverGeometry};
use crate::config::{
    BasisKind, FitWeights, MassKind, MaterialModel, MomentumLimiter, ParticleAcceleration,
    ReconstructionKind, Scenario, StrainKind, StressFit,
};
use crate::error::{Error, Result};
use crate::grid::{BSplineBasis, Basis, CpdiBasis, DdmpmBasis, GimpBasis, Grid, LinearBasis};
use crate::linalg::assembly::SplineSpace;
use crate::linalg::{CoarseOperators, LinearSolver};
use crate::mapping::{
    CubicSplineMapping, DirectMapping, Mapping, MlsKind, MlsMapping, SubpointMapping, TlsMapping,
};
use crate::particles::Particles;
use crate::physics::stability::{critical_time_step, critical_time_step_consistent};
use crate::physics::step::TimeStepper;
use crate::physics::two_phase::{
    PhaseSolvers, TwoPhaseBoundary, TwoPhaseMaterial, TwoPhaseStepper,
};
use crate::physics::{MassSystem, Material, Simulation, Stepper};
use crate::problems::{self, Problem};

/// Everything a stepper needs besides its basis and mapping.
struct StepperParts {
    grid: Grid,
    /// The one-phase law, or the skeleton law of a two-phase material.
    material: Material,
    /// The two-phase material (then the stepper is a [`TwoPhaseStepper`]).
    two_phase: Option<TwoPhaseMaterial>,
    boundary: TwoPhaseBoundary,
    force: bool,
}

/// Validate `scenario`, build its problem and a simulation at `t = 0`. Unless `force`,
/// a time step above the stability limit is an input error.
pub fn build_simulation(
    scenario: &Scenario,
    force: bool,
) -> Result<(Box<dyn Problem>, Simulation)> {
    scenario.validate()?;
    crate::app::memory::check_scenario_fits(scenario)?;
    if scenario.problem.dim != 1 {
        return Err(Error::invalid(
            "problem.dim",
            scenario.problem.dim,
            "this is the 1D simulation; 2D / 3D scenarios are built by \
             app::tensor_run::build_tensor_simulation",
        ));
    }
    let problem = problems::build(scenario)?;
    let grid = Grid::new(problem.length(), scenario.grid.cells.along_x());
    let two_phase = match scenario.material.model {
        MaterialModel::TwoPhase => Some(TwoPhaseMaterial::from_config(&scenario.material)?),
        _ => {
            TwoPhaseMaterial::reject_keys(&scenario.material)?;
            None
        }
    };
    let material = match &two_phase {
        Some(m) => m.skeleton,
        None => Material::require(&scenario.material)?,
    };
    let mut particles = problem.initial_particles(
        &grid,
        scenario.particles.per_cell,
        scenario.material.density,
    );
    let parts = StepperParts {
        grid,
        material,
        two_phase,
        boundary: TwoPhaseBoundary {
            solid: problem.boundary(),
            liquid: problem.liquid_boundary(),
        },
        force,
    };
    let method = &scenario.method;
    let stepper = match method.reconstruction {
        // DDMPM sub-points (SPEC §3.3): the direct quadrature over N points per particle.
        ReconstructionKind::None if method.subpoints > 0 => {
            let mapping = SubpointMapping::new(grid, method.subpoints);
            with_basis(scenario, parts, mapping, &mut particles)?
        }
        ReconstructionKind::None => {
            with_basis(scenario, parts, DirectMapping::default(), &mut particles)?
        }
        ReconstructionKind::Tls => {
            let points = gauss_points(scenario);
            let (dim, two_phase) = (scenario.problem.dim, parts.two_phase.is_some());
            let mapping =
                TlsMapping::new(grid, points, method.degenerate_cells, method.cell_totals)
                    .ok_or_else(|| {
                        Error::invalid("method.gauss_points", points, "not a supported Gauss rule")
                    })?
                    .with_adjoint(method.strain(dim, two_phase) == StrainKind::Adjoint)
                    .with_conservative_degree(method.conservative_degree(1))
                    .with_momentum_limiter(
                        method.momentum_limiter() == MomentumLimiter::KineticEnergy,
                    )
                    .with_conservative_stress(method.stress_fit() == StressFit::Conservative)
                    .with_domain_weights(method.fit_weights(dim, two_phase) == FitWeights::Domains)
                    .with_particle_metric(method.adjoint_mass(dim, two_phase));
            with_basis(scenario, parts, mapping, &mut particles)?
        }
        ReconstructionKind::CubicSpline => {
            // SPEC §4.2: a 2-point rule on each half cell unless `method.gauss_points` says.
            let points = match method.gauss_points {
                0 => 2,
                n => n,
            };
            let mapping = CubicSplineMapping::new(grid, points).ok_or_else(|| {
                Error::invalid("method.gauss_points", points, "not a supported Gauss rule")
            })?;
            with_basis(scenario, parts, mapping, &mut particles)?
        }
        ReconstructionKind::Mls | ReconstructionKind::Imls => {
            // SPEC §4.3: the Gauss points of TLS, fits centred at each point.
            let two_phase = parts.two_phase.is_some();
            let kind = if method.reconstruction == ReconstructionKind::Mls {
                MlsKind::Mls
            } else {
                MlsKind::Imls
            };
            let points = gauss_points(scenario);
            let mapping = MlsMapping::new(grid, points, kind)
                .ok_or_else(|| {
                    Error::invalid("method.gauss_points", points, "not a supported Gauss rule")
                })?
                .with_consistent_velocity(method.mass == MassKind::Consistent)
                .with_adjoint_strain(
                    method.strain(scenario.problem.dim, two_phase) == StrainKind::Adjoint,
                )
                .with_conjugate_acceleration(
                    // The two-phase step accelerates its particles itself.
                    !two_phase && method.particle_acceleration() == ParticleAcceleration::Conjugate,
                );
            with_basis(scenario, parts, mapping, &mut particles)?
        }
    };
    let start_time = problem.start_time();
    Ok((
        problem,
        Simulation::new(stepper, particles).starting_at(start_time),
    ))
}

/// Gauss points per cell of a reconstruction: `method.gauss_points`, or (0) `p + 2` for a
/// basis of polynomial degree `p`, which integrates `M^C = int rho_hat phi phi^T` (degree
/// `2 + 2p`) exactly.
pub fn gauss_points(scenario: &Scenario) -> usize {
    match scenario.method.gauss_points {
        0 => {
            let degree = match scenario.method.basis {
                BasisKind::Bspline => scenario.method.order,
                _ => 1,
            };
            degree + 2
        }
        n => n,
    }
}

/// The solver of consistent mass systems (`solver.kind`) on the grid's DOFs: B-splines of
/// `method.order` for the B-spline basis, linear hats (order 1) for the others.
fn mass_solver(scenario: &Scenario, grid: &Grid) -> Result<Box<dyn LinearSolver>> {
    let order = match scenario.method.basis {
        BasisKind::Bspline => scenario.method.order,
        _ => 1,
    };
    let space = SplineSpace::new(order, grid.cells, grid.length)
        .ok_or_else(|| Error::invalid("method.order", order, "no B-spline space of this order"))?;
    let geometry = SolverGeometry {
        directions: vec![space],
        boundary_dropped: false,
        coarse_operators: CoarseOperators::Galerkin,
        density: None,
    };
    build_solver(&scenario.solver, &geometry)
}

/// Dispatch on `method.basis` for a given mapping.
fn with_basis<M: Mapping + Clone + 'static>(
    scenario: &Scenario,
    parts: StepperParts,
    mapping: M,
    particles: &mut Particles,
) -> Result<Box<dyn TimeStepper>> {
    let grid = parts.grid;
    match scenario.method.basis {
        BasisKind::Linear => stepper(scenario, parts, LinearBasis::new(grid), mapping, particles),
        BasisKind::Ddmpm => {
            let basis = DdmpmBasis::with_integrals(
                grid,
                scenario.method.node_integrals(),
                scenario.method.subpoints,
            );
            stepper(scenario, parts, basis, mapping, particles)
        }
        BasisKind::Gimp => stepper(scenario, parts, GimpBasis::new(grid), mapping, particles),
        BasisKind::Cpdi => stepper(scenario, parts, CpdiBasis::new(grid), mapping, particles),
        BasisKind::Bspline => {
            let order = scenario.method.order;
            let basis = BSplineBasis::new(grid, order).ok_or_else(|| {
                Error::invalid(
                    "method.order",
                    order,
                    format!(
                        "B-spline order must be between 1 and {}",
                        crate::grid::bspline::MAX_ORDER
                    ),
                )
            })?;
            stepper(scenario, parts, basis, mapping, particles)
        }
    }
}

/// The monomorphised stepper, after the stability check of its basis.
fn stepper<B: Basis + 'static, M: Mapping + Clone + 'static>(
    scenario: &Scenario,
    parts: StepperParts,
    basis: B,
    mapping: M,
    particles: &mut Particles,
) -> Result<Box<dyn TimeStepper>> {
    if let Some(material) = parts.two_phase {
        return two_phase_stepper(scenario, parts, material, basis, mapping, particles);
    }
    let stepper = Stepper::new(
        parts.grid,
        basis,
        mapping,
        parts.material,
        scenario.method.scheme,
        parts.boundary.solid,
        scenario.time.dt.seconds(),
        MassSystem::new(
            scenario.method.acceleration_mass(),
            scenario.method.mass,
            mass_solver(scenario, &parts.grid)?,
        ),
        particles,
    );
    let modulus = parts.material.wave_modulus();
    let mut limit = critical_time_step(&stepper.basis, particles, modulus);
    if scenario.method.acceleration_mass() == MassKind::Consistent {
        limit = limit.min(critical_time_step_consistent(
            &stepper.basis,
            particles,
            modulus,
        ));
    }
    if scenario.time.dt.seconds() > limit && !parts.force {
        return Err(Error::UnstableTimeStep {
            dt: scenario.time.dt.seconds(),
            limit,
        });
    }
    Ok(Box::new(stepper))
}

/// The two-phase stepper (SPEC §2.1), after the stability check: the fastest wave of the
/// mixture ([`TwoPhaseMaterial::max_wave_speed`]) on the particle operators of the basis,
/// and the explicit drag limit `2 k / (n g)`.
fn two_phase_stepper<B: Basis + 'static, M: Mapping + Clone + 'static>(
    scenario: &Scenario,
    parts: StepperParts,
    material: TwoPhaseMaterial,
    basis: B,
    mapping: M,
    particles: &mut Particles,
) -> Result<Box<dyn TimeStepper>> {
    let method = &scenario.method;
    let system = || -> Result<MassSystem> {
        Ok(MassSystem::new(
            method.acceleration_mass(),
            method.mass,
            mass_solver(scenario, &parts.grid)?,
        ))
    };
    let solvers = PhaseSolvers {
        solid: system()?,
        liquid: MassSystem::new(
            method.acceleration_mass(),
            method.acceleration_mass(),
            mass_solver(scenario, &parts.grid)?,
        ),
        liquid_bar: system()?,
    };
    let stepper = TwoPhaseStepper::new(
        parts.grid,
        basis,
        mapping,
        material,
        parts.boundary,
        scenario.time.dt.seconds(),
        method.acceleration_mass(),
        solvers,
        particles,
    )?;
    // The wave limit: particle operators with the mixture density and the modulus of the
    // fastest wave, c_max^2 rho_sat.
    let density = material.saturated_density();
    let mut mixture = particles.clone();
    for (m, v) in mixture.mass.iter_mut().zip(&mixture.volume) {
        *m = density * v;
    }
    let modulus = density * material.max_wave_speed().powi(2);
    let mut limit = critical_time_step(&stepper.basis, &mixture, modulus);
    if method.acceleration_mass() == MassKind::Consistent {
        limit = limit.min(critical_time_step_consistent(
            &stepper.basis,
            &mixture,
            modulus,
        ));
    }
    limit = limit.min(material.drag_time_step());
    if scenario.time.dt.seconds() > limit && !parts.force {
        return Err(Error::UnstableTimeStep {
            dt: scenario.time.dt.seconds(),
            limit,
        });
    }
    Ok(Box::new(stepper))
}
