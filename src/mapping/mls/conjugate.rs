//! A particle acceleration conjugate to the MLS / IMLS momentum map (linear basis).
//!
//! With the linear basis the nodal velocity is a linear fit at the node,
//! `v_i = sum_p c_ip v_p` with `c_ip = w_p (l_0 + l_1 s_p)` (the fit functional,
//! `s_p = (x_p - x_i) / h`), and the momentum `p_i = m_i v_i`: a linear map `p = P v`,
//! `P_ip = m_i c_ip`. The particles are then accelerated with the hats,
//! `a_p = sum_i N_i(x_p) a_i`, which is not `P^T`: the grid's work
//! `sum_i a_i p_i` and the particles' `sum_p m_p v_p a_p` differ at first order in `dt`, by
//! `dt sum_i a_i (p_i - sum_p N_i(x_p) m_p v_p)`, and on long runs that feeds energy into
//! the particle velocities.
//!
//! Here the acceleration is the transpose, `a_p = (P'^T a)_p / m_p`, of a momentum map `P'`
//! corrected so that every particle's column carries its own mass and first moment:
//!
//! ```text
//! P'_ip = m_i c_ip + m_p N_i(x_p) (alpha_p + beta_p (x_i - x_p))
//! alpha_p = 1 - S0_p / m_p,   S0_p = sum_i m_i c_ip
//! beta_p  = -S1_p / (m_p q_p), S1_p = sum_i m_i c_ip (x_i - x_p),
//! q_p = (x_R - x_p) (x_p - x_L)  (the hat's second moment)
//! ```
//!
//! so `sum_i P'_ip = m_p` and `sum_i P'_ip x_i = m_p x_p`: the map conserves momentum, and
//! the acceleration is exact for a linear acceleration field. `S0_p`, `S1_p` differ from
//! `m_p`, 0 by what the fit does not conserve (small where the particles are smooth), so
//! `P'` stays close to the fit. A particle within `1e-9 h` of a node (`q_p` near 0) keeps
//! `beta_p = 0`. Then `sum_p m_p v_p a_p = sum_i a_i p'_i` exactly.

use super::{kernel, support, MlsMapping, Moments, RemedyCounts};
use crate::particles::{CellBins, Particles};
use rayon::prelude::*;

/// Particles per rayon task.
const PARTICLES_PER_TASK: usize = 1024;
/// Nodes per rayon task.
const NODES_PER_TASK: usize = 256;

impl MlsMapping {
    /// The nodal fit functionals `[l_0, l_1]` at the particles' positions and every
    /// particle's correction `[alpha_p, beta_p]`, from the lumped masses of the mass map
    /// just done.
    pub(super) fn prepare_conjugate(&mut self, particles: &Particles, bins: &CellBins) {
        let (kind, mesh) = (self.kind, self.grid);
        let x = &particles.x;
        self.node_functional.resize(mesh.cells + 1, [0.0; 2]);
        self.node_functional
            .par_iter_mut()
            .with_min_len(NODES_PER_TASK)
            .enumerate()
            .for_each(|(node, out)| {
                let xi = mesh.cell_left(node);
                let range = support(bins, node as isize - 2, node as isize + 1);
                let m = Moments::<1>::gather(xi, mesh.inv_h, range, x, |_| [0.0]);
                let unit = Moments::<2> {
                    mu: m.mu,
                    rhs: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
                };
                *out = unit.fit(kind, 1, &mut RemedyCounts::default());
            });
        let (functional, lumped) = (&self.node_functional, &self.lumped);
        let Particles { cell, mass, .. } = particles;
        self.correction.resize(x.len(), [0.0; 2]);
        self.correction
            .par_chunks_mut(PARTICLES_PER_TASK)
            .enumerate()
            .for_each(|(chunk, out)| {
                let start = chunk * PARTICLES_PER_TASK;
                for (k, out) in out.iter_mut().enumerate() {
                    let p = start + k;
                    let (mut s0, mut s1) = (0.0, 0.0);
                    for_each_fit_weight(&mesh, functional, cell[p], x[p], |node, xi, c| {
                        let weight = lumped[node] * c;
                        s0 += weight;
                        s1 += weight * (xi - x[p]);
                    });
                    let (left, right) = (mesh.cell_left(cell[p]), mesh.cell_left(cell[p] + 1));
                    let q = (right - x[p]) * (x[p] - left);
                    let alpha = 1.0 - s0 / mass[p];
                    let beta = if q > 1e-9 * mesh.h * mesh.h {
                        -s1 / (mass[p] * q)
                    } else {
                        0.0
                    };
                    *out = [alpha, beta];
                }
            });
    }

