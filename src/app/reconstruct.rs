//! `tlsmpm reconstruct`: the function-reconstruction benchmark (SPEC §6.1, IJNME Table 1).
//!
//! `f(x) = sin x + 2` on `[0, 4 pi]`, 4 cells of size `pi`, 11 data points. The published
//! positions are not known; this layout follows the description (positions as fractions
//! of the cell, `x = (e + t) pi` in cell `e = 0..3`):
//!
//! | cell | `t` | note |
//! |---|---|---|
//! | 1 `[0, pi]` | 0, 0.58, 1 | the ends, plus one fixed pseudo-random interior point |
//! | 2 `[pi, 2 pi]` | 0, 0.37, 0.81 | `t = 0` is the point at `pi` shared with cell 1 |
//! | 3 `[2 pi, 3 pi]` | 0.25, 0.5, 0.75 | uniformly spaced interior points |
//! | 4 `[3 pi, 4 pi]` | 0.12, 0.46, 0.89 | fixed pseudo-random |
//!
//! (3 points per cell so that every cell has a well-posed 3-term fit; 11 distinct points.)
//!
//! * **TLS**: per cell the conservative fit of SPEC §4.1 with the 3 Taylor functions,
//!   `a_1 = (1/|e|) int_e f` (the exact cell integral plays the particle mass), `a_2, a_3`
//!   by least squares on the cell's points. The integral of the reconstruction is
//!   `sum_e a_1 |e| = int f` whatever the layout: round-off error.
//! * **Cubic spline**: the global not-a-knot spline through the 11 points (SPEC §4.2).
//!
//! Errors: `RMS = sqrt((1/L) sum_g w_g (f_hat - f)^2(x_g))` with 100 Gauss points per cell,
//! and the relative integral error `|sum_g w_g f_hat(x_g) - int f| / |int f|` with 2 Gauss
//! points per cell (exact for the quadratic TLS pieces).
//!
//! **Degenerate cell.** Cell 2 with points at `pi` and `5 pi / 3` only: at those points
//! `psi_3 = -psi_2 / 3`, so the 2x2 block of the conservative fit is singular (the raw
//! solve is refused, or with rounding gives huge coefficients). Without a virtual point
//! the fit is order-reduced (`psi_3` dropped); with the virtual point, cell 3's
//! reconstruction evaluated at the shared face `2 pi` is added as a third data point
//! (it enters the least-squares block, never `a_1`).
//!
//! Outputs: `reconstruction.csv` (`x,exact,tls,spline,tls_degenerate,tls_virtual` at the
//! 100 Gauss points of every cell) and `reconstruction.svg`.

use crate::error::{Error, Result};
use crate::mapping::quadrature::GaussPoints;
use crate::numerics::cubic_spline::CubicSpline;
use crate::numerics::gauss::GaussRule;
use crate::numerics::taylor::{add_rhs, solve, solve_reduced, FitKind, NormalMatrix, TaylorCell};
use crate::output::plot::{profile_plot, Axes, Series, Style};
use crate::output::write_atomic;
use std::f64::consts::PI;
use std::fmt::Write as _;
use std::path::Path;

/// Number of cells.
pub const CELLS: usize = 4;

/// Data positions per cell as fractions of the cell (see the module table).
pub const LAYOUT: [&[f64]; CELLS] = [
    &[0.0, 0.58, 1.0],
    &[0.0, 0.37, 0.81],
    &[0.25, 0.5, 0.75],
    &[0.12, 0.46, 0.89],
];

/// Published TLS errors (IJNME Table 1).
pub const PUBLISHED: Errors = Errors {
    rms: 4.00e-2,
    integral: 2.79e-15,
};
/// Published cubic-spline errors.
pub const PUBLISHED_SPLINE: Errors = Errors {
    rms: 6.09e-2,
    integral: 4.28e-2,
};

/// The RMS rule: 25 Gauss points on each quarter of a cell, 100 per cell.
const RMS_POINTS: usize = 25;
const RMS_PIECES: usize = 4;

/// `f(x) = sin x + 2`.
pub fn exact(x: f64) -> f64 {
    x.sin() + 2.0
}

