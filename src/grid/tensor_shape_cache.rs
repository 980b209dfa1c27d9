//! The tensor-product basis evaluated once per 2D / 3D step and read back by the later
//! passes at the same positions (`docs/dimensions.md`; measurements in `perf/README.md`).
//!
//! Within one step of the dimension-generic core the particles do not move until the last
//! pass, yet three passes need the `D` one-dimensional shapes `phi^a_i(x_a)`,
//! `dphi^a_i(x_a)` of every particle: the mass and force scatter, the particle-velocity
//! update with the momentum scatter (MUSL; the momentum scatter in USL) and the particle
//! update. For bases whose evaluation costs more than reading it back
//! ([`crate::grid::Basis::reuse_shapes`]: B-splines of order 2 and higher, GIMP) the first
//! pass stores each particle's shape in a [`TensorShapeCache`] as it evaluates it, and the
//! later passes take it from there through the [`TensorShapeSource`] plug point; other bases
//! evaluate in every pass ([`EvaluateTensor`]). Both sources give the same values bit for
//! bit (the cache stores what the evaluation returned), so a run's output does not depend
//! on the choice.
//!
//! Memory per particle: `D` first-node indices (`u32`) and `2 N D` values, `N` the fixed
//! support of the basis: 104 bytes in 2D and 156 in 3D for quadratic B-splines.
//!
//! Large caches (at least [`STREAMING_BYTES`] of values) are written with non-temporal
//! stores on x86_64: by the time a later pass reads a particle's shape back, the other
//! particle arrays have streamed through the caches, so loading each line before
//! overwriting it (the write-allocate read of an ordinary store) is wasted memory
//! traffic — about 12% of a 2D quadratic B-spline step's. Smaller caches stay in the CPU
//! caches between the passes and keep ordinary stores. The bits stored are the same either
//! way. (Measured in `perf/README.md`: +3% at 10⁶ particles in 2D, −12% if 10⁵
//! particles were streamed.)

use super::{Basis, TensorBasis, TensorShape};
use std::ops::Range;

/// Size of the cached values from which [`ShapeSlots::store`] writes with non-temporal
/// stores (64 MiB: about 6·10⁵ particles in 2D and 4·10⁵ in 3D with quadratic
/// B-splines; well above the per-core share of a server's last-level cache).
pub const STREAMING_BYTES: usize = 64 << 20;

/// Where a particle pass of the dimension-generic core takes particle `k`'s shape from.
pub trait TensorShapeSource<const D: usize>: Sync {
    /// The shape of particle `k` at `x` with domain half-lengths `half_length`
    /// ([`TensorBasis::eval_particle_n`] with support `N`, in the cell that contains `x`).
    fn shape_of<B: Basis, const N: usize>(
        &self,
        basis: &TensorBasis<D, B>,
        k: usize,
        x: [f64; D],
        half_length: [f64; D],
        shape: &mut TensorShape<D>,
    );
}

/// Evaluate the basis in the pass itself.
#[derive(Clone, Copy, Debug, Default)]
pub struct EvaluateTensor;

impl<const D: usize> TensorShapeSource<D> for EvaluateTensor {
    #[inline(always)]
    fn shape_of<B: Basis, const N: usize>(
        &self,
        basis: &TensorBasis<D, B>,
        _k: usize,
        x: [f64; D],
        half_length: [f64; D],
        shape: &mut TensorShape<D>,
    ) {
        basis.eval_particle_n::<N>(basis.grid.axis_cells(x), x, half_length, shape);
    }
}

/// The shapes of all particles at their positions of the current step, for a basis of
/// fixed support `N` per axis: per particle the first node of each axis and, axis by
/// axis, the `N` values then the `N` derivatives.
#[derive(Clone, Debug)]
pub struct TensorShapeCache<const D: usize> {
    support: usize,
    /// Whether [`ShapeSlots::store`] bypasses the caches (values of at least
    /// `streaming_bytes`).
    streaming: bool,
    /// [`STREAMING_BYTES`] (changed by tests only).
    streaming_bytes: usize,
    first: Vec<[u32; D]>,
    values: Vec<f64>,
}

/// The slots of a contiguous range of particles, to be filled by one task
/// ([`TensorShapeCache::slots`]).
#[derive(Debug)]
pub struct ShapeSlots<'a, const D: usize> {
    start: usize,
    streaming: bool,
    first: &'a mut [[u32; D]],
    values: &'a mut [f64],
}

impl<const D: usize> Default for TensorShapeCache<D> {
    fn default() -> Self {
        Self {
            support: 0,
            streaming: false,
            streaming_bytes: STREAMING_BYTES,
            first: Vec::new(),
            values: Vec::new(),
        }
    }
}

