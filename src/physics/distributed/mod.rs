//! The 2D / 3D step split over ranks (`docs/distributed.md`).
//!
//! The grid's cell layers along its longest axis are cut into slabs
//! ([`SlabDecomposition`]); each rank steps the particles of its slab with the ordinary
//! [`super::tensor::TensorStepper`] and a [`RankContext`] that the stepper calls at three
//! points of a step:
//!
//! ```text
//! after the mass and force scatter   m_I, f_I += the neighbours' parts on shared node layers
//! after the momentum scatter (MUSL)  p_I      += the neighbours' parts on shared node layers
//! after the particle update          particles that left the slab move to the neighbour
//! ```
//!
//! and it sums the diagnostics (grid mass and momentum over the node layers each rank
//! owns, particle momentum, energies, crossings, failures) over ranks in rank order. TLS
//! sees the ranks through [`crate::mapping::tensor::SlabCells`] (its own cells, cell
//! totals across slab faces, the material extent), and the consistent mass is solved by
//! [`DistributedCg`]. On a shared node both ranks add the same two partial sums
//! (`a + b = b + a` in floating point), so every rank sees the same nodal values. The
//! partial sums themselves are grouped by rank, so results agree with one process to
//! round-off, not bit for bit.
//!
//! Each rank keeps the whole grid's node arrays (only its touched layers are ever
//! non-zero); the lumped mass, the velocity division and the constraints run over all of
//! them. That is `O(nodes)` memory and work per rank: fine next to the particles at 4–8
//! per cell for a few ranks, the first thing to restrict for many.

pub mod cg;
pub mod exchange;
#[cfg(feature = "mpi")]
pub mod mpi_ranks;
pub mod slab;

pub use cg::DistributedCg;
pub use exchange::{LocalRanks, RankExchange, SingleRank};
#[cfg(feature = "mpi")]
pub use mpi_ranks::MpiRanks;
pub use slab::SlabDecomposition;

use crate::error::Result;
use crate::grid::{Basis, TensorBasis};
use crate::mapping::tensor::SlabCells;
use crate::particles::TensorParticles;
use exchange::exchange_error;
use std::ops::Range;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::Instant;

/// How layers along the cut axis sit in a lexicographic numbering (axis 0 fastest): a
/// set of layers is one contiguous run of indices per index of the slower axes.
#[derive(Clone, Copy, Debug)]
struct Layers {
    /// Items (nodes or cells) per step along the cut axis: the product of the faster axes'
    /// counts.
    stride: usize,
    /// Layers along the cut axis.
    count: usize,
    /// Items in all.
    total: usize,
}

impl Layers {
    fn of(counts: &[usize], axis: usize) -> Self {
        Self {
            stride: counts[..axis].iter().product(),
            count: counts[axis],
            total: counts.iter().product(),
        }
    }

    /// The cut-axis layer of item `index`.
    fn layer_of(&self, index: usize) -> usize {
        (index / self.stride) % self.count
    }

    /// The contiguous index runs of `layers`, in increasing order.
    fn runs(&self, layers: Range<usize>) -> impl Iterator<Item = Range<usize>> + '_ {
        let block = self.stride * self.count;
        (0..self.total / block.max(1)).filter_map(move |outer| {
            let base = outer * block;
            (!layers.is_empty())
                .then(|| base + layers.start * self.stride..base + layers.end * self.stride)
        })
    }
}

/// One rank's part in a distributed step: its exchange, the decomposition, and how node
/// and cell layers of the cut axis map to flat indices.
pub struct RankContext {
    exchange: Box<dyn RankExchange>,
    slabs: SlabDecomposition,
    nodes: Layers,
    cells: Layers,
    /// Seconds spent in the exchange so far (the bits of an `f64`).
    exchange_seconds: AtomicU64,
    /// Where each particle goes this step ([`Self::plan_migration`]), reused.
    destinations: Mutex<Vec<Option<usize>>>,
}

impl RankContext {
    /// The context of `exchange`'s rank for a run on `basis`; refuses a decomposition of
    /// the grid into `exchange.ranks()` slabs that [`SlabDecomposition::new`] refuses.
    pub fn new<const D: usize, B: Basis>(
        basis: &TensorBasis<D, B>,
        exchange: Box<dyn RankExchange>,
    ) -> Result<Self> {
        let slabs = SlabDecomposition::new(basis, exchange.ranks())?;
        let axis = slabs.axis();
        let cells: Vec<usize> = basis.grid.axes.iter().map(|g| g.cells).collect();
        Ok(Self {
            exchange,
            nodes: Layers::of(&basis.dofs(), axis),
            cells: Layers::of(&cells, axis),
            slabs,
            exchange_seconds: AtomicU64::new(0.0f64.to_bits()),
            destinations: Mutex::new(Vec::new()),
        })
    }

    /// Seconds spent exchanging with the other ranks so far (waiting for them included).
    pub fn exchange_seconds(&self) -> f64 {
        f64::from_bits(self.exchange_seconds.load(Ordering::Relaxed))
    }

