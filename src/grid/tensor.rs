//! The dimension-generic background grid and tensor-product bases (`D` = 1, 2, 3; see
//! `docs/dimensions.md`).
//!
//! [`TensorGrid`] is a uniform grid of `cells[a]` cells of size `h[a]` per axis on
//! `[0, L_a]`, cells and nodes numbered lexicographically with x fastest:
//! `cell = i_x + n_x (i_y + n_y i_z)`. A [`TensorBasis`] is the tensor product of one 1D
//! [`Basis`] per axis (linear hats, B-splines of any order, GIMP), so that
//!
//! ```text
//! phi_I(x) = prod_a phi^a_{I_a}(x_a),    d phi_I / d x_b = dphi^b_{I_b}(x_b) prod_{a != b} phi^a_{I_a}(x_a)
//! ```
//! A point evaluation fills one 1D [`Shape`] per axis ([`TensorShape`], on the stack); the
//! products are formed on the fly by [`TensorShape::for_each_node`], so no evaluation
//! allocates. The DOFs of axis `a` that sit on its two end faces are the 1D basis'
//! [`Basis::boundary_dofs`].

use super::{Basis, Grid, Shape};

/// Evaluate `$body` with the const `$n` set to the fixed support of `$basis` (a 1D
/// [`Basis`] or a [`TensorBasis`]: B-splines of order 1–3) when it is 2, 3 or 4, else to 0
/// (run-time support): one dispatch per pass, then loops compiled for that support size.
macro_rules! with_fixed_support {
    ($basis:expr, $n:ident => $body:expr) => {
        match $basis.fixed_support() {
            Some(2) => {
                const $n: usize = 2;
                $body
            }
            Some(3) => {
                const $n: usize = 3;
                $body
            }
            Some(4) => {
                const $n: usize = 4;
                $body
            }
            _ => {
                const $n: usize = 0;
                $body
            }
        }
    };
}
pub(crate) use with_fixed_support;

/// A uniform grid of `cells[a]` cells per axis on `[0, length[a]]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TensorGrid<const D: usize> {
    /// The 1D grid of each axis.
    pub axes: [Grid; D],
}

impl<const D: usize> TensorGrid<D> {
    /// A grid of `cells[a]` equal cells on `[0, length[a]]` per axis.
    pub fn new(length: [f64; D], cells: [usize; D]) -> Self {
        Self {
            axes: std::array::from_fn(|a| Grid::new(length[a], cells[a])),
        }
    }

    /// Total number of cells.
    pub fn num_cells(&self) -> usize {
        self.axes.iter().map(|g| g.cells).product()
    }

    /// Cell counts per axis.
    pub fn cells(&self) -> [usize; D] {
        std::array::from_fn(|a| self.axes[a].cells)
    }

    /// Cell sizes per axis.
    pub fn h(&self) -> [f64; D] {
        std::array::from_fn(|a| self.axes[a].h)
    }

    /// The smallest cell size.
    pub fn min_h(&self) -> f64 {
        self.axes.iter().map(|g| g.h).fold(f64::INFINITY, f64::min)
    }

    /// Lexicographic index of the cell with axis indices `index` (x fastest).
    #[inline]
    pub fn cell_index(&self, index: [usize; D]) -> usize {
        let mut cell = 0;
        for a in (0..D).rev() {
            cell = cell * self.axes[a].cells + index[a];
        }
        cell
    }

    /// The cell containing `x` (each axis as [`Grid::cell_of`]), `None` outside the grid.
    ///
    /// ```
    /// use tlsmpm::grid::TensorGrid;
    /// let grid = TensorGrid::new([1.0, 2.0], [4, 2]);
    /// assert_eq!(grid.cell_of([0.3, 1.5]), Some(1 + 4 * 1));
    /// assert_eq!(grid.cell_of([0.3, 2.5]), None);
    /// ```
    #[inline]
    pub fn cell_of(&self, x: [f64; D]) -> Option<usize> {
        let mut cell = 0;
        for a in (0..D).rev() {
            cell = cell * self.axes[a].cells + self.axes[a].cell_of(x[a])?;
        }
        Some(cell)
    }

