//! Conservative Taylor least squares (TLS) mapping (SPEC §4.1; IJNME paper §5).
//!
//! Per active cell `e` (see [`CellDomains`]) and per field, a quadratic Taylor
//! reconstruction `f_hat_e = sum_i a_i psi_i` is fitted to the particles of the cell:
//!
//! * stress: full least squares (`a_1, a_2, a_3` free);
//! * density `rho_p = m_p / V_p`: conservative, `a_1 = (sum_{p in e} m_p) / |e|`;
//! * momentum density `rho_p v_p`: conservative, `a_1 = (sum_{p in e} m_p v_p) / |e|`.
//!
//! Since `int_e psi_2 = int_e psi_3 = 0`, `int_e rho_hat = sum m_p` and
//! `int_e (rho v)_hat = sum m_p v_p` in every cell; with a Gauss rule exact for quadratics
//! (2+ points) and a partition-of-unity basis the mapped mass `sum_i m_i` and momentum
//! `sum_i p_i` equal the particle totals to round-off (IJNME §5.5).
//!
//! **Batches.** Per step and parallel over cells: one pass over the binned particles builds
//! every cell's normal matrix `D = sum psi psi^T` (shared by all fields), right-hand sides
//! and conserved totals; one pass solves every cell's 3x3 (full, stress) and 2x2
//! (conservative, density) systems and limits the density; a pass over the degenerate
//! cells only (skipped when there is none) repairs them from their neighbours; one pass
//! integrates. The results are flat `[N_e][3]` coefficient arrays per field. The momentum
//! mapping reuses `D` (same positions) with its own right-hand side.
//!
//! **Fit weights** (`method.fit_weights`): each particle is one point of weight 1 in the
//! fits of the cell of its centre (`"points"`, published), or a point in every cell its
//! domain `x_p ± V_p/2` overlaps, weighted by the overlapping fraction (`"domains"`,
//! [`FitPoints`]): then `D = sum_p w_pc psi psi^T` and the fits change continuously when a
//! particle crosses a face (docs/reconstruction.md "Domain-weighted fits").
//!
//! **Degenerate cells** (fewer points than unknowns, or a condition number of the block
//! not well posed, see [`crate::numerics::taylor`]): with `method.degenerate_cells = "virtual_points"` (default) the
//! reconstructions of the well-posed neighbouring cells are evaluated at the shared faces
//! and added as data points (they enter `D` and the fitted coefficients, never `a_1`, so
//! conservation is untouched); if that is still not enough, or with `"order_reduction"`,
//! `psi_3` and then `psi_2` are dropped. A fit never produces NaN.
//!
//! **Density limiter.** A conservative quadratic fit can dip below zero in a cell whose
//! density varies strongly; then `a_2, a_3` are scaled by
//! `theta = a_1 / (a_1 - min_g rho_hat(x_g))` (Zhang–Shu), which keeps `a_1` (mass) and
//! makes `rho_hat >= 0` at every Gauss point, so the lumped masses are non-negative and
//! `M^C` is positive semi-definite.
//!
//! **Kinetic-energy limiter** (`method.momentum_limiter = "kinetic_energy"`,
//! [`fit::limit_momentum`]): a momentum fit whose velocity `(rho v)_hat / rho_hat` carries
//! more kinetic energy than the cell's particles is blended towards the cell's mean
//! velocity times `rho_hat` (momentum kept), so the mapping to the grid never adds kinetic
//! energy, as plain MPM's does not.
//!
//! **Adjoint strain and acceleration** (`method.strain = "adjoint"`, [`adjoint`]): the
//! transposes of the linear maps particle stress → internal force and particle velocity →
//! momentum replace the basis gradient and values at the particles in the particle update.

