//! 2D / 3D runs (`problem.dim = 2 | 3`, `docs/dimensions.md`): scenario → monomorphised
//! [`TensorStepper`] (dispatched once on the dimension and `method.basis`), the time loop,
//! and the outputs of DESIGN §7: `summary.json`, `particles.csv`, `history.csv`, VTU
//! snapshots with a `.pvd` series, and a scatter plot of the particles coloured by
//! `stress_xx`. On a numerical failure everything computed is written before the error
//! is returned, as in 1D.

use crate::app::solvers::{build_solver, SolverGeometry};
use crate::app::tensor_vtk::VtkFrames;
use crate::app::RunOptions;
use crate::config::MassKind;
use crate::config::{
    integer_root, BasisKind, MaterialModel, ReconstructionKind, Scenario, SolverKind, TimeStep,
    VelocityReference,
};
use crate::error::{Error, Result};
use crate::grid::{BSplineBasis, Basis, GimpBasis, Grid, LinearBasis, TensorBasis};
use crate::linalg::assembly::SplineSpace;
use crate::linalg::CoarseOperators;
use crate::mapping::tensor::TensorMapping;
use crate::mapping::tensor_direct::TensorDirectMapping;
use crate::mapping::tensor_tls::TensorTlsMapping;
use crate::mapping::RemedyCounts;
use crate::output::csv::write_history;
use crate::output::scatter::{scatter_plot, ScatterAxes};
use crate::output::summary::{Conservation, Errors, SolverSummary};
use crate::output::tensor_csv::{write_tensor_particles, TensorExactColumn};
use crate::output::Summary;
use crate::particles::tensor::STRESS_COMPONENTS;
use crate::particles::TensorParticles;
use crate::physics::distributed::{gather_particles, RankExchange};
use crate::physics::tensor::stability::tensor_critical_time_step;
use crate::physics::tensor::{
    lame, LinearElasticTensor, NeoHookeanTensor, NodeConstraints, TensorMassSolve, TensorMaterial,
    TensorSimulation, TensorStepper, TimeStepping,
};
use crate::problems::tensor::TensorProblem;
use crate::problems::Field;
use std::borrow::Cow;
use std::path::Path;
use std::time::Instant;

/// Validate `scenario` (dimension `D`), build its problem and a simulation at `t = 0`.
/// Unless `force`, a fixed time step above the stability limit is an input error.
pub fn build_tensor_simulation<const D: usize>(
    scenario: &Scenario,
    force: bool,
) -> Result<(TensorProblem<D>, TensorSimulation<D>)> {
    scenario.validate()?;
    crate::app::memory::check_scenario_fits(scenario)?;
    if scenario.problem.dim != D {
        return Err(Error::invalid(
            "problem.dim",
            scenario.problem.dim,
            format!("this build path is for {D}D"),
        ));
    }
    let problem = TensorProblem::<D>::from_scenario(scenario)?;
    let per_axis = integer_root(scenario.particles.per_cell, D).ok_or_else(|| {
        Error::invalid(
            "particles.per_cell",
            scenario.particles.per_cell,
            "not a perfect power of the dimension",
        )
    })?;
    let m = &scenario.material;
    let material = match m.model {
        MaterialModel::NeoHookean => {
            let (Some(mu), Some(lambda)) = (m.shear_modulus, m.lame_lambda) else {
                return Err(Error::invalid(
                    "material.shear_modulus",
                    "(missing)",
                    "required by material.model = \"neo_hookean\"",
                ));
            };
            TensorMaterial::NeoHookean(NeoHookeanTensor { lambda, mu })
        }
        _ => {
            let (lambda, mu) = lame(m.youngs_modulus, m.poisson_ratio.unwrap_or(0.0));
            TensorMaterial::Linear(LinearElasticTensor { lambda, mu })
        }
    };
    let particles = problem.initial_particles(per_axis, m.density);
    let grid = problem.grid();
    let parts = Parts {
        scenario,
        material,
        per_axis,
        force,
    };
    let simulation = match scenario.method.basis {
        BasisKind::Linear => parts.finish(
            TensorBasis::new(grid, LinearBasis::new),
            false,
            particles,
            &problem,
        )?,
        BasisKind::Gimp => parts.finish(
            TensorBasis::new(grid, GimpBasis::new),
            true,
            particles,
            &problem,
        )?,
        BasisKind::Bspline => {
            let order = scenario.method.order;
            if BSplineBasis::new(Grid::new(1.0, 1), order).is_none() {
                return Err(Error::invalid(
                    "method.order",
                    order,
                    "not a supported order",
                ));
            }
            let make =
                |g: Grid| BSplineBasis::new(g, order).unwrap_or_else(|| unreachable_basis(g));
            parts.finish(TensorBasis::new(grid, make), false, particles, &problem)?
        }
        other => {
            return Err(Error::invalid(
                "method.basis",
                crate::config::toml_value(&other),
                "is 1D only",
            ))
        }
    };
    Ok((problem, simulation))
}

