//! Numerics with no knowledge of the grid or particles: B-spline evaluation, deterministic reductions and the
//! error norms of SPEC §6.

pub mod bspline;
pub mod norms;
pub mod sum;