    /// The axis indices of the cell containing `x` (each axis as [`Grid::cell_of`]),
    /// `None` outside the grid; [`Self::cell_index`] of them is [`Self::cell_of`].
    #[inline]
    pub fn axis_cells_of(&self, x: [f64; D]) -> Option<[usize; D]> {
        let mut index = [0; D];
        for a in 0..D {
            index[a] = self.axes[a].cell_of(x[a])?;
        }
        Some(index)
    }

    /// The axis indices of the cell containing `x`, clamped into the grid (for points known
    /// to be inside, e.g. binned particles).
    #[inline]
    pub fn axis_cells(&self, x: [f64; D]) -> [usize; D] {
        std::array::from_fn(|a| {
            let g = &self.axes[a];
            let xi = (x[a] - g.origin) * g.inv_h;
            // `as i64` saturates (NaN goes to 0) in fewer instructions than `as usize`;
            // the clamp sends negative indices to 0 and large ones to the last cell.
            (xi as i64).clamp(0, g.cells as i64 - 1) as usize
        })
    }

    /// Number of cells in one layer of the last axis (`prod_{a < D-1} cells[a]`).
    pub fn cells_per_layer(&self) -> usize {
        self.axes[..D - 1].iter().map(|g| g.cells).product()
    }
}

/// The non-zero basis functions at one point, one 1D [`Shape`] per axis.
#[derive(Clone, Copy, Debug)]
pub struct TensorShape<const D: usize> {
    pub axes: [Shape; D],
}

impl<const D: usize> Default for TensorShape<D> {
    fn default() -> Self {
        Self {
            axes: [Shape::default(); D],
        }
    }
}

impl<const D: usize> TensorShape<D> {
    /// Call `visit(node, phi, grad_phi)` for every node of the support, with the node's
    /// lexicographic index for DOF strides `stride` (see [`TensorBasis::strides`]), in
    /// lexicographic order (x fastest).
    #[inline(always)]
    pub fn for_each_node(&self, stride: &[usize; D], visit: impl FnMut(usize, f64, [f64; D])) {
        self.for_each_node_n::<0>(stride, visit)
    }

    /// [`Self::for_each_node`] for a support of `N` functions per axis known at compile
    /// time (`N = 0`: the run-time `Shape::len`), so that the loops unroll.
    #[inline(always)]
    pub fn for_each_node_n<const N: usize>(
        &self,
        stride: &[usize; D],
        mut visit: impl FnMut(usize, f64, [f64; D]),
    ) {
        // Row by row (the products of [`Self::for_each_row_n`] are the ones a node loop
        // forms, in the same order: bitwise the same values).
        let (phi_x, dphi_x) = self.x_functions_n::<N>();
        self.for_each_row_n::<N>(stride, |first, w, dw| {
            for (i, (&px, &dx)) in phi_x.iter().zip(dphi_x).enumerate() {
                let mut g = [0.0; D];
                g[0] = dx * w;
                for (g, dw) in g.iter_mut().zip(&dw).skip(1) {
                    *g = px * dw;
                }
                visit(first + i, px * w, g);
            }
        });
    }

    /// The x-axis functions `(phi^0_i, dphi^0_i)` of every row of the support (see
    /// [`Self::for_each_row_n`]), `N` of each (`N = 0`: the run-time support).
    #[inline(always)]
    pub fn x_functions_n<const N: usize>(&self) -> (&[f64], &[f64]) {
        let x = &self.axes[0];
        let n = support::<N>(x);
        (&x.phi[..n], &x.dphi[..n])
    }

