//! Profile the MPM step with pprof and write a flamegraph.
//!
//! ```text
//! cargo run --release --example profile_step -- --particles 1000000 --steps 200
//! cargo run --release --example profile_step -- --particles 120000 --steps 2000 --out /tmp/fg.svg
//! ```
//!
//! Runs `--steps` steps of the vibrating bar (`scenarios/vibrating_bar.toml`: linear basis,
//! lumped mass, MUSL, 12 particles per cell, `dt = 1e-7`) with about `--particles`
//! particles on the global rayon pool (`RAYON_NUM_THREADS` picks the thread count), sampled
//! at 1000 Hz. Writes the flamegraph SVG to `--out` (default `perf/flamegraph_step.svg` in
//! the crate) and prints the frames with the most self samples and the `tlsmpm` functions
//! with the most inclusive samples. See `perf/README.md`.

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

    const SCENARIO: &str = include_str!("../scenarios/vibrating_bar.toml");
    const PER_CELL: usize = 12;

    pub const USAGE: &str = "\
usage: profile_step [--particles N] [--steps S] [--out FILE]

  --particles N   particles, rounded down to a multiple of 12 (default 1000000, at least 12)
  --steps S       time steps to profile (default 200, at least 1)
  --out FILE      flamegraph SVG to write (default perf/flamegraph_step.svg in the crate)
  -h, --help      this message";

    pub struct Options {
        pub particles: usize,
        pub steps: usize,
        pub out: PathBuf,
    }

    impl Options {
        /// `Ok(None)` for `--help`; `Err` with a message for bad arguments.
        pub fn parse(args: &[String]) -> Result<Option<Self>, String> {
            let mut options = Options {
                particles: 1_000_000,
                steps: 200,
                out: PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("perf/flamegraph_step.svg"),
            };
            let flags = ["--particles", "--steps", "--out"];
            let complete = common::parse_flags(args, &flags, |flag, value| {
                match flag {
                    "--particles" => {
                        options.particles = common::count(flag, &value)?;
                        if options.particles < PER_CELL {
                            return Err(format!(
                                "`--particles {value}`: need at least {PER_CELL} (one cell)"
                            ));
                        }
                    }
                    "--steps" => options.steps = common::count(flag, &value)?,
                    _ => options.out = common::out_path(value)?,
                }
                Ok(())
            })?;
            Ok(complete.then_some(options))
        }
    }

    pub fn run(options: &Options) -> Result<(), String> {
        let cells = options.particles / PER_CELL;
        let overrides = [
            format!("grid.cells={cells}"),
            format!("particles.per_cell={PER_CELL}"),
            "time.dt=1.0e-7".to_string(),
        ];
        let scenario = tlsmpm::config::from_str(SCENARIO, "vibrating_bar.toml", &overrides)
            .map_err(|e| e.to_string())?;
        let (problem, mut sim) = build_simulation(&scenario, false).map_err(|e| e.to_string())?;
        let particles = sim.particles.len();
        let threads = rayon::current_num_threads();
        println!(
            "profiling {} steps, {particles} particles on {cells} cells, {threads} rayon threads",
            options.steps
        );

        let guard = common::start_profiler()?;
        let start = Instant::now();
        let dt = sim.stepper.dt();
        let mut crossings = 0;
        for step in 1..=options.steps {
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
            1e3 * elapsed / options.steps as f64,
            (particles * options.steps) as f64 / elapsed
        );

        common::write_flamegraph(&report, &options.out)?;
        common::print_tables(&report);
        Ok(())
    }
}
