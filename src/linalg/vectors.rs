//! The vector operations of the Krylov solves (`docs/solvers.md`, "Vector operations"):
//! dot products, the CG updates and the projections onto kept DOFs, fused where they
//! read the same vectors.
//!
//! Short vectors (below [`PARALLEL_MIN_LEN`], every 1D system of the published
//! benchmarks) are handled in one serial pass, each sum in index order. Long vectors (a
//! 2D / 3D consistent mass: 2.5·10⁵ DOFs at 500² cells) are split into fixed blocks of
//! [`BLOCK`] entries over the rayon pool: a sum is the sum, in block order, of the blocks'
//! partial sums, each taken over four interleaved lanes,
//!
//! ```text
//! s = sum_b ((s_b0 + s_b1) + (s_b2 + s_b3)),   s_bj = sum_(i in block b, i = j mod 4) a_i b_i
//! ```
//!
//! so the result depends on the vector length only, never on the thread count.

use rayon::prelude::*;

/// Vectors at least this long are processed in parallel blocks.
pub const PARALLEL_MIN_LEN: usize = 16_384;

/// Entries per block of a long vector.
const BLOCK: usize = 4096;

/// `sum_i a_i b_i` of one block over four lanes (module docs).
#[inline]
fn block_dot(a: &[f64], b: &[f64]) -> f64 {
    let mut lanes = [0.0; 4];
    let (a4, b4) = (a.chunks_exact(4), b.chunks_exact(4));
    let (a_rest, b_rest) = (a4.remainder(), b4.remainder());
    for (a, b) in a4.zip(b4) {
        for j in 0..4 {
            lanes[j] += a[j] * b[j];
        }
    }
    for (j, (a, b)) in a_rest.iter().zip(b_rest).enumerate() {
        lanes[j] += a * b;
    }
    (lanes[0] + lanes[1]) + (lanes[2] + lanes[3])
}

/// The partial sums of the blocks, added in block order.
fn sum_blocks(partials: impl IndexedParallelIterator<Item = f64>) -> f64 {
    let partials: Vec<f64> = partials.collect();
    partials.iter().sum()
}

/// `sum_i a_i b_i` (module docs for the order of the sum).
///
/// ```
/// use tlsmpm::linalg::vectors::dot;
/// assert_eq!(dot(&[1.0, 2.0], &[3.0, 4.0]), 11.0);
/// let long = vec![0.5; 40_000];
/// assert_eq!(dot(&long, &long), 10_000.0);
/// ```
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    if a.len() < PARALLEL_MIN_LEN {
        return a.iter().zip(b).map(|(x, y)| x * y).sum();
    }
    sum_blocks(
        a.par_chunks(BLOCK)
            .zip(b.par_chunks(BLOCK))
            .map(|(a, b)| block_dot(a, b)),
    )
}

/// `v_i = 0` where `keep[i]` is false (no-op without `keep`), then `sum_i v_i w_i`.
pub fn project_dot(v: &mut [f64], keep: Option<&[bool]>, w: &[f64]) -> f64 {
    if v.len() < PARALLEL_MIN_LEN {
        project_serial(v, keep);
        return dot(v, w);
    }
    sum_blocks(
        v.par_chunks_mut(BLOCK)
            .zip(w.par_chunks(BLOCK))
            .enumerate()
            .map(|(block, (v, w))| {
                project_serial(v, keep.map(|k| &k[block * BLOCK..][..v.len()]));
                block_dot(v, w)
            }),
    )
}

/// `v_i = 0` where `keep[i]` is false (no-op without `keep`).
pub fn project(v: &mut [f64], keep: Option<&[bool]>) {
    if v.len() < PARALLEL_MIN_LEN {
        return project_serial(v, keep);
    }
    v.par_chunks_mut(BLOCK).enumerate().for_each(|(block, v)| {
        project_serial(v, keep.map(|k| &k[block * BLOCK..][..v.len()]));
    });
}

fn project_serial(v: &mut [f64], keep: Option<&[bool]>) {
    if let Some(keep) = keep {
        for (vi, &k) in v.iter_mut().zip(keep) {
            if !k {
                *vi = 0.0;
            }
        }
    }
}

/// The residual of a starting guess: `r = b - q` (`q = A x`), projected onto `keep`;
/// returns `r . r`.
pub fn residual(r: &mut [f64], b: &[f64], q: &[f64], keep: Option<&[bool]>) -> f64 {
    let serial = |r: &mut [f64], b: &[f64], q: &[f64], keep: Option<&[bool]>| {
        for ((r, bi), qi) in r.iter_mut().zip(b).zip(q) {
            *r = bi - qi;
        }
        project_serial(r, keep);
    };
    if r.len() < PARALLEL_MIN_LEN {
        serial(r, b, q, keep);
        return dot(r, r);
    }
    sum_blocks(
        r.par_chunks_mut(BLOCK)
            .zip(b.par_chunks(BLOCK))
            .zip(q.par_chunks(BLOCK))
            .enumerate()
            .map(|(block, ((r, b), q))| {
                serial(r, b, q, keep.map(|k| &k[block * BLOCK..][..r.len()]));
                block_dot(r, r)
            }),
    )
}