    /// Run `exchange`, adding its wall time to [`Self::exchange_seconds`].
    fn timed<T>(&self, exchange: impl FnOnce() -> T) -> T {
        let start = Instant::now();
        let result = exchange();
        let total = self.exchange_seconds() + start.elapsed().as_secs_f64();
        self.exchange_seconds
            .store(total.to_bits(), Ordering::Relaxed);
        result
    }

    /// This rank.
    pub fn rank(&self) -> usize {
        self.exchange.rank()
    }

    /// The number of ranks.
    pub fn ranks(&self) -> usize {
        self.slabs.ranks()
    }

    /// The decomposition.
    pub fn slabs(&self) -> &SlabDecomposition {
        &self.slabs
    }

    /// Whether lexicographic cell `cell` lies in this rank's slab.
    pub fn owns_cell(&self, cell: usize) -> bool {
        self.slabs
            .cell_layers(self.rank())
            .contains(&self.cells.layer_of(cell))
    }

    /// The flat node indices of this rank's owned node layers, as contiguous runs in
    /// increasing order (one run when the cut axis is the last).
    pub fn owned_nodes(&self) -> impl Iterator<Item = Range<usize>> + '_ {
        self.nodes.runs(self.slabs.owned_node_layers(self.rank()))
    }

    /// The flat node indices this rank's particles can touch, as contiguous runs in
    /// increasing order: outside them every node value of the rank is 0.
    pub fn touched_nodes(&self) -> impl Iterator<Item = Range<usize>> + '_ {
        self.nodes.runs(self.slabs.touched_node_layers(self.rank()))
    }

    /// `sum_i value(i)` over this rank's owned nodes, in index order.
    pub fn sum_over_owned_nodes(&self, value: impl Fn(usize) -> f64) -> f64 {
        self.owned_nodes().flatten().map(value).sum()
    }

    /// Add the neighbours' values on the shared node layers of `field` (`width` values per
    /// node, nodes in lexicographic order).
    pub fn add_shared(&self, field: &mut [f64], width: usize) -> Result<()> {
        let r = self.rank();
        let lower = match r {
            0 => 0..0,
            _ => self.slabs.shared_with_upper(r - 1),
        };
        let upper = self.slabs.shared_with_upper(r);
        self.add_from_neighbours(field, width, self.nodes, lower, upper)
    }

    /// Add to `field` on the layers `lower` and `upper` (`width` values per item of
    /// `layout`) what the lower and upper neighbours send of theirs on the same layers.
    fn add_from_neighbours(
        &self,
        field: &mut [f64],
        width: usize,
        layout: Layers,
        lower: Range<usize>,
        upper: Range<usize>,
    ) -> Result<()> {
        let runs = |layers: Range<usize>| {
            layout
                .runs(layers)
                .map(|r| r.start * width..r.end * width)
                .collect::<Vec<_>>()
        };
        let (lower, upper) = (runs(lower), runs(upper));
        let pack = |runs: &[Range<usize>]| -> Vec<f64> {
            runs.iter()
                .flat_map(|r| field[r.clone()].iter().copied())
                .collect()
        };
        let (send_lower, send_upper) = (pack(&lower), pack(&upper));
        let (from_lower, from_upper) =
            self.timed(|| self.exchange.swap_with_neighbours(&send_lower, &send_upper))?;
        for (runs, received) in [(lower, from_lower), (upper, from_upper)] {
            let len: usize = runs.iter().map(|r| r.len()).sum();
            if received.len() != len {
                return Err(exchange_error(
                    "a neighbour sent a shared layer of another size",
                ));
            }
            let mut received = received.iter();
            for run in runs {
                for (value, other) in field[run].iter_mut().zip(received.by_ref()) {
                    *value += other;
                }
            }
        }
        Ok(())
    }

    /// `sum_r local_r` over ranks, folded in rank order.
    pub fn sum(&self, local: &[f64]) -> Result<Vec<f64>> {
        self.timed(|| self.exchange.sum_over_ranks(local))
    }

    /// `(sum_r summand_r, max_r maximand_r)` in one exchange, the sum folded in rank order
    /// (the bits of [`Self::sum`]).
    pub fn sum_and_max(&self, summand: f64, maximand: f64) -> Result<(f64, f64)> {
        let all = self.timed(|| self.exchange.all_gather(&[summand, maximand]))?;
        let mut total = (0.0, f64::NEG_INFINITY);
        for part in &all {
            let [s, m] = part[..] else {
                return Err(exchange_error(
                    "ranks gathered vectors of different lengths",
                ));
            };
            total = (total.0 + s, total.1.max(m));
        }
        Ok(total)
    }

    /// Whether any rank had `failed` (every rank must call this in the same step).
    pub fn any_failed(&self, failed: bool) -> Result<bool> {
        Ok(self.sum(&[f64::from(u8::from(failed))])?[0] > 0.0)
    }

    /// Keep only the particles of this rank's slab (at the start of a run, when every
    /// rank built all of them).
    pub fn keep_own<const D: usize>(&self, particles: &mut TensorParticles<D>) {
        let mut elsewhere = vec![Vec::new()];
        let cells = particles.cell.clone();
        particles.take_records(|k| (!self.owns_cell(cells[k])).then_some(0), &mut elsewhere);
    }

    /// Mark where every particle goes after this step's update: `None` stays, `Some(0)`
    /// the lower neighbour, `Some(1)` the upper one (kept for [`Self::migrate`]). Returns
    /// the id of a particle that crossed a whole slab in one step, if one did (the time
    /// step is far above the stability limit, or the slab is thinner than a cell of
    /// travel): every rank must then learn of it before any moves a particle.
    pub fn plan_migration<const D: usize>(&self, particles: &TensorParticles<D>) -> Option<usize> {
        let r = self.rank();
        let own = self.slabs.cell_layers(r);
        let mut destinations = self
            .destinations
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        destinations.clear();
        let mut jumped = None;
        destinations.extend(particles.cell.iter().zip(&particles.id).map(|(&c, &id)| {
            let layer = self.cells.layer_of(c);
            if own.contains(&layer) {
                return None;
            }
            let owner = self.slabs.owner_of_layer(layer);
            if owner.abs_diff(r) > 1 {
                jumped = jumped.or(Some(id));
            }
            Some(usize::from(owner > r))
        }));
        jumped
    }

    /// Send the particles [`Self::plan_migration`] marked to the neighbour slab they
    /// entered and append the neighbours' arrivals; returns how many left and arrived.
    pub fn migrate<const D: usize>(&self, particles: &mut TensorParticles<D>) -> Result<usize> {
        let mut outboxes = [Vec::new(), Vec::new()];
        {
            let destinations = self
                .destinations
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            if destinations.len() != particles.len() {
                return Err(exchange_error(
                    "the particles changed between planning and migrating",
                ));
            }
            particles.take_records(|k| destinations[k], &mut outboxes);
        }
        let left = (outboxes[0].len() + outboxes[1].len()) / TensorParticles::<D>::record_len();
        let (from_lower, from_upper) = self.timed(|| {
            self.exchange
                .swap_with_neighbours(&outboxes[0], &outboxes[1])
        })?;
        let before = particles.len();
        particles.append_records(&from_lower)?;
        particles.append_records(&from_upper)?;
        Ok(left + particles.len() - before)
    }
}

