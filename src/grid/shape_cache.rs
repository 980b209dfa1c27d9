//! The basis evaluated once per step at the particles, and read back by every pass at the
//! same positions (measurements in `perf/README.md`).
//!
//! Within one 1D step the particles do not move until the last pass, yet four passes need
//! `phi_i(x_p)` and `dphi_i(x_p)`: the mass and force scatter, the particle-velocity
//! update, the momentum scatter and the particle update. For a basis whose evaluation costs
//! more than reading it back ([`Basis::reuse_shapes`]: B-splines of order 2 and higher,
//! GIMP, CPDI) a step fills a [`ShapeCache`] once and the passes take their shapes from it
//! through the [`ShapeSource`] plug point; for the linear hat, recomputing is cheaper than
//! the memory traffic, and the passes evaluate ([`Evaluate`]). Both sources give the same
//! values bit for bit (the cache stores what the evaluation returned). With the direct
//! mapping the particle update refills each slot with the particle's next shape
//! ([`CacheSlots`], [`crate::mapping::next`]), so the next step does not fill the cache.
//!
//! Memory: `W` values and `W` gradients per particle, `W = Basis::max_window()`, plus the
//! first DOF and the support size: `16 W + 9` bytes per particle (57 B for quadratic
//! B-splines, 73 B for cubic ones and for 1D GIMP / CPDI, whose window is 4 nodes). With a
//! fixed support the shape starts at its cell's window, so the passes move only the
//! `16 W` bytes of values and gradients (the first DOF and support are allocated but not
//! used).

use super::basis::shape_dot;
use super::tensor::with_fixed_support;
use super::{Basis, Shape};
use rayon::prelude::*;

/// Evaluate `$body` with `$source` bound to the cache in `$shapes` (`Some`) or to
/// `&$evaluate` (`None`): the dispatch once per pass, each arm a monomorphised copy. Used
/// with [`ShapeCache`] / [`Evaluate`] in 1D and with
/// [`super::TensorShapeCache`] / [`super::EvaluateTensor`] in 2D / 3D.
macro_rules! with_shape_source {
    ($shapes:expr, $evaluate:expr, $source:ident => $body:expr) => {
        match $shapes {
            Some(cache) => {
                let $source = cache;
                $body
            }
            None => {
                let $source = &$evaluate;
                $body
            }
        }
    };
}
pub(crate) use with_shape_source;

/// Particles per rayon task of [`ShapeCache::fill`].
const PARTICLES_PER_TASK: usize = 4096;

/// Where a particle pass takes the shape of particle `p` from.
pub trait ShapeSource: Sync {
    /// The shape of particle `p` at `x` in `cell` with domain half-length `half_length`
    /// ([`Basis::eval_particle_n`] with support `N`).
    fn shape_of<B: Basis, const N: usize>(
        &self,
        basis: &B,
        p: usize,
        cell: usize,
        x: f64,
        half_length: f64,
        shape: &mut Shape,
    );

    /// `values(first, phi)` with the values `phi` of the shape of particle `p` (the same
    /// numbers as [`Self::shape_of`]) and its first DOF, for a pass that needs no gradient.
    /// A cache hands its slot over as it is, without copying the shape out.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn with_values<B: Basis, const N: usize, R>(
        &self,
        basis: &B,
        p: usize,
        cell: usize,
        x: f64,
        half_length: f64,
        shape: &mut Shape,
        values: impl FnOnce(usize, &[f64]) -> R,
    ) -> R {
        self.shape_of::<B, N>(basis, p, cell, x, half_length, shape);
        values(shape.first, &shape.phi[..shape.support::<N>()])
    }
}

/// Evaluate the basis in the pass itself.
#[derive(Clone, Copy, Debug, Default)]
pub struct Evaluate;

impl ShapeSource for Evaluate {
    #[inline(always)]
    fn shape_of<B: Basis, const N: usize>(
        &self,
        basis: &B,
        _p: usize,
        cell: usize,
        x: f64,
        half_length: f64,
        shape: &mut Shape,
    ) {
        basis.eval_particle_n::<N>(cell, x, half_length, shape);
    }
}