use super::quadrature::{integrate_mass_and_force, integrate_momentum, CellDomains, GaussPoints};
use super::{CellScatter, GridFields, Mapping, RemedyCounts};
use crate::config::{AdjointMass, CellTotals, DegenerateRemedy};
use crate::grid::{Basis, Grid};
use crate::numerics::gauss::GaussRule;
use crate::numerics::taylor::{add_rhs, FitKind, TaylorCell};
use crate::particles::{CellBins, Particles};
use fit::{cell_total, limit_density, limit_momentum, CellSums, FieldFit, FitContext, FitState};
use rayon::prelude::*;

/// Cells per rayon task in the batched passes.
const CELLS_PER_TASK: usize = 128;

/// The TLS mapping with Gauss quadrature.
#[derive(Clone, Debug)]
pub struct TlsMapping {
    grid: Grid,
    remedy: DegenerateRemedy,
    totals: CellTotals,
    points: GaussPoints,
    domains: CellDomains,
    taylor: Vec<TaylorCell>,
    sums: Vec<CellSums>,
    stress: FieldFit,
    density: FieldFit,
    momentum: FieldFit,
    remedies: RemedyCounts,
    scatter: CellScatter,
    /// Taylor functions of the conservative fits of density and momentum:
    /// `method.conservative_degree + 1` (3, the published quadratic fit, by default).
    conservative_terms: usize,
    /// `method.strain = "adjoint"`: the strain and particle acceleration adjoint to the
    /// mapping's internal force and momentum ([`adjoint`]).
    adjoint: Option<adjoint::AdjointScratch>,
    /// `method.momentum_limiter = "kinetic_energy"`: per cell, the `theta` of the last
    /// momentum fit ([`fit::limit_momentum`]; 1 where it was kept); `None`: no limiter.
    momentum_theta: Option<Vec<f64>>,
    /// `method.stress_fit = "conservative"`: the stress fit keeps the cell total
    /// `sum_p s_pc V_p sigma_p` (so `int sigma_hat = sum_p V_p sigma_p`), like density and
    /// momentum; else a full least-squares fit (the published method).
    conservative_stress: bool,
    /// `method.fit_weights = "domains"`: each particle enters the fits of every cell its
    /// domain overlaps, weighted by the overlapping fraction ([`for_each_fit_point`]);
    /// else one point of weight 1 in the cell of its centre (the published method).
    domain_weights: bool,
    /// `method.adjoint_mass`: the particle metric `W` of the adjoint acceleration and
    /// strain, the particle masses (fit volumes), the consistent metric of
    /// [`particle_mass`] (exact for linear fields) or that of [`quadratic_mass`] (exact for
    /// quadratic fields as well).
    particle_metric: AdjointMass,
}

impl TlsMapping {
    /// TLS on `grid` with an `gauss_points`-point Gauss rule per cell; `None` unless
    /// `gauss_points` is between 2 (exact for the quadratic reconstruction) and
    /// [`crate::numerics::gauss::MAX_POINTS`].
    pub fn new(
        grid: Grid,
        gauss_points: usize,
        remedy: DegenerateRemedy,
        totals: CellTotals,
    ) -> Option<Self> {
        if gauss_points < 2 {
            return None;
        }
        let rule = GaussRule::new(gauss_points)?;
        let cells = grid.cells;
        Some(Self {
            grid,
            remedy,
            totals,
            points: GaussPoints { rule, pieces: 1 },
            domains: CellDomains::default(),
            taylor: vec![TaylorCell::default(); cells],
            sums: vec![CellSums::default(); cells],
            stress: FieldFit::new(cells),
            density: FieldFit::new(cells),
            momentum: FieldFit::new(cells),
            remedies: RemedyCounts::default(),
            scatter: CellScatter::default(),
            conservative_terms: 3,
            adjoint: None,
            momentum_theta: None,
            conservative_stress: false,
            domain_weights: false,
            particle_metric: AdjointMass::Lumped,
        })
    }

