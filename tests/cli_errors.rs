//! The command line's error contract (DESIGN §2), checked on the `tlsmpm` binary itself:
//! bad input (unreadable scenario, invalid TOML, unknown keys, non-positive values, an
//! unstable time step, unavailable methods, bad flags) exits with code 2 and one clear
//! `stderr` line naming the key and value, never a panic; a numerical failure exits with
//! code 1 after writing `summary.json` (status `"failed"`), `particles.csv` and
//! `history.csv`; and the normal runs (`run FILE`, `run NAME`, `list`) exit with code 0.

use std::path::{Path, PathBuf};
use std::process::Command;
use tempfile::TempDir;

/// Exit code and captured output of one `tlsmpm` invocation.
struct Outcome {
    code: i32,
    stdout: String,
    stderr: String,
}

/// Run `tlsmpm ARGS...` from the crate root (so `scenarios/...` resolves).
fn tlsmpm<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> Outcome {
    let output = Command::new(env!("CARGO_BIN_EXE_tlsmpm"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("start tlsmpm");
    Outcome {
        code: output
            .status
            .code()
            .unwrap_or_else(|| panic!("tlsmpm killed by a signal: {:?}", output.status)),
        stdout: String::from_utf8_lossy(&output.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&output.stderr).into_owned(),
    }
}

/// `tlsmpm run SCENARIO --quiet --out OUT --set S... FLAGS...`.
fn run(scenario: &str, out: &Path, sets: &[&str], flags: &[&str]) -> Outcome {
    let mut args: Vec<String> = vec![
        "run".into(),
        scenario.into(),
        "--quiet".into(),
        "--out".into(),
        out.display().to_string(),
    ];
    for set in sets {
        args.push("--set".into());
        args.push((*set).into());
    }
    args.extend(flags.iter().map(|f| f.to_string()));
    tlsmpm(&args)
}

fn tempdir() -> TempDir {
    tempfile::tempdir().expect("temporary directory")
}

/// The single, non-empty, panic-free `stderr` line of a failed invocation.
fn error_line(o: &Outcome) -> &str {
    let err = &o.stderr;
    assert!(
        !err.contains("panicked") && !err.contains("RUST_BACKTRACE"),
        "panic on stderr:\n{err}"
    );
    let line = err.trim_end_matches('\n');
    assert!(!line.trim().is_empty(), "empty stderr (exit {})", o.code);
    assert!(!line.contains('\n'), "more than one stderr line:\n{err}");
    assert!(line.starts_with("error: "), "unexpected stderr: {line}");
    line
}

/// Assert `line` contains every needle (ASCII case-insensitive, so `nan` matches `NaN`).
fn assert_names(line: &str, needles: &[&str]) {
    let lower = line.to_ascii_lowercase();
    for needle in needles {
        assert!(
            lower.contains(&needle.to_ascii_lowercase()),
            "stderr does not name `{needle}`: {line}"
        );
    }
}

/// Run a scenario that must be rejected as bad input: exit code 2, one line naming every
/// needle, and no results written.
fn expect_input_error(scenario: &str, sets: &[&str], flags: &[&str], needles: &[&str]) {
    let dir = tempdir();
    let out = dir.path().join("out");
    let o = run(scenario, &out, sets, flags);
    let context = format!("run {scenario} {sets:?} {flags:?}");
    assert_eq!(o.code, 2, "{context}: exit code; stderr: {}", o.stderr);
    assert_names(error_line(&o), needles);
    assert!(
        !out.join("summary.json").exists(),
        "{context}: bad input must not write results"
    );
}

/// Write `text` to `dir/name` and return its path as a string.
fn write_file(dir: &TempDir, name: &str, text: impl AsRef<[u8]>) -> String {
    let path = dir.path().join(name);
    std::fs::write(&path, text).expect("write scenario file");
    path.display().to_string()
}

/// The shipped vibrating-bar scenario with `cells = 40` replaced by `cells`.
fn bar_with_grid(cells: &str) -> String {
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/vibrating_bar.toml"),
    )
    .expect("read vibrating_bar.toml");
    assert!(text.contains("cells = 40"));
    text.replace("cells = 40", cells)
}

const BAR: &str = "scenarios/vibrating_bar.toml";
const COLUMN: &str = "scenarios/column_compaction.toml";
const TINY: &str = "grid.cells=5";
const CONSOLIDATION: &str = "scenarios/consolidation.toml";

/// The step number in `... at step N ...`.
fn failed_step(message: &str) -> usize {
    let (_, rest) = message
        .split_once("step ")
        .unwrap_or_else(|| panic!("no `step N` in: {message}"));
    let digits: String = rest.chars().take_while(char::is_ascii_digit).collect();
    digits
        .parse()
        .unwrap_or_else(|_| panic!("no step number in: {message}"))
}

/// Run a scenario that must fail numerically: exit code 1, one line naming the step, and
/// the state of the completed steps in `summary.json`, `particles.csv` and `history.csv`.
fn expect_numerical_failure(scenario: &str, sets: &[&str], flags: &[&str]) {
    let dir = tempdir();
    let out = dir.path().join("out");
    let o = run(scenario, &out, sets, flags);
    let context = format!("run {scenario} {sets:?} {flags:?}");
    assert_eq!(o.code, 1, "{context}: exit code; stderr: {}", o.stderr);
    let line = error_line(&o);
    let step = failed_step(line);
    assert!(step >= 1, "{context}: {line}");

    let read = |name: &str| {
        std::fs::read_to_string(out.join(name))
            .unwrap_or_else(|e| panic!("{context}: {name} not written after failure: {e}"))
    };
    let summary: serde_json::Value =
        serde_json::from_str(&read("summary.json")).expect("summary.json is JSON");
    assert_eq!(summary["status"], "failed", "{context}: {summary}");
    let failure = summary["failure"].as_str().expect("failure message");
    assert!(line.contains(failure), "{context}: `{failure}` vs `{line}`");
    assert_eq!(failed_step(failure), step);
    let completed = step - 1;
    assert_eq!(summary["n_steps"], completed, "{context}: {summary}");
    assert_eq!(summary["failed_step"], step, "{context}: {summary}");

    let particles = read("particles.csv");
    let n_particles = summary["n_particles"].as_u64().expect("n_particles") as usize;
    assert!(particles.starts_with("x0,x,u,v,stress,volume,density,mass"));
    assert_eq!(particles.lines().count(), 1 + n_particles, "{context}");

    let history = read("history.csv");
    assert!(history.starts_with("step,time,"));
    assert_eq!(history.lines().count(), 1 + completed, "{context}");
}

// ---- 1. missing or unreadable scenario ------------------------------------------------

#[test]
fn missing_scenario_file_is_bad_input() {
    expect_input_error(
        "scenarios/no_such_scenario.toml",
        &[],
        &[],
        &["cannot read", "scenarios/no_such_scenario.toml"],
    );
}

#[test]
fn unreadable_scenarios_are_bad_input() {
    // A directory cannot be read as a file, even by root.
    expect_input_error("scenarios", &[], &[], &["cannot read", "scenarios"]);
    // Nor can bytes that are not UTF-8 be read as TOML text.
    let dir = tempdir();
    let binary = write_file(&dir, "binary.toml", [0xff_u8, 0xfe, 0x00, 0x80]);
    expect_input_error(&binary, &[], &[], &["cannot read", &binary]);
}

// ---- 2. invalid TOML ------------------------------------------------------------------

#[test]
fn toml_syntax_error_is_bad_input_with_its_line() {
    let dir = tempdir();
    let bad = write_file(
        &dir,
        "bad.toml",
        "[problem]\nkind = \"vibrating_bar\"\n[grid\ncells = 5\n",
    );
    expect_input_error(&bad, &[], &[], &["invalid scenario", &bad, "line 3"]);
}

// ---- 3. unknown keys ------------------------------------------------------------------

#[test]
fn unknown_key_in_file_names_the_dotted_key() {
    let dir = tempdir();
    let file = write_file(&dir, "typo.toml", bar_with_grid("cells = 5\ncelss = 3"));
    expect_input_error(&file, &[], &[], &["unknown key", "`grid.celss`"]);
}

#[test]
fn unknown_key_via_set_names_the_dotted_key() {
    for (set, key) in [
        ("material.young=1", "`material.young`"),
        ("grid.celss=3", "`grid.celss`"),
        ("solvr.kind=cg", "`solvr`"),
    ] {
        expect_input_error(BAR, &[TINY, set], &[], &["unknown key", key]);
    }
}

// ---- 4. non-positive values -----------------------------------------------------------

#[test]
fn non_positive_values_name_the_key_and_value() {
    let keys = [
        "grid.cells",
        "particles.per_cell",
        "material.density",
        "material.youngs_modulus",
        "time.dt",
    ];
    for key in keys {
        for value in ["0", "-1"] {
            let set = format!("{key}={value}");
            expect_input_error(BAR, &[TINY, &set], &[], &[key, value]);
        }
    }
    for value in ["nan", "inf", "-inf"] {
        let set = format!("time.dt={value}");
        expect_input_error(BAR, &[TINY, &set], &[], &["time.dt", value]);
    }
    expect_input_error(BAR, &[TINY, "time.dt=abc"], &[], &["time.dt", "abc"]);
}

// ---- 5. stability limit ---------------------------------------------------------------

#[test]
fn time_step_above_stability_limit_needs_force() {
    // h / c = (50 m / 50) / sqrt(1e6 Pa / 1 kg/m³) = 1e-3 s.
    expect_input_error(
        COLUMN,
        &["time.dt=0.01"],
        &[],
        &["`time.dt`", "1e-2", "1.000e-3", "--force"],
    );
    let dir = tempdir();
    let o = run(COLUMN, dir.path(), &["time.dt=0.01"], &["--force"]);
    assert_ne!(o.code, 2, "--force must run: {}", o.stderr);
    assert!(
        !o.stderr.contains("panicked") && !o.stderr.contains("RUST_BACKTRACE"),
        "panic on stderr:\n{}",
        o.stderr
    );
    if o.code != 0 {
        assert_eq!(o.code, 1, "stderr: {}", o.stderr);
        error_line(&o);
    }
}

// ---- 6. numerical failure -------------------------------------------------------------

#[test]
fn forced_unstable_run_fails_with_partial_output() {
    // 100 times the stability limit (h / c = 10 m / 1000 m/s): a particle leaves the grid
    // within a few steps.
    expect_numerical_failure(
        COLUMN,
        &[TINY, "particles.per_cell=2", "time.dt=0.1"],
        &["--force"],
    );
}

#[test]
fn study_keeps_the_completed_rows_when_a_finer_run_fails() {
    // dt = h / (2 c) on 5 cells, 5 h / c on 50: the second run collapses a particle.
    let dir = tempdir();
    let out = dir.path().join("study");
    let out_arg = out.display().to_string();
    let o = tlsmpm(&[
        "study",
        COLUMN,
        "--cells",
        "5,50",
        "--quiet",
        "--force",
        "--set",
        "particles.per_cell=2",
        "--set",
        "time.dt=0.005",
        "--out",
        &out_arg,
    ]);
    assert_eq!(o.code, 1, "stderr: {}", o.stderr);
    assert!(failed_step(error_line(&o)) >= 1);
    let table = std::fs::read_to_string(out.join("study.csv")).expect("study.csv kept");
    let rows: Vec<&str> = table.lines().collect();
    assert_eq!(rows.len(), 2, "header and the 5-cell row: {table}");
    assert!(rows[0].starts_with("cells,h,n_particles,"), "{table}");
    assert!(rows[1].starts_with("5,"), "{table}");
    let failed: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("cells_50/summary.json")).expect("failed summary"),
    )
    .expect("summary.json is JSON");
    assert_eq!(failed["status"], "failed");
}

