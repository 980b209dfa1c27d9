//! Assembly of B-spline mass matrices (SPEC §5): 1D (banded) and 2D tensor product, any
//! order, with a density given at the quadrature points.
//!
//! ```text
//! M_ij     = int rho phi_i phi_j dx                 (1D, bandwidth p)
//! P_ij     = int phi_i^p phi_j^q dx                 (mixed mass between orders p and q)
//! f_i      = c int phi_i dx                         (load of a constant body force c)
//! M_(i,j)  = int int rho phi_ix phi_iy phi_jx phi_jy dx dy   (2D, DOF i = i_y n_x + i_x)
//! ```
//!
//! Integrals use `points` Gauss points per span and direction (`p + 1` is exact for a
//! constant density). With a constant density the 2D matrix is the Kronecker product
//! `M_y (x) M_x` of the 1D ones ([`CsrMatrix::kron`]).
//!
//! The 2D assembly runs in parallel over block rows `i_y` (all DOFs of one `y` function):
//! a block row receives the contributions of the element rows `e_y = i_y - p ..= i_y`, summed
//! in a fixed order, and only its own rows are written, so there are no races and the
//! result is bitwise the same for any thread count. Sum factorisation keeps the cost at
//! `O((p + 1)^5)` per element instead of `O((p + 1)^6)`.

use super::CsrMatrix;
use crate::numerics::bspline::{open_uniform, MAX_DEGREE};
use crate::numerics::gauss::GaussRule;
use rayon::prelude::*;

/// B-splines of degree `order` on an open uniform knot vector with `spans` equal spans of
/// `[0, length]`: `spans + order` functions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplineSpace {
    pub order: usize,
    pub spans: usize,
    pub length: f64,
}

/// A quadrature point handed to a density function: its span (per direction), its index
/// in the span's rule and its coordinates. 1D assembly sets the second entries to 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuadraturePoint {
    pub span: [usize; 2],
    pub index: [usize; 2],
    pub x: [f64; 2],
}

/// Basis values of every span at its quadrature points: `values[(span * points + g) *
/// (order + 1) + k]` is `phi_{span + k}(x_g)`.
struct Tabulated {
    order: usize,
    points: usize,
    x: Vec<f64>,
    /// Quadrature weight times the span Jacobian.
    weight: Vec<f64>,
    values: Vec<f64>,
}

impl Tabulated {
    fn phi(&self, span: usize, g: usize) -> &[f64] {
        let start = (span * self.points + g) * (self.order + 1);
        &self.values[start..start + self.order + 1]
    }
}

impl SplineSpace {
    /// `None` unless `1 <= spans`, `order <= MAX_DEGREE` and `length > 0`.
    ///
    /// ```
    /// let space = tlsmpm::linalg::assembly::SplineSpace::new(2, 8, 1.0).unwrap();
    /// assert_eq!(space.functions(), 10);
    /// ```
    pub fn new(order: usize, spans: usize, length: f64) -> Option<Self> {
        (spans >= 1 && order <= MAX_DEGREE && length > 0.0 && length.is_finite()).then_some(Self {
            order,
            spans,
            length,
        })
    }

    /// Number of functions, `spans + order`.
    pub fn functions(&self) -> usize {
        self.spans + self.order
    }

    /// The same spans at another order.
    pub fn with_order(&self, order: usize) -> Self {
        Self { order, ..*self }
    }

    /// Width of a span.
    pub fn span_width(&self) -> f64 {
        self.length / self.spans as f64
    }

    fn tabulate(&self, points: usize) -> Tabulated {
        let rule = GaussRule::new(points.clamp(1, crate::numerics::gauss::MAX_POINTS))
            .unwrap_or_else(|| unreachable!("clamped to the supported rules"));
        let p = self.order;
        let h = self.span_width();
        let mut table = Tabulated {
            order: p,
            points: rule.len,
            x: Vec::with_capacity(self.spans * rule.len),
            weight: Vec::with_capacity(self.spans * rule.len),
            values: Vec::with_capacity(self.spans * rule.len * (p + 1)),
        };
        let mut values = [0.0; MAX_DEGREE + 1];
        let mut derivatives = [0.0; MAX_DEGREE + 1];
        for span in 0..self.spans {
            for (u, w) in rule.mapped(span as f64, span as f64 + 1.0) {
                open_uniform(p, self.spans, span, u, &mut values, &mut derivatives);
                table.x.push(u * h);
                table.weight.push(w * h);
                table.values.extend_from_slice(&values[..=p]);
            }
        }
        table
    }
}