/// The mass of the acceleration solve in 2D / 3D: `method.acceleration_mass`, default
/// lumped. (The consistent matrix in both solves diverges on the 2D manufactured solution
/// with 4 particles per cell after a few hundred steps, lumped acceleration with a
/// consistent velocity solve is stable and the most accurate: `docs/tls.md`.)
fn tensor_acceleration_mass(method: &crate::config::MethodConfig) -> MassKind {
    method.acceleration_mass.unwrap_or(MassKind::Lumped)
}

/// Order 1 exists for every grid (only reached if a validated order were refused).
fn unreachable_basis(g: Grid) -> BSplineBasis {
    match BSplineBasis::new(g, 1) {
        Some(b) => b,
        None => unreachable!("order 1 is always supported"),
    }
}

struct Parts<'a> {
    scenario: &'a Scenario,
    material: TensorMaterial,
    per_axis: usize,
    force: bool,
}

impl Parts<'_> {
    fn finish<const D: usize, B: Basis + Clone + 'static>(
        &self,
        basis: TensorBasis<D, B>,
        particle_domain: bool,
        mut particles: TensorParticles<D>,
        problem: &TensorProblem<D>,
    ) -> Result<TensorSimulation<D>> {
        let density = self.scenario.material.density;
        let modulus = self.material.wave_modulus();
        let limit = tensor_critical_time_step(&basis, [self.per_axis; D], density, modulus);
        let stepping = match self.scenario.time.dt {
            TimeStep::Fixed(dt) => {
                if dt > limit && !self.force {
                    return Err(Error::UnstableTimeStep { dt, limit });
                }
                TimeStepping::Fixed(dt)
            }
            TimeStep::Auto => TimeStepping::Auto {
                cfl: self.scenario.time.cfl.unwrap_or(0.5),
                initial_limit: limit,
                initial_speed: (modulus / density).sqrt(),
            },
        };
        let half_length0: [f64; D] =
            std::array::from_fn(|a| 0.5 * basis.grid.axes[a].h / self.per_axis as f64);
        let method = &self.scenario.method;
        let stepper: Box<dyn crate::physics::tensor::TensorTimeStepper<D>> =
            match method.reconstruction {
                ReconstructionKind::Tls => {
                    let points = crate::app::build::gauss_points(self.scenario);
                    let mapping = TensorTlsMapping::new(
                        &basis,
                        points,
                        method.cell_totals,
                        half_length0,
                        particle_domain,
                    )
                    .ok_or_else(|| {
                        Error::invalid("method.gauss_points", points, "not a supported Gauss rule")
                    })?
                    .with_conservative_degree(method.conservative_degree(D));
                    let acceleration = tensor_acceleration_mass(method);
                    if acceleration == MassKind::Consistent || method.mass == MassKind::Consistent {
                        let mapping = mapping.with_consistent_mass(&basis).ok_or_else(|| {
                            Error::invalid(
                                "method.order",
                                method.order,
                                "too large a support for the consistent mass in this dimension",
                            )
                        })?;
                        let solve = self.mass_solve(&basis, problem)?;
                        let stepper = self.stepper(basis, mapping, problem, &mut particles);
                        Box::new(stepper.with_mass_solve(solve))
                    } else {
                        Box::new(self.stepper(basis, mapping, problem, &mut particles))
                    }
                }
                _ => {
                    let mapping =
                        TensorDirectMapping::new(&basis, particle_domain.then_some(half_length0));
                    Box::new(self.stepper(basis, mapping, problem, &mut particles))
                }
            };
        Ok(TensorSimulation::new(
            stepper,
            particles,
            stepping,
            self.scenario.time.end,
        ))
    }

    fn stepper<const D: usize, B: Basis + Clone + 'static, M: TensorMapping<D> + 'static>(
        &self,
        basis: TensorBasis<D, B>,
        mapping: M,
        problem: &TensorProblem<D>,
        particles: &mut TensorParticles<D>,
    ) -> TensorStepper<D, B, M> {
        let constraints = NodeConstraints::new(&basis, &problem.faces);
        TensorStepper::new(
            basis,
            mapping,
            self.material,
            self.scenario.method.scheme,
            constraints,
            particles,
        )
    }

    /// The consistent-mass solves: `solver.kind` (2D / 3D default
    /// [`crate::config::tensor_default_solver`]) on the B-spline spaces of the axes (order
    /// 1 for hats and GIMP).
    fn mass_solve<const D: usize, B: Basis>(
        &self,
        basis: &TensorBasis<D, B>,
        problem: &TensorProblem<D>,
    ) -> Result<TensorMassSolve<D>> {
        let method = &self.scenario.method;
        let order = match method.basis {
            BasisKind::Bspline => method.order,
            _ => 1,
        };
        let grid = basis.grid;
        let directions = (0..D)
            .map(|a| {
                let g = grid.axes[a];
                SplineSpace::new(order, g.cells, g.length).ok_or_else(|| {
                    Error::invalid("method.order", order, "no B-spline space of this order")
                })
            })
            .collect::<Result<Vec<_>>>()?;
        let geometry = SolverGeometry {
            directions,
            boundary_dropped: false,
            coarse_operators: CoarseOperators::Galerkin,
            density: None,
        };
        let mut config = self.scenario.solver.clone();
        config.kind = Some(config.tensor_kind(D));
        let constraints = NodeConstraints::new(basis, &problem.faces);
        TensorMassSolve::new(
            tensor_acceleration_mass(method),
            method.mass,
            basis.num_dofs(),
            &constraints,
            config.tolerance,
            || build_solver(&config, &geometry),
        )
    }
}