    /// Conservative fits (density, momentum) of total degree at most `degree` (0..=2,
    /// `method.conservative_degree`; larger values are taken as 2): 1 fits
    /// `a_1 + a_2 psi_2`, the degree of the 2D/3D default. Full fits (stress) stay
    /// quadratic.
    pub fn with_conservative_degree(mut self, degree: usize) -> Self {
        self.conservative_terms = degree.min(2) + 1;
        self
    }

    /// With `adjoint`, the particle strain increments and accelerations are the adjoints
    /// of the mapping's internal force and momentum (`method.strain = "adjoint"`, see
    /// [`adjoint`]); else the basis gradient and values at the particles (the published
    /// method).
    pub fn with_adjoint(mut self, adjoint: bool) -> Self {
        self.adjoint = adjoint.then(adjoint::AdjointScratch::default);
        self
    }

    /// With `limit`, momentum fits are held to the kinetic energy of their particles
    /// (`method.momentum_limiter = "kinetic_energy"`, [`fit::limit_momentum`]).
    pub fn with_momentum_limiter(mut self, limit: bool) -> Self {
        self.momentum_theta = limit.then(|| vec![1.0; self.grid.cells]);
        self
    }

    /// With `conservative`, the stress fit keeps the cell total `sum_p s_pc V_p sigma_p`
    /// (`method.stress_fit = "conservative"`): the integral of the fitted stress is then
    /// the particles' `sum_p V_p sigma_p`, and with the adjoint strain each particle's
    /// weight `V~_p` is its volume, so the step conserves the physical energy.
    pub fn with_conservative_stress(mut self, conservative: bool) -> Self {
        self.conservative_stress = conservative;
        self
    }

    /// Weight the particles in the least-squares fits by the share of their domain in each
    /// cell it overlaps (`method.fit_weights = "domains"`, [`for_each_fit_point`]): a fit
    /// then changes continuously as a particle crosses a face, where with one point per
    /// particle in the cell of its centre it jumps. Conservation is unchanged (the fits'
    /// means are the cell totals either way).
    pub fn with_domain_weights(mut self, domain_weights: bool) -> Self {
        self.domain_weights = domain_weights;
        self
    }

    /// The particle metric `W` of the adjoint step (`method.strain = "adjoint"`): the
    /// particle acceleration is `W^{-1} P^T a`. `Lumped` (the default) is `diag(m_p)`,
    /// exact for uniform accelerations only; `Consistent` the metric of [`particle_mass`],
    /// exact for linear ones; `Quadratic` that of [`quadratic_mass`], exact for quadratic
    /// ones where a cell's particles allow it (`method.adjoint_mass`). Momentum and the
    /// neutral frozen step are kept by each.
    pub fn with_particle_metric(mut self, metric: AdjointMass) -> Self {
        self.particle_metric = metric;
        self
    }

    /// The active part of each cell used by the last mapping.
    pub fn domains(&self) -> &CellDomains {
        &self.domains
    }

    /// The Taylor basis of cell `cell` in the last mapping.
    pub fn taylor_cell(&self, cell: usize) -> &TaylorCell {
        &self.taylor[cell]
    }

    /// Stress coefficients `[N_e][3]` of the last mapping.
    pub fn stress(&self) -> &[[f64; 3]] {
        &self.stress.coefficients
    }

    /// Density coefficients `[N_e][3]` of the last mapping.
    pub fn density(&self) -> &[[f64; 3]] {
        &self.density.coefficients
    }

    /// Momentum-density coefficients `[N_e][3]` of the last mapping.
    pub fn momentum(&self) -> &[[f64; 3]] {
        &self.momentum.coefficients
    }
}

