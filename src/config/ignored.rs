//! Keys that another choice of the scenario makes meaningless (`method.order` with the
//! linear basis, `solver.*` with a lumped mass, ...). They are accepted, not refused — a
//! sweep that toggles `method.basis` over one scenario file must still run — and named in
//! a warning on stderr and in `summary.json` (`warnings`).
//!
//! Only keys written in the file or given with `--set` are checked ([`GivenKeys`]), never
//! defaults.

use super::schema::{
    BasisKind, MassKind, MaterialModel, ProblemKind, ReconstructionKind, ReferenceKind, Scenario,
    SolverKind, StrainKind,
};
use super::toml_value;
use std::collections::BTreeMap;

/// Where a key's value came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KeySource {
    File,
    Set,
}

/// The dotted keys a scenario was given (`method.order`), each with where it came from and
/// its value as TOML writes it (the last source wins: `--set` over the file).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct GivenKeys(pub BTreeMap<String, (KeySource, String)>);

impl GivenKeys {
    /// Every leaf key of `table` (a value that is not a table), from `source`.
    pub fn add_table(&mut self, table: &toml::Table, source: KeySource) {
        fn walk(
            keys: &mut BTreeMap<String, (KeySource, String)>,
            prefix: &str,
            table: &toml::Table,
            source: KeySource,
        ) {
            for (name, value) in table {
                let key = if prefix.is_empty() {
                    name.clone()
                } else {
                    format!("{prefix}.{name}")
                };
                match value {
                    toml::Value::Table(inner) => walk(keys, &key, inner, source),
                    _ => {
                        keys.insert(key, (source, value.to_string()));
                    }
                }
            }
        }
        walk(&mut self.0, "", table, source);
    }

    /// Whether `key` was given.
    pub fn contains(&self, key: &str) -> bool {
        self.0.contains_key(key)
    }

    /// Where `key` came from, if it was given.
    pub fn source(&self, key: &str) -> Option<KeySource> {
        self.0.get(key).map(|(source, _)| *source)
    }

    /// The value `key` was given, as TOML writes it (`3`, `"cg"`).
    pub fn value(&self, key: &str) -> Option<&str> {
        self.0.get(key).map(|(_, value)| value.as_str())
    }
}

