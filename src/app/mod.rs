//! The application layer: building a simulation from a scenario (the one place where the
//! configuration is dispatched to concrete basis / mapping types), running it with its
//! outputs, convergence studies, and the built-in scenarios.

pub mod build;
pub mod builtin;
pub mod run;
pub mod study;

pub use build::build_simulation;
pub use run::{run, RunOptions};
pub use study::{study, StudyRow};
