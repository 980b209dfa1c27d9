//! The manufactured-solution bar with a neo-Hookean material (SPEC §6.5): the published
//! behaviour of plain MPM (no convergence under grid crossing) and CPDI (about second
//! order on coarse grids), at small sizes.

mod common;

use common::{orders, scenario, study};
use tlsmpm::problems::Field;

#[test]
fn plain_mpm_does_not_converge_under_grid_crossing() {
    let rows = study(scenario("mms_bar", &[]), &[8, 16, 32]);
    let stress = orders(&rows, Field::Stress);
    // The stress error grows with refinement (published: no convergence).
    assert!(
        stress.iter().all(|&o| o < 0.0),
        "MPM stress orders {stress:?}"
    );
}

#[test]
fn cpdi_converges_on_coarse_grids() {
    let rows = study(scenario("mms_bar", &["method.basis=cpdi"]), &[8, 16, 32]);
    for field in [Field::Displacement, Field::Velocity, Field::Stress] {
        let o = orders(&rows, field);
        assert!(o.iter().all(|&o| o > 1.5), "CPDI {field:?} orders {o:?}");
    }
}
