//! Dual-domain MPM gradients (DDMPM, SPEC §3.2).
//!
//! The functions are the linear hats `phi_i`; the gradient used for internal forces and
//! strains is the blend
//!
//! ```text
//! grad_tilde_i(x) = sum_j (phi_j(x) / V_j) G_ji,   G_ji = int_Omega phi_j dphi_i,   V_j = int_Omega phi_j
//! alpha(x)        = 2 sum_i phi_i(x) phi_{i+1}(x)            (= 2 xi (1 - xi) in a cell)
//! grad_bar_i(x)   = alpha(x) dphi_i(x) + (1 - alpha(x)) grad_tilde_i(x)
//! ```
//!
//! **Quadrature choice** (`method.node_integrals`): the node integrals `V_j` and `G_ji` run
//! over the material domain, recomputed from the configuration at the start of every step.
//! With `particles` (default for the direct mapping, as in the original DDMPM) they are
//! particle sums, `V_j = sum_p V_p phi_j(x_p)` and `G_ji = sum_p V_p phi_j(x_p) dphi_i(x_p)`;
//! with `domain` (default with a reconstruction, whose Gauss quadrature replaces particle
//! quadrature) they are exact integrals over the active part `[lo, hi]` of every cell that
//! holds particles (the cell clipped to the material extent). Because `dphi` is constant
//! in a cell, each cell needs only the two integrals `S_e^L = int_e phi_e` and
//! `S_e^R = int_e phi_{e+1}` (particle sums `sum_p V_p phi(x_p)`, or exactly
//! `h [(b - a) - (b^2 - a^2)/2]` and `h (b^2 - a^2)/2` for the active part
//! `[x_e + a h, x_e + b h]`); with `subpoints` (the default when `method.subpoints = N > 0`)
//! they are sums over the `N` sub-points `x_p + ((k + 1/2)/N - 1/2) V_p` of every particle
//! (weight `V_p / N`, clipped to the grid), in closed form per particle and cell (the
//! sub-points in a cell are a contiguous run of an arithmetic progression):
//!
//! ```text
//! V_j = S_j^L + S_{j-1}^R,   G_{j,j-1} = -S_{j-1}^R / h,   G_{jj} = (S_{j-1}^R - S_j^L) / h,   G_{j,j+1} = S_j^L / h
//! ```
//!
//! so `sum_i G_ji = 0` and the gradients of a point sum to zero (a constant stress gives no
//! interior force). A point of cell `e` touches the DOFs `e - 1 ..= e + 2`. Nodes with no
//! material (`V_j = 0`) contribute no `grad_tilde`.

use super::{Basis, Grid, ParticleQuadrature, Shape};
use crate::config::NodeIntegrals;
use rayon::prelude::*;

/// Cells per rayon task when the node integrals are accumulated.
const CELLS_PER_TASK: usize = 256;

/// Linear hats with the dual-domain gradient.
#[derive(Clone, Debug)]
pub struct DdmpmBasis {
    grid: Grid,
    integrals: NodeIntegrals,
    /// Sub-points per particle for [`NodeIntegrals::Subpoints`].
    subpoints: usize,
    /// Per cell `[S^L, S^R]`.
    cell_integrals: Vec<[f64; 2]>,
    /// Per node `G_{j,i} / V_j` for `i = j - 1, j, j + 1`.
    weighted_integrals: Vec<[f64; 3]>,
}

impl DdmpmBasis {
    /// The basis on `grid` with node integrals by particle quadrature; [`Basis::update`]
    /// must run before the first evaluation.
    pub fn new(grid: Grid) -> Self {
        Self::with_integrals(grid, NodeIntegrals::Particles, 1)
    }

    /// The basis on `grid` with the given quadrature of the node integrals (`subpoints`
    /// per particle for [`NodeIntegrals::Subpoints`], at least 1).
    pub fn with_integrals(grid: Grid, integrals: NodeIntegrals, subpoints: usize) -> Self {
        Self {
            grid,
            integrals,
            subpoints: subpoints.max(1),
            cell_integrals: vec![[0.0; 2]; grid.cells],
            weighted_integrals: vec![[0.0; 3]; grid.cells + 1],
        }
    }
}

