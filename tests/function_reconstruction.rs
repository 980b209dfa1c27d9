//! `tlsmpm reconstruct` (SPEC §6.1, IJNME Table 1): TLS keeps the integral of the data to
//! round-off, the cubic spline does not; the degenerate cell is repaired by a virtual point.

use std::process::Command;
use tlsmpm::app::reconstruct::{reconstruct, PUBLISHED, PUBLISHED_SPLINE};

#[test]
fn tls_conserves_the_integral_and_the_spline_does_not() {
    let report = reconstruct(None).expect("reconstruction");
    assert_eq!(report.points.len(), 11);
    assert!(report.tls.integral < 1e-13, "{:e}", report.tls.integral);
    assert!(
        report.spline.integral > 1e-6,
        "{:e}",
        report.spline.integral
    );
    // Unpublished positions: the same size as the published RMS errors.
    assert!(
        report.tls.rms < 2.5 * PUBLISHED.rms && report.tls.rms > 0.2 * PUBLISHED.rms,
        "TLS rms {:e}",
        report.tls.rms
    );
    assert!(
        report.spline.rms < 2.5 * PUBLISHED_SPLINE.rms,
        "spline rms {:e}",
        report.spline.rms
    );
}

#[test]
fn degenerate_cell_needs_the_virtual_point() {
    let report = reconstruct(None).expect("reconstruction");
    // pi and 5 pi / 3: psi_3 = -psi_2 / 3 there, the 2x2 block is singular.
    assert!(report.degenerate_refused);
    assert!(report.degenerate_relative_determinant.abs() < 1e-12);
    // Order reduction alone leaves a large error in the cell; the virtual point fixes it.
    assert!(
        report.degenerate_cell_rms > 3.0 * report.virtual_cell_rms,
        "{:e} vs {:e}",
        report.degenerate_cell_rms,
        report.virtual_cell_rms
    );
    assert!(
        report.degenerate_cell_rms > 0.1,
        "{:e}",
        report.degenerate_cell_rms
    );
    assert!(
        report.virtual_cell_rms < 0.1,
        "{:e}",
        report.virtual_cell_rms
    );
    // Both stay conservative.
    assert!(report.degenerate.integral < 1e-13 && report.virtual_point.integral < 1e-13);
}

#[test]
fn cli_writes_the_table_csv_and_plot() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let output = Command::new(env!("CARGO_BIN_EXE_tlsmpm"))
        .args(["reconstruct", "--out"])
        .arg(dir.path())
        .output()
        .expect("start tlsmpm");
    assert!(output.status.success(), "{output:?}");
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        stdout.contains("TLS") && stdout.contains("cubic spline"),
        "{stdout}"
    );
    let csv = std::fs::read_to_string(dir.path().join("reconstruction.csv")).expect("csv");
    let mut lines = csv.lines();
    assert_eq!(
        lines.next(),
        Some("x,exact,tls,spline,tls_degenerate,tls_virtual")
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().expect("number")).collect())
        .collect();
    assert_eq!(rows.len(), 400);
    assert!(rows
        .iter()
        .all(|r| r.len() == 6 && r.iter().all(|v| v.is_finite())));
    assert!(rows.windows(2).all(|w| w[0][0] < w[1][0]));
    let svg = std::fs::read_to_string(dir.path().join("reconstruction.svg")).expect("svg");
    assert!(svg.contains("<svg") && svg.contains("cubic spline"));
}