/// The shapes of all particles at their current positions, `W` slots each. Read it with
/// the `N` it was filled with (the basis' fixed support, `with_fixed_support!`) or with
/// `N = 0`.
///
/// Filled with a fixed support (`N > 0`), a shape starts at its cell's window
/// ([`Basis::fixed_support`]): `first` and `len` are then neither written nor read, and
/// every read takes them from the cell.
#[derive(Clone, Debug, Default)]
pub struct ShapeCache {
    width: usize,
    /// Filled and stored with a fixed support: `first` / `len` are not kept.
    fixed: bool,
    first: Vec<usize>,
    len: Vec<u8>,
    phi: Vec<f64>,
    dphi: Vec<f64>,
}

impl ShapeCache {
    /// Evaluate `basis` at every particle (`x`, its `cell`, half-length `volume / 2`), in
    /// parallel; the buffers are reused from step to step.
    ///
    /// ```
    /// use tlsmpm::grid::{Basis, BSplineBasis, Grid, Shape, ShapeCache, ShapeSource};
    /// let grid = Grid::new(1.0, 4);
    /// let basis = BSplineBasis::new(grid, 2).unwrap();
    /// let (x, cell, volume) = ([0.1, 0.6], [0, 2], [0.1, 0.1]);
    /// let mut cache = ShapeCache::default();
    /// cache.fill(&basis, &x, &cell, &volume);
    /// let (mut cached, mut direct) = (Shape::default(), Shape::default());
    /// cache.shape_of::<_, 3>(&basis, 1, 2, 0.6, 0.05, &mut cached);
    /// basis.eval(2, 0.6, &mut direct);
    /// assert_eq!((cached.first, cached.phi, cached.dphi), (direct.first, direct.phi, direct.dphi));
    /// ```
    pub fn fill<B: Basis>(&mut self, basis: &B, x: &[f64], cell: &[usize], volume: &[f64]) {
        with_fixed_support!(basis, N => self.fill_n::<B, N>(basis, x, cell, volume));
    }

    fn fill_n<B: Basis, const N: usize>(
        &mut self,
        basis: &B,
        x: &[f64],
        cell: &[usize],
        volume: &[f64],
    ) {
        let n = x.len();
        // A fixed support fills its `N` slots exactly (`N = p + 1 = max_window` for
        // B-splines), so that reads index with the compile-time `N`.
        let width = if N == 0 { basis.max_window() } else { N };
        self.width = width;
        self.fixed = N > 0;
        self.first.resize(n, 0);
        self.len.resize(n, 0);
        self.phi.resize(n * width, 0.0);
        self.dphi.resize(n * width, 0.0);
        let block = PARTICLES_PER_TASK;
        (
            self.first.par_chunks_mut(block),
            self.len.par_chunks_mut(block),
            self.phi.par_chunks_mut(block * width),
            self.dphi.par_chunks_mut(block * width),
        )
            .into_par_iter()
            .enumerate()
            .for_each(|(chunk, (first, len, phi, dphi))| {
                let start = chunk * block;
                let mut shape = Shape::default();
                let mut slots = CacheSlots {
                    width,
                    first,
                    len,
                    phi,
                    dphi,
                };
                for k in 0..slots.first.len() {
                    let p = start + k;
                    basis.eval_particle_n::<N>(cell[p], x[p], 0.5 * volume[p], &mut shape);
                    slots.store::<N>(k, &shape);
                }
            });
    }

    /// The first DOF and the support of particle `p`'s shape in cell `cell`: from the
    /// cell's window when filled with a fixed support, else as stored.
    #[inline(always)]
    fn first_and_len<B: Basis>(&self, basis: &B, p: usize, cell: usize) -> (usize, usize) {
        if self.fixed {
            (basis.cell_window(cell).0, self.width)
        } else {
            (self.first[p], usize::from(self.len[p]))
        }
    }

    /// The number of particles the cache holds shapes of.
    pub fn len(&self) -> usize {
        self.first.len()
    }

    /// Whether the cache holds no shape.
    pub fn is_empty(&self) -> bool {
        self.first.is_empty()
    }

    /// The filled cache cut into the slots of consecutive tasks of `per_task` particles,
    /// for a pass that reads each particle's shape and stores a new one in its place (the
    /// particle update mapping the next step, [`crate::mapping::next`]).
    pub fn task_slots(
        &mut self,
        per_task: usize,
    ) -> impl IndexedParallelIterator<Item = CacheSlots<'_>> {
        let width = self.width.max(1);
        (
            self.first.par_chunks_mut(per_task),
            self.len.par_chunks_mut(per_task),
            self.phi.par_chunks_mut(per_task * width),
            self.dphi.par_chunks_mut(per_task * width),
        )
            .into_par_iter()
            .map(move |(first, len, phi, dphi)| CacheSlots {
                width,
                first,
                len,
                phi,
                dphi,
            })
    }
}

