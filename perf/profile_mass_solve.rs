//! Profile the consistent-mass solve with pprof and write a flamegraph.
//!
//! ```text
//! cargo run --profile profiling --example profile_mass_solve
//! cargo run --profile profiling --example profile_mass_solve -- --solver kron --solves 200
//! cargo run --profile profiling --example profile_mass_solve -- --dim 1 --cells 1e6 --solver banded
//! ```
//!
//! Assembles the `tlsmpm solver-study` problem (B-splines of order `--order` on `--cells`
//! spans per direction of the unit interval or square, boundary DOFs dropped, load
//! `f_i = 9.81 int phi_i`, density `--density`), builds the `--solver` solver once (as a
//! time stepper does), then runs `--solves` solves from a zero guess on the global rayon
//! pool (`RAYON_NUM_THREADS` picks the thread count), sampled at 1000 Hz. Writes the
//! flamegraph SVG to `--out` (default `perf/flamegraph_mass_solve.svg` in the crate) and
//! prints the frames with the most self samples and the `tlsmpm` functions with the most
//! inclusive samples. See `perf/README.md`.

#[cfg(unix)]
fn main() {
    common::main(profile::USAGE, profile::Options::parse, profile::run);
}

#[cfg(not(unix))]
fn main() {
    eprintln!("error: profile_mass_solve needs pprof, which is only available on unix");
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
    use tlsmpm::app::solver_study::{StudyDensity, StudyProblem, MAX_STUDY_DOFS};
    use tlsmpm::app::solvers::build_solver;
    use tlsmpm::config::{SolverConfig, SolverKind};

    /// Highest B-spline order accepted (that of `tlsmpm solver-study`).
    const MAX_ORDER: usize = tlsmpm::app::solver_study::MAX_STUDY_ORDER;

    pub const USAGE: &str = "\
usage: profile_mass_solve [--dim D] [--order P] [--cells N] [--solver KIND]
                          [--density unit|sine] [--solves S] [--out FILE]

  --dim D         1 or 2 (default 2)
  --order P       B-spline order, 1 to 10 (default 5)
  --cells N       spans per direction (default 256)
  --solver KIND   cg, pcg, pmg, pmg_cg, direct, banded or kron (default cg)
  --density D     unit (rho = 1) or sine (rho = 1 + 0.9 sin 2 pi x sin 2 pi y, the
                  MPM-like variable density; default)
  --solves S      solves to profile, each from a zero guess (default 20, at least 1)
  --out FILE      flamegraph SVG to write (default perf/flamegraph_mass_solve.svg in the crate)
  -h, --help      this message";

    pub struct Options {
        pub dim: usize,
        pub order: usize,
        pub cells: usize,
        pub solver: SolverKind,
        pub density: StudyDensity,
        pub solves: usize,
        pub out: PathBuf,
    }

    impl Options {
        /// `Ok(None)` for `--help`; `Err` with a message for bad arguments.
        pub fn parse(args: &[String]) -> Result<Option<Self>, String> {
            let mut options = Options {
                dim: 2,
                order: 5,
                cells: 256,
                solver: SolverKind::Cg,
                density: StudyDensity::Sine,
                solves: 20,
                out: PathBuf::from(env!("CARGO_MANIFEST_DIR"))
                    .join("perf/flamegraph_mass_solve.svg"),
            };
            let flags = [
                "--dim",
                "--order",
                "--cells",
                "--solver",
                "--density",
                "--solves",
                "--out",
            ];
            let complete = common::parse_flags(args, &flags, |flag, value| {
                match flag {
                    "--dim" => {
                        options.dim = match value.as_str() {
                            "1" => 1,
                            "2" => 2,
                            _ => return Err(format!("`--dim {value}`: expected 1 or 2")),
                        }
                    }
                    "--order" => {
                        options.order = common::count(flag, &value)?;
                        if options.order > MAX_ORDER {
                            return Err(format!(
                                "`--order {value}`: expected an order from 1 to {MAX_ORDER}"
                            ));
                        }
                    }
                    "--cells" => options.cells = common::count(flag, &value)?,
                    "--solver" => {
                        options.solver = SolverKind::parse(&value).ok_or_else(|| {
                            let kinds: Vec<&str> =
                                SolverKind::ALL.iter().map(|k| k.name()).collect();
                            format!("`--solver {value}`: expected one of {}", kinds.join(", "))
                        })?
                    }
                    "--density" => {
                        options.density = StudyDensity::parse(&value)
                            .ok_or_else(|| format!("`--density {value}`: expected unit or sine"))?
                    }
                    "--solves" => options.solves = common::count(flag, &value)?,
                    _ => options.out = common::out_path(value)?,
                }
                Ok(())
            })?;
            if !complete {
                return Ok(None);
            }
            // Interior DOFs per direction: cells + order - 2 (at least one).
            let per_direction = options
                .cells
                .checked_add(options.order)
                .map(|n| n.saturating_sub(2));
            let dofs = per_direction.and_then(|n| n.checked_pow(options.dim as u32));
            match dofs {
                Some(0) => {
                    return Err(format!(
                        "`--order {} --cells {}`: no interior DOFs (need order + cells >= 3)",
                        options.order, options.cells
                    ))
                }
                Some(n) if n <= MAX_STUDY_DOFS => {}
                _ => {
                    return Err(format!(
                        "`--cells {}`: more than {MAX_STUDY_DOFS} DOFs in {}D",
                        options.cells, options.dim
                    ))
                }
            }
            Ok(Some(options))
        }
    }

    pub fn run(options: &Options) -> Result<(), String> {
        let density = match options.density {
            StudyDensity::Unit => "unit",
            StudyDensity::Sine => "sine",
        };
        let problem = StudyProblem::new(options.dim, options.order, options.cells, options.density)
            .map_err(|e| format!("assembling the mass matrix: {e}"))?;
        let kind = options.solver;
        let config = SolverConfig {
            kind: Some(kind),
            ..Default::default()
        };
        let mut solver = build_solver(&config, &problem.geometry)
            .map_err(|e| format!("solver `{}`: {e}", kind.name()))?;
        let dofs = problem.matrix.rows;
        let threads = rayon::current_num_threads();
        println!(
            "{}D, order {}, {} cells per direction, {density} density: {dofs} DOFs, {} nonzeros",
            options.dim,
            options.order,
            options.cells,
            problem.matrix.nnz()
        );
        let target = match kind {
            SolverKind::Direct | SolverKind::Banded => "factorisation".to_string(),
            _ => format!("relative residual {:e}", config.tolerance),
        };
        println!(
            "profiling {} `{}` solves ({target}), {threads} rayon threads",
            options.solves,
            kind.name(),
        );

        let mut x = vec![0.0; dofs];
        let guard = common::start_profiler()?;
        let start = Instant::now();
        let mut first = None;
        for solve in 1..=options.solves {
            x.fill(0.0);
            let stats = solver
                .solve(&problem.matrix, &problem.rhs, &mut x)
                .map_err(|e| format!("solve {solve} (`{}`): {e}", kind.name()))?;
            first.get_or_insert((stats, start.elapsed().as_secs_f64()));
        }
        let elapsed = start.elapsed().as_secs_f64();
        let report = common::build_report(&guard)?;
        if let Some((stats, seconds)) = first {
            println!(
                "first solve: {} iterations, relative residual {:.3e}, {:.3} ms",
                stats.iterations,
                stats.relative_residual,
                1e3 * seconds
            );
        }
        println!(
            "{:.3} s, {:.3} ms/solve, {:.3e} DOFs/s",
            elapsed,
            1e3 * elapsed / options.solves as f64,
            (dofs * options.solves) as f64 / elapsed
        );

        common::write_flamegraph(&report, &options.out)?;
        common::print_tables(&report);
        Ok(())
    }
}
