//! The output directory of `tlsmpm run` (`docs/outputs.md`): `--out` always holds exactly
//! one run. An existing run is refused without `--force` and replaced whole with it (no
//! stale file survives); SIGINT stops a run between steps and leaves a complete directory
//! with status `"interrupted"` (exit 130); a failed or interrupted run never touches the
//! previous run in the same `--out`.

use std::path::Path;
use std::process::{Command, Output};

const BAR: &str = "scenarios/vibrating_bar.toml";
const COLUMN: &str = "scenarios/column_compaction.toml";

fn tlsmpm(args: &[&str]) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_tlsmpm"));
    command.args(args).current_dir(env!("CARGO_MANIFEST_DIR"));
    command
}

fn run(args: &[&str]) -> Output {
    tlsmpm(args).output().expect("start tlsmpm")
}

fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

fn summary(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("summary.json"))
        .unwrap_or_else(|e| panic!("{}: no summary.json: {e}", dir.display()));
    serde_json::from_str(&text).expect("summary.json is JSON")
}

/// File names in `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// A small run of the bar into `out` (5 cells), exit 0.
fn small_bar(out: &str, flags: &[&str]) {
    let mut args = vec!["run", BAR, "--quiet", "--out", out, "--set", "grid.cells=5"];
    args.extend_from_slice(flags);
    let output = run(&args);
    assert_eq!(output.status.code(), Some(0), "{}", stderr(&output));
}

#[test]
fn an_existing_run_is_refused_without_force_and_replaced_whole_with_it() {
    let root = tempfile::tempdir().expect("tempdir");
    let out = root.path().join("out");
    let out_arg = out.to_str().expect("utf-8 path");
    small_bar(out_arg, &[]);
    let before = std::fs::read(out.join("summary.json")).expect("summary");

    // Refused: exit 2, naming the directory and --force; the run is untouched.
    let refused = run(&["run", COLUMN, "--quiet", "--out", out_arg]);
    assert_eq!(refused.status.code(), Some(2), "{}", stderr(&refused));
    let message = stderr(&refused);
    assert!(
        message.contains(out_arg) && message.contains("--force"),
        "{message}"
    );
    assert_eq!(
        std::fs::read(out.join("summary.json")).expect("kept"),
        before
    );

    // Replaced whole: a stray file of the old run does not survive.
    std::fs::write(out.join("pore_pressure.svg"), "from another run").expect("write");
    let replaced = run(&[
        "run",
        COLUMN,
        "--quiet",
        "--force",
        "--out",
        out_arg,
        "--set",
        "grid.cells=5",
        "--set",
        "particles.per_cell=2",
    ]);
    assert_eq!(replaced.status.code(), Some(0), "{}", stderr(&replaced));
    assert!(!out.join("pore_pressure.svg").exists());
    assert_eq!(summary(&out)["problem"], "column_compaction");
    // Nothing but the run's own directory is left beside it (no staging directories).
    assert_eq!(names(root.path()), ["out"]);
}

#[test]
fn a_failed_run_leaves_the_previous_run_intact() {
    let root = tempfile::tempdir().expect("tempdir");
    let out = root.path().join("out");
    let out_arg = out.to_str().expect("utf-8 path");
    small_bar(out_arg, &[]);
    let before = std::fs::read(out.join("particles.csv")).expect("particles");
    // 100 times the stability limit: a particle leaves the grid within a few steps.
    let failed = run(&[
        "run",
        COLUMN,
        "--quiet",
        "--force",
        "--out",
        out_arg,
        "--set",
        "grid.cells=5",
        "--set",
        "particles.per_cell=2",
        "--set",
        "time.dt=0.1",
    ]);
    assert_eq!(failed.status.code(), Some(1), "{}", stderr(&failed));
    assert_eq!(
        std::fs::read(out.join("particles.csv")).expect("kept"),
        before
    );
    let incomplete = root.path().join("out.incomplete");
    assert!(
        stderr(&failed).contains("out.incomplete"),
        "{}",
        stderr(&failed)
    );
    assert_eq!(summary(&incomplete)["status"], "failed");
    assert_eq!(names(root.path()), ["out", "out.incomplete"]);
}

/// Start a run of about an hour, send SIGINT once it has run a second, and return its
/// output.
#[cfg(unix)]
fn interrupted_bar(out: &str, flags: &[&str]) -> Output {
    let mut args = vec![
        "run",
        BAR,
        "--quiet",
        "--out",
        out,
        "--set",
        "time.end=100",
        "--threads",
        "1",
    ];
    args.extend_from_slice(flags);
    let child = tlsmpm(&args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("start tlsmpm");
    std::thread::sleep(std::time::Duration::from_millis(1500));
    let pid = libc::pid_t::try_from(child.id()).expect("pid");
    // SAFETY: signals a child process this test started and has not yet waited for.
    assert_eq!(unsafe { libc::kill(pid, libc::SIGINT) }, 0);
    child.wait_with_output().expect("wait for tlsmpm")
}

#[cfg(unix)]
#[test]
fn sigint_stops_the_run_and_writes_the_state_reached() {
    let root = tempfile::tempdir().expect("tempdir");
    let out = root.path().join("out");
    let out_arg = out.to_str().expect("utf-8 path");
    let output = interrupted_bar(out_arg, &[]);
    assert_eq!(output.status.code(), Some(130), "{}", stderr(&output));
    assert!(!stderr(&output).contains("panicked"), "{}", stderr(&output));
    let summary = summary(&out);
    assert_eq!(summary["status"], "interrupted", "{summary}");
    let steps = summary["n_steps"].as_u64().expect("n_steps");
    assert!((1..1_000_000_000).contains(&steps), "{summary}");
    assert!(summary.get("failed_step").is_none(), "{summary}");
    // The complete set of files, with the particle state of the last step.
    let particles = std::fs::read_to_string(out.join("particles.csv")).expect("particles");
    let n = summary["n_particles"].as_u64().expect("n_particles") as usize;
    assert_eq!(particles.lines().count(), 1 + n);
    let history = std::fs::read_to_string(out.join("history.csv")).expect("history");
    assert_eq!(history.lines().count() as u64, 1 + steps);
    assert!(out.join("stress.svg").is_file());
    assert_eq!(names(root.path()), ["out"]);
}

#[cfg(unix)]
#[test]
fn an_interrupted_run_leaves_the_previous_run_intact() {
    let root = tempfile::tempdir().expect("tempdir");
    let out = root.path().join("out");
    let out_arg = out.to_str().expect("utf-8 path");
    small_bar(out_arg, &[]);
    let before = std::fs::read(out.join("summary.json")).expect("summary");
    let output = interrupted_bar(out_arg, &["--force"]);
    assert_eq!(output.status.code(), Some(130), "{}", stderr(&output));
    assert_eq!(
        std::fs::read(out.join("summary.json")).expect("kept"),
        before
    );
    assert_eq!(
        summary(&root.path().join("out.incomplete"))["status"],
        "interrupted"
    );
}
