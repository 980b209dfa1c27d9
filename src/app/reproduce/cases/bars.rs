//! The function reconstruction and the vibrating bars of Wobbes et al. 2019 (IJNME):
//! Table 1, the small bar's orders and Table 3, the large bar against ULFEM and Table 5.

use super::{doc, number, run};
use super::{three_bases, BSMPM_TLS_CONSISTENT};
use crate::app::reproduce::case::{
    Better, Case, Measure, Pair, ReconstructValue, Rule, RunSpec, RunValue, StudySpec,
};
use crate::problems::Field;

pub(super) fn function_reconstruction() -> Case {
    let layout = "the data positions are not published: ours follow the description \
                  (boundary points in cell 1, uniform in cell 3, fixed pseudo-random elsewhere)";
    let r = |q: &str, v, m, rule, reason| {
        number(
            q,
            v,
            Measure::Reconstruct(m),
            rule,
            Better::Neither,
            reason,
            doc::RECONSTRUCT,
        )
    };
    Case {
        id: "function_reconstruction",
        source: "Wobbes et al. 2019 (IJNME), Table 1",
        title: "Function reconstruction, sin x + 2 on [0, 4 pi], 4 cells, 11 points",
        numbers: vec![
            r(
                "TLS integral rel. error",
                2.79e-15,
                ReconstructValue::TlsIntegral,
                Rule::RoundOff(1e-13),
                "",
            ),
            r(
                "cubic-spline integral rel. error",
                4.28e-2,
                ReconstructValue::SplineIntegral,
                Rule::Factor(3.0),
                layout,
            ),
            r(
                "TLS RMS",
                4.00e-2,
                ReconstructValue::TlsRms,
                Rule::Factor(3.0),
                layout,
            ),
            r(
                "cubic-spline RMS",
                6.09e-2,
                ReconstructValue::SplineRms,
                Rule::Factor(3.0),
                layout,
            ),
        ],
        context: vec![],
        plots: vec![],
    }
}

pub(super) fn small_bar_orders() -> Case {
    let mpm = StudySpec {
        label: "MPM, dt = 1e-8",
        scenario: "vibrating_bar",
        sets: &["time.dt=1e-8"],
        cells: &[5, 10, 20, 40],
        quick_cells: &[5, 10, 20],
    };
    let bsmpm_tls = StudySpec {
        label: "BSMPM-TLS consistent, dt = 1e-9",
        scenario: "vibrating_bar",
        sets: &[
            "method.basis=bspline",
            "method.reconstruction=tls",
            "method.mass=consistent",
            "time.dt=1e-9",
        ],
        cells: &[5, 10, 20, 40],
        quick_cells: &[5, 10, 20],
    };
    let order = |q: &str, study: StudySpec, field, value, reason| {
        let page = if study == mpm {
            doc::MPM_SMALL_BAR
        } else {
            doc::SMALL_BAR
        };
        number(
            q,
            value,
            Measure::Order(study, field, Pair::Overall),
            Rule::Order(0.3),
            Better::Higher,
            reason,
            page,
        )
    };
    let spline_derivative = "the stress is the derivative of a quadratic spline, one order \
                             below the field (stated as a known limit of the method)";
    Case {
        id: "small_bar_orders",
        source: "Wobbes et al. 2019 (IJNME), vibrating bar, small deformation (convergence)",
        title: "Small vibrating bar: RMS orders from 5 to 40 cells, 12 PPC",
        numbers: vec![
            order("MPM u order", mpm, Field::Displacement, 2.0, ""),
            order("MPM v order", mpm, Field::Velocity, 2.0, ""),
            order("MPM sigma order", mpm, Field::Stress, 1.0, ""),
            order("BSMPM-TLS u order", bsmpm_tls, Field::Displacement, 3.0, ""),
            order("BSMPM-TLS v order", bsmpm_tls, Field::Velocity, 3.0, ""),
            order(
                "BSMPM-TLS sigma order",
                bsmpm_tls,
                Field::Stress,
                3.0,
                spline_derivative,
            ),
            number(
                "MPM u error / MPM-TLS u error, 40 cells",
                1.7,
                Measure::Ratio(
                    (
                        run("vibrating_bar", &[]),
                        RunValue::RelL2(Field::Displacement),
                    ),
                    (
                        run(
                            "vibrating_bar",
                            &["method.reconstruction=tls", "method.mass=consistent"],
                        ),
                        RunValue::RelL2(Field::Displacement),
                    ),
                ),
                Rule::Relative(0.25),
                Better::Higher,
                "TLS here maps the velocity with the consistent mass, which removes more of \
                 the mapping error (with lumped masses the ratio is 1.003)",
                doc::SMALL_BAR,
            ),
        ],
        context: vec![],
        plots: vec![],
    }
}

