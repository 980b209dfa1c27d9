//! The scenarios shipped with the solver (`scenarios/*.toml`, embedded in the binary so
//! `tlsmpm run NAME` and `tlsmpm list` work from any directory).

/// A built-in scenario: name, one-line description, TOML text.
pub struct Builtin {
    pub name: &'static str,
    pub description: &'static str,
    pub toml: &'static str,
}

/// All built-in scenarios.
pub const BUILTIN: &[Builtin] = &[
    Builtin {
        name: "vibrating_bar",
        description:
            "vibrating bar, small deformation (Wobbes et al. 2019): 40 cells, 12 PPC, exact solution",
        toml: include_str!("../../scenarios/vibrating_bar.toml"),
    },
    Builtin {
        name: "vibrating_bar_large",
        description:
            "vibrating bar, large deformation (Wobbes et al. 2019): Hill law, 20 cells, 8 PPC, grid crossing, ULFEM reference",
        toml: include_str!("../../scenarios/vibrating_bar_large.toml"),
    },
    Builtin {
        name: "column_compaction",
        description: "column compaction (Bardenhagen & Kober): Hill law, ramped gravity, 50 cells, 20 PPC",
        toml: include_str!("../../scenarios/column_compaction.toml"),
    },
    Builtin {
        name: "consolidation",
        description: "two-phase consolidation, small deformation: Terzaghi, \
                      from t = 5 s, 20 cells, 4 PPC",
        toml: include_str!("../../scenarios/consolidation.toml"),
    },
    Builtin {
        name: "consolidation_large",
        description: "two-phase consolidation, large deformation: Hill skeleton, \
                      BSMPM-TLS lumped, 120 cells, 16 PPC, 0.4 s",
        toml: include_str!("../../scenarios/consolidation_large.toml"),
    },
    Builtin {
        name: "mms_bar",
        description: "manufactured-solution bar (Tran et al. 2019): neo-Hookean, A = 0.1 m, body force \
                      at the particles, MPM-IMLS, 32 cells, 3 PPC",
        toml: include_str!("../../scenarios/mms_bar.toml"),
    },
    Builtin {
        name: "axis_aligned_mms",
        description: "axis-aligned manufactured solution, 2D plane strain (Wallstedt & Guilkey \
                      2008): neo-Hookean, quadratic B-splines, 16 x 16 cells, 4 PPC",
        toml: include_str!("../../scenarios/axis_aligned_mms.toml"),
    },
];

/// The built-in scenario called `name`, if any.
pub fn find(name: &str) -> Option<&'static Builtin> {
    BUILTIN.iter().find(|b| b.name == name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_parses_and_validates() {
        for b in BUILTIN {
            let s = crate::config::from_str(b.toml, b.name, &[]).unwrap();
            s.validate().unwrap();
            match s.problem.dim {
                1 => drop(crate::app::build_simulation(&s, false).unwrap()),
                2 => drop(crate::app::tensor_run::build_tensor_simulation::<2>(&s, false).unwrap()),
                _ => drop(crate::app::tensor_run::build_tensor_simulation::<3>(&s, false).unwrap()),
            }
        }
    }
}
