//! Column compaction (SPEC §6.4): MPM, DDMPM, BSMPM (orders 1..5), GIMP and CPDI on the
//! published set-up against the published stress errors and grid-crossing count; DDMPM
//! with sub-points (SPEC §3.3, Table 8) on a coarsened column.

mod common;

use common::{by_id, run, scenario, simulate};

/// Published relative L2 stress errors (Wobbes et al. 2019, Fig. 10): MPM, DDMPM, BSMPM.
const PUBLISHED_MPM: f64 = 4.4677e-2;
const PUBLISHED_DDMPM: f64 = 4.4555e-2;
const PUBLISHED_BSMPM: f64 = 4.8511e-3;

fn stress_error(overrides: &[&str]) -> (f64, usize) {
    let summary = run(scenario("column_compaction", overrides), None);
    assert!(
        summary.conservation.max_rel_mass_error <= 1e-13,
        "{overrides:?}"
    );
    assert!(
        summary.conservation.max_rel_momentum_error <= 1e-13,
        "{overrides:?}"
    );
    let rel = summary.errors.expect("exact stress").rel_l2["stress"];
    (rel, summary.grid_crossings)
}

#[test]
fn bsmpm_is_ten_times_more_accurate_than_mpm() {
    let (rel, crossings) = stress_error(&["method.basis=\"bspline\"", "method.order=2"]);
    // Published 4.85e-3; ours is lower (3.8e-3): no worse than the paper, and the same
    // tenfold gain over MPM.
    assert!(
        rel < 1.05 * PUBLISHED_BSMPM && rel > 0.5 * PUBLISHED_BSMPM,
        "BSMPM rel L2 {rel:e} vs published {PUBLISHED_BSMPM:e}"
    );
    assert!(crossings > 100, "knot-span crossings {crossings}");
}

#[test]
fn ddmpm_with_particle_quadrature_stays_at_the_mpm_error_level() {
    // Node integrals by particle quadrature (SPEC §3.2): the dual-domain gradient only
    // slightly changes the grid-crossing error (published 4.46e-2; ours 5.6e-2).
    let (rel, _) = stress_error(&["method.basis=\"ddmpm\""]);
    assert!(
        rel > 0.8 * PUBLISHED_DDMPM && rel < 1.4 * PUBLISHED_DDMPM,
        "DDMPM rel L2 {rel:e} vs published {PUBLISHED_DDMPM:e}"
    );
}

#[test]
fn gimp_and_cpdi_remove_most_of_the_grid_crossing_error() {
    for basis in ["gimp", "cpdi"] {
        let (rel, _) = stress_error(&[&format!("method.basis=\"{basis}\"")]);
        assert!(rel < 0.3 * PUBLISHED_MPM, "{basis}: rel L2 {rel:e}");
    }
}

#[test]
fn bsmpm_orders_one_to_five_run_and_order_one_is_mpm() {
    let coarse = ["grid.cells=10", "particles.per_cell=4", "time.end=0.2"];
    let with = |extra: &[&str]| {
        let mut overrides = coarse.to_vec();
        overrides.extend_from_slice(extra);
        simulate(&scenario("column_compaction", &overrides))
    };
    let mpm = with(&[]);
    let order_one = with(&["method.basis=\"bspline\"", "method.order=1"]);
    let (a, b) = (
        by_id(&mpm, &mpm.particles.stress),
        by_id(&order_one, &order_one.particles.stress),
    );
    let scale = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    for (x, y) in a.iter().zip(&b) {
        assert!((x - y).abs() <= 1e-12 * scale, "{x} vs {y}");
    }
    for order in 2..=5 {
        let order_key = format!("method.order={order}");
        let sim = with(&["method.basis=\"bspline\"", &order_key]);
        assert_eq!(sim.steps_done, 2000);
        assert!(sim.max_mass_error <= 1e-13 && sim.max_momentum_error <= 1e-13);
        assert!(sim.particles.stress.iter().all(|s| s.is_finite()));
    }
}

#[test]
fn published_setup_matches_published_error_and_crossings() {
    let summary = run(scenario("column_compaction", &[]), None);
    let rel = summary.errors.expect("exact stress").rel_l2["stress"];
    // SPEC §6.4: a recomputation with the Hill law gives 4.55e-2, within 2% of the paper.
    assert!(
        (rel / PUBLISHED_MPM - 1.0).abs() < 0.03,
        "rel L2 stress error {rel:e} vs published {PUBLISHED_MPM:e}"
    );
    // Published: about 180 crossings.
    assert!(
        (160..=210).contains(&summary.grid_crossings),
        "crossings {}",
        summary.grid_crossings
    );
    assert!(summary.conservation.max_rel_mass_error <= 1e-13);
    assert!(summary.conservation.max_rel_momentum_error <= 1e-13);
}

