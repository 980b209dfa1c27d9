//! The particle strain and acceleration adjoint to the TLS internal force and momentum
//! (`method.strain = "adjoint"`, docs/reconstruction.md "Adjoint strain and acceleration").
//!
//! Every TLS fit is linear in its particle data: the stress coefficients of cell `c` are
//! `a_c = S_c(r_c)` with `r_c = sum_p w_pc psi_c(x_p) sigma_p` (`w_pc` the particle's fit
//! weight in `c`: 1 for the particles of `c`, or the share of its domain in `c` with
//! `method.fit_weights = "domains"`; plus, in a repaired cell,
//! virtual points `psi_c(x_f) a_n . psi_n(x_f)` from the fitted neighbour `n` at the shared
//! face `x_f`), and the momentum coefficients are `alpha_c = S_c(r_c, t_c / |e_c|)` with
//! `r_c = sum_p w_pc psi_c(x_p) rho_p v_p` and the conserved total `t_c = sum_p s_pc m_p v_p`
//! (`s_pc` the share of particle `p` in cell `c`). So the power of the internal force and
//! the work of the grid accelerations on the mapped momentum are
//!
//! ```text
//! sum_i v_i f_i = sum_c L_c . a_c,      L_c = sum_g w_g dv(x_g) psi_c(x_g)
//! sum_i a_i p_i = sum_c A_c . alpha_c,  A_c = sum_g w_g a(x_g) psi_c(x_g)
//! ```
//!
//! with `dv = sum_i dphi_i v_i` and `a = sum_i phi_i a_i` at the Gauss points `x_g` of the
//! step's quadrature. Pulling the loads `L_c`, `A_c` back through the fits (the transpose
//! of each small solve, applied by solving for unit right-hand sides with the same matrix
//! and the same remedy, so it is exact whatever the remedy) gives
//!
//! ```text
//! deps_p = dt (d/dsigma_p sum_i v_i f_i) / V~_p,   V~_p = d/dsigma_p int sigma_hat
//! a_p    = (d/dv_p sum_i a_i p_i) / m_p
//! ```
//!
//! For a frozen particle configuration the step `d/dt (v_p, sigma_p)` then conserves
//! `sum m_p v_p^2 / 2 + sum V~_p sigma_p^2 / (2E)`: its eigenvalues are imaginary for every
//! remedy, totals rule and particle count (the growing modes of the gradient strain with
//! virtual points or `cell_totals = "centres"` are gone). `V~_p` (the particle's weight in
//! the integral of the fitted stress) makes the strain exact for a uniform velocity
//! gradient; `m_p` is exact for a uniform acceleration because the momentum fit conserves
//! momentum. A particle with `V~_p` below [`MIN_FIT_VOLUME`]` V_p` (a fit that gives it
//! little, even negative, weight) is normalised by `V_p` instead (counted as
//! `strain_fallbacks`): any positive weight keeps the conjugacy, so the step stays neutral;
//! only that particle's strain under a uniform gradient is then not exact.
//!
//! Dividing by `m_p` and `V~_p` is a diagonal particle metric, exact for uniform fields
//! only (first order in `h` for others); `method.adjoint_mass = "consistent"` replaces it
//! by the consistent metric of [`super::particle_mass`], exact for linear fields.

use super::{
    add_shares, for_each_fit_cell, particle_mass, FieldFit, FitContext, FitState, TlsMapping,
    CELLS_PER_TASK,
};
use crate::config::{CellTotals, DegenerateRemedy};
use crate::grid::{Basis, Grid};
use crate::numerics::taylor::{
    solve_reduced_with_spread, solve_with_spread, FitKind, NormalMatrix, TaylorCell, MIN_SPREAD,
    REPAIR_MIN_SPREAD,
};
use crate::particles::Particles;
use rayon::prelude::*;

/// Smallest accepted `V~_p / V_p`.
pub const MIN_FIT_VOLUME: f64 = 0.1;
/// Particles per rayon task.
const PARTICLES_PER_TASK: usize = 1024;

/// Derivatives of a cell's load `L . a_c` with respect to the fit's inputs.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Pullback {
    /// `d (L . a_c) / d r_c`.
    rhs: [f64; 3],
    /// `d (L . a_c) / d a_1` (conservative fits; 0 for full fits).
    fixed_mean: f64,
}

