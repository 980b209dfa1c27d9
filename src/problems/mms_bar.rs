//! The manufactured-solution bar with a neo-Hookean material (IMLS paper; SPEC §6.5).
//!
//! With `k = 2 pi / L`, `c = sqrt(E / rho_0)`, `E = mu (3 lambda + 2 mu) / (lambda + mu)`
//! and `omega = c pi / L`, the manufactured displacement and the fields it implies are
//!
//! ```text
//! u(X, t) = A sin(k X) sin(omega t)          v = A omega sin(k X) cos(omega t)
//! F       = 1 + A k cos(k X) sin(omega t)    sigma = P(F) = lambda ln(F)/F + mu (F - 1/F)
//! b(X, t) = d2u/dt2 - (1/rho_0) dP/dX
//!         = -omega^2 u + (1/rho_0) P'(F) A k^2 sin(k X) sin(omega t)
//! P'(F)   = lambda (1 - ln F) / F^2 + mu (1 + 1/F^2)
//! ```
//! (the printed body force of the paper is garbled; this one is derived from the momentum
//! balance `rho_0 d2u/dt2 = dP/dX + rho_0 b` in the reference configuration and tested
//! against it by finite differences). Both ends are fixed (`u(0) = u(L) = 0`); the bar
//! starts undeformed with `v(X, 0) = A omega sin(k X)`. Exact fields are functions of the
//! material position `X_p` (the particles' initial positions); the body force is given at
//! every particle ([`crate::physics::Body::PerParticle`]). Published set-up: `L = 1 m`,
//! `mu = 3.85e6 Pa`, `lambda = 5.77e6 Pa`, `rho_0 = 1000 kg/m^3`, `A = 0.1 m`,
//! `dt = 1e-5 s`, end 0.02 s, cells 8..128, 3 particles per cell.

use super::{Field, PlotAxis, Problem};
use crate::config::{display_float, require_positive, Scenario};
use crate::error::{Error, Result};
use crate::grid::Grid;
use crate::particles::Particles;
use crate::physics::{Boundary, Material, NeoHookean};
use std::f64::consts::PI;

/// Default amplitude `A` in m.
const DEFAULT_AMPLITUDE: f64 = 0.1;

/// The manufactured-solution bar.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MmsBar {
    pub length: f64,
    pub amplitude: f64,
    pub density: f64,
    pub law: NeoHookean,
}

impl MmsBar {
    /// From `problem.length` (default 1), `problem.amplitude` (default 0.1) and a
    /// neo-Hookean `[material]`.
    pub fn from_scenario(scenario: &Scenario) -> Result<Self> {
        let length = scenario.problem.length.unwrap_or(1.0);
        require_positive("problem.length", length)?;
        let amplitude = scenario.problem.amplitude.unwrap_or(DEFAULT_AMPLITUDE);
        if !amplitude.is_finite() {
            return Err(Error::invalid(
                "problem.amplitude",
                display_float(amplitude),
                "must be finite",
            ));
        }
        let law = match Material::from_config(&scenario.material) {
            Some(Material::NeoHookean(law)) => law,
            _ => {
                return Err(Error::invalid(
                    "material.model",
                    crate::config::toml_value(&scenario.material.model),
                    "the manufactured solution of problem.kind = \"mms_bar\" is for \
                     material.model = \"neo_hookean\"",
                ))
            }
        };
        Ok(Self {
            length,
            amplitude,
            density: scenario.material.density,
            law,
        })
    }

    /// `E = mu (3 lambda + 2 mu) / (lambda + mu)`.
    pub fn youngs_modulus(&self) -> f64 {
        let (mu, lambda) = (self.law.shear_modulus, self.law.lame_lambda);
        mu * (3.0 * lambda + 2.0 * mu) / (lambda + mu)
    }

    /// `omega = c pi / L` with `c = sqrt(E / rho_0)`.
    pub fn omega(&self) -> f64 {
        (self.youngs_modulus() / self.density).sqrt() * PI / self.length
    }

    fn wavenumber(&self) -> f64 {
        2.0 * PI / self.length
    }

    /// Deformation gradient `F(X, t)`.
    pub fn deformation_gradient(&self, x0: f64, t: f64) -> f64 {
        let k = self.wavenumber();
        1.0 + self.amplitude * k * (k * x0).cos() * (self.omega() * t).sin()
    }

    /// The manufactured body force `b(X, t)` (module doc).
    pub fn body_force(&self, x0: f64, t: f64) -> f64 {
        let (k, w) = (self.wavenumber(), self.omega());
        let s = (k * x0).sin() * (w * t).sin();
        let u = self.amplitude * s;
        let f = self.deformation_gradient(x0, t);
        -w * w * u + self.law.tangent(f) * self.amplitude * k * k * s / self.density
    }
}

