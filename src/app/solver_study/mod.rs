//! `tlsmpm solver-study` (DESIGN §2, SPEC §5.1): B-spline mass matrices on the unit
//! interval or square, boundary DOFs eliminated (first and last function of each direction
//! dropped), right-hand side the load of a constant body force `f_i = 9.81 int phi_i`;
//! for every order and cell count, the condition number and, per solver, the iterations,
//! the time and the relative residual of a solve to `solver.tolerance` from a zero guess.
//!
//! With unit density the 2D matrix is `M_1D (x) M_1D` exactly (SPEC §5.1); `--density sine`
//! uses `rho = 1 + 0.9 sin 2 pi x sin 2 pi y` (1D: `1 + 0.9 sin 2 pi x`), the variable-density
//! case of SPEC §5.3, assembled with `p + 2` Gauss points per span and direction.
//!
//! Outputs: `solver_study.csv` (columns `dim,order,cells,dofs,condition_number,solver,
//! iterations,seconds,relative_residual`; a failed solve leaves `iterations` empty and
//! `seconds`, `relative_residual` as `nan`), `solver_iterations.svg` and
//! `solver_seconds.svg` (against the order, at the largest cell count), and the tables in
//! the layout of SPEC §5.1 (returned as text).

pub mod published;

use crate::app::solvers::{build_solver, SolverGeometry};
use crate::config::{SolverConfig, SolverKind};
use crate::error::{Error, Result};
use crate::linalg::assembly::{interior, load_1d, QuadraturePoint, SplineSpace};
use crate::linalg::{condition, CoarseOperators, CsrMatrix, DirectCholesky, KroneckerFactors};
use crate::output::plot::{loglog_plot, Axes, Series, Style};
use crate::output::write_atomic;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Body force of the right-hand side (SPEC §5.1).
pub const BODY_FORCE: f64 = 9.81;
/// Condition numbers are estimated up to this many DOFs: Lanczos keeps its basis of up to
/// [`CONDITION_MAX_STEPS`] vectors (at most 1 GB).
pub const MAX_CONDITION_DOFS: usize = 125_000;
/// Lanczos steps per extreme eigenvalue.
pub const CONDITION_MAX_STEPS: usize = 1_000;
/// Lanczos stops when the extreme Ritz values change by less than this (relative) over five
/// steps; far below the 3 digits asked for.
pub const CONDITION_TOLERANCE: f64 = 1e-7;
/// Highest B-spline order of the study.
pub const MAX_STUDY_ORDER: usize = 10;
/// Most DOFs of one study matrix.
pub const MAX_STUDY_DOFS: usize = 20_000_000;

/// The density of the study matrices.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StudyDensity {
    /// `rho = 1`: the published set-up.
    Unit,
    /// `rho = 1 + 0.9 sin 2 pi x sin 2 pi y`.
    Sine,
}

impl StudyDensity {
    pub fn parse(name: &str) -> Option<Self> {
        match name {
            "unit" => Some(Self::Unit),
            "sine" => Some(Self::Sine),
            _ => None,
        }
    }
}

/// What to study.
#[derive(Clone, Debug)]
pub struct SolverStudyOptions {
    pub dim: usize,
    pub orders: Vec<usize>,
    pub cells: Vec<usize>,
    pub solvers: Vec<SolverKind>,
    /// Tolerance, smoother and sweeps; `kind` is replaced by each of `solvers`.
    pub config: SolverConfig,
    pub density: StudyDensity,
    /// Timed repetitions of each solve (the fastest is reported).
    pub repeats: usize,
    pub out_dir: PathBuf,
}

impl SolverStudyOptions {
    /// The default solver list: every kind that applies to `dim` (banded only in 1D, where
    /// it is the speed limit; in 2D its band is `p (n + p)` wide).
    pub fn default_solvers(dim: usize) -> Vec<SolverKind> {
        SolverKind::ALL
            .into_iter()
            .filter(|&k| dim == 1 || k != SolverKind::Banded)
            .collect()
    }

    fn validate(&self) -> Result<()> {
        if !(1..=2).contains(&self.dim) {
            return Err(Error::invalid("--dim", self.dim, "must be 1 or 2"));
        }
        if self.orders.is_empty() || self.cells.is_empty() || self.solvers.is_empty() {
            return Err(Error::invalid(
                "--orders/--cells/--solvers",
                "(empty)",
                "give at least one value each",
            ));
        }
        if let Some(&p) = self.orders.iter().find(|&&p| p == 0 || p > MAX_STUDY_ORDER) {
            return Err(Error::invalid(
                "--orders",
                p,
                format!("B-spline orders must be between 1 and {MAX_STUDY_ORDER}"),
            ));
        }
        for &n in &self.cells {
            let max_order = self.orders.iter().copied().max().unwrap_or(1);
            let dofs = (n + max_order).saturating_sub(2).pow(self.dim as u32);
            if n < 2 || dofs > MAX_STUDY_DOFS {
                return Err(Error::invalid(
                    "--cells",
                    n,
                    format!("need at least 2 spans and at most {MAX_STUDY_DOFS} DOFs"),
                ));
            }
        }
        if !(self.config.tolerance > 0.0 && self.config.tolerance < 1.0) {
            return Err(Error::invalid(
                "--tolerance",
                self.config.tolerance,
                "must be in (0, 1)",
            ));
        }
        if self.repeats == 0 {
            return Err(Error::invalid("--repeats", 0, "must be at least 1"));
        }
        Ok(())
    }
}