/// `int_a^b f`.
fn exact_integral(a: f64, b: f64) -> f64 {
    a.cos() - b.cos() + 2.0 * (b - a)
}

/// RMS and relative integral error of a reconstruction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Errors {
    pub rms: f64,
    pub integral: f64,
}

/// Everything `tlsmpm reconstruct` reports.
#[derive(Clone, Debug)]
pub struct ReconstructionReport {
    /// Data points of the regular layout.
    pub points: Vec<f64>,
    pub tls: Errors,
    pub spline: Errors,
    /// Determinant of the 2x2 conservative block of the degenerate cell (relative to the
    /// product of its diagonal: 0 means singular).
    pub degenerate_relative_determinant: f64,
    /// Whether the plain 3-term solve of the degenerate cell was refused.
    pub degenerate_refused: bool,
    /// RMS in the degenerate cell `[pi, 2 pi]`: without remedy (order reduction), with the
    /// virtual point, and of the regular layout's TLS fit there.
    pub degenerate_cell_rms: f64,
    pub virtual_cell_rms: f64,
    pub regular_cell_rms: f64,
    /// Whole-domain errors of the two degenerate-case reconstructions.
    pub degenerate: Errors,
    pub virtual_point: Errors,
}

/// A piecewise-quadratic TLS reconstruction: one Taylor basis and coefficients per cell.
#[derive(Clone, Copy, Debug, Default)]
struct Tls {
    cells: [TaylorCell; CELLS],
    coefficients: [[f64; 3]; CELLS],
}

impl Tls {
    fn eval(&self, cell: usize, x: f64) -> f64 {
        self.cells[cell].eval(&self.coefficients[cell], x)
    }
}

/// The cell `[e pi, (e + 1) pi]`.
fn cell_bounds(cell: usize) -> (f64, f64) {
    (cell as f64 * PI, (cell + 1) as f64 * PI)
}

/// The normal equations of `points` in `cell`.
fn normal_equations(taylor: &TaylorCell, points: &[(f64, f64)]) -> (NormalMatrix, [f64; 3]) {
    let mut normal = NormalMatrix::default();
    let mut rhs = [0.0; 3];
    for &(x, u) in points {
        let psi = taylor.psi(x);
        normal.add(&psi);
        add_rhs(&mut rhs, &psi, u);
    }
    (normal, rhs)
}

/// Conservative 3-term fit of `points` in `cell` (order reduction if it is ill-posed).
/// Returns the coefficients and whether the 3-term solve was refused.
fn fit_cell(cell: usize, points: &[(f64, f64)]) -> ([f64; 3], bool) {
    let (lo, hi) = cell_bounds(cell);
    let taylor = TaylorCell::new(lo, hi);
    let (normal, rhs) = normal_equations(&taylor, points);
    let kind = FitKind::Conservative(exact_integral(lo, hi) / (hi - lo));
    match solve(&normal, &rhs, kind, 3) {
        Some(a) => (a, false),
        None => (solve_reduced(&normal, &rhs, kind).0, true),
    }
}

/// TLS through per-cell point sets.
fn fit_tls(points: &[Vec<(f64, f64)>; CELLS]) -> (Tls, [bool; CELLS]) {
    let mut tls = Tls::default();
    let mut refused = [false; CELLS];
    for cell in 0..CELLS {
        let (lo, hi) = cell_bounds(cell);
        tls.cells[cell] = TaylorCell::new(lo, hi);
        let (a, r) = fit_cell(cell, &points[cell]);
        tls.coefficients[cell] = a;
        refused[cell] = r;
    }
    (tls, refused)
}

/// `sqrt((1/L) int (g - f)^2)` over `cells` with the RMS points.
fn rms(rule: &GaussPoints, cells: std::ops::Range<usize>, g: &impl Fn(usize, f64) -> f64) -> f64 {
    let (mut sum, mut length) = (0.0, 0.0);
    for cell in cells {
        let (lo, hi) = cell_bounds(cell);
        length += hi - lo;
        rule.for_each(lo, hi, |x, w| sum += w * (g(cell, x) - exact(x)).powi(2));
    }
    (sum / length).sqrt()
}