#[test]
fn without_grid_crossing_the_stress_is_much_more_accurate() {
    // A tenth of the load keeps every particle in its cell (max displacement ~2.5 cm
    // against cells of 1 m); the remaining error is the dynamic response to the ramp.
    let summary = run(
        scenario("column_compaction", &["problem.gravity=-20"]),
        None,
    );
    assert_eq!(summary.grid_crossings, 0);
    let rel = summary.errors.expect("exact stress").rel_l2["stress"];
    assert!(rel < 0.5 * PUBLISHED_MPM, "rel L2 {rel:e}");
}

/// Published TLS stress errors (Wobbes et al. 2019, Fig. 10): MPM, DDMPM, BSMPM.
const PUBLISHED_TLS: [(&str, f64); 3] = [
    ("linear", 9.2396e-3),
    ("ddmpm", 4.7796e-3),
    ("bspline", 4.1054e-3),
];

#[test]
fn tls_with_particle_centre_totals_reproduces_the_published_errors() {
    // The published method: each particle's mass and momentum in the cell of its centre,
    // the gradient strain (one point per particle in the fits); DDMPM node integrals exact
    // over the material (the default with a reconstruction).
    for (basis, published) in PUBLISHED_TLS {
        let (rel, _) = stress_error(&[
            &format!("method.basis=\"{basis}\""),
            "method.reconstruction=\"tls\"",
            "method.cell_totals=\"centres\"",
            "method.strain=\"gradient\"",
        ]);
        assert!(
            (rel / published - 1.0).abs() < 0.03,
            "{basis}-TLS: {rel:e} vs published {published:e}"
        );
    }
}

#[test]
fn tls_with_domain_totals_beats_the_published_errors() {
    for (basis, published) in PUBLISHED_TLS {
        let (rel, _) = stress_error(&[
            &format!("method.basis=\"{basis}\""),
            "method.reconstruction=\"tls\"",
        ]);
        assert!(
            rel < published,
            "{basis}-TLS: {rel:e} vs published {published:e}"
        );
    }
}

#[test]
fn ddmpm_node_integrals_by_particles_keep_tls_at_the_mpm_error_level() {
    // Why `method.node_integrals = "domain"` is the default with a reconstruction.
    let (rel, _) = stress_error(&[
        "method.basis=\"ddmpm\"",
        "method.reconstruction=\"tls\"",
        "method.node_integrals=\"particles\"",
    ]);
    assert!(rel > 0.02, "{rel:e}");
}

#[test]
fn tls_stays_stable_and_accurate_with_three_particles_per_cell() {
    for basis in ["linear", "bspline"] {
        let (rel, _) = stress_error(&[
            &format!("method.basis=\"{basis}\""),
            "method.reconstruction=\"tls\"",
            "particles.per_cell=3",
        ]);
        assert!(rel < 1e-2, "{basis}-TLS, 3 ppc: {rel:e}");
    }
}

#[test]
fn ddmpm_subpoints_converge_to_the_exact_node_integrals() {
    // Coarsened column (20 cells, 8 PPC, faster ramp). Sub-points are the quadrature of the
    // DDMPM node integrals and of the mapping (SPEC §3.3): as N grows the error moves from
    // particle quadrature towards the exact domain integrals (measured 2.46e-2 plain,
    // 1.56e-2 N = 8, 1.05e-2 N = 32, 1.01e-2 exact), conserving mass and momentum to
    // round-off (checked by `stress_error`). Sub-points in the mapping alone change
    // nothing (2.42e-2): the node integrals carry the gain of Table 8.
    let coarse = [
        "grid.cells=20",
        "particles.per_cell=8",
        "time.end=0.1",
        "method.basis=\"ddmpm\"",
    ];
    let with = |extra: &[&str]| {
        let mut overrides = coarse.to_vec();
        overrides.extend_from_slice(extra);
        stress_error(&overrides).0
    };
    let plain = with(&[]);
    let one = with(&["method.subpoints=1"]);
    let eight = with(&["method.subpoints=8"]);
    let many = with(&["method.subpoints=32"]);
    let exact = with(&["method.node_integrals=\"domain\""]);
    let mapping_only = with(&["method.subpoints=32", "method.node_integrals=\"particles\""]);
    assert_eq!(one.to_bits(), plain.to_bits(), "N = 1 is plain DDMPM");
    assert!(eight < 0.7 * plain, "N=8 {eight:e} vs DDMPM {plain:e}");
    assert!(many < 0.75 * eight, "N=32 {many:e} vs N=8 {eight:e}");
    assert!(
        (many / exact - 1.0).abs() < 0.1,
        "N=32 {many:e} vs exact {exact:e}"
    );
    assert!(
        (mapping_only / plain - 1.0).abs() < 0.05,
        "{mapping_only:e} vs {plain:e}"
    );
}