#[test]
fn non_finite_stress_fails_with_partial_output() {
    // A finite but absurd initial velocity overflows the stress in the first step.
    expect_numerical_failure(BAR, &[TINY, "problem.v0=1e308"], &[]);
}

#[test]
fn unwritable_output_directory_is_bad_input_naming_the_path() {
    let dir = tempdir();
    let file = dir.path().join("file");
    std::fs::write(&file, "not a directory").expect("write file");
    let out: PathBuf = file.join("out");
    let o = run(BAR, &out, &[TINY], &[]);
    assert_eq!(o.code, 2, "stderr: {}", o.stderr);
    assert_names(
        error_line(&o),
        &["cannot write", &out.display().to_string()],
    );
}

// ---- 7. bad flags ---------------------------------------------------------------------

/// Clap's own errors are several lines; they must still be exit 2, name the flag and the
/// value, and carry no misleading tip.
fn expect_flag_error(flags: &[&str], needles: &[&str]) {
    let dir = tempdir();
    let o = run(BAR, &dir.path().join("out"), &[TINY], flags);
    assert_eq!(o.code, 2, "{flags:?}: stderr: {}", o.stderr);
    assert!(
        !o.stderr.contains("panicked") && !o.stderr.contains("tip:"),
        "{}",
        o.stderr
    );
    assert_names(&o.stderr, needles);
}

