//! Output files (DESIGN §4): stable names and columns, snapshots, history length.

mod common;

use common::scenario;
use tlsmpm::app::{self, RunOptions};

#[test]
fn run_writes_the_stable_files_and_evenly_spread_snapshots() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut s = scenario("vibrating_bar", &["grid.cells=5", "output.snapshots=4"]);
    s.output.plots = true;
    let options = RunOptions {
        out_dir: dir.path().to_path_buf(),
        threads: Some(1),
        force: false,
        stop: None,
        warnings: Vec::new(),
        ranks: None,
    };
    let mut calls = 0;
    let summary = app::run(&s, "bar", &options, &mut |_, _| calls += 1).expect("run");
    assert_eq!(summary.n_steps, 19);
    assert_eq!(calls, 19);
    let read = |name: &str| std::fs::read_to_string(dir.path().join(name)).expect(name);

    let particles = read("particles.csv");
    assert_eq!(
        particles.lines().next(),
        Some("x0,x,u,v,stress,volume,density,mass,u_exact,v_exact,stress_exact")
    );
    assert_eq!(particles.lines().count(), 1 + 60);

    let history = read("history.csv");
    assert_eq!(
        history.lines().next(),
        Some("step,time,mass_rel_error,momentum_rel_error,kinetic_energy,strain_energy,grid_crossings")
    );
    assert_eq!(history.lines().count(), 1 + 19);

    // Snapshots at steps ceil(k 19 / 4) = 5, 10, 15, 19; the last one is the final state.
    for k in 1..=4 {
        assert!(dir.path().join(format!("snapshot_{k:04}.csv")).exists());
    }
    assert!(!dir.path().join("snapshot_0005.csv").exists());
    assert_eq!(read("snapshot_0004.csv"), particles);
    assert_ne!(read("snapshot_0001.csv"), particles);

    let summary: serde_json::Value =
        serde_json::from_str(&read("summary.json")).expect("summary.json is JSON");
    for key in [
        "scenario",
        "n_particles",
        "n_cells",
        "n_steps",
        "threads",
        "wall_seconds",
        "errors",
        "conservation",
        "grid_crossings",
        "solver",
    ] {
        assert!(summary.get(key).is_some(), "summary.json lacks {key}");
    }
    for key in ["displacement", "velocity", "stress"] {
        assert!(summary["errors"]["rms"][key].is_f64());
        assert!(summary["errors"]["rel_l2"][key].is_f64());
    }
    assert!(summary["conservation"]["max_rel_mass_error"].is_f64());
    assert!(summary["conservation"]["max_rel_momentum_error"].is_f64());
    assert_eq!(summary["solver"]["kind"], "lumped");
    assert!(read("stress.svg").starts_with("<svg"));
    // Nothing half-written is left behind.
    let leftovers = std::fs::read_dir(dir.path())
        .expect("read_dir")
        .filter_map(Result::ok)
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .count();
    assert_eq!(leftovers, 0);
}
