//! Deterministic parallel reductions.
//!
//! `rayon`'s `sum()` combines partial sums in an order that depends on work stealing, so
//! its last bits change with the thread count. Here the input is cut into fixed blocks of
//! [`BLOCK`] items, each block is summed left to right (in parallel), and the block sums are
//! added left to right: the result depends only on the data, never on the thread count.

use rayon::prelude::*;

/// Items per block of a deterministic reduction.
pub const BLOCK: usize = 4096;

/// `sum_{k < n} term(k)`, bitwise identical for any thread count.
///
/// ```
/// let s = tlsmpm::numerics::sum::deterministic_sum(10_000, |k| k as f64);
/// assert_eq!(s, 49_995_000.0);
/// ```
pub fn deterministic_sum<F>(n: usize, term: F) -> f64
where
    F: Fn(usize) -> f64 + Sync,
{
    if n <= BLOCK {
        return (0..n).map(&term).sum();
    }
    let blocks = n.div_ceil(BLOCK);
    let partial: Vec<f64> = (0..blocks)
        .into_par_iter()
        .map(|b| (b * BLOCK..((b + 1) * BLOCK).min(n)).map(&term).sum())
        .collect();
    partial.iter().sum()
}

/// `K` sums `sum_{k < n} terms(k)[j]` in one pass, each bitwise identical for any thread
/// count (same blocking as [`deterministic_sum`]).
///
/// ```
/// let [count, total] = tlsmpm::numerics::sum::deterministic_sums(100, |k| [1.0, k as f64]);
/// assert_eq!((count, total), (100.0, 4950.0));
/// ```
pub fn deterministic_sums<F, const K: usize>(n: usize, terms: F) -> [f64; K]
where
    F: Fn(usize) -> [f64; K] + Sync,
{
    let block_sum = |range: std::ops::Range<usize>| {
        let mut acc = [0.0; K];
        for k in range {
            for (a, t) in acc.iter_mut().zip(terms(k)) {
                *a += t;
            }
        }
        acc
    };
    if n <= BLOCK {
        return block_sum(0..n);
    }
    let partial: Vec<[f64; K]> = (0..n.div_ceil(BLOCK))
        .into_par_iter()
        .map(|b| block_sum(b * BLOCK..((b + 1) * BLOCK).min(n)))
        .collect();
    sum_block_partials(&partial)
}

/// The total of consecutive blocks' partial sums (each block of [`BLOCK`] items summed
/// left to right), added left to right: what [`deterministic_sums`] returns for the same
/// terms, bit for bit, so a parallel loop over blocks of [`BLOCK`] items can fold its own
/// sums and keep them. One block is returned as it is.
///
/// ```
/// use tlsmpm::numerics::sum::{deterministic_sums, sum_block_partials, BLOCK};
/// let n = 2 * BLOCK + 5;
/// let term = |k: usize| [1.0 / (k as f64 + 1.0)];
/// let partial: Vec<[f64; 1]> = (0..n)
///     .collect::<Vec<_>>()
///     .chunks(BLOCK)
///     .map(|block| [block.iter().fold(0.0, |acc, &k| acc + term(k)[0])])
///     .collect();
/// assert_eq!(sum_block_partials(&partial), deterministic_sums(n, term));
/// ```
pub fn sum_block_partials<const K: usize>(partial: &[[f64; K]]) -> [f64; K] {
    if let [single] = partial {
        return *single;
    }
    let mut total = [0.0; K];
    for block in partial {
        for (t, b) in total.iter_mut().zip(block) {
            *t += b;
        }
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_bits_for_one_and_two_threads() {
        let n = 100_003;
        let term = |k: usize| ((k as f64) * 0.37).sin() * 1e-3 + 1.0 / (k as f64 + 1.0);
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| deterministic_sum(n, term));
        let two = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap()
            .install(|| deterministic_sum(n, term));
        assert_eq!(one.to_bits(), two.to_bits());
        let [a, b] = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap()
            .install(|| deterministic_sums(n, |k| [term(k), 2.0 * term(k)]));
        assert_eq!(a.to_bits(), one.to_bits());
        assert_eq!(b.to_bits(), (2.0 * one).to_bits());
        let serial: f64 = (0..n).map(term).sum();
        assert!((one - serial).abs() < 1e-10 * serial.abs());
    }
}
