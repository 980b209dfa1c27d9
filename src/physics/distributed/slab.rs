//! Slabs of cell layers along one axis, one per rank (`docs/distributed.md`).
//!
//! The cut axis is the one with the most cells (the last of equals). Rank `r` of `R` owns
//! the cells of that axis' layers `[c_r, c_{r+1})` and every particle
//! in them; the layers are split as evenly as possible (the first `L mod R` ranks take one
//! layer more). Its particles can touch the node layers [`TensorBasis::layer_dofs`] of its
//! cells (`touched`), a range that overlaps the neighbours' by the basis support: those
//! **shared** node layers are where two ranks' scatters must be summed. For sums that
//! count each node once (grid mass, grid momentum) the node layers are partitioned:
//! rank `r` **owns** `[t_r, t_{r+1})` with `t_r` the first node layer rank `r` touches
//! (`t_0 = 0`, the last rank owns up to the end).
//!
//! Along the last axis (the slowest in the lexicographic numbering) a rank's cells and
//! nodes and each shared range are contiguous in memory; along another axis they are
//! strided, one contiguous run per index of the slower axes. A decomposition is refused
//! unless every rank shares nodes with its direct neighbours only (a slab at least as
//! thick as the basis support), so that one exchange with each neighbour completes a sum.

use crate::error::{Error, Result};
use crate::grid::{Basis, TensorBasis};
use std::ops::Range;

/// The split of a grid's cell layers along one axis over ranks.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SlabDecomposition {
    /// The cut axis.
    axis: usize,
    cell_layers: Vec<Range<usize>>,
    touched: Vec<Range<usize>>,
    owned: Vec<Range<usize>>,
    node_layers: usize,
}

impl SlabDecomposition {
    /// `ranks` slabs of `basis`' grid along its longest axis in cells (the last of
    /// equals).
    ///
    /// Errors (naming `grid.cells`) when there are more ranks than cell layers along that
    /// axis or a slab would be thinner than the basis support.
    pub fn new<const D: usize, B: Basis>(basis: &TensorBasis<D, B>, ranks: usize) -> Result<Self> {
        let axis = (0..D)
            .rev()
            .max_by_key(|&a| (basis.grid.axes[a].cells, a))
            .unwrap_or(0);
        let layers = basis.grid.axes[axis].cells;
        let node_layers = basis.dofs()[axis];
        let along = basis.axis(axis);
        let mut slabs = Self::from_layer_dofs(layers, node_layers, ranks, |l| {
            let (first, _) = along.cell_window(l.start);
            let (end_first, end_len) = along.cell_window(l.end - 1);
            first..end_first + end_len
        })
        .map_err(|e| match e {
            Error::InvalidValue { key, value, reason } => Error::InvalidValue {
                key,
                value,
                reason: reason.replace("the cut axis", &format!("axis {}", ["x", "y", "z"][axis])),
            },
            e => e,
        })?;
        slabs.axis = axis;
        Ok(slabs)
    }

    /// The split of `layers` cell layers whose cells touch the node layers
    /// `layer_dofs(cell layers)` of `node_layers` in all.
    ///
    /// ```
    /// use tlsmpm::physics::distributed::SlabDecomposition;
    /// // 10 cell layers of quadratic B-splines (cell c touches node layers c..c+3).
    /// let slabs = SlabDecomposition::from_layer_dofs(10, 12, 3, |l| l.start..l.end + 2).unwrap();
    /// assert_eq!(slabs.cell_layers(0), 0..4);
    /// assert_eq!(slabs.cell_layers(2), 7..10);
    /// assert_eq!(slabs.touched_node_layers(1), 4..9);
    /// assert_eq!(slabs.shared_with_upper(0), 4..6);
    /// assert_eq!(slabs.owned_node_layers(1), 4..7);
    /// ```
    pub fn from_layer_dofs(
        layers: usize,
        node_layers: usize,
        ranks: usize,
        layer_dofs: impl Fn(Range<usize>) -> Range<usize>,
    ) -> Result<Self> {
        if ranks == 0 {
            return Err(Error::invalid(
                "ranks",
                ranks,
                "at least one rank is needed",
            ));
        }
        if ranks > layers {
            return Err(Error::invalid(
                "grid.cells",
                layers,
                format!(
                    "{ranks} ranks on {layers} cell layers along the cut axis: at most one \
                     rank per layer (use fewer ranks or more cells)"
                ),
            ));
        }
        let (base, extra) = (layers / ranks, layers % ranks);
        let mut cell_layers = Vec::with_capacity(ranks);
        let mut start = 0;
        for r in 0..ranks {
            let len = base + usize::from(r < extra);
            cell_layers.push(start..start + len);
            start += len;
        }
        let touched: Vec<Range<usize>> =
            cell_layers.iter().map(|l| layer_dofs(l.clone())).collect();
        for r in 1..ranks.saturating_sub(1) {
            if touched[r - 1].end > touched[r + 1].start {
                let thinnest = cell_layers.iter().map(|l| l.len()).min().unwrap_or(0);
                return Err(Error::invalid(
                    "grid.cells",
                    layers,
                    format!(
                        "{ranks} ranks on {layers} cell layers along the cut axis give slabs \
                         of {thinnest} layers, thinner than the basis support: ranks {} and {} \
                         would share nodes (use fewer ranks or more cells)",
                        r - 1,
                        r + 1
                    ),
                ));
            }
        }
        let owned = (0..ranks)
            .map(|r| {
                let start = if r == 0 { 0 } else { touched[r].start };
                let end = if r + 1 == ranks {
                    node_layers
                } else {
                    touched[r + 1].start
                };
                start..end
            })
            .collect();
        Ok(Self {
            axis: 0,
            cell_layers,
            touched,
            owned,
            node_layers,
        })
    }

