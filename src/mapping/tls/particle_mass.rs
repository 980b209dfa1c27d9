//! The consistent particle mass (and fit volume) of the adjoint TLS step (`method.adjoint_mass =
//! "consistent"`, docs/reconstruction.md "Consistent particle metric").
//!
//! The adjoint acceleration solves `W a = f` for the particle accelerations `a`, where
//! `f = P^T a_grid` is the pull-back of the grid accelerations through the momentum map
//! ([`super::adjoint`]) and `W` is a symmetric positive definite particle mass. With the
//! lumped `W = diag(m_p)` the acceleration is exact for a uniform field only: for a linear
//! field `a(x) = x` the pull-back is `f_p = m_p x_p + d_p`, whose defect `d_p` (the
//! particles are not the Gauss quadrature of the fit's moments) is of relative size
//! `1 / n^2` at `n` particles per cell in reference coordinates, so `a_p` errs by
//! `O(h a' / n^2)`: first order in `h`, where the basis value `sum_i phi_i(x_p) a_i` is of
//! the basis' order.
//!
//! The consistent mass is, per cell `c` and the particles `p` of the cell of their
//! centre (block diagonal, so momentum stays per cell):
//!
//! ```text
//! W_c = diag(m) + (d' xt^T + xt d'^T) / s - xt xt^T (d' . xt) / s^2
//! xt_p = x_p - mean(x),  s = xt . xt,  d'_p = d_p - m_p (sum d) / (sum m)
//! ```
//!
//! It keeps the lumped row sums (`W 1 = m`, as `xt . 1 = d' . 1 = 0`), so
//! `sum_p m_p a_p = sum_p f_p` (momentum), and maps the linear field to its pull-back up
//! to the cell's mean defect (`W x = f(x) - m (sum d) / (sum m)`): a linear acceleration is
//! reproduced up to the offset `(sum d) / (sum m)`, the cell's first-moment defect, which
//! is of higher order. Any symmetric positive definite `W` keeps the frozen step neutral
//! (the conserved energy is `v^T W v / 2 + ...`), but a `W` that changes with the particle
//! configuration feeds energy in as the particles move (`v^T dW/dt v / 2`; the large
//! vibrating bar gains 30x with `W` allowed within 0.5..2 of `diag(m)`). So the correction
//! is scaled by the largest `theta <= 1` that keeps the eigenvalues of
//! `diag(m)^{-1/2} W_c diag(m)^{-1/2}` within [`MIN_EIGENVALUE`]..[`MAX_EIGENVALUE`] (1%):
//! smooth fields at several particles per cell keep the full correction (its size is
//! `1 / n^2` times the field's variation over a cell), strongly deformed cells fall back
//! continuously towards the lumped mass. A cell of one particle keeps the lumped mass.
//! `W_c` is the diagonal plus a rank-2 term, so `W_c^{-1}` is applied by the Woodbury
//! formula with one 2x2 solve per cell.
//!
//! The same metric, with the fit volumes `V~_p` in place of `m_p` and the power of the
//! velocity gradient field `dv(x) = x` in place of the linear acceleration, makes the
//! adjoint strain exact for linear velocity gradients.

use super::cell_metric::{metric_accelerations, CellMetric, MetricInputs};

/// Smallest accepted eigenvalue of `diag(m)^{-1/2} W_c diag(m)^{-1/2}`.
pub const MIN_EIGENVALUE: f64 = 0.99;
/// Largest accepted eigenvalue of `diag(m)^{-1/2} W_c diag(m)^{-1/2}`.
pub const MAX_EIGENVALUE: f64 = 1.01;

/// The per-cell Woodbury solution: `a_p = (f_p - d'_p z_0 - xt_p z_1) / m_p`.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct CellCorrection {
    /// `z` of the 2x2 solve.
    z: [f64; 2],
    /// The mean particle position of the cell.
    mean_x: f64,
    /// `(sum d) / (sum m)`.
    mean_defect: f64,
    /// The correction was scaled by `theta < 1`.
    limited: bool,
}

