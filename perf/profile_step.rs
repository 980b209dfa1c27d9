//! Profile the MPM step with pprof and write a flamegraph.
//!
//! ```text
//! cargo run --profile profiling --example profile_step -- --particles 1000000 --steps 200
//! cargo run --profile profiling --example profile_step -- --particles 120000 --steps 2000 --out /tmp/fg.svg
//! cargo run --profile profiling --example profile_step -- --basis bspline --order 2 --out /tmp/fg_p2.svg
//! cargo run --profile profiling --example profile_step -- --dim 2 --cells 128 --solver kron --steps 50
//! ```
//!
//! `--dim 1` (default): `--steps` steps of the vibrating bar
//! (`scenarios/vibrating_bar.toml`: linear basis, lumped mass, MUSL, 12 particles per cell,
//! `dt = 1e-7`) with about `--particles` particles, or with `--basis` (`bspline` of
//! `--order`, `gimp`, `cpdi`, ...) instead of the linear one. `--dim 2 | 3`: the axis-aligned
//! manufactured solution (`scenarios/axis_aligned_mms.toml`) on `--cells` cells per axis
//! with `--per-cell` particles per cell, B-splines of `--order`, TLS
//! (`--reconstruction none` for plain B-spline MPM) and the consistent mass solved with
//! `--solver` (`--mass lumped` for the lumped step); it also prints the seconds per phase
//! of the step and the share of the mass solve. Runs on the global rayon pool
//! (`RAYON_NUM_THREADS` picks the thread count), sampled at 1000 Hz. Writes the flamegraph
//! SVG to `--out` (default `perf/flamegraph_step.svg`, 2D/3D
//! `perf/flamegraph_step_<dim>d.svg` in the crate) and prints the frames with the most self
//! samples and the `tlsmpm` functions with the most inclusive samples. See
//! `perf/README.md`.

#[cfg(unix)]
fn main() {
    common::main(profile::USAGE, profile::Options::parse, profile::run);
}

#[cfg(not(unix))]
fn main() {
    eprintln!("error: profile_step needs pprof, which is only available on unix");
    std::process::exit(1);
}

#[cfg(unix)]
#[path = "common/mod.rs"]
mod common;

#[cfg(unix)]
mod profile {
    use crate::common;
    use std::path::PathBuf;
    use std::time::Instant;
    use tlsmpm::app::build::build_simulation;
    use tlsmpm::app::tensor_run::build_tensor_simulation;

    const SCENARIO: &str = include_str!("../scenarios/vibrating_bar.toml");
    const MMS: &str = include_str!("../scenarios/axis_aligned_mms.toml");
    const PER_CELL: usize = 12;

    pub const USAGE: &str = "\
usage: profile_step [--dim 1|2|3] [--particles N] [--steps S] [--out FILE]
                    [--basis B] [--order p] [--cells n] [--per-cell k] [--order p] [--reconstruction tls|none]
                    [--mass consistent|lumped] [--solver kron|pmg_cg|pmg|cg|pcg|direct]