impl Problem for MmsBar {
    fn name(&self) -> &'static str {
        "mms_bar"
    }

    fn length(&self) -> f64 {
        self.length
    }

    fn initial_particles(&self, grid: &Grid, per_cell: usize, density: f64) -> Particles {
        let mut particles = Particles::at_subcell_centres(grid, per_cell, density);
        for (v, &x0) in particles.v.iter_mut().zip(&particles.x0) {
            *v = self.initial_velocity(x0);
        }
        particles
    }

    fn boundary(&self) -> Boundary {
        Boundary::fixed_both()
    }

    /// The body force is not uniform: see [`Problem::body_acceleration_at`].
    fn body_acceleration(&self, _t: f64) -> f64 {
        0.0
    }

    fn body_varies_in_space(&self) -> bool {
        true
    }

    fn body_acceleration_at(&self, x0: f64, t: f64) -> f64 {
        self.body_force(x0, t)
    }

    fn exact_fields(&self) -> &'static [Field] {
        &Field::ALL
    }

    fn exact(&self, field: Field, x0: f64, t: f64) -> Option<f64> {
        let (k, w) = (self.wavenumber(), self.omega());
        let a = self.amplitude;
        match field {
            Field::Displacement => Some(a * (k * x0).sin() * (w * t).sin()),
            Field::Velocity => Some(a * w * (k * x0).sin() * (w * t).cos()),
            Field::Stress => Some(self.law.stress(self.deformation_gradient(x0, t))),
            _ => None,
        }
    }

    fn initial_velocity(&self, x0: f64) -> f64 {
        self.amplitude * self.omega() * (self.wavenumber() * x0).sin()
    }

    /// The quarter periods `t = j pi / (2 omega)`, `j = 0..3`: `v` peaks at even `j`, `u`
    /// and `F - 1` (so `sigma`) at odd `j` (with opposite signs, so both stretch and
    /// compression), up to `end`.
    fn solution_peak_times(&self, end: f64) -> Vec<f64> {
        let quarter = PI / (2.0 * self.omega());
        (0..4)
            .map(|j| j as f64 * quarter)
            .filter(|&t| t <= end)
            .collect()
    }

    fn plot_axis(&self) -> PlotAxis {
        PlotAxis::Initial
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bar() -> MmsBar {
        MmsBar {
            length: 1.0,
            amplitude: 0.1,
            density: 1000.0,
            law: NeoHookean {
                shear_modulus: 3.85e6,
                lame_lambda: 5.77e6,
            },
        }
    }

    /// Sixth-order central difference of `f` at `x` with step `h`.
    fn derivative(f: impl Fn(f64) -> f64, x: f64, h: f64) -> f64 {
        (45.0 * (f(x + h) - f(x - h)) - 9.0 * (f(x + 2.0 * h) - f(x - 2.0 * h))
            + (f(x + 3.0 * h) - f(x - 3.0 * h)))
            / (60.0 * h)
    }

    #[test]
    fn manufactured_fields_satisfy_the_momentum_balance() {
        // rho_0 dv/dt = dP/dX + rho_0 b, each term by finite differences of the exact
        // fields; the residual is at round-off relative to the largest term.
        let bar = bar();
        let period = 2.0 * PI / bar.omega();
        // Residuals relative to the largest term anywhere (at the nodes of sin(kX) every
        // term vanishes).
        let (mut worst, mut scale): (f64, f64) = (0.0, 0.0);
        for i in 1..20 {
            let x = i as f64 / 20.0;
            for j in 0..7 {
                let t = (0.013 + 0.137 * j as f64) * period;
                let v = |t: f64| bar.exact(Field::Velocity, x, t).unwrap_or(f64::NAN);
                let p = |x: f64| bar.exact(Field::Stress, x, t).unwrap_or(f64::NAN);
                let inertia = bar.density * derivative(v, t, 1e-3 * period);
                let force = derivative(p, x, 1e-3);
                let body = bar.density * bar.body_force(x, t);
                scale = scale.max(inertia.abs()).max(force.abs()).max(body.abs());
                worst = worst.max((inertia - force - body).abs());
            }
        }
        let worst = worst / scale;
        assert!(worst < 1e-9, "momentum residual {worst:e}");
        // And v = du/dt, F = 1 + du/dX.
        let (x, t) = (0.3, 0.2 * period);
        let u = |t: f64| bar.exact(Field::Displacement, x, t).unwrap_or(f64::NAN);
        let v = bar.exact(Field::Velocity, x, t).unwrap_or(f64::NAN);
        assert!((derivative(u, t, 1e-3 * period) - v).abs() < 1e-9 * v.abs());
        let ux = |x: f64| bar.exact(Field::Displacement, x, t).unwrap_or(f64::NAN);
        let f = bar.deformation_gradient(x, t);
        assert!((1.0 + derivative(ux, x, 1e-3) - f).abs() < 1e-11);
    }

    #[test]
    fn published_parameters() {
        let bar = bar();
        // E = 3.85e6 (3 * 5.77e6 + 7.7e6) / 9.62e6 ~ 1.0e7 Pa, c ~ 100 m/s.
        assert!((bar.youngs_modulus() - 1.0e7).abs() < 1e5);
        // The deformation gradient swings between 1 -/+ A k = 0.37 and 1.63.
        let k_a = 0.1 * 2.0 * PI;
        let quarter = PI / (2.0 * bar.omega());
        assert!((bar.deformation_gradient(0.0, quarter) - (1.0 + k_a)).abs() < 1e-12);
        assert!((bar.deformation_gradient(0.5, quarter) - (1.0 - k_a)).abs() < 1e-12);
    }
}