#[test]
fn multigrid_and_kronecker_solvers_handle_the_empty_top_of_the_column() {
    // The compacting column leaves the top DOFs without mass: they are eliminated (identity
    // rows), which the Galerkin p-multigrid hierarchy and the Kronecker preconditioner mask.
    let base = [
        "method.basis=\"bspline\"",
        "method.order=3",
        "method.reconstruction=\"tls\"",
        "method.mass=\"consistent\"",
        "solver.tolerance=1e-12",
    ];
    let (reference, _) = stress_error(&base);
    for kind in ["pmg", "pmg_cg", "kron"] {
        let key = format!("solver.kind=\"{kind}\"");
        let mut overrides = base.to_vec();
        overrides.push(&key);
        let summary = run(scenario("column_compaction", &overrides), None);
        assert_eq!(summary.solver.kind, kind);
        // The momentum error counts the solve's imbalance |sum (M v - p)|: the solver
        // tolerance, not round-off.
        let momentum = summary.conservation.max_rel_momentum_error;
        assert!(momentum <= 1e-10, "{kind}: momentum error {momentum:e}");
        let error = summary.errors.expect("exact stress").rel_l2["stress"];
        assert!(
            (error - reference).abs() <= 1e-8 * reference,
            "{kind}: {error:e} vs banded {reference:e}"
        );
    }
}

#[test]
fn tls_with_the_adjoint_strain_runs_the_column_at_one_and_two_particles_per_cell() {
    // With the published gradient strain these runs stop with a collapsed particle near
    // the free top (steps 2609 / 3392); the adjoint strain and acceleration keep the
    // frozen step neutral. Measured with one point per particle and the particle masses:
    // 4.9e-3 and 1.4e-2 (plain MPM 8.2e-3 / 1.2e-2); with the defaults (domain weights,
    // the quadratic metric) below the same bounds.
    let adjoint_alone = [
        "method.strain=\"adjoint\"",
        "method.fit_weights=\"points\"",
        "method.adjoint_mass=\"lumped\"",
    ];
    for sets in [&adjoint_alone[..], &[]] {
        for (per_cell, bound) in [(1, 1e-2), (2, 2.5e-2)] {
            let per_cell = format!("particles.per_cell={per_cell}");
            let mut overrides = vec!["method.reconstruction=\"tls\"", per_cell.as_str()];
            overrides.extend_from_slice(sets);
            let (rel, _) = stress_error(&overrides);
            assert!(rel < bound, "{overrides:?}: rel L2 {rel:e}");
        }
    }
}

#[test]
fn tls_with_the_energy_consistent_settings_runs_the_column_at_one_and_two_particles_per_cell() {
    // Adjoint strain, conservative stress fit and kinetic-energy limiter, lumped mass:
    // every particle's fit weight is its volume (no strain fallbacks), the step conserves
    // the physical energy, and the mapping adds no kinetic energy. Measured: linear
    // 3.9e-3 / 7.1e-3, quadratic B-spline 4.3e-3 / 7.5e-3 (with the adjoint strain
    // alone the B-spline run at 2 per cell was 2.4e-1; without the limiter it stops).
    for basis in [
        &["method.basis=\"linear\""][..],
        &["method.basis=\"bspline\"", "method.order=2"],
    ] {
        for per_cell in [1, 2] {
            let per_cell = format!("particles.per_cell={per_cell}");
            let mut sets = vec![
                "method.reconstruction=\"tls\"",
                "method.strain=\"adjoint\"",
                "method.stress_fit=\"conservative\"",
                "method.momentum_limiter=\"kinetic_energy\"",
                per_cell.as_str(),
            ];
            sets.extend_from_slice(basis);
            let (rel, _) = stress_error(&sets);
            assert!(rel < 1e-2, "{sets:?}: rel L2 {rel:e}");
        }
    }
}
