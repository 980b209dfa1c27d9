//! Warnings about a run that completed but whose results should not be trusted: errors
//! against the exact solution above 100 %, or a total energy that grew well beyond its value
//! after the first step. They are printed on stderr and kept in `summary.json`
//! (`warnings`); the run still exits 0.

use crate::output::summary::Errors;
use crate::physics::HistoryRow;

/// A relative L2 error above this is reported (the error is larger than the solution).
pub const ERROR_LIMIT: f64 = 1.0;

/// Growth of the total (kinetic + stored) energy over its value after the first step
/// beyond which a run is reported. Runs that start without energy (loaded from rest) are
/// not checked.
pub const ENERGY_GROWTH_LIMIT: f64 = 2.0;

/// The warnings of a finished run.
///
/// ```
/// use tlsmpm::app::warnings::run_warnings;
/// use tlsmpm::output::summary::Errors;
/// let mut errors = Errors::default();
/// errors.rel_l2.insert("stress".into(), 268.0);
/// let warnings = run_warnings(Some(&errors), &[]);
/// assert!(warnings[0].contains("stress"));
/// ```
pub fn run_warnings(errors: Option<&Errors>, history: &[HistoryRow]) -> Vec<String> {
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
    let energy = |row: &HistoryRow| row.kinetic_energy + row.strain_energy;
    if let Some(first) = history.first().map(energy).filter(|&e| e > 0.0) {
        let peak = history.iter().map(energy).fold(first, f64::max);
        if peak > ENERGY_GROWTH_LIMIT * first {
            warnings.push(format!(
                "the total energy grew to {:.2} times its value after the first step (limit \
                 {ENERGY_GROWTH_LIMIT}): the run is unstable or the method gains energy",
                peak / first
            ));
        }
    }
    warnings
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(kinetic: f64) -> HistoryRow {
        HistoryRow {
            kinetic_energy: kinetic,
            ..HistoryRow::default()
        }
    }

    #[test]
    fn energy_growth_and_large_errors_are_reported_and_small_ones_not() {
        let steady = [row(1.0), row(1.5), row(0.7)];
        assert!(run_warnings(None, &steady).is_empty());
        let growing = [row(1.0), row(4.6)];
        let warnings = run_warnings(None, &growing);
        assert_eq!(warnings.len(), 1);
        assert!(warnings[0].contains("4.60 times"), "{warnings:?}");
        // From rest (gravity, loading): not checked.
        assert!(run_warnings(None, &[row(0.0), row(10.0)]).is_empty());
        let mut errors = Errors::default();
        errors.rel_l2.insert("u".into(), 0.01);
        assert!(run_warnings(Some(&errors), &steady).is_empty());
        errors.rel_l2.insert("v".into(), 59.0);
        assert_eq!(run_warnings(Some(&errors), &steady).len(), 1);
    }
}
