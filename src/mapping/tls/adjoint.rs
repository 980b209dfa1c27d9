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
    add_shares, for_each_fit_cell, particle_mass, quadratic_mass, FieldFit, FitContext, FitState,
    TlsMapping, CELLS_PER_TASK,
};
use crate::config::{AdjointMass, CellTotals, DegenerateRemedy};
use crate::grid::{Basis, Grid};
use crate::numerics::taylor::{
    solve_reduced_with_spread, solve_with_spread, FitKind, NormalMatrix, TaylorCell,
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
    /// power of the velocity gradient fields `dv(x) = x` and (quadratic metric) `x^2`.
    strain_loads: Vec<[[f64; 3]; 4]>,
    strain_pullbacks: Vec<[Pullback; 4]>,
    /// Per cell, the work of the grid accelerations and (with the consistent particle
    /// mass) of the fields `a(x) = x` and (quadratic metric) `x^2`.
    momentum_loads: Vec<[[f64; 3]; 3]>,
    momentum_pullbacks: Vec<[Pullback; 3]>,
    /// Kinetic-energy limiter: per cell and load, `(1 - theta) A_c . rho_hat_c / rho_1`,
    /// the derivative of the blended part's work by the cell's mean momentum density.
    mean_velocity_loads: Vec<[f64; 3]>,
    /// Consistent particle mass: per particle, the pull-backs `P^T a` and `P^T x`, and per
    /// cell the Woodbury data ([`particle_mass`]).
    particle_force: Vec<f64>,
    particle_linear: Vec<f64>,
    /// The pull-backs of `x^2` (quadratic metric only).
    particle_quadratic: Vec<f64>,
    /// The strain's particle weights `V~_p` (consistent metric only).
    particle_weight: Vec<f64>,
    corrections: Vec<Option<particle_mass::CellCorrection>>,
    quadratic_corrections: Vec<Option<quadratic_mass::QuadraticCorrection>>,
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

/// What the pull-back of one particle reads besides the cells' pull-backs: the grid, the
/// cells' Taylor bases and the rules for the fit weights and the conserved totals.
#[derive(Clone, Copy)]
struct ParticleRoutes<'a> {
    mesh: &'a Grid,
    taylor: &'a [TaylorCell],
    domain_weights: bool,
    by_domains: bool,
}

impl ParticleRoutes<'_> {
    /// The derivatives of the work of the first `K` of the cells' `L` loads by the datum of
    /// particle `p` (in cell `c`, at `x`, of volume `volume`):
    ///
    /// ```text
    /// scale sum_e w_pe (d/dr_e) . psi_e(x_p)  +  sum_e s_pe q_p (d/dt_e)
    /// ```
    ///
    /// through the fits of the cells the particle enters (`scale`: its density for the
    /// momentum, 1 for the stress) and, with `totals = Some((q_p, per_total))`, through the
    /// conserved totals of the cells its amount `q_p` is shared among (`per_total(e, load)`:
    /// the load's work per unit of cell `e`'s total; see [`through_totals`]).
    #[inline]
    fn pull_back<const L: usize, const K: usize>(
        &self,
        pullbacks: &[[Pullback; L]],
        (c, x, volume): (usize, f64, f64),
        scale: f64,
        totals: Option<(f64, &impl Fn(usize, usize) -> f64)>,
    ) -> [f64; K] {
        debug_assert!(K <= L, "{K} loads pulled back of {L}");
        let mut through_fits = [0.0; K];
        for_each_fit_cell(self.mesh, self.domain_weights, c, x, volume, |e, w| {
            let psi = self.taylor[e].psi(x);
            for (through, pullback) in through_fits.iter_mut().zip(&pullbacks[e]) {
                *through += w * dot(&pullback.rhs, &psi);
            }
        });
        let mut pulled = [0.0; K];
        for (load, pulled) in pulled.iter_mut().enumerate() {
            let through_totals = match totals {
                Some((q, per_total)) => {
                    through_totals(self.by_domains, self.mesh, c, x, volume, q, |e| {
                        per_total(e, load)
                    })
                }
                None => 0.0,
            };
            *pulled = through_fits[load] * scale + through_totals;
        }
        pulled
    }
}

