//! Warnings about a run that completed but whose results should not be trusted: an error
//! against the exact solution above 100 %. They are printed on stderr and kept in
//! `summary.json` (`warnings`); the run still exits 0.
//!
//! An energy-growth check is not made: loaded problems (gravity, a surface load) start
//! at rest and gain energy legitimately, and the energy at `t = 0` that would tell the
//! two apart is not recorded.

use crate::output::summary::Errors;

/// A relative L2 error above this is reported (the error is larger than the solution).
pub const ERROR_LIMIT: f64 = 1.0;

/// The warnings of a finished run.
///
/// ```
/// use tlsmpm::app::warnings::run_warnings;
/// use tlsmpm::output::summary::Errors;
/// let mut errors = Errors::default();
/// errors.rel_l2.insert("stress".into(), 268.0);
/// let warnings = run_warnings(Some(&errors));
/// assert!(warnings[0].contains("stress"));
/// ```
pub fn run_warnings(errors: Option<&Errors>) -> Vec<String> {
    let mut warnings = Vec::new();
    if let Some(errors) = errors {
        for (field, &rel) in &errors.rel_l2 {
            if rel > ERROR_LIMIT {
                warnings.push(format!(
                    "the relative L2 error of {field} is {rel:.3e}, above {:.0}%: the method \
                     does not converge on this problem at this resolution",
                    100.0 * ERROR_LIMIT
                ));
            }
        }
    }
    warnings
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_above_100_percent_are_reported_and_smaller_ones_not() {
        assert!(run_warnings(None).is_empty());
        let mut errors = Errors::default();
        errors.rel_l2.insert("u".into(), 0.01);
        assert!(run_warnings(Some(&errors)).is_empty());
        errors.rel_l2.insert("v".into(), 59.0);
        let warnings = run_warnings(Some(&errors));
        assert_eq!(warnings.len(), 1);
        assert!(warnings[0].contains("of v is 5.900e1"), "{warnings:?}");
    }
}