    /// Call `row(first, w, dw)` for every row of the support along x, in lexicographic
    /// order: the row's nodes are `first + i` for the x-functions `i` of
    /// [`Self::x_functions_n`], `w = prod_{a >= 1} phi^a` is the product of the other
    /// axes' functions and `dw[b] = d w / d x_b` for `b >= 1` (`dw[0] = 0`), so that
    ///
    /// ```text
    /// phi_I = phi^0_i w,   d phi_I / d x_0 = dphi^0_i w,   d phi_I / d x_b = phi^0_i dw[b]
    /// ```
    /// Kernels that form their per-node coefficients once per row (sum factorisation)
    /// spend `O(N)` products per row instead of `O(N D)` per node. In 1D there is one row
    /// with `w = 1`.
    #[inline(always)]
    pub fn for_each_row_n<const N: usize>(
        &self,
        stride: &[usize; D],
        mut row: impl FnMut(usize, f64, [f64; D]),
    ) {
        let s = &self.axes;
        match D {
            1 => row(s[0].first, 1.0, [0.0; D]),
            2 => {
                for j in 0..support::<N>(&s[1]) {
                    let mut dw = [0.0; D];
                    dw[1] = s[1].dphi[j];
                    row((s[1].first + j) * stride[1] + s[0].first, s[1].phi[j], dw);
                }
            }
            _ => {
                for k in 0..support::<N>(&s[2]) {
                    let (pz, dz) = (s[2].phi[k], s[2].dphi[k]);
                    let plane = (s[2].first + k) * stride[2] + s[0].first;
                    for j in 0..support::<N>(&s[1]) {
                        let (py, dy) = (s[1].phi[j], s[1].dphi[j]);
                        let mut dw = [0.0; D];
                        dw[1] = dy * pz;
                        dw[2] = py * dz;
                        row(plane + (s[1].first + j) * stride[1], py * pz, dw);
                    }
                }
            }
        }
    }

    /// `sum_I phi_I g_I` of a grid vector field (one `[f64; D]` per node).
    #[inline]
    pub fn interpolate(&self, stride: &[usize; D], field: &[[f64; D]]) -> [f64; D] {
        self.interpolate_n::<0>(stride, field)
    }

    /// [`Self::interpolate`] for a support size `N` known at compile time (see
    /// [`Self::for_each_node_n`]), sum-factorised: `sum_rows w sum_i phi^0_i g_I` (row
    /// sums along x first, see [`Self::for_each_row_n`]).
    #[inline(always)]
    pub fn interpolate_n<const N: usize>(
        &self,
        stride: &[usize; D],
        field: &[[f64; D]],
    ) -> [f64; D] {
        let (phi_x, _) = self.x_functions_n::<N>();
        let mut out = [0.0; D];
        self.for_each_row_n::<N>(stride, |first, w, _| {
            let mut sum = [0.0; D];
            for (px, g) in phi_x.iter().zip(&field[first..first + phi_x.len()]) {
                for a in 0..D {
                    sum[a] += px * g[a];
                }
            }
            for a in 0..D {
                out[a] += w * sum[a];
            }
        });
        out
    }

    /// `sum_I phi_I g_I` and the gradient `L_ab = sum_I g_{I,a} d phi_I / d x_b` of a grid
    /// vector field, sum-factorised: the x sums `sum_i phi_i g_I`, `sum_i dphi_i g_I` of each
    /// row first, then the rows (`2 D` multiply-adds per node instead of `D + D^2` and the
    /// products of the shape).
    #[inline]
    pub fn interpolate_with_gradient(
        &self,
        stride: &[usize; D],
        field: &[[f64; D]],
    ) -> ([f64; D], [[f64; D]; D]) {
        self.interpolate_with_gradient_n::<0>(stride, field)
    }