    /// The cut axis (0 for a decomposition made by [`Self::from_layer_dofs`]).
    pub fn axis(&self) -> usize {
        self.axis
    }

    /// Number of ranks.
    pub fn ranks(&self) -> usize {
        self.cell_layers.len()
    }

    /// Node layers along the cut axis.
    pub fn node_layers(&self) -> usize {
        self.node_layers
    }

    /// The cell layers of rank `r` along the cut axis.
    pub fn cell_layers(&self, r: usize) -> Range<usize> {
        self.cell_layers[r].clone()
    }

    /// The rank that owns cell layer `layer` of the cut axis.
    pub fn owner_of_layer(&self, layer: usize) -> usize {
        self.cell_layers
            .partition_point(|l| l.end <= layer)
            .min(self.ranks() - 1)
    }

    /// The node layers the particles of rank `r` can touch.
    pub fn touched_node_layers(&self, r: usize) -> Range<usize> {
        self.touched[r].clone()
    }

    /// The node layers rank `r` counts in sums over the grid (a partition of all layers).
    pub fn owned_node_layers(&self, r: usize) -> Range<usize> {
        self.owned[r].clone()
    }

    /// The node layers ranks `r` and `r + 1` both touch (empty for the last rank).
    pub fn shared_with_upper(&self, r: usize) -> Range<usize> {
        match self.touched.get(r + 1) {
            Some(upper) => upper.start..self.touched[r].end.max(upper.start),
            None => 0..0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{BSplineBasis, GimpBasis, LinearBasis, TensorGrid};
    use proptest::prelude::*;

    fn check_invariants(slabs: &SlabDecomposition, layers: usize) {
        let ranks = slabs.ranks();
        // Cell layers: consecutive, covering, non-empty.
        assert_eq!(slabs.cell_layers(0).start, 0);
        assert_eq!(slabs.cell_layers(ranks - 1).end, layers);
        for r in 0..ranks {
            assert!(!slabs.cell_layers(r).is_empty());
            if r > 0 {
                assert_eq!(slabs.cell_layers(r - 1).end, slabs.cell_layers(r).start);
            }
            for l in slabs.cell_layers(r) {
                assert_eq!(slabs.owner_of_layer(l), r);
            }
        }
        // Owned node layers partition 0..node_layers, each inside the owner's touched range.
        let mut next = 0;
        for r in 0..ranks {
            let owned = slabs.owned_node_layers(r);
            assert_eq!(owned.start, next);
            next = owned.end;
            let touched = slabs.touched_node_layers(r);
            assert!(touched.start <= owned.start && owned.end <= touched.end.max(owned.end));
            assert!(
                owned.is_empty() || owned.end <= touched.end,
                "rank {r}: {owned:?} {touched:?}"
            );
        }
        assert_eq!(next, slabs.node_layers());
        // Only neighbours share nodes.
        for r in 0..ranks {
            for s in r + 2..ranks {
                assert!(slabs.touched_node_layers(r).end <= slabs.touched_node_layers(s).start);
            }
        }
    }

    #[test]
    fn refuses_more_ranks_than_layers_and_thin_slabs() {
        let grid = TensorGrid::new([1.0, 1.0], [4, 4]);
        let p2 = TensorBasis::new(grid, |g| BSplineBasis::new(g, 2).unwrap());
        let message = SlabDecomposition::new(&p2, 5).unwrap_err().to_string();
        assert!(
            message.contains("grid.cells") && message.contains("5 ranks on 4"),
            "{message}"
        );
        // 4 layers on 3 ranks: slabs of 1 layer, quadratic support 3 nodes.
        let message = SlabDecomposition::new(&p2, 3).unwrap_err().to_string();
        assert!(
            message.contains("thinner than the basis support"),
            "{message}"
        );
        assert!(SlabDecomposition::new(&p2, 0).is_err());
        let linear = TensorBasis::new(grid, LinearBasis::new);
        assert!(SlabDecomposition::new(&linear, 4).is_ok());
    }

    #[test]
    fn the_cut_is_along_the_longest_axis() {
        let wide = TensorGrid::new([2.0, 1.0], [8, 4]);
        let p2 = TensorBasis::new(wide, |g| BSplineBasis::new(g, 2).unwrap());
        let slabs = SlabDecomposition::new(&p2, 2).unwrap();
        assert_eq!((slabs.axis(), slabs.cell_layers(1)), (0, 4..8));
        assert_eq!(slabs.node_layers(), 10);
        let message = SlabDecomposition::new(&p2, 9).unwrap_err().to_string();
        assert!(
            message.contains("9 ranks on 8 cell layers along axis x"),
            "{message}"
        );
        let cube = TensorGrid::new([1.0; 3], [4, 6, 6]);
        let linear = TensorBasis::new(cube, LinearBasis::new);
        assert_eq!(SlabDecomposition::new(&linear, 2).unwrap().axis(), 2);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn slabs_partition_cells_and_nodes(layers in 1usize..40, ranks in 1usize..9, order in 1usize..4, gimp: bool) {
            let grid = TensorGrid::new([1.0, 2.0], [3, layers]);
            let slabs = if gimp {
                SlabDecomposition::new(&TensorBasis::new(grid, GimpBasis::new), ranks)
            } else {
                SlabDecomposition::new(&TensorBasis::new(grid, |g| BSplineBasis::new(g, order).unwrap()), ranks)
            };
            match slabs {
                // Fewer than 3 layers in y: the cut is along x.
                Ok(slabs) => check_invariants(&slabs, grid.axes[slabs.axis()].cells),
                Err(e) => prop_assert!(ranks > 1 && e.to_string().contains("grid.cells"), "{e}"),
            }
        }
    }
}
