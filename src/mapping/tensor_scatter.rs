//! Deterministic parallel scatter from binned particles to the nodes of a
//! [`TensorBasis`] (`D` = 1, 2, 3).
//!
//! The cells are cut into tasks of whole layers of the last axis (slabs: columns of cells
//! in 1D, rows in 2D, planes in 3D). The particles of a task are contiguous (they are
//! sorted by lexicographic cell), and so are the nodes they touch, `[lo, hi)`. Each task
//! accumulates into its own buffer over `[lo, hi)`, one `[f64; W]` per node; the buffers
//! are then reduced node by node in increasing task order, in parallel over the tasks'
//! owned node ranges. The partition depends only on the grid, never on the thread count,
//! and so every sum happens in the same order: results are bitwise identical for any
//! number of threads.
//!
//! A scatter built [`TensorScatter::with_slack`] widens each task's node range by `slack`
//! layers of cells on either side, so that a particle binned into a task at the last sort
//! may have moved up to `slack` layers away along the last axis and still scatter into its
//! task's buffer: the particles need re-sorting only when one strays further (see
//! `TensorMapping::bin_slack`). The widening changes no sum, only which buffer holds it.

use crate::grid::{Basis, TensorBasis};
use rayon::prelude::*;
use std::ops::Range;

/// Aim for at least this many cells per task.
const CELLS_PER_TASK: usize = 256;

/// Keep at least this many tasks when tasks are widened to cut their halo (enough for 16
/// threads with four tasks each).
const MIN_TASKS: usize = 64;

/// One task: its cells (a range of lexicographic cells = whole layers) and its nodes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ScatterTask {
    pub cells: Range<usize>,
    pub nodes: Range<usize>,
    /// Offset of the task's buffer in the shared buffer (in nodes).
    offset: usize,
}

/// The task partition and the reusable buffers of one scatter width.
#[derive(Clone, Debug)]
pub struct TensorScatter<const W: usize> {
    tasks: Vec<ScatterTask>,
    buffer: Vec<[f64; W]>,
    num_dofs: usize,
}

/// The task partition of `basis`, each task's nodes widened by `slack` layers of cells on
/// either side (see the module doc).
pub fn scatter_tasks<const D: usize, B: Basis>(
    basis: &TensorBasis<D, B>,
    slack: usize,
) -> Vec<ScatterTask> {
    let cells_per_layer = basis.grid.cells_per_layer();
    let layers = basis.grid.axes[D - 1].cells;
    let layers_per_task = layers_per_task(basis, slack);
    let node_stride = basis.strides()[D - 1];
    let mut tasks = Vec::new();
    let mut offset = 0;
    let mut start = 0;
    while start < layers {
        let end = (start + layers_per_task).min(layers);
        let dofs = basis.layer_dofs(start.saturating_sub(slack)..(end + slack).min(layers));
        let nodes = dofs.start * node_stride..dofs.end * node_stride;
        let len = nodes.len();
        tasks.push(ScatterTask {
            cells: start * cells_per_layer..end * cells_per_layer,
            nodes,
            offset,
        });
        offset += len;
        start = end;
    }
    tasks
}

/// Layers of cells per task: at least [`CELLS_PER_TASK`] cells, and where a layer is
/// large enough that this is a single layer (2D and 3D grids of hundreds of cells across),
/// twice as many layers as the task's halo of nodes, so that the buffers (zeroed, filled
/// and reduced in every scatter) hold `(layers + halo) / layers` = 1.5 times the node
/// layers the task owns, not `halo + 1` times; but never so many that fewer than
/// [`MIN_TASKS`] tasks remain (then the buffers hold more). The halo is the node layers a
/// task's particles reach beyond its own cell layers: the support width of the last axis
/// minus one, plus `slack` on either side. The partition depends only on the grid, the
/// basis and `slack` (never on the thread count).
fn layers_per_task<const D: usize, B: Basis>(basis: &TensorBasis<D, B>, slack: usize) -> usize {
    let cells_per_layer = basis.grid.cells_per_layer();
    let layers = basis.grid.axes[D - 1].cells;
    let by_cells = CELLS_PER_TASK.div_ceil(cells_per_layer).clamp(1, layers);
    let halo = basis.axis(D - 1).max_window().saturating_sub(1) + 2 * slack;
    let by_halo = (2 * halo).min((layers / MIN_TASKS).max(by_cells));
    by_cells.max(by_halo).clamp(1, layers)
}

impl<const W: usize> TensorScatter<W> {
    /// Buffers for `basis`, for particles binned by their current cell.
    pub fn new<const D: usize, B: Basis>(basis: &TensorBasis<D, B>) -> Self {
        Self::with_slack(basis, 0)
    }

