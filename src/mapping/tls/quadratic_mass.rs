//! The quadratic particle metric of the adjoint TLS step (`method.adjoint_mass =
//! "quadratic"`, docs/reconstruction.md "Consistent particle metric"): the consistent
//! metric of [`super::particle_mass`] made exact for quadratic fields as well.
//!
//! Per cell `c`, over the particles of the cell of their centre, with `xt = x - mean(x)`,
//! the pull-backs `l_1 = P^T x`, `l_2 = P^T x^2` and the defects
//!
//! ```text
//! e_1 = l_1 - m x,   e_2 = (l_2 - m x^2) - 2 mean(x) e_1     (the defect of (x - mean x)^2)
//! e'_k = e_k - m (sum e_k) / (sum m)
//! Q = [xt, xt^2 - mean(xt^2)],   E = [e'_1, e'_2],   G = Q^T Q,   S = sym(Q^T E)
//! W_c = diag(m) + C,   C = E G^-1 Q^T + Q G^-1 E^T - Q G^-1 S G^-1 Q^T
//! ```
//!
//! `C` is symmetric, `C 1 = 0` (row sums, so momentum is kept per cell) and `C Q = E` up to
//! the skew part of `Q^T E` (the particles' and the fit's second moments differ there): so
//! `W` maps a quadratic field to its pull-back up to a constant per cell, where the linear
//! metric is exact for linear fields only. For one correction column (`Q = [xt]`) this is
//! the linear metric. `C = U K U^T` with `U = [E, Q]` and
//! `K = [[0, G^-1], [G^-1, -G^-1 S G^-1]]`, `K^-1 = [[S, G], [G, 0]]`, so `W^-1` is applied
//! by the Woodbury formula with one 4x4 solve per cell.
//!
//! A cell takes the whole correction where the eigenvalues of
//! `diag(m)^{-1/2} W_c diag(m)^{-1/2}` stay within `1 -+` [`QUADRATIC_WINDOW`] (5%), and
//! the linear metric (scaled into its 1% window) elsewhere, or where `G` is (nearly)
//! singular (fewer than three particles, or two positions only). Scaling the quadratic
//! correction into the linear metric's 1% window, or into 5%, was measured worse: the
//! first loses the quadratic accuracy on the small vibrating bar, the second feeds energy
//! into the large one (docs/reconstruction.md).

use nalgebra::{Matrix2, Matrix4, Vector4};

use super::cell_metric::{metric_accelerations, CellMetric, MetricInputs};
use super::particle_mass;

/// The quadratic correction is taken where the eigenvalues of
/// `diag(m)^{-1/2} W_c diag(m)^{-1/2}` lie within `1 -+ QUADRATIC_WINDOW`; elsewhere the
/// cell takes the linear metric (with its own 1% window). The quadratic moment defect of
/// `n` evenly spaced particles is about `5 / n^2` of the mass (3.5% at 12 per cell, where
/// the linear one is `1 / n^2`), so 5% admits it from about 10 particles per cell on;
/// scaling it into 1% as the linear metric does loses it everywhere.
pub const QUADRATIC_WINDOW: f64 = 0.05;
/// Smallest accepted `det G / (G_11 G_22)`: below it the two correction columns are
/// nearly parallel and the cell takes the linear metric.
const MIN_INDEPENDENCE: f64 = 1e-8;

/// The per-cell Woodbury solution:
/// `a_p = (f_p - e'_1p z_0 - e'_2p z_1 - xt_p z_2 - (xt_p^2 - mean(xt^2)) z_3) / m_p`.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct QuadraticCorrection {
    z: [f64; 4],
    mean_x: f64,
    mean_square: f64,
    /// `(sum e_k) / (sum m)`.
    mean_defect: [f64; 2],
    /// The cell took the linear metric instead.
    limited: bool,
}

/// The per-particle inputs of one cell.
#[derive(Clone, Copy)]
struct CellData<'a> {
    x: &'a [f64],
    mass: &'a [f64],
    force: &'a [f64],
    linear: &'a [f64],
    quadratic: &'a [f64],
}

