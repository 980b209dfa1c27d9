//! Saturated two-phase soil (SPEC §1.2, §2.1): the material ([`material`]) and the v–w
//! MUSL step ([`step`]) with a solid and a liquid phase on the same particles.

pub mod material;
pub mod step;

pub use material::TwoPhaseMaterial;
pub use step::{PhaseSolvers, TwoPhaseBoundary, TwoPhaseStepper};
