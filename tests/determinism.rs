//! Results are bitwise identical for any thread count (DESIGN §1): the per-cell scatter
//! buffers are reduced in a fixed order and every reduction is blocked deterministically.

mod common;

use common::{pool, scenario};
use std::process::Command;
use tlsmpm::app::build_simulation;
use tlsmpm::particles::Particles;

fn bits(values: &[f64]) -> Vec<u64> {
    values.iter().map(|v| v.to_bits()).collect()
}

fn simulate(threads: usize, steps: usize) -> (Particles, Vec<u64>) {
    simulate_with(threads, steps, &[])
}

fn simulate_with(threads: usize, steps: usize, overrides: &[&str]) -> (Particles, Vec<u64>) {
    // Large bar with crossings and re-sorting; enough particles and cells for many tasks.
    let mut all = vec!["grid.cells=1000"];
    all.extend_from_slice(overrides);
    let s = scenario("vibrating_bar_large", &all);
    let (problem, mut sim) = build_simulation(&s, false).expect("build");
    pool(threads)
        .install(|| sim.run(steps, &|t| problem.body_acceleration(t), &mut |_| Ok(())))
        .expect("run");
    let history: Vec<u64> = sim
        .history
        .iter()
        .flat_map(|h| {
            [
                h.mass_rel_error.to_bits(),
                h.momentum_rel_error.unwrap_or(0.0).to_bits(),
                h.kinetic_energy.to_bits(),
                h.grid_crossings as u64,
            ]
        })
        .collect();
    (sim.particles, history)
}

#[test]
fn every_basis_gives_the_same_bits_on_one_and_three_threads() {
    for basis in ["ddmpm", "bspline", "gimp", "cpdi"] {
        let key = format!("method.basis=\"{basis}\"");
        let (serial, serial_history) = simulate_with(1, 100, &[&key, "method.order=3"]);
        let (parallel, parallel_history) = simulate_with(3, 100, &[&key, "method.order=3"]);
        assert_eq!(serial.id, parallel.id, "{basis}");
        assert_eq!(bits(&serial.x), bits(&parallel.x), "{basis}");
        assert_eq!(bits(&serial.stress), bits(&parallel.stress), "{basis}");
        assert_eq!(serial_history, parallel_history, "{basis}");
    }
}

#[test]
fn reconstructions_give_the_same_bits_on_one_and_three_threads() {
    for reconstruction in ["tls", "cubic_spline", "imls", "mls"] {
        for basis in ["linear", "ddmpm", "bspline"] {
            for mass in ["lumped", "consistent"] {
                // 1000 cells: the consistent-mass stability limit of B-splines is below
                // the scenario's 1e-4 s.
                let keys = [
                    format!("method.basis=\"{basis}\""),
                    format!("method.reconstruction=\"{reconstruction}\""),
                    format!("method.mass=\"{mass}\""),
                    "time.dt=2e-5".to_string(),
                ];
                let keys: Vec<&str> = keys.iter().map(String::as_str).collect();
                let label = format!("{reconstruction} {basis} {mass}");
                let (serial, serial_history) = simulate_with(1, 60, &keys);
                let (parallel, parallel_history) = simulate_with(3, 60, &keys);
                assert_eq!(serial.id, parallel.id, "{label}");
                assert_eq!(bits(&serial.x), bits(&parallel.x), "{label}");
                assert_eq!(bits(&serial.v), bits(&parallel.v), "{label}");
                assert_eq!(bits(&serial.stress), bits(&parallel.stress), "{label}");
                assert_eq!(serial_history, parallel_history, "{label}");
            }
        }
    }
}

#[test]
fn ddmpm_subpoints_give_the_same_bits_on_one_and_three_threads() {
    // Sub-points cross into neighbouring cells; the mapping bins them by their own cell.
    let keys = ["method.basis=\"ddmpm\"", "method.subpoints=5"];
    let (serial, serial_history) = simulate_with(1, 100, &keys);
    let (parallel, parallel_history) = simulate_with(3, 100, &keys);
    assert_eq!(serial.id, parallel.id);
    assert_eq!(bits(&serial.x), bits(&parallel.x));
    assert_eq!(bits(&serial.v), bits(&parallel.v));
    assert_eq!(bits(&serial.stress), bits(&parallel.stress));
    assert_eq!(serial_history, parallel_history);
}