impl<const D: usize> TensorShapeCache<D> {
    /// A cache that streams its stores from `bytes` of values on (tests of both paths).
    #[cfg(test)]
    fn streaming_from(bytes: usize) -> Self {
        Self {
            streaming_bytes: bytes,
            ..Self::default()
        }
    }

    /// Room for `particles` shapes of support `support` per axis (buffers reused).
    pub fn resize(&mut self, particles: usize, support: usize) {
        self.support = support;
        self.first.resize(particles, [0; D]);
        self.values.resize(particles * 2 * support * D, 0.0);
        self.streaming = std::mem::size_of_val(self.values.as_slice()) >= self.streaming_bytes;
    }

    /// Disjoint slots for the particle ranges `ranges`, which must be consecutive and
    /// start at 0 (as the tasks of a scatter are).
    pub fn slots(&mut self, ranges: &[Range<usize>]) -> Vec<ShapeSlots<'_, D>> {
        let per_particle = 2 * self.support * D;
        let mut slots = Vec::with_capacity(ranges.len());
        let (mut first, mut values) = (self.first.as_mut_slice(), self.values.as_mut_slice());
        let mut next = 0;
        for r in ranges {
            debug_assert_eq!(r.start, next, "ranges must be consecutive from 0");
            let (f, f_rest) = std::mem::take(&mut first).split_at_mut(r.len());
            let (v, v_rest) = std::mem::take(&mut values).split_at_mut(r.len() * per_particle);
            slots.push(ShapeSlots {
                start: r.start,
                streaming: self.streaming,
                first: f,
                values: v,
            });
            (first, values) = (f_rest, v_rest);
            next = r.end;
        }
        slots
    }

    /// [`Self::slots`] for a pass that reads each particle's shape from its slot and then
    /// stores the particle's next shape there ([`ShapeSlots`] is a [`TensorShapeSource`]
    /// of its own range): ordinary stores, since the line was just read.
    pub fn slots_in_place(&mut self, ranges: &[Range<usize>]) -> Vec<ShapeSlots<'_, D>> {
        let mut slots = self.slots(ranges);
        for slot in &mut slots {
            slot.streaming = false;
        }
        slots
    }
}

impl<const D: usize> ShapeSlots<'_, D> {
    /// Store the shape of particle `k` (in this slot's range), support `N` per axis.
    #[inline(always)]
    pub fn store<const N: usize>(&mut self, k: usize, shape: &TensorShape<D>) {
        let i = k - self.start;
        let values = &mut self.values[i * 2 * N * D..(i + 1) * 2 * N * D];
        for (a, axis) in shape.axes.iter().enumerate() {
            self.first[i][a] = axis.first as u32;
            let slot = &mut values[2 * N * a..2 * N * (a + 1)];
            if self.streaming {
                stream(&mut slot[..N], &axis.phi[..N]);
                stream(&mut slot[N..], &axis.dphi[..N]);
            } else {
                slot[..N].copy_from_slice(&axis.phi[..N]);
                slot[N..].copy_from_slice(&axis.dphi[..N]);
            }
        }
    }

    /// Orders the streaming stores of [`Self::store`] before the slots are handed back.
    #[inline]
    pub fn finish(&mut self) {
        #[cfg(target_arch = "x86_64")]
        if self.streaming {
            // SAFETY: `sfence` has no preconditions (SSE, part of the x86_64 baseline).
            unsafe { std::arch::x86_64::_mm_sfence() }
        }
    }
}

