//! One simulation with its outputs: `summary.json`, `particles.csv`, `history.csv`,
//! snapshots and the stress-profile plot. On a numerical failure everything computed is
//! written before the error is returned: `summary.json` (status `"failed"`, the message
//! and `failed_step`), the history of the completed steps, and `particles.csv` with the
//! particle state at the moment of failure (partly updated by the failing step, so the
//! non-finite values or the escaping particle can be located). A run asked to stop
//! ([`RunOptions::stop`]) ends after the current step and writes the same files with status
//! `"interrupted"`.

use crate::app::build_simulation;
use crate::app::warnings::{run_warnings, FieldError};
use crate::config::{Scenario, VelocityReference};
use crate::error::{Error, Result};
use crate::numerics::norms::{relative_l2, rms};
use crate::output::csv::{write_history, write_particles, ExactColumn};
use crate::output::plot::{profile_plot, semilogy_plot, Axes, Series, Style, Values};
use crate::output::summary::{Conservation, Errors, SolverSummary};
use crate::output::Summary;
use crate::particles::Particles;
use crate::physics::distributed::RankExchange;
use crate::physics::Simulation;
use crate::problems::{Field, PlotAxis, Problem, ProblemBody};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// How to run.
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// Output directory (created if missing; the files of this run are written into it).
    pub out_dir: PathBuf,
    /// Worker threads (`None`: rayon's default, one per core).
    pub threads: Option<usize>,
    /// Run even if the time step is above the stability limit.
    pub force: bool,
    /// Checked after every step: once it is `true` the run stops with
    /// [`Error::Interrupted`], after writing the state reached (status `"interrupted"`).
    pub stop: Option<&'static AtomicBool>,
    /// Warnings found by the caller (a study's replaced keys), reported in the summary
    /// with the run's own.
    pub warnings: Vec<String>,
    /// The ranks of a distributed 2D / 3D run (`None`: one process).
    pub ranks: Option<Ranks>,
}

/// How a distributed run reaches the other ranks: a new [`RankExchange`] of this
/// process's rank on each call (`docs/distributed.md`).
#[derive(Clone)]
pub struct Ranks(pub std::sync::Arc<dyn Fn() -> Box<dyn RankExchange> + Send + Sync>);

impl std::fmt::Debug for Ranks {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Ranks(..)")
    }
}

impl RunOptions {
    /// `Err(Error::Interrupted)` once [`RunOptions::stop`] is set.
    pub(crate) fn check_stop(&self, step: usize, time: f64) -> Result<()> {
        match self.stop {
            Some(stop) if stop.load(Ordering::Relaxed) => Err(Error::Interrupted { step, time }),
            _ => Ok(()),
        }
    }
}

/// Run `scenario` (named `name` in the summary), writing all outputs into
/// `options.out_dir`. `progress(step, n_steps)` is called after every step.
pub fn run(
    scenario: &Scenario,
    name: &str,
    options: &RunOptions,
    progress: &mut (dyn FnMut(usize, usize) + Send),
) -> Result<Summary> {
    if scenario.problem.dim != 1 {
        return crate::app::tensor_run::run_tensor(scenario, name, options, progress);
    }
    if options.ranks.is_some() {
        return Err(Error::invalid(
            "problem.dim",
            1,
            "a distributed run (more than one MPI rank) needs problem.dim = 2 or 3",
        ));
    }
    let pool = thread_pool(options.threads)?;
    let (problem, mut simulation) = build_simulation(scenario, options.force)?;
    std::fs::create_dir_all(&options.out_dir).map_err(|e| Error::write(&options.out_dir, e))?;
    let n_steps = scenario.n_steps();
    let snapshots = scenario.output.snapshots.min(n_steps);
    let vtk = scenario.output.vtk;
    let mut vtk_series: Vec<(f64, String)> = Vec::new();
    if vtk {
        let file = "particles_0000.vtu".to_string();
        write_vtu_1d(&options.out_dir.join(&file), &simulation.particles)?;
        vtk_series.push((simulation.time(), file));
    }
    let clock = Instant::now();
    let mut snapshot_error = None;
    let outcome = pool.install(|| {
        simulation.run(
            n_steps,
            &ProblemBody(problem.as_ref()),
            &mut |sim: &Simulation| {
                progress(sim.steps_done, n_steps);
                // Snapshot k of `snapshots` at step ceil(k n / snapshots), the last one final.
                if snapshots > 0 && (sim.steps_done * snapshots) % n_steps < snapshots {
                    let k = sim.steps_done * snapshots / n_steps;
                    let result = if vtk {
                        let file = format!("particles_{k:04}.vtu");
                        vtk_series.push((sim.time(), file.clone()));
                        write_vtu_1d(&options.out_dir.join(file), &sim.particles)
                    } else {
                        let path = options.out_dir.join(format!("snapshot_{k:04}.csv"));
                        let columns = exact_columns(problem.as_ref(), sim, scenario);
                        write_particles(&path, &sim.particles, &as_refs(&columns))
                    };
                    if let Err(e) = result {
                        snapshot_error = Some(e);
                    }
                }
                options.check_stop(sim.steps_done, sim.time())
            },
        )
    });
    let wall_seconds = clock.elapsed().as_secs_f64();
    if let Some(e) = snapshot_error {
        return Err(e);
    }
    if vtk {
        if vtk_series
            .last()
            .is_none_or(|(t, _)| *t < simulation.time())
        {
            let file = format!("particles_{:04}.vtu", vtk_series.len());
            write_vtu_1d(&options.out_dir.join(&file), &simulation.particles)?;
            vtk_series.push((simulation.time(), file));
        }
        crate::output::vtu::write_pvd(&options.out_dir.join("particles.pvd"), &vtk_series)?;
    }
    let summary = write_outputs(
        scenario,
        name,
        problem.as_ref(),
        &simulation,
        &options.out_dir,
        pool.current_num_threads(),
        wall_seconds,
        outcome.as_ref().err(),
        &options.warnings,
    )?;
    outcome.map(|()| summary)
}

