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
        let serial: f64 = (0..n).map(term).sum();
        assert!((one - serial).abs() < 1e-10 * serial.abs());
    }
}
