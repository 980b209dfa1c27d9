//! Compressed sparse row matrices: the one sparse format of the crate.

/// Rows per rayon task of the parallel products.
const PAR_BLOCK: usize = 4096;

/// A square or rectangular matrix in CSR form.
#[derive(Clone, Debug, PartialEq)]
pub struct CsrMatrix {
    pub rows: usize,
    pub cols: usize,
    /// `row_start[i]..row_start[i+1]` indexes row `i` in `col_index` / `values`.
    pub row_start: Vec<usize>,
    pub col_index: Vec<usize>,
    pub values: Vec<f64>,
}

impl CsrMatrix {
    /// Build from `(row, col, value)` triplets; duplicates are summed, columns sorted.
    pub fn from_triplets(rows: usize, cols: usize, triplets: &[(usize, usize, f64)]) -> Self {
        let mut sorted: Vec<(usize, usize, f64)> = triplets
            .iter()
            .copied()
            .filter(|&(r, c, _)| r < rows && c < cols)
            .collect();
        sorted.sort_by_key(|&(r, c, _)| (r, c));
        let mut row_start = vec![0; rows + 1];
        let mut col_index = Vec::with_capacity(sorted.len());
        let mut values: Vec<f64> = Vec::with_capacity(sorted.len());
        let mut last: Option<(usize, usize)> = None;
        for (r, c, v) in sorted {
            if last == Some((r, c)) {
                if let Some(back) = values.last_mut() {
                    *back += v;
                }
                continue;
            }
            col_index.push(c);
            values.push(v);
            row_start[r + 1] += 1;
            last = Some((r, c));
        }
        for i in 0..rows {
            row_start[i + 1] += row_start[i];
        }
        Self {
            rows,
            cols,
            row_start,
            col_index,
            values,
        }
    }

    /// The `n x n` matrix with the symmetric band pattern `|i - j| <= bandwidth`, all zero.
    /// Row `i` stores columns `i.saturating_sub(bandwidth) ..= min(i + bandwidth, n - 1)` in
    /// order, so [`CsrMatrix::band_index`] finds an entry without a search.
    ///
    /// ```
    /// let m = tlsmpm::linalg::CsrMatrix::band(4, 1);
    /// assert_eq!(m.row_start, vec![0, 2, 5, 8, 10]);
    /// assert_eq!(m.band_index(2, 3), 7);
    /// ```
    pub fn band(n: usize, bandwidth: usize) -> Self {
        let mut row_start = Vec::with_capacity(n + 1);
        let mut col_index = Vec::new();
        row_start.push(0);
        for i in 0..n {
            let last = (i + bandwidth).min(n.saturating_sub(1));
            col_index.extend(i.saturating_sub(bandwidth)..=last);
            row_start.push(col_index.len());
        }
        let values = vec![0.0; col_index.len()];
        Self {
            rows: n,
            cols: n,
            row_start,
            col_index,
            values,
        }
    }

    /// Position of `(row, col)` in `values` for a matrix built by [`CsrMatrix::band`] with
    /// `|row - col|` within the band.
    #[inline]
    pub fn band_index(&self, row: usize, col: usize) -> usize {
        self.row_start[row] + col - self.col_index[self.row_start[row]]
    }

    /// Replace the rows and columns of the DOFs with `keep[i] == false` by those of the
    /// identity (Dirichlet or inactive DOFs eliminated from a symmetric system).
    pub fn constrain(&mut self, keep: &[bool]) {
        for (i, &keep_row) in keep.iter().enumerate().take(self.rows) {
            for k in self.row_start[i]..self.row_start[i + 1] {
                let j = self.col_index[k];
                if !keep_row || !keep[j] {
                    self.values[k] = if i == j { 1.0 } else { 0.0 };
                }
            }
        }
    }

    /// `y = A x`.
    pub fn mul_vec(&self, x: &[f64], y: &mut [f64]) {
        for (i, yi) in y.iter_mut().enumerate().take(self.rows) {
            *yi = self.row_times(i, x);
        }
    }

