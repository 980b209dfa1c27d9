//! The per-cell least-squares fits of the 2D/3D TLS mapping (`docs/tls.md`): stress by full
//! least squares, density and vector densities (momentum, body force) conservative, so that
//! `int_box rho_hat = c_e` and `int_box (rho v)_hat = sum_p m_p v_p` in every cell;
//! degenerate cells drop Taylor terms (counted in [`RemedyCounts`]), negative density fits
//! are limited.

// Index loops: the indices enter the formulas (terms, axes).
#![allow(clippy::needless_range_loop)]

use super::bins::CellParticles;
use super::cells::{box_volume, limit_density};
use super::{stress_components, TensorTlsMapping, CELLS_PER_TASK, MAX_DEGREE};
use crate::error::Result;
use crate::mapping::RemedyCounts;
use crate::numerics::taylor_nd::{add_rhs, fit_degree, Factor, NormalMatrix, TaylorBox, MAX_TERMS};
use crate::particles::tensor::stress_index;
use crate::particles::TensorParticles;
use rayon::prelude::*;

impl<const D: usize> TensorTlsMapping<D> {
    /// Fit stress (full) and density (conservative) in every active cell; density limiter.
    /// With `body` (per-particle body forces `b_p`, totals in `cell_totals[e][1..]`), also
    /// the conservative fits of `rho_p b_p` into `self.vector`, from the same normal
    /// matrix.
    pub(super) fn fit_stress_and_density(
        &mut self,
        particles: &TensorParticles<D>,
        bins: &CellParticles,
        body: Option<&[Vec<f64>; D]>,
    ) {
        let components = stress_components::<D>();
        let ns = components.len();
        let (lo, hi, active, totals) = (&self.lo, &self.hi, &self.active, &self.cell_totals);
        let conservative_degree = self.conservative_degree;
        let rule = &self.rule;
        let counts: RemedyCounts = self
            .stress
            .par_chunks_mut(ns)
            .zip(self.density.par_iter_mut())
            .zip(self.vector.par_chunks_mut(D))
            .with_min_len(CELLS_PER_TASK)
            .enumerate()
            .map_init(
                || (Factor::default(), Factor::default()),
                |(full, conservative), (cell, ((stress, density), body_fits))| {
                    if !active[cell] {
                        stress.fill([0.0; MAX_TERMS]);
                        *density = [0.0; MAX_TERMS];
                        body_fits.fill([0.0; MAX_TERMS]);
                        return RemedyCounts::default();
                    }
                    let taylor = TaylorBox::new(lo[cell], hi[cell]);
                    let mut normal = NormalMatrix::<D>::default();
                    let mut stress_rhs = [[0.0; MAX_TERMS]; 6];
                    let mut density_rhs = [0.0; MAX_TERMS];
                    let mut body_rhs = [[0.0; MAX_TERMS]; D];
                    for &p in bins.of(cell) {
                        let t = taylor.terms(particles.position(p));
                        normal.add(&t);
                        for (rhs, &(a, c)) in stress_rhs.iter_mut().zip(&components) {
                            add_rhs::<D>(rhs, &t, particles.stress[stress_index(a, c)][p]);
                        }
                        add_rhs::<D>(&mut density_rhs, &t, particles.density(p));
                        if let Some(b) = body {
                            for a in 0..D {
                                add_rhs::<D>(&mut body_rhs[a], &t, particles.density(p) * b[a][p]);
                            }
                        }
                    }
                    let q_full = fit_degree(&normal, false, MAX_DEGREE, full);
                    let q_cons = fit_degree(&normal, true, conservative_degree, conservative);
                    for (a, rhs) in stress.iter_mut().zip(&stress_rhs) {
                        *a = full.solve(&normal, rhs, 0.0);
                    }
                    let volume = box_volume(&lo[cell], &hi[cell]);
                    let a1 = totals[cell][0] / volume;
                    *density = conservative.solve(&normal, &density_rhs, a1);
                    let density_limited_fits =
                        limit_density(&taylor, rule, (lo[cell], hi[cell]), density);
                    if body.is_some() {
                        for a in 0..D {
                            body_fits[a] = conservative.solve(
                                &normal,
                                &body_rhs[a],
                                totals[cell][1 + a] / volume,
                            );
                        }
                    }
                    let reduced = u64::from(q_full < MAX_DEGREE)
                        + u64::from(q_cons < conservative_degree)
                            * if body.is_some() { 2 } else { 1 };
                    RemedyCounts {
                        density_limited_fits,
                        ..RemedyCounts::order_reduced(reduced)
                    }
                },
            )
            .sum();
        self.remedies += counts;
    }

    /// Conservative fits of the `D` components of `values[a][p]` (densities
    /// `rho_p values_p`, totals `m_p values_p`) into `self.vector`.
    pub(super) fn fit_vector(
        &mut self,
        particles: &TensorParticles<D>,
        bins: &CellParticles,
        values: &[Vec<f64>; D],
    ) -> Result<()> {
        self.update_totals(particles, bins, |p| {
            let mut q = [0.0; 4];
            for a in 0..D {
                q[a] = particles.mass[p] * values[a][p];
            }
            q
        })?;
        let (lo, hi, active, totals) = (&self.lo, &self.hi, &self.active, &self.cell_totals);
        let conservative_degree = self.conservative_degree;
        let counts: RemedyCounts = self
            .vector
            .par_chunks_mut(D)
            .with_min_len(CELLS_PER_TASK)
            .enumerate()
            .map_init(Factor::default, |conservative, (cell, fits)| {
                if !active[cell] {
                    fits.fill([0.0; MAX_TERMS]);
                    return RemedyCounts::default();
                }
                let taylor = TaylorBox::new(lo[cell], hi[cell]);
                let mut normal = NormalMatrix::<D>::default();
                let mut rhs = [[0.0; MAX_TERMS]; D];
                for &p in bins.of(cell) {
                    let t = taylor.terms(particles.position(p));
                    normal.add(&t);
                    for a in 0..D {
                        add_rhs::<D>(&mut rhs[a], &t, particles.density(p) * values[a][p]);
                    }
                }
                let q = fit_degree(&normal, true, conservative_degree, conservative);
                let volume = box_volume(&lo[cell], &hi[cell]);
                for a in 0..D {
                    fits[a] = conservative.solve(&normal, &rhs[a], totals[cell][a] / volume);
                }
                RemedyCounts::order_reduced(u64::from(q < conservative_degree))
            })
            .sum();
        self.remedies += counts;
        Ok(())
    }
}