/// Run a 2D / 3D `scenario` with its outputs (see the module doc). `progress(step,
/// n_steps)` is called after every step (`n_steps` estimated for automatic steps).
pub fn run_tensor(
    scenario: &Scenario,
    name: &str,
    options: &RunOptions,
    progress: &mut (dyn FnMut(usize, usize) + Send),
) -> Result<Summary> {
    match scenario.problem.dim {
        1 => run_dim::<1>(scenario, name, options, progress),
        2 => run_dim::<2>(scenario, name, options, progress),
        3 => run_dim::<3>(scenario, name, options, progress),
        dim => Err(Error::invalid("problem.dim", dim, "must be 1, 2 or 3")),
    }
}

fn run_dim<const D: usize>(
    scenario: &Scenario,
    name: &str,
    options: &RunOptions,
    progress: &mut (dyn FnMut(usize, usize) + Send),
) -> Result<Summary> {
    let pool = crate::app::run::thread_pool(options.threads)?;
    // Defaults that `summary.json`'s `config` states as run: the consistent mass of a
    // distributed run defaults to Jacobi CG (the 2D / 3D default, the Kronecker
    // preconditioner, is not local per rank); the degree of the conservative TLS fits
    // depends on the dimension.
    let resolved_scenario;
    let distributed_default = options.ranks.is_some() && scenario.solver.kind.is_none();
    let tls_default = scenario.method.reconstruction == ReconstructionKind::Tls
        && scenario.method.conservative_degree.is_none();
    let scenario = if distributed_default || tls_default {
        let mut s = scenario.clone();
        if distributed_default {
            s.solver.kind = Some(SolverKind::Pcg);
        }
        if tls_default {
            s.method.conservative_degree = Some(s.method.conservative_degree(D));
        }
        resolved_scenario = s;
        &resolved_scenario
    } else {
        scenario
    };
    let (problem, mut simulation) =
        pool.install(|| build_tensor_simulation::<D>(scenario, options.force))?;
    // A distributed run: this rank's slab of particles; `gather` brings every rank's
    // particles to rank 0, which writes the outputs.
    let gather = match &options.ranks {
        Some(ranks) => {
            if D == 1 {
                return Err(Error::invalid(
                    "problem.dim",
                    1,
                    "a distributed run needs problem.dim = 2 or 3",
                ));
            }
            simulation.distribute((ranks.0)())?;
            Some((ranks.0)())
        }
        None => None,
    };
    let out = &options.out_dir;
    std::fs::create_dir_all(out).map_err(|e| Error::write(out, e))?;
    let snapshots = scenario.output.snapshots;
    let vtk = scenario.output.vtk;
    let end = scenario.time.end;
    let mut frames = VtkFrames::new(out, gather.as_deref())?;
    let mut snapshot_error = None;
    let mut next_snapshot = 1;
    let estimate = |sim: &TensorSimulation<D>| {
        sim.fixed_steps().unwrap_or_else(|| {
            let dt = sim.dt.max(f64::MIN_POSITIVE);
            sim.steps_done + ((end - sim.time) / dt).ceil().max(0.0) as usize
        })
    };
    if vtk {
        frames.write(0, 0.0, &simulation.particles)?;
    }
    let clock = Instant::now();
    let outcome = pool.install(|| {
        simulation.run(&problem, &mut |sim| {
            progress(sim.steps_done, estimate(sim));
            // Snapshot k of `snapshots` once the time passes k / snapshots of the run.
            while snapshots > 0
                && next_snapshot <= snapshots
                && sim.time >= end * next_snapshot as f64 / snapshots as f64 * (1.0 - 1e-12)
            {
                let k = next_snapshot;
                next_snapshot += 1;
                // VTU: each rank its piece; CSV: every rank's particles on rank 0.
                let result = if vtk {
                    frames.write(k, sim.time, &sim.particles)
                } else {
                    let Some(p) = writable(&gather, &sim.particles)? else {
                        continue;
                    };
                    let columns = exact_columns_of(&problem, &p, sim, scenario);
                    write_tensor_particles(
                        &out.join(format!("snapshot_{k:04}.csv")),
                        &p,
                        &as_refs(&columns),
                    )
                };
                if let Err(e) = result {
                    snapshot_error = Some(e);
                }
            }
            options.check_stop(sim.steps_done, sim.time)?;
            Ok(true)
        })
    });
    let wall_seconds = clock.elapsed().as_secs_f64();
    if let Some(e) = snapshot_error {
        return Err(e);
    }
    // Rank 0 of a distributed run writes with every rank's particles.
    let (write_files, own_particles) = match &gather {
        None => (true, None),
        Some(exchange) => match gather_particles(exchange.as_ref(), &simulation.particles)? {
            Some(all) => (
                true,
                Some(std::mem::replace(&mut simulation.particles, all)),
            ),
            None => (false, None),
        },
    };
    // This rank's particles (for its VTU piece), all of them in one process.
    let own_particles = own_particles.as_ref().unwrap_or(&simulation.particles);
    let remedies = remedies_over_ranks(&gather, simulation.stepper.remedies())?;
    if vtk {
        if frames.last_time().is_none_or(|t| t < simulation.time) {
            frames.write(frames.len(), simulation.time, own_particles)?;
        }
        frames.finish()?;
    }
    let summary = pool.install(|| {
        write_outputs(
            scenario,
            name,
            &problem,
            &simulation,
            out,
            pool.current_num_threads(),
            wall_seconds,
            outcome.as_ref().err(),
            &options.warnings,
            remedies,
            write_files,
        )
    })?;
    outcome.map(|()| summary)
}