/// The strain pull-backs of one particle (the power, the fit volume `V~_p`, ...) with
/// `V~_p` replaced by the particle volume `V_p` where it is at most [`MIN_FIT_VOLUME`]` V_p`
/// or NaN; and whether it was (a fallback).
#[inline]
fn with_fit_volume<const K: usize>(mut pulled: [f64; K], volume: f64) -> ([f64; K], bool) {
    // NaN falls back too.
    let fitted_enough = pulled[1] > MIN_FIT_VOLUME * volume;
    let fallback = !fitted_enough;
    if fallback {
        pulled[1] = volume;
    }
    (pulled, fallback)
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
        let state = field.state[cell];
        let mut route = Route {
            normal: self.sums[cell].normal,
            terms: self.terms(kind(conservative, 0.0)),
            reduced: false,
            spread: state.min_spread(),
        };
        match state {
            FitState::Inactive => return None,
            FitState::Fitted => {}
            FitState::Repaired => {
                route.reduced = true;
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
    fn particle_routes(&self) -> ParticleRoutes<'_> {
        ParticleRoutes {
            mesh: &self.grid,
            taylor: &self.taylor,
            domain_weights: self.domain_weights,
            by_domains: self.totals == CellTotals::Domains,
        }
    }

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
        let consistent = self.particle_metric != AdjointMass::Lumped;
        let quadratic = self.particle_metric == AdjointMass::Quadratic;
        scratch.strain_loads.clear();
        scratch.strain_loads.resize(cells, [[0.0; 3]; 4]);
        scratch
            .strain_loads
            .par_iter_mut()
            .with_min_len(CELLS_PER_TASK)
            .enumerate()
            .for_each(|(cell, [load, volume_load, linear_load, quadratic_load])| {
                points.for_each_shape(basis, domains, cell, |x, w, shape| {
                    let psi = taylor[cell].psi(x);
                    let power = w * shape.gradient(velocity);
                    for j in 0..3 {
                        load[j] += power * psi[j];
                        volume_load[j] += w * psi[j];
                    }
                    if consistent {
                        for j in 0..3 {
                            linear_load[j] += w * x * psi[j];
                        }
                    }
                    if quadratic {
                        for j in 0..3 {
                            quadratic_load[j] += w * x * x * psi[j];
                        }
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
        let routes = self.particle_routes();
        let Particles {
            x, cell, volume, ..
        } = particles;
        // Per particle: `d/dsigma_p` of the power, the fit volume `V~_p` (or `V_p` where it is
        // too small: a fallback) and, with the consistent metric, `d/dsigma_p` of the power
        // of `dv(x) = x`.
        let totals = |p: usize| conservative.then_some((volume[p], &per_total));
        let route = |p: usize| (cell[p], x[p], volume[p]);
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
                        let pulled = routes.pull_back(pullbacks, route(p), 1.0, totals(p));
                        let ([work, weight], fallback) = with_fit_volume(pulled, volume[p]);
                        fallbacks += u64::from(fallback);
                        *deps = dt * work / weight;
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
        let squares = &mut scratch.particle_quadratic;
        for field in [&mut *work, &mut *weight, &mut *linear, &mut *squares] {
            field.resize(x.len(), 0.0);
        }
        let fallbacks: u64 = work
            .par_chunks_mut(PARTICLES_PER_TASK)
            .zip(weight.par_chunks_mut(PARTICLES_PER_TASK))
            .zip(linear.par_chunks_mut(PARTICLES_PER_TASK))
            .zip(squares.par_chunks_mut(PARTICLES_PER_TASK))
            .enumerate()
            .map(|(chunk, (((work, weight), linear), squares))| {
                let start = chunk * PARTICLES_PER_TASK;
                let mut fallbacks = 0;
                for k in 0..work.len() {
                    let p = start + k;
                    let pulled = routes.pull_back(pullbacks, route(p), 1.0, totals(p));
                    let ([w, v, l, q], fallback) = with_fit_volume(pulled, volume[p]);
                    fallbacks += u64::from(fallback);
                    (work[k], weight[k], linear[k], squares[k]) = (w, v, l, q);
                }
                fallbacks
            })
            .sum();
        self.remedies.limited_consistent_cells +=
            self.particle_metric_solve(&mut scratch, cells, cell, x, Metric::FitVolume, deps);
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
        let consistent = self.particle_metric != AdjointMass::Lumped;
        let quadratic = self.particle_metric == AdjointMass::Quadratic;
        scratch.momentum_loads.clear();
        scratch.momentum_loads.resize(cells, [[0.0; 3]; 3]);
        scratch
            .momentum_loads
            .par_iter_mut()
            .with_min_len(CELLS_PER_TASK)
            .enumerate()
            .for_each(|(cell, [load, linear_load, quadratic_load])| {
                points.for_each_shape(basis, domains, cell, |x, w, shape| {
                    let psi = taylor[cell].psi(x);
                    let work = w * shape.interpolate(acceleration);
                    for j in 0..3 {
                        load[j] += work * psi[j];
                    }
                    if consistent {
                        for j in 0..3 {
                            linear_load[j] += w * x * psi[j];
                        }
                    }
                    if quadratic {
                        for j in 0..3 {
                            quadratic_load[j] += w * x * x * psi[j];
                        }
                    }
                });
            });
        // With the kinetic-energy limiter the cell's coefficients are
        // `theta alpha_c + (1 - theta) (a_1 / rho_1) rho_hat_c`: the fit's part takes the
        // load scaled by `theta`, the blended part depends on the mean `a_1` only.
        scratch.mean_velocity_loads.clear();
        scratch.mean_velocity_loads.resize(cells, [0.0; 3]);
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
        let routes = self.particle_routes();
        let Particles {
            x,
            cell,
            volume,
            mass,
            density,
            ..
        } = particles;
        // `d/dv_p` of the work (and, with the consistent metric, of the work of `a(x) = x`):
        // through the fits and the conserved totals.
        let totals = |p: usize| Some((mass[p], &per_total));
        let route = |p: usize| (cell[p], x[p], volume[p]);
        out.resize(x.len(), 0.0);
        if !consistent {
            out.par_chunks_mut(PARTICLES_PER_TASK)
                .enumerate()
                .for_each(|(chunk, out)| {
                    let start = chunk * PARTICLES_PER_TASK;
                    for (k, a) in out.iter_mut().enumerate() {
                        let p = start + k;
                        let [work] = routes.pull_back(pullbacks, route(p), density[p], totals(p));
                        *a = work / mass[p];
                    }
                });
            self.adjoint = Some(scratch);
            return;
        }
        let (force, linear) = (&mut scratch.particle_force, &mut scratch.particle_linear);
        let squares = &mut scratch.particle_quadratic;
        for field in [&mut *force, &mut *linear, &mut *squares] {
            field.resize(x.len(), 0.0);
        }
        force
            .par_chunks_mut(PARTICLES_PER_TASK)
            .zip(linear.par_chunks_mut(PARTICLES_PER_TASK))
            .zip(squares.par_chunks_mut(PARTICLES_PER_TASK))
            .enumerate()
            .for_each(|(chunk, ((force, linear), squares))| {
                let start = chunk * PARTICLES_PER_TASK;
                for k in 0..force.len() {
                    let p = start + k;
                    [force[k], linear[k], squares[k]] =
                        routes.pull_back(pullbacks, route(p), density[p], totals(p));
                }
            });
        self.remedies.limited_consistent_cells +=
            self.particle_metric_solve(&mut scratch, cells, cell, x, Metric::Mass(mass), out);
        self.adjoint = Some(scratch);
    }

    /// `out = W^{-1} f` with the consistent particle metric (linear, [`particle_mass`], or
    /// quadratic, [`quadratic_mass`]) from the pull-backs in `scratch` (`f`: the work or
    /// the power; `P^T x`, `P^T x^2`); the metric's diagonal is the particle masses or the
    /// fit volumes `V~_p` in `scratch`. Returns the number of limited cells.
    fn particle_metric_solve(
        &self,
        scratch: &mut AdjointScratch,
        cells: usize,
        cell: &[usize],
        x: &[f64],
        metric: Metric,
        out: &mut [f64],
    ) -> u64 {
        let diagonal = match metric {
            Metric::Mass(mass) => mass,
            Metric::FitVolume => &scratch.particle_weight,
        };
        if self.particle_metric == AdjointMass::Quadratic {
            quadratic_mass::quadratic_accelerations(
                cells,
                cell,
                x,
                diagonal,
                &scratch.particle_force,
                &scratch.particle_linear,
                &scratch.particle_quadratic,
                &mut scratch.quadratic_corrections,
                out,
            )
        } else {
            particle_mass::consistent_accelerations(
                cells,
                cell,
                x,
                diagonal,
                &scratch.particle_force,
                &scratch.particle_linear,
                &mut scratch.corrections,
                out,
            )
        }
    }
}

/// The diagonal of a consistent particle metric.
#[derive(Clone, Copy)]
enum Metric<'a> {
    /// The particle masses (the acceleration).
    Mass(&'a [f64]),
    /// The fit volumes `V~_p` of the scratch (the strain).
    FitVolume,
}
