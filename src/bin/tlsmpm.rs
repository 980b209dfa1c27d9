//! `tlsmpm`: the command line (DESIGN §2). A thin layer over the library: argument parsing,
//! scenario loading, the progress bar, and the mapping of errors to exit codes
//! (0 success, 2 bad input, 1 numerical failure after the partial output is written).

use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};
use tlsmpm::app::overlay::{Axis, OverlayOptions};
use tlsmpm::app::solver_study::{SolverStudyOptions, StudyDensity};
use tlsmpm::app::{self, builtin, RunOptions};
use tlsmpm::config::{self, Scenario, Smoother, SolverConfig, SolverKind};

#[derive(Parser)]
#[command(
    name = "tlsmpm",
    version,
    about = "Material point methods with conservative Taylor least squares"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run one simulation.
    Run {
        #[command(flatten)]
        common: Common,
    },
    /// Run a scenario over several cell counts and report convergence orders.
    Study {
        #[command(flatten)]
        common: Common,
        /// Cell counts, comma separated (e.g. 5,10,20,40).
        #[arg(long, value_delimiter = ',', required = true)]
        cells: Vec<usize>,
    },
    /// Function-reconstruction benchmark (SPEC 6.1): TLS vs cubic spline on sin x + 2.
    Reconstruct {
        /// Output directory for reconstruction.csv and reconstruction.svg.
        #[arg(long, default_value = "out/reconstruction")]
        out: PathBuf,
    },
    /// Consistent-mass solver study (SPEC 5.1): condition numbers, iterations and time per
    /// solver for B-spline mass matrices on the unit interval or square.
    SolverStudy {
        /// Dimension: 1 (banded matrices) or 2 (tensor product).
        #[arg(long, default_value_t = 2)]
        dim: usize,
        /// B-spline orders, comma separated.
        #[arg(long, value_delimiter = ',', default_value = "1,2,3,4,5")]
        orders: Vec<usize>,
        /// Spans per direction (1/h), comma separated.
        #[arg(long, value_delimiter = ',', default_value = "8,16,32,64")]
        cells: Vec<usize>,
        /// Solvers, comma separated: cg, pcg, pmg, pmg_cg, direct, banded, kron
        /// [default: all; banded only in 1D].
        #[arg(long, value_delimiter = ',')]
        solvers: Vec<String>,
        /// Relative residual to reach.
        #[arg(long, default_value_t = 1e-8)]
        tolerance: f64,
        /// p-multigrid smoother: jacobi, gauss_seidel or symmetric_gauss_seidel (the best
        /// of SPEC 5.2).
        #[arg(long, default_value = "symmetric_gauss_seidel")]
        smoother: String,
        /// p-multigrid pre-smoothing sweeps.
        #[arg(long, default_value_t = 8)]
        pre_smooth: usize,
        /// p-multigrid post-smoothing sweeps.
        #[arg(long, default_value_t = 8)]
        post_smooth: usize,
        /// Density: unit (published set-up) or sine (1 + 0.9 sin 2 pi x sin 2 pi y).
        #[arg(long, default_value = "unit")]
        density: String,
        /// Timed repetitions per solve (the fastest is reported).
        #[arg(long, default_value_t = 3)]
        repeats: usize,
        /// Worker threads [default: one per core].
        #[arg(long)]
        threads: Option<usize>,
        /// Output directory.
        #[arg(long, default_value = "out/solver_study")]
        out: PathBuf,
    },
    /// Overlay one particle field (a `particles.csv` column) of several finished runs.
    Overlay {
        /// Run directories, each holding a particles.csv.
        #[arg(required = true, num_args = 1..)]
        runs: Vec<PathBuf>,
        /// Column to plot (any name in the header, e.g. stress, pore_pressure, u).
        #[arg(long)]
        field: String,
        /// Horizontal axis: x0 (initial position), x (current position), or h (cell size of
        /// study directories: their study.csv on log-log axes).
        #[arg(long, default_value = "x0")]
        axis: String,
        /// Series label, one per run in order (repeatable) [default: the directory name
        /// with the basis / reconstruction of its summary.json].
        #[arg(long = "label")]
        labels: Vec<String>,
        /// Also draw the first run's <FIELD>_exact column as a line.
        #[arg(long)]
        exact: bool,
        /// Output SVG [default: overlay_<FIELD>.svg].
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// List the built-in scenarios.
    List,
}