#[test]
fn zero_negative_or_machine_filling_thread_counts_are_bad_input() {
    // Thousands of threads would hang the machine building the pool: refused at once.
    expect_flag_error(
        &["--threads", "100000"],
        &["--threads", "100000", "per core"],
    );
    expect_flag_error(&["--threads", "-1"], &["--threads", "-1", "whole number"]);
    expect_flag_error(&["--threads", "0"], &["--threads", "0", "at least 1"]);
}

#[test]
fn too_many_particles_blames_the_key_that_is_out_of_scale() {
    let huge = "1000000000000";
    let per_cell = format!("particles.per_cell={huge}");
    expect_input_error(BAR, &[&per_cell], &[], &["particles.per_cell", huge]);
    let cells = format!("grid.cells={huge}");
    expect_input_error(BAR, &[&cells], &[], &["grid.cells", huge]);
    let per_cell_2d = format!("particles.per_cell={}", 1_u64 << 40);
    expect_input_error(
        "axis_aligned_mms",
        &[&per_cell_2d],
        &[],
        &["particles.per_cell"],
    );
}

#[test]
fn a_run_larger_than_the_free_memory_is_refused_with_the_estimate() {
    // 120 000 particles against 16 MiB of memory (the variable stands for a batch job's
    // limit): refused before anything is allocated, naming both keys and the estimate.
    let dir = tempdir();
    let out = dir.path().join("out");
    let output = Command::new(env!("CARGO_BIN_EXE_tlsmpm"))
        .args(["run", BAR, "--quiet", "--set", "grid.cells=10000", "--out"])
        .arg(&out)
        .env("TLSMPM_AVAILABLE_MEMORY", (16_u64 << 20).to_string())
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("start tlsmpm");
    let o = Outcome {
        code: output.status.code().expect("exit code"),
        stdout: String::new(),
        stderr: String::from_utf8_lossy(&output.stderr).into_owned(),
    };
    assert_eq!(o.code, 2, "stderr: {}", o.stderr);
    assert_names(
        error_line(&o),
        &[
            "grid.cells",
            "particles.per_cell",
            "120000",
            "GiB",
            "available",
        ],
    );
    assert!(!out.exists(), "nothing written");
}