/// `local` summed over the ranks of a distributed run (each counts its own cells).
fn remedies_over_ranks(
    gather: &Option<Box<dyn RankExchange>>,
    local: RemedyCounts,
) -> Result<RemedyCounts> {
    let Some(exchange) = gather else {
        return Ok(local);
    };
    let counts = [
        local.degenerate_fits,
        local.virtual_point_fits,
        local.order_reduced_fits,
        local.density_limited_fits,
        local.strain_fallbacks,
        local.momentum_limited_fits,
        local.limited_consistent_cells,
    ];
    // Counts are exact in f64 below 2^53.
    let total = exchange.sum_over_ranks(&counts.map(|c| c as f64))?;
    let count = |k: usize| total.get(k).copied().unwrap_or(0.0) as u64;
    Ok(RemedyCounts {
        degenerate_fits: count(0),
        virtual_point_fits: count(1),
        order_reduced_fits: count(2),
        density_limited_fits: count(3),
        strain_fallbacks: count(4),
        momentum_limited_fits: count(5),
        limited_consistent_cells: count(6),
    })
}

/// The particles to write: all of them, and on rank 0 only for a distributed run (whose
/// exchange is `gather`).
fn writable<'a, const D: usize>(
    gather: &Option<Box<dyn RankExchange>>,
    p: &'a TensorParticles<D>,
) -> Result<Option<Cow<'a, TensorParticles<D>>>> {
    match gather {
        None => Ok(Some(Cow::Borrowed(p))),
        Some(exchange) => Ok(gather_particles(exchange.as_ref(), p)?.map(Cow::Owned)),
    }
}

