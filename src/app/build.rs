//! Scenario → [`Simulation`]: validation, the stability check, and the dispatch from
//! scenario keys to monomorphised steppers (`Stepper<LinearBasis, DirectMapping>`,
//! `Stepper<BSplineBasis, DirectMapping>`, ...): the only place that matches on
//! `method.basis` and `method.reconstruction`.

use crate::config::{BasisKind, ReconstructionKind, Scenario};
use crate::error::{Error, Result};
use crate::grid::{BSplineBasis, Basis, CpdiBasis, DdmpmBasis, GimpBasis, Grid, LinearBasis};
use crate::mapping::{DirectMapping, Mapping};
use crate::particles::Particles;
use crate::physics::stability::critical_time_step;
use crate::physics::step::TimeStepper;
use crate::physics::{Boundary, Material, Simulation, Stepper};
use crate::problems::{self, Problem};

/// Everything a stepper needs besides its basis and mapping.
struct StepperParts {
    grid: Grid,
    material: Material,
    boundary: Boundary,
    force: bool,
}

/// Validate `scenario`, build its problem and a simulation at `t = 0`. Unless `force`,
/// a time step above the stability limit is an input error.
pub fn build_simulation(
    scenario: &Scenario,
    force: bool,
) -> Result<(Box<dyn Problem>, Simulation)> {
    scenario.validate()?;
    let problem = problems::build(scenario)?;
    let grid = Grid::new(problem.length(), scenario.grid.cells);
    let material = Material::require(&scenario.material)?;
    let mut particles = problem.initial_particles(
        &grid,
        scenario.particles.per_cell,
        scenario.material.density,
    );
    let parts = StepperParts {
        grid,
        material,
        boundary: problem.boundary(),
        force,
    };
    let method = &scenario.method;
    let stepper = match method.reconstruction {
        ReconstructionKind::None => {
            with_basis(scenario, parts, DirectMapping::default(), &mut particles)?
        }
        reconstruction => {
            return Err(Error::invalid(
                "method.reconstruction",
                format!("{reconstruction:?}"),
                "not available in this version of tlsmpm",
            ))
        }
    };
    Ok((problem, Simulation::new(stepper, particles)))
}

/// Dispatch on `method.basis` for a given mapping.
fn with_basis<M: Mapping + 'static>(
    scenario: &Scenario,
    parts: StepperParts,
    mapping: M,
    particles: &mut Particles,
) -> Result<Box<dyn TimeStepper>> {
    let grid = parts.grid;
    match scenario.method.basis {
        BasisKind::Linear => stepper(scenario, parts, LinearBasis::new(grid), mapping, particles),
        BasisKind::Ddmpm => stepper(scenario, parts, DdmpmBasis::new(grid), mapping, particles),
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
fn stepper<B: Basis + 'static, M: Mapping + 'static>(
    scenario: &Scenario,
    parts: StepperParts,
    basis: B,
    mapping: M,
    particles: &mut Particles,
) -> Result<Box<dyn TimeStepper>> {
    let stepper = Stepper::new(
        parts.grid,
        basis,
        mapping,
        parts.material,
        scenario.method.scheme,
        parts.boundary,
        scenario.time.dt,
        particles,
    );
    let limit = critical_time_step(&stepper.basis, particles, parts.material.wave_modulus());
    if scenario.time.dt > limit && !parts.force {
        return Err(Error::UnstableTimeStep {
            dt: scenario.time.dt,
            limit,
        });
    }
    Ok(Box::new(stepper))
}