impl Mapping for TlsMapping {
    fn name(&self) -> &'static str {
        "tls"
    }

    fn map_mass_and_internal_force<B: Basis>(
        &mut self,
        basis: &B,
        particles: &Particles,
        bins: &CellBins,
        grid: &mut GridFields,
    ) {
        let by_domains = self.totals == CellTotals::Domains;
        let conservative_stress = self.conservative_stress;
        self.domains
            .update(&self.grid, particles, bins, !by_domains);
        let (mesh, domains) = (&self.grid, &self.domains);
        let (x, stress, mass, volume, density) = (
            &particles.x,
            &particles.stress,
            &particles.mass,
            &particles.volume,
            &particles.density,
        );
        let points = FitPoints::new(mesh, bins, particles, self.domain_weights);
        // Pass 1: normal matrices, right-hand sides, mass shares.
        self.taylor
            .par_iter_mut()
            .zip(self.sums.par_iter_mut())
            .with_min_len(CELLS_PER_TASK)
            .enumerate()
            .for_each(|(cell, (taylor, sums))| {
                *sums = CellSums::default();
                if !domains.is_active(cell) {
                    return;
                }
                // Accumulate in locals (registers), store once.
                let basis = TaylorCell::new(domains.lo[cell], domains.hi[cell]);
                let mut local = CellSums::default();
                points.for_each(cell, |p, w, own| {
                    let psi = basis.psi(x[p]);
                    local.normal.add_weighted(&psi, w);
                    add_rhs(&mut local.stress_rhs, &psi, w * stress[p]);
                    // rho_p = m_p / V_p, carried by the particles.
                    add_rhs(&mut local.density_rhs, &psi, w * density[p]);
                    if !own {
                        // A neighbour's particle: its totals are counted in its own cell.
                        return;
                    }
                    if by_domains {
                        add_shares(&mut local.mass_shares, mesh, cell, x[p], volume[p], mass[p]);
                        if conservative_stress {
                            let force = volume[p] * stress[p];
                            add_shares(
                                &mut local.stress_shares,
                                mesh,
                                cell,
                                x[p],
                                volume[p],
                                force,
                            );
                        }
                    } else {
                        local.mass_shares[1] += mass[p];
                        local.stress_shares[1] += volume[p] * stress[p];
                    }
                });
                *taylor = basis;
                *sums = local;
            });
        // Pass 2: plain fits of stress and density, density limiter.
        let (taylor, sums, points) = (&self.taylor, &self.sums, &self.points);
        let context = FitContext {
            grid: &self.grid,
            remedy: self.remedy,
            taylor,
            sums,
            conservative_terms: self.conservative_terms,
        };
        let stress_context = context.for_stress();
        let density_kind = |cell: usize| {
            FitKind::Conservative(cell_total(sums, cell, |s| s.mass_shares) / domains.length(cell))
        };
        let stress_kind = |cell: usize| stress_kind(conservative_stress, sums, domains, cell);
        let limited: u64 = (
            self.stress.coefficients.par_iter_mut(),
            self.stress.state.par_iter_mut(),
            self.density.coefficients.par_iter_mut(),
            self.density.state.par_iter_mut(),
        )
            .into_par_iter()
            .with_min_len(CELLS_PER_TASK)
            .enumerate()
            .map(
                |(cell, (stress_a, stress_state, density_a, density_state))| {
                    let active = domains.is_active(cell);
                    let s = &sums[cell];
                    (*stress_state, *stress_a) = stress_context.plain_fit(
                        active,
                        &s.normal,
                        &s.stress_rhs,
                        stress_kind(cell),
                    );
                    (*density_state, *density_a) =
                        context.plain_fit(active, &s.normal, &s.density_rhs, density_kind(cell));
                    if *density_state == FitState::Fitted {
                        limit_density(
                            &taylor[cell],
                            points,
                            domains.lo[cell],
                            domains.hi[cell],
                            density_a,
                        )
                    } else {
                        0
                    }
                },
            )
            .sum();
        // Pass 3 (only where needed): repairs from the neighbours' plain fits.
        let mut counts = RemedyCounts {
            density_limited_fits: limited,
            ..RemedyCounts::default()
        };
        counts += stress_context.repair_all(
            &mut self.stress,
            |cell| sums[cell].stress_rhs,
            stress_kind,
            |_, _| 0,
        );
        counts += context.repair_all(
            &mut self.density,
            |cell| sums[cell].density_rhs,
            density_kind,
            |cell, a| limit_density(&taylor[cell], points, domains.lo[cell], domains.hi[cell], a),
        );
        self.remedies += counts;
        if self.momentum_theta.is_some() {
            // The kinetic-energy limiter needs `rho_hat >= 0`: a cell without mass (inside
            // the material extent, its slopes from virtual points) gets no density.
            for a in self.density.coefficients.iter_mut().filter(|a| a[0] <= 0.0) {
                *a = [0.0; 3];
            }
        }
        // Pass 4: Gauss quadrature.
        let (stress, density) = (&self.stress.coefficients, &self.density.coefficients);
        integrate_mass_and_force(
            &mut self.scatter,
            basis,
            domains,
            points,
            |cell, x| taylor[cell].eval(&stress[cell], x),
            |cell, x| taylor[cell].eval(&density[cell], x),
            grid,
        );
    }

    fn map_momentum<B: Basis>(
        &mut self,
        basis: &B,
        particles: &Particles,
        bins: &CellBins,
        grid: &mut GridFields,
    ) {
        let by_domains = self.totals == CellTotals::Domains;
        let limited = self.momentum_theta.is_some();
        let (mesh, domains, taylor) = (&self.grid, &self.domains, &self.taylor);
        let (x, mass, volume, density, v) = (
            &particles.x,
            &particles.mass,
            &particles.volume,
            &particles.density,
            &particles.v,
        );
        let points = FitPoints::new(mesh, bins, particles, self.domain_weights);
        // Pass 1: right-hand sides and momentum shares (D is still valid).
        self.sums
            .par_iter_mut()
            .with_min_len(CELLS_PER_TASK)
            .enumerate()
            .for_each(|(cell, sums)| {
                sums.momentum_rhs = [0.0; 3];
                sums.momentum_shares = [0.0; 3];
                sums.energy_shares = [0.0; 3];
                if !domains.is_active(cell) {
                    return;
                }
                let basis = taylor[cell];
                let (mut rhs, mut shares, mut energy) = ([0.0; 3], [0.0; 3], [0.0; 3]);
                points.for_each(cell, |p, w, own| {
                    let psi = basis.psi(x[p]);
                    add_rhs(&mut rhs, &psi, w * density[p] * v[p]);
                    if !own {
                        return;
                    }
                    let momentum = mass[p] * v[p];
                    if by_domains {
                        add_shares(&mut shares, mesh, cell, x[p], volume[p], momentum);
                        if limited {
                            let twice_energy = momentum * v[p];
                            add_shares(&mut energy, mesh, cell, x[p], volume[p], twice_energy);
                        }
                    } else {
                        shares[1] += momentum;
                        energy[1] += momentum * v[p];
                    }
                });
                sums.momentum_rhs = rhs;
                sums.momentum_shares = shares;
                sums.energy_shares = energy;
            });
        // Pass 2: plain fits; pass 3: repairs.
        let sums = &self.sums;
        let context = FitContext {
            grid: mesh,
            remedy: self.remedy,
            taylor,
            sums,
            conservative_terms: self.conservative_terms,
        };
        let kind = |cell: usize| {
            FitKind::Conservative(
                cell_total(sums, cell, |s| s.momentum_shares) / domains.length(cell),
            )
        };
        (
            self.momentum.coefficients.par_iter_mut(),
            self.momentum.state.par_iter_mut(),
        )
            .into_par_iter()
            .with_min_len(CELLS_PER_TASK)
            .enumerate()
            .for_each(|(cell, (a, state))| {
                (*state, *a) = context.plain_fit(
                    domains.is_active(cell),
                    &sums[cell].normal,
                    &sums[cell].momentum_rhs,
                    kind(cell),
                );
            });
        self.remedies += context.repair_all(
            &mut self.momentum,
            |cell| sums[cell].momentum_rhs,
            kind,
            |_, _| 0,
        );
        // Kinetic-energy limiter, after the repairs (their virtual points come from the
        // neighbours' unlimited fits, as the adjoint assumes).
        if let Some(theta) = self.momentum_theta.as_mut() {
            let (points, density) = (&self.points, &self.density.coefficients);
            let limited: u64 = (
                theta.par_iter_mut(),
                self.momentum.coefficients.par_iter_mut(),
            )
                .into_par_iter()
                .with_min_len(CELLS_PER_TASK)
                .enumerate()
                .map(|(cell, (theta, momentum))| {
                    *theta = 1.0;
                    if !domains.is_active(cell) {
                        return 0;
                    }
                    let energy = cell_total(sums, cell, |s| s.energy_shares);
                    let (lo, hi) = (domains.lo[cell], domains.hi[cell]);
                    *theta = limit_momentum(
                        &taylor[cell],
                        points,
                        lo,
                        hi,
                        &density[cell],
                        energy,
                        momentum,
                    );
                    u64::from(*theta < 1.0)
                })
                .sum();
            self.remedies.momentum_limited_fits += limited;
        }
        // Pass 4: Gauss quadrature.
        let momentum = &self.momentum.coefficients;
        integrate_momentum(
            &mut self.scatter,
            basis,
            domains,
            &self.points,
            |cell, x| taylor[cell].eval(&momentum[cell], x),
            grid,
        );
    }

    fn strain_increments<B: Basis>(
        &mut self,
        basis: &B,
        particles: &Particles,
        velocity: &[f64],
        dt: f64,
        deps: &mut Vec<f64>,
    ) -> bool {
        if self.adjoint.is_none() {
            return false;
        }
        self.adjoint_strain_increments(basis, particles, velocity, dt, deps);
        true
    }

    fn particle_accelerations<B: Basis>(
        &mut self,
        basis: &B,
        particles: &Particles,
        acceleration: &[f64],
        out: &mut Vec<f64>,
    ) -> bool {
        if self.adjoint.is_none() {
            return false;
        }
        self.adjoint_accelerations(basis, particles, acceleration, out);
        true
    }

    fn remedies(&self) -> RemedyCounts {
        self.remedies
    }
}