/// One solve of the study (one CSV row).
#[derive(Clone, Debug, PartialEq)]
pub struct SolverStudyRow {
    pub dim: usize,
    pub order: usize,
    pub cells: usize,
    pub dofs: usize,
    /// `None` above [`MAX_CONDITION_DOFS`].
    pub condition_number: Option<f64>,
    pub solver: SolverKind,
    /// `None` when the solve failed.
    pub iterations: Option<usize>,
    pub seconds: f64,
    pub relative_residual: f64,
}

/// `rho = 1 + 0.9 sin 2 pi x`.
fn sine_density_1d(q: &QuadraturePoint) -> f64 {
    1.0 + 0.9 * (2.0 * std::f64::consts::PI * q.x[0]).sin()
}

/// `rho = 1 + 0.9 sin 2 pi x sin 2 pi y`.
fn sine_density_2d(q: &QuadraturePoint) -> f64 {
    let tau = 2.0 * std::f64::consts::PI;
    1.0 + 0.9 * (tau * q.x[0]).sin() * (tau * q.x[1]).sin()
}

/// The study problem at one order and cell count: the matrix with boundary DOFs dropped,
/// the load vector and the geometry the structured solvers need.
pub struct StudyProblem {
    pub geometry: SolverGeometry,
    pub matrix: CsrMatrix,
    pub rhs: Vec<f64>,
}

impl StudyProblem {
    /// Assemble the `dim`-dimensional problem of B-splines of `order` on `cells` spans per
    /// direction.
    pub fn new(dim: usize, order: usize, cells: usize, density: StudyDensity) -> Result<Self> {
        study_problem(dim, order, cells, density)
    }
}

fn study_problem(
    dim: usize,
    order: usize,
    cells: usize,
    density: StudyDensity,
) -> Result<StudyProblem> {
    let space = SplineSpace::new(order, cells, 1.0)
        .ok_or_else(|| Error::invalid("--orders", order, "no B-spline space of this order"))?;
    let keep = interior(space.functions());
    let load: Vec<f64> = load_1d(&space, BODY_FORCE)
        .into_iter()
        .zip(&keep)
        .filter_map(|(f, &k)| k.then_some(f))
        .collect();
    let geometry = SolverGeometry {
        directions: vec![space; dim],
        boundary_dropped: true,
        coarse_operators: CoarseOperators::Rediscretised,
        density: match density {
            StudyDensity::Unit => None,
            StudyDensity::Sine if dim == 1 => Some(sine_density_1d),
            StudyDensity::Sine => Some(sine_density_2d),
        },
    };
    let rhs: Vec<f64> = if dim == 1 {
        load
    } else {
        load.iter()
            .flat_map(|&fy| load.iter().map(move |&fx| fx * fy))
            .collect()
    };
    let matrix = match (dim, geometry.density) {
        // Unit density: exactly the Kronecker product of the 1D matrices (SPEC §5.1).
        (1, None) => geometry.unit_masses().remove(0),
        (_, None) => {
            let m = geometry.unit_masses().remove(0);
            m.kron(&m)
        }
        (_, Some(rho)) => geometry.mass_matrix(order, Some(rho))?,
    };
    Ok(StudyProblem {
        geometry,
        matrix,
        rhs,
    })
}

/// `kappa(M)` by Lanczos on `M` and on `M^{-1}`; the inverse is the Kronecker line solve for
/// unit density and a sparse Cholesky otherwise.
fn condition_number(problem: &StudyProblem, density: StudyDensity) -> Result<f64> {
    let a = &problem.matrix;
    let estimate = match density {
        StudyDensity::Unit => {
            let mut factors = KroneckerFactors::new(&problem.geometry.unit_masses())?;
            let mut inverse = |r: &[f64], z: &mut [f64]| factors.solve(r, z);
            condition::condition_number_with(
                a,
                Some(&mut inverse),
                CONDITION_MAX_STEPS,
                CONDITION_TOLERANCE,
            )?
        }
        StudyDensity::Sine => {
            let mut direct = DirectCholesky::new();
            direct.factor(a)?;
            let mut failed = None;
            let mut inverse = |r: &[f64], z: &mut [f64]| {
                if let Err(err) = direct.solve_factored(r, z) {
                    failed.get_or_insert(err);
                    z.fill(f64::NAN);
                }
            };
            let estimate = condition::condition_number_with(
                a,
                Some(&mut inverse),
                CONDITION_MAX_STEPS,
                CONDITION_TOLERANCE,
            );
            if let Some(err) = failed {
                return Err(err);
            }
            estimate?
        }
    };
    Ok(estimate.condition_number)
}