pub(super) fn small_bar_conservation() -> Case {
    // IJNME Table 3: (method, reconstruction, mass, momentum).
    let table = [
        ("MPM", "cubic_spline", 2.38e-12, 3.71e-6),
        ("DDMPM", "cubic_spline", 3.92e-13, 3.71e-6),
        ("BSMPM", "cubic_spline", 7.39e-15, 1.79e-6),
        ("MPM", "tls", 7.50e-15, 2.10e-16),
        ("DDMPM", "tls", 7.39e-15, 2.52e-16),
        ("BSMPM", "tls", 7.50e-15, 1.76e-16),
    ];
    let spline = "the cubic spline is not conservative: its error depends on where the \
                  particles sit in their cells, which the paper does not give (ours: \
                  sub-cell centres)";
    let mut numbers = Vec::new();
    for (method, reconstruction, mass, momentum) in table {
        let sets = three_bases(reconstruction)
            .into_iter()
            .find(|(m, _)| *m == method)
            .map_or(&[][..], |(_, sets)| sets);
        let spec = run("vibrating_bar", sets);
        let name = if reconstruction == "tls" {
            "TLS"
        } else {
            "spline"
        };
        for (what, value, measure) in [
            ("mass", mass, RunValue::MassError),
            ("momentum", momentum, RunValue::MomentumError),
        ] {
            let (rule, reason) = if reconstruction == "tls" {
                (Rule::RoundOff(1e-13), "")
            } else {
                (Rule::Factor(10.0), spline)
            };
            numbers.push(number(
                format!("{method}-{name} {what} error"),
                value,
                Measure::Run(spec, measure),
                rule,
                Better::Lower,
                reason,
                doc::SMALL_BAR,
            ));
        }
    }
    Case {
        id: "small_bar_conservation",
        source: "Wobbes et al. 2019 (IJNME), Table 3",
        title: "Small vibrating bar, 40 cells, 12 PPC: largest relative mass and momentum error of the mapping",
        numbers,
        context: vec![],
        plots: vec![],
    }
}

pub(super) fn large_bar() -> Case {
    let mpm = run("vibrating_bar_large", &[]);
    let stress = RunValue::RelL2(Field::Stress);
    let factor = |q: &str, value, sets: &'static [&'static str], reason: &'static str| {
        // A known reason only for TLS (the cell totals); the spline's gain is measured,
        // not explained.
        let better = if q.ends_with("TLS") {
            Better::Higher
        } else {
            Better::Neither
        };
        number(
            q,
            value,
            Measure::Ratio((mpm, stress), (run("vibrating_bar_large", sets), stress)),
            Rule::Relative(0.25),
            better,
            reason,
            doc::LARGE_BAR,
        )
    };
    let domains = "the 1D TLS defaults count each particle in the cells its domain overlaps \
                   (method.cell_totals and method.fit_weights = \"domains\"), so cell masses \
                   and fits do not jump when particles cross faces, and take the adjoint \
                   strain; the published step with the paper's per-centre totals \
                   (method.strain = \"gradient\", method.cell_totals = \"centres\") gives \
                   10.5 (BSMPM) and 11.2 (DDMPM)";
    let spline = "not explained: the gain comes with the consistent mass (BSMPM-spline with \
                  a lumped mass reduces the MPM error only 2.6x), and the paper does not say \
                  which mass its spline variants used";
    let tls_runs: Vec<(RunSpec, RunValue)> = three_bases("tls")
        .into_iter()
        .map(|(_, sets)| (run("vibrating_bar_large", sets), RunValue::MassError))
        .collect();
    let momentum = |list: &[(RunSpec, RunValue)]| -> Vec<(RunSpec, RunValue)> {
        list.iter()
            .map(|(spec, _)| (*spec, RunValue::MomentumError))
            .collect()
    };
    let spline_runs: Vec<(RunSpec, RunValue)> = three_bases("cubic_spline")
        .into_iter()
        .map(|(_, sets)| (run("vibrating_bar_large", sets), RunValue::MomentumError))
        .collect();
    Case {
        id: "large_bar",
        source: "Wobbes et al. 2019 (IJNME), vibrating bar, large deformation (text) and Table 5",
        title: "Large vibrating bar, 20 cells, 8 PPC, against ULFEM (120 DOFs): factor by which the stress rel. L2 error of MPM is reduced",
        numbers: vec![
            factor("BSMPM-TLS", 9.9, BSMPM_TLS_CONSISTENT, domains),
            factor(
                "BSMPM-spline",
                13.5,
                &[
                    "method.basis=bspline",
                    "method.reconstruction=cubic_spline",
                    "method.mass=consistent",
                ],
                spline,
            ),
            factor(
                "DDMPM-TLS",
                7.8,
                &[
                    "method.basis=ddmpm",
                    "method.reconstruction=tls",
                    "method.mass=consistent",
                ],
                domains,
            ),
            factor(
                "DDMPM-spline",
                8.9,
                &[
                    "method.basis=ddmpm",
                    "method.reconstruction=cubic_spline",
                    "method.mass=consistent",
                ],
                spline,
            ),
            number(
                    "MPM grid crossings",
                    100.0,
                    Measure::Run(mpm, RunValue::GridCrossings),
                    Rule::AtLeast(100.0),
                    Better::Neither,
                    "",
                    doc::MPM_LARGE_BAR,
                )
                .stated("> 100"),
            number(
                "TLS mass error, largest of MPM / DDMPM / BSMPM",
                2.9e-14,
                Measure::MaxOf(tls_runs.clone()),
                Rule::RoundOff(1e-13),
                Better::Lower,
                "",
                doc::LARGE_BAR,
            ),
            number(
                "TLS momentum error, largest of MPM / DDMPM / BSMPM",
                5.8e-15,
                Measure::MaxOf(momentum(&tls_runs)),
                Rule::RoundOff(1e-13),
                Better::Lower,
                "",
                doc::LARGE_BAR,
            ),
            number(
                "spline momentum error, largest of MPM / DDMPM / BSMPM",
                8.2e-5,
                Measure::MaxOf(spline_runs),
                Rule::Factor(10.0),
                Better::Lower,
                "the cubic spline is not conservative; its error depends on the particle \
                 layout, which the paper does not give",
                doc::LARGE_BAR,
            ),
        ],
        context: vec![],
        plots: vec![],
    }
}
