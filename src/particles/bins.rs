//! Per-cell particle bins by counting sort.
//!
//! `cell_start[e]..cell_start[e+1]` are the particles of cell `e` after sorting. The sort
//! is stable, so the particle order (and therefore every per-cell sum) is deterministic.

use super::Particles;

/// The stable counting sort by cell shared by every particle store: fills `cell_start`
/// (`cells + 1` entries, `cell_start[e]` the first slot of cell `e`) from `cell` (each
/// `< cells`) and returns `true` when `cell` is already non-decreasing; otherwise fills
/// `order` with the particles of cell 0, then of cell 1, ..., each cell's in storage order,
/// and returns `false`.
///
/// ```
/// let (mut start, mut order) = (Vec::new(), Vec::new());
/// assert!(!tlsmpm::particles::counting_order(&[2, 0, 2, 1], 3, &mut start, &mut order));
/// assert_eq!((start, order), (vec![0, 1, 2, 4], vec![1, 3, 0, 2]));
/// ```
pub fn counting_order(
    cell: &[usize],
    cells: usize,
    cell_start: &mut Vec<usize>,
    order: &mut Vec<usize>,
) -> bool {
    cell_start.clear();
    cell_start.resize(cells + 1, 0);
    for &c in cell {
        cell_start[c + 1] += 1;
    }
    for e in 0..cells {
        cell_start[e + 1] += cell_start[e];
    }
    if cell.windows(2).all(|w| w[0] <= w[1]) {
        return true;
    }
    order.clear();
    order.resize(cell.len(), 0);
    let mut next = cell_start[..cells].to_vec();
    for (k, &c) in cell.iter().enumerate() {
        order[next[c]] = k;
        next[c] += 1;
    }
    false
}

/// Sorted per-cell bins: `cell_start` has `N_e + 1` entries.
#[derive(Clone, Debug, Default)]
pub struct CellBins {
    pub cell_start: Vec<usize>,
    order: Vec<usize>,
    scratch: Vec<f64>,
}

impl CellBins {
    /// Particles of cell `cell` as an index range.
    #[inline]
    pub fn range(&self, cell: usize) -> std::ops::Range<usize> {
        self.cell_start[cell]..self.cell_start[cell + 1]
    }

    /// Number of cells.
    pub fn cells(&self) -> usize {
        self.cell_start.len().saturating_sub(1)
    }

    /// The bins of particles whose cells `cell` are already non-decreasing: `cell_start[e]`
    /// is the first particle with `cell >= e`, found in one scan of the cell boundaries
    /// (no counting, no permutation). The same bins as [`CellBins::sort`] gives for
    /// sorted particles.
    ///
    /// ```
    /// let mut bins = tlsmpm::particles::CellBins::default();
    /// bins.rebuild_sorted(&[0, 0, 2, 2, 2, 3], 5);
    /// assert_eq!(bins.cell_start, [0, 2, 2, 5, 6, 6]);
    /// ```
    pub fn rebuild_sorted(&mut self, cell: &[usize], cells: usize) {
        debug_assert!(cell.windows(2).all(|w| w[0] <= w[1]));
        self.cell_start.clear();
        self.cell_start.resize(cells + 1, cell.len());
        let mut next = 0;
        for (p, &c) in cell.iter().enumerate() {
            // Cells `next..=c` start at `p` (empty ones included).
            if c >= next {
                self.cell_start[next..=c].fill(p);
                next = c + 1;
            }
        }
    }

    /// Counting-sort `particles` by `particles.cell` into `cells` bins, permuting the
    /// particle arrays only when the order actually changed.
    pub fn sort(&mut self, particles: &mut Particles, cells: usize) {
        if counting_order(
            &particles.cell,
            cells,
            &mut self.cell_start,
            &mut self.order,
        ) {
            return;
        }
        particles.permute(&self.order, &mut self.scratch);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::Grid;

    #[test]
    fn counting_sort_groups_by_cell_stably() {
        let grid = Grid::new(1.0, 4);
        let mut p = Particles::at_subcell_centres(&grid, 2, 1.0);
        // Scramble: move particle 0 into cell 3 and particle 7 into cell 0.
        p.cell[0] = 3;
        p.x[0] = 0.9;
        p.cell[7] = 0;
        p.x[7] = 0.1;
        let mut bins = CellBins::default();
        bins.sort(&mut p, 4);
        assert_eq!(bins.cell_start, vec![0, 2, 4, 6, 8]);
        assert!(p.cell.windows(2).all(|w| w[0] <= w[1]));
        assert_eq!(p.id, vec![1, 7, 2, 3, 4, 5, 0, 6]);
        assert_eq!(p.x[1], 0.1);
        assert_eq!(bins.range(3), 6..8);
    }

    proptest::proptest! {
        /// For particles in cell order, the boundary scan gives the counting sort's bins.
        #[test]
        fn boundary_scan_equals_counting_sort(
            mut cell in proptest::collection::vec(0usize..12, 0..60),
            extra in 0usize..4,
        ) {
            cell.sort_unstable();
            let cells = 12 + extra;
            let mut p = Particles::at_subcell_centres(&Grid::new(1.0, 1), cell.len(), 1.0);
            p.cell.clone_from(&cell);
            let (mut counted, mut scanned) = (CellBins::default(), CellBins::default());
            counted.sort(&mut p, cells);
            scanned.rebuild_sorted(&cell, cells);
            proptest::prop_assert_eq!(counted.cell_start, scanned.cell_start);
        }
    }
}
