//! Numerics with no knowledge of the grid or particles: deterministic reductions and the
//! error norms of SPEC §6.

pub mod norms;
pub mod sum;