/// The exact values of every known field at every particle (storage order), at the
/// current time (velocity at `t - dt/2` with `output.velocity_reference = "half_step"`).
pub fn exact_columns<const D: usize>(
    problem: &TensorProblem<D>,
    simulation: &TensorSimulation<D>,
    scenario: &Scenario,
) -> Vec<(Field, Vec<Vec<f64>>)> {
    exact_columns_of(problem, &simulation.particles, simulation, scenario)
}

/// [`exact_columns`] at the particles `p` (all ranks' particles in a distributed run).
fn exact_columns_of<const D: usize>(
    problem: &TensorProblem<D>,
    p: &TensorParticles<D>,
    simulation: &TensorSimulation<D>,
    scenario: &Scenario,
) -> Vec<(Field, Vec<Vec<f64>>)> {
    use rayon::prelude::*;
    problem
        .exact_fields()
        .iter()
        .map(|&field| {
            let t = match (field, scenario.output.velocity_reference) {
                (Field::Velocity, VelocityReference::HalfStep) if simulation.steps_done > 0 => {
                    simulation.time - 0.5 * simulation.dt
                }
                _ => simulation.time,
            };
            let per_particle: Vec<[f64; 6]> = (0..p.len())
                .into_par_iter()
                .with_min_len(4096)
                .map(|k| problem.exact(field, p.material_position(k), t))
                .collect();
            let components = if field == Field::Stress { 6 } else { D };
            let values = (0..components)
                .map(|c| per_particle.iter().map(|e| e[c]).collect())
                .collect();
            (field, values)
        })
        .collect()
}

fn as_refs(columns: &[(Field, Vec<Vec<f64>>)]) -> Vec<TensorExactColumn<'_>> {
    columns
        .iter()
        .map(|(field, values)| TensorExactColumn {
            field: *field,
            values,
        })
        .collect()
}

/// The particle components of `field` (`D` vectors, or the six stress components).
fn numerical<const D: usize>(p: &TensorParticles<D>, field: Field) -> Vec<&[f64]> {
    match field {
        Field::Displacement => p.u.iter().map(|c| c.as_slice()).collect(),
        Field::Velocity => p.v.iter().map(|c| c.as_slice()).collect(),
        _ => p.stress.iter().map(|c| c.as_slice()).collect(),
    }
}

/// RMS over particles of the error norm and its relative L2 counterpart: Euclidean for
/// vectors, Frobenius for the stress (off-diagonal components count twice).
pub fn vector_errors(numerical: &[&[f64]], exact: &[Vec<f64>], stress: bool) -> (f64, f64) {
    let n = numerical.first().map_or(0, |c| c.len());
    let weight = |c: usize| if stress && c >= 3 { 2.0 } else { 1.0 };
    let [error2, exact2] = crate::numerics::sum::deterministic_sums(n, |k| {
        let mut e2 = 0.0;
        let mut x2 = 0.0;
        for (c, (num, ex)) in numerical.iter().zip(exact).enumerate() {
            let d = num[k] - ex[k];
            e2 += weight(c) * d * d;
            x2 += weight(c) * ex[k] * ex[k];
        }
        [e2, x2]
    });
    let rms = (error2 / n.max(1) as f64).sqrt();
    let rel = if exact2 > 0.0 {
        (error2 / exact2).sqrt()
    } else {
        f64::NAN
    };
    (rms, rel)
}