/// The shape slots of a run of consecutive particles of a [`ShapeCache`], indexed from 0:
/// contract a particle's shape with a grid field ([`CacheSlots::dots`]) and store a new
/// one in its place ([`CacheSlots::store`]), with the `N` the cache is filled with (or
/// `N = 0`).
pub struct CacheSlots<'a> {
    width: usize,
    first: &'a mut [usize],
    len: &'a mut [u8],
    phi: &'a mut [f64],
    dphi: &'a mut [f64],
}

impl CacheSlots<'_> {
    /// `(phi^T g, dphi^T g)` of the shape in slot `k` against the grid field `g` (the
    /// gradient only when `gradient`, else 0), read straight from the slot: bitwise
    /// [`Shape::interpolate_n`] and [`Shape::gradient_n`] of the loaded shape.
    ///
    /// `cell` is the particle's cell. With a fixed support (`N > 0`) the shape starts at the
    /// cell's window ([`Basis::fixed_support`]), so its first DOF is not read back: a
    /// stream of 8 bytes per particle less.
    #[inline(always)]
    pub fn dots<B: Basis, const N: usize>(
        &self,
        basis: &B,
        k: usize,
        cell: usize,
        g: &[f64],
        gradient: bool,
    ) -> (f64, f64) {
        let first = if N == 0 {
            self.first[k]
        } else {
            basis.cell_window(cell).0
        };
        // `[at..][..n]` rather than `[at..at + n]`: with `n = N` the slices then have a
        // length known at compile time and the dots unroll (same sums, same order).
        let (phi, dphi) = if N == 0 {
            let (at, n) = (k * self.width, usize::from(self.len[k]));
            (&self.phi[at..][..n], &self.dphi[at..][..n])
        } else {
            debug_assert_eq!(N, self.width, "read with the support it was filled with");
            // Slot `k` as an `[f64; N]`: one bound per field.
            (
                &self.phi.as_chunks::<N>().0[k][..],
                &self.dphi.as_chunks::<N>().0[k][..],
            )
        };
        let g = &g[first..][..phi.len()];
        let interpolated = shape_dot(phi, g);
        let slope = if gradient { shape_dot(dphi, g) } else { 0.0 };
        (interpolated, slope)
    }

    /// Store `shape` (of support `N`, or `shape.len` when `N = 0`) in slot `k`.
    #[inline(always)]
    pub fn store<const N: usize>(&mut self, k: usize, shape: &Shape) {
        let support = shape.support::<N>();
        if N == 0 {
            self.first[k] = shape.first;
            self.len[k] = support as u8;
            let at = k * self.width;
            self.phi[at..][..support].copy_from_slice(&shape.phi[..support]);
            self.dphi[at..][..support].copy_from_slice(&shape.dphi[..support]);
        } else {
            debug_assert_eq!(N, self.width, "stored with the support it was filled with");
            // A fixed support starts at the cell's window: no `first` / `len` to keep
            // (`ShapeCache::fixed`).
            // Slot `k` as an `[f64; N]`: one bound per field.
            self.phi.as_chunks_mut::<N>().0[k].copy_from_slice(&shape.phi[..N]);
            self.dphi.as_chunks_mut::<N>().0[k].copy_from_slice(&shape.dphi[..N]);
        }
    }
}

impl ShapeSource for ShapeCache {
    #[inline(always)]
    fn shape_of<B: Basis, const N: usize>(
        &self,
        basis: &B,
        p: usize,
        cell: usize,
        _x: f64,
        _half_length: f64,
        shape: &mut Shape,
    ) {
        debug_assert!(
            N == 0 || (N == self.width && self.fixed),
            "read with the support it was filled with"
        );
        if N == 0 {
            let (first, support) = self.first_and_len(basis, p, cell);
            shape.first = first;
            let slots = p * self.width..p * self.width + support;
            shape.len = support;
            shape.phi[..support].copy_from_slice(&self.phi[slots.clone()]);
            shape.dphi[..support].copy_from_slice(&self.dphi[slots]);
        } else {
            // Filled with the same `N`: `width == N` (see `fill_n`).
            shape.first = basis.cell_window(cell).0;
            shape.len = N;
            shape.phi[..N].copy_from_slice(&self.phi.as_chunks::<N>().0[p]);
            shape.dphi[..N].copy_from_slice(&self.dphi.as_chunks::<N>().0[p]);
        }
    }