/// Scratch of the adjoint passes: per cell, the loads and their pull-backs (strain: the
/// power and the volume load; acceleration: the work).
#[derive(Clone, Debug, Default)]
pub(super) struct AdjointScratch {
    /// Per cell: the power, the volume load and (with the consistent particle metric) the
    /// power of the velocity gradient field `dv(x) = x`.
    strain_loads: Vec<[[f64; 3]; 3]>,
    strain_pullbacks: Vec<[Pullback; 3]>,
    /// Per cell, the work of the grid accelerations and (with the consistent particle
    /// mass) of the field `a(x) = x`.
    momentum_loads: Vec<[[f64; 3]; 2]>,
    momentum_pullbacks: Vec<[Pullback; 2]>,
    /// Kinetic-energy limiter: per cell and load, `(1 - theta) A_c . rho_hat_c / rho_1`,
    /// the derivative of the blended part's work by the cell's mean momentum density.
    mean_velocity_loads: Vec<[f64; 2]>,
    /// Consistent particle mass: per particle, the pull-backs `P^T a` and `P^T x`, and per
    /// cell the Woodbury data ([`particle_mass`]).
    particle_force: Vec<f64>,
    particle_linear: Vec<f64>,
    /// The strain's particle weights `V~_p` (consistent metric only).
    particle_weight: Vec<f64>,
    corrections: Vec<Option<particle_mass::CellCorrection>>,
}

#[inline]
fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The derivative, through the conserved cell totals, of the loads' work by the quantity of
/// particle `p` (in cell `c`) whose amount is `q` (`V_p` for the stress, `m_p` for the
/// momentum): its shares in the cells its domain overlaps (all in `c` with
/// `cell_totals = "centres"`) times `per_total(cell)`, the work per unit of that cell's
/// total.
#[inline]
fn through_totals(
    by_domains: bool,
    mesh: &Grid,
    c: usize,
    x: f64,
    volume: f64,
    q: f64,
    per_total: impl Fn(usize) -> f64,
) -> f64 {
    let mut shares = [0.0; 3];
    if by_domains {
        add_shares(&mut shares, mesh, c, x, volume, q);
    } else {
        shares[1] = q;
    }
    let left = if c > 0 { per_total(c - 1) } else { 0.0 };
    let right = if c + 1 < mesh.cells {
        per_total(c + 1)
    } else {
        0.0
    };
    shares[0] * left + shares[1] * per_total(c) + shares[2] * right
}

/// `sum_e w_pe (d/dr_e) . psi_e(x_p)` for each of the `K` loads: the derivatives, through
/// the fits of the cells that particle `p` (in cell `c`, at `x`, of volume `volume`)
/// enters, of the loads' work by the particle's datum.
#[inline]
fn through_fits<const K: usize>(
    mesh: &Grid,
    domain_weights: bool,
    taylor: &[TaylorCell],
    pullbacks: &[[Pullback; K]],
    (c, x, volume): (usize, f64, f64),
) -> [f64; K] {
    let mut through = [0.0; K];
    for_each_fit_cell(mesh, domain_weights, c, x, volume, |e, w| {
        let psi = taylor[e].psi(x);
        for (through, pullback) in through.iter_mut().zip(&pullbacks[e]) {
            *through += w * dot(&pullback.rhs, &psi);
        }
    });
    through
}

/// How a cell's fit was solved: its normal matrix (with any virtual points), the Taylor
/// functions it starts from and whether order reduction was allowed.
struct Route {
    normal: NormalMatrix,
    terms: usize,
    reduced: bool,
    spread: f64,
}

impl FitContext<'_> {
    /// The route of `cell`'s fit of `field` (as in `plain_fit` / `FitContext::repair`);
    /// `None` for an inactive cell.
    fn route(&self, field: &FieldFit, cell: usize, conservative: bool) -> Option<Route> {
        let mut route = Route {
            normal: self.sums[cell].normal,
            terms: self.terms(kind(conservative, 0.0)),
            reduced: false,
            spread: MIN_SPREAD,
        };
        match field.state[cell] {
            FitState::Inactive => return None,
            FitState::Fitted => {}
            FitState::Repaired => {
                route.reduced = true;
                route.spread = REPAIR_MIN_SPREAD;
                if self.remedy == DegenerateRemedy::VirtualPoints {
                    for (_, face) in self.virtual_points(field, cell).into_iter().flatten() {
                        route.normal.add(&self.taylor[cell].psi(face));
                    }
                    // The well-posedness test depends on the matrix only.
                    route.reduced = solve_with_spread(
                        &route.normal,
                        &[0.0; 3],
                        kind(conservative, 0.0),
                        route.terms,
                        route.spread,
                    )
                    .is_none();
                }
            }
        }
        Some(route)
    }
}