#[derive(Args)]
struct Common {
    /// Scenario file (TOML), or the name of a built-in scenario (see `tlsmpm list`).
    scenario: String,
    /// Output directory [default: out/<scenario file stem>].
    #[arg(long)]
    out: Option<PathBuf>,
    /// Override a scenario key, e.g. --set grid.cells=40 (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// Worker threads [default: one per core].
    #[arg(long)]
    threads: Option<usize>,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
    /// Run even if the time step exceeds the stability limit.
    #[arg(long)]
    force: bool,
}

impl Common {
    /// Load the scenario (file, else built-in name) and its name (file stem).
    fn load(&self) -> tlsmpm::Result<(Scenario, String)> {
        let path = Path::new(&self.scenario);
        if !path.exists() {
            if let Some(b) = builtin::find(&self.scenario) {
                return Ok((
                    config::from_str(b.toml, b.name, &self.set)?,
                    b.name.to_string(),
                ));
            }
        }
        let scenario = config::load(path, &self.set)?;
        let name = path.file_stem().map_or_else(
            || "scenario".to_string(),
            |s| s.to_string_lossy().into_owned(),
        );
        Ok((scenario, name))
    }

    fn options(&self, name: &str) -> RunOptions {
        RunOptions {
            out_dir: self
                .out
                .clone()
                .unwrap_or_else(|| Path::new("out").join(name)),
            threads: self.threads,
            force: self.force,
        }
    }
}

/// A progress bar on stderr that appears only after a second, and never when quiet or
/// when stderr is not a terminal.
struct Progress {
    bar: ProgressBar,
    start: Instant,
    visible: bool,
    enabled: bool,
}

impl Progress {
    fn new(quiet: bool) -> Self {
        let bar = ProgressBar::with_draw_target(Some(0), ProgressDrawTarget::hidden());
        if let Ok(style) = ProgressStyle::with_template(
            "{prefix} [{bar:40}] {pos}/{len} steps, {per_sec}, eta {eta}",
        ) {
            bar.set_style(style.progress_chars("=> "));
        }
        Self {
            bar,
            start: Instant::now(),
            visible: false,
            enabled: !quiet && std::io::stderr().is_terminal(),
        }
    }

    fn update(&mut self, prefix: &str, step: usize, total: usize) {
        if !self.enabled {
            return;
        }
        if !self.visible && self.start.elapsed() > Duration::from_secs(1) {
            self.bar.set_draw_target(ProgressDrawTarget::stderr());
            self.visible = true;
        }
        self.bar.set_prefix(prefix.to_string());
        self.bar.set_length(total as u64);
        self.bar.set_position(step as u64);
    }

    fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match execute(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            let code = err
                .downcast_ref::<tlsmpm::Error>()
                .map_or(1, tlsmpm::Error::exit_code);
            // Library messages already carry their cause: print the top level only.
            eprintln!("error: {err}");
            ExitCode::from(code as u8)
        }
    }
}

