//! [`RankExchange`] over MPI (rsmpi and the system's MPI library; feature `mpi`).
//!
//! Neighbour swaps are non-blocking sends and probed receives (tags: up-going, down-going,
//! gather), so no rank waits for another's send to complete; gathers and sums use the
//! world communicator's collectives.

use super::exchange::{exchange_error, RankExchange};
use crate::error::Result;
use ::mpi::point_to_point::{Destination, Source};
use ::mpi::topology::{Communicator, SimpleCommunicator};
use ::mpi::traits::CommunicatorCollectives;

const UP: i32 = 1;
const DOWN: i32 = 2;
const TO_ROOT: i32 = 3;

/// This process's rank of `MPI_COMM_WORLD`.
pub struct MpiRanks {
    world: SimpleCommunicator,
}

// SAFETY: the communicator is a handle that MPI lets any thread use under
// `MPI_THREAD_FUNNELED` as long as only one thread calls MPI; the stepper calls the
// exchange only from the thread that called `step` (never from its rayon tasks), and a
// run holds one `MpiRanks` per process.
unsafe impl Send for MpiRanks {}
// SAFETY: as above; `&MpiRanks` is never shared between threads that call MPI.
unsafe impl Sync for MpiRanks {}

impl MpiRanks {
    /// The world communicator (MPI must be initialised, see `mpi::initialize`).
    pub fn world() -> Self {
        Self {
            world: SimpleCommunicator::world(),
        }
    }
}

impl RankExchange for MpiRanks {
    fn rank(&self) -> usize {
        usize::try_from(self.world.rank()).unwrap_or(0)
    }

    fn ranks(&self) -> usize {
        usize::try_from(self.world.size()).unwrap_or(1)
    }

    fn swap_with_neighbours(
        &self,
        to_lower: &[f64],
        to_upper: &[f64],
    ) -> Result<(Vec<f64>, Vec<f64>)> {
        let (rank, ranks) = (self.world.rank(), self.world.size());
        let lower = (rank > 0).then(|| self.world.process_at_rank(rank - 1));
        let upper = (rank + 1 < ranks).then(|| self.world.process_at_rank(rank + 1));
        ::mpi::request::scope(|scope| {
            let up = upper.map(|p| p.immediate_send_with_tag(scope, to_upper, UP));
            let down = lower.map(|p| p.immediate_send_with_tag(scope, to_lower, DOWN));
            let from_lower = lower.map_or_else(Vec::new, |p| p.receive_vec_with_tag::<f64>(UP).0);
            let from_upper = upper.map_or_else(Vec::new, |p| p.receive_vec_with_tag::<f64>(DOWN).0);
            if let Some(request) = up {
                request.wait();
            }
            if let Some(request) = down {
                request.wait();
            }
            Ok((from_lower, from_upper))
        })
    }

    fn all_gather(&self, local: &[f64]) -> Result<Vec<Vec<f64>>> {
        let ranks = self.ranks();
        let lengths = {
            let mut lengths = vec![0u64; ranks];
            self.world
                .all_gather_into(&(local.len() as u64), &mut lengths[..]);
            lengths
        };
        if lengths.iter().any(|&l| l != local.len() as u64) {
            return Err(exchange_error(
                "ranks gathered vectors of different lengths",
            ));
        }
        let mut all = vec![0.0; ranks * local.len()];
        self.world.all_gather_into(local, &mut all[..]);
        Ok(all
            .chunks(local.len().max(1))
            .map(<[f64]>::to_vec)
            .take(ranks)
            .collect())
    }

    fn gather_to_root(&self, local: &[f64]) -> Result<Option<Vec<f64>>> {
        let rank = self.world.rank();
        if rank != 0 {
            self.world.process_at_rank(0).send_with_tag(local, TO_ROOT);
            return Ok(None);
        }
        let mut all = local.to_vec();
        for r in 1..self.world.size() {
            let (part, _) = self
                .world
                .process_at_rank(r)
                .receive_vec_with_tag::<f64>(TO_ROOT);
            all.extend_from_slice(&part);
        }
        Ok(Some(all))
    }
}