    /// [`Self::interpolate_with_gradient`] for a support size `N` known at compile time
    /// (see [`Self::for_each_node_n`]).
    #[inline(always)]
    pub fn interpolate_with_gradient_n<const N: usize>(
        &self,
        stride: &[usize; D],
        field: &[[f64; D]],
    ) -> ([f64; D], [[f64; D]; D]) {
        let s = &self.axes;
        let mut value = [0.0; D];
        let mut gradient = [[0.0; D]; D];
        // Row sums along x of the row starting at node `row`.
        let row_sums = |row: usize| {
            let (mut r0, mut r1) = ([0.0; D], [0.0; D]);
            for i in 0..support::<N>(&s[0]) {
                let (px, dx) = (s[0].phi[i], s[0].dphi[i]);
                let g = &field[row + i];
                for a in 0..D {
                    r0[a] += px * g[a];
                    r1[a] += dx * g[a];
                }
            }
            (r0, r1)
        };
        match D {
            1 => {
                let (r0, r1) = row_sums(s[0].first);
                value = r0;
                for a in 0..D {
                    gradient[a][0] = r1[a];
                }
            }
            2 => {
                for j in 0..support::<N>(&s[1]) {
                    let (py, dy) = (s[1].phi[j], s[1].dphi[j]);
                    let (r0, r1) = row_sums((s[1].first + j) * stride[1] + s[0].first);
                    for a in 0..D {
                        value[a] += py * r0[a];
                        gradient[a][0] += py * r1[a];
                        gradient[a][1] += dy * r0[a];
                    }
                }
            }
            _ => {
                for k in 0..support::<N>(&s[2]) {
                    let (pz, dz) = (s[2].phi[k], s[2].dphi[k]);
                    let plane = (s[2].first + k) * stride[2];
                    // Plane sums over y of the row sums: value, d/dx, d/dy.
                    let (mut q0, mut qx, mut qy) = ([0.0; D], [0.0; D], [0.0; D]);
                    for j in 0..support::<N>(&s[1]) {
                        let (py, dy) = (s[1].phi[j], s[1].dphi[j]);
                        let (r0, r1) = row_sums(plane + (s[1].first + j) * stride[1] + s[0].first);
                        for a in 0..D {
                            q0[a] += py * r0[a];
                            qx[a] += py * r1[a];
                            qy[a] += dy * r0[a];
                        }
                    }
                    for a in 0..D {
                        value[a] += pz * q0[a];
                        gradient[a][0] += pz * qx[a];
                        gradient[a][1] += pz * qy[a];
                        gradient[a][2] += dz * q0[a];
                    }
                }
            }
        }
        (value, gradient)
    }
}

/// The number of non-zero functions of `shape`: `N` when known at compile time, else
/// `shape.len`.
#[inline(always)]
fn support<const N: usize>(shape: &Shape) -> usize {
    debug_assert!(N == 0 || N == shape.len, "support {N} != {}", shape.len);
    if N == 0 {
        shape.len
    } else {
        N
    }
}

/// The tensor product of the 1D basis `B` on each axis of a [`TensorGrid`].
#[derive(Clone, Debug)]
pub struct TensorBasis<const D: usize, B: Basis> {
    pub grid: TensorGrid<D>,
    axes: [B; D],
    dofs: [usize; D],
    strides: [usize; D],
}

impl<const D: usize, B: Basis + Clone> TensorBasis<D, B> {
    /// The product of `make(axis_grid)` over the axes of `grid`.
    pub fn new(grid: TensorGrid<D>, make: impl Fn(Grid) -> B) -> Self {
        let axes: [B; D] = std::array::from_fn(|a| make(grid.axes[a]));
        let dofs: [usize; D] = std::array::from_fn(|a| axes[a].num_dofs());
        let mut strides = [1; D];
        for a in 1..D {
            strides[a] = strides[a - 1] * dofs[a - 1];
        }
        Self {
            grid,
            axes,
            dofs,
            strides,
        }
    }
}

