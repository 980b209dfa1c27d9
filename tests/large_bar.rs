//! Large-deformation vibrating bar (SPEC §6.3) against the ULFEM reference
//! (`problem.reference = "ulfem"`, 120 DOFs): grid crossing of MPM and the error reduction
//! of DDMPM, BSMPM, GIMP and CPDI.

mod common;

use common::{run, scenario};

fn stress_error(overrides: &[&str]) -> (f64, usize) {
    let mut all = vec!["problem.reference=\"ulfem\""];
    all.extend_from_slice(overrides);
    let summary = run(scenario("vibrating_bar_large", &all), None);
    assert!(summary.conservation.max_rel_mass_error <= 1e-14);
    assert!(summary.conservation.max_rel_momentum_error <= 1e-14);
    let errors = summary.errors.expect("reference errors");
    assert_eq!(
        errors.rel_l2.len(),
        3,
        "u, v and stress against the reference"
    );
    (errors.rel_l2["stress"], summary.grid_crossings)
}

#[test]
fn mpm_crosses_cells_over_a_hundred_times_and_smoother_bases_halve_its_error() {
    let (mpm, crossings) = stress_error(&[]);
    assert!(crossings > 100, "MPM grid crossings {crossings}");
    assert!(mpm > 0.02, "MPM must show the grid-crossing error: {mpm:e}");
    for basis in ["ddmpm", "bspline", "gimp", "cpdi"] {
        let key = format!("method.basis=\"{basis}\"");
        let (rel, _) = stress_error(&[&key]);
        assert!(rel < 0.5 * mpm, "{basis}: {rel:e} vs MPM {mpm:e}");
    }
}

#[test]
fn the_reference_is_converged_for_the_mpm_comparison() {
    // The MPM error against 120 and 480 reference DOFs differs by far less than itself.
    let (coarse, _) = stress_error(&[]);
    let (fine, _) = stress_error(&["problem.reference_dofs=480"]);
    assert!(
        (coarse - fine).abs() < 0.02 * fine,
        "120 DOFs {coarse:e}, 480 DOFs {fine:e}"
    );
}

/// Relative L2 stress error and the conservation errors (no conservation assertion).
fn tls_run(overrides: &[&str]) -> (f64, tlsmpm::output::summary::Conservation, String) {
    let mut all = vec![
        "problem.reference=\"ulfem\"",
        "method.reconstruction=\"tls\"",
    ];
    all.extend_from_slice(overrides);
    let summary = run(scenario("vibrating_bar_large", &all), None);
    let rel = summary.errors.expect("reference errors").rel_l2["stress"];
    (rel, summary.conservation, summary.status)
}

#[test]
fn tls_reduces_the_mpm_error_by_at_least_the_published_factors() {
    // Published reduction of the plain-MPM stress error: BSMPM-TLS 9.9, DDMPM-TLS 7.8.
    let (mpm, _) = stress_error(&[]);
    // The published step (gradient strain, per-centre totals) and the 1D defaults (adjoint
    // strain, domain totals and fit weights, quadratic metric). Measured with the adjoint
    // strain and per-centre totals: BSMPM-TLS 9.86, below the published 9.9.
    for (basis, published, mass) in [
        ("bspline", 9.9, "consistent"),
        ("ddmpm", 7.8, "lumped"),
        ("ddmpm", 7.8, "consistent"),
    ] {
        for method in [
            &[
                "method.strain=\"gradient\"",
                "method.cell_totals=\"centres\"",
            ][..],
            &[],
        ] {
            let mut sets = vec![
                format!("method.basis=\"{basis}\""),
                format!("method.mass=\"{mass}\""),
            ];
            sets.extend(method.iter().map(|s| s.to_string()));
            let sets: Vec<&str> = sets.iter().map(String::as_str).collect();
            let (rel, conservation, status) = tls_run(&sets);
            assert_eq!(status, "completed");
            assert!(conservation.max_rel_mass_error <= 1e-13, "{conservation:?}");
            assert!(
                conservation.max_rel_momentum_error <= 1e-13,
                "{conservation:?}"
            );
            let factor = mpm / rel;
            assert!(
                factor >= published,
                "{basis} {mass} {method:?}: factor {factor}"
            );
        }
    }
}