/// Both error measures of `g(cell, x)` on the whole domain.
fn errors(fine: &GaussPoints, coarse: &GaussRule, g: &impl Fn(usize, f64) -> f64) -> Errors {
    let mut integral = 0.0;
    for cell in 0..CELLS {
        let (lo, hi) = cell_bounds(cell);
        integral += coarse
            .mapped(lo, hi)
            .map(|(x, w)| w * g(cell, x))
            .sum::<f64>();
    }
    let exact_total = exact_integral(0.0, CELLS as f64 * PI);
    Errors {
        rms: rms(fine, 0..CELLS, g),
        integral: (integral - exact_total).abs() / exact_total.abs(),
    }
}

/// Run the benchmark; with `out_dir`, write `reconstruction.csv` and `reconstruction.svg`.
pub fn reconstruct(out_dir: Option<&Path>) -> Result<ReconstructionReport> {
    let fine = GaussPoints {
        rule: GaussRule::new(RMS_POINTS)
            .ok_or_else(|| Error::invalid("gauss rule", RMS_POINTS, "unavailable"))?,
        pieces: RMS_PIECES,
    };
    let coarse = GaussRule::new(2).ok_or_else(|| Error::invalid("gauss rule", 2, "unavailable"))?;

    // Regular layout: per-cell point sets (pi shared by cells 1 and 2) and the distinct
    // points for the spline.
    let cell_points: [Vec<(f64, f64)>; CELLS] = std::array::from_fn(|cell| {
        LAYOUT[cell]
            .iter()
            .map(|t| {
                let x = (cell as f64 + t) * PI;
                (x, exact(x))
            })
            .collect()
    });
    let mut points: Vec<f64> = cell_points.iter().flatten().map(|p| p.0).collect();
    points.sort_by(f64::total_cmp);
    points.dedup();
    let values: Vec<f64> = points.iter().map(|&x| exact(x)).collect();
    let mut spline = CubicSpline::new();
    spline.fit(&points, &values);

    let (tls, _) = fit_tls(&cell_points);
    let tls_eval = |cell: usize, x: f64| tls.eval(cell, x);
    let spline_eval = |_: usize, x: f64| spline.eval(x);

    // Degenerate case: cell 2 holds pi and 5 pi / 3 only.
    let degenerate_points = [(PI, exact(PI)), (5.0 * PI / 3.0, exact(5.0 * PI / 3.0))];
    let mut degenerate_sets = cell_points.clone();
    degenerate_sets[1] = degenerate_points.to_vec();
    let (degenerate, refused) = fit_tls(&degenerate_sets);
    let taylor = TaylorCell::new(PI, 2.0 * PI);
    let (normal, _) = normal_equations(&taylor, &degenerate_points);
    let d = normal.d;
    let relative_determinant = (d[1][1] * d[2][2] - d[1][2] * d[1][2]) / (d[1][1] * d[2][2]);
    // Virtual point at the face 2 pi, from cell 3's reconstruction.
    let mut virtual_sets = degenerate_sets.clone();
    let face = 2.0 * PI;
    virtual_sets[1].push((face, degenerate.eval(2, face)));
    let (virtual_point, _) = fit_tls(&virtual_sets);
    let degenerate_eval = |cell: usize, x: f64| degenerate.eval(cell, x);
    let virtual_eval = |cell: usize, x: f64| virtual_point.eval(cell, x);

    let report = ReconstructionReport {
        tls: errors(&fine, &coarse, &tls_eval),
        spline: errors(&fine, &coarse, &spline_eval),
        degenerate_relative_determinant: relative_determinant,
        degenerate_refused: refused[1],
        degenerate_cell_rms: rms(&fine, 1..2, &degenerate_eval),
        virtual_cell_rms: rms(&fine, 1..2, &virtual_eval),
        regular_cell_rms: rms(&fine, 1..2, &tls_eval),
        degenerate: errors(&fine, &coarse, &degenerate_eval),
        virtual_point: errors(&fine, &coarse, &virtual_eval),
        points,
    };

    if let Some(dir) = out_dir {
        std::fs::create_dir_all(dir).map_err(|e| Error::write(dir, e))?;
        let mut x = Vec::with_capacity(CELLS * RMS_POINTS * RMS_PIECES);
        let mut columns: [Vec<f64>; 5] = Default::default();
        for cell in 0..CELLS {
            let (lo, hi) = cell_bounds(cell);
            fine.for_each(lo, hi, |xg, _| {
                x.push(xg);
                let row = [
                    exact(xg),
                    tls_eval(cell, xg),
                    spline_eval(cell, xg),
                    degenerate_eval(cell, xg),
                    virtual_eval(cell, xg),
                ];
                for (column, value) in columns.iter_mut().zip(row) {
                    column.push(value);
                }
            });
        }
        let mut csv = String::from("x,exact,tls,spline,tls_degenerate,tls_virtual\n");
        for (k, xk) in x.iter().enumerate() {
            let _ = write!(csv, "{xk:e}");
            for column in &columns {
                let _ = write!(csv, ",{:e}", column[k]);
            }
            csv.push('\n');
        }
        write_atomic(&dir.join("reconstruction.csv"), csv.as_bytes())?;
        let data_y: Vec<f64> = report.points.iter().map(|&x| exact(x)).collect();
        let [exact_y, tls_y, spline_y, degenerate_y, virtual_y] = &columns;
        profile_plot(
            &dir.join("reconstruction.svg"),
            &Axes {
                title: "Reconstruction of sin x + 2 on 4 cells",
                x_label: "x",
                y_label: "f(x)",
            },
            &[
                Series {
                    label: "exact",
                    x: (&x).into(),
                    y: exact_y.into(),
                    style: Style::Reference,
                },
                Series {
                    label: "TLS",
                    x: (&x).into(),
                    y: tls_y.into(),
                    style: Style::Line,
                },
                Series {
                    label: "cubic spline",
                    x: (&x).into(),
                    y: spline_y.into(),
                    style: Style::Line,
                },
                Series {
                    label: "TLS, cell 2 order-reduced",
                    x: (&x).into(),
                    y: degenerate_y.into(),
                    style: Style::Line,
                },
                Series {
                    label: "TLS, cell 2 + virtual point",
                    x: (&x).into(),
                    y: virtual_y.into(),
                    style: Style::Line,
                },
                Series {
                    label: "data points",
                    x: (&report.points).into(),
                    y: (&data_y).into(),
                    style: Style::Points,
                },
            ],
        )?;
    }
    Ok(report)
}

