//! Distributed runs under `mpirun` (built with `--features mpi`; `.ci/run` installs Open
//! MPI and runs these): 2D runs on 2 and 4 ranks write the particles of one process to
//! round-off and repeat bit for bit; a bad decomposition and a dying rank end the job
//! with a non-zero exit instead of a hang.
#![cfg(feature = "mpi")]

use std::path::Path;
use std::process::{Command, Output};
use tlsmpm::output::vtu::read_vtu_summary;

fn tlsmpm(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tlsmpm"))
        .args(args)
        .output()
        .expect("run tlsmpm")
}

/// `mpirun -np ranks` (oversubscribed, as root where CI runs as root) of `program args`.
fn mpirun(ranks: usize, program: &str, args: &[&str]) -> Output {
    Command::new("mpirun")
        .args([
            "--oversubscribe",
            "--allow-run-as-root",
            "-np",
            &ranks.to_string(),
        ])
        .arg(program)
        .args(args)
        .env("OMPI_MCA_rmaps_base_oversubscribe", "1")
        .output()
        .expect("mpirun (install Open MPI: apt-get install openmpi-bin libopenmpi-dev)")
}

/// `particles.csv` of `dir`: the header and the rows (sorted by id in the file).
fn particles(dir: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(dir.join("particles.csv")).expect("particles.csv");
    let mut lines = text.lines();
    let header: Vec<String> = lines
        .next()
        .expect("header")
        .split(',')
        .map(String::from)
        .collect();
    let rows = lines
        .map(|l| l.split(',').map(|v| v.parse().expect("number")).collect())
        .collect();
    (header, rows)
}

/// Largest difference of the displacement, velocity and stress columns, each relative to
/// the largest magnitude of its whole field (the transverse components of an extruded run
/// are round-off themselves).
fn largest_relative_difference(dir_a: &Path, dir_b: &Path) -> f64 {
    let (header, a) = particles(dir_a);
    let (header_b, b) = particles(dir_b);
    assert_eq!(header, header_b);
    assert_eq!(a.len(), b.len(), "particle count");
    let mut worst = 0.0f64;
    for prefix in ["u_", "v_", "stress_"] {
        let columns: Vec<usize> = header
            .iter()
            .enumerate()
            .filter(|(_, h)| h.starts_with(prefix) && !h.ends_with("_exact"))
            .map(|(c, _)| c)
            .collect();
        assert!(!columns.is_empty(), "{prefix}");
        let scale = a
            .iter()
            .flat_map(|r| columns.iter().map(|&c| r[c].abs()))
            .fold(0.0f64, f64::max);
        for (ra, rb) in a.iter().zip(&b) {
            for &c in &columns {
                worst = worst.max((ra[c] - rb[c]).abs() / scale);
            }
        }
    }
    worst
}