#[inline]
fn kind(conservative: bool, mean: f64) -> FitKind {
    if conservative {
        FitKind::Conservative(mean)
    } else {
        FitKind::Full
    }
}

impl Route {
    /// The fit of this route for right-hand side `rhs` and fixed mean `mean`.
    fn fit(&self, rhs: &[f64; 3], mean: f64, conservative: bool) -> [f64; 3] {
        let kind = kind(conservative, mean);
        if self.reduced {
            solve_reduced_with_spread(&self.normal, rhs, kind, self.terms, self.spread).0
        } else {
            solve_with_spread(&self.normal, rhs, kind, self.terms, self.spread).unwrap_or([0.0; 3])
        }
    }

    /// `load . S(rhs, mean)` differentiated by `rhs` and `mean`, for each of `K` loads:
    /// the fit is linear, so the derivatives are the load against the fits of unit inputs
    /// (solved once for all loads).
    fn pull_back<const K: usize>(
        &self,
        loads: &[[f64; 3]; K],
        conservative: bool,
    ) -> [Pullback; K] {
        let unit_fits = [0, 1, 2].map(|j| {
            let mut e = [0.0; 3];
            e[j] = 1.0;
            self.fit(&e, 0.0, conservative)
        });
        let mean_fit = conservative.then(|| self.fit(&[0.0; 3], 1.0, conservative));
        loads.map(|load| Pullback {
            rhs: unit_fits.map(|fit| dot(&load, &fit)),
            fixed_mean: mean_fit.map_or(0.0, |fit| dot(&load, &fit)),
        })
    }
}

/// Pull the per-cell loads back through the fits of `field`: the repaired cells first (in
/// parallel), whose virtual points add loads to their fitted neighbours (in cell order),
/// then the fitted cells (in parallel). `loads` is consumed.
fn pull_back_field<const K: usize>(
    context: &FitContext,
    field: &FieldFit,
    conservative: bool,
    loads: &mut [[[f64; 3]; K]],
    out: &mut Vec<[Pullback; K]>,
) {
    out.clear();
    out.resize(loads.len(), [Pullback::default(); K]);
    let pass = |out: &mut [[Pullback; K]], loads: &[[[f64; 3]; K]], state: FitState| {
        out.par_iter_mut()
            .with_min_len(CELLS_PER_TASK)
            .enumerate()
            .filter(|(cell, _)| field.state[*cell] == state)
            .for_each(|(cell, pullback)| {
                if let Some(route) = context.route(field, cell, conservative) {
                    *pullback = route.pull_back(&loads[cell], conservative);
                }
            });
    };
    pass(out, loads, FitState::Repaired);
    let repaired = field
        .state
        .iter()
        .enumerate()
        .filter(|(_, &s)| s == FitState::Repaired)
        .map(|(cell, _)| cell);
    let with_virtual_points = context.remedy == DegenerateRemedy::VirtualPoints;
    for cell in repaired.filter(|_| with_virtual_points) {
        for (neighbour, face) in context.virtual_points(field, cell).into_iter().flatten() {
            // A virtual point adds `psi_c(x_f) (a_n . psi_n(x_f))` to the right-hand side.
            let (psi_cell, psi) = (
                context.taylor[cell].psi(face),
                context.taylor[neighbour].psi(face),
            );
            for (load, pullback) in loads[neighbour].iter_mut().zip(&out[cell]) {
                let weight = dot(&pullback.rhs, &psi_cell);
                for (load, psi) in load.iter_mut().zip(psi) {
                    *load += weight * psi;
                }
            }
        }
    }
    pass(out, loads, FitState::Fitted);
}

