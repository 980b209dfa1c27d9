//! The "axis-aligned" manufactured solution of Wallstedt & Guilkey (2008), the case Uintah
//! ships as `AxisAligned`, in `D = 1, 2, 3` dimensions (`D = 2` is plane strain).
//!
//! Reference: P. C. Wallstedt, J. E. Guilkey, "An evaluation of explicit time integration
//! schemes for use with the generalized interpolation material point method", J. Comput.
//! Phys. 227 (2008) 9628–9642.
//!
//! On the unit square/cube, material coordinates `X` in `[0, 1]^D`, with the phases
//! `phi = (0, 2 pi / 3, 4 pi / 3)` for `i = x, y, z`:
//!
//! ```text
//! u_i(X, t) = A sin(pi X_i) sin(c pi t + phi_i)
//! v_i(X, t) = A c pi sin(pi X_i) cos(c pi t + phi_i)
//! F         = diag(F_ii),  F_ii = 1 + A pi cos(pi X_i) sin(c pi t + phi_i)
//! J         = prod_i F_ii                      (axes beyond D have F = 1)
//! sigma     = (lambda ln J / J) I + (mu / J) (B - I),  B = F F^T
//! P         = J sigma F^-T,  P_ii = mu F_ii + (lambda ln J - mu) / F_ii
//! ```
//!
//! The body acceleration `b` makes `u` a solution of `rho_0 d2u/dt2 = Div_X P + rho_0 b`.
//! Only `F_ii` depends on `X_i`, so with `F'_ii = dF_ii/dX_i = -pi^2 u_i` and
//! `d(ln J)/dX_i = F'_ii / F_ii`,
//!
//! ```text
//! dP_ii/dX_i = F'_ii [mu + lambda / F_ii^2 - (lambda ln J - mu) / F_ii^2]
//!            = -pi^2 u_i [mu - (lambda (ln J - 1) - mu) / F_ii^2]
//! d2u_i/dt2  = -c^2 pi^2 u_i
//! b_i        = d2u_i/dt2 - (1/rho_0) dP_ii/dX_i
//!            = pi^2 u_i (mu / rho_0 - c^2 - (lambda (ln J - 1) - mu) / (rho_0 F_ii^2))
//! ```
//!
//! This derived form is identical, term for term, to Uintah's `AxisAligned` body force
//! (`MMS::computeExternalForceForMMS` in `src/CCA/Components/MPM/MMS/MMS.cc`, which uses
//! the same phases `sin(pi (2/3 + c t))`, `sin(pi (4/3 + c t))`). The
//! manufactured `u` is not a solution without `b`. The normal displacement vanishes on the
//! walls (`u_i = 0` at `X_i = 0, 1`: roller walls), and the motion is periodic with period
//! `2 / c`. Published constants: `rho_0 = 1`, `mu = 3846.15`, `K = 8333.33`,
//! `lambda = K - 2 mu / 3`, `E = 9 K mu / (3 K + mu)` (about `1e4`), `c = sqrt(E / rho_0)`
//! (about 100), `A = 0.05`.

use std::f64::consts::PI;

/// Published shear modulus `mu`.
const SHEAR_MODULUS: f64 = 3846.15;
/// Published bulk modulus `K`.
const BULK_MODULUS: f64 = 8333.33;
/// Published reference density `rho_0`.
const DENSITY: f64 = 1.0;

/// The axis-aligned manufactured solution (see the module documentation for the formulas).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisAlignedMms {
    /// Displacement amplitude `A`.
    pub amplitude: f64,
    /// Shear modulus `mu`.
    pub shear_modulus: f64,
    /// Lamé's first parameter `lambda`.
    pub lame_lambda: f64,
    /// Reference density `rho_0`.
    pub density: f64,
    /// Wave speed `c` in the time argument `c pi t + phi_i` (published: `sqrt(E / rho_0)`).
    pub wave_speed: f64,
}

