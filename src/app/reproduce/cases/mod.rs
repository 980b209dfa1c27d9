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

mod bars;
mod column;
mod consolidation;
mod mms;
mod solvers;

use super::case::{Better, Case, Measure, Published, Rule, RunSpec};
use bars::{function_reconstruction, large_bar, small_bar_conservation, small_bar_orders};
use column::{column_compaction, column_subpoints};
use consolidation::{consolidation, consolidation_large};
use mms::{axis_aligned_mms, mms_bar};
use solvers::solver_tables;

/// `docs/` pages that explain the numbers (relative to the repository).
pub(crate) mod doc {
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

const BSMPM_TLS_CONSISTENT: &[&str] = &[
    "method.basis=bspline",
    "method.reconstruction=tls",
    "method.mass=consistent",
];

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