    /// The diagonal (zero where a row stores no diagonal entry).
    pub fn diagonal(&self) -> Vec<f64> {
        let mut diagonal = Vec::new();
        self.diagonal_into(&mut diagonal);
        diagonal
    }

    /// The diagonal into `out`, reusing its allocation (per-solve set-ups).
    pub fn diagonal_into(&self, out: &mut Vec<f64>) {
        out.clear();
        out.extend((0..self.rows.min(self.cols)).map(|i| {
            let range = self.row_start[i]..self.row_start[i + 1];
            let columns = &self.col_index[range.clone()];
            // Columns are sorted in every matrix the crate builds: binary search, with a
            // scan as the fallback for hand-made unsorted rows.
            let position = columns
                .binary_search(&i)
                .ok()
                .or_else(|| columns.iter().position(|&j| j == i));
            position.map_or(0.0, |k| self.values[range.start + k])
        }));
    }

    /// Row `i`'s diagonal entry (0 where the row stores none) and whether the row couples
    /// to another DOF: a non-zero off-diagonal value in a column `j` with `active[j]`
    /// (any column without `active`). For an active row this is the row of the matrix
    /// [`CsrMatrix::constrain`] would build from `active`, read without the copy.
    ///
    /// ```
    /// let m = tlsmpm::linalg::CsrMatrix::from_triplets(
    ///     3, 3, &[(0, 0, 2.0), (0, 1, 0.5), (1, 1, 3.0), (2, 2, 4.0)]);
    /// assert_eq!(m.diagonal_and_coupling(0, None), (2.0, true));
    /// assert_eq!(m.diagonal_and_coupling(0, Some(&[true, false, true])), (2.0, false));
    /// assert_eq!(m.diagonal_and_coupling(2, None), (4.0, false));
    /// ```
    pub fn diagonal_and_coupling(&self, i: usize, active: Option<&[bool]>) -> (f64, bool) {
        let (mut diagonal, mut coupled) = (0.0, false);
        for k in self.row_start[i]..self.row_start[i + 1] {
            let j = self.col_index[k];
            if j == i {
                diagonal = self.values[k];
            } else if self.values[k] != 0.0 && active.is_none_or(|active| active[j]) {
                coupled = true;
            }
        }
        (diagonal, coupled)
    }

    /// Whether row `i` stores no non-zero off-diagonal value: a DOF eliminated by
    /// [`CsrMatrix::constrain`] (an identity row), decoupled from the others.
    pub fn row_is_decoupled(&self, i: usize) -> bool {
        (self.row_start[i]..self.row_start[i + 1])
            .all(|k| self.col_index[k] == i || self.values[k] == 0.0)
    }
}