/// `target.copy_from_slice(source)` with stores that bypass the caches where the target
/// supports them (x86_64 `movnti`): the cache is read back a pass later, after the other
/// particle arrays have streamed through, so reading its lines before writing them is
/// wasted bandwidth.
#[inline(always)]
fn stream(target: &mut [f64], source: &[f64]) {
    assert_eq!(target.len(), source.len());
    #[cfg(target_arch = "x86_64")]
    for (t, s) in target.iter_mut().zip(source) {
        // SAFETY: `t` is a valid, aligned, exclusively borrowed `f64` (8 bytes, the size of
        // `i64`); `movnti` is part of SSE2, in the x86_64 baseline.
        unsafe {
            std::arch::x86_64::_mm_stream_si64((t as *mut f64).cast::<i64>(), s.to_bits() as i64);
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    target.copy_from_slice(source);
}

impl<const D: usize> TensorShapeSource<D> for TensorShapeCache<D> {
    /// Particle `k`'s stored shape; `N` must be the support it was stored with.
    #[inline(always)]
    fn shape_of<B: Basis, const N: usize>(
        &self,
        _basis: &TensorBasis<D, B>,
        k: usize,
        _x: [f64; D],
        _half_length: [f64; D],
        shape: &mut TensorShape<D>,
    ) {
        debug_assert_eq!(N, self.support, "read with the support it was stored with");
        read_slot::<D, N>(&self.first, &self.values, k, shape);
    }
}

impl<const D: usize> TensorShapeSource<D> for ShapeSlots<'_, D> {
    /// Particle `k`'s shape as stored in this slot (`k` in the slot's range).
    #[inline(always)]
    fn shape_of<B: Basis, const N: usize>(
        &self,
        _basis: &TensorBasis<D, B>,
        k: usize,
        _x: [f64; D],
        _half_length: [f64; D],
        shape: &mut TensorShape<D>,
    ) {
        read_slot::<D, N>(self.first, self.values, k - self.start, shape);
    }
}

/// The shape stored at index `i` of `first` / `values` (support `N` per axis).
#[inline(always)]
fn read_slot<const D: usize, const N: usize>(
    first: &[[u32; D]],
    values: &[f64],
    i: usize,
    shape: &mut TensorShape<D>,
) {
    let first = first[i];
    let values = &values[i * 2 * N * D..(i + 1) * 2 * N * D];
    for (a, axis) in shape.axes.iter_mut().enumerate() {
        let slot = &values[2 * N * a..2 * N * (a + 1)];
        axis.first = first[a] as usize;
        axis.len = N;
        axis.phi[..N].copy_from_slice(&slot[..N]);
        axis.dphi[..N].copy_from_slice(&slot[N..]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{BSplineBasis, GimpBasis, TensorGrid};
    use proptest::prelude::*;

    /// Store the evaluation at each point, read it back, compare bit for bit.
    fn round_trip<B: Basis + Clone, const N: usize>(
        basis: &TensorBasis<2, B>,
        points: &[([f64; 2], [f64; 2])],
    ) {
        // Ordinary stores, then streaming ones (every cache size streams from 0 bytes).
        for streaming_bytes in [STREAMING_BYTES, 0] {
            round_trip_with::<B, N>(basis, points, streaming_bytes);
        }
    }

    fn round_trip_with<B: Basis + Clone, const N: usize>(
        basis: &TensorBasis<2, B>,
        points: &[([f64; 2], [f64; 2])],
        streaming_bytes: usize,
    ) {
        let n = points.len();
        let mut cache = TensorShapeCache::<2>::streaming_from(streaming_bytes);
        cache.resize(n, N);
        assert_eq!(cache.streaming, streaming_bytes == 0);
        let half = n / 2;
        {
            let mut slots = cache.slots(&[0..half, half..n]);
            for (k, &(x, l)) in points.iter().enumerate() {
                let mut shape = TensorShape::default();
                EvaluateTensor.shape_of::<B, N>(basis, k, x, l, &mut shape);
                slots[usize::from(k >= half)].store::<N>(k, &shape);
            }
            for slot in &mut slots {
                slot.finish();
            }
        }
        for (k, &(x, l)) in points.iter().enumerate() {
            let (mut direct, mut cached) = (TensorShape::default(), TensorShape::default());
            EvaluateTensor.shape_of::<B, N>(basis, k, x, l, &mut direct);
            cache.shape_of::<B, N>(basis, k, [f64::NAN; 2], [f64::NAN; 2], &mut cached);
            for a in 0..2 {
                let (d, c) = (&direct.axes[a], &cached.axes[a]);
                assert_eq!((d.first, d.len), (c.first, c.len));
                for i in 0..N {
                    assert_eq!(d.phi[i].to_bits(), c.phi[i].to_bits());
                    assert_eq!(d.dphi[i].to_bits(), c.dphi[i].to_bits());
                }
            }
        }
    }

    proptest! {
        #[test]
        fn the_cache_returns_the_evaluation_bit_for_bit(
            raw in prop::collection::vec((0.0..1.0f64, 0.0..1.0f64, 0.0..0.05f64), 1..40),
        ) {
            let grid = TensorGrid::new([1.0, 2.0], [7, 9]);
            let points: Vec<([f64; 2], [f64; 2])> = raw
                .iter()
                .map(|&(x, y, l)| ([x, 2.0 * y], [l, 0.5 * l]))
                .collect();
            let quadratic = TensorBasis::new(grid, |g| BSplineBasis::new(g, 2).unwrap());
            round_trip::<_, 3>(&quadratic, &points);
            let cubic = TensorBasis::new(grid, |g| BSplineBasis::new(g, 3).unwrap());
            round_trip::<_, 4>(&cubic, &points);
            let gimp = TensorBasis::new(grid, GimpBasis::new);
            round_trip::<_, 4>(&gimp, &points);
        }
    }
}