    /// `momentum[i] += sum_p m_p N_i(x_p) (alpha_p + beta_p (x_i - x_p)) v_p`: the
    /// correction part of `P' v`.
    pub(super) fn add_momentum_correction(
        &self,
        particles: &Particles,
        bins: &CellBins,
        momentum: &mut [f64],
    ) {
        let (mesh, correction) = (self.grid, &self.correction);
        let Particles { x, v, mass, .. } = particles;
        momentum
            .par_iter_mut()
            .with_min_len(NODES_PER_TASK)
            .enumerate()
            .for_each(|(node, out)| {
                let xi = mesh.cell_left(node);
                let mut sum = 0.0;
                for p in support(bins, node as isize - 1, node as isize) {
                    sum += mass[p] * correction_weight(x[p], xi, mesh.inv_h, correction[p]) * v[p];
                }
                *out += sum;
            });
    }

    /// `out[p] = (P'^T a)_p / m_p` for the grid accelerations `acceleration`.
    pub(super) fn conjugate_accelerations(
        &self,
        particles: &Particles,
        acceleration: &[f64],
        out: &mut Vec<f64>,
    ) {
        let (mesh, functional, lumped) = (self.grid, &self.node_functional, &self.lumped);
        let correction = &self.correction;
        let Particles { x, cell, mass, .. } = particles;
        out.resize(x.len(), 0.0);
        out.par_chunks_mut(PARTICLES_PER_TASK)
            .enumerate()
            .for_each(|(chunk, out)| {
                let start = chunk * PARTICLES_PER_TASK;
                for (k, out) in out.iter_mut().enumerate() {
                    let p = start + k;
                    let mut fitted = 0.0;
                    for_each_fit_weight(&mesh, functional, cell[p], x[p], |node, _, c| {
                        fitted += lumped[node] * c * acceleration[node];
                    });
                    // The weights the momentum correction gathers: an exact transpose.
                    let (e, xp) = (cell[p], x[p]);
                    let corrected =
                        correction_weight(xp, mesh.cell_left(e), mesh.inv_h, correction[p])
                            * acceleration[e]
                            + correction_weight(
                                xp,
                                mesh.cell_left(e + 1),
                                mesh.inv_h,
                                correction[p],
                            ) * acceleration[e + 1];
                    *out = fitted / mass[p] + corrected;
                }
            });
    }
}

/// `N_i(x_p) (alpha_p + beta_p (x_i - x_p))`: the weight (over `m_p`) of the particle at
/// `x` with correction `[alpha, beta]` on the node at `xi` in the corrected column of `P'`;
/// zero beyond the hat.
#[inline]
fn correction_weight(x: f64, xi: f64, inv_h: f64, [alpha, beta]: [f64; 2]) -> f64 {
    let hat = (1.0 - ((x - xi) * inv_h).abs()).max(0.0);
    hat * (alpha + beta * (xi - x))
}

