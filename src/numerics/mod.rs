//! Numerics with no knowledge of the grid or particles: B-spline evaluation, Gauss–Legendre
//! rules, Taylor least-squares fits, cubic splines, deterministic reductions and the error
//! norms of SPEC §6.

pub mod bspline;
pub mod cubic_spline;
pub mod gauss;
pub mod norms;
pub mod sum;
pub mod taylor;
pub mod taylor_nd;
