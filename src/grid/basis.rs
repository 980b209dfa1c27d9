//! The [`Basis`] trait: the grid functions `phi_i` and the gradients used for internal
//! forces and strains (SPEC §3).
//!
//! A basis evaluates, for a point in a given cell, all its non-zero functions at once into a
//! stack-allocated [`Shape`] (no allocation per particle). Kernels are generic over the
//! basis, so the evaluation is monomorphised and inlined in the particle loops.

use super::Grid;

/// Most non-zero functions a basis may have at one point (B-splines up to order 15).
pub const MAX_SUPPORT: usize = 16;

/// The non-zero grid functions at one point: `phi[k]`, `dphi[k]` belong to DOF `first + k`,
/// `k < len`.
#[derive(Clone, Copy, Debug)]
pub struct Shape {
    pub first: usize,
    pub len: usize,
    pub phi: [f64; MAX_SUPPORT],
    pub dphi: [f64; MAX_SUPPORT],
}

impl Default for Shape {
    fn default() -> Self {
        Self {
            first: 0,
            len: 0,
            phi: [0.0; MAX_SUPPORT],
            dphi: [0.0; MAX_SUPPORT],
        }
    }
}

impl Shape {
    /// `sum_k phi_k g[first + k]`: interpolate a grid field.
    #[inline]
    pub fn interpolate(&self, grid_field: &[f64]) -> f64 {
        self.interpolate_n::<0>(grid_field)
    }

    /// [`Shape::interpolate`] over exactly `N` functions (`N = 0`: `len`), for shapes from
    /// [`Basis::eval_particle_n`]: the same operations in the same order, unrolled.
    #[inline(always)]
    pub fn interpolate_n<const N: usize>(&self, grid_field: &[f64]) -> f64 {
        self.dot_n::<N>(&self.phi, grid_field)
    }

    /// [`Shape::gradient`] over exactly `N` functions (`N = 0`: `len`).
    #[inline(always)]
    pub fn gradient_n<const N: usize>(&self, grid_field: &[f64]) -> f64 {
        self.dot_n::<N>(&self.dphi, grid_field)
    }

    /// `sum_k functions_k g[first + k]` over [`Self::support`] functions.
    #[inline(always)]
    fn dot_n<const N: usize>(&self, functions: &[f64; MAX_SUPPORT], grid_field: &[f64]) -> f64 {
        let n = self.support::<N>();
        shape_dot(&functions[..n], &grid_field[self.first..self.first + n])
    }

    /// The number of functions a loop over a shape from [`Basis::eval_particle_n`] runs
    /// over: `N`, known at compile time, or `len` when `N = 0`.
    #[inline(always)]
    pub fn support<const N: usize>(&self) -> usize {
        if N == 0 {
            self.len
        } else {
            N
        }
    }

    /// `sum_k dphi_k g[first + k]`: the gradient of a grid field.
    #[inline]
    pub fn gradient(&self, grid_field: &[f64]) -> f64 {
        self.gradient_n::<0>(grid_field)
    }
}

/// `sum_k functions_k g_k` in index order: the one contraction of a shape with a grid
/// field ([`Shape::interpolate_n`], [`Shape::gradient_n`], and the passes that read shapes
/// straight from a [`super::ShapeCache`]), so that every path sums the same bits.
///
/// ```
/// assert_eq!(tlsmpm::grid::basis::shape_dot(&[0.25, 0.75], &[2.0, 4.0]), 3.5);
/// ```
#[inline(always)]
pub fn shape_dot(functions: &[f64], g: &[f64]) -> f64 {
    functions.iter().zip(g).map(|(p, v)| p * v).sum()
}

/// Grid functions on a 1D background grid.
pub trait Basis: Sync + Send {
    /// Name as in the scenario key `method.basis`.
    fn name(&self) -> &'static str;

    /// Number of grid DOFs `N_n`.
    fn num_dofs(&self) -> usize;

    /// The DOF window `(first, len)` that any point of cell `cell` can touch; per-cell
    /// scatter buffers have this size.
    fn cell_window(&self, cell: usize) -> (usize, usize);

    /// The largest `len` of any [`Basis::cell_window`].
    fn max_window(&self) -> usize;

    /// Evaluate the non-zero functions and gradients at `x`, which lies in cell `cell`.
    fn eval(&self, cell: usize, x: f64, shape: &mut Shape);

    /// Evaluate at a particle whose domain is `[x - half_length, x + half_length]`
    /// (`half_length = V_p / 2` in 1D). Point bases ignore the domain (the default);
    /// GIMP and CPDI average over it.
    #[inline]
    fn eval_particle(&self, cell: usize, x: f64, half_length: f64, shape: &mut Shape) {
        let _ = half_length;
        self.eval(cell, x, shape);
    }