impl CellCorrection {
    /// `z` of the Woodbury solve (the coefficients of `d'` and `xt`).
    pub(super) fn woodbury_solution(&self) -> [f64; 2] {
        self.z
    }
}

/// The particle accelerations `a = W^{-1} f` (see the module doc; the driver is
/// [`metric_accelerations`]): `cell` is sorted, `force` is `f = P^T a_grid`, `linear` the
/// pull-back of the field `a(x) = x`. Returns the number of cells of two particles or more
/// whose correction was scaled down (or dropped).
#[allow(clippy::too_many_arguments)]
pub(super) fn consistent_accelerations(
    cells: usize,
    cell: &[usize],
    x: &[f64],
    mass: &[f64],
    force: &[f64],
    linear: &[f64],
    corrections: &mut Vec<Option<CellCorrection>>,
    out: &mut [f64],
) -> u64 {
    let inputs = MetricInputs {
        x,
        mass,
        force,
        pulled_back: [linear],
    };
    metric_accelerations(cells, cell, inputs, corrections, out)
}

impl CellMetric<1> for CellCorrection {
    fn correction(cell: MetricInputs<'_, 1>) -> Option<Self> {
        cell_correction(cell.x, cell.mass, cell.force, cell.pulled_back[0])
    }

    fn limited(&self) -> bool {
        self.limited
    }

    /// `a_p = (f_p - d'_p z_0 - xt_p z_1) / m_p`.
    #[inline]
    fn acceleration(&self, inputs: &MetricInputs<'_, 1>, p: usize) -> f64 {
        let (x, m, linear) = (inputs.x[p], inputs.mass[p], inputs.pulled_back[0][p]);
        let defect = linear - m * x - self.mean_defect * m;
        (inputs.force[p] - defect * self.z[0] - (x - self.mean_x) * self.z[1]) / m
    }
}

