//! Scenario → [`Simulation`]: validation, the stability check, and the dispatch from
//! scenario keys to monomorphised steppers (`Stepper<LinearBasis, DirectMapping>`, ...).

use crate::config::{BasisKind, ReconstructionKind, Scenario};
use crate::error::{Error, Result};
use crate::grid::{Basis, Grid, LinearBasis};
use crate::mapping::DirectMapping;
use crate::physics::step::TimeStepper;
use crate::physics::{Material, Simulation, Stepper};
use crate::problems::{self, Problem};

/// Critical time step `factor h / c` with the initial wave speed `c = sqrt(E / rho)`.
pub fn stability_limit(scenario: &Scenario, grid: &Grid, basis: &dyn Basis) -> f64 {
    let c = (scenario.material.youngs_modulus / scenario.material.density).sqrt();
    basis.stability_factor() * grid.h / c
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
    let material = Material::from_config(&scenario.material).ok_or_else(|| {
        Error::invalid(
            "material.model",
            format!("{:?}", scenario.material.model),
            "not a one-phase elastic model",
        )
    })?;
    let mut particles = problem.initial_particles(
        &grid,
        scenario.particles.per_cell,
        scenario.material.density,
    );
    let method = &scenario.method;
    let dt = scenario.time.dt;
    let stepper: Box<dyn TimeStepper> = match (method.basis, method.reconstruction) {
        (BasisKind::Linear, ReconstructionKind::None) => {
            let basis = LinearBasis::new(grid);
            check_stability(scenario, &grid, &basis, force)?;
            Box::new(Stepper::new(
                grid,
                basis,
                DirectMapping::default(),
                material,
                method.scheme,
                problem.boundary(),
                dt,
                &mut particles,
            ))
        }
        (basis, reconstruction) => {
            return Err(Error::invalid(
                "method",
                format!("basis = {basis:?}, reconstruction = {reconstruction:?}"),
                "combination not available in this version of tlsmpm",
            ))
        }
    };
    Ok((problem, Simulation::new(stepper, particles)))
}

fn check_stability(scenario: &Scenario, grid: &Grid, basis: &dyn Basis, force: bool) -> Result<()> {
    let limit = stability_limit(scenario, grid, basis);
    if scenario.time.dt > limit && !force {
        return Err(Error::UnstableTimeStep {
            dt: scenario.time.dt,
            limit,
        });
    }
    Ok(())
}
