//! The 2D / 3D lumped step split over ranks (`docs/distributed.md`).
//!
//! The grid's last-axis cell layers are cut into slabs ([`SlabDecomposition`]); each rank
//! steps the particles of its slab with the ordinary [`super::tensor::TensorStepper`] and
//! a [`RankContext`] that the stepper calls at three points of a step:
//!
//! ```text
//! after the mass and force scatter   m_I, f_I += the neighbours' parts on shared node layers
//! after the momentum scatter (MUSL)  p_I      += the neighbours' parts on shared node layers
//! after the particle update          particles that left the slab move to the neighbour
//! ```
//!
//! and it sums the diagnostics (grid mass and momentum over the node layers each rank
//! owns, particle momentum, energies, crossings, failures) over ranks in rank order. On a
//! shared node both ranks add the same two partial sums (`a + b = b + a` in floating
//! point), so every rank sees the same nodal values. The partial sums themselves are
//! grouped by rank, so results agree with one process to round-off, not bit for bit.
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

/// One rank's part in a distributed step: its exchange, the decomposition, and the sizes
/// that turn node and cell layers into flat index ranges.
pub struct RankContext {
    exchange: Box<dyn RankExchange>,
    slabs: SlabDecomposition,
    /// Nodes per last-axis node layer (the product of the other axes' DOFs).
    nodes_per_layer: usize,
    /// Cells per last-axis cell layer.
    cells_per_layer: usize,
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
        let dofs = basis.dofs();
        Ok(Self {
            exchange,
            slabs,
            nodes_per_layer: dofs[..D - 1].iter().product(),
            cells_per_layer: basis.grid.cells_per_layer(),
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
            .contains(&(cell / self.cells_per_layer))
    }

    /// The flat node indices of this rank's owned node layers.
    pub fn owned_nodes(&self) -> Range<usize> {
        self.node_range(self.slabs.owned_node_layers(self.rank()))
    }

    fn node_range(&self, layers: Range<usize>) -> Range<usize> {
        layers.start * self.nodes_per_layer..layers.end * self.nodes_per_layer
    }

    /// Add the neighbours' values on the shared node layers of `field` (`width` values per
    /// node, nodes in lexicographic order).
    pub fn add_shared(&self, field: &mut [f64], width: usize) -> Result<()> {
        let r = self.rank();
        let lower = match r {
            0 => 0..0,
            _ => self.node_range(self.slabs.shared_with_upper(r - 1)),
        };
        let upper = self.node_range(self.slabs.shared_with_upper(r));
        self.add_from_neighbours(field, width, lower, upper)
    }

    /// Add to `field` on the index ranges `lower` and `upper` (in units of `width` values)
    /// what the lower and upper neighbours send of theirs on the same ranges.
    fn add_from_neighbours(
        &self,
        field: &mut [f64],
        width: usize,
        lower: Range<usize>,
        upper: Range<usize>,
    ) -> Result<()> {
        let scaled = |items: Range<usize>| items.start * width..items.end * width;
        let (lower, upper) = (scaled(lower), scaled(upper));
        let (from_lower, from_upper) = self.timed(|| {
            self.exchange
                .swap_with_neighbours(&field[lower.clone()], &field[upper.clone()])
        })?;
        for (range, received) in [(lower, from_lower), (upper, from_upper)] {
            if received.len() != range.len() {
                return Err(exchange_error(
                    "a neighbour sent a shared layer of another size",
                ));
            }
            for (value, other) in field[range].iter_mut().zip(&received) {
                *value += other;
            }
        }
        Ok(())
    }

    /// `sum_r local_r` over ranks, folded in rank order.
    pub fn sum(&self, local: &[f64]) -> Result<Vec<f64>> {
        self.timed(|| self.exchange.sum_over_ranks(local))
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
            let layer = c / self.cells_per_layer;
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
    fn owned_cells(&self) -> Range<usize> {
        let layers = self.slabs.cell_layers(self.rank());
        layers.start * self.cells_per_layer..layers.end * self.cells_per_layer
    }

    fn add_shared_cells(&self, values: &mut [f64], width: usize) -> Result<()> {
        let (r, last) = (self.rank(), self.slabs.ranks() - 1);
        let layers = self.slabs.cell_layers(r);
        let cells = |l: Range<usize>| l.start * self.cells_per_layer..l.end * self.cells_per_layer;
        let lower = match r {
            0 => 0..0,
            _ => cells(layers.start - 1..layers.start + 1),
        };
        let upper = match r == last {
            true => 0..0,
            false => cells(layers.end - 1..layers.end + 1),
        };
        self.add_from_neighbours(values, width, lower, upper)
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
        local[c] = grid[context.owned_nodes()].iter().map(|g| g[c]).sum();
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