impl TlsMapping {
    fn context(&self) -> FitContext<'_> {
        FitContext {
            grid: &self.grid,
            remedy: self.remedy,
            taylor: &self.taylor,
            sums: &self.sums,
            conservative_terms: self.conservative_terms,
        }
    }

    /// Fill `deps` with the adjoint strain increments (positions of the last
    /// [`crate::mapping::Mapping::map_mass_and_internal_force`]).
    pub(super) fn adjoint_strain_increments<B: Basis>(
        &mut self,
        basis: &B,
        particles: &Particles,
        velocity: &[f64],
        dt: f64,
        deps: &mut Vec<f64>,
    ) {
        let mut scratch = self.adjoint.take().unwrap_or_default();
        let cells = self.grid.cells;
        let (taylor, points, domains) = (&self.taylor, &self.points, &self.domains);
        let consistent = self.consistent_particle_mass;
        scratch.strain_loads.clear();
        scratch.strain_loads.resize(cells, [[0.0; 3]; 3]);
        scratch
            .strain_loads
            .par_iter_mut()
            .with_min_len(CELLS_PER_TASK)
            .enumerate()
            .for_each(|(cell, [load, volume_load, linear_load])| {
                if !consistent {
                    points.for_each_shape(basis, domains, cell, |x, w, shape| {
                        let psi = taylor[cell].psi(x);
                        let power = w * shape.gradient(velocity);
                        for j in 0..3 {
                            load[j] += power * psi[j];
                            volume_load[j] += w * psi[j];
                        }
                    });
                    return;
                }
                points.for_each_shape(basis, domains, cell, |x, w, shape| {
                    let psi = taylor[cell].psi(x);
                    let power = w * shape.gradient(velocity);
                    for j in 0..3 {
                        load[j] += power * psi[j];
                        volume_load[j] += w * psi[j];
                        linear_load[j] += w * x * psi[j];
                    }
                });
            });
        let conservative = self.conservative_stress;
        let context = self.context().for_stress();
        pull_back_field(
            &context,
            &self.stress,
            conservative,
            &mut scratch.strain_loads,
            &mut scratch.strain_pullbacks,
        );
        let pullbacks = &scratch.strain_pullbacks;
        // A conservative stress fit: `d a_1 / d t_c = 1 / |e_c|` with the total
        // `t_c = sum_p s_pc V_p sigma_p`, for the power and the volume load.
        let per_total = |c: usize, load: usize| {
            if conservative && domains.is_active(c) {
                pullbacks[c][load].fixed_mean / domains.length(c)
            } else {
                0.0
            }
        };
        let by_domains = self.totals == CellTotals::Domains;
        let domain_weights = self.domain_weights;
        let mesh = &self.grid;
        let Particles {
            x, cell, volume, ..
        } = particles;
        // With the consistent metric, per particle: `d/dsigma_p` of the power, the fit
        // volume `V~_p` (or `V_p` where it is too small: a fallback) and `d/dsigma_p` of the
        // power of `dv(x) = x`.
        let pull_back_particle = |p: usize| {
            let c = cell[p];
            let through_fits = through_fits(
                mesh,
                domain_weights,
                taylor,
                pullbacks,
                (c, x[p], volume[p]),
            );
            let mut pulled = [0.0; 3];
            for load in 0..3 {
                let through_totals = if conservative {
                    through_totals(by_domains, mesh, c, x[p], volume[p], volume[p], |e| {
                        per_total(e, load)
                    })
                } else {
                    0.0
                };
                pulled[load] = through_fits[load] + through_totals;
            }
            // NaN falls back too.
            let fitted_enough = pulled[1] > MIN_FIT_VOLUME * volume[p];
            let fallback = !fitted_enough;
            if fallback {
                pulled[1] = volume[p];
            }
            (pulled, fallback)
        };
        deps.resize(x.len(), 0.0);
        if !consistent {
            let fallbacks: u64 = deps
                .par_chunks_mut(PARTICLES_PER_TASK)
                .enumerate()
                .map(|(chunk, deps)| {
                    let start = chunk * PARTICLES_PER_TASK;
                    let mut fallbacks = 0;
                    for (k, deps) in deps.iter_mut().enumerate() {
                        let p = start + k;
                        let c = cell[p];
                        // Through the fits: `sum_e w_pe (d/dr_e) . psi_e(x_p)` over the cells
                        // whose fits the particle enters.
                        let (mut through_work, mut through_volume) = (0.0, 0.0);
                        for_each_fit_cell(mesh, domain_weights, c, x[p], volume[p], |e, w| {
                            let psi = taylor[e].psi(x[p]);
                            let [work, fit_volume, _] = &pullbacks[e];
                            through_work += w * dot(&work.rhs, &psi);
                            through_volume += w * dot(&fit_volume.rhs, &psi);
                        });
                        let [through_totals, volume_through_totals] = if conservative {
                            [0, 1].map(|load| {
                                through_totals(
                                    by_domains,
                                    mesh,
                                    c,
                                    x[p],
                                    volume[p],
                                    volume[p],
                                    |e| per_total(e, load),
                                )
                            })
                        } else {
                            [0.0; 2]
                        };
                        let fitted = through_volume + volume_through_totals;
                        // NaN falls back too.
                        let weight = if fitted > MIN_FIT_VOLUME * volume[p] {
                            fitted
                        } else {
                            fallbacks += 1;
                            volume[p]
                        };
                        *deps = dt * (through_work + through_totals) / weight;
                    }
                    fallbacks
                })
                .sum();
            self.remedies.strain_fallbacks += fallbacks;
            self.adjoint = Some(scratch);
            return;
        }
        let work = &mut scratch.particle_force;
        let (weight, linear) = (&mut scratch.particle_weight, &mut scratch.particle_linear);
        for field in [&mut *work, &mut *weight, &mut *linear] {
            field.resize(x.len(), 0.0);
        }
        let fallbacks: u64 = work
            .par_chunks_mut(PARTICLES_PER_TASK)
            .zip(weight.par_chunks_mut(PARTICLES_PER_TASK))
            .zip(linear.par_chunks_mut(PARTICLES_PER_TASK))
            .enumerate()
            .map(|(chunk, ((work, weight), linear))| {
                let start = chunk * PARTICLES_PER_TASK;
                let mut fallbacks = 0;
                for k in 0..work.len() {
                    let ([w, v, l], fallback) = pull_back_particle(start + k);
                    fallbacks += u64::from(fallback);
                    (work[k], weight[k], linear[k]) = (w, v, l);
                }
                fallbacks
            })
            .sum();
        self.remedies.limited_consistent_cells += particle_mass::consistent_accelerations(
            cells,
            cell,
            x,
            &scratch.particle_weight,
            &scratch.particle_force,
            &scratch.particle_linear,
            &mut scratch.corrections,
            deps,
        );
        deps.par_iter_mut().for_each(|deps| *deps *= dt);
        self.remedies.strain_fallbacks += fallbacks;
        self.adjoint = Some(scratch);
    }

    /// Fill `out` with the adjoint particle accelerations (positions and momentum fit of
    /// the last [`crate::mapping::Mapping::map_momentum`]).
    pub(super) fn adjoint_accelerations<B: Basis>(
        &mut self,
        basis: &B,
        particles: &Particles,
        acceleration: &[f64],
        out: &mut Vec<f64>,
    ) {
        let mut scratch = self.adjoint.take().unwrap_or_default();
        let cells = self.grid.cells;
        let (taylor, points, domains) = (&self.taylor, &self.points, &self.domains);
        let consistent = self.consistent_particle_mass;
        scratch.momentum_loads.clear();
        scratch.momentum_loads.resize(cells, [[0.0; 3]; 2]);
        scratch
            .momentum_loads
            .par_iter_mut()
            .with_min_len(CELLS_PER_TASK)
            .enumerate()
            .for_each(|(cell, [load, linear_load])| {
                if !consistent {
                    points.for_each_shape(basis, domains, cell, |x, w, shape| {
                        let psi = taylor[cell].psi(x);
                        let work = w * shape.interpolate(acceleration);
                        for j in 0..3 {
                            load[j] += work * psi[j];
                        }
                    });
                    return;
                }
                points.for_each_shape(basis, domains, cell, |x, w, shape| {
                    let psi = taylor[cell].psi(x);
                    let work = w * shape.interpolate(acceleration);
                    for j in 0..3 {
                        load[j] += work * psi[j];
                        linear_load[j] += w * x * psi[j];
                    }
                });
            });
        // With the kinetic-energy limiter the cell's coefficients are
        // `theta alpha_c + (1 - theta) (a_1 / rho_1) rho_hat_c`: the fit's part takes the
        // load scaled by `theta`, the blended part depends on the mean `a_1` only.
        scratch.mean_velocity_loads.clear();
        scratch.mean_velocity_loads.resize(cells, [0.0; 2]);
        if let Some(theta) = &self.momentum_theta {
            let density = &self.density.coefficients;
            scratch
                .momentum_loads
                .par_iter_mut()
                .zip(scratch.mean_velocity_loads.par_iter_mut())
                .with_min_len(CELLS_PER_TASK)
                .enumerate()
                .filter(|(cell, _)| theta[*cell] < 1.0)
                .for_each(|(cell, (loads, mean_loads))| {
                    for (load, mean_load) in loads.iter_mut().zip(mean_loads) {
                        // A cell without mass has no momentum: no blended part.
                        if density[cell][0] > 0.0 {
                            *mean_load =
                                (1.0 - theta[cell]) * dot(load, &density[cell]) / density[cell][0];
                        }
                        for l in load.iter_mut() {
                            *l *= theta[cell];
                        }
                    }
                });
        }
        pull_back_field(
            &self.context(),
            &self.momentum,
            true,
            &mut scratch.momentum_loads,
            &mut scratch.momentum_pullbacks,
        );
        // `d a_1 / d t_c = 1 / |e_c|`.
        let (pullbacks, mean_loads) = (&scratch.momentum_pullbacks, &scratch.mean_velocity_loads);
        let per_total = |c: usize, load: usize| {
            if domains.is_active(c) {
                (pullbacks[c][load].fixed_mean + mean_loads[c][load]) / domains.length(c)
            } else {
                0.0
            }
        };
        let by_domains = self.totals == CellTotals::Domains;
        let domain_weights = self.domain_weights;
        let mesh = &self.grid;
        let Particles {
            x,
            cell,
            volume,
            mass,
            density,
            ..
        } = particles;
        // With the consistent metric, `d/dv_p` of the work of both loads: through the fits
        // and the conserved totals.
        let pull_back_particle = |p: usize| {
            let c = cell[p];
            let through_fits = through_fits(
                mesh,
                domain_weights,
                taylor,
                pullbacks,
                (c, x[p], volume[p]),
            );
            let mut pulled = [0.0; 2];
            for load in 0..2 {
                let through_totals =
                    through_totals(by_domains, mesh, c, x[p], volume[p], mass[p], |e| {
                        per_total(e, load)
                    });
                pulled[load] = through_fits[load] * density[p] + through_totals;
            }
            pulled
        };
        out.resize(x.len(), 0.0);
        if !consistent {
            out.par_chunks_mut(PARTICLES_PER_TASK)
                .enumerate()
                .for_each(|(chunk, out)| {
                    let start = chunk * PARTICLES_PER_TASK;
                    for (k, a) in out.iter_mut().enumerate() {
                        let p = start + k;
                        let c = cell[p];
                        let through_totals =
                            through_totals(by_domains, mesh, c, x[p], volume[p], mass[p], |e| {
                                per_total(e, 0)
                            });
                        let mut through_fit = 0.0;
                        for_each_fit_cell(mesh, domain_weights, c, x[p], volume[p], |e, w| {
                            through_fit += w * dot(&pullbacks[e][0].rhs, &taylor[e].psi(x[p]));
                        });
                        let through_fit = through_fit * density[p];
                        *a = (through_fit + through_totals) / mass[p];
                    }
                });
            self.adjoint = Some(scratch);
            return;
        }
        let (force, linear) = (&mut scratch.particle_force, &mut scratch.particle_linear);
        force.resize(x.len(), 0.0);
        linear.resize(x.len(), 0.0);
        force
            .par_chunks_mut(PARTICLES_PER_TASK)
            .zip(linear.par_chunks_mut(PARTICLES_PER_TASK))
            .enumerate()
            .for_each(|(chunk, (force, linear))| {
                let start = chunk * PARTICLES_PER_TASK;
                for (k, (f, l)) in force.iter_mut().zip(linear.iter_mut()).enumerate() {
                    [*f, *l] = pull_back_particle(start + k);
                }
            });
        self.remedies.limited_consistent_cells += particle_mass::consistent_accelerations(
            cells,
            cell,
            x,
            mass,
            &scratch.particle_force,
            &scratch.particle_linear,
            &mut scratch.corrections,
            out,
        );
        self.adjoint = Some(scratch);
    }
}
