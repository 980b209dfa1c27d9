//! The table of reproduction cases: every published table or figure of the sources, the
//! runs behind each number, the published value, the tolerance and what explains a
//! difference. The one place where a published number lives next to the way we compute
//! ours (the solver tables come from [`crate::app::solver_study::published`], the
//! reconstruction numbers from [`crate::app::reconstruct`]).
//!
//! Sources: Wobbes et al. 2019, *Conservative Taylor least squares reconstruction with
//! application to material point methods*, IJNME (TLS, bars, column); Tran et al. 2019,
//! IMLS MPM (manufactured-solution bar); the two-phase TLS consolidation study and the
//! p-multigrid mass-matrix study (restated in `docs/`); Wallstedt & Guilkey 2008, J. Comput.
//! Phys. 227 (axis-aligned manufactured solution).

use super::case::{
    Better, Case, Measure, Pair, Plot, Published, ReconstructValue, Rule, RunSpec, RunValue,
    SolverTable, StudySpec,
};
use crate::app::solver_study::published;
use crate::problems::Field;

/// `docs/` pages that explain the numbers (relative to the repository).
mod doc {
    pub const RECONSTRUCT: &str =
        "docs/reconstruction.md#function-reconstruction-tlsmpm-reconstruct";
    pub const MPM_SMALL_BAR: &str = "docs/mpm.md#small-vibrating-bar";
    pub const SMALL_BAR: &str = "docs/reconstruction.md#small-vibrating-bar";
    pub const LARGE_BAR: &str = "docs/reconstruction.md#large-vibrating-bar";
    pub const MPM_LARGE_BAR: &str = "docs/mpm.md#large-vibrating-bar";
    pub const CELL_TOTALS: &str = "docs/reconstruction.md#cell-totals";
    pub const MPM_COLUMN: &str = "docs/mpm.md#column-compaction";
    pub const COLUMN: &str = "docs/reconstruction.md#column-compaction";
    pub const SUBPOINTS: &str = "docs/reconstruction.md#ddmpm-with-sub-points";
    pub const MMS_BAR: &str = "docs/mls.md#observed-orders-on-the-mms-bar";
    pub const CONSOLIDATION: &str = "docs/consolidation.md#published-comparison";
    pub const PORE_PRESSURE: &str = "docs/consolidation.md#pore-pressure-order";
    pub const CONSOLIDATION_LARGE: &str =
        "docs/consolidation.md#large-deformation-permeability-and-settlement";
    pub const CONDITION: &str = "docs/solvers.md#condition-numbers";
    pub const CG: &str = "docs/solvers.md#cg-iterations";
    pub const PMG: &str = "docs/solvers.md#p-multigrid-cycles";
    pub const DIMENSIONS: &str =
        "docs/dimensions.md#convergence-on-the-axis-aligned-manufactured-solution";
}