#[allow(clippy::too_many_arguments)]
fn write_outputs<const D: usize>(
    scenario: &Scenario,
    name: &str,
    problem: &TensorProblem<D>,
    simulation: &TensorSimulation<D>,
    out: &Path,
    threads: usize,
    wall_seconds: f64,
    failure: Option<&Error>,
    extra_warnings: &[String],
    remedies: RemedyCounts,
    write_files: bool,
) -> Result<Summary> {
    let p = &simulation.particles;
    let columns = exact_columns(problem, simulation, scenario);
    let mut field_errors = Vec::new();
    let errors = (!columns.is_empty()).then(|| {
        let mut errors = Errors::default();
        for (field, exact) in &columns {
            let (rms, rel) = vector_errors(&numerical(p, *field), exact, *field == Field::Stress);
            errors.rms.insert(field.name().into(), rms);
            errors.rel_l2.insert(field.name().into(), rel);
            // Judged against the exact field at the end (`rel_l2`).
            field_errors.push(crate::app::warnings::FieldError {
                field: field.name().into(),
                error_l2: rel,
                size_l2: 1.0,
                at_end_only: true,
            });
        }
        errors
    });
    let mut warnings = scenario.ignored_key_warnings();
    warnings.extend(extra_warnings.iter().cloned());
    warnings.extend(crate::app::warnings::run_warnings(&field_errors));
    let (status, failed_step) = Error::run_outcome(failure, simulation.steps_done);
    let summary = Summary {
        scenario: name.to_string(),
        status: status.into(),
        failure: failure.map(|e| e.to_string()),
        failed_step,
        problem: problem.name().into(),
        dim: Some(D),
        basis: simulation.stepper.basis_name().into(),
        reconstruction: simulation.stepper.reconstruction_name().into(),
        n_particles: p.len(),
        n_cells: problem.cells.iter().product(),
        n_steps: simulation.steps_done,
        time: simulation.time,
        threads,
        wall_seconds,
        errors,
        conservation: Conservation {
            max_rel_mass_error: simulation.max_mass_error,
            max_rel_momentum_error: simulation.max_momentum_error,
            liquid_max_rel_mass_error: None,
            liquid_max_rel_momentum_error: None,
        },
        grid_crossings: simulation.grid_crossings,
        solver: {
            let totals = simulation.stepper.solver_totals();
            SolverSummary {
                kind: totals.kind.into(),
                total_iterations: totals.total_iterations,
                max_iterations: totals.max_iterations,
                solves: totals.solves,
            }
        },
        timings: Some(simulation.stepper.timings()),
        reconstruction_remedies: remedies,
        warnings,
        config: scenario.clone(),
    };
    if !write_files {
        return Ok(summary);
    }
    write_tensor_particles(&out.join("particles.csv"), p, &as_refs(&columns))?;
    write_history(&out.join("history.csv"), &simulation.history)?;
    if scenario.output.plots && D >= 2 {
        let title = format!(
            "{name}: stress_xx at t = {:.4e} s ({}, {}D{})",
            simulation.time,
            simulation.stepper.basis_name(),
            D,
            if D == 3 { ", projected on x-y" } else { "" }
        );
        scatter_plot(
            &out.join("stress.svg"),
            &ScatterAxes {
                title: &title,
                x_label: "x [m]",
                y_label: "y [m]",
                colour_label: &format!("stress_{} [Pa]", STRESS_COMPONENTS[0]),
            },
            &p.x[0],
            &p.x[1.min(D - 1)],
            &p.stress[0],
        )?;
    }
    summary.write(&out.join("summary.json"))?;
    Ok(summary)
}