/// `f(node, x_node, c_ip)` for every node whose fit kernel reaches `x` (`|x - x_i| < 1.5 h`:
/// nodes `cell - 1 ..= cell + 2`), with `c_ip = w (l_0 + l_1 s)` the particle's weight in
/// that node's fit functional `functional[node] = [l_0, l_1]`.
#[inline]
fn for_each_fit_weight(
    mesh: &crate::grid::Grid,
    functional: &[[f64; 2]],
    cell: usize,
    x: f64,
    mut f: impl FnMut(usize, f64, f64),
) {
    let first = cell.saturating_sub(1);
    let last = (cell + 2).min(mesh.cells);
    for (node, [l0, l1]) in functional.iter().enumerate().take(last + 1).skip(first) {
        let xi = mesh.cell_left(node);
        let s = (x - xi) * mesh.inv_h;
        let w = kernel(s);
        if w == 0.0 {
            continue;
        }
        f(node, xi, w * (l0 + l1 * s));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{Basis, Grid, LinearBasis};
    use crate::mapping::mls::MlsKind;
    use crate::mapping::{GridFields, Mapping};

    /// On an uneven layout (2–4 particles per cell, density `1 + x`): every column of the
    /// corrected map `P'` (the momentum of a unit velocity of one particle) sums to the
    /// particle's mass with first moment `m_p x_p`, the particle acceleration is `P'^T a /
    /// m_p` for any `a`, and exact for a linear `a`.
    #[test]
    fn corrected_columns_keep_mass_and_first_moment() {
        let grid = Grid::new(1.0, 8);
        let mut particles = Particles::default();
        let mut k = 0;
        for e in 0..8 {
            let n = 2 + (e * 5) % 3;
            for j in 0..n {
                let t = (j as f64 + 0.3 + 0.4 * ((k * 7) % 5) as f64 / 5.0) / n as f64;
                let x = grid.cell_left(e) + t * grid.h;
                particles.id.push(k);
                particles.x0.push(x);
                particles.x.push(x);
                particles.u.push(0.0);
                particles.v.push(0.0);
                particles.stress.push(0.0);
                particles.volume.push(grid.h / n as f64);
                particles.density.push(1.0 + x);
                particles.mass.push((1.0 + x) * grid.h / n as f64);
                particles.deformation_gradient.push(1.0);
                particles.cell.push(e);
                k += 1;
            }
        }
        let mut bins = CellBins::default();
        bins.sort(&mut particles, grid.cells);
        let basis = LinearBasis::new(grid);
        let mut mapping = MlsMapping::new(grid, 3, MlsKind::Imls)
            .unwrap()
            .with_conjugate_acceleration(true);
        let mut fields = GridFields::new(basis.num_dofs());
        mapping.map_mass_and_internal_force(&basis, &particles, &bins, &mut fields);
        let n = particles.x.len();
        // Columns of P' by unit velocities.
        for p in 0..n {
            let mut unit = particles.clone();
            unit.v.iter_mut().for_each(|v| *v = 0.0);
            unit.v[p] = 1.0;
            mapping.map_momentum(&basis, &unit, &bins, &mut fields);
            let column = fields.momentum.clone();
            let total: f64 = column.iter().sum();
            let moment: f64 = column
                .iter()
                .enumerate()
                .map(|(i, c)| c * grid.cell_left(i))
                .sum();
            let m = particles.mass[p];
            assert!((total - m).abs() < 1e-13, "{p}: {total} vs {m}");
            assert!((moment - m * particles.x[p]).abs() < 1e-13, "{p}: {moment}");
            // Transpose: a_p = column . a / m_p.
            let a: Vec<f64> = (0..basis.num_dofs()).map(|i| (i as f64).sin()).collect();
            let mut out = Vec::new();
            assert!(mapping.particle_accelerations(&basis, &particles, &a, &mut out));
            let expected: f64 = column.iter().zip(&a).map(|(c, a)| c * a).sum::<f64>() / m;
            assert!(
                (out[p] - expected).abs() < 1e-12,
                "{p}: {} vs {expected}",
                out[p]
            );
            // Linear accelerations are exact.
            let linear: Vec<f64> = (0..basis.num_dofs())
                .map(|i| 2.0 - 3.0 * grid.cell_left(i))
                .collect();
            mapping.particle_accelerations(&basis, &particles, &linear, &mut out);
            let exact = 2.0 - 3.0 * particles.x[p];
            assert!((out[p] - exact).abs() < 1e-12, "{p}: {} vs {exact}", out[p]);
        }
    }
}
