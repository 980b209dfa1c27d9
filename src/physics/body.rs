//! Body forces of a step (SPEC §1.1: `f_ext = int rho b phi`): uniform in space (gravity,
//! the ramped column load), or a field `b(X, t)` given at every particle (the body force of
//! a manufactured solution, SPEC §6.5), which the mapping integrates like a momentum
//! density, `f_ext_i = int (rho b)_hat phi_i` (`sum_p m_p b_p phi_i` for particle
//! quadrature), so a reconstruction treats it with the same quadrature as the stresses.

/// The body acceleration of one step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Body<'a> {
    /// The same signed acceleration everywhere.
    Uniform(f64),
    /// One signed acceleration per particle, in particle storage order.
    PerParticle(&'a [f64]),
}

/// Where the time loop gets the body force of each step from.
///
/// A uniform source is evaluated at the end time of the step (as the ramped column load
/// always was); a field is evaluated at the start time `t_n` of the step, where the
/// stresses of the explicit step are, which keeps the Euler–Cromer step second order
/// against a velocity compared half a step back.
pub trait BodySource {
    /// `Some(b(t))` when the body force is uniform in space.
    fn uniform(&self, t: f64) -> Option<f64>;
    /// `b(X_p, t)` for the material positions `x0` (only called when `uniform` is `None`).
    fn at_particles(&self, x0: &[f64], t: f64, out: &mut [f64]) {
        for (b, _) in out.iter_mut().zip(x0) {
            *b = self.uniform(t).unwrap_or(0.0);
        }
    }
}

/// Any `Fn(t) -> b` is a uniform source.
impl<F: Fn(f64) -> f64> BodySource for F {
    fn uniform(&self, t: f64) -> Option<f64> {
        Some(self(t))
    }
}