impl CsrMatrix {
    /// The `n x n` identity.
    pub fn identity(n: usize) -> Self {
        Self {
            rows: n,
            cols: n,
            row_start: (0..=n).collect(),
            col_index: (0..n).collect(),
            values: vec![1.0; n],
        }
    }

    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.values.len()
    }

    /// Whether `other` has the same shape and sparsity pattern (so a symbolic
    /// factorisation or a hierarchy built for one serves the other).
    pub fn same_pattern(&self, other: &CsrMatrix) -> bool {
        self.rows == other.rows
            && self.cols == other.cols
            && self.row_start == other.row_start
            && self.col_index == other.col_index
    }

    /// `y = A x`, rows split over the rayon pool in fixed blocks. Every `y_i` is summed
    /// in the same order as by [`CsrMatrix::mul_vec`], so the result is bitwise the same
    /// for any thread count.
    pub fn par_mul_vec(&self, x: &[f64], y: &mut [f64]) {
        if self.rows < 2 * PAR_BLOCK {
            self.mul_vec(x, y);
            return;
        }
        self.par_mul_vec_rows(x, &mut y[..self.rows], 0);
    }

    /// `y_i = (A x)_{first + i}` for the rows `first..first + y.len()`, in fixed blocks
    /// over the rayon pool (each row summed as by [`CsrMatrix::mul_vec`]).
    pub fn par_mul_vec_rows(&self, x: &[f64], y: &mut [f64], first: usize) {
        use rayon::prelude::*;
        y.par_chunks_mut(PAR_BLOCK)
            .enumerate()
            .for_each(|(block, y_block)| {
                let first = first + block * PAR_BLOCK;
                for (offset, yi) in y_block.iter_mut().enumerate() {
                    *yi = self.row_times(first + offset, x);
                }
            });
    }

    /// `ys[s] = A xs[s]` for every `s`, rows split over the rayon pool in fixed blocks: one
    /// pass over `A` for all the products (each row is read from memory once and from cache
    /// for the other vectors), each written straight into its own output. Every entry is
    /// summed as by [`CsrMatrix::mul_vec`], so each product is bitwise
    /// [`CsrMatrix::par_mul_vec`]'s.
    ///
    /// ```
    /// let a = tlsmpm::linalg::CsrMatrix::from_triplets(
    ///     2, 2, &[(0, 0, 2.0), (0, 1, 1.0), (1, 1, 3.0)]);
    /// let (mut y0, mut y1) = (vec![0.0; 2], vec![0.0; 2]);
    /// a.par_mul_vecs(&[&[1.0, 1.0], &[1.0, -1.0]], &mut [&mut y0, &mut y1]);
    /// assert_eq!((y0, y1), (vec![3.0, 3.0], vec![1.0, -3.0]));
    /// ```
    pub fn par_mul_vecs(&self, xs: &[&[f64]], ys: &mut [&mut [f64]]) {
        use rayon::prelude::*;
        let blocks = self.rows.div_ceil(PAR_BLOCK);
        let mut outputs: Vec<Vec<&mut [f64]>> =
            (0..blocks).map(|_| Vec::with_capacity(xs.len())).collect();
        for y in ys.iter_mut() {
            for (block, chunk) in y[..self.rows].chunks_mut(PAR_BLOCK).enumerate() {
                outputs[block].push(chunk);
            }
        }
        let rows_of = |(block, mut outs): (usize, Vec<&mut [f64]>)| {
            let first = block * PAR_BLOCK;
            let len = outs.first().map_or(0, |y| y.len());
            for offset in 0..len {
                for (x, y) in xs.iter().zip(outs.iter_mut()) {
                    y[offset] = self.row_times(first + offset, x);
                }
            }
        };
        if self.rows < 2 * PAR_BLOCK {
            outputs.into_iter().enumerate().for_each(rows_of);
        } else {
            outputs.into_par_iter().enumerate().for_each(rows_of);
        }
    }

    /// `(A x)_i`, the row's products summed in storage order (as [`CsrMatrix::mul_vec`]).
    #[inline]
    pub fn row_times(&self, i: usize, x: &[f64]) -> f64 {
        let range = self.row_start[i]..self.row_start[i + 1];
        self.col_index[range.clone()]
            .iter()
            .zip(&self.values[range])
            .map(|(&j, &a)| a * x[j])
            .sum()
    }

    /// `y = A^T x`.
    pub fn mul_transpose_vec(&self, x: &[f64], y: &mut [f64]) {
        y[..self.cols].fill(0.0);
        for (i, &xi) in x.iter().enumerate().take(self.rows) {
            for k in self.row_start[i]..self.row_start[i + 1] {
                y[self.col_index[k]] += self.values[k] * xi;
            }
        }
    }

    /// Row sums `sum_j A_ij`: the row-sum lumped diagonal of a mass matrix.
    pub fn row_sums(&self) -> Vec<f64> {
        (0..self.rows)
            .map(|i| {
                self.values[self.row_start[i]..self.row_start[i + 1]]
                    .iter()
                    .sum()
            })
            .collect()
    }

    /// `A^T`.
    pub fn transpose(&self) -> CsrMatrix {
        let mut count = vec![0usize; self.cols + 1];
        for &j in &self.col_index {
            count[j + 1] += 1;
        }
        for j in 0..self.cols {
            count[j + 1] += count[j];
        }
        let row_start = count.clone();
        let mut next = count;
        let mut col_index = vec![0; self.nnz()];
        let mut values = vec![0.0; self.nnz()];
        for i in 0..self.rows {
            for k in self.row_start[i]..self.row_start[i + 1] {
                let j = self.col_index[k];
                col_index[next[j]] = i;
                values[next[j]] = self.values[k];
                next[j] += 1;
            }
        }
        CsrMatrix {
            rows: self.cols,
            cols: self.rows,
            row_start,
            col_index,
            values,
        }
    }

    /// The sparse product `A B` (columns sorted; explicit zeros of the product kept so the
    /// pattern depends on the patterns of `A` and `B` only).
    pub fn matmul(&self, other: &CsrMatrix) -> CsrMatrix {
        assert_eq!(self.cols, other.rows, "matmul: inner dimensions differ");
        let mut row_start = Vec::with_capacity(self.rows + 1);
        let mut col_index = Vec::new();
        let mut values = Vec::new();
        let mut accumulator = vec![0.0; other.cols];
        let mut marker = vec![usize::MAX; other.cols];
        let mut row_columns: Vec<usize> = Vec::new();
        row_start.push(0);
        for i in 0..self.rows {
            row_columns.clear();
            for k in self.row_start[i]..self.row_start[i + 1] {
                let (l, a) = (self.col_index[k], self.values[k]);
                for m in other.row_start[l]..other.row_start[l + 1] {
                    let j = other.col_index[m];
                    if marker[j] != i {
                        marker[j] = i;
                        accumulator[j] = 0.0;
                        row_columns.push(j);
                    }
                    accumulator[j] += a * other.values[m];
                }
            }
            row_columns.sort_unstable();
            for &j in &row_columns {
                col_index.push(j);
                values.push(accumulator[j]);
            }
            row_start.push(col_index.len());
        }
        CsrMatrix {
            rows: self.rows,
            cols: other.cols,
            row_start,
            col_index,
            values,
        }
    }

    /// The Kronecker product `A (x) B`: entry `(i_a n_b + i_b, j_a m_b + j_b)` is
    /// `A_{i_a j_a} B_{i_b j_b}`. With `B` acting on the fast (x) index, a 2D tensor-product
    /// mass matrix on DOFs `i = i_y n_x + i_x` is `M_y (x) M_x`.
    ///
    /// ```
    /// use tlsmpm::linalg::CsrMatrix;
    /// let a = CsrMatrix::from_triplets(2, 2, &[(0, 0, 1.0), (0, 1, 2.0), (1, 1, 3.0)]);
    /// let k = a.kron(&CsrMatrix::identity(2));
    /// assert_eq!((k.rows, k.nnz()), (4, 6));
    /// assert_eq!(k.values, vec![1.0, 2.0, 1.0, 2.0, 3.0, 3.0]);
    /// ```
    pub fn kron(&self, other: &CsrMatrix) -> CsrMatrix {
        let rows = self.rows * other.rows;
        let cols = self.cols * other.cols;
        let mut row_start = Vec::with_capacity(rows + 1);
        let mut col_index = Vec::with_capacity(self.nnz() * other.nnz());
        let mut values = Vec::with_capacity(self.nnz() * other.nnz());
        row_start.push(0);
        for ia in 0..self.rows {
            for ib in 0..other.rows {
                for ka in self.row_start[ia]..self.row_start[ia + 1] {
                    let (ja, a) = (self.col_index[ka], self.values[ka]);
                    for kb in other.row_start[ib]..other.row_start[ib + 1] {
                        col_index.push(ja * other.cols + other.col_index[kb]);
                        values.push(a * other.values[kb]);
                    }
                }
                row_start.push(col_index.len());
            }
        }
        CsrMatrix {
            rows,
            cols,
            row_start,
            col_index,
            values,
        }
    }

    /// The rows with `keep_rows[i]` and the columns with `keep_cols[j]`, renumbered in
    /// order (boundary DOFs eliminated by dropping them).
    pub fn submatrix(&self, keep_rows: &[bool], keep_cols: &[bool]) -> CsrMatrix {
        let mut new_col = vec![usize::MAX; self.cols];
        let mut cols = 0;
        for (j, &keep) in keep_cols.iter().enumerate().take(self.cols) {
            if keep {
                new_col[j] = cols;
                cols += 1;
            }
        }
        let mut row_start = vec![0];
        let mut col_index = Vec::new();
        let mut values = Vec::new();
        for (i, &keep) in keep_rows.iter().enumerate().take(self.rows) {
            if !keep {
                continue;
            }
            for k in self.row_start[i]..self.row_start[i + 1] {
                let j = new_col[self.col_index[k]];
                if j != usize::MAX {
                    col_index.push(j);
                    values.push(self.values[k]);
                }
            }
            row_start.push(col_index.len());
        }
        CsrMatrix {
            rows: row_start.len() - 1,
            cols,
            row_start,
            col_index,
            values,
        }
    }

    /// The dense matrix, row by row (duplicates summed): for tests and small debugging
    /// output.
    pub fn to_dense(&self) -> Vec<Vec<f64>> {
        let mut dense = vec![vec![0.0; self.cols]; self.rows];
        for (i, row) in dense.iter_mut().enumerate() {
            for k in self.row_start[i]..self.row_start[i + 1] {
                row[self.col_index[k]] += self.values[k];
            }
        }
        dense
    }

    /// Scale row `i` by `row_scale[i]`.
    pub fn scale_rows(&mut self, row_scale: &[f64]) {
        for (i, &s) in row_scale.iter().enumerate().take(self.rows) {
            for v in &mut self.values[self.row_start[i]..self.row_start[i + 1]] {
                *v *= s;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triplets_sum_duplicates_and_multiply() {
        let a =
            CsrMatrix::from_triplets(2, 2, &[(0, 0, 1.0), (0, 1, 2.0), (1, 1, 3.0), (0, 0, 1.0)]);
        assert_eq!(a.values, vec![2.0, 2.0, 3.0]);
        let mut y = [0.0; 2];
        a.mul_vec(&[1.0, 1.0], &mut y);
        assert_eq!(y, [4.0, 3.0]);
        assert_eq!(a.diagonal(), vec![2.0, 3.0]);
    }

    fn sample() -> CsrMatrix {
        CsrMatrix::from_triplets(
            3,
            2,
            &[
                (0, 0, 1.0),
                (0, 1, 2.0),
                (1, 1, 3.0),
                (2, 0, 4.0),
                (2, 1, 5.0),
            ],
        )
    }

    #[test]
    fn transpose_matmul_kron_and_submatrix_agree_with_dense_algebra() {
        let a = sample();
        let at = a.transpose();
        assert_eq!(
            at.to_dense(),
            vec![vec![1.0, 0.0, 4.0], vec![2.0, 3.0, 5.0]]
        );
        let ata = at.matmul(&a);
        assert_eq!(ata.to_dense(), vec![vec![17.0, 22.0], vec![22.0, 38.0]]);
        let k = at.kron(&a);
        let (da, dat, dk) = (a.to_dense(), at.to_dense(), k.to_dense());
        for ia in 0..2 {
            for ja in 0..3 {
                for ib in 0..3 {
                    for jb in 0..2 {
                        assert_eq!(dk[ia * 3 + ib][ja * 2 + jb], dat[ia][ja] * da[ib][jb]);
                    }
                }
            }
        }
        let s = a.submatrix(&[true, false, true], &[false, true]);
        assert_eq!(s.to_dense(), vec![vec![2.0], vec![5.0]]);
        let mut y = [0.0; 2];
        a.mul_transpose_vec(&[1.0, 1.0, 1.0], &mut y);
        assert_eq!(y, [5.0, 10.0]);
        assert_eq!(a.row_sums(), vec![3.0, 3.0, 9.0]);
    }

    #[test]
    fn parallel_product_is_bitwise_the_serial_one() {
        let n = 20_000;
        let mut a = CsrMatrix::band(n, 2);
        for (k, v) in a.values.iter_mut().enumerate() {
            *v = 1.0 / (1.0 + k as f64);
        }
        let x: Vec<f64> = (0..n).map(|i| (i as f64 * 0.1).sin()).collect();
        let (mut serial, mut parallel) = (vec![0.0; n], vec![0.0; n]);
        a.mul_vec(&x, &mut serial);
        a.par_mul_vec(&x, &mut parallel);
        assert_eq!(serial, parallel);
    }
}