/// A 1D particle state as a VTU file (points on the x axis; two-phase runs add the liquid
/// velocity and pore pressure).
fn write_vtu_1d(path: &Path, p: &Particles) -> Result<()> {
    use crate::output::vtu::{write_vtu, PointArray};
    let mut arrays = vec![
        PointArray::new("displacement", vec![&p.u]),
        PointArray::new("velocity", vec![&p.v]),
        PointArray::new("stress", vec![&p.stress]),
        PointArray::new("volume", vec![&p.volume]),
        PointArray::new("density", vec![&p.density]),
        PointArray::new("mass", vec![&p.mass]),
    ];
    if let Some(l) = &p.liquid {
        arrays.push(PointArray::new("liquid_velocity", vec![&l.velocity]));
        arrays.push(PointArray::new("pore_pressure", vec![&l.pore_pressure]));
    }
    write_vtu(path, &[&p.x], &arrays)
}

/// A rayon pool of `threads` workers (`None`: one per core); 0 is an input error.
pub fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    if threads == Some(0) {
        return Err(Error::invalid("--threads", 0, "must be at least 1"));
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()
        .map_err(|e| Error::invalid("--threads", threads.unwrap_or(0), e.to_string()))
}

/// Exact (or reference) values of every known field at every particle, at the current
/// time (velocity at `t - dt/2` with `output.velocity_reference = "half_step"`, unless the
/// reference velocity is itself time-stepped).
pub fn exact_columns(
    problem: &dyn Problem,
    simulation: &Simulation,
    scenario: &Scenario,
) -> Vec<(Field, Vec<f64>)> {
    let t = simulation.time();
    let dt = scenario.time.dt.seconds();
    problem
        .exact_fields()
        .iter()
        .map(|&field| {
            let time = match (field, scenario.output.velocity_reference) {
                (field, VelocityReference::HalfStep)
                    if field.is_velocity()
                        && simulation.steps_done > 0
                        && !problem.velocity_is_time_stepped() =>
                {
                    t - 0.5 * dt
                }
                _ => t,
            };
            let values = problem.exact_profile(field, &simulation.particles.x0, time);
            (field, values)
        })
        .collect()
}

fn as_refs(columns: &[(Field, Vec<f64>)]) -> Vec<ExactColumn<'_>> {
    columns
        .iter()
        .map(|(field, values)| ExactColumn {
            field: *field,
            values,
        })
        .collect()
}

/// The final error of `field` (`error_l2`, `sqrt(n)` times its RMS error) and the size of
/// its exact solution over the run (the
/// largest L2 norm at the end and at the problem's peak times), for [`run_warnings`].
fn field_error(
    problem: &dyn Problem,
    field: Field,
    error_l2: f64,
    exact: &[f64],
    x0: &[f64],
    end: f64,
) -> FieldError {
    let l2 = |values: &[f64]| values.iter().map(|v| v * v).sum::<f64>().sqrt();
    let peaks = problem.solution_peak_times(end);
    let size_l2 = peaks
        .iter()
        .map(|&t| l2(&problem.exact_profile(field, x0, t)))
        .fold(l2(exact), f64::max);
    FieldError {
        field: field.name().into(),
        error_l2,
        size_l2,
        at_end_only: peaks.is_empty(),
    }
}