    /// Buffers for `basis`, for particles at most `slack` layers of cells (last axis) away
    /// from the cell they were binned in.
    pub fn with_slack<const D: usize, B: Basis>(basis: &TensorBasis<D, B>, slack: usize) -> Self {
        let tasks = scatter_tasks(basis, slack);
        let total = tasks.last().map_or(0, |t| t.offset + t.nodes.len());
        Self {
            tasks,
            buffer: vec![[0.0; W]; total],
            num_dofs: basis.num_dofs(),
        }
    }

    /// The tasks, in reduction order.
    pub fn tasks(&self) -> &[ScatterTask] {
        &self.tasks
    }

    /// Scatter into `output` (`num_dofs` nodes, overwritten). `kernel(task, particles,
    /// lo, local)` adds the contributions of the particles `particles` (the task's cells,
    /// from `cell_start`) to `local[node - lo]`; `local` is zeroed on entry. `state(task)`
    /// gives each task its own mutable state (e.g. its particles' velocity chunks).
    pub fn scatter_with<S, K>(
        &mut self,
        cell_start: &[usize],
        states: Vec<S>,
        output: &mut [[f64; W]],
        kernel: K,
    ) where
        S: Send,
        K: Fn(S, Range<usize>, usize, &mut [[f64; W]]) + Sync,
    {
        self.run(states, output, |state, cells, lo, local| {
            kernel(
                state,
                cell_start[cells.start]..cell_start[cells.end],
                lo,
                local,
            )
        });
    }

    /// Scatter by cells: `kernel(cells, lo, local)` adds the contributions of the task's
    /// cells `cells` (e.g. their Gauss points) to `local[node - lo]`.
    pub fn scatter_cells<K>(&mut self, output: &mut [[f64; W]], kernel: K)
    where
        K: Fn(Range<usize>, usize, &mut [[f64; W]]) + Sync,
    {
        let states = vec![(); self.tasks.len()];
        self.run(states, output, |(), cells, lo, local| {
            kernel(cells, lo, local)
        });
    }

    /// Run `kernel(state, task cells, lo, local)` for every task on its zeroed buffer,
    /// then reduce into `output`.
    fn run<S, K>(&mut self, states: Vec<S>, output: &mut [[f64; W]], kernel: K)
    where
        S: Send,
        K: Fn(S, Range<usize>, usize, &mut [[f64; W]]) + Sync,
    {
        debug_assert_eq!(output.len(), self.num_dofs);
        debug_assert_eq!(states.len(), self.tasks.len());
        let mut chunks: Vec<&mut [[f64; W]]> = Vec::with_capacity(self.tasks.len());
        let mut rest = self.buffer.as_mut_slice();
        for task in &self.tasks {
            let (chunk, tail) = rest.split_at_mut(task.nodes.len());
            chunks.push(chunk);
            rest = tail;
        }
        let tasks = &self.tasks;
        chunks
            .into_par_iter()
            .zip(states)
            .enumerate()
            .for_each(|(k, (local, state))| {
                local.fill([0.0; W]);
                let task = &tasks[k];
                kernel(state, task.cells.clone(), task.nodes.start, local);
            });
        self.reduce(output);
    }

    /// [`TensorScatter::scatter_with`] without per-task state.
    pub fn scatter<K>(&mut self, cell_start: &[usize], output: &mut [[f64; W]], kernel: K)
    where
        K: Fn(Range<usize>, usize, &mut [[f64; W]]) + Sync,
    {
        let states = vec![(); self.tasks.len()];
        self.scatter_with(cell_start, states, output, |(), p, lo, local| {
            kernel(p, lo, local)
        });
    }