#[test]
fn an_unknown_scenario_name_lists_the_builtins() {
    let dir = tempdir();
    let o = run("vibrating_barr", &dir.path().join("out"), &[], &[]);
    assert_eq!(o.code, 2, "stderr: {}", o.stderr);
    assert_names(
        error_line(&o),
        &[
            "vibrating_barr",
            "vibrating_bar_large",
            "column_compaction",
            "tlsmpm list",
        ],
    );
}

#[cfg(unix)]
#[test]
fn a_closed_stdout_pipe_ends_quietly() {
    // `tlsmpm list | head -0`: the reader is gone before tlsmpm writes.
    let mut child = Command::new(env!("CARGO_BIN_EXE_tlsmpm"))
        .arg("list")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("start tlsmpm");
    drop(child.stdout.take());
    let output = child.wait_with_output().expect("wait");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.is_empty(), "stderr: {stderr}");
    assert_ne!(output.status.code(), Some(101), "a panic");
}

#[test]
fn messages_write_values_as_the_scenario_file_does() {
    // `"linear"` as in the file, not the Rust variant name `Linear`.
    let dir = tempdir();
    let o = run(
        CONSOLIDATION,
        &dir.path().join("out"),
        &["material.model=\"linear\""],
        &[],
    );
    assert_eq!(o.code, 2, "stderr: {}", o.stderr);
    let line = error_line(&o);
    assert!(
        line.contains("material.model") && line.contains("\"linear\""),
        "{line}"
    );
    assert!(!line.contains("Linear"), "{line}");
}

#[test]
fn malformed_set_is_bad_input() {
    expect_input_error(
        BAR,
        &["grid.cells"],
        &[],
        &["--set", "grid.cells", "KEY=VALUE"],
    );
    expect_input_error(BAR, &["=5"], &[], &["--set", "empty key"]);
    expect_input_error(
        BAR,
        &["grid.cells.x=1"],
        &[],
        &["grid.cells.x", "not a table"],
    );
}

// ---- 8. two-phase keys ----------------------------------------------------------------

