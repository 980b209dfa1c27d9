//! The one error type of the library.
//!
//! Three families, mapped to exit codes by the binary (DESIGN §2):
//! * input errors (unreadable file, invalid TOML, unknown key, invalid value, unstable time
//!   step) → exit code 2, with a message that names the offending key and value;
//! * numerical failures (NaN/infinity, solver breakdown or divergence) → exit code 1, after
//!   the caller has written what was computed so far;
//! * output errors (the output directory cannot be created or written) → exit code 2, with
//!   the path;
//! * an interrupt (SIGINT / SIGTERM, checked between steps) → exit code 130, after the
//!   state reached has been written with status `"interrupted"`.

use std::path::PathBuf;

/// Result alias used throughout the crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Everything that can go wrong in `tlsmpm`.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A scenario or input file could not be read.
    #[error("cannot read {path}: {source}")]
    ReadInput {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The scenario text is not valid TOML, or does not match the scenario schema.
    #[error("invalid scenario {origin}: {message}")]
    Parse { origin: String, message: String },
    /// A scenario key that does not exist.
    #[error("unknown key `{key}`{hint}")]
    UnknownKey { key: String, hint: String },
    /// A key with a value outside its valid range.
    #[error("invalid value for `{key}` = {value}: {reason}")]
    InvalidValue {
        key: String,
        value: String,
        reason: String,
    },
    /// The time step is above the stability limit (override with `--force`).
    #[error(
        "`time.dt` = {dt:e} exceeds the stability limit {limit:.3e} s (2 / omega_max of the mass system: h / c for linear hats with lumped mass, h / (sqrt(3) c) with consistent mass); use --force to run anyway"
    )]
    UnstableTimeStep { dt: f64, limit: f64 },
    /// A NaN or infinite value appeared during the run.
    #[error("non-finite {field} at step {step} (t = {time:e} s)")]
    NonFinite {
        field: &'static str,
        step: usize,
        time: f64,
    },
    /// A particle's volume became zero or negative (`1 + deps <= 0`: the grid velocity
    /// field folded the material).
    #[error("non-positive volume of particle {particle} at step {step} (t = {time:e} s)")]
    CollapsedVolume {
        particle: usize,
        step: usize,
        time: f64,
    },
    /// A particle moved outside the background grid.
    #[error("particle {particle} left the grid (x = {x:e}) at step {step} (t = {time:e} s)")]
    LeftGrid {
        particle: usize,
        x: f64,
        step: usize,
        time: f64,
    },
    /// A linear solver broke down or did not converge.
    #[error("linear solver `{solver}` failed: {reason}")]
    Solver { solver: String, reason: String },
    /// The exchange between the ranks of a distributed run failed, or another rank did.
    #[error("distributed run: {reason}")]
    Distributed { reason: String },
    /// A result file could not be written.
    #[error("cannot write {path}: {reason}")]
    WriteOutput { path: PathBuf, reason: String },
    /// The run was asked to stop (SIGINT / SIGTERM) and stopped after `step` steps.
    #[error("interrupted after step {step} (t = {time:e} s)")]
    Interrupted { step: usize, time: f64 },
}

impl Error {
    /// Shorthand for [`Error::InvalidValue`].
    pub fn invalid(key: &str, value: impl std::fmt::Display, reason: impl Into<String>) -> Self {
        Error::InvalidValue {
            key: key.to_string(),
            value: value.to_string(),
            reason: reason.into(),
        }
    }

    /// `true` for errors caused by the user's input, before anything was computed (exit
    /// code 2); `false` for numerical failures, output failures and interrupts.
    pub fn is_input_error(&self) -> bool {
        matches!(
            self,
            Error::ReadInput { .. }
                | Error::Parse { .. }
                | Error::UnknownKey { .. }
                | Error::InvalidValue { .. }
                | Error::UnstableTimeStep { .. }
        )
    }

    /// Process exit code for this error: 2 for bad input and unusable output paths, 130
    /// for an interrupt, 1 for a numerical failure.
    ///
    /// ```
    /// use tlsmpm::Error;
    /// assert_eq!(Error::invalid("grid.cells", 0, "must be positive").exit_code(), 2);
    /// assert_eq!(Error::Interrupted { step: 3, time: 0.1 }.exit_code(), 130);
    /// ```
    pub fn exit_code(&self) -> i32 {
        match self {
            _ if self.is_input_error() => 2,
            Error::WriteOutput { .. } => 2,
            Error::Interrupted { .. } => 130,
            _ => 1,
        }
    }

    /// `summary.json`'s `status` and `failed_step` of a run that ended with `failure` (or
    /// completed) after `steps_done` steps: `"completed"`, `"failed"` with the step that
    /// failed, or `"interrupted"` (no failed step: every step it took completed).
    ///
    /// ```
    /// use tlsmpm::Error;
    /// assert_eq!(Error::run_outcome(None, 5), ("completed", None));
    /// let stop = Error::Interrupted { step: 5, time: 0.1 };
    /// assert_eq!(Error::run_outcome(Some(&stop), 5), ("interrupted", None));
    /// ```
    pub fn run_outcome(
        failure: Option<&Error>,
        steps_done: usize,
    ) -> (&'static str, Option<usize>) {
        match failure {
            None => ("completed", None),
            Some(Error::Interrupted { .. }) => ("interrupted", None),
            Some(_) => ("failed", Some(steps_done + 1)),
        }
    }

    /// Shorthand for [`Error::WriteOutput`].
    pub fn write(path: &std::path::Path, reason: impl std::fmt::Display) -> Self {
        Error::WriteOutput {
            path: path.to_path_buf(),
            reason: reason.to_string(),
        }
    }
}
