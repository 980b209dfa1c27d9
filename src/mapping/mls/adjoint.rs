//! The particle strain conjugate to the MLS / IMLS internal force (`method.strain =
//! "adjoint"`).
//!
//! The internal force integrates the fitted stress at the Gauss points,
//! `f_i = sum_g dphi_i(x_g) sigma_hat(x_g) w_g` with `sigma_hat(x_g) = sum_p psi_p(x_g)
//! sigma_p` linear in the particle stresses (the fit functional of `mls.rs`). Its work on the grid
//! velocities is `sum_p sigma_p sum_g psi_p(x_g) w_g dv(x_g)`, so the strain rate that is
//! work-conjugate to `sigma_p` is
//!
//! ```text
//! deps_p = dt sum_g psi_p(x_g) w_g dv(x_g) / V~_p,    V~_p = sum_g psi_p(x_g) w_g,
//! ```
//!
//! the `psi_p`-weighted mean of the Gauss-point velocity gradients (`dv = sum_i dphi_i v_i`),
//! exact for a uniform gradient. With it the semi-discrete step is neutrally stable for a
//! frozen particle configuration: the eigenvalues of `d/dt (v_p, sigma_p)` are imaginary.
//! With the velocity gradient at the particle (the paper's eq. 37) the force and strain
//! operators are not adjoint and a mode grows (64 cells of the MMS bar: about 40 /s,
//! independent of `dt`). A particle whose fit volume `V~_p` is below
//! [`MIN_FIT_VOLUME`]` V_p` uses the basis gradient at the particle (counted as
//! `strain_fallbacks`).

use super::{kernel, MlsMapping};
use crate::grid::{Basis, Shape};
use crate::particles::Particles;
use rayon::prelude::*;

/// Smallest accepted `V~_p / V_p`.
pub const MIN_FIT_VOLUME: f64 = 0.1;
/// Particles per rayon task.
const PARTICLES_PER_TASK: usize = 1024;

impl MlsMapping {
    /// Fill `deps` with the adjoint strain increments of the particles (positions of the
    /// last [`crate::mapping::Mapping::map_mass_and_internal_force`]).
    pub(super) fn adjoint_strain_increments<B: Basis>(
        &mut self,
        basis: &B,
        particles: &Particles,
        velocity: &[f64],
        dt: f64,
        deps: &mut Vec<f64>,
    ) {
        let ng = self.points.rule.len;
        let cells = self.grid.cells;
        let (domains, points) = (&self.domains, &self.points);

        // `[x_g, w_g, w_g dv(x_g)]` at every Gauss point of the active cells (zero weight
        // elsewhere).
        self.gauss_gradient.clear();
        self.gauss_gradient.resize(cells * ng, [0.0; 3]);
        self.gauss_gradient
            .par_chunks_mut(ng)
            .enumerate()
            .for_each(|(cell, out)| {
                let mut g = 0;
                points.for_each_shape(basis, domains, cell, |xg, wg, shape| {
                    out[g] = [xg, wg, wg * shape.gradient(velocity)];
                    g += 1;
                });
            });

        // The psi-weighted mean over the Gauss points within the kernel support.
        let (functional, gauss) = (&self.functional, &self.gauss_gradient);
        let inv_h = self.grid.inv_h;
        let Particles {
            x, cell, volume, ..
        } = particles;
        deps.resize(x.len(), 0.0);
        let fallbacks: u64 = deps
            .par_chunks_mut(PARTICLES_PER_TASK)
            .enumerate()
            .map(|(chunk, deps)| {
                let start = chunk * PARTICLES_PER_TASK;
                let mut shape = Shape::default();
                let mut fallbacks = 0;
                for (k, deps) in deps.iter_mut().enumerate() {
                    let p = start + k;
                    let c = cell[p];
                    // `|x_p - x_g| < 1.5 h` reaches at most two cells either side.
                    let first = c.saturating_sub(2) * ng;
                    let last = (c + 3).min(cells) * ng;
                    let (mut work, mut fit_volume) = (0.0, 0.0);
                    for ([xg, wg, work_g], [l0, l1, l2]) in
                        gauss[first..last].iter().zip(&functional[first..last])
                    {
                        let s = (x[p] - xg) * inv_h;
                        let w = kernel(s);
                        if w != 0.0 && *wg != 0.0 {
                            let psi = w * (l0 + s * (l1 + s * l2));
                            work += psi * work_g;
                            fit_volume += psi * wg;
                        }
                    }
                    *deps = if fit_volume > MIN_FIT_VOLUME * volume[p] {
                        dt * work / fit_volume
                    } else {
                        fallbacks += 1;
                        basis.eval_particle(cell[p], x[p], 0.5 * volume[p], &mut shape);
                        dt * shape.gradient(velocity)
                    };
                }
                fallbacks
            })
            .sum();
        self.remedies.strain_fallbacks += fallbacks;
    }
}
