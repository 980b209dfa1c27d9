//! `tlsmpm reproduce`: every published table of the sources re-run by one command, each
//! number next to the published one with a verdict (`docs/reproduce.md`).
//!
//! * [`case`]: the vocabulary (what is run, which number is taken, how it is compared);
//! * [`cases`]: the table of cases, the one place the published numbers live with the
//!   runs behind them;
//! * [`measure`]: runs each run, study and table once and takes the numbers from them;
//! * [`report`]: `report.md`, its summary table and the plots.
//!
//! A case that fails to run (an error, not a `differs` verdict) is reported as failed and
//! the rest go on; [`ReproduceReport::failures`] counts them (the CLI exits 1 then).

pub mod case;
pub mod cases;
pub mod measure;
pub mod report;

pub use case::{
    Better, Case, Measure, Pair, Plot, Published, ReconstructValue, Rule, RunSpec, RunValue,
    SolverTable, StudySpec, Verdict,
};

use crate::error::{Error, Result};
use measure::Lab;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// What to reproduce and where.
#[derive(Clone, Debug, Default)]
pub struct ReproduceOptions {
    /// Case ids; empty or `all`: every case.
    pub ids: Vec<String>,
    /// The smaller `--quick` sizes and only the numbers marked quick.
    pub quick: bool,
    pub out_dir: PathBuf,
    pub threads: Option<usize>,
    /// Checked between steps of every run (see [`crate::app::RunOptions::stop`]).
    pub stop: Option<&'static AtomicBool>,
}

/// One published number with ours.
#[derive(Clone, Debug)]
pub struct Row {
    pub published: Published,
    /// Our number, or why it could not be computed.
    pub ours: std::result::Result<f64, String>,
}

impl Row {
    /// `None` when ours could not be computed.
    pub fn verdict(&self) -> Option<Verdict> {
        self.ours.as_ref().ok().map(|&v| self.published.verdict(v))
    }
}

/// The rows of one case and its wall time.
#[derive(Clone, Debug)]
pub struct CaseOutcome {
    pub case: Case,
    pub rows: Vec<Row>,
    pub seconds: f64,
}

/// Counts of one case or of the whole report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counts {
    pub compared: usize,
    pub matched: usize,
    pub better: usize,
    pub differs: usize,
    /// Numbers that could not be computed (a run failed).
    pub failed: usize,
}

impl Counts {
    fn of(rows: &[Row]) -> Self {
        let mut counts = Counts::default();
        for row in rows {
            match row.verdict() {
                Some(Verdict::Matched) => counts.matched += 1,
                Some(Verdict::Better) => counts.better += 1,
                Some(Verdict::Differs) => counts.differs += 1,
                None => counts.failed += 1,
            }
            counts.compared += usize::from(row.verdict().is_some());
        }
        counts
    }

    fn add(&mut self, other: Counts) {
        self.compared += other.compared;
        self.matched += other.matched;
        self.better += other.better;
        self.differs += other.differs;
        self.failed += other.failed;
    }
}

impl CaseOutcome {
    pub fn counts(&self) -> Counts {
        Counts::of(&self.rows)
    }
}

/// Everything `report.md` holds.
#[derive(Clone, Debug)]
pub struct ReproduceReport {
    pub quick: bool,
    pub cases: Vec<CaseOutcome>,
    pub seconds: f64,
    pub threads: usize,
}

impl ReproduceReport {
    pub fn counts(&self) -> Counts {
        let mut total = Counts::default();
        for case in &self.cases {
            total.add(case.counts());
        }
        total
    }

    /// Numbers that could not be computed.
    pub fn failures(&self) -> usize {
        self.counts().failed
    }
}

/// The cases named by `ids` (empty or `all`: every case), in table order; an unknown id
/// is an input error naming the known ones.
///
/// ```
/// use tlsmpm::app::reproduce::select;
/// assert_eq!(select(&["mms_bar".into()]).unwrap()[0].id, "mms_bar");
/// assert!(select(&["no_such_case".into()]).is_err());
/// ```
pub fn select(ids: &[String]) -> Result<Vec<Case>> {
    let all = cases::cases();
    if ids.is_empty() || ids.iter().any(|id| id == "all") {
        return Ok(all);
    }
    for id in ids {
        if !all.iter().any(|c| c.id == id) {
            let known: Vec<&str> = all.iter().map(|c| c.id).collect();
            return Err(Error::invalid(
                "ID",
                id,
                format!("no such case; the cases are {} (or all)", known.join(", ")),
            ));
        }
    }
    Ok(all
        .into_iter()
        .filter(|c| ids.iter().any(|id| id == c.id))
        .collect())
}

/// Run the selected cases and write `report.md` (after every case, so a long run shows
/// what is done). `progress(case, what, step, total)` after every step of every run.
pub fn reproduce(
    options: &ReproduceOptions,
    progress: &mut (dyn FnMut(&str, &str, usize, usize) + Send),
) -> Result<ReproduceReport> {
    let selected = select(&options.ids)?;
    std::fs::create_dir_all(&options.out_dir).map_err(|e| Error::write(&options.out_dir, e))?;
    let threads = crate::app::run::thread_pool(options.threads)?.current_num_threads();
    let clock = Instant::now();
    let mut report = ReproduceReport {
        quick: options.quick,
        cases: Vec::new(),
        seconds: 0.0,
        threads,
    };
    let current = std::sync::Mutex::new(String::new());
    let mut step_progress = |what: &str, step: usize, total: usize| {
        let case = current.lock().map(|c| c.clone()).unwrap_or_default();
        progress(&case, what, step, total)
    };
    let mut lab = Lab::new(
        options.quick,
        &options.out_dir,
        options.threads,
        options.stop,
        &mut step_progress,
    );
    for case in selected {
        if let Ok(mut c) = current.lock() {
            *c = case.id.to_string();
        }
        let start = Instant::now();
        let rows: Vec<Row> = case
            .numbers
            .iter()
            .filter(|n| n.quick || !options.quick)
            .map(|n| Row {
                published: n.clone(),
                ours: lab.measure(&n.measure),
            })
            .collect();
        for study in &case.context {
            // Shown in the case's table of orders; a failure is reported there.
            let _ = lab.study(study);
        }
        report::plots(&case, &lab)?;
        report.cases.push(CaseOutcome {
            case,
            rows,
            seconds: start.elapsed().as_secs_f64(),
        });
        report.seconds = clock.elapsed().as_secs_f64();
        report::write(&options.out_dir, &report, &lab)?;
        if options.stop.is_some_and(|s| s.load(Ordering::Relaxed)) {
            return Err(Error::Interrupted {
                step: report.cases.len(),
                time: report.seconds,
            });
        }
    }
    Ok(report)
}