impl QuadraticCorrection {
    /// The columns `[e'_1, e'_2, xt, xt^2 - mean(xt^2)]` of `U` at particle `(x, m, l_1, l_2)`.
    #[inline]
    fn columns(&self, x: f64, m: f64, linear: f64, quadratic: f64) -> [f64; 4] {
        let e1 = linear - m * x;
        let xt = x - self.mean_x;
        let e2 = (quadratic - m * x * x) - 2.0 * self.mean_x * e1;
        [
            e1 - m * self.mean_defect[0],
            e2 - m * self.mean_defect[1],
            xt,
            xt * xt - self.mean_square,
        ]
    }

    #[inline]
    fn particle_acceleration(
        &self,
        x: f64,
        m: f64,
        force: f64,
        linear: f64,
        quadratic: f64,
    ) -> f64 {
        let u = self.columns(x, m, linear, quadratic);
        (force - u[0] * self.z[0] - u[1] * self.z[1] - u[2] * self.z[2] - u[3] * self.z[3]) / m
    }
}

/// The particle accelerations `a = W^{-1} f` with the quadratic metric (see the module
/// doc); as [`particle_mass::consistent_accelerations`], with `quadratic` the pull-back of
/// `a(x) = x^2`. Returns the number of cells of two particles or more that took the linear
/// metric (or the lumped one) instead of the quadratic correction.
#[allow(clippy::too_many_arguments)]
pub(super) fn quadratic_accelerations(
    cells: usize,
    cell: &[usize],
    x: &[f64],
    mass: &[f64],
    force: &[f64],
    linear: &[f64],
    quadratic: &[f64],
    corrections: &mut Vec<Option<QuadraticCorrection>>,
    out: &mut [f64],
) -> u64 {
    let inputs = MetricInputs {
        x,
        mass,
        force,
        pulled_back: [linear, quadratic],
    };
    metric_accelerations(cells, cell, inputs, corrections, out)
}

impl CellMetric<2> for QuadraticCorrection {
    fn correction(cell: MetricInputs<'_, 2>) -> Option<Self> {
        cell_correction(CellData {
            x: cell.x,
            mass: cell.mass,
            force: cell.force,
            linear: cell.pulled_back[0],
            quadratic: cell.pulled_back[1],
        })
    }

    fn limited(&self) -> bool {
        self.limited
    }

    #[inline]
    fn acceleration(&self, inputs: &MetricInputs<'_, 2>, p: usize) -> f64 {
        let [linear, quadratic] = inputs.pulled_back;
        self.particle_acceleration(
            inputs.x[p],
            inputs.mass[p],
            inputs.force[p],
            linear[p],
            quadratic[p],
        )
    }
}

