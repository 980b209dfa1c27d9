//! Streaming of one text row per particle: rows are formatted in parallel chunks of
//! [`ROWS_PER_CHUNK`] and written in order, a bounded batch of chunks at a time, so a file
//! of `N` rows never exists whole in memory (one batch of `2 · threads` chunks being written
//! while the next is formatted, a few MB) and the bytes do not depend on the thread count.

use rayon::prelude::*;
use std::io::Write;

/// Rows per formatting chunk.
pub const ROWS_PER_CHUNK: usize = 16_384;

/// Storage indices in the order of the particles' original ids: the inverse permutation
/// when `ids` is a permutation of `0..n` (every run's particles; `O(n)`), otherwise a
/// stable sort by id.
///
/// ```
/// use tlsmpm::output::rows::id_order;
/// assert_eq!(id_order(&[2, 0, 1]), vec![1, 2, 0]);
/// assert_eq!(id_order(&[7, 3, 3]), vec![1, 2, 0]);
/// ```
pub fn id_order(ids: &[usize]) -> Vec<usize> {
    let n = ids.len();
    let mut order = vec![usize::MAX; n];
    let is_permutation = ids.iter().enumerate().all(|(k, &id)| {
        id < n && order[id] == usize::MAX && {
            order[id] = k;
            true
        }
    });
    if !is_permutation {
        order = (0..n).collect();
        order.par_sort_by_key(|&k| ids[k]);
    }
    order
}

/// Write one row per entry of `order` (`row(k, out)` appends the row of storage index
/// `k`, newline included), formatting chunks in parallel on the current rayon pool; each
/// batch is written while the next one is formatted.
pub fn write_rows(
    writer: &mut (dyn Write + Send),
    order: &[usize],
    row: impl Fn(usize, &mut Vec<u8>) + Sync,
) -> std::io::Result<()> {
    let batch = ROWS_PER_CHUNK * 2 * rayon::current_num_threads().max(1);
    let format = |rows: &[usize]| -> Vec<Vec<u8>> {
        rows.par_chunks(ROWS_PER_CHUNK)
            .map(|chunk| {
                let mut out = Vec::with_capacity(chunk.len() * 160);
                for &k in chunk {
                    row(k, &mut out);
                }
                out
            })
            .collect()
    };
    let write = |writer: &mut (dyn Write + Send), chunks: &[Vec<u8>]| {
        chunks.iter().try_for_each(|chunk| writer.write_all(chunk))
    };
    let mut pending: Vec<Vec<u8>> = Vec::new();
    for rows in order.chunks(batch) {
        let (written, formatted) = rayon::join(|| write(writer, &pending), || format(rows));
        written?;
        pending = formatted;
    }
    write(writer, &pending)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_come_out_in_order_for_any_thread_count() {
        let order: Vec<usize> = (0..3 * ROWS_PER_CHUNK + 17).rev().collect();
        let write = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let mut out = Vec::new();
            pool.install(|| {
                write_rows(&mut out, &order, |k, out| {
                    out.extend_from_slice(format!("{k}\n").as_bytes())
                })
            })
            .unwrap();
            out
        };
        let serial = write(1);
        let expected: String = order.iter().map(|k| format!("{k}\n")).collect();
        assert_eq!(serial, expected.into_bytes());
        assert_eq!(write(3), serial);
    }

    #[test]
    fn id_order_inverts_permutations_and_sorts_the_rest() {
        let ids = [4, 0, 3, 1, 2];
        let order = id_order(&ids);
        let sorted: Vec<usize> = order.iter().map(|&k| ids[k]).collect();
        assert_eq!(sorted, vec![0, 1, 2, 3, 4]);
        // Not a permutation (gap and duplicate): stable sort.
        assert_eq!(id_order(&[9, 2, 2, 0]), vec![3, 1, 2, 0]);
        assert!(id_order(&[]).is_empty());
    }
}
