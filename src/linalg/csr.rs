//! Compressed sparse row matrices: the one sparse format of the crate.

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
            let range = self.row_start[i]..self.row_start[i + 1];
            *yi = self.col_index[range.clone()]
                .iter()
                .zip(&self.values[range])
                .map(|(&j, &a)| a * x[j])
                .sum();
        }
    }

    /// The diagonal (zero where a row stores no diagonal entry).
    pub fn diagonal(&self) -> Vec<f64> {
        (0..self.rows.min(self.cols))
            .map(|i| {
                let range = self.row_start[i]..self.row_start[i + 1];
                self.col_index[range.clone()]
                    .iter()
                    .zip(&self.values[range])
                    .find(|(&j, _)| j == i)
                    .map_or(0.0, |(_, &a)| a)
            })
            .collect()
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
}
