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
