//! The next step's shapes, mass and internal force, mapped by the 1D particle update of
//! this step (docs/performance.md, "1D: the next step mapped in the particle update";
//! measured in `perf/README.md`).
//!
//! The direct mapping's first pass of a step evaluates every particle's shape (the step's
//! [`ShapeCache`]) and scatters
//!
//! ```text
//! m_i     = sum_p m_p phi_i(x_p)
//! f_int_i = sum_p sigma_p dphi_i(x_p) V_p
//! ```
//!
//! cell by cell ([`super::CellScatter`]: a local sum per cell over its particles in storage
//! order, the cells then added in increasing order). Everything it reads is at hand in the
//! previous step's particle update the moment a particle has moved, so the update does it
//! there: each update task ([`NextTask`]) reads a particle's current shape from its cache
//! slot, stores the next one in the same slot and adds the particle to the local sums of
//! its new cell, cell after cell in storage order. A cell whose particles all lie in one
//! task gets exactly the local sums of the first pass. A cell cut by a task boundary is
//! summed again over its particles after the update ([`NextMassForce::reduce`]), in the
//! first pass's order. The cells are then added in increasing order, as the first pass
//! adds them: `m_i` and `f_int_i` are bitwise those the next step's first pass computes.
//!
//! That holds while the particles stay sorted by cell (in 1D, unless two pass each
//! other): after a re-sort the slots no longer belong to the same particles, the result
//! is dropped and the next step maps as usual.

use super::points::add_mass_and_force;
use super::scatter::Local;
use crate::grid::{Basis, CacheSlots, Shape, ShapeCache, ShapeSource, MAX_SUPPORT};
use crate::particles::{CellBins, Particles};
use rayon::prelude::*;

/// The cells one update task summed, in increasing order, and their local sums.
#[derive(Clone, Debug, Default)]
struct TaskCells {
    cells: Vec<usize>,
    /// Per cell, `width` masses then `width` forces of its DOF window.
    sums: Vec<f64>,
}

/// The per-task sums of the next step's mass and internal force (the buffers are reused
/// from step to step).
#[derive(Clone, Debug, Default)]
pub struct NextMassForce {
    tasks: Vec<TaskCells>,
    width: usize,
}

/// One update task's share: the shape slots of its particles and the local sums of the
/// cells they moved to.
pub struct NextTask<'a> {
    slots: CacheSlots<'a>,
    out: &'a mut TaskCells,
    width: usize,
    /// The cell being summed (`usize::MAX`: none yet) and the first DOF of its window.
    cell: usize,
    window_first: usize,
    local: Local<2>,
}

impl NextMassForce {
    /// The update tasks of `per_task` consecutive particles, each with its slots of the
    /// filled `cache` (the particles' current shapes).
    pub fn tasks<'a, B: Basis>(
        &'a mut self,
        basis: &B,
        cache: &'a mut ShapeCache,
        per_task: usize,
    ) -> impl IndexedParallelIterator<Item = NextTask<'a>> {
        self.tasks
            .resize_with(cache.len().div_ceil(per_task), TaskCells::default);
        self.width = basis.max_window();
        let width = self.width;
        cache
            .task_slots(per_task)
            .zip(self.tasks.par_iter_mut())
            .map(move |(slots, out)| {
                out.cells.clear();
                out.sums.clear();
                NextTask {
                    slots,
                    out,
                    width,
                    cell: usize::MAX,
                    window_first: 0,
                    local: [[0.0; MAX_SUPPORT]; 2],
                }
            })
    }

    /// Write the next step's `m_i` into `mass` and `f_int_i` into `internal_force`, from
    /// the tasks' sums of the last update. `bins` are the particles' bins after it (still
    /// sorted by cell, see the module doc) and `cache` holds the shapes the tasks stored.
    pub fn reduce<B: Basis>(
        &self,
        basis: &B,
        bins: &CellBins,
        cache: &ShapeCache,
        particles: &Particles,
        mass: &mut [f64],
        internal_force: &mut [f64],
    ) {
        mass.fill(0.0);
        internal_force.fill(0.0);
        let width = self.width;
        let mut add = |cell: usize, m: &[f64], f: &[f64]| {
            let (first, len) = basis.cell_window(cell);
            for (o, l) in mass[first..first + len].iter_mut().zip(&m[..len]) {
                *o += l;
            }
            for (o, l) in internal_force[first..first + len].iter_mut().zip(&f[..len]) {
                *o += l;
            }
        };
        // The cell last summed again (it may span more than two tasks).
        let mut summed_again = None;
        for (t, task) in self.tasks.iter().enumerate() {
            let next_first = self.tasks.get(t + 1).and_then(|n| n.cells.first());
            for (i, (&cell, sums)) in task
                .cells
                .iter()
                .zip(task.sums.chunks_exact(2 * width))
                .enumerate()
            {
                if summed_again == Some(cell) {
                    continue;
                }
                if i + 1 == task.cells.len() && next_first == Some(&cell) {
                    let [m, f] = cell_sums(basis, bins, cache, particles, cell);
                    add(cell, &m, &f);
                    summed_again = Some(cell);
                } else {
                    let (m, f) = sums.split_at(width);
                    add(cell, m, f);
                }
            }
        }
    }
}