  --dim D          1: the vibrating bar (default); 2, 3: the axis-aligned MMS
  --particles N    1D: particles, rounded down to a multiple of 12 (default 1000000)
  --steps S        time steps to profile (default 200 in 1D, 20 in 2D/3D, at least 1)
  --out FILE       flamegraph SVG to write (default perf/flamegraph_step[_2d|_3d].svg)
  --basis B        method.basis (1D default: the scenario's linear; 2D/3D: bspline)
  --order p        B-spline order (default 2; for --basis bspline in 1D)
  2D/3D only:
  --cells n        cells per axis (default 500 in 2D, 50 in 3D)
  --per-cell k     particles per cell, a perfect square / cube (default 4 in 2D, 8 in 3D)
  --reconstruction tls (default) or none
  --mass           consistent (default; method.mass) or lumped
  --solver K       solver.kind of the consistent mass (default: the 2D/3D default)
  -h, --help       this message

2D/3D steps use dt = min(1e-5, h / (4 c)) with c = 100, below the stability limit.";

    pub struct Options {
        pub dim: usize,
        pub particles: usize,
        pub steps: Option<usize>,
        pub out: Option<PathBuf>,
        pub cells: Option<usize>,
        pub per_cell: Option<usize>,
        pub order: usize,
        pub basis: Option<String>,
        pub reconstruction: String,
        pub mass: String,
        pub solver: Option<String>,
    }

    impl Options {
        /// `Ok(None)` for `--help`; `Err` with a message for bad arguments.
        pub fn parse(args: &[String]) -> Result<Option<Self>, String> {
            let mut options = Options {
                dim: 1,
                particles: 1_000_000,
                steps: None,
                out: None,
                cells: None,
                per_cell: None,
                order: 2,
                basis: None,
                reconstruction: "tls".into(),
                mass: "consistent".into(),
                solver: None,
            };
            let flags = [
                "--dim",
                "--particles",
                "--steps",
                "--out",
                "--cells",
                "--per-cell",
                "--order",
                "--basis",
                "--reconstruction",
                "--mass",
                "--solver",
            ];
            let complete = common::parse_flags(args, &flags, |flag, value| {
                match flag {
                    "--dim" => {
                        options.dim = common::count(flag, &value)?;
                        if options.dim > 3 {
                            return Err(format!("`--dim {value}`: expected 1, 2 or 3"));
                        }
                    }
                    "--particles" => {
                        options.particles = common::count(flag, &value)?;
                        if options.particles < PER_CELL {
                            return Err(format!(
                                "`--particles {value}`: need at least {PER_CELL} (one cell)"
                            ));
                        }
                    }
                    "--steps" => options.steps = Some(common::count(flag, &value)?),
                    "--cells" => options.cells = Some(common::count(flag, &value)?),
                    "--per-cell" => options.per_cell = Some(common::count(flag, &value)?),
                    "--order" => options.order = common::count(flag, &value)?,
                    "--basis" => options.basis = Some(value),
                    "--reconstruction" => match value.as_str() {
                        "tls" | "none" => options.reconstruction = value,
                        _ => return Err(format!("`--reconstruction {value}`: tls or none")),
                    },
                    "--mass" => match value.as_str() {
                        "consistent" | "lumped" => options.mass = value,
                        _ => return Err(format!("`--mass {value}`: consistent or lumped")),
                    },
                    "--solver" => options.solver = Some(value),
                    _ => options.out = Some(common::out_path(value)?),
                }
                Ok(())
            })?;
            Ok(complete.then_some(options))
        }
    }

    pub fn run(options: &Options) -> Result<(), String> {
        match options.dim {
            2 => run_tensor::<2>(options),
            3 => run_tensor::<3>(options),
            _ => run_bar(options),
        }
    }

    fn default_out(name: &str) -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("perf")
            .join(name)
    }

    fn run_bar(options: &Options) -> Result<(), String> {
        let cells = options.particles / PER_CELL;
        let steps = options.steps.unwrap_or(200);
        let mut overrides = vec![
            format!("grid.cells={cells}"),
            format!("particles.per_cell={PER_CELL}"),
            "time.dt=1.0e-7".to_string(),
        ];
        if let Some(basis) = &options.basis {
            overrides.push(format!("method.basis=\"{basis}\""));
            if basis == "bspline" {
                overrides.push(format!("method.order={}", options.order));
            }
        }
        let scenario = tlsmpm::config::from_str(SCENARIO, "vibrating_bar.toml", &overrides)
            .map_err(|e| e.to_string())?;
        let (problem, mut sim) = build_simulation(&scenario, false).map_err(|e| e.to_string())?;
        let particles = sim.particles.len();
        let threads = rayon::current_num_threads();
        let basis = options.basis.as_deref().unwrap_or("linear");
        println!(
            "profiling {steps} steps, {particles} particles on {cells} cells ({basis}), \
             {threads} rayon threads"
        );

        let guard = common::start_profiler()?;
        let start = Instant::now();
        let dt = sim.stepper.dt();
        let mut crossings = 0;
        for step in 1..=steps {
            let time = step as f64 * dt;
            let report = sim
                .stepper
                .step(
                    &mut sim.particles,
                    tlsmpm::physics::Body::Uniform(problem.body_acceleration(time)),
                    step,
                    time,
                )
                .map_err(|e| e.to_string())?;
            crossings += report.crossings;
        }
        let elapsed = start.elapsed().as_secs_f64();
        let report = common::build_report(&guard)?;
        println!(
            "{:.3} s, {:.3} ms/step, {:.3e} particle-steps/s, {crossings} grid crossings",
            elapsed,
            1e3 * elapsed / steps as f64,
            (particles * steps) as f64 / elapsed
        );

        let out = options
            .out
            .clone()
            .unwrap_or_else(|| default_out("flamegraph_step.svg"));
        common::write_flamegraph(&report, &out)?;
        common::print_tables(&report);
        Ok(())
    }

