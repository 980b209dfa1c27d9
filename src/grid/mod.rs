//! The background grid and its bases (SPEC §3).
//!
//! [`Grid`] is the uniform 1D mesh of `N_e` cells (knot spans) on `[origin, origin + L]`;
//! [`Basis`] is the plug point for the grid functions: linear hats ([`LinearBasis`]), the
//! dual-domain gradient ([`DdmpmBasis`]), B-splines of any order ([`BSplineBasis`]), and the
//! particle-domain bases GIMP ([`GimpBasis`]) and CPDI ([`CpdiBasis`]).

pub mod basis;
pub mod bspline;
pub mod cpdi;
pub mod ddmpm;
mod domain;
pub mod gimp;
pub mod linear;
pub mod shape_cache;
pub mod tensor;
pub mod tensor_shape_cache;

use crate::numerics::index_as_f64;
pub use basis::{Basis, ParticleQuadrature, Shape, MAX_SUPPORT};
pub use bspline::BSplineBasis;
pub use cpdi::CpdiBasis;
pub use ddmpm::DdmpmBasis;
pub use gimp::GimpBasis;
pub use linear::LinearBasis;
pub use shape_cache::{CacheSlots, Evaluate, ShapeCache, ShapeSource};
pub use tensor::{TensorBasis, TensorGrid, TensorShape};
pub use tensor_shape_cache::{EvaluateTensor, ShapeSlots, TensorShapeCache, TensorShapeSource};

/// A uniform 1D grid of `cells` cells of size `h` starting at `origin`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    pub origin: f64,
    pub length: f64,
    pub cells: usize,
    /// Cell size `h = length / cells`.
    pub h: f64,
    /// `1 / h`.
    pub inv_h: f64,
}

impl Grid {
    /// A grid of `cells` equal cells on `[0, length]`.
    pub fn new(length: f64, cells: usize) -> Self {
        Self {
            origin: 0.0,
            length,
            cells,
            h: length / cells as f64,
            inv_h: cells as f64 / length,
        }
    }

    /// Left end of cell `cell`.
    #[inline]
    pub fn cell_left(&self, cell: usize) -> f64 {
        self.origin + index_as_f64(cell) * self.h
    }

    /// The cell containing `x`, or `None` outside `[origin, origin + length]`. The right end
    /// belongs to the last cell; a point on an interior face belongs to the cell on its right.
    ///
    /// ```
    /// let g = tlsmpm::grid::Grid::new(1.0, 4);
    /// assert_eq!(g.cell_of(0.3), Some(1));
    /// assert_eq!(g.cell_of(1.0), Some(3));
    /// assert_eq!(g.cell_of(1.1), None);
    /// ```
    #[inline]
    pub fn cell_of(&self, x: f64) -> Option<usize> {
        let xi = (x - self.origin) * self.inv_h;
        // One comparison pair also rejects NaN; the cell count and the in-range `xi`
        // convert through `i64` (one instruction each) rather than `u64` (a fix-up
        // sequence on x86-64): the same cell.
        let cells = self.cells as i64;
        if !(xi >= 0.0 && xi <= cells as f64) {
            return None;
        }
        Some((xi as i64).min(cells - 1) as usize)
    }
}

#[cfg(test)]
mod tests {
    use super::Grid;
    use proptest::prelude::*;

    /// `cell_of` as the definition reads: `floor((x - origin) / h)` clamped to the last
    /// cell on the right end, `None` outside `[origin, origin + length]` and for NaN.
    fn cell_by_definition(g: &Grid, x: f64) -> Option<usize> {
        let xi = (x - g.origin) * g.inv_h;
        if xi.is_nan() || xi < 0.0 || xi > g.cells as f64 {
            return None;
        }
        Some((xi.floor() as usize).min(g.cells - 1))
    }

    proptest! {
        #[test]
        fn cell_of_is_the_floor_of_the_scaled_coordinate(
            cells in 1usize..100_000,
            length in 0.01f64..100.0,
            t in -0.1f64..1.1,
        ) {
            let g = Grid::new(length, cells);
            let x = t * length;
            prop_assert_eq!(g.cell_of(x), cell_by_definition(&g, x));
            for edge in [0.0, length, -0.0, f64::NAN, f64::INFINITY, -f64::INFINITY] {
                prop_assert_eq!(g.cell_of(edge), cell_by_definition(&g, edge));
            }
        }
    }
}