#[test]
fn one_two_and_three_threads_give_the_same_bits() {
    let (serial, serial_history) = simulate(1, 300);
    assert!(
        serial_history.last().copied().unwrap_or(0) > 0,
        "no grid crossing"
    );
    for threads in [2, 3] {
        let (parallel, parallel_history) = simulate(threads, 300);
        assert_eq!(serial.id, parallel.id);
        for (a, b) in [
            (&serial.x, &parallel.x),
            (&serial.u, &parallel.u),
            (&serial.v, &parallel.v),
            (&serial.stress, &parallel.stress),
            (&serial.volume, &parallel.volume),
            (&serial.density, &parallel.density),
        ] {
            assert_eq!(bits(a), bits(b), "{threads} threads");
        }
        assert_eq!(serial_history, parallel_history, "{threads} threads");
    }
}

#[test]
fn binary_writes_identical_particles_csv_for_threads_1_and_2() {
    let dir = tempfile::tempdir().expect("tempdir");
    let mut outputs = Vec::new();
    for threads in ["1", "2"] {
        let out = dir.path().join(format!("threads_{threads}"));
        let status = Command::new(env!("CARGO_BIN_EXE_tlsmpm"))
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .args([
                "run",
                "scenarios/column_compaction.toml",
                "--quiet",
                "--threads",
            ])
            .arg(threads)
            .args([
                "--set",
                "grid.cells=200",
                "--set",
                "output.plots=false",
                "--out",
            ])
            .arg(&out)
            .status()
            .expect("binary runs");
        assert!(status.success());
        outputs.push(std::fs::read(out.join("particles.csv")).expect("particles.csv"));
    }
    assert!(!outputs[0].is_empty());
    assert!(
        outputs[0] == outputs[1],
        "particles.csv differs between 1 and 2 threads"
    );
}

/// The energies of `history.csv` are summed inside the particle update (one block of the
/// deterministic sum per task): each row equals, bit for bit, a separate deterministic
/// pass over the particles after that step (`TimeStepper::energies`), for every law, both
/// schemes and the consistent mass, on many blocks, and on 1 and 3 threads.
#[test]
fn energies_folded_into_the_particle_update_equal_a_separate_pass() {
    let cases: [&[&str]; 4] = [
        &[],
        &["method.scheme=\"usl\""],
        &[
            "method.basis=\"bspline\"",
            "method.order=2",
            "method.reconstruction=\"tls\"",
            "method.mass=\"consistent\"",
            // Below the consistent mass's stability limit at 1000 cells.
            "time.dt=5e-5",
        ],
        &["material.model=\"linear\""],
    ];
    for overrides in cases {
        for threads in [1, 3] {
            // 1000 cells x 8 particles: two blocks of 4096 particles (one partial).
            let mut all = vec!["grid.cells=1000"];
            all.extend_from_slice(overrides);
            let s = scenario("vibrating_bar_large", &all);
            assert!(s.grid.cells.along_x() * s.particles.per_cell > 4096);
            let (problem, mut sim) = build_simulation(&s, false).expect("build");
            pool(threads).install(|| {
                for _ in 0..20 {
                    sim.run(1, &|t| problem.body_acceleration(t), &mut |_| Ok(()))
                        .expect("run");
                    let row = sim.history.last().expect("a row per step");
                    let (kinetic, strain) = sim.stepper.energies(&sim.particles);
                    assert!(kinetic > 0.0 && strain > 0.0, "{overrides:?}");
                    assert_eq!(
                        (row.kinetic_energy.to_bits(), row.strain_energy.to_bits()),
                        (kinetic.to_bits(), strain.to_bits()),
                        "{overrides:?}, {threads} threads, step {}",
                        row.step
                    );
                }
            });
        }
    }
}