impl Basis for DdmpmBasis {
    fn name(&self) -> &'static str {
        "ddmpm"
    }

    fn num_dofs(&self) -> usize {
        self.grid.cells + 1
    }

    #[inline]
    fn cell_window(&self, cell: usize) -> (usize, usize) {
        let first = cell.saturating_sub(1);
        let last = (cell + 2).min(self.grid.cells);
        (first, last + 1 - first)
    }

    fn max_window(&self) -> usize {
        4.min(self.grid.cells + 1)
    }

    #[inline]
    fn eval(&self, cell: usize, x: f64, shape: &mut Shape) {
        let xi = (x - self.grid.cell_left(cell)) * self.grid.inv_h;
        let (a, b) = (1.0 - xi, xi);
        let alpha = 2.0 * a * b;
        let inv_h = self.grid.inv_h;
        let w = &self.weighted_integrals;
        let (left, right) = (w[cell], w[cell + 1]);
        // grad_tilde at DOFs e-1, e, e+1, e+2 and the hat gradients there.
        let tilde = [
            a * left[0],
            a * left[1] + b * right[0],
            a * left[2] + b * right[1],
            b * right[2],
        ];
        let phi = [0.0, a, b, 0.0];
        let dphi = [0.0, -inv_h, inv_h, 0.0];
        let (first, len) = self.cell_window(cell);
        // Offset of DOF `first` in the 4-wide local arrays (1 unless cell 0).
        let skip = first + 1 - cell;
        for k in 0..len {
            let m = skip + k;
            shape.phi[k] = phi[m];
            shape.dphi[k] = alpha * dphi[m] + (1.0 - alpha) * tilde[m];
        }
        shape.first = first;
        shape.len = len;
    }

    fn depends_on_particles(&self) -> bool {
        true
    }

    fn update(&mut self, quadrature: ParticleQuadrature<'_>) {
        let grid = self.grid;
        let integrals = match (self.integrals, self.subpoints) {
            // One sub-point is the particle itself.
            (NodeIntegrals::Subpoints, 1) => NodeIntegrals::Particles,
            (integrals, _) => integrals,
        };
        let extent = match integrals {
            NodeIntegrals::Domain => quadrature.material_extent(),
            _ => (0.0, 0.0),
        };
        let (subpoints, reach) = match integrals {
            NodeIntegrals::Subpoints => (self.subpoints, subpoint_reach(&grid, quadrature)),
            _ => (1, 0),
        };
        self.cell_integrals
            .par_iter_mut()
            .with_min_len(CELLS_PER_TASK)
            .enumerate()
            .for_each(|(cell, sums)| {
                let left = grid.cell_left(cell);
                let mut s = [0.0; 2];
                if integrals == NodeIntegrals::Domain {
                    if let Some((lo, hi)) = quadrature.active_part(&grid, cell, extent) {
                        let (a, b) = ((lo - left) * grid.inv_h, (hi - left) * grid.inv_h);
                        let right = 0.5 * (b * b - a * a);
                        s = [grid.h * ((b - a) - right), grid.h * right];
                    }
                    *sums = s;
                    return;
                }
                if integrals == NodeIntegrals::Subpoints {
                    let first = cell.saturating_sub(reach);
                    let last = (cell + reach).min(grid.cells - 1);
                    for p in quadrature.cell_start[first]..quadrature.cell_start[last + 1] {
                        let [l, r] = subpoint_sums(
                            &grid,
                            cell,
                            quadrature.x[p],
                            quadrature.volume[p],
                            subpoints,
                        );
                        s[0] += l;
                        s[1] += r;
                    }
                    *sums = s;
                    return;
                }
                for p in quadrature.range(cell) {
                    let xi = (quadrature.x[p] - left) * grid.inv_h;
                    let v = quadrature.volume[p];
                    s[0] += v * (1.0 - xi);
                    s[1] += v * xi;
                }
                *sums = s;
            });
        let cells = grid.cells;
        let inv_h = grid.inv_h;
        for j in 0..=cells {
            let from_left_cell = if j > 0 {
                self.cell_integrals[j - 1][1]
            } else {
                0.0
            };
            let from_right_cell = if j < cells {
                self.cell_integrals[j][0]
            } else {
                0.0
            };
            let volume = from_left_cell + from_right_cell;
            self.weighted_integrals[j] = if volume > 0.0 {
                let w = inv_h / volume;
                [
                    -from_left_cell * w,
                    (from_left_cell - from_right_cell) * w,
                    from_right_cell * w,
                ]
            } else {
                [0.0; 3]
            };
        }
    }
}