impl<const D: usize, B: Basis> TensorBasis<D, B> {
    /// Name of the 1D basis (`method.basis`).
    pub fn name(&self) -> &'static str {
        self.axes[0].name()
    }

    /// The 1D basis of axis `a`.
    pub fn axis(&self, a: usize) -> &B {
        &self.axes[a]
    }

    /// Total number of DOFs (nodes) `prod_a N_a`.
    pub fn num_dofs(&self) -> usize {
        self.dofs.iter().product()
    }

    /// DOFs per axis.
    pub fn dofs(&self) -> [usize; D] {
        self.dofs
    }

    /// Lexicographic node strides: node `I` has index `sum_a I_a strides[a]`.
    pub fn strides(&self) -> &[usize; D] {
        &self.strides
    }

    /// The DOF range `[first, end)` of the last axis that the cells of last-axis layers
    /// `layers` can touch.
    pub fn layer_dofs(&self, layers: std::ops::Range<usize>) -> std::ops::Range<usize> {
        let last = &self.axes[D - 1];
        let (first, _) = last.cell_window(layers.start);
        let (end_first, end_len) = last.cell_window(layers.end - 1);
        first..end_first + end_len
    }

    /// Evaluate at `x` in the cell with axis indices `cell`, for a particle domain of
    /// half-lengths `half_length` (ignored by point bases).
    #[inline(always)]
    pub fn eval_particle(
        &self,
        cell: [usize; D],
        x: [f64; D],
        half_length: [f64; D],
        shape: &mut TensorShape<D>,
    ) {
        self.eval_particle_n::<0>(cell, x, half_length, shape);
    }

    /// [`Self::eval_particle`] for the fixed support `N` of every axis
    /// ([`Basis::eval_particle_n`]; `N = 0`: run-time support).
    #[inline(always)]
    pub fn eval_particle_n<const N: usize>(
        &self,
        cell: [usize; D],
        x: [f64; D],
        half_length: [f64; D],
        shape: &mut TensorShape<D>,
    ) {
        for a in 0..D {
            self.axes[a].eval_particle_n::<N>(cell[a], x[a], half_length[a], &mut shape.axes[a]);
        }
    }

    /// `Some(n)` when every axis has the fixed support `n` ([`Basis::fixed_support`]).
    pub fn fixed_support(&self) -> Option<usize> {
        let n = self.axes[0].fixed_support()?;
        self.axes
            .iter()
            .all(|b| b.fixed_support() == Some(n))
            .then_some(n)
    }

    /// The DOFs of axis `a` on its `[min, max]` faces.
    pub fn face_dofs(&self, a: usize) -> (usize, usize) {
        self.axes[a].boundary_dofs()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{BSplineBasis, GimpBasis, LinearBasis};
    use proptest::prelude::*;

    fn check_partition_of_unity<const D: usize, B: Basis + Clone>(
        basis: &TensorBasis<D, B>,
        x: [f64; D],
        half: [f64; D],
    ) -> std::result::Result<(), TestCaseError> {
        let cell = basis.grid.axis_cells(x);
        let mut shape = TensorShape::default();
        basis.eval_particle(cell, x, half, &mut shape);
        let mut sum = 0.0;
        let mut grad_sum = [0.0; D];
        let mut min_phi = f64::INFINITY;
        shape.for_each_node(basis.strides(), |_, phi, grad| {
            sum += phi;
            for b in 0..D {
                grad_sum[b] += grad[b];
            }
            min_phi = min_phi.min(phi);
        });
        prop_assert!(min_phi >= -1e-14, "phi {min_phi}");
        prop_assert!((sum - 1.0).abs() < 1e-13, "sum {sum}");
        for g in grad_sum {
            prop_assert!(g.abs() < 1e-10, "grad sum {g}");
        }
        Ok(())
    }

    proptest! {
        #[test]
        fn tensor_products_are_partitions_of_unity(
            nx in 1usize..9, ny in 1usize..9, nz in 1usize..5,
            t in proptest::array::uniform3(0.0f64..1.0), order in 1usize..5,
        ) {
            let g2 = TensorGrid::new([1.0, 2.0], [nx, ny]);
            let x2 = [t[0], 2.0 * t[1]];
            check_partition_of_unity(&TensorBasis::new(g2, LinearBasis::new), x2, [0.0; 2])?;
            let b2 = TensorBasis::new(g2, |g| BSplineBasis::new(g, order).unwrap());
            check_partition_of_unity(&b2, x2, [0.0; 2])?;
            let half = [0.25 / nx as f64, 0.5 / ny as f64];
            check_partition_of_unity(&TensorBasis::new(g2, GimpBasis::new), x2, half)?;
            let g3 = TensorGrid::new([1.0, 1.0, 0.5], [nx, ny, nz]);
            let x3 = [t[0], t[1], 0.5 * t[2]];
            let b3 = TensorBasis::new(g3, |g| BSplineBasis::new(g, order).unwrap());
            check_partition_of_unity(&b3, x3, [0.0; 3])?;
        }

        #[test]
        fn gradients_match_finite_differences(
            t in proptest::array::uniform3(0.05f64..0.95), order in 1usize..4,
        ) {
            // A smooth grid field: f_I = sin(I . c); compare the interpolated gradient with
            // central differences of the interpolation inside one cell.
            let grid = TensorGrid::new([1.0, 1.0, 1.0], [5, 4, 3]);
            let basis = TensorBasis::new(grid, |g| BSplineBasis::new(g, order + 1).unwrap());
            let field: Vec<[f64; 3]> = (0..basis.num_dofs())
                .map(|i| [(0.3 * i as f64).sin(), (0.7 * i as f64).cos(), 0.01 * i as f64])
                .collect();
            let x = t;
            let cell = grid.axis_cells(x);
            let eval = |x: [f64; 3]| {
                let mut s = TensorShape::default();
                basis.eval_particle(cell, x, [0.0; 3], &mut s);
                s.interpolate_with_gradient(basis.strides(), &field)
            };
            let (_, gradient) = eval(x);
            let eps = 1e-6;
            for b in 0..3 {
                let (mut xp, mut xm) = (x, x);
                xp[b] += eps;
                xm[b] -= eps;
                if grid.axis_cells(xp) != cell || grid.axis_cells(xm) != cell {
                    continue;
                }
                let (fp, fm) = (eval(xp).0, eval(xm).0);
                for a in 0..3 {
                    let fd = (fp[a] - fm[a]) / (2.0 * eps);
                    prop_assert!((fd - gradient[a][b]).abs() < 1e-6 * (1.0 + fd.abs()),
                        "a {a} b {b}: fd {fd} vs {}", gradient[a][b]);
                }
            }
        }
    }

    #[test]
    fn cells_and_nodes_are_lexicographic_with_x_fastest() {
        let grid = TensorGrid::new([2.0, 3.0, 1.0], [2, 3, 1]);
        assert_eq!(grid.num_cells(), 6);
        assert_eq!(grid.cell_index([1, 2, 0]), 1 + 2 * 2);
        assert_eq!(grid.cell_of([1.5, 2.5, 0.5]), Some(5));
        assert_eq!(grid.cell_of([1.5, 3.5, 0.5]), None);
        let basis = TensorBasis::new(grid, |g| BSplineBasis::new(g, 2).unwrap());
        assert_eq!(basis.dofs(), [4, 5, 3]);
        assert_eq!(basis.strides(), &[1, 4, 20]);
        assert_eq!(basis.num_dofs(), 60);
        let mut shape = TensorShape::default();
        basis.eval_particle([1, 2, 0], [1.5, 2.5, 0.5], [0.0; 3], &mut shape);
        let mut nodes = Vec::new();
        shape.for_each_node(basis.strides(), |node, _, _| nodes.push(node));
        assert_eq!(nodes.len(), 27);
        assert!(nodes.windows(2).all(|w| w[0] < w[1]));
        assert_eq!(nodes[0], 1 + 2 * 4);
        assert_eq!(basis.layer_dofs(0..1), 0..3);
    }
}