/// The stress fit of `cell`: conservative with the mean `sum_p s_pc V_p sigma_p / |e_c|`
/// (`method.stress_fit = "conservative"`), else full.
fn stress_kind(
    conservative: bool,
    sums: &[CellSums],
    domains: &CellDomains,
    cell: usize,
) -> FitKind {
    if conservative {
        FitKind::Conservative(cell_total(sums, cell, |s| s.stress_shares) / domains.length(cell))
    } else {
        FitKind::Full
    }
}

/// Split `q` of a particle of `cell` between the cells its domain
/// `[x - l, x + l]` overlaps (`l = min(V/2, h)`, clipped to the grid; at most one cell on
/// either side): `shares += [to the left cell, kept, to the right cell]` in proportion to
/// the overlaps (`method.cell_totals = "domains"`). The three parts add up to `q`, so the
/// cell totals stay conservative.
#[inline]
fn add_shares(shares: &mut [f64; 3], grid: &Grid, cell: usize, x: f64, volume: f64, q: f64) {
    let (left, right) = (grid.cell_left(cell), grid.cell_left(cell + 1));
    let half = 0.5 * volume;
    if x - half >= left && x + half <= right {
        // The common case: the domain lies inside the cell.
        shares[1] += q;
        return;
    }
    let half = half.min(grid.h);
    let (a, b) = (
        (x - half).max(grid.origin),
        (x + half).min(grid.origin + grid.length),
    );
    let per_length = q / (b - a);
    let to_left = (left - a).max(0.0) * per_length;
    let to_right = (b - right).max(0.0) * per_length;
    shares[0] += to_left;
    shares[1] += q - to_left - to_right;
    shares[2] += to_right;
}