impl AxisAlignedMms {
    /// The published constants with amplitude `amplitude`: `rho_0 = 1`, `mu = 3846.15`,
    /// `K = 8333.33`, `lambda = K - 2 mu / 3`, `E = 9 K mu / (3 K + mu)`,
    /// `c = sqrt(E / rho_0)` (the published amplitude is `0.05`).
    pub fn published(amplitude: f64) -> Self {
        let mu = SHEAR_MODULUS;
        let k = BULK_MODULUS;
        let youngs = 9.0 * k * mu / (3.0 * k + mu);
        Self {
            amplitude,
            shear_modulus: mu,
            lame_lambda: k - 2.0 * mu / 3.0,
            density: DENSITY,
            wave_speed: (youngs / DENSITY).sqrt(),
        }
    }

    /// Time argument `c pi t + phi_i` of axis `i`, `phi_i = 2 pi i / 3`.
    fn argument(&self, i: usize, t: f64) -> f64 {
        self.wave_speed * PI * t + 2.0 * PI * i as f64 / 3.0
    }

    /// Displacement `u_i = A sin(pi X_i) sin(c pi t + phi_i)`.
    pub fn displacement<const D: usize>(&self, x0: [f64; D], t: f64) -> [f64; D] {
        const { assert!(D >= 1 && D <= 3, "D must be 1, 2 or 3") };
        std::array::from_fn(|i| self.amplitude * (PI * x0[i]).sin() * self.argument(i, t).sin())
    }

    /// Velocity `v_i = du_i/dt = A c pi sin(pi X_i) cos(c pi t + phi_i)`.
    pub fn velocity<const D: usize>(&self, x0: [f64; D], t: f64) -> [f64; D] {
        const { assert!(D >= 1 && D <= 3, "D must be 1, 2 or 3") };
        std::array::from_fn(|i| {
            self.amplitude * self.wave_speed * PI * (PI * x0[i]).sin() * self.argument(i, t).cos()
        })
    }

    /// Diagonal of `F`: `F_ii = 1 + A pi cos(pi X_i) sin(c pi t + phi_i)` (the other
    /// components of `F` vanish; axes beyond `D` have `F = 1`).
    pub fn stretch<const D: usize>(&self, x0: [f64; D], t: f64) -> [f64; D] {
        const { assert!(D >= 1 && D <= 3, "D must be 1, 2 or 3") };
        std::array::from_fn(|i| {
            1.0 + self.amplitude * PI * (PI * x0[i]).cos() * self.argument(i, t).sin()
        })
    }

    /// Cauchy stress `sigma = (lambda ln J / J) I + (mu / J) (B - I)`, `B = F F^T`,
    /// `J = prod_i F_ii`, in the order `[xx, yy, zz, xy, xz, yz]`. The shear components are
    /// 0; axes beyond `D` have `B = 1`, so there `sigma = lambda ln J / J` (the plane-strain
    /// `sigma_zz` in 2D).
    pub fn cauchy_stress<const D: usize>(&self, x0: [f64; D], t: f64) -> [f64; 6] {
        let f = self.stretch(x0, t);
        let j: f64 = f.iter().product();
        let pressure_part = self.lame_lambda * j.ln() / j;
        let mut sigma = [0.0; 6];
        for (i, s) in sigma.iter_mut().take(3).enumerate() {
            let fi = f.get(i).copied().unwrap_or(1.0);
            *s = pressure_part + self.shear_modulus / j * (fi * fi - 1.0);
        }
        sigma
    }

    /// Body acceleration (per unit mass)
    /// `b_i = pi^2 u_i (mu / rho_0 - c^2 - (lambda (ln J - 1) - mu) / (rho_0 F_ii^2))`,
    /// from `rho_0 d2u/dt2 = Div_X P + rho_0 b` (derived in the module documentation; the
    /// same as Uintah's).
    pub fn body_force<const D: usize>(&self, x0: [f64; D], t: f64) -> [f64; D] {
        let u = self.displacement(x0, t);
        let f = self.stretch(x0, t);
        let ln_j: f64 = f.iter().map(|fi| fi.ln()).sum();
        let (mu, lambda, rho) = (self.shear_modulus, self.lame_lambda, self.density);
        let c2 = self.wave_speed * self.wave_speed;
        std::array::from_fn(|i| {
            PI * PI * u[i] * (mu / rho - c2 - (lambda * (ln_j - 1.0) - mu) / (rho * f[i] * f[i]))
        })
    }

