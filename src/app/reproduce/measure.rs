//! Running what the cases need, each run, study and table once: a [`Lab`] keeps the
//! outcomes (keyed by what was run) and takes the numbers of [`Measure`]s from them.
//!
//! Layout under the output directory: `runs/<scenario>[__<overrides>]/` (each run's usual
//! outputs), `studies/<scenario>[__<overrides>]/` (a study: `study.csv`,
//! `convergence.svg`, `cells_<N>/`), `reconstruction/`, `solver_study/`.

use super::case::{Measure, Pair, ReconstructValue, RunSpec, RunValue, SolverTable, StudySpec};
use crate::app::overlay::Table;
use crate::app::reconstruct::ReconstructionReport;
use crate::app::solver_study::{SolverStudyOptions, SolverStudyRow, StudyDensity};
use crate::app::{builtin, RunOptions, StudyRow};
use crate::config::{self, Scenario, Smoother, SolverConfig, SolverKind};
use crate::error::{Error, Result};
use crate::numerics::norms::observed_order;
use crate::output::Summary;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

/// Cell counts (1/h) of the condition numbers and V-cycle counts, and of the CG counts.
const SOLVER_CELLS: [usize; 4] = [8, 16, 32, 64];
const CG_CELLS: [usize; 4] = [16, 32, 64, 128];
/// `--quick`: the two coarsest of each.
pub(crate) const QUICK_SOLVER_CELLS: [usize; 2] = [8, 16];
pub(crate) const QUICK_CG_CELLS: [usize; 2] = [16, 32];
/// Orders of the solver tables.
const SOLVER_ORDERS: [usize; 5] = [1, 2, 3, 4, 5];

/// A finished run: where its files are and its summary.
pub struct RunOutcome {
    pub dir: PathBuf,
    pub summary: Summary,
}

/// A finished study.
pub struct StudyOutcome {
    pub dir: PathBuf,
    pub rows: Vec<StudyRow>,
}

/// Runs, studies and tables, each done once; what failed is kept as its message.
pub struct Lab<'a> {
    pub quick: bool,
    pub out_dir: PathBuf,
    pub threads: Option<usize>,
    pub stop: Option<&'static AtomicBool>,
    /// `progress(what, step, total)` after every step of a run.
    pub progress: &'a mut (dyn FnMut(&str, usize, usize) + Send),
    runs: HashMap<RunSpec, std::result::Result<RunOutcome, String>>,
    studies: HashMap<(RunSpec, Vec<usize>), std::result::Result<StudyOutcome, String>>,
    reconstruction: Option<std::result::Result<ReconstructionReport, String>>,
    solver: Option<std::result::Result<Vec<SolverStudyRow>, String>>,
}

/// The directory name of a run or study: the scenario, then each override with `=` as
/// `-` and anything but letters, digits, `.`, `_`, `-` dropped.
///
/// ```
/// use tlsmpm::app::reproduce::{measure::dir_name, RunSpec};
/// let spec = RunSpec { scenario: "column_compaction", sets: &["method.basis=ddmpm"] };
/// assert_eq!(dir_name(&spec), "column_compaction__method.basis-ddmpm");
/// ```
pub fn dir_name(spec: &RunSpec) -> String {
    let mut name = spec.scenario.to_string();
    for set in spec.sets {
        name.push_str("__");
        name.extend(set.chars().filter_map(|c| match c {
            '=' => Some('-'),
            c if c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-') => Some(c),
            _ => None,
        }));
    }
    name
}

/// The built-in scenario of `spec` with its overrides.
fn scenario_of(spec: &RunSpec) -> Result<Scenario> {
    let builtin = builtin::find(spec.scenario).ok_or_else(|| {
        Error::invalid("reproduce case", spec.scenario, "no such built-in scenario")
    })?;
    let sets: Vec<String> = spec.sets.iter().map(|s| s.to_string()).collect();
    config::from_str(builtin.toml, builtin.name, &sets)
}

impl<'a> Lab<'a> {
    pub fn new(
        quick: bool,
        out_dir: &Path,
        threads: Option<usize>,
        stop: Option<&'static AtomicBool>,
        progress: &'a mut (dyn FnMut(&str, usize, usize) + Send),
    ) -> Self {
        Self {
            quick,
            out_dir: out_dir.to_path_buf(),
            threads,
            stop,
            progress,
            runs: HashMap::new(),
            studies: HashMap::new(),
            reconstruction: None,
            solver: None,
        }
    }

    fn run_options(&self, dir: PathBuf) -> RunOptions {
        RunOptions {
            out_dir: dir,
            threads: self.threads,
            force: false,
            stop: self.stop,
            warnings: Vec::new(),
            ranks: None,
        }
    }