/// `f_i = c int phi_i dx`, the load vector of a constant body force `c`.
///
/// ```
/// use tlsmpm::linalg::assembly::{load_1d, SplineSpace};
/// let f = load_1d(&SplineSpace::new(2, 4, 1.0).unwrap(), 9.81);
/// assert!((f.iter().sum::<f64>() - 9.81).abs() < 1e-13);
/// ```
pub fn load_1d(space: &SplineSpace, c: f64) -> Vec<f64> {
    let table = space.tabulate(space.order + 1);
    let mut load = vec![0.0; space.functions()];
    for span in 0..space.spans {
        for g in 0..table.points {
            let w = table.weight[span * table.points + g];
            for (k, &phi) in table.phi(span, g).iter().enumerate() {
                load[span + k] += c * w * phi;
            }
        }
    }
    load
}

/// The 1D mass matrix `int rho phi_i phi_j` with `points` Gauss points per span; banded
/// CSR of bandwidth `order` (see [`CsrMatrix::band`]).
///
/// ```
/// use tlsmpm::linalg::assembly::{mass_1d, SplineSpace};
/// // Linear hats on 2 spans of [0, 1]: h/6 [2 1 0; 1 4 1; 0 1 2], h = 1/2.
/// let m = mass_1d(&SplineSpace::new(1, 2, 1.0).unwrap(), 2, |_| 1.0);
/// assert!((m.values[m.band_index(1, 1)] - 4.0 / 12.0).abs() < 1e-15);
/// ```
pub fn mass_1d(
    space: &SplineSpace,
    points: usize,
    density: impl Fn(&QuadraturePoint) -> f64,
) -> CsrMatrix {
    let p = space.order;
    let table = space.tabulate(points);
    let mut mass = CsrMatrix::band(space.functions(), p);
    for span in 0..space.spans {
        for g in 0..table.points {
            let at = span * table.points + g;
            let point = QuadraturePoint {
                span: [span, 0],
                index: [g, 0],
                x: [table.x[at], 0.0],
            };
            let w = table.weight[at] * density(&point);
            let phi = table.phi(span, g);
            for a in 0..=p {
                for b in 0..=p {
                    let k = mass.band_index(span + a, span + b);
                    mass.values[k] += w * phi[a] * phi[b];
                }
            }
        }
    }
    mass
}

/// The mixed mass `P_ij = int phi_i^{fine} phi_j^{coarse}` between two orders on the same
/// spans (`fine.functions() x coarse.functions()`), exact by Gauss quadrature.
pub fn mixed_mass_1d(fine: &SplineSpace, coarse: &SplineSpace) -> CsrMatrix {
    let points = (fine.order + coarse.order) / 2 + 1;
    let (tf, tc) = (fine.tabulate(points), coarse.tabulate(points));
    let mut triplets = Vec::with_capacity(fine.spans * (fine.order + 1) * (coarse.order + 1));
    for span in 0..fine.spans.min(coarse.spans) {
        for a in 0..=fine.order {
            for b in 0..=coarse.order {
                let value: f64 = (0..tf.points)
                    .map(|g| {
                        tf.weight[span * tf.points + g] * tf.phi(span, g)[a] * tc.phi(span, g)[b]
                    })
                    .sum();
                triplets.push((span + a, span + b, value));
            }
        }
    }
    CsrMatrix::from_triplets(fine.functions(), coarse.functions(), &triplets)
}

/// `keep[i]` for all but the first and last function: homogeneous Dirichlet DOFs
/// eliminated (SPEC §5.1).
pub fn interior(functions: usize) -> Vec<bool> {
    (0..functions).map(|i| i > 0 && i + 1 < functions).collect()
}