    fn run_tensor<const D: usize>(options: &Options) -> Result<(), String> {
        let cells = options.cells.unwrap_or(if D == 2 { 500 } else { 50 });
        let per_cell = options.per_cell.unwrap_or(1 << D);
        let steps = options.steps.unwrap_or(20);
        // The scenario's 1e-5, or a quarter of h / c (c = 100) on fine grids, below the
        // stability limit of B-splines up to order 3.
        let dt = f64::min(1.0e-5, 0.25 / (100.0 * cells as f64));
        let mut overrides = vec![
            format!("problem.dim={D}"),
            format!("grid.cells={cells}"),
            format!("particles.per_cell={per_cell}"),
            format!("method.order={}", options.order),
            format!(
                "method.basis=\"{}\"",
                options.basis.as_deref().unwrap_or("bspline")
            ),
            format!("method.reconstruction={}", options.reconstruction),
            format!("method.mass={}", options.mass),
            format!("time.dt={dt:e}"),
            format!("time.end={:e}", dt * steps as f64),
            "output.plots=false".to_string(),
        ];
        if let Some(kind) = &options.solver {
            overrides.push(format!("solver.kind={kind}"));
        }
        let scenario = tlsmpm::config::from_str(MMS, "axis_aligned_mms.toml", &overrides)
            .map_err(|e| e.to_string())?;
        let (problem, mut sim) =
            build_tensor_simulation::<D>(&scenario, false).map_err(|e| e.to_string())?;
        let particles = sim.particles.len();
        let threads = rayon::current_num_threads();
        println!(
            "profiling {steps} steps of axis_aligned_mms {D}D: {particles} particles on {cells}^{D} cells, \
             B-splines p = {}, reconstruction {}, mass {}, solver {}, {threads} rayon threads",
            options.order,
            options.reconstruction,
            options.mass,
            sim.stepper.solver_totals().kind,
        );

        let guard = common::start_profiler()?;
        let start = Instant::now();
        sim.run(&problem, &mut |_| Ok(true))
            .map_err(|e| e.to_string())?;
        let elapsed = start.elapsed().as_secs_f64();
        let report = common::build_report(&guard)?;
        let steps = sim.steps_done;
        println!(
            "{:.3} s, {:.3} ms/step, {:.3e} particle-steps/s, {} grid crossings",
            elapsed,
            1e3 * elapsed / steps as f64,
            (particles * steps) as f64 / elapsed,
            sim.grid_crossings
        );
        let solver = sim.stepper.solver_totals();
        let t = sim.stepper.timings();
        let per_step = |s: f64| 1e3 * s / t.steps.max(1) as f64;
        let share = |s: f64| 100.0 * s / t.total_seconds().max(f64::MIN_POSITIVE);
        println!("\nphase                     ms/step   share");
        for (name, seconds) in [
            ("mass and force mapping", t.mass_and_force_seconds),
            ("consistent-mass assembly", t.assembly_seconds),
            ("mass solve", t.mass_solve_seconds),
            ("velocity and momentum", t.velocity_and_momentum_seconds),
            ("particle update", t.particle_update_seconds),
        ] {
            println!(
                "{name:<25} {:8.3}  {:5.1}%",
                per_step(seconds),
                share(seconds)
            );
        }
        println!("{:<25} {:8.3}", "total", per_step(t.total_seconds()));
        if solver.kind != "lumped" {
            println!(
                "solver {}: {} iterations in {} solves ({:.2} per solve), at most {}",
                solver.kind,
                solver.total_iterations,
                solver.solves,
                solver.total_iterations as f64 / solver.solves.max(1) as f64,
                solver.max_iterations
            );
        }

        let out = options
            .out
            .clone()
            .unwrap_or_else(|| default_out(&format!("flamegraph_step_{D}d.svg")));
        common::write_flamegraph(&report, &out)?;
        common::print_tables(&report);
        Ok(())
    }
}
