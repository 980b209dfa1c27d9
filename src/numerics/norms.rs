//! Error measures of SPEC §6, evaluated at particle positions:
//!
//! * `RMS = sqrt(mean_p (f_num - f_exact)^2)`
//! * relative L2 error `||f_num - f_exact||_2 / ||f_exact||_2`
//! * observed order between two resolutions, `log(e_1 / e_2) / log(h_1 / h_2)`.

/// Root-mean-square difference of two equally long slices (0 for empty input).
///
/// ```
/// let e = tlsmpm::numerics::norms::rms(&[1.0, 2.0], &[1.0, 0.0]);
/// assert!((e - 2f64.sqrt()).abs() < 1e-15);
/// ```
pub fn rms(numerical: &[f64], exact: &[f64]) -> f64 {
    let n = numerical.len().min(exact.len());
    if n == 0 {
        return 0.0;
    }
    let sum: f64 = numerical
        .iter()
        .zip(exact)
        .map(|(a, b)| (a - b) * (a - b))
        .sum();
    (sum / n as f64).sqrt()
}

/// Relative L2 error `||num - exact|| / ||exact||`; the absolute norm if `exact` is zero.
///
/// ```
/// let e = tlsmpm::numerics::norms::relative_l2(&[1.1, 2.2], &[1.0, 2.0]);
/// assert!((e - 0.1).abs() < 1e-14);
/// ```
pub fn relative_l2(numerical: &[f64], exact: &[f64]) -> f64 {
    let diff: f64 = numerical
        .iter()
        .zip(exact)
        .map(|(a, b)| (a - b) * (a - b))
        .sum();
    let norm: f64 = exact.iter().map(|b| b * b).sum();
    if norm > 0.0 {
        (diff / norm).sqrt()
    } else {
        diff.sqrt()
    }
}

/// Observed convergence order between errors `e_coarse` at `h_coarse` and `e_fine` at
/// `h_fine`: `log(e_coarse / e_fine) / log(h_coarse / h_fine)`. `NaN` if undefined.
///
/// ```
/// let p = tlsmpm::numerics::norms::observed_order(4e-2, 0.2, 1e-2, 0.1);
/// assert!((p - 2.0).abs() < 1e-12);
/// ```
pub fn observed_order(e_coarse: f64, h_coarse: f64, e_fine: f64, h_fine: f64) -> f64 {
    if e_coarse > 0.0 && e_fine > 0.0 && h_coarse > 0.0 && h_fine > 0.0 && h_coarse != h_fine {
        (e_coarse / e_fine).ln() / (h_coarse / h_fine).ln()
    } else {
        f64::NAN
    }
}