/// The Woodbury data of one cell's consistent mass, `None` where it keeps the lumped
/// mass.
pub(super) fn cell_correction(
    x: &[f64],
    mass: &[f64],
    force: &[f64],
    linear: &[f64],
) -> Option<CellCorrection> {
    let n = x.len();
    if n < 2 {
        return None;
    }
    let mean_x = x.iter().sum::<f64>() / n as f64;
    let total_mass: f64 = mass.iter().sum();
    let total_defect: f64 = (0..n).map(|p| linear[p] - mass[p] * x[p]).sum();
    let mean_defect = total_defect / total_mass;
    // Sums over the cell: s = xt.xt, dx = d'.xt, G = U^T diag(m)^{-1} U with U = [d', xt],
    // and U^T diag(m)^{-1} f.
    let (mut s, mut dx) = (0.0, 0.0);
    let (mut g_dd, mut g_dx, mut g_xx) = (0.0, 0.0, 0.0);
    let (mut r_d, mut r_x) = (0.0, 0.0);
    for p in 0..n {
        let xt = x[p] - mean_x;
        let d = linear[p] - mass[p] * x[p] - mean_defect * mass[p];
        let m = mass[p];
        s += xt * xt;
        dx += d * xt;
        g_dd += d * d / m;
        g_dx += d * xt / m;
        g_xx += xt * xt / m;
        r_d += d * force[p] / m;
        r_x += xt * force[p] / m;
    }
    let spread = s > 0.0;
    if !spread || !total_mass.is_finite() || !mean_defect.is_finite() {
        return None;
    }
    // W = D + theta U K U^T with K = [[0, 1/s], [1/s, -dx/s^2]]; its eigenvalues relative
    // to D are 1 and 1 + theta mu, mu those of K G (real: W is symmetric).
    let kg = [
        [g_dx / s, g_xx / s],
        [
            g_dd / s - dx * g_dx / (s * s),
            g_dx / s - dx * g_xx / (s * s),
        ],
    ];
    let trace = kg[0][0] + kg[1][1];
    let det = kg[0][0] * kg[1][1] - kg[0][1] * kg[1][0];
    let root = (0.25 * trace * trace - det).max(0.0).sqrt();
    let (smallest, largest) = (0.5 * trace - root, 0.5 * trace + root);
    // The largest theta <= 1 with 1 + theta mu in [MIN_EIGENVALUE, MAX_EIGENVALUE].
    let mut theta: f64 = 1.0;
    if smallest < 0.0 {
        theta = theta.min((1.0 - MIN_EIGENVALUE) / -smallest);
    }
    if largest > 0.0 {
        theta = theta.min((MAX_EIGENVALUE - 1.0) / largest);
    }
    let positive = theta > 0.0;
    if !positive {
        return None;
    }
    // Woodbury: a = D^{-1} f - D^{-1} U T^{-1} U^T D^{-1} f, T = (theta K)^{-1} + G,
    // K^{-1} = [[dx, s], [s, 0]].
    let t = [
        [dx / theta + g_dd, s / theta + g_dx],
        [s / theta + g_dx, g_xx],
    ];
    let det_t = t[0][0] * t[1][1] - t[0][1] * t[1][0];
    let invertible = det_t.abs() > 0.0;
    if !invertible {
        return None;
    }
    let z = [
        (t[1][1] * r_d - t[0][1] * r_x) / det_t,
        (t[0][0] * r_x - t[1][0] * r_d) / det_t,
    ];
    z.iter().all(|v| v.is_finite()).then_some(CellCorrection {
        z,
        mean_x,
        mean_defect,
        limited: theta < 1.0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};

    /// A cell of `n` particles with masses and positions from `seed`, and a pull-back of
    /// `a(x) = x` whose defect is `defect` times the mass over `n`.
    fn cell(n: usize, seed: u64, defect: f64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
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
        let linear: Vec<f64> = (0..n)
            .map(|p| mass[p] * x[p] + defect * mass[p] * (next() - 0.5) / n as f64)
            .collect();
        (x, mass, linear)
    }

    /// The dense `W_c` of the module doc, unscaled.
    fn dense_mass(x: &[f64], mass: &[f64], linear: &[f64]) -> DMatrix<f64> {
        let n = x.len();
        let mean_x = x.iter().sum::<f64>() / n as f64;
        let total_mass: f64 = mass.iter().sum();
        let mean_defect = (0..n).map(|p| linear[p] - mass[p] * x[p]).sum::<f64>() / total_mass;
        let xt = DVector::from_iterator(n, x.iter().map(|x| x - mean_x));
        let d = DVector::from_iterator(
            n,
            (0..n).map(|p| linear[p] - mass[p] * x[p] - mean_defect * mass[p]),
        );
        let s = xt.dot(&xt);
        DMatrix::from_diagonal(&DVector::from_column_slice(mass))
            + (&d * xt.transpose() + &xt * d.transpose()) / s
            - &xt * xt.transpose() * (d.dot(&xt) / (s * s))
    }

    fn solve(x: &[f64], mass: &[f64], force: &[f64], linear: &[f64]) -> (Vec<f64>, u64) {
        let n = x.len();
        let mut out = vec![0.0; n];
        let limited = consistent_accelerations(
            1,
            &vec![0; n],
            x,
            mass,
            force,
            linear,
            &mut Vec::new(),
            &mut out,
        );
        (out, limited)
    }

    #[test]
    fn the_woodbury_solve_matches_the_dense_consistent_mass() {
        for (n, seed) in [(2, 1), (3, 2), (6, 3), (20, 4)] {
            let (x, mass, linear) = cell(n, seed, 1e-4);
            let force: Vec<f64> = (0..n).map(|p| mass[p] * (1.0 + x[p] * x[p])).collect();
            let (out, limited) = solve(&x, &mass, &force, &linear);
            assert_eq!(limited, 0, "{n} particles: the full correction");
            let w = dense_mass(&x, &mass, &linear);
            let residual =
                &w * DVector::from_column_slice(&out) - DVector::from_column_slice(&force);
            let scale = force.iter().fold(0.0, |m: f64, f| m.max(f.abs()));
            assert!(residual.amax() < 1e-12 * scale, "{n} particles");
            // Symmetric positive definite, row sums the masses.
            assert!(w.clone().cholesky().is_some());
            for (p, m) in mass.iter().enumerate() {
                assert!((w.row(p).sum() - m).abs() < 1e-13, "{n} particles");
            }
        }
    }

    #[test]
    fn uniform_and_linear_fields_are_reproduced_and_momentum_is_kept() {
        let n = 7;
        let (x, mass, linear) = cell(n, 9, 1e-4);
        // Uniform: f = 3 m.
        let uniform: Vec<f64> = mass.iter().map(|m| 3.0 * m).collect();
        let (out, _) = solve(&x, &mass, &uniform, &linear);
        assert!(out.iter().all(|a| (a - 3.0).abs() < 1e-13), "{out:?}");
        // Linear: f = the pull-back of a(x) = x, reproduced up to the mean defect.
        let (out, limited) = solve(&x, &mass, &linear, &linear);
        assert_eq!(limited, 0);
        let total_mass: f64 = mass.iter().sum();
        let offset = (0..n).map(|p| linear[p] - mass[p] * x[p]).sum::<f64>() / total_mass;
        for p in 0..n {
            assert!(
                (out[p] - x[p] - offset).abs() < 1e-12,
                "{p}: {} vs {}",
                out[p],
                x[p]
            );
            // The lumped acceleration errs by the particle's own defect.
            assert!((linear[p] / mass[p] - x[p]).abs() > 1e-7);
        }
        let momentum: f64 = (0..n).map(|p| mass[p] * out[p]).sum();
        assert!((momentum - linear.iter().sum::<f64>()).abs() < 1e-13 * momentum.abs());
    }

    #[test]
    fn a_large_correction_is_scaled_to_stay_within_one_percent_of_the_lumped_mass() {
        let n = 6;
        let (x, mass, linear) = cell(n, 5, 0.5);
        let force: Vec<f64> = (0..n).map(|p| mass[p] * (1.0 + x[p])).collect();
        let (out, limited) = solve(&x, &mass, &force, &linear);
        assert_eq!(limited, 1);
        // W within [0.99, 1.01] diag(m): |D^(1/2) (a - D^-1 f)| <= 0.0102 |D^(-1/2) f|.
        let (mut change, mut size) = (0.0, 0.0);
        for p in 0..n {
            change += mass[p] * (out[p] - force[p] / mass[p]).powi(2);
            size += force[p] * force[p] / mass[p];
        }
        assert!(change.sqrt() <= 0.0102 * size.sqrt(), "{change} vs {size}");
        assert!(change > 0.0, "still corrected");
        let momentum: f64 = (0..n).map(|p| mass[p] * out[p]).sum();
        assert!((momentum - force.iter().sum::<f64>()).abs() < 1e-13 * momentum.abs());
    }

    #[test]
    fn a_single_particle_keeps_the_lumped_mass() {
        let mut out = vec![0.0; 3];
        // Cell 0: one particle; cell 1: two.
        let cell = [0, 1, 1];
        let x = [0.5, 1.4, 1.6];
        let mass = [1.0, 2.0, 1.0];
        let linear = [0.5, 2.8, 1.6];
        let force = [2.0, 3.0, 4.0];
        let mut corrections = Vec::new();
        consistent_accelerations(
            2,
            &cell,
            &x,
            &mass,
            &force,
            &linear,
            &mut corrections,
            &mut out,
        );
        assert_eq!(out[0], 2.0);
        // No defect: the consistent mass is the lumped one.
        assert!((out[1] - 1.5).abs() < 1e-15 && (out[2] - 4.0).abs() < 1e-15);
    }
}