/// The data points of the TLS fits (`method.fit_weights`).
#[derive(Clone, Copy)]
struct FitPoints<'a> {
    grid: &'a Grid,
    bins: &'a CellBins,
    x: &'a [f64],
    volume: &'a [f64],
    domain_weights: bool,
}

impl<'a> FitPoints<'a> {
    /// The fit points of `particles` (binned by `bins`) on `grid`.
    fn new(
        grid: &'a Grid,
        bins: &'a CellBins,
        particles: &'a Particles,
        domain_weights: bool,
    ) -> Self {
        Self {
            grid,
            bins,
            x: &particles.x,
            volume: &particles.volume,
            domain_weights,
        }
    }

    /// Call `f(p, w, own)` for every particle `p` in the fit of `cell` with its weight
    /// `w`; `own` says that `p` is binned in `cell`. With domain weights these are the
    /// particles of `cell - 1`, `cell` and `cell + 1` whose domains overlap `cell`, each
    /// weighted by the overlapping fraction (the shares of [`add_shares`], the same as
    /// [`for_each_fit_cell`] gives from the particle's side); else the particles of
    /// `cell`, weight 1.
    #[inline]
    fn for_each(&self, cell: usize, mut f: impl FnMut(usize, f64, bool)) {
        if !self.domain_weights {
            for p in self.bins.range(cell) {
                f(p, 1.0, true);
            }
            return;
        }
        let neighbours = cell.saturating_sub(1)..(cell + 2).min(self.grid.cells);
        let (left, right) = (self.grid.cell_left(cell), self.grid.cell_left(cell + 1));
        for home in neighbours {
            for p in self.bins.range(home) {
                // A neighbour's particle reaches into `cell` only across the shared face
                // (`add_shares` clips the half-width to `h`): skip the others cheaply.
                let (x, reach) = (self.x[p], (0.5 * self.volume[p]).min(self.grid.h));
                if (home < cell && x + reach <= left) || (home > cell && x - reach >= right) {
                    continue;
                }
                let shares = domain_shares(self.grid, home, x, self.volume[p]);
                // The share in `cell`: index 0, 1, 2 for `cell = home - 1, home, home + 1`.
                // A particle of `cell` is always visited: its totals are counted there.
                let w = shares[cell + 1 - home];
                if w > 0.0 || home == cell {
                    f(p, w, home == cell);
                }
            }
        }
    }
}