/// The particle values of `field` (NaN when the particles lack it).
fn numerical(particles: &Particles, field: Field) -> std::borrow::Cow<'_, [f64]> {
    field
        .values(particles)
        .unwrap_or_else(|| vec![f64::NAN; particles.len()].into())
}

#[allow(clippy::too_many_arguments)]
fn write_outputs(
    scenario: &Scenario,
    name: &str,
    problem: &dyn Problem,
    simulation: &Simulation,
    out_dir: &Path,
    threads: usize,
    wall_seconds: f64,
    failure: Option<&Error>,
    extra_warnings: &[String],
) -> Result<Summary> {
    let particles = &simulation.particles;
    let columns = exact_columns(problem, simulation, scenario);
    let mut field_errors = Vec::new();
    let errors = (!columns.is_empty()).then(|| {
        let mut errors = Errors::default();
        for (field, exact) in &columns {
            let num = numerical(particles, *field);
            let error_rms = rms(&num, exact);
            errors.rms.insert(field.name().into(), error_rms);
            errors
                .rel_l2
                .insert(field.name().into(), relative_l2(&num, exact));
            field_errors.push(field_error(
                problem,
                *field,
                error_rms * (num.len().min(exact.len()) as f64).sqrt(),
                exact,
                &particles.x0,
                simulation.time(),
            ));
        }
        errors
    });
    let (basis, reconstruction) = simulation.stepper.method_names();
    let mut warnings = scenario.ignored_key_warnings();
    warnings.extend(extra_warnings.iter().cloned());
    warnings.extend(run_warnings(&field_errors));
    let (status, failed_step) = Error::run_outcome(failure, simulation.steps_done);
    let summary = Summary {
        scenario: name.to_string(),
        status: status.into(),
        failure: failure.map(|e| e.to_string()),
        failed_step,
        problem: problem.name().into(),
        dim: None,
        basis: basis.into(),
        reconstruction: reconstruction.into(),
        n_particles: particles.len(),
        n_cells: scenario.grid.cells.along_x(),
        n_steps: simulation.steps_done,
        time: simulation.time(),
        threads,
        wall_seconds,
        errors,
        conservation: Conservation {
            max_rel_mass_error: simulation.max_mass_error,
            max_rel_momentum_error: simulation.max_momentum_error,
            liquid_max_rel_mass_error: simulation.max_liquid_mass_error,
            liquid_max_rel_momentum_error: simulation.max_liquid_momentum_error,
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
        timings: None,
        reconstruction_remedies: simulation.stepper.remedies(),
        warnings,
        config: scenario.clone(),
    };
    write_particles(
        &out_dir.join("particles.csv"),
        particles,
        &as_refs(&columns),
    )?;
    write_history(&out_dir.join("history.csv"), &simulation.history)?;
    if scenario.output.plots {
        let profiles: &[(Field, &str, &str)] = if particles.liquid.is_some() {
            &[
                (Field::Stress, "stress.svg", "total stress [Pa]"),
                (
                    Field::PorePressure,
                    "pore_pressure.svg",
                    "pore pressure [Pa]",
                ),
                (
                    Field::EffectiveStress,
                    "effective_stress.svg",
                    "effective stress [Pa]",
                ),
            ]
        } else {
            &[(Field::Stress, "stress.svg", "stress [Pa]")]
        };
        let positions = plot_positions(problem, particles);
        for &(field, file, y_label) in profiles {
            profile_of(
                &out_dir.join(file),
                name,
                field,
                y_label,
                problem,
                &positions,
                simulation,
                &columns,
            )?;
        }
        if !columns.is_empty() {
            error_plot(
                &out_dir.join("errors.svg"),
                name,
                &positions,
                simulation,
                &columns,
            )?;
        }
    }
    summary.write(&out_dir.join("summary.json"))?;
    Ok(summary)
}

/// Particle order along the plot axis of `problem`, and the axis label.
fn plot_positions<'a>(problem: &dyn Problem, p: &'a Particles) -> PlotPositions<'a> {
    let (position, x_label) = match problem.plot_axis() {
        PlotAxis::Current => (&p.x, "x [m]"),
        PlotAxis::Initial => (&p.x0, "initial position X [m]"),
    };
    let mut order: Vec<usize> = (0..p.len()).collect();
    // Stable: equal positions keep storage order, for any thread count.
    order.par_sort_by(|&a, &b| position[a].total_cmp(&position[b]));
    PlotPositions {
        order,
        position,
        x_label,
    }
}

