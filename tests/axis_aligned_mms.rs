//! The axis-aligned manufactured solution (Wallstedt & Guilkey 2008) in 2D plane strain and
//! 3D: linear-hat MPM loses convergence on fine grids (grid crossing), GIMP and quadratic
//! B-splines converge at about second order in displacement (`docs/dimensions.md`).

mod common;

use common::{orders, scenario, study};
use tlsmpm::problems::Field;

fn study_2d(basis: &[&str], cells: &[usize]) -> Vec<tlsmpm::app::StudyRow> {
    study(scenario("axis_aligned_mms", basis), cells)
}

#[test]
fn linear_hats_do_not_converge_in_2d() {
    let rows = study_2d(&["method.basis=\"linear\""], &[16, 32, 64]);
    let u = orders(&rows, Field::Displacement);
    let s = orders(&rows, Field::Stress);
    assert!(u[1] < 0.5, "displacement orders {u:?}");
    assert!(s.iter().all(|&o| o < 0.3), "stress orders {s:?}");
}

#[test]
fn gimp_and_quadratic_bsplines_converge_at_second_order_in_2d() {
    let rows = study_2d(&["method.basis=\"gimp\""], &[8, 16, 32]);
    for field in Field::ALL {
        let o = orders(&rows, field);
        assert!(o.iter().all(|&o| o > 1.8), "GIMP {field:?} orders {o:?}");
    }
    let rows = study_2d(
        &["method.basis=\"bspline\"", "method.order=2"],
        &[8, 16, 32],
    );
    let u = orders(&rows, Field::Displacement);
    assert!(
        u.iter().all(|&o| o > 1.7),
        "BSMPM p = 2 displacement orders {u:?}"
    );
}

#[test]
fn gimp_and_quadratic_bsplines_converge_in_3d() {
    for basis in [
        &["method.basis=\"gimp\""][..],
        &["method.basis=\"bspline\"", "method.order=2"],
    ] {
        let mut sets = basis.to_vec();
        sets.extend(["problem.dim=3", "particles.per_cell=8"]);
        let rows = study(scenario("axis_aligned_mms", &sets), &[4, 8, 12]);
        let u = orders(&rows, Field::Displacement);
        assert!(u[1] > 1.8, "{basis:?} 3D displacement orders {u:?}");
        let s = orders(&rows, Field::Stress);
        assert!(s[1] > 1.5, "{basis:?} 3D stress orders {s:?}");
    }
}
