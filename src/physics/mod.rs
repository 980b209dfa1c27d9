//! Physics: constitutive laws (SPEC §1.1), boundary conditions, the one-phase MUSL/USL
//! Euler–Cromer step (SPEC §2), the two-phase MUSL step (SPEC §1.2, §2.1, [`two_phase`])
//! and the time loop with its diagnostics.

pub mod body;
pub mod boundary;
pub mod distributed;
pub mod mass;
pub mod material;
pub mod simulation;
pub mod stability;
pub mod step;
pub mod tensor;
pub mod two_phase;
pub(crate) mod update;
pub(crate) mod velocity;

pub use body::{Body, BodySource};
pub use boundary::Boundary;
pub use mass::{MassSystem, SolverTotals};
pub use material::{ConstitutiveLaw, Hill, LinearElastic, Material, NeoHookean};
pub use simulation::{HistoryRow, Simulation};
pub use step::{StepReport, Stepper};
