//! The column compaction of Wobbes et al. 2019 (IJNME): the errors of its Fig. 10, Table 7
//! (conservation) and Table 8 (DDMPM with sub-points).

use super::BSMPM_TLS_CONSISTENT;
use super::{doc, number, run};
use crate::app::reproduce::case::{Better, Case, Measure, Plot, Rule, RunValue};
use crate::problems::Field;

/// What explains the plain (no reconstruction) column errors.
fn plain_reason(method: &str) -> &'static str {
    match method {
        "DDMPM" => {
            "without a reconstruction DDMPM integrates its node integrals by particle \
             quadrature (method.node_integrals = \"particles\"), which keeps the error at \
             5-6e-2; exact integrals (\"domain\") give 4.6e-3"
        }
        "BSMPM" => {
            "not explained: ours is 4.02e-3 with the consistent mass (the mass of the \
             paper's BSMPM-TLS and BSMPM-spline, which match) and 3.76e-3 with the lumped \
             mass, both below the published value"
        }
        _ => "",
    }
}

pub(super) fn column_compaction() -> Case {
    let stress = RunValue::RelL2(Field::Stress);
    let plain: [(&str, &'static [&'static str], f64); 3] = [
        ("MPM", &[], 4.4677e-2),
        ("DDMPM", &["method.basis=ddmpm"], 4.4555e-2),
        (
            "BSMPM",
            &["method.basis=bspline", "method.mass=consistent"],
            4.8511e-3,
        ),
    ];
    let tls: [(&str, &'static [&'static str], f64); 3] = [
        ("MPM-TLS", &["method.reconstruction=tls"], 9.2396e-3),
        (
            "DDMPM-TLS",
            &["method.basis=ddmpm", "method.reconstruction=tls"],
            4.7796e-3,
        ),
        ("BSMPM-TLS", BSMPM_TLS_CONSISTENT, 4.1054e-3),
    ];
    let spline: [(&str, &'static [&'static str], f64); 3] = [
        (
            "MPM-spline",
            &["method.reconstruction=cubic_spline"],
            9.1614e-3,
        ),
        (
            "DDMPM-spline",
            &["method.basis=ddmpm", "method.reconstruction=cubic_spline"],
            4.7844e-3,
        ),
        (
            "BSMPM-spline",
            &[
                "method.basis=bspline",
                "method.reconstruction=cubic_spline",
                "method.mass=consistent",
            ],
            4.0812e-3,
        ),
    ];
    let domains = "the 1D TLS defaults count each particle in the cells its domain overlaps \
                   (method.cell_totals and method.fit_weights = \"domains\") and take the \
                   adjoint strain; the published step with the paper's per-centre totals \
                   (method.strain = \"gradient\", method.cell_totals = \"centres\") gives \
                   9.2586e-3 / 4.7794e-3 / 4.0137e-3 for MPM / DDMPM / BSMPM-TLS";
    let mut numbers = Vec::new();
    for (method, sets, value) in plain {
        // Plain BSMPM is below the published error for a reason not known: no `better`.
        let better = if method == "BSMPM" {
            Better::Neither
        } else {
            Better::Lower
        };
        numbers.push(number(
            format!("{method} stress rel. L2"),
            value,
            Measure::Run(run("column_compaction", sets), stress),
            Rule::Relative(0.05),
            better,
            plain_reason(method),
            doc::MPM_COLUMN,
        ));
    }
    for (method, sets, value) in tls {
        numbers.push(number(
            format!("{method} stress rel. L2"),
            value,
            Measure::Run(run("column_compaction", sets), stress),
            Rule::Relative(0.05),
            Better::Lower,
            domains,
            doc::CELL_TOTALS,
        ));
    }
    for (method, sets, value) in spline {
        numbers.push(number(
            format!("{method} stress rel. L2"),
            value,
            Measure::Run(run("column_compaction", sets), stress),
            Rule::Relative(0.05),
            Better::Lower,
            "",
            doc::COLUMN,
        ));
    }
    let crossings = number(
        "MPM grid crossings",
        180.0,
        Measure::Run(run("column_compaction", &[]), RunValue::GridCrossings),
        Rule::Relative(0.15),
        Better::Neither,
        "",
        doc::MPM_COLUMN,
    )
    .stated("~180");
    numbers.push(crossings);
    let runs = |list: &[(&str, &'static [&'static str], f64)], value| -> Vec<_> {
        list.iter()
            .map(|(_, sets, _)| (run("column_compaction", sets), value))
            .collect()
    };
    numbers.push(number(
        "TLS mass error, largest of the three",
        1.05e-12,
        Measure::MaxOf(runs(&tls, RunValue::MassError)),
        Rule::AtMost(1.05e-11),
        Better::Lower,
        "",
        doc::COLUMN,
    ));
    numbers.push(number(
        "TLS momentum error, largest of the three",
        5.6e-13,
        Measure::MaxOf(runs(&tls, RunValue::MomentumError)),
        Rule::AtMost(5.6e-12),
        Better::Lower,
        "",
        doc::COLUMN,
    ));
    numbers.push(number(
        "spline momentum error at the end, largest of the three",
        3.5e-6,
        Measure::MaxOf(runs(&spline, RunValue::FinalMomentumError)),
        Rule::Factor(3.0),
        Better::Lower,
        "the spline is not conservative: its error at the end matches, but it reaches \
         2.3e-3 during the run (the table gives no maximum)",
        doc::COLUMN,
    ));
    let exact_runs = vec![
        ("MPM", run("column_compaction", &[])),
        (
            "MPM-TLS",
            run("column_compaction", &["method.reconstruction=tls"]),
        ),
        (
            "MPM-spline",
            run("column_compaction", &["method.reconstruction=cubic_spline"]),
        ),
    ];
    Case {
        id: "column_compaction",
        source: "Wobbes et al. 2019 (IJNME), column compaction (errors of Fig. 10) and Table 7",
        title: "Column compaction, 50 cells, 20 PPC, 0.5 s: stress rel. L2 error at the end and conservation",
        numbers,
        context: vec![],
        plots: vec![Plot::Runs {
            file: "column_compaction_stress.svg",
            field: "stress",
            runs: exact_runs,
            exact: true,
        }],
    }
}

