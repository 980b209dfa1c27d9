//! The vocabulary of a reproduction case: what is run ([`RunSpec`], [`StudySpec`]), which
//! number is taken from it ([`Measure`]), the published value it is compared with and how
//! ([`Published`], [`Rule`]), and the verdict ([`Verdict`]).

use crate::problems::Field;

/// One run of a built-in scenario with `--set` overrides (`"key=value"`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct RunSpec {
    pub scenario: &'static str,
    pub sets: &'static [&'static str],
}

/// A convergence study of a built-in scenario: the full and the `--quick` cell counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct StudySpec {
    pub label: &'static str,
    pub scenario: &'static str,
    pub sets: &'static [&'static str],
    pub cells: &'static [usize],
    pub quick_cells: &'static [usize],
}

impl StudySpec {
    /// The cell counts of a full or a quick reproduction.
    pub fn cells(&self, quick: bool) -> &'static [usize] {
        if quick {
            self.quick_cells
        } else {
            self.cells
        }
    }
}

/// A number of one run's outputs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RunValue {
    /// Relative L2 error of a field against the exact (or reference) solution.
    RelL2(Field),
    /// Largest relative mass error of the mapping over the run (solid).
    MassError,
    /// Largest relative momentum error of the mapping over the run (solid).
    MomentumError,
    /// The same two for the liquid of a two-phase run.
    LiquidMassError,
    LiquidMomentumError,
    /// The relative mass and momentum error of the mapping at the last step
    /// (`history.csv`), for tables that report the end of the run.
    FinalMassError,
    FinalMomentumError,
    /// Particle moves from one cell to another, summed over the run.
    GridCrossings,
    /// Wall-clock seconds of the time loop.
    WallSeconds,
    /// Settlement of the top particle (largest `x0`): minus its `particles.csv` column `u`.
    TopSettlement,
}

/// Which observed order of a study: `log(e_a / e_b) / log(h_a / h_b)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pair {
    /// From the coarsest to the finest grid (the average order).
    Overall,
    /// The two coarsest grids.
    Coarsest,
    /// The two finest grids.
    Finest,
}

/// The solver tables of the p-multigrid / consistent-mass study (2D, unit density).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SolverTable {
    ConditionNumber,
    CgIterations,
    VCycles,
}

/// What `tlsmpm reconstruct` reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReconstructValue {
    TlsIntegral,
    SplineIntegral,
    TlsRms,
    SplineRms,
}

/// How our number is obtained.
#[derive(Clone, Debug, PartialEq)]
pub enum Measure {
    /// One value of one run.
    Run(RunSpec, RunValue),
    /// `numerator / denominator` of two runs' values.
    Ratio((RunSpec, RunValue), (RunSpec, RunValue)),
    /// The largest value over several runs.
    MaxOf(Vec<(RunSpec, RunValue)>),
    /// An observed RMS order of a study.
    Order(StudySpec, Field, Pair),
    /// The function-reconstruction benchmark.
    Reconstruct(ReconstructValue),
    /// One entry `(order p, 1/h)` of the 2D solver tables.
    Solver(SolverTable, usize, usize),
}

/// When our number counts as the published one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Rule {
    /// Equal when both are rounded to this many significant digits.
    Digits(u32),
    /// `|ours / published - 1| <= tolerance`.
    Relative(f64),
    /// Within this factor either way (the same size).
    Factor(f64),
    /// Both at round-off: ours `<=` this bound.
    RoundOff(f64),
    /// An observed order: `|ours - published| <= tolerance`.
    Order(f64),
    /// Ours `<=` this bound (e.g. "does not converge": an order of at most 0.5).
    AtMost(f64),
    /// Ours `>=` this bound (e.g. "second order": an order of at least 1.7).
    AtLeast(f64),
}

impl Rule {
    /// Whether `ours` matches `published` under this rule.
    ///
    /// ```
    /// use tlsmpm::app::reproduce::Rule;
    /// assert!(Rule::Digits(3).matches(424.4, 424.0));
    /// assert!(!Rule::Digits(3).matches(425.2, 424.0));
    /// assert!(Rule::Order(0.3).matches(2.83, 3.0));
    /// assert!(Rule::Factor(3.0).matches(1e-15, 2.5e-15));
    /// ```
    pub fn matches(self, ours: f64, published: f64) -> bool {
        if !ours.is_finite() {
            return false;
        }
        match self {
            Rule::Digits(digits) => {
                let round = |x: f64| format!("{:.*e}", digits.saturating_sub(1) as usize, x);
                round(ours) == round(published)
            }
            Rule::Relative(tolerance) => (ours / published - 1.0).abs() <= tolerance,
            Rule::Factor(factor) => {
                ours > 0.0 && published > 0.0 && {
                    let ratio = ours / published;
                    ratio <= factor && ratio >= 1.0 / factor
                }
            }
            Rule::RoundOff(bound) | Rule::AtMost(bound) => ours <= bound,
            Rule::Order(tolerance) => (ours - published).abs() <= tolerance,
            Rule::AtLeast(bound) => ours >= bound,
        }
    }