#[test]
fn bad_two_phase_input_names_the_key() {
    for (set, needles) in [
        (
            "material.porosity=1.2",
            &["`material.porosity`", "1.2", "between 0 and 1"][..],
        ),
        (
            "material.permeability=0",
            &["`material.permeability`", "positive"][..],
        ),
        (
            "material.bulk_modulus_liquid=-3e8",
            &["`material.bulk_modulus_liquid`"][..],
        ),
        ("problem.start_time=-1", &["`problem.start_time`", "-1"][..]),
        ("problem.v0=1", &["`problem.v0`", "consolidation"][..]),
        (
            "material.model=linear",
            &["`material.model`", "two_phase"][..],
        ),
        ("method.scheme=usl", &["`method.scheme`", "MUSL"][..]),
        ("material.skeleton=neo", &["material.skeleton", "neo"][..]),
        (
            "problem.reference=ulfem",
            &["`problem.reference`", "exact"][..],
        ),
        (
            "method.strain=adjoint",
            &["`method.strain`", "two-phase", "gradient"][..],
        ),
    ] {
        expect_input_error(CONSOLIDATION, &[TINY, set], &[], needles);
    }
    // Two-phase keys on a one-phase material, and a two-phase material on a one-phase
    // problem.
    expect_input_error(
        BAR,
        &[TINY, "material.porosity=0.3"],
        &[],
        &["`material.porosity`", "two_phase"],
    );
    expect_input_error(
        BAR,
        &[TINY, "material.model=two_phase"],
        &[],
        &["`material.model`", "consolidation"],
    );
    // Neo-Hookean needs both moduli, and they are rejected for the other models.
    expect_input_error(
        BAR,
        &[
            TINY,
            "material.model=neo_hookean",
            "material.lame_lambda=5.77e6",
        ],
        &[],
        &["`material.shear_modulus`", "required", "neo_hookean"],
    );
    expect_input_error(
        BAR,
        &[TINY, "material.shear_modulus=3.85e6"],
        &[],
        &["`material.shear_modulus`", "neo_hookean"],
    );
    expect_input_error(
        BAR,
        &[TINY, "problem.load=-1e4"],
        &[],
        &["`problem.load`", "vibrating_bar"],
    );
    // The explicit drag limit 2 k / (n g (1 + n rho_w / ((1 - n) rho_s))) = 4.06e-6 s.
    expect_input_error(
        CONSOLIDATION,
        &[TINY, "time.dt=1e-5", "time.end=1e-4"],
        &[],
        &["`time.dt`", "stability limit"],
    );
}

#[test]
fn bad_mms_input_names_the_key() {
    const MMS: &str = "scenarios/mms_bar.toml";
    expect_input_error(
        MMS,
        &[TINY, "material.model=linear", "material.shear_modulus=1"],
        &[],
        &["`material.shear_modulus`", "neo_hookean"],
    );
    expect_input_error(
        BAR,
        &[TINY, "problem.amplitude=0.1"],
        &[],
        &["`problem.amplitude`", "vibrating_bar"],
    );
    expect_input_error(
        MMS,
        &[TINY, "problem.amplitude=inf"],
        &[],
        &["`problem.amplitude`", "finite"],
    );
}

// ---- 9. documented but unavailable methods --------------------------------------------

#[test]
fn unavailable_methods_name_their_key() {
    // MLS, IMLS and VTK output are implemented now: a 1D run with VTK writes the series.
    let dir = tempdir();
    let out = dir.path().join("out");
    let o = run(
        BAR,
        &out,
        &[TINY, "output.vtk=true", "output.snapshots=2"],
        &[],
    );
    assert_eq!(o.code, 0, "{}", o.stderr);
    let pvd = std::fs::read_to_string(out.join("particles.pvd")).expect("pvd");
    assert_eq!(pvd.matches("<DataSet").count(), 3, "{pvd}");
    let vtu = std::fs::read_to_string(out.join("particles_0002.vtu")).expect("final vtu");
    let summary = tlsmpm::output::vtu::read_vtu_summary(&vtu).expect("valid VTU");
    let csv = std::fs::read_to_string(out.join("particles.csv")).expect("csv");
    assert_eq!(summary.n_points, csv.lines().count() - 1);
    expect_input_error(
        BAR,
        &[TINY, "method.subpoints=4", "method.reconstruction=tls"],
        &[],
        &["`method.subpoints`", "4", "reconstruction", "tls"],
    );
    expect_input_error(
        BAR,
        &[TINY, "method.mass=consistent", "solver.kind=multigrid"],
        &[],
        &["solver.kind", "multigrid"],
    );
    expect_input_error(
        BAR,
        &[
            TINY,
            "solver.kind=pmg_cg",
            "solver.pre_smooth=2",
            "solver.post_smooth=3",
        ],
        &[],
        &["`solver.post_smooth`", "3", "symmetric"],
    );
    expect_input_error(
        BAR,
        &[
            TINY,
            "solver.kind=pmg",
            "solver.pre_smooth=0",
            "solver.post_smooth=0",
        ],
        &[],
        &["`solver.pre_smooth`", "0"],
    );
    for points in ["1", "33"] {
        expect_input_error(
            BAR,
            &[
                TINY,
                "method.reconstruction=tls",
                &format!("method.gauss_points={points}"),
            ],
            &[],
            &["`method.gauss_points`", points],
        );
    }
    expect_input_error(
        BAR,
        &[TINY, "method.degenerate_cells=magic"],
        &[],
        &["method.degenerate_cells", "magic"],
    );
}

