//! The application layer: building a simulation from a scenario (the one place where the
//! configuration is dispatched to concrete basis / mapping types), running it with its
//! outputs, convergence studies, the built-in scenarios, and the function-reconstruction
//! benchmark (`tlsmpm reconstruct`), and overlays of one field from several runs
//! (`tlsmpm overlay`).

pub mod build;
pub mod builtin;
pub mod memory;
pub mod overlay;
pub mod reconstruct;
pub mod reproduce;
pub mod run;
pub mod solver_study;
pub mod solvers;
pub mod study;
pub mod tensor_run;
mod tensor_vtk;
pub mod warnings;

pub use build::build_simulation;
pub use overlay::{overlay, OverlayOptions};
pub use reconstruct::{reconstruct, ReconstructionReport};
pub use run::{run, RunOptions};
pub use study::{study, StudyRow};