fn run_args<'a>(scenario: &'a str, out: &'a str, sets: &'a [&'a str]) -> Vec<&'a str> {
    let mut args = vec!["run", scenario, "--quiet", "--out", out, "--threads", "1"];
    for s in sets {
        args.extend(["--set", s]);
    }
    args
}

#[test]
fn two_and_four_ranks_write_the_one_process_particles_and_repeat_bit_for_bit() {
    let cases: [(&str, &[&str]); 3] = [
        ("axis_aligned_mms", &["grid.cells=16", "time.end=0.004"]),
        // TLS with the consistent mass: CG over ranks, to a tolerance below the test's.
        (
            "axis_aligned_mms",
            &[
                "grid.cells=16",
                "time.end=0.002",
                "method.reconstruction=\"tls\"",
                "method.mass=\"consistent\"",
                "solver.kind=\"pcg\"",
                "solver.tolerance=1e-13",
            ],
        ),
        (
            "column_compaction",
            &[
                "problem.dim=2",
                "particles.per_cell=4",
                "material.model=\"linear\"",
                "grid.cells=[4, 16]",
                "time.end=0.05",
            ],
        ),
    ];
    let dir = tempfile::tempdir().expect("temp dir");
    for (case, (scenario, sets)) in cases.into_iter().enumerate() {
        let one = dir.path().join(format!("{case}_{scenario}_1"));
        let output = tlsmpm(&run_args(scenario, one.to_str().unwrap(), sets));
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        for ranks in [2, 4] {
            let many = dir.path().join(format!("{case}_{scenario}_{ranks}"));
            let args = run_args(scenario, many.to_str().unwrap(), sets);
            let output = mpirun(ranks, env!("CARGO_BIN_EXE_tlsmpm"), &args);
            assert!(
                output.status.success(),
                "{scenario} {ranks}: {}",
                String::from_utf8_lossy(&output.stderr)
            );
            let difference = largest_relative_difference(&one, &many);
            assert!(
                difference < 1e-12,
                "{scenario} on {ranks} ranks: {difference:e}"
            );
            let history = std::fs::read_to_string(many.join("history.csv")).expect("history");
            for row in history.lines().skip(1) {
                let values: Vec<f64> = row.split(',').map(|v| v.parse().unwrap_or(0.0)).collect();
                assert!(
                    values[2] < 1e-13 && values[3] < 1e-13,
                    "{scenario} {ranks}: {row}"
                );
            }
            if ranks == 2 {
                let again = dir.path().join(format!("{case}_{scenario}_{ranks}_again"));
                let args = run_args(scenario, again.to_str().unwrap(), sets);
                let output = mpirun(ranks, env!("CARGO_BIN_EXE_tlsmpm"), &args);
                assert!(output.status.success());
                let read = |d: &Path| std::fs::read(d.join("particles.csv")).expect("csv");
                assert!(read(&many) == read(&again), "{scenario}: repeat differs");
            }
        }
    }
}

#[test]
fn a_bad_decomposition_or_a_dying_rank_ends_the_job_with_a_non_zero_exit() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("bad");
    let args = run_args("axis_aligned_mms", out.to_str().unwrap(), &["grid.cells=3"]);
    let output = mpirun(4, env!("CARGO_BIN_EXE_tlsmpm"), &args);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    // Every rank finds the same fault; mpirun may end the others once the first has
    // exited, so any one whole line will do (each message is written in one piece).
    let whole_line = stderr.lines().any(|line| {
        line.starts_with("rank ")
            && line
                .contains(": error: invalid value for `grid.cells` = 3: 4 ranks on 3 cell layers")
    });
    assert!(whole_line, "{stderr}");
    // Rank 1 is killed mid-run: mpirun ends the job (no hang), non-zero.
    let out = dir.path().join("dead");
    let run =
        "if [ \"$OMPI_COMM_WORLD_RANK\" = 1 ]; then exec timeout -s KILL 1 \"$0\" \"$@\"; fi; \
               exec \"$0\" \"$@\"";
    let mut args = vec!["-c", run, env!("CARGO_BIN_EXE_tlsmpm")];
    let sets = ["grid.cells=64", "time.end=1"];
    let run_args = run_args("axis_aligned_mms", out.to_str().unwrap(), &sets);
    args.extend(run_args.iter().copied());
    let started = std::time::Instant::now();
    let output = mpirun(2, "sh", &args);
    assert!(
        !output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(started.elapsed().as_secs() < 60, "the job hung");
}

#[test]
fn every_rank_writes_its_vtu_piece_and_the_pvtu_names_them() {
    let sets = [
        "grid.cells=12",
        "time.end=0.002",
        "output.vtk=true",
        "output.snapshots=1",
        "method.reconstruction=\"tls\"",
        "method.mass=\"consistent\"",
    ];
    let dir = tempfile::tempdir().expect("temp dir");
    let one = dir.path().join("one");
    let output = tlsmpm(&run_args("axis_aligned_mms", one.to_str().unwrap(), &sets));
    assert!(output.status.success());
    let many = dir.path().join("many");
    let output = mpirun(
        2,
        env!("CARGO_BIN_EXE_tlsmpm"),
        &run_args("axis_aligned_mms", many.to_str().unwrap(), &sets),
    );
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    let pvd = std::fs::read_to_string(many.join("particles.pvd")).expect("pvd");
    assert!(pvd.contains("file=\"particles_0001.pvtu\""), "{pvd}");
    // The consistent mass of a distributed run defaults to Jacobi CG.
    let summary = std::fs::read_to_string(many.join("summary.json")).expect("summary");
    assert!(summary.contains("\"kind\": \"pcg\""), "{summary}");
    for frame in ["particles_0000", "particles_0001"] {
        let index = std::fs::read_to_string(many.join(format!("{frame}.pvtu"))).expect("pvtu");
        let reference = std::fs::read_to_string(one.join(format!("{frame}.vtu"))).expect("vtu");
        let reference = read_vtu_summary(&reference).expect("reference vtu");
        let mut masses = Vec::new();
        for rank in 0..2 {
            let piece = format!("{frame}_{rank:04}.vtu");
            assert!(
                index.contains(&format!("<Piece Source=\"{piece}\"/>")),
                "{index}"
            );
            let text = std::fs::read_to_string(many.join(&piece)).expect("piece");
            let piece = read_vtu_summary(&text).expect("piece vtu");
            assert!(piece.n_points > 0, "{frame}: rank {rank} wrote no particle");
            for (name, components, values) in &piece.arrays {
                let declared = format!("Name=\"{name}\" NumberOfComponents=\"{components}\"");
                assert!(index.contains(&declared), "{frame}: {declared}");
                if name == "mass" {
                    masses.extend(values.iter().map(|m| m.to_bits()));
                }
            }
        }
        // Together the pieces hold every particle once (masses do not change).
        let (_, _, reference_mass) = reference
            .arrays
            .iter()
            .find(|(name, _, _)| name == "mass")
            .expect("mass");
        let mut expected: Vec<u64> = reference_mass.iter().map(|m| m.to_bits()).collect();
        masses.sort_unstable();
        expected.sort_unstable();
        assert_eq!(masses, expected, "{frame}");
    }
}