pub(super) fn column_subpoints() -> Case {
    // IJNME Table 8: sub-points, rel. L2 stress error, time relative to DDMPM-TLS.
    const TABLE: [(usize, &[&str], f64, f64); 7] = [
        (
            2,
            &["method.basis=ddmpm", "method.subpoints=2"],
            3.41e-2,
            0.30,
        ),
        (
            4,
            &["method.basis=ddmpm", "method.subpoints=4"],
            2.72e-2,
            0.42,
        ),
        (
            8,
            &["method.basis=ddmpm", "method.subpoints=8"],
            2.15e-2,
            0.68,
        ),
        (
            16,
            &["method.basis=ddmpm", "method.subpoints=16"],
            1.52e-2,
            1.28,
        ),
        (
            32,
            &["method.basis=ddmpm", "method.subpoints=32"],
            8.12e-3,
            3.36,
        ),
        (
            64,
            &["method.basis=ddmpm", "method.subpoints=64"],
            6.23e-3,
            6.37,
        ),
        (
            128,
            &["method.basis=ddmpm", "method.subpoints=128"],
            5.61e-3,
            14.4,
        ),
    ];
    // The paper's DDMPM-TLS step (the gradient strain, one point per particle): the
    // default adjoint step costs 2-3.5x more (docs/reconstruction.md), which would make
    // every ratio look like the paper's for the wrong reason.
    let ddmpm_tls = run(
        "column_compaction",
        &[
            "method.basis=ddmpm",
            "method.reconstruction=tls",
            "method.strain=gradient",
        ],
    );
    let mut numbers = Vec::new();
    for (n, sets, error, time) in TABLE {
        let spec = run("column_compaction", sets);
        // --quick stops at 32 sub-points (64 and 128 take 20 s of the 30).
        let quick = n <= 32;
        numbers.push(
            number(
                format!("{n} sub-points: stress rel. L2"),
                error,
                Measure::Run(spec, RunValue::RelL2(Field::Stress)),
                Rule::Relative(0.25),
                Better::Lower,
                "sub-points spread evenly over each particle's domain; the paper does not give \
             its placement",
                doc::SUBPOINTS,
            )
            .quick(quick),
        );
        numbers.push(
            number(
                format!("{n} sub-points: time / DDMPM-TLS time"),
                time,
                Measure::Ratio(
                    (spec, RunValue::WallSeconds),
                    (ddmpm_tls, RunValue::WallSeconds),
                ),
                Rule::Factor(2.0),
                Better::Lower,
                "our TLS mapping is relatively cheaper than the paper's (batched per-cell fits), \
             so every sub-point count costs more than DDMPM-TLS here; the reference is the \
             published TLS step (method.strain = \"gradient\"), the default adjoint step \
             costs 2-3.5x more (wall times vary by machine and load)",
                doc::SUBPOINTS,
            )
            .quick(quick),
        );
    }
    Case {
        id: "column_subpoints",
        source: "Wobbes et al. 2019 (IJNME), Table 8",
        title: "Column compaction, DDMPM with sub-points against DDMPM-TLS",
        numbers,
        context: vec![],
        plots: vec![],
    }
}