#[test]
fn bspline_order_out_of_range_names_the_key() {
    for order in ["0", "16"] {
        expect_input_error(
            BAR,
            &[
                TINY,
                "method.basis=bspline",
                &format!("method.order={order}"),
            ],
            &[],
            &["`method.order`", order, "between 1 and 15"],
        );
    }
    expect_input_error(
        BAR,
        &[
            TINY,
            "problem.reference=\"ulfem\"",
            "problem.reference_dofs=1",
        ],
        &[],
        &["`problem.reference_dofs`", "at least 2"],
    );
}

// ---- 9. positive controls -------------------------------------------------------------

/// A successful run into a fresh directory: exit code 0, the stable files written.
fn expect_success(scenario: &str, sets: &[&str]) {
    let dir = tempdir();
    let o = run(scenario, dir.path(), sets, &[]);
    assert_eq!(o.code, 0, "run {scenario}: stderr: {}", o.stderr);
    assert!(
        o.stderr.is_empty(),
        "quiet run wrote to stderr: {}",
        o.stderr
    );
    for name in ["summary.json", "particles.csv", "history.csv", "stress.svg"] {
        assert!(dir.path().join(name).is_file(), "run {scenario}: no {name}");
    }
    let summary: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("summary.json")).expect("read summary.json"),
    )
    .expect("summary.json is JSON");
    assert_eq!(summary["status"], "completed", "{summary}");
    assert_eq!(summary["warnings"], serde_json::json!([]), "{summary}");
}

#[test]
fn a_run_with_errors_above_100_percent_warns_on_stderr_and_in_the_summary() {
    // Plain MPM on the manufactured-solution bar: a velocity error 1.55 times the size of
    // the exact velocity (its largest L2 norm over the period).
    let dir = tempdir();
    let out = dir.path().join("out");
    let o = run(
        "mms_bar",
        &out,
        &["method.basis=linear", "method.reconstruction=none"],
        &[],
    );
    assert_eq!(o.code, 0, "stderr: {}", o.stderr);
    assert!(
        o.stderr
            .contains("warning: the L2 error of velocity is 1.55"),
        "{}",
        o.stderr
    );
    let summary: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("summary.json")).expect("summary.json"),
    )
    .expect("JSON");
    let warnings = summary["warnings"].as_array().expect("warnings");
    assert!(!warnings.is_empty(), "{summary}");
}

#[test]
fn scenario_file_runs() {
    expect_success(BAR, &[]);
}

#[test]
fn builtin_scenario_runs_by_name() {
    expect_success("vibrating_bar", &[]);
}

#[test]
fn list_shows_the_builtin_scenarios() {
    let o = tlsmpm(&["list"]);
    assert_eq!(o.code, 0, "stderr: {}", o.stderr);
    for name in ["vibrating_bar", "vibrating_bar_large", "column_compaction"] {
        assert!(
            o.stdout
                .lines()
                .any(|l| l.split_whitespace().next() == Some(name)),
            "`tlsmpm list` does not list {name}:\n{}",
            o.stdout
        );
    }
}

