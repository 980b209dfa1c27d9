//! What ranks say to each other during a step, behind one trait ([`RankExchange`]), and
//! an in-process implementation ([`LocalRanks`]: one thread per rank) that runs the
//! distributed step in the ordinary test suite without MPI.
//!
//! Two collective operations are enough for the step (`docs/distributed.md`):
//! * [`RankExchange::swap_with_neighbours`]: send one buffer to rank `r - 1` and one to
//!   `r + 1`, receive theirs (shared node and cell layers, migrating particles);
//! * [`RankExchange::all_gather`]: every rank's short vector on every rank, in rank order
//!   (global sums folded in rank order are bitwise the same on every rank and for any
//!   number of threads).
//!
//! Every rank must call the same operations in the same order.

use crate::error::{Error, Result};
use std::sync::{Arc, Barrier, Mutex};

/// The communication of one rank with the others.
pub trait RankExchange: Send + Sync {
    /// This rank, `0..ranks()`.
    fn rank(&self) -> usize;
    /// Number of ranks.
    fn ranks(&self) -> usize;
    /// Send `to_lower` to rank `r - 1` and `to_upper` to rank `r + 1` (ignored where there
    /// is no such rank); returns what ranks `r - 1` and `r + 1` sent this rank (empty
    /// where there is no such rank).
    fn swap_with_neighbours(
        &self,
        to_lower: &[f64],
        to_upper: &[f64],
    ) -> Result<(Vec<f64>, Vec<f64>)>;
    /// Every rank's `local`, in rank order.
    fn all_gather(&self, local: &[f64]) -> Result<Vec<Vec<f64>>>;
    /// Every rank's `local` concatenated in rank order on rank 0 (`None` on the others).
    fn gather_to_root(&self, local: &[f64]) -> Result<Option<Vec<f64>>>;

    /// `sum_r local_r` component by component, folded in rank order (the same bits on
    /// every rank).
    fn sum_over_ranks(&self, local: &[f64]) -> Result<Vec<f64>> {
        let all = self.all_gather(local)?;
        let mut total = vec![0.0; local.len()];
        for part in &all {
            if part.len() != total.len() {
                return Err(exchange_error("ranks summed vectors of different lengths"));
            }
            for (t, v) in total.iter_mut().zip(part) {
                *t += v;
            }
        }
        Ok(total)
    }
}

pub(crate) fn exchange_error(reason: &str) -> Error {
    Error::Distributed {
        reason: reason.to_string(),
    }
}

/// The mailboxes of [`LocalRanks`]: one outgoing pair of buffers per rank.
struct Mailboxes {
    barrier: Barrier,
    outgoing: Vec<Mutex<Vec<Vec<f64>>>>,
}

/// One rank of a group of ranks that run as threads of one process.
pub struct LocalRanks {
    rank: usize,
    shared: Arc<Mailboxes>,
}

impl LocalRanks {
    /// `ranks` connected ranks, to be moved to one thread each.
    pub fn group(ranks: usize) -> Vec<LocalRanks> {
        let shared = Arc::new(Mailboxes {
            barrier: Barrier::new(ranks),
            outgoing: (0..ranks).map(|_| Mutex::new(Vec::new())).collect(),
        });
        (0..ranks)
            .map(|rank| LocalRanks {
                rank,
                shared: Arc::clone(&shared),
            })
            .collect()
    }

    /// Post `messages`, wait for every rank, read with `read`, wait again (so that the
    /// boxes can be reused).
    fn collective<T>(
        &self,
        messages: Vec<Vec<f64>>,
        read: impl FnOnce(&[Mutex<Vec<Vec<f64>>>]) -> Result<T>,
    ) -> Result<T> {
        let boxes = &self.shared.outgoing;
        *boxes[self.rank]
            .lock()
            .map_err(|_| exchange_error("a rank failed while holding its mailbox"))? = messages;
        self.shared.barrier.wait();
        let result = read(boxes);
        self.shared.barrier.wait();
        result
    }
}

fn message(boxes: &[Mutex<Vec<Vec<f64>>>], rank: usize, slot: usize) -> Result<Vec<f64>> {
    let outgoing = boxes[rank]
        .lock()
        .map_err(|_| exchange_error("a rank failed while holding its mailbox"))?;
    Ok(outgoing.get(slot).cloned().unwrap_or_default())
}

impl RankExchange for LocalRanks {
    fn rank(&self) -> usize {
        self.rank
    }

    fn ranks(&self) -> usize {
        self.shared.outgoing.len()
    }

    fn swap_with_neighbours(
        &self,
        to_lower: &[f64],
        to_upper: &[f64],
    ) -> Result<(Vec<f64>, Vec<f64>)> {
        let (rank, ranks) = (self.rank, self.ranks());
        self.collective(vec![to_lower.to_vec(), to_upper.to_vec()], |boxes| {
            let from_lower = if rank > 0 {
                message(boxes, rank - 1, 1)?
            } else {
                Vec::new()
            };
            let from_upper = if rank + 1 < ranks {
                message(boxes, rank + 1, 0)?
            } else {
                Vec::new()
            };
            Ok((from_lower, from_upper))
        })
    }

    fn all_gather(&self, local: &[f64]) -> Result<Vec<Vec<f64>>> {
        let ranks = self.ranks();
        self.collective(vec![local.to_vec()], |boxes| {
            (0..ranks).map(|r| message(boxes, r, 0)).collect()
        })
    }

    fn gather_to_root(&self, local: &[f64]) -> Result<Option<Vec<f64>>> {
        // `all_gather` of this backend takes vectors of any length.
        let all = self.all_gather(local)?;
        Ok((self.rank == 0).then(|| all.concat()))
    }
}

/// The exchange of a run on one rank: nothing to send, sums of one term.
#[derive(Clone, Copy, Debug, Default)]
pub struct SingleRank;

impl RankExchange for SingleRank {
    fn rank(&self) -> usize {
        0
    }
    fn ranks(&self) -> usize {
        1
    }
    fn swap_with_neighbours(&self, _: &[f64], _: &[f64]) -> Result<(Vec<f64>, Vec<f64>)> {
        Ok((Vec::new(), Vec::new()))
    }
    fn all_gather(&self, local: &[f64]) -> Result<Vec<Vec<f64>>> {
        Ok(vec![local.to_vec()])
    }
    fn gather_to_root(&self, local: &[f64]) -> Result<Option<Vec<f64>>> {
        Ok(Some(local.to_vec()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn local_ranks_swap_with_neighbours_and_gather_in_rank_order() {
        let results: Vec<_> = std::thread::scope(|scope| {
            let handles: Vec<_> = LocalRanks::group(3)
                .into_iter()
                .map(|ex| {
                    scope.spawn(move || {
                        let r = ex.rank() as f64;
                        let swapped = ex.swap_with_neighbours(&[r, -1.0], &[r, 1.0]).unwrap();
                        let gathered = ex.all_gather(&[10.0 * r]).unwrap();
                        let sum = ex.sum_over_ranks(&[r, 1.0]).unwrap();
                        (swapped, gathered, sum)
                    })
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        assert_eq!(results[0].0, (vec![], vec![1.0, -1.0]));
        assert_eq!(results[1].0, (vec![0.0, 1.0], vec![2.0, -1.0]));
        assert_eq!(results[2].0, (vec![1.0, 1.0], vec![]));
        for (_, gathered, sum) in &results {
            assert_eq!(gathered, &vec![vec![0.0], vec![10.0], vec![20.0]]);
            assert_eq!(sum, &vec![3.0, 3.0]);
        }
    }
}