/// Particles sorted along the plot axis (shared by every plot of a run). The plots read
/// the particle arrays through `order` ([`Values::Computed`]): no sorted copy of a column
/// is made, so plotting 1e7 particles costs the order (8 bytes a particle) and no more.
struct PlotPositions<'a> {
    /// Storage indices in the order of the plot axis.
    order: Vec<usize>,
    /// The positions along the plot axis, in storage order.
    position: &'a [f64],
    x_label: &'static str,
}

impl PlotPositions<'_> {
    /// The sorted position of the `i`-th particle along the plot axis.
    fn x(&self, i: usize) -> f64 {
        self.position[self.order[i]]
    }

    /// `values` read in the order of the plot axis.
    fn sorted<'v>(&'v self, values: &'v [f64]) -> impl Fn(usize) -> f64 + Sync + 'v {
        move |i| values[self.order[i]]
    }
}

/// One field of the error profile: the particles' values, the exact ones (both in storage
/// order) and `max_p |f_exact|` (1 where that is 0).
struct ErrorField<'a> {
    label: &'a str,
    numerical: std::borrow::Cow<'a, [f64]>,
    exact: &'a [f64],
    scale: f64,
}

/// Error profile: `|f_p - f_exact(X_p)| / max_p |f_exact|` of every known field over the
/// plot axis; shows where the error lives (e.g. the boundary spans of lumped BSMPM).
fn error_plot(
    path: &Path,
    name: &str,
    positions: &PlotPositions,
    simulation: &Simulation,
    columns: &[(Field, Vec<f64>)],
) -> Result<()> {
    let p = &simulation.particles;
    let n = positions.order.len();
    let fields: Vec<ErrorField> = columns
        .iter()
        .map(|(field, exact)| {
            let scale = exact.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            ErrorField {
                label: field.name(),
                numerical: numerical(p, *field),
                exact,
                scale: if scale > 0.0 { scale } else { 1.0 },
            }
        })
        .collect();
    let errors: Vec<_> = fields
        .iter()
        .map(|f| {
            move |i: usize| {
                let k = positions.order[i];
                (f.numerical[k] - f.exact[k]).abs() / f.scale
            }
        })
        .collect();
    let x = |i: usize| positions.x(i);
    // Points, not lines: neighbouring particles' errors are not a curve (they alternate
    // in sign and size), and on the log axis 1e-3 and 1e-10 are both readable.
    let series: Vec<Series> = fields
        .iter()
        .zip(&errors)
        .map(|(f, error)| Series {
            label: f.label,
            x: Values::Computed { len: n, at: &x },
            y: Values::Computed { len: n, at: error },
            style: Style::Points,
        })
        .collect();
    let (basis, reconstruction) = simulation.stepper.method_names();
    let title = format!(
        "{name} ({basis} / {reconstruction}): |error| / max |exact| at t = {:.4e} s",
        simulation.time()
    );
    semilogy_plot(
        path,
        &Axes {
            title: &title,
            x_label: positions.x_label,
            y_label: "relative error",
        },
        &series,
    )
}

/// Profile of `field`: particles (points) against the exact / reference values (line),
/// over the current or initial position as the problem prefers.
#[allow(clippy::too_many_arguments)]
fn profile_of(
    path: &Path,
    name: &str,
    field: Field,
    y_label: &str,
    problem: &dyn Problem,
    positions: &PlotPositions,
    simulation: &Simulation,
    columns: &[(Field, Vec<f64>)],
) -> Result<()> {
    let p = &simulation.particles;
    let n = positions.order.len();
    let values = numerical(p, field);
    let numerical_at = positions.sorted(&values);
    let exact = columns.iter().find(|(f, _)| *f == field);
    let exact_at = exact.map(|(_, values)| positions.sorted(values));
    let x = |i: usize| positions.x(i);
    let (basis, reconstruction) = simulation.stepper.method_names();
    let label = format!("{basis} / {reconstruction}");
    // The reference first, so that the particles are drawn over it.
    let mut series = Vec::new();
    if let Some(exact_at) = &exact_at {
        series.push(Series {
            label: problem.reference_label(),
            x: Values::Computed { len: n, at: &x },
            y: Values::Computed {
                len: n,
                at: exact_at,
            },
            style: Style::Reference,
        });
    }
    series.push(Series {
        label: &label,
        x: Values::Computed { len: n, at: &x },
        y: Values::Computed {
            len: n,
            at: &numerical_at,
        },
        style: Style::Points,
    });
    let title = format!(
        "{name}: {} at t = {:.4e} s",
        field.name().replace('_', " "),
        simulation.time()
    );
    profile_plot(
        path,
        &Axes {
            title: &title,
            x_label: positions.x_label,
            y_label,
        },
        &series,
    )
}