#[test]
fn solver_study_rejects_bad_options_with_exit_code_2() {
    let dir = tempdir();
    let out = dir.path().join("study");
    let out = out.to_string_lossy();
    for (args, needles) in [
        (vec!["--dim", "3"], vec!["`--dim`", "3"]),
        (vec!["--solvers", "cg,lu"], vec!["`--solvers`", "lu"]),
        (vec!["--orders", "0"], vec!["`--orders`", "0"]),
        (vec!["--smoother", "sor"], vec!["`--smoother`", "sor"]),
        (vec!["--density", "wavy"], vec!["`--density`", "wavy"]),
        (vec!["--tolerance", "2"], vec!["`--tolerance`", "2"]),
    ] {
        let mut all = vec!["solver-study", "--out", &out];
        all.extend(&args);
        let o = tlsmpm(&all);
        assert_eq!(o.code, 2, "{args:?}: {}", o.stderr);
        assert_names(error_line(&o), &needles);
    }
}

#[test]
fn two_and_three_dimensional_bad_input_names_the_key() {
    let cases: &[(&[&str], &[&str])] = &[
        (
            &["particles.per_cell=3"],
            &["particles.per_cell", "3", "perfect square"],
        ),
        (
            &["problem.dim=3", "particles.per_cell=4"],
            &["particles.per_cell", "4", "perfect cube"],
        ),
        (
            &["method.basis=\"ddmpm\""],
            &["method.basis", "ddmpm", "1D only"],
        ),
        (
            &["method.basis=\"cpdi\""],
            &["method.basis", "cpdi", "1D only"],
        ),
        (
            &["method.reconstruction=\"imls\""],
            &["method.reconstruction", "imls", "1D only"],
        ),
        (&["material.model=\"hill\""], &["material.model", "hill"]),
        (&["boundary.w_min=\"roller\""], &["boundary.w_min"]),
        (
            &["boundary.x_min=\"sticky\""],
            &["boundary.x_min", "sticky"],
        ),
        (&["boundary.z_min=\"roller\""], &["boundary.z_min", "2D"]),
        (
            &["grid.cells=[8, 8, 8]"],
            &["grid.cells", "3 entries", "needs 2"],
        ),
        (&["grid.cells=[8, 0]"], &["grid.cells", "at least 1"]),
        (&["problem.dim=4"], &["problem.dim", "4"]),
        (&["time.dt=\"soon\""], &["time.dt", "soon"]),
        (&["time.dt=\"auto\"", "time.cfl=2"], &["time.cfl", "2"]),
    ];
    for (sets, needles) in cases {
        expect_input_error("axis_aligned_mms", sets, &[], needles);
    }
    let linear = [
        "problem.kind=\"column_compaction\"",
        "problem.dim=2",
        "material.model=\"linear\"",
        "particles.per_cell=4",
        "time.end=1e-3",
    ];
    for (nu, needle) in [("0.5", "[0, 0.5)"), ("-0.1", "[0, 0.5)")] {
        let mut sets = linear.to_vec();
        let set = format!("material.poisson_ratio={nu}");
        sets.push(&set);
        expect_input_error(
            "column_compaction",
            &sets,
            &[],
            &["material.poisson_ratio", nu, needle],
        );
    }
    // The 2D keys in a 1D scenario.
    expect_input_error(
        "vibrating_bar",
        &["material.poisson_ratio=0.3"],
        &[],
        &["material.poisson_ratio", "2D / 3D"],
    );
    expect_input_error(
        "vibrating_bar",
        &["boundary.x_min=\"fixed\""],
        &[],
        &["boundary.x_min"],
    );
    expect_input_error(
        "vibrating_bar",
        &["grid.cells=[4, 4]"],
        &[],
        &["grid.cells", "2 entries"],
    );
    expect_input_error(
        "vibrating_bar",
        &["time.dt=\"auto\""],
        &[],
        &["time.dt", "auto"],
    );
    expect_input_error(
        "vibrating_bar",
        &["problem.kind=\"axis_aligned_mms\""],
        &[],
        &["problem.kind", "problem.dim = 2 or 3"],
    );
}

#[test]
fn a_two_dimensional_run_writes_the_stable_columns() {
    let dir = tempdir();
    let out = dir.path().join("out");
    let o = run(
        "axis_aligned_mms",
        &out,
        &["grid.cells=4", "time.end=1e-4"],
        &[],
    );
    assert_eq!(o.code, 0, "{}", o.stderr);
    let csv = std::fs::read_to_string(out.join("particles.csv")).expect("particles.csv");
    let header = csv.lines().next().expect("header");
    assert_eq!(
        header,
        "x0,y0,x,y,u_x,u_y,v_x,v_y,stress_xx,stress_yy,stress_zz,stress_xy,volume,density,mass,\
         u_x_exact,u_y_exact,v_x_exact,v_y_exact,stress_xx_exact,stress_yy_exact,\
         stress_zz_exact,stress_xy_exact"
    );
    assert_eq!(csv.lines().count(), 1 + 64);
    let summary = std::fs::read_to_string(out.join("summary.json")).expect("summary");
    assert!(summary.contains("\"dim\": 2"), "{summary}");
    assert!(out.join("stress.svg").exists());
}

