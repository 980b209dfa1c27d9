//! Helpers shared by the integration tests: built-in scenarios with overrides, runs into
//! temporary directories, thread pools of a given size.

#![allow(dead_code)]

pub mod tensor;

use tlsmpm::app::{self, builtin, RunOptions, StudyRow};
use tlsmpm::config::{self, Scenario};
use tlsmpm::output::Summary;
use tlsmpm::problems::Field;

/// A built-in scenario with `KEY=VALUE` overrides.
pub fn scenario(name: &str, overrides: &[&str]) -> Scenario {
    let builtin = builtin::find(name).expect("built-in scenario");
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    config::from_str(builtin.toml, name, &overrides).expect("valid scenario")
}

fn options(dir: &tempfile::TempDir, threads: Option<usize>) -> RunOptions {
    RunOptions {
        out_dir: dir.path().to_path_buf(),
        threads,
        force: false,
        stop: None,
        warnings: Vec::new(),
        ranks: None,
    }
}

/// Run a scenario (no plots) and return its summary.
pub fn run(mut scenario: Scenario, threads: Option<usize>) -> Summary {
    scenario.output.plots = false;
    let dir = tempfile::tempdir().expect("temporary directory");
    app::run(&scenario, "test", &options(&dir, threads), &mut |_, _| {}).expect("run succeeds")
}

/// Run a convergence study (no plots).
pub fn study(mut scenario: Scenario, cells: &[usize]) -> Vec<StudyRow> {
    scenario.output.plots = false;
    let dir = tempfile::tempdir().expect("temporary directory");
    app::study(
        &scenario,
        "test",
        cells,
        &options(&dir, None),
        &mut |_, _, _| {},
    )
    .expect("study succeeds")
}

/// Observed RMS orders of `field` between successive rows.
pub fn orders(rows: &[StudyRow], field: Field) -> Vec<f64> {
    rows.iter()
        .skip(1)
        .map(|row| {
            row.fields
                .iter()
                .find(|f| f.0 == field)
                .map(|f| f.3)
                .expect("field in study")
        })
        .collect()
}

/// RMS error of `field` in each row.
pub fn rms_errors(rows: &[StudyRow], field: Field) -> Vec<f64> {
    rows.iter()
        .map(|row| {
            row.fields
                .iter()
                .find(|f| f.0 == field)
                .map(|f| f.1)
                .expect("field in study")
        })
        .collect()
}

/// A rayon pool of `threads` threads.
pub fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool")
}

/// Build and run a scenario in memory; returns the finished simulation (particles in
/// bin order, `id` gives the original index).
pub fn simulate(scenario: &Scenario) -> tlsmpm::physics::Simulation {
    let (problem, mut simulation) = app::build_simulation(scenario, false).expect("valid scenario");
    simulation
        .run(
            scenario.n_steps(),
            &tlsmpm::problems::ProblemBody(problem.as_ref()),
            &mut |_| Ok(()),
        )
        .expect("run succeeds");
    simulation
}

/// A particle field in original (id) order.
pub fn by_id(simulation: &tlsmpm::physics::Simulation, field: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; field.len()];
    for (k, &id) in simulation.particles.id.iter().enumerate() {
        out[id] = field[k];
    }
    out
}
