//! `tlsmpm`: the command line. A thin layer over the library: argument parsing, scenario
//! loading, the output directory of a run (staged and renamed into place, see
//! [`tlsmpm::output::run_dir`]), SIGINT / SIGTERM, the progress display, and the mapping of
//! errors to exit codes (0 success; 2 bad input or an unusable output path; 1 numerical
//! failure, after the partial output is written; 130 interrupted, after the state reached
//! is written).

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
use tlsmpm::output::run_dir::StagedDir;

/// SIGINT / SIGTERM: the first asks the run to stop after the current step (it writes the
/// state reached, status `"interrupted"`, exit 130); a second one aborts at once.
mod interrupt {
    use std::sync::atomic::AtomicBool;

    /// Set by the first signal; runs poll it between steps.
    pub static STOP: AtomicBool = AtomicBool::new(false);

    #[cfg(unix)]
    extern "C" fn on_signal(_: libc::c_int) {
        // Async-signal-safe: one lock-free atomic and `_exit`.
        if STOP.swap(true, std::sync::atomic::Ordering::SeqCst) {
            // SAFETY: `_exit` is async-signal-safe and does not return.
            unsafe { libc::_exit(130) };
        }
    }

    /// Install the handlers, and restore the default SIGPIPE so that `tlsmpm ... | head`
    /// ends quietly instead of panicking on a closed pipe.
    pub fn install() {
        #[cfg(unix)]
        // SAFETY: the handler only touches an atomic and calls `_exit`; SIG_DFL for
        // SIGPIPE is the C default that Rust's runtime replaced.
        unsafe {
            let handler = on_signal as extern "C" fn(libc::c_int) as libc::sighandler_t;
            libc::signal(libc::SIGINT, handler);
            libc::signal(libc::SIGTERM, handler);
            libc::signal(libc::SIGPIPE, libc::SIG_DFL);
        }
    }

    /// Whether a stop was asked for.
    pub fn requested() -> bool {
        STOP.load(std::sync::atomic::Ordering::SeqCst)
    }
}

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
    /// Function-reconstruction benchmark: TLS vs cubic spline on sin x + 2 (the accuracy
    /// and conservation of one reconstruction, without a time step).
    Reconstruct {
        /// Output directory for reconstruction.csv and reconstruction.svg.
        #[arg(long, default_value = "out/reconstruction")]
        out: PathBuf,
    },
    /// Consistent-mass solver study (README, "Consistent-mass solvers"): condition numbers,
    /// iterations and time per solver for B-spline mass matrices on the unit interval or
    /// square.
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
        /// p-multigrid smoother: jacobi, gauss_seidel or symmetric_gauss_seidel (the
        /// best of the three on B-spline mass matrices).
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
        /// Horizontal axis: x0 (initial position), x (current position), h (cell size of
        /// study directories: their study.csv on log-log axes) or time (history.csv, with
        /// total_energy = kinetic_energy + strain_energy).
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
    /// Re-run the published tables and figures of the sources and write report.md: every
    /// published number next to ours, with a verdict (matched / better / differs) and its
    /// reason (docs/reproduce.md).
    Reproduce {
        /// Case ids (see --list) or all [default: all].
        ids: Vec<String>,
        /// The smallest sizes that still show the published behaviour (about 50 s on 2
        /// cores; the full run about 95 s).
        #[arg(long)]
        quick: bool,
        /// Output directory: report.md, the plots, runs/, studies/.
        #[arg(long, default_value = "out/reproduce")]
        out: PathBuf,
        /// Worker threads [default: one per core; at most 16 per core].
        #[arg(long, allow_negative_numbers = true, value_parser = parse_threads)]
        threads: Option<usize>,
        /// Print the case ids with their sources, and run nothing.
        #[arg(long)]
        list: bool,
        /// No progress display and no summary on stdout.
        #[arg(long)]
        quiet: bool,
        /// Replace an existing output directory whole.
        #[arg(long)]
        force: bool,
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
    /// Worker threads [default: one per core; at most 16 per core].
    #[arg(long, allow_negative_numbers = true, value_parser = parse_threads)]
    threads: Option<usize>,
    /// No progress display and no summary on stdout (errors are still printed).
    #[arg(long)]
    quiet: bool,
    /// Replace an existing output directory whole, and run even if the time step exceeds
    /// the stability limit.
    #[arg(long)]
    force: bool,
}