#[test]
fn keys_a_choice_makes_meaningless_are_warned_about_not_refused() {
    // A basis sweep over one scenario file: `method.order` means nothing to linear hats,
    // `solver.kind` nothing to a lumped mass. The run goes ahead and names both.
    let dir = tempdir();
    let out = dir.path().join("out");
    let o = run(BAR, &out, &[TINY, "method.order=3", "solver.kind=cg"], &[]);
    assert_eq!(o.code, 0, "stderr: {}", o.stderr);
    for needle in [
        "warning: method.order = 3 is ignored: only method.basis = \"bspline\"",
        "warning: solver.kind = \"cg\" is ignored: no consistent mass is solved",
    ] {
        assert!(o.stderr.contains(needle), "{needle}: {}", o.stderr);
    }
    let summary: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("summary.json")).expect("summary.json"),
    )
    .expect("JSON");
    let warnings = summary["warnings"].as_array().expect("warnings");
    assert_eq!(warnings.len(), 2, "{summary}");
    // With the B-spline basis the order takes effect: no warning about it.
    let o = run(
        BAR,
        &dir.path().join("bspline"),
        &[TINY, "method.basis=bspline", "method.order=3"],
        &[],
    );
    assert_eq!(o.code, 0, "stderr: {}", o.stderr);
    assert!(!o.stderr.contains("warning"), "{}", o.stderr);
}

/// `tlsmpm study BAR --quiet --cells 4,8 [--set SET] --out OUT`.
fn study_bar(out: &Path, set: Option<&str>) -> Outcome {
    let mut args = vec!["study", BAR, "--quiet", "--cells", "4,8"];
    if let Some(set) = set {
        args.extend(["--set", set]);
    }
    let out = out.display().to_string();
    args.extend(["--out", out.as_str()]);
    tlsmpm(&args)
}

#[test]
fn a_study_names_the_grid_cells_its_cell_counts_replace() {
    let dir = tempdir();
    let out = dir.path().join("study");
    let o = study_bar(&out, Some("grid.cells=80"));
    assert_eq!(o.code, 0, "stderr: {}", o.stderr);
    let needle = "grid.cells = 80 given with --set is ignored: study --cells";
    assert_eq!(o.stderr.matches(needle).count(), 1, "{}", o.stderr);
    // Each run's summary carries it; the scenario file's own `grid.cells` is not named.
    let summary =
        std::fs::read_to_string(out.join("cells_8").join("summary.json")).expect("summary.json");
    assert!(summary.contains(needle), "{summary}");
    let o = study_bar(&dir.path().join("plain"), None);
    assert_eq!(o.code, 0, "stderr: {}", o.stderr);
    assert!(!o.stderr.contains("warning"), "{}", o.stderr);
}

/// A build without the `mpi` feature started by `mpirun` on several ranks refuses to run
/// (each copy would run the whole problem into the same directory).
#[cfg(not(feature = "mpi"))]
#[test]
fn a_build_without_mpi_refuses_to_run_as_one_of_several_mpi_ranks() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("run");
    let output = Command::new(env!("CARGO_BIN_EXE_tlsmpm"))
        .args(["run", "axis_aligned_mms", "--quiet", "--out"])
        .arg(&out)
        .env("OMPI_COMM_WORLD_SIZE", "2")
        .output()
        .expect("start tlsmpm");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("--features mpi"), "{stderr}");
    assert!(!out.exists());
    // One rank (or no launcher) runs as usual.
    let output = Command::new(env!("CARGO_BIN_EXE_tlsmpm"))
        .args([
            "run",
            "axis_aligned_mms",
            "--quiet",
            "--set",
            "grid.cells=4",
            "--set",
        ])
        .arg("time.end=1e-4")
        .arg("--out")
        .arg(&out)
        .env("OMPI_COMM_WORLD_SIZE", "1")
        .output()
        .expect("start tlsmpm");
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
}