/// The Woodbury data of one cell, `None` where it keeps the lumped mass.
fn cell_correction(data: CellData) -> Option<QuadraticCorrection> {
    let CellData {
        x,
        mass,
        force,
        linear,
        quadratic,
    } = data;
    let n = x.len();
    if n < 2 {
        return None;
    }
    let mean_x = x.iter().sum::<f64>() / n as f64;
    let mean_square = x.iter().map(|x| (x - mean_x).powi(2)).sum::<f64>() / n as f64;
    let total_mass: f64 = mass.iter().sum();
    let mut correction = QuadraticCorrection {
        mean_x,
        mean_square,
        ..Default::default()
    };
    let mut total_defect = [0.0; 2];
    for p in 0..n {
        let [e1, e2, _, _] = correction.columns(x[p], mass[p], linear[p], quadratic[p]);
        total_defect[0] += e1;
        total_defect[1] += e2;
    }
    correction.mean_defect = total_defect.map(|t| t / total_mass);
    if !total_mass.is_finite() || correction.mean_defect.iter().any(|d| !d.is_finite()) {
        return None;
    }
    // G = Q^T Q, Q^T E, H = U^T diag(m)^-1 U, r = U^T diag(m)^-1 f.
    let (mut g, mut qe) = (Matrix2::<f64>::zeros(), Matrix2::<f64>::zeros());
    let (mut h, mut r) = (Matrix4::<f64>::zeros(), Vector4::<f64>::zeros());
    for p in 0..n {
        let u = Vector4::from(correction.columns(x[p], mass[p], linear[p], quadratic[p]));
        let m = mass[p];
        for i in 0..2 {
            for j in 0..2 {
                g[(i, j)] += u[2 + i] * u[2 + j];
                qe[(i, j)] += u[2 + i] * u[j];
            }
        }
        h += u * u.transpose() / m;
        r += u * (force[p] / m);
    }
    let independent = g[(0, 0)] > 0.0
        && g[(1, 1)] > 0.0
        && g.determinant() > MIN_INDEPENDENCE * g[(0, 0)] * g[(1, 1)];
    let Some(g_inverse) = independent.then(|| g.try_inverse()).flatten() else {
        return linear_fallback(data, correction);
    };
    let s = (qe + qe.transpose()) * 0.5;
    let mut k = Matrix4::<f64>::zeros();
    k.fixed_view_mut::<2, 2>(0, 2).copy_from(&g_inverse);
    k.fixed_view_mut::<2, 2>(2, 0).copy_from(&g_inverse);
    k.fixed_view_mut::<2, 2>(2, 2)
        .copy_from(&(-g_inverse * s * g_inverse));
    // The whole correction or the linear metric: 1 + mu within the window.
    if !within_window(&k, &h) {
        return linear_fallback(data, correction);
    }
    // T = K^-1 + H, K^-1 = [[S, G], [G, 0]].
    let mut t = h;
    for i in 0..2 {
        for j in 0..2 {
            t[(i, j)] += s[(i, j)];
            t[(i, 2 + j)] += g[(i, j)];
            t[(2 + i, j)] += g[(i, j)];
        }
    }
    let Some(z) = t.lu().solve(&r).filter(|z| z.iter().all(|v| v.is_finite())) else {
        return linear_fallback(data, correction);
    };
    correction.z = [z[0], z[1], z[2], z[3]];
    Some(correction)
}

/// Whether the eigenvalues `mu` of `K H` (those of `diag(m)^{-1/2} C diag(m)^{-1/2}`, real)
/// lie within `-+` [`QUADRATIC_WINDOW`]. They are real, so `sum mu^2 = tr((K H)^2)` bounds
/// them all at the cost of a product; only a cell that fails that bound takes the
/// eigenvalues of the symmetric `H^{1/2} K H^{1/2}` (columns scaled to a unit diagonal of
/// `H` first).
fn within_window(k: &Matrix4<f64>, h: &Matrix4<f64>) -> bool {
    let kh = k * h;
    let sum_of_squares = (kh * kh).trace();
    if sum_of_squares <= QUADRATIC_WINDOW * QUADRATIC_WINDOW {
        return true;
    }
    let scale = Vector4::from_fn(|i, _| {
        let d = h[(i, i)];
        if d > 0.0 {
            1.0 / d.sqrt()
        } else {
            1.0
        }
    });
    let scaled_h = Matrix4::from_fn(|i, j| h[(i, j)] * scale[i] * scale[j]);
    let scaled_k = Matrix4::from_fn(|i, j| k[(i, j)] / (scale[i] * scale[j]));
    let eigen = scaled_h.symmetric_eigen();
    let root = eigen.eigenvectors
        * Matrix4::from_diagonal(&eigen.eigenvalues.map(|l| l.max(0.0).sqrt()))
        * eigen.eigenvectors.transpose();
    let spectrum = (root * scaled_k * root).symmetric_eigenvalues();
    spectrum.min() >= -QUADRATIC_WINDOW && spectrum.max() <= QUADRATIC_WINDOW
}

