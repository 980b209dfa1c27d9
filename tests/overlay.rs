//! `tlsmpm overlay` on real runs: two small vibrating-bar runs overlaid with the exact
//! stress (exit code 0, both default labels in the SVG), and an unknown column (exit code 2
//! naming it).

mod common;

use common::scenario;
use std::path::Path;
use std::process::Command;
use tlsmpm::app::{self, RunOptions};

/// Run the 5-cell vibrating bar with `overrides` into a temporary directory named `prefix...`.
fn run(prefix: &str, overrides: &[&str]) -> tempfile::TempDir {
    let dir = tempfile::Builder::new()
        .prefix(prefix)
        .tempdir()
        .expect("tempdir");
    let mut overrides = overrides.to_vec();
    overrides.push("grid.cells=5");
    let mut s = scenario("vibrating_bar", &overrides);
    s.output.plots = false;
    let options = RunOptions {
        out_dir: dir.path().to_path_buf(),
        threads: Some(1),
        force: false,
        stop: None,
        warnings: Vec::new(),
        ranks: None,
    };
    app::run(&s, "bar", &options, &mut |_, _| {}).expect("run");
    dir
}

/// `tlsmpm overlay ARGS...`: exit code and stderr.
fn overlay(args: &[&Path]) -> (i32, String) {
    let output = Command::new(env!("CARGO_BIN_EXE_tlsmpm"))
        .arg("overlay")
        .args(args)
        .output()
        .expect("start tlsmpm");
    let code = output.status.code().expect("exit code, not a signal");
    (code, String::from_utf8_lossy(&output.stderr).into_owned())
}

#[test]
fn overlays_two_runs_with_the_exact_stress() {
    let a = run("overlay_coarse_", &["particles.per_cell=2"]);
    let b = run("overlay_fine_", &["particles.per_cell=4"]);
    let out = tempfile::tempdir().expect("tempdir");
    let svg = out.path().join("o.svg");
    let args = [
        a.path(),
        b.path(),
        Path::new("--field"),
        Path::new("stress"),
        Path::new("--exact"),
        Path::new("--out"),
        &svg,
    ];
    let (code, stderr) = overlay(&args);
    assert_eq!(code, 0, "{stderr}");
    let text = std::fs::read_to_string(&svg).expect("overlay SVG written");
    for dir in [&a, &b] {
        let name = dir.path().file_name().expect("name").to_string_lossy();
        assert!(text.contains(&*name), "label {name} missing");
    }
    assert!(text.contains("exact") && text.contains("stress of 2 runs"));

    let args = [
        a.path(),
        Path::new("--field"),
        Path::new("nope"),
        Path::new("--out"),
        &svg,
    ];
    let (code, stderr) = overlay(&args);
    assert_eq!(code, 2, "{stderr}");
    assert!(
        stderr.contains("nope") && stderr.contains("stress_exact"),
        "{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
}