    /// The run of `spec` (run now if it has not been).
    pub fn run(&mut self, spec: &RunSpec) -> std::result::Result<&RunOutcome, String> {
        if !self.runs.contains_key(spec) {
            let dir = self.out_dir.join("runs").join(dir_name(spec));
            let options = self.run_options(dir.clone());
            let label = dir_name(spec);
            let progress = &mut *self.progress;
            let outcome = scenario_of(spec)
                .and_then(|scenario| {
                    crate::app::run(&scenario, spec.scenario, &options, &mut |step, total| {
                        progress(&label, step, total)
                    })
                })
                .map(|summary| RunOutcome { dir, summary })
                .map_err(|e| format!("{}: {e}", dir_name(spec)));
            self.runs.insert(*spec, outcome);
        }
        match &self.runs[spec] {
            Ok(outcome) => Ok(outcome),
            Err(e) => Err(e.clone()),
        }
    }

    /// The study of `spec` at the cell counts of this reproduction.
    pub fn study(&mut self, spec: &StudySpec) -> std::result::Result<&StudyOutcome, String> {
        let run = RunSpec {
            scenario: spec.scenario,
            sets: spec.sets,
        };
        let cells = spec.cells(self.quick).to_vec();
        let key = (run, cells.clone());
        if !self.studies.contains_key(&key) {
            let dir = self.out_dir.join("studies").join(dir_name(&run));
            let options = self.run_options(dir.clone());
            let progress = &mut *self.progress;
            let outcome = scenario_of(&run)
                .and_then(|scenario| {
                    crate::app::study(
                        &scenario,
                        spec.scenario,
                        &cells,
                        &options,
                        &mut |n, s, t| progress(&format!("{} ({n} cells)", spec.label), s, t),
                    )
                })
                .map(|rows| StudyOutcome { dir, rows })
                .map_err(|e| format!("study {}: {e}", spec.label));
            self.studies.insert(key.clone(), outcome);
        }
        match &self.studies[&key] {
            Ok(outcome) => Ok(outcome),
            Err(e) => Err(e.clone()),
        }
    }

    fn reconstruction(&mut self) -> std::result::Result<&ReconstructionReport, String> {
        if self.reconstruction.is_none() {
            let dir = self.out_dir.join("reconstruction");
            self.reconstruction =
                Some(crate::app::reconstruct(Some(&dir)).map_err(|e| format!("reconstruct: {e}")));
        }
        match &self.reconstruction {
            Some(Ok(report)) => Ok(report),
            Some(Err(e)) => Err(e.clone()),
            None => Err("reconstruct: not run".into()),
        }
    }

    /// The 2D solver tables: CG at [`CG_CELLS`], p-multigrid (and the condition numbers)
    /// at [`SOLVER_CELLS`], every order 1..5 (the `--quick` sizes: the two coarsest).
    fn solver_rows(&mut self) -> std::result::Result<&[SolverStudyRow], String> {
        if self.solver.is_none() {
            let (cells, cg_cells): (&[usize], &[usize]) = if self.quick {
                (&QUICK_SOLVER_CELLS, &QUICK_CG_CELLS)
            } else {
                (&SOLVER_CELLS, &CG_CELLS)
            };
            let study = |cells: &[usize], kind: SolverKind, dir: &str| {
                let options = SolverStudyOptions {
                    dim: 2,
                    orders: SOLVER_ORDERS.to_vec(),
                    cells: cells.to_vec(),
                    solvers: vec![kind],
                    config: SolverConfig {
                        smoother: Smoother::SymmetricGaussSeidel,
                        ..SolverConfig::default()
                    },
                    density: StudyDensity::Unit,
                    repeats: 1,
                    out_dir: self.out_dir.join("solver_study").join(dir),
                };
                crate::app::run::thread_pool(self.threads).and_then(|pool| {
                    pool.install(|| {
                        crate::app::solver_study::solver_study(&options, &mut |_, _, _| {})
                    })
                })
            };
            let rows = study(cells, SolverKind::Pmg, "pmg").and_then(|mut rows| {
                rows.extend(study(cg_cells, SolverKind::Cg, "cg")?);
                Ok(rows)
            });
            self.solver = Some(rows.map_err(|e| format!("solver-study: {e}")));
        }
        match &self.solver {
            Some(Ok(rows)) => Ok(rows),
            Some(Err(e)) => Err(e.clone()),
            None => Err("solver-study: not run".into()),
        }
    }