/// The local sums of `cell` over its particles in storage order, as the first pass sums
/// them.
fn cell_sums<B: Basis>(
    basis: &B,
    bins: &CellBins,
    cache: &ShapeCache,
    particles: &Particles,
    cell: usize,
) -> Local<2> {
    let mut local = [[0.0; MAX_SUPPORT]; 2];
    let first = basis.cell_window(cell).0;
    let mut shape = Shape::default();
    let (mass, stress, volume) = (&particles.mass, &particles.stress, &particles.volume);
    for p in bins.range(cell) {
        let half_length = 0.5 * volume[p];
        cache.shape_of::<B, 0>(basis, p, cell, particles.x[p], half_length, &mut shape);
        add_mass_and_force::<0>(
            &mut local,
            shape.first - first,
            &shape,
            mass[p],
            stress[p] * volume[p],
        );
    }
    local
}

impl NextTask<'_> {
    /// `(phi^T g, dphi^T g)` of the current shape of the task's particle `k` in `cell` (the
    /// gradient only when `gradient`), read straight from its slot ([`CacheSlots::dots`]).
    #[inline(always)]
    pub fn current_dots<B: Basis, const N: usize>(
        &self,
        basis: &B,
        k: usize,
        cell: usize,
        g: &[f64],
        gradient: bool,
    ) -> (f64, f64) {
        self.slots.dots::<B, N>(basis, k, cell, g, gradient)
    }

    /// Particle `k` moved to `x` in `cell` with volume `volume`, mass `mass` and stress
    /// `stress`: evaluate its shape there (into `shape`), store it in its slot and add the
    /// particle to the sums of `cell`. Called for the task's particles in storage order.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn map<B: Basis, const N: usize>(
        &mut self,
        basis: &B,
        k: usize,
        cell: usize,
        x: f64,
        volume: f64,
        mass: f64,
        stress: f64,
        shape: &mut Shape,
    ) {
        basis.eval_particle_n::<N>(cell, x, 0.5 * volume, shape);
        self.slots.store::<N>(k, shape);
        if cell != self.cell {
            self.flush();
            self.cell = cell;
            self.window_first = basis.cell_window(cell).0;
        }
        let offset = shape.first - self.window_first;
        add_mass_and_force::<N>(&mut self.local, offset, shape, mass, stress * volume);
    }

    /// Close the task: keep the sums of its last cell.
    pub fn finish(&mut self) {
        self.flush();
        self.cell = usize::MAX;
    }

    fn flush(&mut self) {
        if self.cell == usize::MAX {
            return;
        }
        self.out.cells.push(self.cell);
        for row in &mut self.local {
            self.out.sums.extend_from_slice(&row[..self.width]);
            row.fill(0.0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::tensor::with_fixed_support;
    use crate::grid::{BSplineBasis, CpdiBasis, GimpBasis, Grid};
    use crate::mapping::test_layouts::scattered_particles;
    use crate::mapping::{DirectMapping, GridFields, Mapping};
    use proptest::prelude::*;

    /// Map every particle through update tasks of `per_task` particles (as the particle
    /// update does) and reduce; the result must be bitwise the direct mapping's first pass
    /// with the same shapes.
    fn check<B: Basis>(basis: &B, particles: &Particles, bins: &CellBins, per_task: usize) {
        let mut cache = ShapeCache::default();
        cache.fill(basis, &particles.x, &particles.cell, &particles.volume);
        let mut next = NextMassForce::default();
        with_fixed_support!(basis, N => {
            let tasks: Vec<NextTask<'_>> = next.tasks(basis, &mut cache, per_task).collect();
            for (t, mut task) in tasks.into_iter().enumerate() {
                let mut shape = Shape::default();
                let start = t * per_task;
                for k in 0..per_task.min(particles.len() - start) {
                    let p = start + k;
                    let (x, volume) = (particles.x[p], particles.volume[p]);
                    let (mass, stress) = (particles.mass[p], particles.stress[p]);
                    task.map::<B, N>(
                        basis, k, particles.cell[p], x, volume, mass, stress, &mut shape,
                    );
                }
                task.finish();
            }
        });
        let n = basis.num_dofs();
        let (mut mass, mut force) = (vec![f64::NAN; n], vec![f64::NAN; n]);
        next.reduce(basis, bins, &cache, particles, &mut mass, &mut force);
        let mut fields = GridFields::new(n);
        DirectMapping::default().map_mass_and_internal_force_reusing(
            basis,
            particles,
            bins,
            &mut fields,
            &cache,
        );
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&mass), bits(&fields.mass));
        assert_eq!(bits(&force), bits(&fields.internal_force));
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]
        /// Cells cut by task boundaries (tasks of 1 to 40 particles, so that a cell may
        /// span several tasks), empty cells, every fixed-support basis.
        #[test]
        fn the_tasks_sums_reduce_to_the_first_pass_bit_for_bit(
            cells in 3usize..24,
            t in proptest::collection::vec(0.0f64..=1.0, 1..400),
            per_task in 1usize..40,
            order in 1usize..5,
        ) {
            let grid = Grid::new(2.0, cells);
            let (particles, bins) = scattered_particles(&grid, &t);
            check(&BSplineBasis::new(grid, order).unwrap(), &particles, &bins, per_task);
            check(&CpdiBasis::new(grid), &particles, &bins, per_task);
            check(&GimpBasis::new(grid), &particles, &bins, per_task);
        }
    }
}
