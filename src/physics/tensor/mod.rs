//! Physics of the dimension-generic core (`D` = 1, 2, 3; `docs/dimensions.md`):
//! constitutive laws in tensor form, face boundary conditions, the MUSL / USL
//! Euler–Cromer step with lumped or consistent mass, its stability limit and the time loop.
//!
//! Component loops (`for a in 0..D`) index several small arrays at once, as the formulas
//! do; clippy's `needless_range_loop` is allowed here for that reason.

#![allow(clippy::needless_range_loop)]

pub mod boundary;
pub mod mass;
pub mod material;
pub mod simulation;
pub mod stability;
pub mod step;
pub mod timings;
mod update;

pub use boundary::{FaceConditions, NodeConstraints};
pub use mass::TensorMassSolve;
pub use material::{lame, LinearElasticTensor, NeoHookeanTensor, TensorLaw, TensorMaterial};
pub use simulation::{TensorBodySource, TensorSimulation, TensorTimeStepper, TimeStepping};
pub use step::{TensorStepReport, TensorStepper};
pub use timings::StepTimings;