    /// The tolerance in words, for the report.
    pub fn describe(self) -> String {
        match self {
            Rule::Digits(d) => format!("{d} significant digits"),
            Rule::Relative(t) => format!("within {}%", t * 100.0),
            Rule::Factor(f) => format!("within a factor {f}"),
            Rule::RoundOff(b) => format!("round-off (<= {b:.0e})"),
            Rule::Order(t) => format!("order within {t}"),
            Rule::AtMost(b) => format!("at most {b:e}"),
            Rule::AtLeast(b) => format!("at least {b}"),
        }
    }
}

/// Which side of the published number is the better one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Better {
    /// An error: lower is better.
    Lower,
    /// An order or an error reduction: higher is better.
    Higher,
    /// A property of the problem (a condition number, an iteration count to compare in
    /// size): neither side is better.
    Neither,
}

/// One published number and how ours is compared with it.
#[derive(Clone, Debug, PartialEq)]
pub struct Published {
    /// What it is, e.g. `"MPM-TLS stress rel. L2"`.
    pub quantity: String,
    pub value: f64,
    /// How the paper states it when that is not one number (e.g. `"round-off"`, `"2"`);
    /// empty: `value` itself.
    pub stated: &'static str,
    pub measure: Measure,
    pub rule: Rule,
    pub better: Better,
    /// Part of `--quick`.
    pub quick: bool,
    /// What explains our number, in one line: why it differs or is better, or what the
    /// match depends on. Empty when nothing needs saying (a `differs` without one is
    /// reported as unexplained).
    pub reason: &'static str,
    /// The `docs/` page (and anchor) that explains the number, relative to the repository.
    pub doc: &'static str,
}

/// The outcome of one comparison.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    Matched,
    Better,
    Differs,
}

impl Verdict {
    pub fn name(self) -> &'static str {
        match self {
            Verdict::Matched => "matched",
            Verdict::Better => "better",
            Verdict::Differs => "differs",
        }
    }
}

impl Published {
    /// The same number with the paper's wording of it (see [`Published::stated`]).
    pub fn stated(mut self, text: &'static str) -> Self {
        self.stated = text;
        self
    }

    /// The same number, part of `--quick` or not.
    pub fn quick(mut self, quick: bool) -> Self {
        self.quick = quick;
        self
    }

    /// The verdict for our value `ours`: `matched` under the rule, else `better` when ours
    /// lies on the better side and a reason is known, else `differs`.
    pub fn verdict(&self, ours: f64) -> Verdict {
        if self.rule.matches(ours, self.value) {
            return Verdict::Matched;
        }
        let better_side = match self.better {
            Better::Lower => ours < self.value,
            Better::Higher => ours > self.value,
            Better::Neither => false,
        };
        if better_side && ours.is_finite() && !self.reason.is_empty() {
            Verdict::Better
        } else {
            Verdict::Differs
        }
    }
}

/// A published table or figure: the numbers it holds and the studies whose orders are
/// shown with it.
#[derive(Clone, Debug)]
pub struct Case {
    pub id: &'static str,
    /// Paper and table / figure.
    pub source: &'static str,
    pub title: &'static str,
    pub numbers: Vec<Published>,
    /// Further studies shown in the case's table of orders (no published number).
    pub context: Vec<StudySpec>,
    /// Overlays drawn next to the report.
    pub plots: Vec<Plot>,
}

/// A plot of the report: one field of several runs (`x0` axis), or one error of several
/// studies against `h`.
#[derive(Clone, Debug)]
pub enum Plot {
    Runs {
        file: &'static str,
        field: &'static str,
        runs: Vec<(&'static str, RunSpec)>,
        exact: bool,
    },
    Studies {
        file: &'static str,
        field: &'static str,
    },
}

#[cfg(test)]
mod tests {
    use super::*;

    fn number(rule: Rule, better: Better, reason: &'static str) -> Published {
        Published {
            quantity: "q".into(),
            value: 1.0,
            stated: "",
            measure: Measure::Reconstruct(ReconstructValue::TlsRms),
            rule,
            better,
            quick: true,
            reason,
            doc: "docs/reproduce.md",
        }
    }

    #[test]
    fn verdicts_follow_the_rule_and_the_better_side() {
        let error = number(Rule::Relative(0.05), Better::Lower, "known");
        assert_eq!(error.verdict(1.04), Verdict::Matched);
        assert_eq!(error.verdict(0.5), Verdict::Better);
        assert_eq!(error.verdict(1.5), Verdict::Differs);
        assert_eq!(error.verdict(f64::NAN), Verdict::Differs);
        // Better only with a known reason.
        let unexplained = number(Rule::Relative(0.05), Better::Lower, "");
        assert_eq!(unexplained.verdict(0.5), Verdict::Differs);
        let order = number(Rule::Order(0.3), Better::Higher, "known");
        assert_eq!(order.verdict(1.8), Verdict::Better);
        assert_eq!(order.verdict(0.2), Verdict::Differs);
        let size = number(Rule::Factor(2.0), Better::Neither, "known");
        assert_eq!(size.verdict(0.4), Verdict::Differs);
        assert_eq!(size.verdict(1.9), Verdict::Matched);
    }

    #[test]
    fn digits_round_both_numbers() {
        assert!(Rule::Digits(3).matches(3.2951e3, 3.30e3));
        assert!(!Rule::Digits(3).matches(3.29e3, 3.30e3));
        assert!(Rule::Digits(3).matches(55.149, 55.1));
        assert!(!Rule::Digits(3).matches(55.16, 55.1));
        assert!(!Rule::Digits(3).matches(f64::INFINITY, 55.1));
    }
}