    /// Period `2 / c` of the manufactured motion.
    pub fn period(&self) -> f64 {
        2.0 / self.wave_speed
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 6th-order central first derivative: offsets 1..=3, coefficients `3/4, -3/20, 1/60`.
    fn d1(f: impl Fn(f64) -> f64, x: f64, h: f64) -> f64 {
        let c = [3.0 / 4.0, -3.0 / 20.0, 1.0 / 60.0];
        c.iter()
            .enumerate()
            .map(|(k, ck)| {
                let s = (k + 1) as f64 * h;
                ck * (f(x + s) - f(x - s))
            })
            .sum::<f64>()
            / h
    }

    /// 6th-order central second derivative: `-49/18` at 0, `3/2, -3/20, 1/90` at 1..=3.
    fn d2(f: impl Fn(f64) -> f64, x: f64, h: f64) -> f64 {
        let c = [3.0 / 2.0, -3.0 / 20.0, 1.0 / 90.0];
        let side: f64 = c
            .iter()
            .enumerate()
            .map(|(k, ck)| {
                let s = (k + 1) as f64 * h;
                ck * (f(x + s) + f(x - s))
            })
            .sum();
        (side - 49.0 / 18.0 * f(x)) / (h * h)
    }

    /// `P_ii = J sigma_ii / F_ii` from `cauchy_stress` and `stretch` (independent of the
    /// closed form inside `body_force`).
    fn piola_diag<const D: usize>(m: &AxisAlignedMms, x0: [f64; D], t: f64) -> [f64; D] {
        let f = m.stretch(x0, t);
        let j: f64 = f.iter().product();
        let s = m.cauchy_stress(x0, t);
        std::array::from_fn(|i| j * s[i] / f[i])
    }

    /// Points of `{0, 0.13, 0.37, 0.5, 0.81, 1}^D`, less the corners (every `X_i` on a wall):
    /// there `u = 0`, so all three terms of the balance vanish identically and a relative
    /// check is meaningless.
    fn points<const D: usize>() -> Vec<[f64; D]> {
        let xs = [0.0, 0.13, 0.37, 0.5, 0.81, 1.0];
        let n = xs.len().pow(D as u32);
        (0..n)
            .map(|mut k| {
                std::array::from_fn(|_| {
                    let x = xs[k % xs.len()];
                    k /= xs.len();
                    x
                })
            })
            .filter(|p: &[f64; D]| !p.iter().all(|&x| x == 0.0 || x == 1.0))
            .collect()
    }

    /// Largest relative residual `|rho0 d2u/dt2 - Div P - rho0 b| / scale` at `(x0, t)`
    /// with the body force scaled by `1 + perturb`; `scale` is the largest magnitude of the
    /// three terms over all components at the point. Steps: `1e-3` in X, `5e-3` periods in
    /// t (the round-off and truncation errors are then both below ~1e-11 relative).
    fn residual<const D: usize>(m: &AxisAlignedMms, x0: [f64; D], t: f64, perturb: f64) -> f64 {
        let hx = 1e-3;
        let ht = 5e-3 * m.period();
        let b = m.body_force(x0, t);
        let mut terms = Vec::new();
        for i in 0..D {
            let div_p = d1(
                |s| {
                    let mut y = x0;
                    y[i] = s;
                    piola_diag(m, y, t)[i]
                },
                x0[i],
                hx,
            );
            let acc = d2(|s| m.displacement(x0, s)[i], t, ht);
            terms.push((m.density * acc, div_p, m.density * b[i] * (1.0 + perturb)));
        }
        let scale = terms
            .iter()
            .flat_map(|&(a, p, b)| [a.abs(), p.abs(), b.abs()])
            .fold(0.0, f64::max);
        assert!(scale > 0.0);
        terms
            .iter()
            .map(|&(a, p, b)| (a - p - b).abs() / scale)
            .fold(0.0, f64::max)
    }

    fn check_balance<const D: usize>() -> usize {
        let m = AxisAlignedMms::published(0.05);
        let period = m.period();
        // No axis is at rest at these times (`sin(c pi t + phi_i) != 0` for every i), so
        // only the corners of `points` have u = 0.
        let times = [0.05, 0.11, 0.3, 0.57, 0.9, 1.37].map(|s| s * period);
        let (mut count, mut worst, mut weakest) = (0, 0.0_f64, f64::INFINITY);
        for x0 in points::<D>() {
            for &t in &times {
                let r0 = residual(&m, x0, t, 0.0);
                assert!(r0 <= 1e-9, "D = {D}, X = {x0:?}, t = {t}: residual {r0:e}");
                // The perturbation shows by at least ~5e-9 at every point (b_i is smaller
                // than the other terms where its bracket changes sign, so not 1e-6).
                let r = residual(&m, x0, t, 1e-6);
                assert!(
                    r > 1e-9,
                    "D = {D}, X = {x0:?}, t = {t}: perturbed b passes ({r:e})"
                );
                worst = worst.max(r0);
                weakest = weakest.min(r);
                count += 1;
            }
        }
        eprintln!("D = {D}: {count} (X, t), residual <= {worst:e}, perturbed >= {weakest:e}");
        count
    }

    #[test]
    fn momentum_balance_holds_by_finite_differences() {
        let n2 = check_balance::<2>();
        let n3 = check_balance::<3>();
        assert!(n2 >= 50 && n3 >= 50, "{n2} / {n3} points");
    }

    #[test]
    fn momentum_balance_holds_in_1d() {
        let m = AxisAlignedMms::published(0.05);
        for x in [0.13, 0.37, 0.5, 0.81] {
            for s in [0.2, 0.7, 1.1] {
                let r = residual(&m, [x], s * m.period(), 0.0);
                assert!(r <= 1e-9, "X = {x}: residual {r:e}");
            }
        }
    }

    #[test]
    fn normal_displacement_vanishes_on_walls_at_t0() {
        let m = AxisAlignedMms::published(0.05);
        let inner = [0.0, 0.25, 0.6, 1.0];
        for &wall in &[0.0, 1.0] {
            for &a in &inner {
                for &b in &inner {
                    for i in 0..3 {
                        let mut x = [a, b, 0.4];
                        x[i] = wall;
                        let u3 = m.displacement(x, 0.0);
                        assert!(u3[i].abs() < 1e-15, "{x:?}: {u3:?}");
                        if i < 2 {
                            let u2 = m.displacement([x[0], x[1]], 0.0);
                            assert!(u2[i].abs() < 1e-15, "{x:?}: {u2:?}");
                        }
                    }
                }
            }
        }
        // At t = 0 the x motion is at rest (phi_x = 0): u_x = 0 everywhere.
        assert_eq!(m.displacement([0.3, 0.7], 0.0)[0], 0.0);
    }

    #[test]
    fn velocity_is_time_derivative_of_displacement() {
        let m = AxisAlignedMms::published(0.05);
        let ht = 5e-3 * m.period();
        for x0 in points::<3>().into_iter().step_by(7) {
            for s in [0.0, 0.23, 0.8] {
                let t = s * m.period();
                let v = m.velocity(x0, t);
                let vmax = v.iter().fold(0.0_f64, |a, b| a.max(b.abs()));
                for (i, vi) in v.iter().enumerate() {
                    let fd = d1(|tt| m.displacement(x0, tt)[i], t, ht);
                    assert!(
                        (fd - vi).abs() <= 1e-9 * vmax,
                        "{x0:?}, t = {t}: {fd} vs {vi}"
                    );
                }
            }
        }
        let v2 = m.velocity([0.3, 0.6], 0.01);
        let v3 = m.velocity([0.3, 0.6, 0.2], 0.01);
        assert_eq!(v2, [v3[0], v3[1]]);
    }

    #[test]
    fn stretch_is_displacement_gradient() {
        let m = AxisAlignedMms::published(0.05);
        let x0 = [0.21, 0.66, 0.93];
        let t = 0.37 * m.period();
        let f = m.stretch(x0, t);
        for i in 0..3 {
            let grad = d1(
                |s| {
                    let mut y = x0;
                    y[i] = s;
                    m.displacement(y, t)[i]
                },
                x0[i],
                1e-3,
            );
            assert!((1.0 + grad - f[i]).abs() < 1e-12, "{i}: {grad} vs {}", f[i]);
        }
    }

    #[test]
    fn plane_strain_stress_symmetric_and_zero_at_rest() {
        let m = AxisAlignedMms::published(0.05);
        for x0 in points::<2>() {
            for s in [0.0, 0.15, 0.6] {
                let t = s * m.period();
                let f = m.stretch(x0, t);
                let j = f[0] * f[1];
                let sigma = m.cauchy_stress(x0, t);
                let zz = m.lame_lambda * j.ln() / j;
                assert!((sigma[2] - zz).abs() <= 1e-12 * m.lame_lambda);
                assert_eq!(&sigma[3..], &[0.0; 3]);
                // Full 3x3 Cauchy stress is diagonal, hence symmetric.
                let full = [
                    [sigma[0], sigma[3], sigma[4]],
                    [sigma[3], sigma[1], sigma[5]],
                    [sigma[4], sigma[5], sigma[2]],
                ];
                for (a, row) in full.iter().enumerate() {
                    for (b, value) in row.iter().enumerate() {
                        assert_eq!(*value, full[b][a]);
                    }
                }
            }
        }
        let rest = AxisAlignedMms::published(0.0);
        for s in [0.0, 0.3, 0.8] {
            let t = s * rest.period();
            assert_eq!(rest.cauchy_stress([0.2, 0.9], t), [0.0; 6]);
            assert_eq!(rest.cauchy_stress([0.2, 0.9, 0.5], t), [0.0; 6]);
            assert_eq!(rest.cauchy_stress([0.7], t), [0.0; 6]);
            assert_eq!(rest.displacement([0.2, 0.9, 0.5], t), [0.0; 3]);
            assert_eq!(rest.body_force([0.2, 0.9, 0.5], t), [0.0; 3]);
        }
    }

    #[test]
    fn published_constants() {
        let m = AxisAlignedMms::published(0.05);
        let (mu, k) = (3846.15, 8333.33);
        let youngs_expected = 9.0 * k * mu / (3.0 * k + mu);
        let lambda = m.lame_lambda;
        let youngs = mu * (3.0 * lambda + 2.0 * mu) / (lambda + mu);
        assert!((youngs - youngs_expected).abs() <= 1e-6 * youngs_expected);
        assert!((youngs - 1e4).abs() < 1.0, "E = {youngs}");
        assert!((m.wave_speed - youngs.sqrt()).abs() <= 1e-12 * m.wave_speed);
        assert!((m.lame_lambda - (k - 2.0 * mu / 3.0)).abs() < 1e-9);
        assert_eq!(m.density, 1.0);
        assert_eq!(m.amplitude, 0.05);
        assert_eq!(m.shear_modulus, mu);
        assert!((m.period() - 2.0 / m.wave_speed).abs() < 1e-18);
        // Periodic in time with the stated period.
        let x0 = [0.3, 0.45, 0.8];
        let u0 = m.displacement(x0, 0.013);
        let u1 = m.displacement(x0, 0.013 + m.period());
        for i in 0..3 {
            assert!((u0[i] - u1[i]).abs() < 1e-14);
        }
    }
}