impl Scenario {
    /// A warning for each given key that the rest of the scenario makes meaningless.
    ///
    /// ```
    /// use tlsmpm::config::from_str;
    /// let text = "[problem]\nkind = \"vibrating_bar\"\n[grid]\ncells = 4\n\
    ///             [particles]\nper_cell = 2\n[time]\ndt = 1e-6\nend = 1e-5\n\
    ///             [method]\nbasis = \"linear\"\norder = 3\n";
    /// let scenario = from_str(text, "bar", &[]).unwrap();
    /// let warnings = scenario.ignored_key_warnings();
    /// assert_eq!(warnings.len(), 1);
    /// assert!(warnings[0].starts_with("method.order = 3 is ignored"));
    /// ```
    pub fn ignored_key_warnings(&self) -> Vec<String> {
        let method = &self.method;
        let basis = format!("method.basis = {}", toml_value(&method.basis));
        let reconstruction = format!(
            "method.reconstruction = \"{}\"",
            method.reconstruction.name()
        );
        let consistent = method.mass == MassKind::Consistent
            || method.acceleration_mass() == MassKind::Consistent;
        let solver_kind = if self.problem.dim == 1 {
            self.solver.kind()
        } else {
            self.solver.tensor_kind(self.problem.dim)
        };
        let multigrid = matches!(solver_kind, SolverKind::Pmg | SolverKind::PmgCg);
        let kind = self.problem.kind;
        let problem = format!("problem.kind = {}", toml_value(&kind));
        let lumped = "no consistent mass is solved (method.mass and method.acceleration_mass \
                      are \"lumped\")"
            .to_string();
        let two_phase = self.material.model == MaterialModel::TwoPhase;
        // MLS / IMLS fit nodal velocities with the linear basis only.
        let nodal_mls = matches!(
            method.reconstruction,
            ReconstructionKind::Mls | ReconstructionKind::Imls
        ) && method.basis == BasisKind::Linear;
        let only_tls = format!("only used by method.reconstruction = \"tls\" ({reconstruction})");
        let only_multigrid = format!(
            "only used by the p-multigrid solvers (solver.kind = \"{}\"{})",
            solver_kind.name(),
            if consistent {
                ""
            } else {
                ", and no consistent mass is solved"
            }
        );
        let only_problem =
            |name: &str| format!("only used by problem.kind = \"{name}\" ({problem})");
        // (keys, ignored, why: the choice that makes them meaningless).
        let rules: [(&[&str], bool, String); 11] = [
            (
                &["method.adjoint_mass"],
                method.reconstruction == ReconstructionKind::Tls
                    && method.strain(self.problem.dim, two_phase) != StrainKind::Adjoint,
                format!(
                    "only used by method.strain = \"adjoint\" (method.strain = \"{}\")",
                    method.strain(self.problem.dim, two_phase).name()
                ),
            ),
            (
                &["method.order"],
                method.basis != BasisKind::Bspline,
                format!("only method.basis = \"bspline\" has an order ({basis})"),
            ),
            (
                &["method.node_integrals"],
                method.basis != BasisKind::Ddmpm,
                format!("only used by method.basis = \"ddmpm\" ({basis})"),
            ),
            (
                &["method.gauss_points"],
                method.reconstruction == ReconstructionKind::None,
                format!("only used by a reconstruction ({reconstruction})"),
            ),
            (
                &[
                    "method.degenerate_cells",
                    "method.cell_totals",
                    "method.conservative_degree",
                    "method.momentum_limiter",
                    "method.stress_fit",
                    "method.fit_weights",
                    "method.adjoint_mass",
                ],
                method.reconstruction != ReconstructionKind::Tls,
                only_tls,
            ),
            (
                &["method.particle_acceleration"],
                !nodal_mls || method.mass == MassKind::Consistent || two_phase,
                format!(
                    "only used by method.reconstruction = \"mls\" / \"imls\" with \
                     method.basis = \"linear\" and method.mass = \"lumped\", one phase \
                     ({reconstruction}, {basis})"
                ),
            ),
            (&["solver.kind", "solver.tolerance"], !consistent, lumped),
            (
                &["solver.smoother", "solver.pre_smooth", "solver.post_smooth"],
                !consistent || !multigrid,
                only_multigrid,
            ),
            (
                &["problem.v0"],
                kind != ProblemKind::VibratingBar,
                only_problem("vibrating_bar"),
            ),
            (
                &["problem.gravity"],
                kind != ProblemKind::ColumnCompaction,
                only_problem("column_compaction"),
            ),
            (
                &["problem.load", "problem.start_time"],
                kind != ProblemKind::Consolidation,
                only_problem("consolidation"),
            ),
        ];
        let reference = (
            &["problem.reference_dofs"][..],
            self.problem.reference != ReferenceKind::Ulfem,
            format!(
                "only used by problem.reference = \"ulfem\" (problem.reference = {})",
                toml_value(&self.problem.reference)
            ),
        );
        rules
            .iter()
            .chain(std::iter::once(&reference))
            .filter(|(_, ignored, _)| *ignored)
            .flat_map(|(keys, _, why)| keys.iter().map(move |key| (*key, why)))
            .filter_map(|(key, why)| {
                let value = self.given_keys.value(key)?;
                Some(format!("{key} = {value} is ignored: {why}"))
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use crate::config::from_str;
    use crate::config::tests::BAR;

    fn warnings(sets: &[&str]) -> Vec<String> {
        let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
        from_str(BAR, "bar", &sets).unwrap().ignored_key_warnings()
    }

    #[test]
    fn keys_a_choice_makes_meaningless_are_named() {
        for (sets, key) in [
            (&["method.order=3"][..], "method.order = 3 is ignored"),
            (&["method.node_integrals=domain"], "method.node_integrals"),
            (&["method.gauss_points=4"], "method.gauss_points = 4"),
            (&["method.cell_totals=centres"], "method.cell_totals"),
            (&["solver.kind=cg"], "solver.kind = \"cg\" is ignored"),
            (
                &[
                    "method.mass=consistent",
                    "solver.kind=cg",
                    "solver.pre_smooth=2",
                ],
                "solver.pre_smooth = 2",
            ),
            (&["problem.gravity=-10"], "problem.gravity"),
            (&["problem.reference_dofs=50"], "problem.reference_dofs"),
        ] {
            let found = warnings(sets);
            assert_eq!(found.len(), 1, "{sets:?}: {found:?}");
            assert!(found[0].starts_with(key), "{sets:?}: {found:?}");
        }
    }

    #[test]
    fn keys_that_take_effect_and_defaults_are_not_named() {
        for sets in [
            &[][..],
            &["method.basis=bspline", "method.order=3"],
            &["method.basis=ddmpm", "method.node_integrals=domain"],
            &["method.reconstruction=tls", "method.gauss_points=4"],
            &["method.reconstruction=tls", "method.cell_totals=centres"],
            &["method.mass=consistent", "solver.kind=cg"],
            &[
                "method.acceleration_mass=consistent",
                "solver.tolerance=1e-10",
            ],
            &[
                "method.mass=consistent",
                "solver.kind=pmg",
                "solver.pre_smooth=2",
            ],
            &["problem.v0=0.1"],
            &["problem.reference=ulfem", "problem.reference_dofs=50"],
        ] {
            assert_eq!(warnings(sets), Vec::<String>::new(), "{sets:?}");
        }
    }
}