/// Steps `steps` of `scenario` by hand (as `Simulation::run` does, body force included),
/// with the particle update mapping the next step ahead or not; returns the particles, the
/// bits of each step's report and the steps that were mapped ahead.
fn step_1d(
    name: &str,
    overrides: &[&str],
    steps: usize,
    map_ahead: bool,
) -> (Particles, Vec<u64>, usize) {
    use tlsmpm::physics::{Body, BodySource};
    use tlsmpm::problems::ProblemBody;
    let s = scenario(name, overrides);
    let (problem, mut sim) = build_simulation(&s, false).expect("build");
    sim.stepper.set_map_ahead(map_ahead);
    let body = ProblemBody(problem.as_ref());
    let dt = sim.stepper.dt();
    let mut field = vec![0.0; sim.particles.len()];
    let (mut reports, mut ahead) = (Vec::new(), 0);
    pool(2).install(|| {
        for step in 1..=steps {
            let time = step as f64 * dt;
            let report = match body.uniform(time) {
                Some(b) => sim
                    .stepper
                    .step(&mut sim.particles, Body::Uniform(b), step, time),
                None => {
                    body.at_particles(&sim.particles.x0, time - dt, &mut field);
                    let field = Body::PerParticle(&field);
                    sim.stepper.step(&mut sim.particles, field, step, time)
                }
            }
            .expect("step");
            let (kinetic, strain) = report.energies.expect("energies");
            reports.extend([
                report.mass_error.to_bits(),
                report.momentum_error.unwrap_or(0.0).to_bits(),
                kinetic.to_bits(),
                strain.to_bits(),
                report.crossings as u64,
            ]);
            ahead += usize::from(report.mapped_ahead);
        }
    });
    (sim.particles, reports, ahead)
}

#[test]
fn mapping_the_next_step_in_the_1d_particle_update_changes_no_bit() {
    // B-splines, GIMP and CPDI (the bases with a shape cache), MUSL and USL, on the large
    // bar (crossings every step, and re-sorts when particles pass each other) and the MMS
    // bar (a body force per particle): the particles and every step's diagnostics equal
    // those of the plain passes bit for bit.
    let bar = "vibrating_bar_large";
    let cases: [(&str, &[&str]); 6] = [
        (bar, &["method.basis=\"bspline\"", "method.order=2"]),
        (
            bar,
            &[
                "method.basis=\"bspline\"",
                "method.order=3",
                "method.scheme=\"usl\"",
            ],
        ),
        (bar, &["method.basis=\"gimp\""]),
        (bar, &["method.basis=\"cpdi\""]),
        ("mms_bar", &["method.basis=\"bspline\"", "method.order=2"]),
        ("mms_bar", &["method.basis=\"cpdi\"", "grid.cells=64"]),
    ];
    for (name, sets) in cases {
        let mut overrides = vec!["method.reconstruction=\"none\"", "method.mass=\"lumped\""];
        if name == bar {
            overrides.push("grid.cells=1000");
        }
        overrides.extend_from_slice(sets);
        let steps = 150;
        let (ahead, ahead_reports, mapped) = step_1d(name, &overrides, steps, true);
        let (plain, plain_reports, not_mapped) = step_1d(name, &overrides, steps, false);
        let case = format!("{name} {sets:?}");
        eprintln!("{case}: {mapped} of {steps} steps mapped ahead");
        assert_eq!(not_mapped, 0, "{case}");
        assert!(mapped > steps / 2, "{case}: {mapped} steps mapped ahead");
        assert_eq!(ahead_reports, plain_reports, "{case}");
        assert_eq!(ahead.id, plain.id, "{case}");
        for (a, p) in [
            (&ahead.x, &plain.x),
            (&ahead.u, &plain.u),
            (&ahead.v, &plain.v),
            (&ahead.stress, &plain.stress),
            (&ahead.volume, &plain.volume),
            (&ahead.density, &plain.density),
            (&ahead.deformation_gradient, &plain.deformation_gradient),
        ] {
            assert_eq!(bits(a), bits(p), "{case}");
        }
    }
}