/// How many cells away a particle's sub-points can lie: `ceil(max_p V_p / (2h))`.
fn subpoint_reach(grid: &Grid, quadrature: ParticleQuadrature<'_>) -> usize {
    let largest = quadrature
        .volume
        .par_iter()
        .copied()
        .reduce(|| 0.0, |a: f64, b: f64| if b > a { b } else { a });
    let reach = (0.5 * largest * grid.inv_h).ceil();
    if reach.is_finite() && reach < grid.cells as f64 {
        reach as usize
    } else {
        grid.cells
    }
}

/// `[sum_k w phi_e(x_k), sum_k w phi_{e+1}(x_k)]` over the sub-points
/// `x_k = x + ((k + 1/2)/n - 1/2) V`, `k < n`, `w = V / n`, that lie in cell `e` (a point on
/// a face belongs to the cell on its right, the last face to the last cell; points beyond
/// the grid are moved to its ends). The points in the cell are `k0 <= k < k1`, so
/// `sum xi_k = sum (x_k - x_e)/h` is an arithmetic sum.
fn subpoint_sums(grid: &Grid, cell: usize, x: f64, volume: f64, n: usize) -> [f64; 2] {
    let spacing = volume / n as f64;
    let start = x - 0.5 * volume;
    let left = grid.cell_left(cell);
    let right = left + grid.h;
    let count = n as f64;
    // Index of the first sub-point at or right of `y` (as a real, clamped to [0, n]).
    let first_at_or_after = |y: f64| ((y - start) / spacing - 0.5).ceil().clamp(0.0, count);
    let end = grid.origin + grid.length;
    let k0 = if cell == 0 {
        0.0
    } else {
        first_at_or_after(left)
    };
    let k1 = if cell + 1 == grid.cells {
        count
    } else {
        first_at_or_after(right)
    };
    if spacing.is_nan() || spacing <= 0.0 || k1 <= k0 {
        return [0.0; 2];
    }
    // Points below the grid sit at x = origin (xi = 0) in cell 0; above it at x = end
    // (xi = 1) in the last cell.
    let below = if cell == 0 {
        first_at_or_after(grid.origin).min(k1) - k0
    } else {
        0.0
    };
    let above = if cell + 1 == grid.cells {
        k1 - first_at_or_after(end + 1e-12 * grid.h).max(k0)
    } else {
        0.0
    };
    let (inner0, inner1) = (k0 + below, k1 - above);
    let inner = inner1 - inner0;
    // sum_{k = inner0}^{inner1 - 1} (k + 1/2) = (inner1^2 - inner0^2) / 2.
    let xi_sum = if inner > 0.0 {
        (inner * (start - left) + spacing * 0.5 * (inner1 * inner1 - inner0 * inner0)) * grid.inv_h
    } else {
        0.0
    };
    let weight = volume / count;
    let xi_sum = xi_sum + above;
    let points = inner.max(0.0) + below + above;
    [weight * (points - xi_sum), weight * xi_sum]
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn updated(grid: Grid, x: &[f64], volume: &[f64]) -> DdmpmBasis {
        let mut cell_start = vec![0; grid.cells + 1];
        for &xp in x {
            cell_start[grid.cell_of(xp).unwrap() + 1] += 1;
        }
        for e in 0..grid.cells {
            cell_start[e + 1] += cell_start[e];
        }
        let mut basis = DdmpmBasis::new(grid);
        basis.update(ParticleQuadrature {
            x,
            volume,
            cell_start: &cell_start,
        });
        basis
    }

    proptest! {
        /// Random sorted particle layouts: the functions are the hats, the dual-domain
        /// gradients sum to zero and reproduce the gradient of a linear field in the
        /// interior (where `grad_tilde` of a linear field is exact).
        #[test]
        fn gradients_sum_to_zero(cells in 2usize..12, per_cell in 1usize..6,
                                 jitter in prop::collection::vec(0.0f64..1.0, 72),
                                 t in 0.0f64..=1.0) {
            let grid = Grid::new(3.0, cells);
            let mut x = Vec::new();
            for e in 0..cells {
                let mut local: Vec<f64> = (0..per_cell)
                    .map(|k| grid.cell_left(e) + grid.h * (0.02 + 0.96 * jitter[(e * per_cell + k) % 72]))
                    .collect();
                local.sort_by(f64::total_cmp);
                x.extend(local);
            }
            let volume = vec![grid.h / per_cell as f64; x.len()];
            let basis = updated(grid, &x, &volume);
            let point = t * grid.length;
            let cell = grid.cell_of(point).unwrap();
            let mut s = Shape::default();
            basis.eval(cell, point, &mut s);
            let sum: f64 = s.phi[..s.len].iter().sum();
            prop_assert!((sum - 1.0).abs() < 1e-14);
            let dsum: f64 = s.dphi[..s.len].iter().sum();
            prop_assert!(dsum.abs() < 1e-12 * grid.inv_h, "{}", dsum);
            prop_assert!(s.first + s.len <= basis.num_dofs());
            // Linear fields have exact dual-domain gradients (V_j and G_ji share the
            // particle quadrature).
            let g: f64 = (0..s.len).map(|k| s.dphi[k] * (2.0 * grid.cell_left(s.first + k) - 1.0)).sum();
            prop_assert!((g - 2.0).abs() < 1e-10, "{}", g);
        }
    }

    proptest! {
        /// The closed-form sub-point sums equal the sums over the explicit sub-points
        /// (clipped to the grid, binned with `cell_of`), and one sub-point is the particle.
        #[test]
        fn subpoint_sums_match_explicit_sub_points(cells in 1usize..8, x in 0.0f64..=1.0,
                                                   volume in 0.001f64..3.0, n in 1usize..40) {
            let grid = Grid::new(2.0, cells);
            let x = x * grid.length;
            let mut explicit = vec![[0.0; 2]; cells];
            for k in 0..n {
                let xk = (x + ((k as f64 + 0.5) / n as f64 - 0.5) * volume).clamp(0.0, grid.length);
                let e = grid.cell_of(xk).unwrap();
                let xi = (xk - grid.cell_left(e)) * grid.inv_h;
                explicit[e][0] += volume / n as f64 * (1.0 - xi);
                explicit[e][1] += volume / n as f64 * xi;
            }
            for (e, expected) in explicit.iter().enumerate() {
                let closed = subpoint_sums(&grid, e, x, volume, n);
                for j in 0..2 {
                    prop_assert!((closed[j] - expected[j]).abs() < 1e-9 * volume,
                        "cell {} {:?} vs {:?}", e, closed, expected);
                }
            }
        }
    }

    #[test]
    fn cell_centre_gradient_blends_half_and_half() {
        // Uniform layout, 2 particles per cell: S^L = S^R = h/2 everywhere.
        let grid = Grid::new(1.0, 4);
        let x: Vec<f64> = (0..8).map(|k| (k as f64 + 0.5) / 8.0).collect();
        let basis = updated(grid, &x, &[0.125; 8]);
        let mut s = Shape::default();
        basis.eval(1, 0.375, &mut s);
        assert_eq!((s.first, s.len), (0, 4));
        // For a linear field f = x the blended gradient is exact: sum_i grad_bar_i x_i = 1.
        let nodes = [0.0, 0.25, 0.5, 0.75, 1.0];
        let g: f64 = (0..s.len).map(|k| s.dphi[k] * nodes[s.first + k]).sum();
        assert!((g - 1.0).abs() < 1e-12, "{g}");
        // At a node-adjacent point alpha -> 0 and the gradient is grad_tilde alone, which
        // spreads to the neighbouring DOFs.
        basis.eval(1, 0.25 + 1e-9, &mut s);
        assert!(s.dphi[0].abs() > 1.0 && s.dphi[3].abs() < 1e-6);
    }
}
