//! The next step's mass and force, mapped by the particle update of this step
//! (`docs/dimensions.md`, "One pass less per step"; measured in `perf/README.md`).
//!
//! The direct mapping's first pass of a step reads every particle's position, mass,
//! volume, stress and body force, evaluates its shape and scatters
//! `m_I = sum_p m_p phi_I`, `f_I = sum_p (m_p b_p phi_I - V_p sigma_p . grad phi_I)`. All
//! of that is at hand in the previous step's particle update the moment a particle has
//! moved, so the update can do it there: [`NextMassForce`] lends the update the scatter
//! tasks and the shape cache of [`super::tensor_direct::TensorDirectMapping`]. Each task
//! updates its own particles in their storage order, reads each particle's current shape
//! from its slot, stores the next one in the same slot ([`NextTask::map`]) and adds the
//! particle to the task's buffer; the buffers are then reduced as the first pass reduces
//! them. Same particles, same order, same sums: `m_I` and `f_I` are bitwise those the next
//! step's first pass would compute.
//!
//! The task buffers cover the task's cells widened by the mapping's bin slack, so the
//! result is kept only when no particle strayed further from its bin
//! ([`NextMassForce::finish`] with `complete = false` otherwise); the next step then sorts
//! and maps as usual.

use super::tensor_direct::{task_particles, unpack_mass_and_force};
use super::tensor_direct::{TensorBody, TensorGridFields};
use super::tensor_kernels::add_mass_and_force;
use super::tensor_scatter::TensorScatter;
use crate::grid::{Basis, ShapeSlots, TensorBasis, TensorShape, TensorShapeCache};
use std::ops::Range;

/// The direct mapping's mass-and-force scatter and shape cache, lent to the particle update
/// ([`super::tensor::TensorMapping::next_mass_and_force`]).
pub struct NextMassForce<'a, const D: usize> {
    pub(super) scatter: &'a mut TensorScatter<4>,
    pub(super) cache: &'a mut TensorShapeCache<D>,
    /// The mapping's "the cache holds the particles' current shapes" flag.
    pub(super) shapes_current: &'a mut bool,
    pub(super) half_length0: Option<[f64; D]>,
}

/// One scatter task's share of the fused pass: the shape slots of its particles (a
/// [`crate::grid::TensorShapeSource`] of the current shapes until [`NextTask::map`]
/// replaces them) and its scatter buffer.
pub struct NextTask<'s, 'l, 'b, const D: usize> {
    /// The task's shapes: read the current one, then [`NextTask::map`] stores the next.
    pub slots: ShapeSlots<'s, D>,
    lo: usize,
    local: &'l mut [[f64; 4]],
    strides: [usize; D],
    half_length0: Option<[f64; D]>,
    body: TensorBody<'b, D>,
}

impl<const D: usize> NextTask<'_, '_, '_, D> {
    /// Map particle `k` in its new state: evaluate its shape at `x` in the cell of axis
    /// indices `cell` (with the domain half-lengths `l0_a |F_aa|` of the diagonal
    /// `f_diagonal` of its deformation gradient), store it in `k`'s slot and add mass `m`,
    /// volume `volume` and stress components `stress(s)` to the task's buffer.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn map<B: Basis, const N: usize>(
        &mut self,
        basis: &TensorBasis<D, B>,
        k: usize,
        cell: [usize; D],
        x: [f64; D],
        f_diagonal: [f64; D],
        m: f64,
        volume: f64,
        stress: impl Fn(usize) -> f64,
        shape: &mut TensorShape<D>,
    ) {
        let half = match self.half_length0 {
            Some(l0) => std::array::from_fn(|a| l0[a] * f_diagonal[a].abs()),
            None => [0.0; D],
        };
        basis.eval_particle_n::<N>(cell, x, half, shape);
        self.slots.store::<N>(k, shape);
        add_mass_and_force::<D, N>(
            shape,
            &self.strides,
            m,
            volume,
            stress,
            self.body.at(k),
            self.lo,
            self.local,
        );
    }
}

impl<const D: usize> NextMassForce<'_, D> {
    /// The particles of each task: consecutive ranges tiling `0..n`.
    pub fn task_ranges(&self, cell_start: &[usize]) -> Vec<Range<usize>> {
        task_particles(self.scatter.tasks(), cell_start)
    }

    /// Run `kernel(state, particles, task)` on every task in parallel (`states` one per
    /// task, in the order of [`Self::task_ranges`]), then reduce the task buffers into
    /// `fields.mass_force` in the fixed order of the first pass. `body` is the body force
    /// of the next step.
    pub fn run<B: Basis, S, K>(
        &mut self,
        basis: &TensorBasis<D, B>,
        cell_start: &[usize],
        states: Vec<S>,
        body: TensorBody<'_, D>,
        mass_force: &mut [[f64; 4]],
        kernel: K,
    ) where
        S: Send,
        K: Fn(S, Range<usize>, &mut NextTask<'_, '_, '_, D>) + Sync,
    {
        // The cache holds the current shapes of these particles (this step's first pass
        // or the last update stored them), read by the update before each store.
        let ranges = self.task_ranges(cell_start);
        let slots = self.cache.slots_in_place(&ranges);
        let strides = *basis.strides();
        let half_length0 = self.half_length0;
        let states: Vec<(S, ShapeSlots<'_, D>)> = states.into_iter().zip(slots).collect();
        self.scatter.scatter_with(
            cell_start,
            states,
            mass_force,
            |(state, slots), range, lo, local| {
                let mut task = NextTask {
                    slots,
                    lo,
                    local,
                    strides,
                    half_length0,
                    body,
                };
                kernel(state, range, &mut task);
                task.slots.finish();
            },
        );
    }

    /// Keep the result (`complete`: every particle was mapped) as the next step's
    /// `fields.mass`, `fields.force` and current shapes, or drop it.
    pub fn finish(self, complete: bool, fields: &mut TensorGridFields<D>) {
        *self.shapes_current = complete;
        if complete {
            unpack_mass_and_force(fields);
        }
    }
}