/// `--threads`: a whole number from 1 to 16 per core.
fn parse_threads(text: &str) -> Result<usize, String> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let limit = 16 * cores;
    match text.parse::<usize>() {
        Ok(0) => Err("must be at least 1".into()),
        Ok(n) if n > limit => Err(format!(
            "{n} threads is more than 16 per core ({limit} on this machine with {cores} cores)"
        )),
        Ok(n) => Ok(n),
        Err(_) => Err("expected a whole number of worker threads, at least 1".into()),
    }
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
            // A bare word is meant as a built-in name: say which ones exist.
            if path.extension().is_none() && path.components().count() == 1 {
                let names: Vec<&str> = builtin::BUILTIN.iter().map(|b| b.name).collect();
                return Err(tlsmpm::Error::invalid(
                    "SCENARIO",
                    &self.scenario,
                    format!(
                        "no such file or built-in scenario; the built-ins are {} (`tlsmpm list`)",
                        names.join(", ")
                    ),
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
            stop: Some(&interrupt::STOP),
            warnings: Vec::new(),
            ranks: None,
        }
    }
}

/// Run `body` with its output staged for `options.out_dir` (see
/// [`tlsmpm::output::run_dir`]): a success replaces `--out` whole; a numerical failure or
/// an interrupt keeps its partial output (in `--out` if that was free, else beside it);
/// bad input leaves nothing. Returns the result and where the files are.
fn staged_run<T>(
    options: &RunOptions,
    force: bool,
    body: impl FnOnce(&RunOptions) -> tlsmpm::Result<T>,
) -> anyhow::Result<(T, PathBuf)> {
    let staged = StagedDir::create(&options.out_dir, force)?;
    let inner = RunOptions {
        out_dir: staged.path().to_path_buf(),
        ..options.clone()
    };
    match body(&inner) {
        Ok(value) => {
            let dir = staged.commit()?;
            Ok((value, dir))
        }
        Err(err) if err.is_input_error() => {
            staged.discard();
            Err(err.into())
        }
        Err(err) => {
            let target = staged.target().to_path_buf();
            let kept = staged.keep_incomplete()?;
            if kept == target {
                Err(err.into())
            } else {
                Err(anyhow::Error::new(err).context(format!(
                    "{} kept; this run's partial output is in {}",
                    target.display(),
                    kept.display()
                )))
            }
        }
    }
}

/// Progress on stderr, never when quiet: on a terminal a bar that appears after a
/// second; otherwise (a pipe or a log file) one line every [`LINE_EVERY`].
struct Progress {
    bar: ProgressBar,
    start: Instant,
    visible: bool,
    mode: ProgressMode,
    last_line: Instant,
}

#[derive(Clone, Copy, PartialEq)]
enum ProgressMode {
    Off,
    Bar,
    Lines,
}

/// Interval of the progress lines when stderr is not a terminal.
const LINE_EVERY: Duration = Duration::from_secs(10);

impl Progress {
    fn new(quiet: bool) -> Self {
        let bar = ProgressBar::with_draw_target(Some(0), ProgressDrawTarget::hidden());
        if let Ok(style) = ProgressStyle::with_template(
            "{prefix} [{bar:40}] {pos}/{len} steps, {per_sec}, eta {eta}",
        ) {
            bar.set_style(style.progress_chars("=> "));
        }
        let mode = match (quiet, std::io::stderr().is_terminal()) {
            (true, _) => ProgressMode::Off,
            (false, true) => ProgressMode::Bar,
            (false, false) => ProgressMode::Lines,
        };
        Self {
            bar,
            start: Instant::now(),
            visible: false,
            mode,
            last_line: Instant::now(),
        }
    }