    /// Our value of `measure` (running what it needs), or why there is none.
    pub fn measure(&mut self, measure: &Measure) -> std::result::Result<f64, String> {
        match measure {
            Measure::Run(spec, value) => self.run_value(spec, *value),
            Measure::Ratio((a, va), (b, vb)) => {
                let numerator = self.run_value(a, *va)?;
                Ok(numerator / self.run_value(b, *vb)?)
            }
            Measure::MaxOf(list) => {
                let mut largest = f64::NEG_INFINITY;
                for (spec, value) in list {
                    largest = largest.max(self.run_value(spec, *value)?);
                }
                Ok(largest)
            }
            Measure::Order(spec, field, pair) => {
                let rows = &self.study(spec)?.rows;
                let error = |row: &StudyRow| {
                    row.fields
                        .iter()
                        .find(|f| f.0 == *field)
                        .map(|f| (f.1, row.h))
                        .ok_or_else(|| format!("study {}: no {} error", spec.label, field.name()))
                };
                if rows.len() < 2 {
                    return Err(format!("study {}: fewer than two grids", spec.label));
                }
                let n = rows.len();
                let (coarse, fine) = match pair {
                    Pair::Overall => (0, n - 1),
                    Pair::Coarsest => (0, 1),
                    Pair::Finest => (n - 2, n - 1),
                };
                let (e0, h0) = error(&rows[coarse])?;
                let (e1, h1) = error(&rows[fine])?;
                Ok(observed_order(e0, h0, e1, h1))
            }
            Measure::Reconstruct(value) => {
                let report = self.reconstruction()?;
                Ok(match value {
                    ReconstructValue::TlsIntegral => report.tls.integral,
                    ReconstructValue::SplineIntegral => report.spline.integral,
                    ReconstructValue::TlsRms => report.tls.rms,
                    ReconstructValue::SplineRms => report.spline.rms,
                })
            }
            Measure::Solver(table, order, cells) => {
                let (kind, cells, order) = (
                    match table {
                        SolverTable::CgIterations => SolverKind::Cg,
                        _ => SolverKind::Pmg,
                    },
                    *cells,
                    *order,
                );
                let rows = self.solver_rows()?;
                let row = rows
                    .iter()
                    .find(|r| r.solver == kind && r.order == order && r.cells == cells)
                    .ok_or_else(|| format!("solver-study: no row p = {order}, 1/h = {cells}"))?;
                let value = match table {
                    SolverTable::ConditionNumber => row.condition_number,
                    _ => row.iterations.map(|n| n as f64),
                };
                value.ok_or_else(|| format!("solver-study: p = {order}, 1/h = {cells} failed"))
            }
        }
    }

    fn run_value(&mut self, spec: &RunSpec, value: RunValue) -> std::result::Result<f64, String> {
        let outcome = self.run(spec)?;
        let summary = &outcome.summary;
        let c = &summary.conservation;
        let missing = |what: &str| format!("{}: no {what} in summary.json", dir_name(spec));
        match value {
            RunValue::RelL2(field) => summary
                .errors
                .as_ref()
                .and_then(|e| e.rel_l2.get(field.name()).copied())
                .ok_or_else(|| missing(field.name())),
            RunValue::MassError => Ok(c.max_rel_mass_error),
            RunValue::MomentumError => Ok(c.max_rel_momentum_error),
            RunValue::LiquidMassError => c
                .liquid_max_rel_mass_error
                .ok_or_else(|| missing("liquid mass error")),
            RunValue::LiquidMomentumError => c
                .liquid_max_rel_momentum_error
                .ok_or_else(|| missing("liquid momentum error")),
            RunValue::WallSeconds => Ok(summary.wall_seconds),
            RunValue::GridCrossings => Ok(summary.grid_crossings as f64),
            RunValue::FinalMassError | RunValue::FinalMomentumError => {
                let path = outcome.dir.join("history.csv");
                let table = Table::read(&path).map_err(|e| e.to_string())?;
                let name = if value == RunValue::FinalMassError {
                    "mass_rel_error"
                } else {
                    "momentum_rel_error"
                };
                table
                    .header
                    .iter()
                    .position(|h| h == name)
                    .and_then(|k| table.columns[k].last().copied())
                    .ok_or_else(|| format!("{}: no {name} at the last step", path.display()))
            }
            RunValue::TopSettlement => {
                let path = outcome.dir.join("particles.csv");
                let table = Table::read(&path).map_err(|e| e.to_string())?;
                let column = |name: &str| {
                    table
                        .header
                        .iter()
                        .position(|h| h == name)
                        .map(|k| &table.columns[k])
                        .ok_or_else(|| format!("{}: no column {name}", path.display()))
                };
                let (x0, u) = (column("x0")?, column("u")?);
                let top = (0..x0.len())
                    .max_by(|&a, &b| x0[a].total_cmp(&x0[b]))
                    .ok_or_else(|| format!("{}: no particles", path.display()))?;
                Ok(-u[top])
            }
        }
    }

    /// Every finished run and study directory of this reproduction, for plots.
    pub fn study_dir(&self, spec: &StudySpec) -> Option<&Path> {
        let run = RunSpec {
            scenario: spec.scenario,
            sets: spec.sets,
        };
        let key = (run, spec.cells(self.quick).to_vec());
        match self.studies.get(&key) {
            Some(Ok(outcome)) => Some(&outcome.dir),
            _ => None,
        }
    }

    /// The directory of a finished run.
    pub fn run_dir(&self, spec: &RunSpec) -> Option<&Path> {
        match self.runs.get(spec) {
            Some(Ok(outcome)) => Some(&outcome.dir),
            _ => None,
        }
    }

    /// The rows of a finished study.
    pub fn study_rows(&self, spec: &StudySpec) -> Option<&[StudyRow]> {
        let run = RunSpec {
            scenario: spec.scenario,
            sets: spec.sets,
        };
        match self.studies.get(&(run, spec.cells(self.quick).to_vec())) {
            Some(Ok(outcome)) => Some(&outcome.rows),
            _ => None,
        }
    }
}