fn execute(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::List => {
            for b in builtin::BUILTIN {
                println!("{:<22} {}", b.name, b.description);
            }
            Ok(())
        }
        Command::Overlay {
            runs,
            field,
            axis,
            labels,
            exact,
            out,
        } => {
            let axis = Axis::parse(&axis)
                .ok_or_else(|| tlsmpm::Error::invalid("--axis", &axis, "expected x0, x or h"))?;
            let options = OverlayOptions {
                runs,
                field,
                axis,
                labels,
                exact,
                out,
            };
            let path = app::overlay(&options)?;
            println!("wrote {}", path.display());
            Ok(())
        }
        Command::Reconstruct { out } => {
            let report = app::reconstruct(Some(&out))?;
            print!("{}", app::reconstruct::format_table(&report));
            println!("wrote {}", out.display());
            Ok(())
        }
        Command::SolverStudy {
            dim,
            orders,
            cells,
            solvers,
            tolerance,
            smoother,
            pre_smooth,
            post_smooth,
            density,
            repeats,
            threads,
            out,
        } => {
            let solvers = if solvers.is_empty() {
                SolverStudyOptions::default_solvers(dim)
            } else {
                solvers
                    .iter()
                    .map(|name| {
                        SolverKind::parse(name).ok_or_else(|| {
                            tlsmpm::Error::invalid(
                                "--solvers",
                                name,
                                "expected cg, pcg, pmg, pmg_cg, direct, banded or kron",
                            )
                        })
                    })
                    .collect::<Result<_, _>>()?
            };
            let smoother = match smoother.as_str() {
                "jacobi" => Smoother::Jacobi,
                "gauss_seidel" => Smoother::GaussSeidel,
                "symmetric_gauss_seidel" => Smoother::SymmetricGaussSeidel,
                other => {
                    return Err(tlsmpm::Error::invalid(
                        "--smoother",
                        other,
                        "expected jacobi, gauss_seidel or symmetric_gauss_seidel",
                    )
                    .into())
                }
            };
            let density = StudyDensity::parse(&density).ok_or_else(|| {
                tlsmpm::Error::invalid("--density", &density, "expected unit or sine")
            })?;
            let options = SolverStudyOptions {
                dim,
                orders,
                cells,
                solvers,
                config: SolverConfig {
                    tolerance,
                    smoother,
                    pre_smooth,
                    post_smooth,
                    ..SolverConfig::default()
                },
                density,
                repeats,
                out_dir: out,
            };
            let pool = app::run::thread_pool(threads)?;
            let rows = pool.install(|| {
                app::solver_study::solver_study(&options, &mut |p, n, kind| {
                    eprintln!("p = {p}, 1/h = {n}: {}", kind.name())
                })
            })?;
            print!("{}", app::solver_study::format_tables(&options, &rows));
            println!(
                "wrote {}",
                options.out_dir.join("solver_study.csv").display()
            );
            Ok(())
        }
        Command::Run { common } => {
            let (scenario, name) = common.load()?;
            let options = common.options(&name);
            let mut progress = Progress::new(common.quiet);
            let result = app::run(&scenario, &name, &options, &mut |step, total| {
                progress.update("run", step, total)
            });
            progress.finish();
            let summary = result?;
            if !common.quiet {
                print_summary(&summary, &options.out_dir);
            }
            Ok(())
        }
        Command::Study { common, cells } => {
            let (scenario, name) = common.load()?;
            let options = common.options(&name);
            let mut progress = Progress::new(common.quiet);
            let rows = app::study(&scenario, &name, &cells, &options, &mut |n, step, total| {
                progress.update(&format!("{n} cells"), step, total)
            });
            progress.finish();
            let rows = rows?;
            print!("{}", app::study::format_table(&rows));
            println!("wrote {}", options.out_dir.join("study.csv").display());
            Ok(())
        }
    }
}

fn print_summary(summary: &tlsmpm::output::Summary, out_dir: &Path) {
    println!(
        "{}: {} particles, {} cells, {} steps, {:.3} s on {} threads",
        summary.scenario,
        summary.n_particles,
        summary.n_cells,
        summary.n_steps,
        summary.wall_seconds,
        summary.threads
    );
    if let Some(errors) = &summary.errors {
        for (field, rms) in &errors.rms {
            let rel = errors.rel_l2.get(field).copied().unwrap_or(f64::NAN);
            println!("  {field:<13} rms {rms:.4e}  rel L2 {rel:.4e}");
        }
    }
    println!(
        "  conservation: mass {:.3e}, momentum {:.3e}; grid crossings {}",
        summary.conservation.max_rel_mass_error,
        summary.conservation.max_rel_momentum_error,
        summary.grid_crossings
    );
    println!("  wrote {}", out_dir.display());
}