/// The CG step `x += alpha d`, `r -= alpha q`; returns `r . r` of the new residual.
pub fn cg_step(x: &mut [f64], r: &mut [f64], d: &[f64], q: &[f64], alpha: f64) -> f64 {
    let serial = |x: &mut [f64], r: &mut [f64], d: &[f64], q: &[f64]| {
        for (((xi, ri), di), qi) in x.iter_mut().zip(r.iter_mut()).zip(d).zip(q) {
            *xi += alpha * di;
            *ri -= alpha * qi;
        }
    };
    if x.len() < PARALLEL_MIN_LEN {
        serial(x, r, d, q);
        return dot(r, r);
    }
    sum_blocks(
        x.par_chunks_mut(BLOCK)
            .zip(r.par_chunks_mut(BLOCK))
            .zip(d.par_chunks(BLOCK))
            .zip(q.par_chunks(BLOCK))
            .map(|(((x, r), d), q)| {
                serial(x, r, d, q);
                block_dot(r, r)
            }),
    )
}

/// `d = z + beta d`.
pub fn new_direction(d: &mut [f64], z: &[f64], beta: f64) {
    let serial = |d: &mut [f64], z: &[f64]| {
        for (di, zi) in d.iter_mut().zip(z) {
            *di = zi + beta * *di;
        }
    };
    if d.len() < PARALLEL_MIN_LEN {
        return serial(d, z);
    }
    d.par_chunks_mut(BLOCK)
        .zip(z.par_chunks(BLOCK))
        .for_each(|(d, z)| serial(d, z));
}

/// `out_i = f(i, out_i)` for every entry, in parallel blocks for long vectors (an
/// element-wise update: the same result for any split).
pub fn update_each(out: &mut [f64], f: impl Fn(usize, f64) -> f64 + Sync) {
    if out.len() < PARALLEL_MIN_LEN {
        for (i, o) in out.iter_mut().enumerate() {
            *o = f(i, *o);
        }
        return;
    }
    out.par_chunks_mut(BLOCK)
        .enumerate()
        .for_each(|(block, out)| {
            for (offset, o) in out.iter_mut().enumerate() {
                *o = f(block * BLOCK + offset, *o);
            }
        });
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn pseudo_random(n: usize, seed: u64) -> Vec<f64> {
        let mut s = seed;
        (0..n)
            .map(|_| {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            })
            .collect()
    }

    /// Short vectors are summed in index order, as a plain serial loop.
    #[test]
    fn short_vectors_sum_in_index_order() {
        let (a, b) = (pseudo_random(1000, 1), pseudo_random(1000, 2));
        let serial: f64 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
        assert_eq!(dot(&a, &b).to_bits(), serial.to_bits());
    }

    /// Long vectors: the blocked sum of the module docs, the same bits on one and on three
    /// threads, within round-off of the serial sum.
    #[test]
    fn long_sums_are_the_same_on_any_thread_count() {
        let n = 3 * PARALLEL_MIN_LEN + 123;
        let (a, b) = (pseudo_random(n, 3), pseudo_random(n, 4));
        let on = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| dot(&a, &b))
        };
        let (one, three) = (on(1), on(3));
        assert_eq!(one.to_bits(), three.to_bits());
        let blocks: f64 = a
            .chunks(BLOCK)
            .zip(b.chunks(BLOCK))
            .map(|(a, b)| block_dot(a, b))
            .sum();
        assert_eq!(one.to_bits(), blocks.to_bits());
        let serial: f64 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
        let scale: f64 = a.iter().zip(&b).map(|(x, y)| (x * y).abs()).sum();
        assert!((one - serial).abs() <= 1e-14 * scale);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(12))]
        /// Each fused operation equals its unfused sequence (update, projection, then
        /// `dot`), bit for bit, on short and long vectors.
        #[test]
        fn fused_operations_equal_their_parts(
            n in prop_oneof![1usize..300, PARALLEL_MIN_LEN..PARALLEL_MIN_LEN + 9000],
            seed in 0u64..1000,
            alpha in -2.0f64..2.0,
        ) {
            let vectors: Vec<Vec<f64>> = (0..5).map(|k| pseudo_random(n, seed * 7 + k)).collect();
            let keep: Vec<bool> = vectors[4].iter().map(|v| *v > -0.3).collect();

            let (mut x, mut r) = (vectors[0].clone(), vectors[1].clone());
            let rr = cg_step(&mut x, &mut r, &vectors[2], &vectors[3], alpha);
            let (mut x2, mut r2) = (vectors[0].clone(), vectors[1].clone());
            update_each(&mut x2, |i, v| v + alpha * vectors[2][i]);
            update_each(&mut r2, |i, v| v - alpha * vectors[3][i]);
            prop_assert_eq!(&x, &x2);
            prop_assert_eq!(&r, &r2);
            prop_assert_eq!(rr.to_bits(), dot(&r2, &r2).to_bits());

            let mut v = vectors[0].clone();
            let vw = project_dot(&mut v, Some(&keep), &vectors[1]);
            let mut v2 = vectors[0].clone();
            project(&mut v2, Some(&keep));
            prop_assert!(v2.iter().zip(&keep).all(|(v, &k)| k || *v == 0.0));
            prop_assert_eq!(&v, &v2);
            prop_assert_eq!(vw.to_bits(), dot(&v2, &vectors[1]).to_bits());

            let mut res = vec![0.0; n];
            let rr = residual(&mut res, &vectors[0], &vectors[1], Some(&keep));
            let mut res2: Vec<f64> = vectors[0].iter().zip(&vectors[1]).map(|(b, q)| b - q).collect();
            project(&mut res2, Some(&keep));
            prop_assert_eq!(&res, &res2);
            prop_assert_eq!(rr.to_bits(), dot(&res2, &res2).to_bits());

            let mut d = vectors[2].clone();
            new_direction(&mut d, &vectors[3], alpha);
            let d2: Vec<f64> = vectors[2].iter().zip(&vectors[3]).map(|(d, z)| z + alpha * d).collect();
            prop_assert_eq!(&d, &d2);
        }
    }
}