/// The sparsity pattern of the 2D tensor-product matrix: row `(i_x, i_y)` holds columns
/// `(j_x, j_y)` with `|j_x - i_x| <= p_x`, `|j_y - i_y| <= p_y`, ordered by `j_y` then
/// `j_x`.
fn tensor_pattern(x: &SplineSpace, y: &SplineSpace) -> CsrMatrix {
    let (nx, ny) = (x.functions(), y.functions());
    let (px, py) = (x.order, y.order);
    let mut row_start = Vec::with_capacity(nx * ny + 1);
    let mut col_index = Vec::new();
    row_start.push(0);
    for iy in 0..ny {
        for ix in 0..nx {
            for jy in iy.saturating_sub(py)..=(iy + py).min(ny - 1) {
                for jx in ix.saturating_sub(px)..=(ix + px).min(nx - 1) {
                    col_index.push(jy * nx + jx);
                }
            }
            row_start.push(col_index.len());
        }
    }
    let values = vec![0.0; col_index.len()];
    CsrMatrix {
        rows: nx * ny,
        cols: nx * ny,
        row_start,
        col_index,
        values,
    }
}

/// The 2D mass matrix `int int rho phi_i phi_j` on the tensor product of `x` and `y`
/// (DOF `i = i_y n_x + i_x`), `points` Gauss points per span and direction, assembled in
/// parallel over block rows (see the module doc).
pub fn mass_2d(
    x: &SplineSpace,
    y: &SplineSpace,
    points: usize,
    density: impl Fn(&QuadraturePoint) -> f64 + Sync,
) -> CsrMatrix {
    let mut mass = tensor_pattern(x, y);
    let (tx, ty) = (x.tabulate(points), y.tabulate(points));
    let (nx, ny) = (x.functions(), y.functions());
    let (px, py) = (x.order, y.order);
    let (gx_count, gy_count) = (tx.points, ty.points);
    // Split the values into the block rows of each y function.
    let mut blocks: Vec<(usize, &mut [f64])> = Vec::with_capacity(ny);
    let mut rest: &mut [f64] = &mut mass.values;
    for iy in 0..ny {
        let len = mass.row_start[(iy + 1) * nx] - mass.row_start[iy * nx];
        let (block, tail) = rest.split_at_mut(len);
        blocks.push((iy, block));
        rest = tail;
    }
    let row_start = &mass.row_start;
    blocks.into_par_iter().for_each(|(iy, block)| {
        let base = row_start[iy * nx];
        // Column offset of (jx, jy) in row (ix, iy): rows store (2 p_y + 1) x-runs.
        let jy0 = iy.saturating_sub(py);
        // partial[gx * (p_y+1) + b] = sum_gy w_gy rho phi_{iy}(y_g) phi_{ey+b}(y_g)
        let mut partial = vec![0.0; gx_count * (py + 1)];
        for ey in iy.saturating_sub(py)..=iy.min(y.spans - 1) {
            let a_y = iy - ey;
            for ex in 0..x.spans {
                partial.fill(0.0);
                for gx in 0..gx_count {
                    for gy in 0..gy_count {
                        let at_y = ey * gy_count + gy;
                        let point = QuadraturePoint {
                            span: [ex, ey],
                            index: [gx, gy],
                            x: [tx.x[ex * gx_count + gx], ty.x[at_y]],
                        };
                        let phi_y = ty.phi(ey, gy);
                        let w = ty.weight[at_y] * density(&point) * phi_y[a_y];
                        for (b, &phi) in phi_y.iter().enumerate() {
                            partial[gx * (py + 1) + b] += w * phi;
                        }
                    }
                }
                for gx in 0..gx_count {
                    let phi_x = tx.phi(ex, gx);
                    let w_x = tx.weight[ex * gx_count + gx];
                    for a_x in 0..=px {
                        let ix = ex + a_x;
                        let row = iy * nx + ix;
                        let run = (ix + px).min(nx - 1) + 1 - ix.saturating_sub(px);
                        let jx0 = ix.saturating_sub(px);
                        let start = row_start[row] - base;
                        for b_y in 0..=py {
                            let jy = ey + b_y;
                            let s = w_x * phi_x[a_x] * partial[gx * (py + 1) + b_y];
                            let run_start = start + (jy - jy0) * run;
                            for (b_x, &phi) in phi_x.iter().enumerate() {
                                let jx = ex + b_x;
                                block[run_start + jx - jx0] += s * phi;
                            }
                        }
                    }
                }
            }
        }
    });
    mass
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_dimensional_mass_sums_to_the_total_mass_and_reproduces_linear_hats() {
        for order in 1..=5 {
            let space = SplineSpace::new(order, 7, 2.0).unwrap();
            let m = mass_1d(&space, order + 1, |_| 3.0);
            let total: f64 = m.values.iter().sum();
            assert!((total - 6.0).abs() < 1e-12, "order {order}: {total}");
            // Symmetric.
            let d = m.to_dense();
            for (i, row) in d.iter().enumerate() {
                for (j, value) in row.iter().enumerate() {
                    assert!((value - d[j][i]).abs() < 1e-15);
                }
            }
        }
        let m = mass_1d(&SplineSpace::new(1, 4, 1.0).unwrap(), 2, |_| 1.0);
        let h = 0.25;
        assert!((m.values[m.band_index(1, 1)] - 4.0 * h / 6.0).abs() < 1e-15);
        assert!((m.values[m.band_index(1, 2)] - h / 6.0).abs() < 1e-15);
        assert!((m.values[m.band_index(0, 0)] - 2.0 * h / 6.0).abs() < 1e-15);
    }

    #[test]
    fn mixed_mass_is_the_mass_for_equal_orders_and_preserves_integrals() {
        let fine = SplineSpace::new(3, 5, 1.0).unwrap();
        let coarse = fine.with_order(2);
        let mass = mass_1d(&fine, 4, |_| 1.0);
        let same = mixed_mass_1d(&fine, &fine);
        let (dm, ds) = (mass.to_dense(), same.to_dense());
        for i in 0..mass.rows {
            for j in 0..mass.rows {
                assert!((dm[i][j] - ds[i][j]).abs() < 1e-15);
            }
        }
        // Partition of unity: sum_j P_ij = int phi_i^fine.
        let p = mixed_mass_1d(&fine, &coarse);
        let load = load_1d(&fine, 1.0);
        for (row, expected) in p.row_sums().iter().zip(&load) {
            assert!((row - expected).abs() < 1e-15);
        }
    }

    #[test]
    fn two_dimensional_mass_is_the_kronecker_product_for_constant_density() {
        for (px, py) in [(1, 1), (2, 3), (4, 2)] {
            let x = SplineSpace::new(px, 5, 1.0).unwrap();
            let y = SplineSpace::new(py, 4, 2.0).unwrap();
            let points = px.max(py) + 1;
            let m2 = mass_2d(&x, &y, points, |_| 1.0);
            let kron = mass_1d(&y, points, |_| 1.0).kron(&mass_1d(&x, points, |_| 1.0));
            assert_eq!(m2.row_start, kron.row_start);
            assert_eq!(m2.col_index, kron.col_index);
            for (a, b) in m2.values.iter().zip(&kron.values) {
                assert!((a - b).abs() < 1e-15, "{a} {b}");
            }
        }
    }

    #[test]
    fn two_dimensional_mass_with_variable_density_integrates_the_density() {
        let x = SplineSpace::new(2, 6, 1.0).unwrap();
        let density = |q: &QuadraturePoint| 1.0 + q.x[0] * q.x[1];
        let m = mass_2d(&x, &x, 3, density);
        // sum_ij M_ij = int rho = 1 + 1/4.
        let total: f64 = m.values.iter().sum();
        assert!((total - 1.25).abs() < 1e-13, "{total}");
        // Bitwise identical on one thread.
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let serial = pool.install(|| mass_2d(&x, &x, 3, density));
        assert_eq!(serial.values, m.values);
    }
}