/// Run the study; `progress(order, cells, solver)` is called before each solve.
pub fn solver_study(
    options: &SolverStudyOptions,
    progress: &mut dyn FnMut(usize, usize, SolverKind),
) -> Result<Vec<SolverStudyRow>> {
    options.validate()?;
    let mut rows = Vec::new();
    for &order in &options.orders {
        for &cells in &options.cells {
            let problem = study_problem(options.dim, order, cells, options.density)?;
            let dofs = problem.matrix.rows;
            // A spectrum too dense at its ends for Lanczos to settle (long 1D problems) leaves
            // the condition number out with a warning; the solves still run.
            let condition = if dofs <= MAX_CONDITION_DOFS {
                match condition_number(&problem, options.density) {
                    Ok(kappa) => Some(kappa),
                    Err(err) => {
                        eprintln!("warning: condition number at p = {order}, 1/h = {cells}: {err}");
                        None
                    }
                }
            } else {
                None
            };
            for &kind in &options.solvers {
                progress(order, cells, kind);
                let (iterations, seconds, relative_residual) =
                    match time_solve(&problem, kind, options) {
                        Ok((stats, seconds)) => {
                            (Some(stats.iterations), seconds, stats.relative_residual)
                        }
                        Err(err) => {
                            eprintln!(
                                "warning: {} at p = {order}, 1/h = {cells}: {err}",
                                kind.name()
                            );
                            (None, f64::NAN, f64::NAN)
                        }
                    };
                rows.push(SolverStudyRow {
                    dim: options.dim,
                    order,
                    cells,
                    dofs,
                    condition_number: condition,
                    solver: kind,
                    iterations,
                    seconds,
                    relative_residual,
                });
            }
        }
    }
    write_outputs(options, &rows)?;
    Ok(rows)
}

/// Solve from a zero guess once (iterations, residual), then time up to `repeats` more
/// solves within about a second and keep the fastest. Set-up that a time stepper does once
/// (solver construction: transfers, Kronecker factors) is not timed; per-solve work
/// (numeric factorisations, Galerkin coarse operators, preconditioner set-up) is.
fn time_solve(
    problem: &StudyProblem,
    kind: SolverKind,
    options: &SolverStudyOptions,
) -> Result<(crate::linalg::SolveStats, f64)> {
    let config = SolverConfig {
        kind: Some(kind),
        ..options.config.clone()
    };
    let mut solver = build_solver(&config, &problem.geometry)?;
    let mut x = vec![0.0; problem.rhs.len()];
    let start = Instant::now();
    let stats = solver.solve(&problem.matrix, &problem.rhs, &mut x)?;
    let mut fastest = start.elapsed();
    let budget = Instant::now();
    for _ in 1..options.repeats {
        if budget.elapsed() > Duration::from_secs(1) {
            break;
        }
        x.fill(0.0);
        let start = Instant::now();
        solver.solve(&problem.matrix, &problem.rhs, &mut x)?;
        fastest = fastest.min(start.elapsed());
    }
    Ok((stats, fastest.as_secs_f64()))
}