    fn update(&mut self, prefix: &str, step: usize, total: usize) {
        match self.mode {
            ProgressMode::Off => {}
            ProgressMode::Lines => {
                if self.last_line.elapsed() >= LINE_EVERY {
                    self.last_line = Instant::now();
                    let elapsed = self.start.elapsed().as_secs_f64();
                    eprintln!(
                        "{prefix}: step {step}/{total} ({:.0}%), {elapsed:.0} s",
                        100.0 * step as f64 / total.max(1) as f64
                    );
                }
            }
            ProgressMode::Bar => {
                if !self.visible && self.start.elapsed() > Duration::from_secs(1) {
                    self.bar.set_draw_target(ProgressDrawTarget::stderr());
                    self.visible = true;
                }
                self.bar.set_prefix(prefix.to_string());
                self.bar.set_length(total as u64);
                self.bar.set_position(step as u64);
            }
        }
    }

    fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

/// This process's rank and the number of ranks (`(0, 1)` without MPI).
static WORLD: std::sync::OnceLock<(usize, usize)> = std::sync::OnceLock::new();

fn world() -> (usize, usize) {
    WORLD.get().copied().unwrap_or((0, 1))
}

fn main() -> ExitCode {
    interrupt::install();
    let cli = Cli::parse();
    // Under `mpirun` (built with `--features mpi`) every rank runs this binary; MPI is
    // finalised when `_universe` drops at the end of `main`.
    #[cfg(feature = "mpi")]
    let _universe = {
        use mpi::traits::Communicator;
        let universe = mpi::initialize();
        if let Some(universe) = &universe {
            let world = universe.world();
            let rank = usize::try_from(world.rank()).unwrap_or(0);
            let size = usize::try_from(world.size()).unwrap_or(1);
            let _ = WORLD.set((rank, size));
        }
        universe
    };
    run_main(cli)
}

fn run_main(cli: Cli) -> ExitCode {
    // Under `mpirun` a build without MPI would run the whole problem once per rank, all
    // writing the same directory.
    #[cfg(not(feature = "mpi"))]
    if let Some(size) = launched_ranks().filter(|&n| n > 1) {
        eprintln!(
            "error: started as one of {size} MPI ranks, but this tlsmpm was built without \
             MPI: build it with `cargo build --release --features mpi` (docs/distributed.md)"
        );
        return ExitCode::from(2);
    }
    let (rank, ranks) = world();
    let prefix = if ranks > 1 {
        format!("rank {rank}: ")
    } else {
        String::new()
    };
    match execute(cli) {
        Ok(()) if interrupt::requested() => {
            // The signal came after the last step: the output is complete.
            eprintln!("interrupted (after the output was complete)");
            ExitCode::from(130)
        }
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            let code = err
                .downcast_ref::<tlsmpm::Error>()
                .map_or(1, tlsmpm::Error::exit_code);
            // Library messages carry their cause; a context (where the partial output
            // went) comes first.
            let message = match err.downcast_ref::<tlsmpm::Error>() {
                Some(inner) if err.chain().count() > 1 => {
                    format!("{prefix}error: {inner}; {err}\n")
                }
                _ => format!("{prefix}error: {err}\n"),
            };
            // One write per message: under `mpirun` the ranks share the terminal, and
            // `eprintln!` writes a formatted line in pieces that other ranks interleave.
            let _ = std::io::Write::write_all(&mut std::io::stderr().lock(), message.as_bytes());
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
            let axis = Axis::parse(&axis).ok_or_else(|| {
                tlsmpm::Error::invalid("--axis", &axis, "expected x0, x, h or time")
            })?;
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
        Command::Reproduce {
            ids,
            quick,
            out,
            threads,
            list,
            quiet,
            force,
        } => {
            let cases = app::reproduce::select(&ids)?;
            if list {
                for case in &cases {
                    println!("{:<24} {}", case.id, case.source);
                }
                return Ok(());
            }
            let options = app::reproduce::ReproduceOptions {
                ids,
                quick,
                out_dir: out.clone(),
                threads,
                stop: Some(&interrupt::STOP),
            };
            let run_options = RunOptions {
                out_dir: out,
                ..RunOptions::default()
            };
            let mut progress = Progress::new(quiet);
            let result = staged_run(&run_options, force, |staged| {
                let options = app::reproduce::ReproduceOptions {
                    out_dir: staged.out_dir.clone(),
                    ..options.clone()
                };
                app::reproduce::reproduce(&options, &mut |case, what, step, total| {
                    progress.update(&format!("{case}: {what}"), step, total)
                })
            });
            progress.finish();
            let (report, dir) = result?;
            let counts = report.counts();
            if !quiet {
                println!(
                    "{} cases, {} published numbers compared: {} matched, {} better, {} differs; \
                     {:.0} s",
                    report.cases.len(),
                    counts.compared,
                    counts.matched,
                    counts.better,
                    counts.differs,
                    report.seconds
                );
                println!(
                    "wrote {}",
                    dir.join(app::reproduce::report::REPORT).display()
                );
            }
            if counts.failed > 0 {
                anyhow::bail!(
                    "{} published numbers could not be computed (a run failed); see {}",
                    counts.failed,
                    dir.join(app::reproduce::report::REPORT).display()
                );
            }
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
            let mut options = common.options(&name);
            // A distributed run: rank 0 writes the outputs into `--out`; the other ranks
            // stage theirs (nothing but the directory) privately and say nothing.
            let (rank, ranks) = world();
            let root = rank == 0;
            if ranks > 1 {
                options.ranks = distributed_ranks();
                if !root {
                    options.out_dir = std::env::temp_dir()
                        .join(format!("tlsmpm-rank{rank}-{}", std::process::id()));
                }
            }
            let quiet = common.quiet || !root;
            let mut progress = Progress::new(quiet);
            let result = staged_run(&options, common.force || !root, |options| {
                app::run(&scenario, &name, options, &mut |step, total| {
                    progress.update("run", step, total)
                })
            });
            progress.finish();
            let (summary, dir) = result?;
            if !root {
                let _ = std::fs::remove_dir_all(&dir);
                return Ok(());
            }
            for warning in &summary.warnings {
                eprintln!("warning: {warning}");
            }
            if !quiet {
                print_summary(&summary, &dir);
            }
            Ok(())
        }
        Command::Study { common, cells } => {
            let (scenario, name) = common.load()?;
            let options = common.options(&name);
            let mut progress = Progress::new(common.quiet);
            let result = staged_run(&options, common.force, |options| {
                app::study(&scenario, &name, &cells, options, &mut |n, step, total| {
                    progress.update(&format!("{n} cells"), step, total)
                })
            });
            progress.finish();
            let (rows, dir) = result?;
            // The scenario's own warnings once, then each run's further ones.
            let mut shown = app::study::study_warnings(&scenario);
            shown.extend(scenario.ignored_key_warnings());
            for warning in &shown {
                eprintln!("warning: {warning}");
            }
            for row in &rows {
                for warning in row.warnings.iter().filter(|w| !shown.contains(w)) {
                    eprintln!("warning: {} cells: {warning}", row.cells);
                }
            }
            if !common.quiet {
                print!("{}", app::study::format_table(&rows));
                println!("wrote {}", dir.join("study.csv").display());
            }
            Ok(())
        }
    }
}

/// The number of ranks an MPI launcher (Open MPI, MPICH's PMI) says this process is one
/// of, from its environment.
#[cfg(not(feature = "mpi"))]
fn launched_ranks() -> Option<usize> {
    ["OMPI_COMM_WORLD_SIZE", "PMI_SIZE"]
        .iter()
        .find_map(|key| std::env::var(key).ok()?.parse().ok())
}

/// The ranks of `MPI_COMM_WORLD` for a distributed run.
#[cfg(feature = "mpi")]
fn distributed_ranks() -> Option<app::run::Ranks> {
    Some(app::run::Ranks(std::sync::Arc::new(|| {
        Box::new(tlsmpm::physics::distributed::MpiRanks::world())
    })))
}

/// Without the `mpi` feature there is one rank.
#[cfg(not(feature = "mpi"))]
fn distributed_ranks() -> Option<app::run::Ranks> {
    None
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
