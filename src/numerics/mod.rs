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

/// `index as f64` through `i64`: the same value for every index a slice can have (below
/// `isize::MAX`; exact below 2^53), one `cvtsi2sd` on x86_64 where the unsigned conversion
/// takes six instructions. For the node positions and knot spans of the particle loops.
#[inline(always)]
pub(crate) fn index_as_f64(index: usize) -> f64 {
    index as i64 as f64
}