    /// `output[n] = sum_k buffer_k[n]` in increasing task order `k`, in parallel over the
    /// node ranges owned by each task (`[lo_k, lo_{k+1})`).
    fn reduce(&self, output: &mut [[f64; W]]) {
        let tasks = &self.tasks;
        let buffer = &self.buffer;
        // Owned ranges [lo_k, lo_{k+1}) tile [0, num_dofs): lo_0 = 0 and the last task
        // ends at the last node.
        let mut owned: Vec<(usize, &mut [[f64; W]])> = Vec::with_capacity(tasks.len());
        let mut rest = output;
        for (k, task) in tasks.iter().enumerate() {
            let end = tasks.get(k + 1).map_or(task.nodes.end, |t| t.nodes.start);
            let (chunk, tail) = std::mem::take(&mut rest).split_at_mut(end - task.nodes.start);
            owned.push((k, chunk));
            rest = tail;
        }
        owned.into_par_iter().for_each(|(k, out)| {
            let start = tasks[k].nodes.start;
            let end = start + out.len();
            out.fill([0.0; W]);
            // Earlier tasks whose nodes reach into this range, then this one: ascending.
            let mut first = k;
            while first > 0 && tasks[first - 1].nodes.end > start {
                first -= 1;
            }
            for task in &tasks[first..=k] {
                let hi = task.nodes.end.min(end);
                let skip = start.saturating_sub(task.nodes.start);
                let local = &buffer[task.offset + skip..task.offset + skip + (hi - start)];
                for (o, l) in out[..hi - start].iter_mut().zip(local) {
                    for (o, l) in o.iter_mut().zip(l) {
                        *o += l;
                    }
                }
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{BSplineBasis, LinearBasis, TensorGrid};

    #[test]
    fn tasks_cover_all_cells_and_their_nodes() {
        for (cells, order) in [([40usize, 30], 1usize), ([7, 200], 3), ([300, 1], 2)] {
            let grid = TensorGrid::new([1.0, 1.0], cells);
            let basis = TensorBasis::new(grid, |g| BSplineBasis::new(g, order).unwrap());
            let tasks = scatter_tasks(&basis, 0);
            assert_eq!(tasks[0].cells.start, 0);
            assert_eq!(tasks.last().unwrap().cells.end, grid.num_cells());
            assert!(tasks.windows(2).all(|w| w[0].cells.end == w[1].cells.start));
            assert!(tasks
                .windows(2)
                .all(|w| w[0].nodes.start < w[1].nodes.start));
            assert_eq!(tasks.last().unwrap().nodes.end, basis.num_dofs());
        }
    }

    #[test]
    fn a_widened_scatter_takes_particles_a_layer_away_from_their_bin() {
        // Each "particle" is binned in cell `c` but sits one layer up (or down, on odd
        // columns) and scatters 1 to the four nodes of the cell it sits in: with one layer
        // of slack every contribution lands, and the sums equal a serial count.
        let (nx, ny) = (9, 700);
        let grid = TensorGrid::new([1.0, 1.0], [nx, ny]);
        let basis = TensorBasis::new(grid, LinearBasis::new);
        let cell_start: Vec<usize> = (0..=grid.num_cells()).collect();
        let sits_in = |cell: usize| {
            let (i, j) = (cell % nx, cell / nx);
            let j = if i % 2 == 0 {
                (j + 1).min(ny - 1)
            } else {
                j.saturating_sub(1)
            };
            (i, j)
        };
        let strides = *basis.strides();
        let mut expected = vec![[0.0; 1]; basis.num_dofs()];
        for cell in 0..grid.num_cells() {
            let (i, j) = sits_in(cell);
            for (di, dj) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                expected[(i + di) * strides[0] + (j + dj) * strides[1]][0] += 1.0;
            }
        }
        let mut scatter = TensorScatter::<1>::with_slack(&basis, 1);
        assert!(scatter.tasks().len() > 2);
        let mut out = vec![[0.0; 1]; basis.num_dofs()];
        scatter.scatter(&cell_start, &mut out, |particles, lo, local| {
            for cell in particles {
                let (i, j) = sits_in(cell);
                for (di, dj) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    local[(i + di) * strides[0] + (j + dj) * strides[1] - lo][0] += 1.0;
                }
            }
        });
        assert_eq!(out, expected);
    }

    #[test]
    fn reduction_adds_every_task_in_order() {
        // Each particle at a cell centre scatters 1 to every node of its support: the
        // result counts, per node, the cells whose support covers it.
        let grid = TensorGrid::new([1.0, 1.0], [9, 700]);
        let basis = TensorBasis::new(grid, LinearBasis::new);
        let cell_start: Vec<usize> = (0..=grid.num_cells()).collect();
        let mut scatter = TensorScatter::<1>::new(&basis);
        assert!(scatter.tasks().len() > 2);
        let mut out = vec![[0.0; 1]; basis.num_dofs()];
        let strides = *basis.strides();
        scatter.scatter(&cell_start, &mut out, |particles, lo, local| {
            for cell in particles {
                let (i, j) = (cell % 9, cell / 9);
                for (di, dj) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    local[(i + di) * strides[0] + (j + dj) * strides[1] - lo][0] += 1.0;
                }
            }
        });
        let dofs = basis.dofs();
        for j in 0..dofs[1] {
            for i in 0..dofs[0] {
                let along = |k: usize, n: usize| if k == 0 || k == n - 1 { 1.0 } else { 2.0 };
                let expected = along(i, dofs[0]) * along(j, dofs[1]);
                assert_eq!(out[i + j * dofs[0]][0], expected, "node {i} {j}");
            }
        }
    }
}