/// The report as a small text table.
pub fn format_table(report: &ReconstructionReport) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "f(x) = sin x + 2 on [0, 4 pi], 4 cells, {} data points",
        report.points.len()
    );
    let _ = writeln!(out, "{:<34} {:>12} {:>16}", "", "RMS", "integral error");
    for (name, e) in [
        ("TLS (conservative, 3 terms)", report.tls),
        ("cubic spline (not-a-knot)", report.spline),
        ("published TLS", PUBLISHED),
        ("published cubic spline", PUBLISHED_SPLINE),
    ] {
        let _ = writeln!(out, "{name:<34} {:>12.3e} {:>16.3e}", e.rms, e.integral);
    }
    let _ = writeln!(
        out,
        "\ndegenerate cell [pi, 2 pi] with points pi, 5 pi/3: 2x2 block det/(d22 d33) = {:.1e}, \
         3-term fit {}",
        report.degenerate_relative_determinant,
        if report.degenerate_refused {
            "refused (singular)"
        } else {
            "accepted"
        }
    );
    let _ = writeln!(
        out,
        "{:<34} {:>12} {:>16} {:>12}",
        "", "cell RMS", "integral error", "RMS"
    );
    for (name, cell, e) in [
        (
            "no remedy (order reduction)",
            report.degenerate_cell_rms,
            report.degenerate,
        ),
        (
            "virtual point at 2 pi (cell 3)",
            report.virtual_cell_rms,
            report.virtual_point,
        ),
    ] {
        let _ = writeln!(
            out,
            "{name:<34} {cell:>12.3e} {:>16.3e} {:>12.3e}",
            e.integral, e.rms
        );
    }
    let _ = writeln!(
        out,
        "{:<34} {:>12.3e}",
        "regular layout (3 points)", report.regular_cell_rms
    );
    out
}