impl std::fmt::Debug for RankContext {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RankContext")
            .field("rank", &self.rank())
            .field("slabs", &self.slabs)
            .finish_non_exhaustive()
    }
}

impl SlabCells for RankContext {
    fn owns_cell(&self, cell: usize) -> bool {
        RankContext::owns_cell(self, cell)
    }

    fn add_shared_cells(&self, values: &mut [f64], width: usize) -> Result<()> {
        let (r, last) = (self.rank(), self.slabs.ranks() - 1);
        let layers = self.slabs.cell_layers(r);
        let lower = match r {
            0 => 0..0,
            _ => layers.start - 1..layers.start + 1,
        };
        let upper = match r == last {
            true => 0..0,
            false => layers.end - 1..layers.end + 1,
        };
        self.add_from_neighbours(values, width, self.cells, lower, upper)
    }

    fn min_over_ranks(&self, values: &mut [f64]) -> Result<()> {
        // Each rank fills its own slot; the sum (exact: every other term is 0) is the
        // table of all ranks' values.
        let (n, r) = (values.len(), self.rank());
        let mut slots = vec![0.0; n * self.slabs.ranks()];
        slots[r * n..(r + 1) * n].copy_from_slice(values);
        let table = self.sum(&slots)?;
        for (i, value) in values.iter_mut().enumerate() {
            *value = table
                .iter()
                .skip(i)
                .step_by(n)
                .copied()
                .fold(f64::INFINITY, f64::min);
        }
        Ok(())
    }
}

/// `max_c |grid_c - particle_c| / scale` of sums taken over all ranks: `local` is
/// `[grid momentum (D, over owned nodes), particle momentum (D), sum m |v|]`.
pub fn momentum_error_over_ranks<const D: usize>(
    context: &RankContext,
    grid: &[[f64; D]],
    particle: [f64; 3],
    scale: f64,
) -> Result<Option<f64>> {
    let mut local = vec![0.0; 2 * D + 1];
    for c in 0..D {
        local[c] = context.sum_over_owned_nodes(|i| grid[i][c]);
        local[D + c] = particle[c];
    }
    local[2 * D] = scale;
    let total = context.sum(&local)?;
    let scale = total[2 * D];
    let error = (0..D).fold(0.0f64, |e, c| e.max((total[c] - total[D + c]).abs()));
    Ok((scale > 0.0).then_some(error / scale))
}

/// Every rank's particles on rank 0, in rank order (`None` on the other ranks): for the
/// outputs of a distributed run, which rank 0 writes.
pub fn gather_particles<const D: usize>(
    exchange: &dyn RankExchange,
    particles: &TensorParticles<D>,
) -> Result<Option<TensorParticles<D>>> {
    match exchange.gather_to_root(&particles.records())? {
        Some(all) => {
            let mut gathered = TensorParticles::default();
            gathered.append_records(&all)?;
            Ok(Some(gathered))
        }
        None => Ok(None),
    }
}