    /// [`Basis::eval_particle`] in a loop compiled for the fixed support `N`
    /// ([`Basis::fixed_support`]; `N = 0`: run-time support). Bases with a fixed support
    /// may override it with an evaluation specialised for `N` (the same values, bit for
    /// bit); the default is [`Basis::eval_particle`].
    #[inline(always)]
    fn eval_particle_n<const N: usize>(
        &self,
        cell: usize,
        x: f64,
        half_length: f64,
        shape: &mut Shape,
    ) {
        self.eval_particle(cell, x, half_length, shape);
    }

    /// Whether [`Basis::update`] must run before every step (bases that depend on the
    /// particle configuration, like the DDMPM gradient).
    fn depends_on_particles(&self) -> bool {
        false
    }

    /// Recompute what depends on the particle configuration. Default: nothing.
    fn update(&mut self, quadrature: ParticleQuadrature<'_>) {
        let _ = quadrature;
    }

    /// Whether a step should evaluate this basis once per particle and read the values
    /// back in every pass at the same positions ([`super::ShapeCache`]) rather than
    /// evaluate in each pass: `true` where an evaluation costs more than reading its
    /// `2 W` values back from memory. Default: `false` (cheap bases like the linear hat).
    fn reuse_shapes(&self) -> bool {
        false
    }

    /// `Some(n)` when every evaluation has exactly `n` non-zero functions (`Shape::len`),
    /// so that particle loops can be compiled for that support size; `None` (the default)
    /// when it varies (DDMPM; GIMP and CPDI on grids of fewer than three cells).
    ///
    /// A basis with a fixed support also starts every particle shape in cell `cell` at the
    /// cell's window, `Shape::first == self.cell_window(cell).0` (the shape cache relies on
    /// it and does not read `first` back).
    fn fixed_support(&self) -> Option<usize> {
        None
    }

    /// The DOFs on the left and right ends of the domain (for Dirichlet conditions).
    fn boundary_dofs(&self) -> (usize, usize) {
        (0, self.num_dofs() - 1)
    }
}

/// The particle configuration as a quadrature rule: points `x`, weights `volume`, sorted by
/// cell with the particles of cell `e` at `cell_start[e]..cell_start[e + 1]`.
#[derive(Clone, Copy, Debug)]
pub struct ParticleQuadrature<'a> {
    pub x: &'a [f64],
    pub volume: &'a [f64],
    pub cell_start: &'a [usize],
}

impl ParticleQuadrature<'_> {
    /// The particles of cell `cell`.
    #[inline]
    pub fn range(&self, cell: usize) -> std::ops::Range<usize> {
        self.cell_start[cell]..self.cell_start[cell + 1]
    }

    /// Number of cells.
    pub fn cells(&self) -> usize {
        self.cell_start.len().saturating_sub(1)
    }

    /// The material extent `[min_p (x_p - V_p/2), max_p (x_p + V_p/2)]` (parallel min/max,
    /// exact and order independent).
    pub fn material_extent(&self) -> (f64, f64) {
        use rayon::prelude::*;
        let (x, volume) = (self.x, self.volume);
        // Plain comparisons (not f64::min/max) let the loop vectorise.
        x.par_chunks(4096)
            .zip(volume.par_chunks(4096))
            .map(|(x, volume)| {
                let (mut bottom, mut top) = (f64::INFINITY, f64::NEG_INFINITY);
                for (&x, &v) in x.iter().zip(volume) {
                    let (lo, hi) = (x - 0.5 * v, x + 0.5 * v);
                    bottom = if lo < bottom { lo } else { bottom };
                    top = if hi > top { hi } else { top };
                }
                (bottom, top)
            })
            .reduce(
                || (f64::INFINITY, f64::NEG_INFINITY),
                |a, b| (a.0.min(b.0), a.1.max(b.1)),
            )
    }

    /// The active part `[lo, hi]` of cell `cell` of `grid`: the cell clipped to the
    /// material `extent`, or `None` when the cell holds no particle or nothing is left.
    ///
    /// ```
    /// use tlsmpm::grid::{Grid, ParticleQuadrature};
    /// let grid = Grid::new(1.0, 2);
    /// let q = ParticleQuadrature { x: &[0.1, 0.6], volume: &[0.2, 0.2], cell_start: &[0, 1, 2] };
    /// let extent = q.material_extent();
    /// assert_eq!(q.active_part(&grid, 1, extent), Some((0.5, 0.7)));
    /// ```
    #[inline]
    pub fn active_part(&self, grid: &Grid, cell: usize, extent: (f64, f64)) -> Option<(f64, f64)> {
        let left = grid.cell_left(cell);
        let right = left + grid.h;
        let lo = if extent.0 > left { extent.0 } else { left };
        let hi = if extent.1 < right { extent.1 } else { right };
        (!self.range(cell).is_empty() && hi > lo).then_some((lo, hi))
    }
}
