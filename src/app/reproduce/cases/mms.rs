//! The manufactured solutions: the neo-Hookean bar of Tran et al. 2019 (IMLS MPM, with the
//! further methods of the comparison) and the axis-aligned solution of Wallstedt & Guilkey
//! 2008 in 2D.

use super::{doc, number};
use crate::app::reproduce::case::{Better, Case, Measure, Pair, Plot, Rule, StudySpec};
use crate::problems::Field;

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

pub(super) fn mms_bar() -> Case {
    use Field::{Displacement, Stress, Velocity};
    // (study, label, fields, grid pair, published value, as stated, rule)
    type Claim = (
        StudySpec,
        &'static str,
        &'static [Field],
        Pair,
        f64,
        &'static str,
        Rule,
    );
    let claims: [Claim; 3] = [
        (
            mms_study(0),
            "MPM",
            &[Displacement, Stress],
            Pair::Overall,
            0.0,
            "does not converge",
            Rule::AtMost(0.5),
        ),
        (
            mms_study(1),
            "CPDI",
            &[Displacement, Velocity, Stress],
            Pair::Coarsest,
            2.0,
            "2 on coarse grids",
            Rule::AtLeast(1.7),
        ),
        (
            mms_study(2),
            "MPM-IMLS",
            &[Displacement, Velocity, Stress],
            Pair::Overall,
            2.0,
            "2",
            Rule::AtLeast(1.7),
        ),
    ];
    let mut numbers = Vec::new();
    for (study, label, fields, pair, value, stated, rule) in claims {
        let grids = match pair {
            Pair::Coarsest => "two coarsest grids",
            _ => "coarsest to finest",
        };
        for &field in fields {
            numbers.push(
                number(
                    format!("{label} {} order, {grids}", field.name()),
                    value,
                    Measure::Order(study, field, pair),
                    rule,
                    Better::Neither,
                    "",
                    doc::MMS_BAR,
                )
                .stated(stated),
            );
        }
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

pub(super) fn axis_aligned_mms() -> Case {
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
    let stall = number(
        "MPM (linear) displacement order, two finest grids",
        0.0,
        Measure::Order(linear, Field::Displacement, Pair::Finest),
        Rule::AtMost(1.0),
        Better::Neither,
        "",
        doc::DIMENSIONS,
    )
    .stated("stalls or diverges");
    let mut numbers = vec![stall];
    for (name, spec) in [("GIMP", gimp), ("BSMPM p = 2", bspline)] {
        let n = number(
            format!("{name} displacement order, coarsest to finest"),
            2.0,
            Measure::Order(spec, Field::Displacement, Pair::Overall),
            Rule::AtLeast(1.7),
            Better::Neither,
            "",
            doc::DIMENSIONS,
        )
        .stated("about 2");
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