/// The fractions of the domain `[x - V/2, x + V/2]` of a particle binned in `home` that
/// lie in `home - 1`, `home`, `home + 1` (they sum to 1).
#[inline]
fn domain_shares(grid: &Grid, home: usize, x: f64, volume: f64) -> [f64; 3] {
    let mut shares = [0.0; 3];
    add_shares(&mut shares, grid, home, x, volume, 1.0);
    shares
}

/// Call `f(cell, w)` for every cell whose fits the particle at `x` with `volume`, binned
/// in `home`, enters, with its weight there (see [`FitPoints::for_each`]).
#[inline]
pub(super) fn for_each_fit_cell(
    grid: &Grid,
    domain_weights: bool,
    home: usize,
    x: f64,
    volume: f64,
    mut f: impl FnMut(usize, f64),
) {
    if !domain_weights {
        f(home, 1.0);
        return;
    }
    let shares = domain_shares(grid, home, x, volume);
    for (k, &w) in shares.iter().enumerate() {
        if w > 0.0 {
            // k = 0, 1, 2: home - 1, home, home + 1 (a share outside the grid is 0).
            f(home + k - 1, w);
        }
    }
}

pub mod adjoint;
mod cell_metric;
mod fit;
mod particle_mass;
mod quadratic_mass;
#[cfg(test)]
mod tests;