fn write_outputs(options: &SolverStudyOptions, rows: &[SolverStudyRow]) -> Result<()> {
    std::fs::create_dir_all(&options.out_dir)
        .map_err(|e| Error::write(&options.out_dir, e.to_string()))?;
    let mut csv = String::from(
        "dim,order,cells,dofs,condition_number,solver,iterations,seconds,relative_residual\n",
    );
    for r in rows {
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{},{},{:e},{:e}",
            r.dim,
            r.order,
            r.cells,
            r.dofs,
            r.condition_number
                .map_or(String::new(), |k| format!("{k:e}")),
            r.solver.name(),
            r.iterations.map_or(String::new(), |k| k.to_string()),
            r.seconds,
            r.relative_residual
        );
    }
    write_atomic(&options.out_dir.join("solver_study.csv"), csv.as_bytes())?;
    let Some(&largest) = options.cells.iter().max() else {
        return Ok(());
    };
    let labels: Vec<String> = options
        .solvers
        .iter()
        .map(|k| k.name().to_string())
        .collect();
    let mut iteration_series = Vec::new();
    let mut time_series = Vec::new();
    for &kind in &options.solvers {
        let picked: Vec<&SolverStudyRow> = rows
            .iter()
            .filter(|r| r.solver == kind && r.cells == largest && r.iterations.is_some())
            .collect();
        let order: Vec<f64> = picked.iter().map(|r| r.order as f64).collect();
        // Direct solves take 0 iterations: plot them as 1 on the log axis.
        let iterations: Vec<f64> = picked
            .iter()
            .map(|r| r.iterations.unwrap_or(0).max(1) as f64)
            .collect();
        let seconds: Vec<f64> = picked.iter().map(|r| r.seconds).collect();
        iteration_series.push((order.clone(), iterations));
        time_series.push((order, seconds));
    }
    let title = format!("{}D mass matrix, 1/h = {largest}", options.dim);
    for (file, y_label, data) in [
        (
            "solver_iterations.svg",
            "iterations (direct: 1)",
            &iteration_series,
        ),
        ("solver_seconds.svg", "seconds per solve", &time_series),
    ] {
        let series: Vec<Series> = data
            .iter()
            .zip(&labels)
            .map(|((x, y), label)| Series {
                label,
                x: x.into(),
                y: y.into(),
                style: Style::LinePoints,
            })
            .collect();
        loglog_plot(
            &options.out_dir.join(file),
            &Axes {
                title: &title,
                x_label: "B-spline order p",
                y_label,
            },
            &series,
        )?;
    }
    Ok(())
}

/// The tables in the layout of SPEC §5.1 (rows `p`, columns `1/h`): condition numbers,
/// then iterations and seconds per solver; for the 2D unit-density set-up the published
/// value follows in parentheses where SPEC has one.
pub fn format_tables(options: &SolverStudyOptions, rows: &[SolverStudyRow]) -> String {
    let published = options.dim == 2 && options.density == StudyDensity::Unit;
    let mut out = String::new();
    let header = |out: &mut String, title: &str| {
        let _ = writeln!(out, "\n{title}\n");
        let _ = write!(out, "| p \\ 1/h |");
        for n in &options.cells {
            let _ = write!(out, " {n} |");
        }
        let _ = writeln!(out);
        let _ = write!(out, "|---|");
        for _ in &options.cells {
            let _ = write!(out, "---|");
        }
        let _ = writeln!(out);
    };
    let find = |order: usize, cells: usize, kind: SolverKind| {
        rows.iter()
            .find(|r| r.order == order && r.cells == cells && r.solver == kind)
    };
    let first = options.solvers[0];
    header(
        &mut out,
        &format!(
            "Condition number kappa(M), {}D{}",
            options.dim,
            if published { " (published)" } else { "" }
        ),
    );
    for &p in &options.orders {
        let _ = write!(out, "| {p} |");
        for &n in &options.cells {
            let value = find(p, n, first).and_then(|r| r.condition_number);
            let mut cell = value.map_or("-".to_string(), |k| format!("{}", Sig3(k)));
            if published {
                if let Some(k) = published::condition_number(p, n) {
                    let _ = write!(cell, " ({})", Sig3(k));
                }
            }
            let _ = write!(out, " {cell} |");
        }
        let _ = writeln!(out);
    }
    for &kind in &options.solvers {
        header(
            &mut out,
            &format!(
                "{}: iterations to {:e}{}",
                kind.name(),
                options.config.tolerance,
                if published && matches!(kind, SolverKind::Cg | SolverKind::Pmg) {
                    " (published)"
                } else {
                    ""
                }
            ),
        );
        for &p in &options.orders {
            let _ = write!(out, "| {p} |");
            for &n in &options.cells {
                let mut cell = find(p, n, kind)
                    .and_then(|r| r.iterations)
                    .map_or("failed".to_string(), |k| k.to_string());
                if published {
                    if let Some(k) = published::iterations(kind.name(), p, n) {
                        let _ = write!(cell, " ({k})");
                    }
                }
                let _ = write!(out, " {cell} |");
            }
            let _ = writeln!(out);
        }
    }
    for &kind in &options.solvers {
        header(&mut out, &format!("{}: seconds per solve", kind.name()));
        for &p in &options.orders {
            let _ = write!(out, "| {p} |");
            for &n in &options.cells {
                let seconds = find(p, n, kind).map_or(f64::NAN, |r| r.seconds);
                let _ = write!(out, " {seconds:.3e} |");
            }
            let _ = writeln!(out);
        }
    }
    out
}

/// Three significant digits, fixed below 1000 and scientific above.
struct Sig3(f64);

impl std::fmt::Display for Sig3 {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let v = self.0;
        if v.abs() >= 1000.0 {
            write!(f, "{v:.2e}")
        } else if v.abs() >= 100.0 {
            write!(f, "{v:.0}")
        } else if v.abs() >= 10.0 {
            write!(f, "{v:.1}")
        } else {
            write!(f, "{v:.2}")
        }
    }
}
