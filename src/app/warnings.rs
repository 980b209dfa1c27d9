//! Warnings about a run that completed but whose results should not be trusted: an error
//! larger than the solution itself. They are printed on stderr and kept in `summary.json`
//! (`warnings`), beside the warnings about keys a choice made meaningless
//! ([`crate::config::Scenario::ignored_key_warnings`]); the run still exits 0.
//!
//! The error of a field is judged against the size of its exact solution over the run,
//! `max_t ||u_exact(t)||_2` over the end time and the problem's peak times
//! ([`crate::problems::Problem::solution_peak_times`]): the relative L2 error at the end
//! (`summary.json`'s `rel_l2`) is meaningless where the exact field passes through zero
//! there (the manufactured-solution bar after one period, a consolidation that has come to
//! rest). An energy-growth check is not made: loaded problems (gravity, a surface load)
//! start at rest and gain energy legitimately, and the energy at `t = 0` that would tell
//! the two apart is not recorded.

/// An error above this fraction of the solution's size is reported.
pub const ERROR_LIMIT: f64 = 1.0;

/// The final error of one field and the size of the exact field it is judged against.
#[derive(Clone, Debug, PartialEq)]
pub struct FieldError {
    /// The field's output name (`stress`).
    pub field: String,
    /// `||u_h - u_exact||_2` over the particles at the end.
    pub error_l2: f64,
    /// `max_t ||u_exact(t)||_2` over the end and the problem's peak times.
    pub size_l2: f64,
    /// Whether `size_l2` is the norm at the end only (a reference known at the end only).
    pub at_end_only: bool,
}

/// The warnings of a finished run's errors.
///
/// ```
/// use tlsmpm::app::warnings::{run_warnings, FieldError};
/// let stress = FieldError {
///     field: "stress".into(),
///     error_l2: 2.0,
///     size_l2: 1.0,
///     at_end_only: false,
/// };
/// let warnings = run_warnings(&[stress]);
/// assert!(warnings[0].contains("error of stress is 2.000e0 times"));
/// ```
pub fn run_warnings(errors: &[FieldError]) -> Vec<String> {
    errors
        .iter()
        .filter_map(|e| {
            let ratio = if e.size_l2 > 0.0 {
                e.error_l2 / e.size_l2
            } else {
                e.error_l2
            };
            // A NaN (a field the particles lack) is not an error of the method.
            (ratio > ERROR_LIMIT).then(|| {
                let size = if e.at_end_only {
                    "its L2 norm at the end"
                } else {
                    "its largest L2 norm over the run"
                };
                format!(
                    "the L2 error of {} is {ratio:.3e} times the size of the exact {} ({size}): \
                     the method does not converge on this problem at this resolution",
                    e.field, e.field
                )
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn error(field: &str, error_l2: f64, size_l2: f64) -> FieldError {
        FieldError {
            field: field.into(),
            error_l2,
            size_l2,
            at_end_only: true,
        }
    }

    #[test]
    fn errors_above_the_solution_size_are_reported_and_smaller_ones_not() {
        assert!(run_warnings(&[]).is_empty());
        assert!(run_warnings(&[error("u", 0.01, 1.0)]).is_empty());
        let warnings = run_warnings(&[error("u", 0.01, 1.0), error("v", 59.0, 1.0)]);
        assert_eq!(warnings.len(), 1);
        assert!(
            warnings[0].contains("of v is 5.900e1 times"),
            "{warnings:?}"
        );
        assert!(warnings[0].contains("at the end"), "{warnings:?}");
        // A zero solution: the absolute error decides.
        assert!(run_warnings(&[error("u", 1e-20, 0.0)]).is_empty());
        assert_eq!(run_warnings(&[error("u", 2.0, 0.0)]).len(), 1);
    }
}
