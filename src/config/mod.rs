//! Scenario files: the stable TOML keys of DESIGN §3, `--set KEY=VALUE` overrides with
//! dotted keys, and validation.
//!
//! Parsing goes text → `toml::Table` → overrides applied → typed [`Scenario`]
//! (`deny_unknown_fields` everywhere), so an unknown key is an error naming its full dotted
//! path, whether it came from the file or from `--set`. [`Scenario::validate`] then checks
//! ranges (positive sizes, moduli, time step) and names the key and value it rejects.
//!
//! Files: `schema.rs` (the typed sections and their defaults), `parse.rs` (text, overrides,
//! schema errors), `validate.rs` (ranges and combinations, [`Scenario::validate`]),
//! `ignored.rs` (warnings for given keys that other choices make meaningless).

mod ignored;
mod parse;
mod schema;
mod validate;
mod validate_tensor;

pub use ignored::{GivenKeys, KeySource};
pub use parse::{apply_override, display_float, from_str, load, require_positive};
pub use schema::*;
pub use validate_tensor::integer_root;

/// A scenario value as a scenario file writes it (`"neo_hookean"`, not `NeoHookean`), for
/// error messages.
///
/// ```
/// use tlsmpm::config::{toml_value, MaterialModel};
/// assert_eq!(toml_value(&MaterialModel::NeoHookean), "\"neo_hookean\"");
/// ```
pub fn toml_value<T: serde::Serialize>(value: &T) -> String {
    serde_json::to_string(value).unwrap_or_else(|_| "(unprintable)".into())
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::error::Error;

    /// A small vibrating-bar scenario (also used by the sibling modules' tests).
    pub(crate) const BAR: &str = r#"
[problem]
kind = "vibrating_bar"
[grid]
cells = 20
[particles]
per_cell = 12
[time]
dt = 1e-7
end = 1.9e-6
"#;

    #[test]
    fn defaults_and_steps() {
        let s = from_str(BAR, "bar", &[]).unwrap();
        assert_eq!(s.grid.cells, 20);
        assert_eq!(s.material.model, MaterialModel::Linear);
        assert_eq!(s.method.scheme, Scheme::Musl);
        assert_eq!(s.n_steps(), 19);
        s.validate().unwrap();
    }

    #[test]
    fn overrides_use_dotted_keys_and_toml_values() {
        let o = [
            "grid.cells=40".to_string(),
            "method.scheme=usl".to_string(),
            "time.dt=1e-8".to_string(),
            "problem.v0=1".to_string(),
        ];
        let s = from_str(BAR, "bar", &o).unwrap();
        assert_eq!(s.grid.cells, 40);
        assert_eq!(s.method.scheme, Scheme::Usl);
        assert_eq!(s.time.dt, 1e-8);
        assert_eq!(s.problem.v0, Some(1.0));
    }

    #[test]
    fn unknown_keys_name_their_dotted_path() {
        let err = from_str(BAR, "bar", &["grid.celss=3".to_string()]).unwrap_err();
        assert!(
            matches!(&err, Error::UnknownKey { key, .. } if key == "grid.celss"),
            "{err}"
        );
        assert!(err.to_string().contains("--set"), "{err}");
        let err = from_str(BAR, "bar", &["solvr.kind=cg".to_string()]).unwrap_err();
        assert!(
            matches!(&err, Error::UnknownKey { key, .. } if key == "solvr"),
            "{err}"
        );
        let text = format!("{BAR}\n[material]\nyoung = 3.0\n");
        let err = from_str(&text, "bar", &[]).unwrap_err();
        assert!(
            matches!(&err, Error::UnknownKey { key, .. } if key == "material.young"),
            "{err}"
        );
    }

    #[test]
    fn invalid_values_name_the_key() {
        for (set, key) in [
            ("grid.cells=0", "grid.cells"),
            ("particles.per_cell=0", "particles.per_cell"),
            ("material.density=-1", "material.density"),
            ("material.youngs_modulus=0", "material.youngs_modulus"),
            ("time.dt=0", "time.dt"),
            ("time.dt=nan", "time.dt"),
            ("time.dt=1e-300", "time.dt"),
            ("grid.cells=1000000000000", "grid.cells"),
            ("particles.per_cell=4611686018427387904", "grid.cells"),
            (
                "particles.per_cell=18446744073709551615",
                "particles.per_cell",
            ),
        ] {
            let err = from_str(BAR, "bar", &[set.to_string()])
                .and_then(|s| s.validate())
                .unwrap_err();
            assert!(err.to_string().contains(key), "{set}: {err}");
            assert!(err.is_input_error());
        }
    }

    #[test]
    fn the_adjoint_strain_needs_a_reconstruction_and_one_phase() {
        let with = |sets: &[&str]| {
            let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
            from_str(BAR, "bar", &sets).and_then(|s| s.validate().map(|()| s))
        };
        for reconstruction in ["mls", "imls"] {
            let set = format!("method.reconstruction={reconstruction}");
            let scenario = with(&[&set]).unwrap();
            assert_eq!(scenario.method.strain(1, false), StrainKind::Adjoint);
            assert_eq!(scenario.method.strain(1, true), StrainKind::Gradient);
            let scenario = with(&[&set, "method.strain=gradient"]).unwrap();
            assert_eq!(scenario.method.strain(1, false), StrainKind::Gradient);
        }
        assert_eq!(
            with(&[]).unwrap().method.strain(1, false),
            StrainKind::Gradient
        );
        // TLS: adjoint by default in 1D with one phase; gradient (the published method) on
        // request, with two phases and in 2D / 3D.
        let tls = with(&["method.reconstruction=tls"]).unwrap();
        assert_eq!(tls.method.strain(1, false), StrainKind::Adjoint);
        assert_eq!(tls.method.strain(1, true), StrainKind::Gradient);
        assert_eq!(tls.method.strain(2, false), StrainKind::Gradient);
        assert_eq!(tls.method.strain(3, false), StrainKind::Gradient);
        let tls = with(&["method.reconstruction=tls", "method.strain=gradient"]).unwrap();
        assert_eq!(tls.method.strain(1, false), StrainKind::Gradient);
        let tls_2d = with(&[
            "method.reconstruction=tls",
            "problem.dim=2",
            "particles.per_cell=4",
        ])
        .unwrap();
        assert!(tls_2d.ignored_key_warnings().is_empty());
        for sets in [
            &["method.strain=adjoint"][..],
            &[
                "method.strain=adjoint",
                "method.reconstruction=cubic_spline",
            ],
            &["method.strain=sideways"],
        ] {
            let err = with(sets).unwrap_err();
            assert!(err.to_string().contains("method.strain"), "{sets:?}: {err}");
            assert!(err.is_input_error());
        }
    }

    #[test]
    fn the_particle_acceleration_defaults_to_the_basis_and_is_checked() {
        let with = |sets: &[&str]| {
            let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
            from_str(BAR, "bar", &sets).and_then(|s| s.validate().map(|()| s))
        };
        let imls = with(&["method.reconstruction=imls"]).unwrap();
        assert_eq!(
            imls.method.particle_acceleration(),
            ParticleAcceleration::Basis
        );
        assert!(imls.ignored_key_warnings().is_empty());
        let conjugate = with(&[
            "method.reconstruction=imls",
            "method.particle_acceleration=conjugate",
        ])
        .unwrap();
        assert_eq!(
            conjugate.method.particle_acceleration(),
            ParticleAcceleration::Conjugate
        );
        assert!(conjugate.ignored_key_warnings().is_empty());
        // Meaningless with TLS or a consistent velocity mass: a warning naming the key.
        for other in [
            "method.reconstruction=tls",
            "method.mass=consistent",
            "method.basis=bspline",
            "material.model=two_phase",
        ] {
            // Parsed, not validated: a two-phase bar is no valid scenario, the rule is checked.
            let sets = [
                "method.reconstruction=imls",
                other,
                "method.particle_acceleration=conjugate",
            ]
            .map(String::from);
            let s = from_str(BAR, "bar", &sets).unwrap();
            let warnings = s.ignored_key_warnings();
            assert!(
                warnings
                    .iter()
                    .any(|w| w.starts_with("method.particle_acceleration")),
                "{other}: {warnings:?}"
            );
        }
        let err = with(&["method.particle_acceleration=hats"]).unwrap_err();
        assert!(
            err.to_string().contains("method.particle_acceleration"),
            "{err}"
        );
        assert!(err.is_input_error());
    }

    #[test]
    fn the_energy_consistent_tls_keys_are_1d_only_and_checked() {
        let with = |text: &str, sets: &[&str]| {
            let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
            from_str(text, "bar", &sets).and_then(|s| s.validate().map(|()| s))
        };
        let keys = [
            ("method.stress_fit", "conservative"),
            ("method.momentum_limiter", "kinetic_energy"),
            ("method.fit_weights", "domains"),
            ("method.adjoint_mass", "consistent"),
        ];
        // Defaults: the published fit, no limiter; with the adjoint strain (the 1D
        // one-phase default) domain weights and the quadratic metric, with the gradient
        // strain the published point weights and the particle masses.
        let tls = with(BAR, &["method.reconstruction=tls"]).unwrap();
        assert_eq!(tls.method.stress_fit(), StressFit::Full);
        assert_eq!(tls.method.momentum_limiter(), MomentumLimiter::None);
        assert_eq!(tls.method.fit_weights(1, false), FitWeights::Domains);
        assert_eq!(tls.method.adjoint_mass(1, false), AdjointMass::Quadratic);
        for (dim, two_phase) in [(1, true), (2, false), (3, false)] {
            assert_eq!(tls.method.fit_weights(dim, two_phase), FitWeights::Points);
            assert_eq!(tls.method.adjoint_mass(dim, two_phase), AdjointMass::Lumped);
        }
        let published = with(
            BAR,
            &["method.reconstruction=tls", "method.strain=gradient"],
        )
        .unwrap();
        assert_eq!(published.method.fit_weights(1, false), FitWeights::Points);
        assert_eq!(published.method.adjoint_mass(1, false), AdjointMass::Lumped);
        // With TLS but the gradient strain: a warning naming the key.
        let gradient = with(
            BAR,
            &[
                "method.reconstruction=tls",
                "method.strain=gradient",
                "method.adjoint_mass=consistent",
            ],
        )
        .unwrap();
        let warnings = gradient.ignored_key_warnings();
        assert!(
            warnings
                .iter()
                .any(|w| w.starts_with("method.adjoint_mass") && w.contains("method.strain")),
            "{warnings:?}"
        );
        let adjoint = with(
            BAR,
            &[
                "method.reconstruction=tls",
                "method.strain=adjoint",
                "method.adjoint_mass=consistent",
            ],
        )
        .unwrap();
        assert!(adjoint.ignored_key_warnings().is_empty());
        // Without TLS: a warning naming the key.
        let imls = with(
            BAR,
            &["method.reconstruction=imls", "method.fit_weights=domains"],
        )
        .unwrap();
        let warnings = imls.ignored_key_warnings();
        assert!(
            warnings.iter().any(|w| w.starts_with("method.fit_weights")),
            "{warnings:?}"
        );
        for (key, value) in keys {
            let set = format!("{key}={value}");
            assert!(with(BAR, &["method.reconstruction=tls", &set]).is_ok());
            // Refused in 2D / 3D.
            let sets = [
                "method.reconstruction=tls",
                "problem.dim=2",
                "particles.per_cell=4",
                &set,
            ];
            let err = with(BAR, &sets).unwrap_err();
            assert!(err.to_string().contains(key), "{sets:?}: {err}");
            assert!(err.is_input_error());
            let bad = format!("{key}=sideways");
            let err = with(BAR, &["method.reconstruction=tls", &bad]).unwrap_err();
            assert!(err.to_string().contains(key), "{err}");
        }
    }

    #[test]
    fn the_conservative_degree_defaults_by_dimension_and_is_checked() {
        let with = |sets: &[&str]| {
            let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
            from_str(BAR, "bar", &sets).and_then(|s| s.validate().map(|()| s))
        };
        let tls = with(&["method.reconstruction=tls"]).unwrap();
        assert_eq!(
            (
                tls.method.conservative_degree(1),
                tls.method.conservative_degree(2)
            ),
            (2, 1)
        );
        for degree in 0..=2 {
            let set = format!("method.conservative_degree={degree}");
            let s = with(&["method.reconstruction=tls", &set]).unwrap();
            assert_eq!(s.method.conservative_degree(3), degree);
        }
        for value in ["3", "-1", "1.5"] {
            let set = format!("method.conservative_degree={value}");
            let err = with(&["method.reconstruction=tls", &set]).unwrap_err();
            assert!(
                err.to_string().contains("method.conservative_degree"),
                "{value}: {err}"
            );
            assert!(err.is_input_error());
        }
    }

    #[test]
    fn subpoints_need_the_direct_mapping() {
        let with = |sets: &[&str]| {
            let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
            from_str(BAR, "bar", &sets).and_then(|s| s.validate())
        };
        with(&["method.basis=ddmpm", "method.subpoints=4"]).unwrap();
        with(&["method.subpoints=1", "method.mass=consistent"]).unwrap();
        for reconstruction in ["tls", "cubic_spline"] {
            let err = with(&[
                "method.subpoints=4",
                &format!("method.reconstruction={reconstruction}"),
            ])
            .unwrap_err();
            let text = err.to_string();
            assert!(text.contains("method.subpoints"), "{text}");
            assert!(text.contains(reconstruction), "{text}");
            assert!(err.is_input_error());
        }
        let err = with(&["method.subpoints=1000000"]).unwrap_err();
        assert!(err.to_string().contains("method.subpoints"), "{err}");
    }

    #[test]
    fn wrong_types_and_bad_overrides_are_errors() {
        let err = from_str(BAR, "bar", &["grid.cells=-5".to_string()]).unwrap_err();
        assert!(err.to_string().contains("grid.cells"), "{err}");
        let err = from_str(BAR, "bar", &["grid.cells".to_string()]).unwrap_err();
        assert!(err.to_string().contains("KEY=VALUE"), "{err}");
        let err = from_str(BAR, "bar", &["grid.cells.x=1".to_string()]).unwrap_err();
        assert!(err.to_string().contains("not a table"), "{err}");
        let err = from_str("[grid]\ncells = 3\n[problem\nkind=1", "bad", &[]).unwrap_err();
        assert!(matches!(err, Error::Parse { .. }));
        assert!(err.to_string().contains("line 3"), "{err}");
    }
}