#[test]
fn one_and_two_particles_per_cell_run_without_nan_and_conserve() {
    for ppc in ["1", "2"] {
        for basis in ["linear", "bspline"] {
            let (rel, conservation, status) = tls_run(&[
                &format!("particles.per_cell={ppc}"),
                &format!("method.basis=\"{basis}\""),
                "method.mass=\"consistent\"",
            ]);
            assert_eq!(status, "completed", "{ppc} ppc {basis}");
            assert!(rel.is_finite());
            assert!(conservation.max_rel_mass_error <= 1e-13, "{conservation:?}");
            assert!(
                conservation.max_rel_momentum_error <= 1e-13,
                "{conservation:?}"
            );
        }
    }
}

/// `(initial, largest)` total energy (kinetic + stored) of the large bar on 64 cells, 8
/// particles per cell, `v0 = 0.8`, to `end` seconds, and whether the run completed.
fn large_bar_energy(end: f64, overrides: &[&str]) -> (f64, f64, bool) {
    let end = format!("time.end={end}");
    let mut sets = vec![
        "grid.cells=64",
        "problem.reference=\"exact\"",
        "method.reconstruction=\"tls\"",
        end.as_str(),
    ];
    sets.extend_from_slice(overrides);
    let scenario = scenario("vibrating_bar_large", &sets);
    let (problem, mut simulation) =
        tlsmpm::app::build_simulation(&scenario, false).expect("valid scenario");
    let (kinetic, stored) = simulation.energies();
    let initial = kinetic + stored;
    let mut largest = initial;
    let completed = simulation
        .run(
            scenario.n_steps(),
            &tlsmpm::problems::ProblemBody(problem.as_ref()),
            &mut |sim| {
                let (kinetic, stored) = sim.energies();
                largest = largest.max(kinetic + stored);
                Ok(())
            },
        )
        .is_ok();
    (initial, largest, completed)
}

#[test]
fn tls_with_the_energy_consistent_settings_runs_the_large_bar_for_twenty_seconds() {
    // The published TLS (gradient strain, full stress fit) gains energy until a particle
    // collapses (at 4.6 s); the adjoint strain alone (one point per particle, the particle
    // masses) stops at 6.6 s. With the conservative stress fit every particle's fit weight
    // is its volume and the semi-discrete step conserves the physical energy: measured
    // largest total energy 1.25x the initial over 20 s (dt = 1e-4; 1.02x at dt = 5e-5),
    // linear basis.
    let (_, _, published) = large_bar_energy(20.0, &["method.strain=\"gradient\""]);
    assert!(
        !published,
        "the published TLS now survives 20 s: update the docs"
    );
    let (initial, largest, completed) = large_bar_energy(
        20.0,
        &[
            "method.strain=\"adjoint\"",
            "method.fit_weights=\"points\"",
            "method.adjoint_mass=\"lumped\"",
            "method.stress_fit=\"conservative\"",
            "method.momentum_limiter=\"kinetic_energy\"",
        ],
    );
    assert!(completed);
    assert!(
        largest < 1.35 * initial,
        "energy {largest} against {initial} at the start"
    );
}

#[test]
fn tls_with_the_1d_defaults_runs_the_large_bar_for_twenty_seconds() {
    // The defaults (adjoint strain, domain-weighted fits, quadratic particle metric, full
    // stress fit): no growing mode of the frozen step, but the full fit's energy is not
    // the physical one; measured largest total energy 508 J against 320 J at the start
    // (1.59x) over 20 s, linear basis, dt = 1e-4.
    let (initial, largest, completed) = large_bar_energy(20.0, &[]);
    assert!(completed);
    assert!(
        largest < 1.7 * initial,
        "energy {largest} against {initial} at the start"
    );
}

#[test]
fn imls_with_the_conjugate_particle_acceleration_runs_the_large_bar_for_twenty_seconds() {
    // IMLS (adjoint strain, MUSL) accelerates the particles with the hats while its momentum
    // is the nodal velocity fit; the two are not transposes and the run gains energy until a
    // particle collapses at 15.3 s. With the conjugate acceleration the grid's and the
    // particles' work agree: measured largest total energy 1.12x the initial over 20 s
    // (dt = 1e-4; 1.02x at dt = 5e-5).
    let (initial, largest, completed) = large_bar_energy(
        20.0,
        &[
            "method.reconstruction=\"imls\"",
            "method.particle_acceleration=\"conjugate\"",
        ],
    );
    assert!(completed);
    assert!(
        largest < 1.2 * initial,
        "energy {largest} against {initial} at the start"
    );
}