const fn run(scenario: &'static str, sets: &'static [&'static str]) -> RunSpec {
    RunSpec { scenario, sets }
}

#[allow(clippy::too_many_arguments)]
fn number(
    quantity: impl Into<String>,
    value: f64,
    measure: Measure,
    rule: Rule,
    better: Better,
    reason: &'static str,
    doc: &'static str,
) -> Published {
    Published {
        quantity: quantity.into(),
        value,
        stated: "",
        measure,
        rule,
        better,
        quick: true,
        reason,
        doc,
    }
}

/// Every case, in the order of the report.
pub fn cases() -> Vec<Case> {
    vec![
        function_reconstruction(),
        small_bar_orders(),
        small_bar_conservation(),
        large_bar(),
        column_compaction(),
        column_subpoints(),
        mms_bar(),
        consolidation(),
        consolidation_large(),
        solver_tables(),
        axis_aligned_mms(),
    ]
}

fn function_reconstruction() -> Case {
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

const BSMPM_TLS_CONSISTENT: &[&str] = &[
    "method.basis=bspline",
    "method.reconstruction=tls",
    "method.mass=consistent",
];

fn small_bar_orders() -> Case {
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

/// The three bases of the IJNME tables with one reconstruction (BSMPM with the consistent
/// mass, as the paper's BSMPM-TLS).
fn three_bases(reconstruction: &'static str) -> [(&'static str, &'static [&'static str]); 3] {
    match reconstruction {
        "tls" => [
            ("MPM", &["method.reconstruction=tls"]),
            (
                "DDMPM",
                &["method.basis=ddmpm", "method.reconstruction=tls"],
            ),
            ("BSMPM", BSMPM_TLS_CONSISTENT),
        ],
        _ => [
            ("MPM", &["method.reconstruction=cubic_spline"]),
            (
                "DDMPM",
                &["method.basis=ddmpm", "method.reconstruction=cubic_spline"],
            ),
            (
                "BSMPM",
                &[
                    "method.basis=bspline",
                    "method.reconstruction=cubic_spline",
                    "method.mass=consistent",
                ],
            ),
        ],
    }
}

fn small_bar_conservation() -> Case {
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

fn large_bar() -> Case {
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
    let domains = "the fitted cell totals count each particle in the cells its domain \
                   overlaps (method.cell_totals = \"domains\"), so cell masses do not jump when \
                   particles cross faces; the paper's per-centre totals give 10.5 (BSMPM) and \
                   11.2 (DDMPM)";
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
            {
                let mut crossings = number(
                    "MPM grid crossings",
                    100.0,
                    Measure::Run(mpm, RunValue::GridCrossings),
                    Rule::AtLeast(100.0),
                    Better::Neither,
                    "",
                    doc::MPM_LARGE_BAR,
                );
                crossings.stated = "> 100";
                crossings
            },
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

fn column_compaction() -> Case {
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
    let domains = "the fitted cell totals count each particle in the cells its domain \
                   overlaps (method.cell_totals = \"domains\", default); the paper's per-centre \
                   totals (\"centres\") give 9.2586e-3 / 4.7794e-3 / 4.0137e-3 for MPM / DDMPM / \
                   BSMPM-TLS";
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
    let mut crossings = number(
        "MPM grid crossings",
        180.0,
        Measure::Run(run("column_compaction", &[]), RunValue::GridCrossings),
        Rule::Relative(0.15),
        Better::Neither,
        "",
        doc::MPM_COLUMN,
    );
    crossings.stated = "~180";
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

fn column_subpoints() -> Case {
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
    let ddmpm_tls = run(
        "column_compaction",
        &["method.basis=ddmpm", "method.reconstruction=tls"],
    );
    let mut numbers = Vec::new();
    for (n, sets, error, time) in TABLE {
        let spec = run("column_compaction", sets);
        // --quick stops at 32 sub-points (64 and 128 take 20 s of the 30).
        let first = numbers.len();
        numbers.push(number(
            format!("{n} sub-points: stress rel. L2"),
            error,
            Measure::Run(spec, RunValue::RelL2(Field::Stress)),
            Rule::Relative(0.25),
            Better::Lower,
            "sub-points spread evenly over each particle's domain; the paper does not give \
             its placement",
            doc::SUBPOINTS,
        ));
        numbers.push(number(
            format!("{n} sub-points: time / DDMPM-TLS time"),
            time,
            Measure::Ratio(
                (spec, RunValue::WallSeconds),
                (ddmpm_tls, RunValue::WallSeconds),
            ),
            Rule::Factor(2.0),
            Better::Lower,
            "our TLS mapping is relatively cheaper than the paper's (batched per-cell fits), \
             so every sub-point count costs more than DDMPM-TLS here (wall times vary by \
             machine and load)",
            doc::SUBPOINTS,
        ));
        for number in &mut numbers[first..] {
            number.quick = n <= 32;
        }
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

/// The MMS-bar methods of the comparison (label, overrides); the first three are the
/// published ones.
const MMS_METHODS: [(&str, &[&str]); 13] = [
    ("MPM", &["method.reconstruction=none"]),
    ("CPDI", &["method.basis=cpdi", "method.reconstruction=none"]),
    ("IMLS", &["method.reconstruction=imls"]),
    ("MLS", &["method.reconstruction=mls"]),
    (
        "IMLS-CONSISTENT",
        &["method.reconstruction=imls", "method.mass=consistent"],
    ),
    (
        "IMLS-GRADIENT",
        &["method.reconstruction=imls", "method.strain=gradient"],
    ),
    (
        "IMLS-GRADIENT-USL",
        &[
            "method.reconstruction=imls",
            "method.strain=gradient",
            "method.scheme=usl",
        ],
    ),
    (
        "IMLS-CPDI",
        &["method.reconstruction=imls", "method.basis=cpdi"],
    ),
    (
        "IMLS-BSPLINE",
        &[
            "method.reconstruction=imls",
            "method.basis=bspline",
            "method.order=2",
        ],
    ),
    ("MPM-TLS", &["method.reconstruction=tls"]),
    (
        "MPM-TLS-USL",
        &["method.reconstruction=tls", "method.scheme=usl"],
    ),
    (
        "BSMPM-TLS",
        &[
            "method.basis=bspline",
            "method.order=2",
            "method.reconstruction=tls",
        ],
    ),
    (
        "BSMPM-TLS-USL",
        &[
            "method.basis=bspline",
            "method.order=2",
            "method.reconstruction=tls",
            "method.scheme=usl",
        ],
    ),
];

fn mms_study(k: usize) -> StudySpec {
    let (label, sets) = MMS_METHODS[k];
    StudySpec {
        label,
        scenario: "mms_bar",
        sets,
        cells: &[8, 16, 32, 64, 128],
        quick_cells: &[8, 16, 32],
    }
}

fn mms_bar() -> Case {
    let (mpm, cpdi, imls) = (mms_study(0), mms_study(1), mms_study(2));
    let mut numbers = Vec::new();
    for field in [Field::Displacement, Field::Stress] {
        let mut n = number(
            format!("MPM {} order, coarsest to finest", field.name()),
            0.0,
            Measure::Order(mpm, field, Pair::Overall),
            Rule::AtMost(0.5),
            Better::Neither,
            "",
            doc::MMS_BAR,
        );
        n.stated = "does not converge";
        numbers.push(n);
    }
    for field in [Field::Displacement, Field::Velocity, Field::Stress] {
        let mut n = number(
            format!("CPDI {} order, two coarsest grids", field.name()),
            2.0,
            Measure::Order(cpdi, field, Pair::Coarsest),
            Rule::AtLeast(1.7),
            Better::Neither,
            "",
            doc::MMS_BAR,
        );
        n.stated = "2 on coarse grids";
        numbers.push(n);
    }
    for field in [Field::Displacement, Field::Velocity, Field::Stress] {
        let mut n = number(
            format!("MPM-IMLS {} order, coarsest to finest", field.name()),
            2.0,
            Measure::Order(imls, field, Pair::Overall),
            Rule::AtLeast(1.7),
            Better::Neither,
            "",
            doc::MMS_BAR,
        );
        n.stated = "2";
        numbers.push(n);
    }
    Case {
        id: "mms_bar",
        source: "Tran et al. 2019 (IMLS MPM), Figs. 4-6",
        title: "Manufactured-solution bar, neo-Hookean, A = 0.1 m, 3 PPC, 8 to 128 cells: RMS orders (and 10 further methods for comparison)",
        numbers,
        context: (3..MMS_METHODS.len()).map(mms_study).collect(),
        plots: ["displacement", "velocity", "stress"]
            .into_iter()
            .map(|field| Plot::Studies {
                file: match field {
                    "displacement" => "mms_bar_rms_displacement.svg",
                    "velocity" => "mms_bar_rms_velocity.svg",
                    _ => "mms_bar_rms_stress.svg",
                },
                field,
            })
            .collect(),
    }
}

fn consolidation() -> Case {
    let mpm = StudySpec {
        label: "MPM",
        scenario: "consolidation",
        sets: &[],
        cells: &[20, 40, 80, 160],
        quick_cells: &[20, 40, 80],
    };
    let bsmpm_tls = StudySpec {
        label: "BSMPM-TLS consistent",
        scenario: "consolidation",
        sets: BSMPM_TLS_CONSISTENT,
        cells: &[20, 40, 80, 160],
        quick_cells: &[20, 40, 80],
    };
    let gradient = "the pore pressure (and with it sigma') is updated from gradients of the \
                    grid velocities, so its order is one below the velocity's: 1 for linear \
                    hats at off-centre particles";
    let spline_gradient = "the pore pressure and sigma' come from gradients of quadratic \
                           splines: order 2, one below the fields";
    let mut numbers = Vec::new();
    for (field, name) in [
        (Field::Displacement, "u_s"),
        (Field::Velocity, "v_s"),
        (Field::LiquidVelocity, "v_w"),
        (Field::PorePressure, "p"),
        (Field::EffectiveStress, "sigma'"),
    ] {
        let reason = match field {
            Field::PorePressure | Field::EffectiveStress => gradient,
            _ => "",
        };
        numbers.push(number(
            format!("MPM {name} order"),
            2.0,
            Measure::Order(mpm, field, Pair::Overall),
            Rule::Order(0.3),
            Better::Higher,
            reason,
            doc::PORE_PRESSURE,
        ));
    }
    for (field, name) in [
        (Field::Displacement, "u_s"),
        (Field::EffectiveStress, "sigma'"),
        (Field::PorePressure, "p"),
    ] {
        let reason = if field == Field::Displacement {
            "the displacement error reaches the round-off floor (1e-19 m) from 40 cells: no \
             order can be measured past it"
        } else {
            spline_gradient
        };
        numbers.push(number(
            format!("BSMPM-TLS {name} order"),
            3.0,
            Measure::Order(bsmpm_tls, field, Pair::Overall),
            Rule::Order(0.3),
            Better::Higher,
            reason,
            doc::PORE_PRESSURE,
        ));
    }
    let tls = run(
        "consolidation",
        &[
            "method.basis=bspline",
            "method.reconstruction=tls",
            "method.mass=consistent",
            "grid.cells=40",
        ],
    );
    let spline = run(
        "consolidation",
        &["method.reconstruction=cubic_spline", "grid.cells=40"],
    );
    let mut tls_conservation = number(
        "BSMPM-TLS, 40 cells: largest mass / momentum error of both phases",
        1e-13,
        Measure::MaxOf(vec![
            (tls, RunValue::MassError),
            (tls, RunValue::MomentumError),
            (tls, RunValue::LiquidMassError),
            (tls, RunValue::LiquidMomentumError),
        ]),
        Rule::RoundOff(1e-13),
        Better::Lower,
        "",
        doc::CONSOLIDATION,
    );
    tls_conservation.stated = "round-off";
    let mut spline_conservation = number(
        "MPM-spline, 40 cells: largest momentum error of both phases",
        2e-6,
        Measure::MaxOf(vec![
            (spline, RunValue::MomentumError),
            (spline, RunValue::LiquidMomentumError),
        ]),
        Rule::AtMost(2e-6),
        Better::Lower,
        "",
        doc::CONSOLIDATION,
    );
    spline_conservation.stated = "1e-9 .. 2e-6";
    numbers.push(tls_conservation);
    numbers.push(spline_conservation);
    Case {
        id: "consolidation",
        source: "two-phase TLS consolidation study, small deformation (Terzaghi)",
        title: "Consolidation, small deformation: 2e-9 s from the Terzaghi state at 5 s, 4 PPC, 20 to 160 cells",
        numbers,
        context: vec![],
        plots: vec![],
    }
}

fn consolidation_large() -> Case {
    let tls = run("consolidation_large", &[]);
    let spline = run(
        "consolidation_large",
        &["method.reconstruction=cubic_spline"],
    );
    let mpm = run(
        "consolidation_large",
        &["method.basis=linear", "method.reconstruction=none"],
    );
    let all_errors = |spec: RunSpec| {
        vec![
            (spec, RunValue::MassError),
            (spec, RunValue::MomentumError),
            (spec, RunValue::LiquidMassError),
            (spec, RunValue::LiquidMomentumError),
        ]
    };
    Case {
        id: "consolidation_large",
        source: "two-phase TLS consolidation study, large deformation (Hill skeleton)",
        title: "Consolidation, large deformation: 120 cells, 16 PPC, 0.4 s, BSMPM-TLS with lumped mass, permeability k = 3e-4 m/s (not restated by the paper: chosen to give its settlement; k = 1e-5 settles only 9.5e-3 m)",
        numbers: vec![
            number(
                "top settlement at 0.4 s, m",
                5.4e-2,
                Measure::Run(tls, RunValue::TopSettlement),
                Rule::Relative(0.03),
                Better::Neither,
                "the paper does not restate the permeability of this case: k = 3e-4 m/s \
                 gives its settlement (k = 1e-5 settles only 9.5e-3 m)",
                doc::CONSOLIDATION_LARGE,
            ),
            number(
                "BSMPM-TLS: largest mass / momentum error of both phases",
                4e-12,
                Measure::MaxOf(all_errors(tls)),
                Rule::AtMost(4e-12),
                Better::Lower,
                "",
                doc::CONSOLIDATION_LARGE,
            ),
            number(
                "BSMPM-spline: largest mass / momentum error of both phases",
                1.4e-4,
                Measure::MaxOf(all_errors(spline)),
                Rule::Factor(10.0),
                Better::Lower,
                "the spline is not conservative and nothing bounds its error; at the loaded \
                 top the fitted values overshoot as particles cross faces (the permeability \
                 of this case differs from the paper's, see the settlement)",
                doc::CONSOLIDATION_LARGE,
            ),
        ],
        context: vec![],
        plots: vec![Plot::Runs {
            file: "consolidation_large_pore_pressure.svg",
            field: "pore_pressure",
            runs: vec![("MPM", mpm), ("BSMPM-spline", spline), ("BSMPM-TLS", tls)],
            exact: false,
        }],
    }
}

fn solver_tables() -> Case {
    let mut numbers = Vec::new();
    let quick_cells = |cells: usize, cg: bool| if cg { cells <= 32 } else { cells <= 16 };
    for &(p, cells, kappa) in &published::CONDITION_NUMBERS {
        let mut n = number(
            format!("condition number, p = {p}, 1/h = {cells}"),
            kappa,
            Measure::Solver(SolverTable::ConditionNumber, p, cells),
            Rule::Digits(3),
            Better::Neither,
            "ours is exact (Lanczos on M and on M^-1, checked against a dense eigensolver to \
             1e-14); no variant (p Gauss points, boundary DOFs kept) gives the published \
             value, which is off by less than 1%",
            doc::CONDITION,
        );
        n.quick = quick_cells(cells, false);
        numbers.push(n);
    }
    for &(p, cells, iterations) in &published::CG_ITERATIONS {
        let mut n = number(
            format!("CG iterations, p = {p}, 1/h = {cells}"),
            iterations as f64,
            Measure::Solver(SolverTable::CgIterations, p, cells),
            Rule::Factor(1.3),
            Better::Neither,
            "plain CG from a zero guess; the source does not give its CG details (Jacobi-PCG \
             lands within 15% for p <= 4 and at 2x for p = 5); size and trend (growing \
             with p, flat in h) are the published ones",
            doc::CG,
        );
        n.quick = quick_cells(cells, true);
        numbers.push(n);
    }
    for &(p, cells, cycles) in &published::VCYCLES {
        let reason = if p >= 4 {
            "for a mass matrix the slow modes are high-frequency ones that the order-1 level \
             cannot represent, so smoothing does the work: no Jacobi / Gauss-Seidel smoother \
             reaches the published p >= 4 counts (pmg_cg, CG + one V-cycle, does)"
        } else {
            "symmetric Gauss-Seidel smoothing (the best of Jacobi, GS and symmetric GS)"
        };
        let mut n = number(
            format!("p-multigrid V(8,8) cycles, p = {p}, 1/h = {cells}"),
            cycles as f64,
            Measure::Solver(SolverTable::VCycles, p, cells),
            Rule::Factor(1.35),
            Better::Lower,
            reason,
            doc::PMG,
        );
        n.quick = quick_cells(cells, false);
        numbers.push(n);
    }
    Case {
        id: "solver_tables",
        source: "p-multigrid consistent-mass study: condition numbers, CG and V-cycle counts",
        title: "B-spline mass matrices on the unit square (boundary DOFs eliminated, unit density), solves to 1e-8",
        numbers,
        context: vec![],
        plots: vec![],
    }
}

fn axis_aligned_mms() -> Case {
    let study = |label, sets| StudySpec {
        label,
        scenario: "axis_aligned_mms",
        sets,
        cells: &[8, 16, 32, 64],
        quick_cells: &[8, 16, 32],
    };
    let linear = study("MPM (linear)", &["method.basis=linear"]);
    let gimp = study("GIMP", &["method.basis=gimp"]);
    let bspline = study("BSMPM p = 2", &[]);
    let mut stall = number(
        "MPM (linear) displacement order, two finest grids",
        0.0,
        Measure::Order(linear, Field::Displacement, Pair::Finest),
        Rule::AtMost(1.0),
        Better::Neither,
        "",
        doc::DIMENSIONS,
    );
    stall.stated = "stalls or diverges";
    let mut numbers = vec![stall];
    for (name, spec) in [("GIMP", gimp), ("BSMPM p = 2", bspline)] {
        let mut n = number(
            format!("{name} displacement order, coarsest to finest"),
            2.0,
            Measure::Order(spec, Field::Displacement, Pair::Overall),
            Rule::AtLeast(1.7),
            Better::Neither,
            "",
            doc::DIMENSIONS,
        );
        n.stated = "about 2";
        numbers.push(n);
    }
    Case {
        id: "axis_aligned_mms",
        source:
            "Wallstedt & Guilkey 2008 (J. Comput. Phys. 227), axis-aligned manufactured solution",
        title: "Axis-aligned manufactured solution, 2D plane strain, 4 PPC, 8 to 64 cells",
        numbers,
        context: vec![],
        plots: vec![Plot::Studies {
            file: "axis_aligned_mms_rms_displacement.svg",
            field: "displacement",
        }],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashSet;

    #[test]
    fn ids_are_unique_and_every_case_has_published_numbers() {
        let all = cases();
        let ids: HashSet<&str> = all.iter().map(|c| c.id).collect();
        assert_eq!(ids.len(), all.len());
        for case in &all {
            assert!(!case.numbers.is_empty(), "{}", case.id);
            assert!(
                case.numbers.iter().any(|n| n.quick),
                "{}: nothing quick",
                case.id
            );
        }
        // Every solver-table entry is compared.
        let solver = all.iter().find(|c| c.id == "solver_tables").unwrap();
        assert_eq!(solver.numbers.len(), 60);
    }

    #[test]
    fn every_override_is_a_valid_scenario() {
        use crate::app::reproduce::measure::dir_name;
        let mut specs: Vec<RunSpec> = Vec::new();
        for case in cases() {
            for n in &case.numbers {
                match &n.measure {
                    Measure::Run(s, _) => specs.push(*s),
                    Measure::Ratio((a, _), (b, _)) => specs.extend([*a, *b]),
                    Measure::MaxOf(list) => specs.extend(list.iter().map(|(s, _)| *s)),
                    Measure::Order(s, ..) => specs.push(RunSpec {
                        scenario: s.scenario,
                        sets: s.sets,
                    }),
                    _ => {}
                }
            }
        }
        for spec in specs {
            let b = crate::app::builtin::find(spec.scenario).unwrap();
            let sets: Vec<String> = spec.sets.iter().map(|s| s.to_string()).collect();
            let s = crate::config::from_str(b.toml, b.name, &sets)
                .unwrap_or_else(|e| panic!("{}: {e}", dir_name(&spec)));
            s.validate()
                .unwrap_or_else(|e| panic!("{}: {e}", dir_name(&spec)));
        }
    }
}