/// The linear metric of [`particle_mass`] for a cell whose quadratic correction is
/// ill-posed, in the quadratic cell's form (`z_1 = z_3 = 0`).
fn linear_fallback(
    data: CellData,
    mut correction: QuadraticCorrection,
) -> Option<QuadraticCorrection> {
    let linear = particle_mass::cell_correction(data.x, data.mass, data.force, data.linear)?;
    let z = linear.woodbury_solution();
    correction.z = [z[0], 0.0, z[1], 0.0];
    correction.limited = true;
    Some(correction)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};

    /// A cell of `n` particles with masses and positions from `seed`, and the pull-backs
    /// `l = (diag(m) + B) a` of `a(x) = x` and `a(x) = x^2` for a symmetric `B` with zero row
    /// sums of size `defect` times the mass over `n^2`: the particle metric that a fit with
    /// that quadrature defect implies.
    fn cell(n: usize, seed: u64, defect: f64) -> [Vec<f64>; 4] {
        let mut state = seed;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let x: Vec<f64> = (0..n)
            .map(|k| 2.0 + (k as f64 + 0.2 + 0.6 * next()) / n as f64)
            .collect();
        let mass: Vec<f64> = (0..n).map(|_| 0.5 + next()).collect();
        let size = defect / (n * n) as f64;
        let mut b = DMatrix::<f64>::zeros(n, n);
        for _ in 0..3 {
            let v = DVector::from_fn(n, |_, _| next() - 0.5);
            let v = v.add_scalar(-v.mean());
            b += &v * v.transpose() * (size * if next() < 0.5 { -1.0 } else { 1.0 });
        }
        let metric = DMatrix::from_diagonal(&DVector::from_column_slice(&mass)) + b;
        let pull_back = |f: &dyn Fn(f64) -> f64| {
            let a = DVector::from_iterator(n, x.iter().map(|&x| f(x)));
            (&metric * a).as_slice().to_vec()
        };
        let (linear, quadratic) = (pull_back(&|x| x), pull_back(&|x| x * x));
        [x, mass, linear, quadratic]
    }

    /// The dense `W_c` of the module doc.
    fn dense_mass([x, mass, linear, quadratic]: &[Vec<f64>; 4]) -> DMatrix<f64> {
        let n = x.len();
        let mean_x = x.iter().sum::<f64>() / n as f64;
        let mean_square = x.iter().map(|x| (x - mean_x).powi(2)).sum::<f64>() / n as f64;
        let total_mass: f64 = mass.iter().sum();
        let e1: Vec<f64> = (0..n).map(|p| linear[p] - mass[p] * x[p]).collect();
        let e2: Vec<f64> = (0..n)
            .map(|p| {
                let xt = x[p] - mean_x;
                quadratic[p] - 2.0 * mean_x * linear[p] + mean_x * mean_x * mass[p]
                    - mass[p] * xt * xt
            })
            .collect();
        let (k1, k2) = (
            e1.iter().sum::<f64>() / total_mass,
            e2.iter().sum::<f64>() / total_mass,
        );
        let e = DMatrix::from_fn(n, 2, |p, k| [e1[p] - mass[p] * k1, e2[p] - mass[p] * k2][k]);
        let q = DMatrix::from_fn(n, 2, |p, k| {
            let xt = x[p] - mean_x;
            [xt, xt * xt - mean_square][k]
        });
        let g_inverse = (q.transpose() * &q).try_inverse().unwrap();
        let qe = q.transpose() * &e;
        let s = (&qe + qe.transpose()) * 0.5;
        let c = &e * &g_inverse * q.transpose() + &q * &g_inverse * e.transpose()
            - &q * &g_inverse * s * &g_inverse * q.transpose();
        DMatrix::from_diagonal(&DVector::from_column_slice(mass)) + c
    }

    fn solve(data: &[Vec<f64>; 4], force: &[f64]) -> (Vec<f64>, u64) {
        let [x, mass, linear, quadratic] = data;
        let n = x.len();
        let mut out = vec![0.0; n];
        let limited = quadratic_accelerations(
            1,
            &vec![0; n],
            x,
            mass,
            force,
            linear,
            quadratic,
            &mut Vec::new(),
            &mut out,
        );
        (out, limited)
    }

    #[test]
    fn the_woodbury_solve_matches_the_dense_quadratic_metric() {
        for (n, seed) in [(3, 2), (4, 7), (6, 3), (20, 4)] {
            let data = cell(n, seed, 1e-3);
            let force: Vec<f64> = (0..n)
                .map(|p| data[1][p] * (1.0 + data[0][p].powi(3)))
                .collect();
            let (out, limited) = solve(&data, &force);
            assert_eq!(limited, 0, "{n} particles: the full correction");
            let w = dense_mass(&data);
            let residual =
                &w * DVector::from_column_slice(&out) - DVector::from_column_slice(&force);
            let scale = force.iter().fold(0.0, |m: f64, f| m.max(f.abs()));
            assert!(
                residual.amax() < 1e-12 * scale,
                "{n} particles: {}",
                residual.amax()
            );
            assert!(w.clone().cholesky().is_some());
            assert!((&w - w.transpose()).amax() < 1e-14 * scale);
            for (p, m) in data[1].iter().enumerate() {
                assert!((w.row(p).sum() - m).abs() < 1e-13, "{n} particles");
            }
        }
    }

    #[test]
    fn quadratic_fields_are_reproduced_up_to_a_constant_and_momentum_is_kept() {
        let n = 7;
        let data = cell(n, 9, 1e-3);
        let [x, mass, linear, quadratic] = &data;
        let uniform: Vec<f64> = mass.iter().map(|m| 3.0 * m).collect();
        let (out, _) = solve(&data, &uniform);
        assert!(out.iter().all(|a| (a - 3.0).abs() < 1e-13), "{out:?}");
        // a(x) = 2 - x + 3 x^2: its pull-back is linear in those of 1, x and x^2.
        let force: Vec<f64> = (0..n)
            .map(|p| 2.0 * mass[p] - linear[p] + 3.0 * quadratic[p])
            .collect();
        let (out, limited) = solve(&data, &force);
        assert_eq!(limited, 0);
        let exact: Vec<f64> = x.iter().map(|x| 2.0 - x + 3.0 * x * x).collect();
        let mut lumped_error: f64 = 0.0;
        for p in 0..n {
            assert!(
                (out[p] - exact[p]).abs() < 1e-12,
                "{p}: {} vs {}",
                out[p],
                exact[p]
            );
            lumped_error = lumped_error.max((force[p] / mass[p] - exact[p]).abs());
        }
        assert!(
            lumped_error > 1e-6,
            "the lumped mass errs by the defect: {lumped_error}"
        );
        let momentum: f64 = (0..n).map(|p| mass[p] * out[p]).sum();
        let pulled: f64 = force.iter().sum();
        assert!((momentum - pulled).abs() < 1e-13 * pulled.abs());
    }

    #[test]
    fn two_particles_take_the_linear_metric() {
        let data = cell(2, 11, 1e-3);
        let [x, mass, linear, _] = &data;
        let force: Vec<f64> = (0..2).map(|p| mass[p] * (1.0 + x[p])).collect();
        let (out, limited) = solve(&data, &force);
        assert_eq!(limited, 1, "counted as limited");
        let mut linear_out = vec![0.0; 2];
        particle_mass::consistent_accelerations(
            1,
            &[0, 0],
            x,
            mass,
            &force,
            linear,
            &mut Vec::new(),
            &mut linear_out,
        );
        assert_eq!(out, linear_out);
    }

    #[test]
    fn a_correction_beyond_five_percent_takes_the_linear_metric() {
        // A defect of 40 / n^2 of the mass: the quadratic correction would move W by more
        // than 5%, so the cell takes the linear metric (itself scaled into 1%).
        let n = 8;
        let data = cell(n, 13, 40.0);
        let [x, mass, linear, _] = &data;
        let force: Vec<f64> = (0..n).map(|p| mass[p] * (1.0 + x[p] * x[p])).collect();
        let (out, limited) = solve(&data, &force);
        assert_eq!(limited, 1);
        let mut linear_out = vec![0.0; n];
        particle_mass::consistent_accelerations(
            1,
            &vec![0; n],
            x,
            mass,
            &force,
            linear,
            &mut Vec::new(),
            &mut linear_out,
        );
        assert_eq!(out, linear_out);
        // And a small one is taken whole.
        let (_, limited) = solve(&cell(n, 13, 1e-3), &force);
        assert_eq!(limited, 0);
    }
}