    /// The slot itself: no copy into `shape` (which is left as it was).
    #[inline(always)]
    fn with_values<B: Basis, const N: usize, R>(
        &self,
        basis: &B,
        p: usize,
        cell: usize,
        _x: f64,
        _half_length: f64,
        _shape: &mut Shape,
        values: impl FnOnce(usize, &[f64]) -> R,
    ) -> R {
        debug_assert!(
            N == 0 || (N == self.width && self.fixed),
            "read with the support it was filled with"
        );
        if N == 0 {
            let (first, support) = self.first_and_len(basis, p, cell);
            values(first, &self.phi[p * self.width..][..support])
        } else {
            values(
                basis.cell_window(cell).0,
                &self.phi.as_chunks::<N>().0[p][..],
            )
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{BSplineBasis, CpdiBasis, GimpBasis, Grid, LinearBasis};
    use proptest::prelude::*;

    /// The cache returns bitwise what the evaluation returns, for fixed (B-spline) and
    /// variable (CPDI) supports.
    fn check<B: Basis>(basis: &B, grid: &Grid, x: &[f64], volume: &[f64]) {
        let cell: Vec<usize> = x.iter().map(|&x| grid.cell_of(x).unwrap()).collect();
        let mut cache = ShapeCache::default();
        cache.fill(basis, x, &cell, volume);
        for p in 0..x.len() {
            let (mut cached, mut direct) = (Shape::default(), Shape::default());
            cache.shape_of::<B, 0>(basis, p, cell[p], x[p], 0.5 * volume[p], &mut cached);
            basis.eval_particle(cell[p], x[p], 0.5 * volume[p], &mut direct);
            assert_eq!((cached.first, cached.len), (direct.first, direct.len));
            let n = direct.len;
            assert_eq!(cached.phi[..n], direct.phi[..n]);
            assert_eq!(cached.dphi[..n], direct.dphi[..n]);
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn cached_shapes_equal_evaluated_ones(
            cells in 1usize..30,
            order in 1usize..6,
            t in proptest::collection::vec(0.0f64..=1.0, 1..9000),
            l in 0.0f64..1.5,
        ) {
            let grid = Grid::new(2.0, cells);
            let x: Vec<f64> = t.iter().map(|t| t * grid.length).collect();
            let volume = vec![2.0 * l * grid.h; x.len()];
            check(&BSplineBasis::new(grid, order).unwrap(), &grid, &x, &volume);
            check(&CpdiBasis::new(grid), &grid, &x, &volume);
        }

        /// The contract the fixed-support reads rely on (`CacheSlots::dots`,
        /// `ShapeCache::with_values`): a basis with a fixed support starts every particle
        /// shape at its cell's window, at the grid's ends and for point-sized domains too.
        #[test]
        fn fixed_support_shapes_start_at_the_cell_window(
            cells in 1usize..30,
            order in 1usize..6,
            t in proptest::collection::vec(0.0f64..=1.0, 1..200),
            l in 0.0f64..1.5,
        ) {
            fn starts<B: Basis>(basis: &B, grid: &Grid, x: &[f64], half: f64) -> Result<(), TestCaseError> {
                let Some(n) = basis.fixed_support() else { return Ok(()) };
                for &x in x {
                    let cell = grid.cell_of(x).unwrap();
                    let mut shape = Shape::default();
                    basis.eval_particle(cell, x, half, &mut shape);
                    prop_assert_eq!((shape.first, shape.len), (basis.cell_window(cell).0, n));
                }
                Ok(())
            }
            let grid = Grid::new(2.0, cells);
            let x: Vec<f64> = t.iter().map(|t| t * grid.length).collect();
            let half = l * grid.h;
            starts(&BSplineBasis::new(grid, order).unwrap(), &grid, &x, half)?;
            starts(&CpdiBasis::new(grid), &grid, &x, half)?;
            starts(&GimpBasis::new(grid), &grid, &x, half)?;
            starts(&LinearBasis::new(grid), &grid, &x, half)?;
        }
    }
}
