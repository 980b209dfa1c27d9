//! Moving least squares (MLS) and improved MLS (IMLS) mappings (SPEC §4.3; Tran et al.
//! 2019, `seeds/tran2019_imls.txt`).
//!
//! At an evaluation point `x_c` the particle data `f_p` are fitted by weighted least squares
//! in the centred, scaled monomials `p(s) = {1, s, s^2}`, `s = (x_p - x_c) / h`, with the
//! quadratic B-spline kernel `w_p = N2((x_p - x_c) / h)` (support `|x_p - x_c| < 1.5 h`,
//! `N2(s) = 3/4 - s^2` for `|s| <= 1/2`, `(3/2 - |s|)^2 / 2` for `1/2 < |s| < 3/2`). Every
//! particle inside the support is used (cells `c - 2 ..= c + 2` around a point of cell `c`,
//! a contiguous range of the binned particles). The value at `x_c` (`s = 0`) is:
//!
//! * **MLS**: `A a = b` with the moment matrix `A = sum_p w_p p(s_p) p(s_p)^T` and
//!   `b = sum_p w_p p(s_p) f_p`; the value is `a_1`. If `A` is singular or its condition
//!   number (symmetric eigenvalues) exceeds `1e10` the fit is degenerate: it is counted
//!   (`degenerate_fits`, `order_reduced_fits`) and the linear, then the constant fit is used.
//! * **IMLS**: weighted Gram–Schmidt of the monomials under `<f, g> = sum_p w_p f(x_p) g(x_p)`:
//!   `q_0 = 1`, `q_1 = s - c_10`, `q_2 = s^2 - c_20 - c_21 q_1` (`c_ij = <p_i, q_j>/<q_j, q_j>`),
//!   so the moment matrix is diagonal and `a_i = <q_i, f> / <q_i, q_i>`, value
//!   `sum_i a_i q_i(0)`. If `<q_i, q_i> <= 1e-9 <q_0, q_0>` (rank `r < 3`, e.g. 1 or 2
//!   particles) `q_i` and higher are dropped (`order_reduced_fits`). No matrix inversion.
//!
//! In 1D all inner products follow from the weighted moments `mu_k = sum w s^k` (`k <= 4`)
//! and `sum w s^k f_p` (`k <= 2`), accumulated in one pass over the support; the
//! Gram–Schmidt norms are the pivots of `A`, so the two fits agree wherever `A` is well
//! conditioned and differ only in how rank deficiency is detected and handled.
//!
//! **Step** (paper eqs. 24–31): density `rho_p` and stress `sigma_p` are reconstructed at the
//! Gauss points of the active part of every cell ([`CellDomains`], as TLS) and integrated
//! by [`integrate_mass_and_force`] (lumped mass, internal force and, when asked for, the
//! consistent mass matrix). Momentum:
//!
//! * linear basis: nodal velocity `v_i` by a **linear** fit `{1, s}` at the node with the
//!   same kernel, and `p_i = m_i v_i` with the lumped masses of the preceding
//!   [`Mapping::map_mass_and_internal_force`] (stored by the mapping), so that the lumped
//!   solve `v = p / m` returns exactly the (I)MLS nodal velocity; with a consistent velocity
//!   mass ([`MlsMapping::with_consistent_velocity`], `method.mass = "consistent"`) and a
//!   matrix assembled by that call, `p = M^C v` (then the consistent solve returns `v`). The
//!   per-particle body force goes through the same path (`f_i = m_i b_i` or `M^C b`), so with
//!   different acceleration and velocity masses (`method.acceleration_mass`) it follows
//!   the velocity's;
//! * other bases (B-splines, GIMP, CPDI, DDMPM): the DOFs are not nodal values, so
//!   `(rho v)_p = rho_p v_p` is reconstructed at the Gauss points with the quadratic fit and
//!   integrated by [`integrate_momentum`], `p_i = int (rho v)_hat phi_i`.
//!
//! **Particle acceleration** ([`Mapping::particle_accelerations`]): the hats at the
//! particle (the paper's step), or with [`MlsMapping::with_conjugate_acceleration`]
//! (`method.particle_acceleration = "conjugate"`, linear basis, lumped velocity mass) the
//! transpose of a mass- and moment-corrected nodal momentum map ([`conjugate`]), so that the
//! grid's and the particles' work agree.
//!
//! **Strain** ([`Mapping::strain_increments`]): with [`MlsMapping::with_adjoint_strain`]
//! (`method.strain = "adjoint"`, the default for one-phase MLS / IMLS) the particle strain
//! increments are the adjoint of the internal force, the fit-weighted mean of the
//! Gauss-point velocity gradients ([`adjoint`]); otherwise the basis gradient at the
//! particle (the paper's eq. 37), whose semi-discrete step has a growing mode.
//!
//! `map_momentum` reads only `x`, `v` and `density` of the particles it is given (the step
//! also passes a view whose `v` holds a per-particle body force). Remedies are counted per
//! point fit. Every point is fitted independently in parallel (no allocation per point;
//! scratch vectors are reused), and the scatter is [`super::CellScatter`]'s, so results are
//! bitwise identical for any thread count.

use super::quadrature::{integrate_mass_and_force, integrate_momentum, CellDomains, GaussPoints};
use super::{CellScatter, GridFields, Mapping, RemedyCounts};
use crate::grid::{Basis, Grid};
use crate::linalg::CsrMatrix;
use crate::numerics::gauss::GaussRule;
use crate::particles::{CellBins, Particles};
use rayon::prelude::*;
use std::ops::Range;

/// Cells (or nodes) per rayon task.
const CELLS_PER_TASK: usize = 64;
/// IMLS: `q_i` is dropped when `<q_i, q_i> <= RANK_TOL <q_0, q_0>`.
const RANK_TOL: f64 = 1e-9;
/// MLS: largest accepted condition number of the moment matrix.
const MAX_CONDITION: f64 = 1e10;

/// Which least-squares variant.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MlsKind {
    /// Classical MLS: solve the moment matrix, fall back on ill conditioning.
    Mls,
    /// Improved MLS: orthogonal basis, rank adaptive.
    Imls,
}

/// The quadratic B-spline `N2(s)`.
#[inline]
pub fn kernel(s: f64) -> f64 {
    let a = s.abs();
    if a <= 0.5 {
        0.75 - a * a
    } else if a < 1.5 {
        0.5 * (1.5 - a) * (1.5 - a)
    } else {
        0.0
    }
}

/// Weighted moments at one point for `F` fields: `mu[k] = sum w s^k`,
/// `rhs[f][k] = sum w s^k f_p`.
#[derive(Clone, Copy, Debug)]
struct Moments<const F: usize> {
    mu: [f64; 5],
    rhs: [[f64; 3]; F],
}

impl<const F: usize> Moments<F> {
    /// Accumulate over the particles `range` around `centre`.
    #[inline]
    fn gather(
        centre: f64,
        inv_h: f64,
        range: Range<usize>,
        x: &[f64],
        value: impl Fn(usize) -> [f64; F],
    ) -> Self {
        let mut m = Self {
            mu: [0.0; 5],
            rhs: [[0.0; 3]; F],
        };
        for p in range {
            let s = (x[p] - centre) * inv_h;
            let w = kernel(s);
            if w == 0.0 {
                continue;
            }
            let (ws, ws2) = (w * s, w * s * s);
            m.mu[0] += w;
            m.mu[1] += ws;
            m.mu[2] += ws2;
            m.mu[3] += ws2 * s;
            m.mu[4] += ws2 * s * s;
            for (rhs, f) in m.rhs.iter_mut().zip(value(p)) {
                rhs[0] += w * f;
                rhs[1] += ws * f;
                rhs[2] += ws2 * f;
            }
        }
        m
    }

    /// The fitted values at the centre with polynomial degree up to `degree` (1 or 2).
    #[inline]
    fn fit(&self, kind: MlsKind, degree: usize, counts: &mut RemedyCounts) -> [f64; F] {
        match kind {
            MlsKind::Imls => self.imls(degree, counts),
            MlsKind::Mls => self.mls(degree, counts),
        }
    }

    /// IMLS by weighted Gram–Schmidt (rank adaptive).
    fn imls(&self, degree: usize, counts: &mut RemedyCounts) -> [f64; F] {
        let mu = &self.mu;
        let mut out = [0.0; F];
        let n0 = mu[0];
        if n0 <= 0.0 {
            return out;
        }
        let c10 = mu[1] / n0;
        let n1 = mu[2] - c10 * mu[1];
        let mut rank = 1;
        let (mut c20, mut c21, mut n2) = (0.0, 0.0, 0.0);
        if n1 > RANK_TOL * n0 {
            rank = 2;
            if degree >= 2 {
                c20 = mu[2] / n0;
                let s2_q1 = mu[3] - c10 * mu[2];
                c21 = s2_q1 / n1;
                n2 = mu[4] - c20 * mu[2] - c21 * s2_q1;
                if n2 > RANK_TOL * n0 {
                    rank = 3;
                }
            }
        }
        if rank < degree + 1 {
            counts.order_reduced_fits += 1;
        }
        for (o, b) in out.iter_mut().zip(&self.rhs) {
            let a0 = b[0] / n0;
            let mut value = a0;
            if rank >= 2 {
                let q1_f = b[1] - c10 * b[0];
                value -= q1_f / n1 * c10;
                if rank == 3 {
                    let a2 = (b[2] - c20 * b[0] - c21 * q1_f) / n2;
                    value += a2 * (c21 * c10 - c20);
                }
            }
            *o = value;
        }
        out
    }

    /// Classical MLS: solve `A a = b` for the largest well-conditioned degree `<= degree`.
    fn mls(&self, degree: usize, counts: &mut RemedyCounts) -> [f64; F] {
        let mu = &self.mu;
        let mut out = [0.0; F];
        if mu[0] <= 0.0 {
            return out;
        }
        let mut d = degree;
        while d > 0 && !well_conditioned(mu, d) {
            d -= 1;
        }
        if d < degree {
            counts.degenerate_fits += 1;
            counts.order_reduced_fits += 1;
        }
        for (o, b) in out.iter_mut().zip(&self.rhs) {
            *o = match d {
                2 => solve3(mu, b),
                1 => {
                    // [mu0 mu1; mu1 mu2] a = [b0; b1], a_0 by Cramer's rule.
                    (b[0] * mu[2] - b[1] * mu[1]) / (mu[0] * mu[2] - mu[1] * mu[1])
                }
                _ => b[0] / mu[0],
            };
        }
        out
    }
}

/// Whether the moment matrix of degree `d` (1 or 2) is positive definite with a
/// condition number at most [`MAX_CONDITION`].
///
/// Fast path: a moment matrix is positive semi-definite, so with `det > 0` its eigenvalues
/// are positive and `kappa = l_max / l_min <= tr^n / det` (`l_max <= tr`, and `l_min`
/// times the other `n - 1` eigenvalues, each `<= tr`, is `det`); the eigenvalues are only
/// computed when that bound exceeds the limit.
fn well_conditioned(mu: &[f64; 5], d: usize) -> bool {
    let (trace, det) = if d == 1 {
        (mu[0] + mu[2], mu[0] * mu[2] - mu[1] * mu[1])
    } else {
        let minor = |a: f64, b: f64, c: f64, d: f64| a * d - b * c;
        let det = mu[0] * minor(mu[2], mu[3], mu[3], mu[4])
            - mu[1] * minor(mu[1], mu[3], mu[2], mu[4])
            + mu[2] * minor(mu[1], mu[2], mu[2], mu[3]);
        (mu[0] + mu[2] + mu[4], det)
    };
    if det > 0.0 && trace.powi(d as i32 + 1) <= MAX_CONDITION * det {
        return true;
    }
    let (lo, hi) = if d == 1 {
        let (mean, diff) = (0.5 * (mu[0] + mu[2]), 0.5 * (mu[0] - mu[2]));
        let r = diff.hypot(mu[1]);
        (mean - r, mean + r)
    } else {
        eigen3(mu)
    };
    lo > 0.0 && hi <= MAX_CONDITION * lo
}

/// Smallest and largest eigenvalue of the Hankel moment matrix
/// `[[mu0, mu1, mu2], [mu1, mu2, mu3], [mu2, mu3, mu4]]` (trigonometric formula).
fn eigen3(mu: &[f64; 5]) -> (f64, f64) {
    let (a, b, c) = (mu[0], mu[2], mu[4]);
    let (d, e, f) = (mu[1], mu[3], mu[2]); // (0,1), (1,2), (0,2)
    let q = (a + b + c) / 3.0;
    let p1 = d * d + e * e + f * f;
    let p2 = (a - q).powi(2) + (b - q).powi(2) + (c - q).powi(2) + 2.0 * p1;
    let p = (p2 / 6.0).sqrt();
    if p == 0.0 {
        return (q, q);
    }
    let (ba, bb, bc) = ((a - q) / p, (b - q) / p, (c - q) / p);
    let (bd, be, bf) = (d / p, e / p, f / p);
    let det = ba * (bb * bc - be * be) - bd * (bd * bc - be * bf) + bf * (bd * be - bb * bf);
    let phi = (0.5 * det).clamp(-1.0, 1.0).acos() / 3.0;
    let largest = q + 2.0 * p * phi.cos();
    let smallest = q + 2.0 * p * (phi + 2.0 * std::f64::consts::PI / 3.0).cos();
    (smallest, largest)
}

/// `a_0` of the 3x3 Hankel system `A a = b` by Gaussian elimination.
fn solve3(mu: &[f64; 5], b: &[f64; 3]) -> f64 {
    let (l10, l20) = (mu[1] / mu[0], mu[2] / mu[0]);
    let (a11, a12) = (mu[2] - l10 * mu[1], mu[3] - l10 * mu[2]);
    let l21 = a12 / a11;
    let a22 = mu[4] - l20 * mu[2] - l21 * a12;
    let r1 = b[1] - l10 * b[0];
    let r2 = b[2] - l20 * b[0] - l21 * r1;
    let x2 = r2 / a22;
    let x1 = (r1 - a12 * x2) / a11;
    (b[0] - mu[1] * x1 - mu[2] * x2) / mu[0]
}

/// The binned particles of cells `first ..= last` (clipped to the grid), a contiguous range.
#[inline]
fn support(bins: &CellBins, first: isize, last: isize) -> Range<usize> {
    let cells = bins.cells() as isize;
    let lo = first.clamp(0, cells) as usize;
    let hi = (last + 1).clamp(0, cells) as usize;
    bins.cell_start[lo]..bins.cell_start[hi.max(lo)]
}

/// The MLS / IMLS mapping with Gauss quadrature.
#[derive(Clone, Debug)]
pub struct MlsMapping {
    grid: Grid,
    kind: MlsKind,
    points: GaussPoints,
    domains: CellDomains,
    scatter: CellScatter,
    remedies: RemedyCounts,
    /// Fitted `[stress, density]` (or `[rho v, _]`) at the Gauss points, `[cell][g]`.
    values: Vec<[f64; 2]>,
    /// Lumped masses of the last `map_mass_and_internal_force`.
    lumped: Vec<f64>,
    /// Its consistent mass matrix, when it assembled one.
    consistent: Option<CsrMatrix>,
    /// Nodal velocities (linear basis).
    nodal: Vec<f64>,
    /// Whether the velocity solve uses the consistent mass (then `p = M^C v`).
    consistent_velocity: bool,
    /// Whether the particle strains are the adjoint of the internal force
    /// ([`MlsMapping::with_adjoint_strain`]).
    adjoint_strain: bool,
    /// Whether the particle acceleration is the transpose of a mass- and moment-corrected
    /// momentum map ([`conjugate`]; linear basis, lumped velocity mass).
    conjugate_momentum: bool,
    /// Linear nodal fit functionals `[l_0, l_1]` ([`conjugate`]).
    node_functional: Vec<[f64; 2]>,
    /// Every particle's `[alpha_p, beta_p]` ([`conjugate`]).
    correction: Vec<[f64; 2]>,
    /// The stress fit at every Gauss point as a functional of the particle data, `[cell][g]`:
    /// `sigma_hat(x_g) = sum_p w_p (l_0 + l_1 s_p + l_2 s_p^2) sigma_p` (see [`functional`]).
    functional: Vec<[f64; 3]>,
    /// `[x_g, w_g, w_g dv(x_g)]` at every Gauss point, `[cell][g]` (adjoint strain).
    gauss_gradient: Vec<[f64; 3]>,
}

impl MlsMapping {
    /// MLS or IMLS on `grid` with a `gauss_points`-point rule per cell; `None` unless the
    /// rule exists.
    pub fn new(grid: Grid, gauss_points: usize, kind: MlsKind) -> Option<Self> {
        let rule = GaussRule::new(gauss_points)?;
        Some(Self {
            grid,
            kind,
            points: GaussPoints { rule, pieces: 1 },
            domains: CellDomains::default(),
            scatter: CellScatter::default(),
            remedies: RemedyCounts::default(),
            values: Vec::new(),
            lumped: Vec::new(),
            consistent: None,
            nodal: Vec::new(),
            consistent_velocity: false,
            adjoint_strain: false,
            conjugate_momentum: false,
            node_functional: Vec::new(),
            correction: Vec::new(),
            functional: Vec::new(),
            gauss_gradient: Vec::new(),
        })
    }

    /// With the linear basis, map momentum as `M^C v` (when the mass mapping assembled
    /// `M^C`) instead of `m_i v_i`: for a consistent velocity solve (`method.mass`).
    pub fn with_consistent_velocity(mut self, consistent: bool) -> Self {
        self.consistent_velocity = consistent;
        self
    }

    /// Particle strains conjugate to the internal force (`method.strain = "adjoint"`, see
    /// [`adjoint`]) instead of the velocity gradient at the particle (the paper's eq. 37).
    pub fn with_adjoint_strain(mut self, adjoint: bool) -> Self {
        self.adjoint_strain = adjoint;
        self
    }

    /// With the linear basis and the lumped velocity mass, accelerate the particles with the
    /// transpose of a momentum map corrected to keep every particle's mass and first moment
    /// (`method.particle_acceleration = "conjugate"`, see [`conjugate`]) instead of the hats.
    pub fn with_conjugate_acceleration(mut self, conjugate: bool) -> Self {
        self.conjugate_momentum = conjugate;
        self
    }

    /// The consistent mass matrix of the velocity solve, when the momentum is `M^C v`
    /// (assembled by the last mass map and asked for by
    /// [`MlsMapping::with_consistent_velocity`]); `None`: `p_i = m_i v_i`.
    fn consistent_velocity_mass(&self) -> Option<&CsrMatrix> {
        self.consistent
            .as_ref()
            .filter(|_| self.consistent_velocity)
    }

    /// The active part of each cell used by the last mapping.
    pub fn domains(&self) -> &CellDomains {
        &self.domains
    }

    /// Fit `value` (2 fields) at every Gauss point of every active cell into `self.values`;
    /// with `record`, also the fit functional of every point into `self.functional`.
    fn fit_gauss_points(
        &mut self,
        bins: &CellBins,
        x: &[f64],
        value: impl Fn(usize) -> [f64; 2] + Sync,
        record: bool,
    ) {
        let (kind, inv_h, ng) = (self.kind, self.grid.inv_h, self.points.rule.len);
        let (domains, points) = (&self.domains, &self.points);
        self.values.clear();
        self.values.resize(self.grid.cells * ng, [0.0; 2]);
        // Sized (and kept) even when not recorded: the zip below needs one chunk per cell.
        self.functional.resize(self.grid.cells * ng, [0.0; 3]);
        let counts = self
            .values
            .par_chunks_mut(ng)
            .zip(self.functional.par_chunks_mut(ng))
            .with_min_len(CELLS_PER_TASK)
            .enumerate()
            .map(|(cell, (out, functionals))| {
                let mut counts = RemedyCounts::default();
                if !domains.is_active(cell) {
                    return counts;
                }
                // `|x_p - x_g| < 1.5 h` reaches at most two cells either side.
                let range = support(bins, cell as isize - 2, cell as isize + 2);
                let mut g = 0;
                points.for_each(domains.lo[cell], domains.hi[cell], |xg, _| {
                    let m = Moments::<2>::gather(xg, inv_h, range.clone(), x, &value);
                    out[g] = m.fit(kind, 2, &mut counts);
                    if record {
                        functionals[g] = functional(kind, &m.mu);
                    }
                    g += 1;
                });
                counts
            })
            .sum();
        self.remedies += counts;
    }

    /// The fitted values at Gauss point `x` of `cell` (found by its exact position).
    #[inline]
    fn lookup(
        values: &[[f64; 2]],
        domains: &CellDomains,
        points: &GaussPoints,
        cell: usize,
        x: f64,
    ) -> [f64; 2] {
        let ng = points.rule.len;
        let (mut found, mut g) = (None, 0);
        points.for_each(domains.lo[cell], domains.hi[cell], |xg, _| {
            if xg == x {
                found = Some(values[cell * ng + g]);
            }
            g += 1;
        });
        debug_assert!(found.is_some(), "{x} is not a Gauss point of cell {cell}");
        found.unwrap_or_default()
    }
}

impl Mapping for MlsMapping {
    fn name(&self) -> &'static str {
        match self.kind {
            MlsKind::Mls => "mls",
            MlsKind::Imls => "imls",
        }
    }

    fn map_mass_and_internal_force<B: Basis>(
        &mut self,
        basis: &B,
        particles: &Particles,
        bins: &CellBins,
        grid: &mut GridFields,
    ) {
        self.domains.update(&self.grid, particles, bins, true);
        let (stress, density) = (&particles.stress, &particles.density);
        self.fit_gauss_points(
            bins,
            &particles.x,
            |p| [stress[p], density[p]],
            self.adjoint_strain,
        );
        let (values, domains, points) = (&self.values, &self.domains, &self.points);
        integrate_mass_and_force(
            &mut self.scatter,
            basis,
            domains,
            points,
            |cell, x| Self::lookup(values, domains, points, cell, x)[0],
            |cell, x| Self::lookup(values, domains, points, cell, x)[1],
            grid,
        );
        self.lumped.clone_from(&grid.mass);
        match (&mut self.consistent, &grid.consistent_mass) {
            (Some(own), Some(m)) if own.values.len() == m.values.len() => {
                own.values.copy_from_slice(&m.values)
            }
            (own, m) => *own = m.clone(),
        }
        if self.conjugate_momentum && basis.name() == "linear" {
            self.prepare_conjugate(particles, bins);
        }
    }

    fn map_momentum<B: Basis>(
        &mut self,
        basis: &B,
        particles: &Particles,
        bins: &CellBins,
        grid: &mut GridFields,
    ) {
        let (x, v, density) = (&particles.x, &particles.v, &particles.density);
        if basis.name() != "linear" {
            self.fit_gauss_points(bins, x, |p| [density[p] * v[p], 0.0], false);
            let (values, domains, points) = (&self.values, &self.domains, &self.points);
            integrate_momentum(
                &mut self.scatter,
                basis,
                domains,
                points,
                |cell, xg| Self::lookup(values, domains, points, cell, xg)[0],
                grid,
            );
            return;
        }
        let (kind, mesh) = (self.kind, self.grid);
        self.nodal.clear();
        self.nodal.resize(mesh.cells + 1, 0.0);
        let counts = self
            .nodal
            .par_iter_mut()
            .with_min_len(CELLS_PER_TASK)
            .enumerate()
            .map(|(node, out)| {
                let mut counts = RemedyCounts::default();
                let xi = mesh.origin + node as f64 * mesh.h;
                // `|x_p - x_i| < 1.5 h`: cells node - 2 ..= node + 1.
                let range = support(bins, node as isize - 2, node as isize + 1);
                let m = Moments::<1>::gather(xi, mesh.inv_h, range, x, |p| [v[p]]);
                *out = m.fit(kind, 1, &mut counts)[0];
                counts
            })
            .sum();
        self.remedies += counts;
        match self.consistent_velocity_mass() {
            Some(matrix) => matrix.mul_vec(&self.nodal, &mut grid.momentum),
            None => {
                for ((p, m), vi) in grid.momentum.iter_mut().zip(&self.lumped).zip(&self.nodal) {
                    *p = m * vi;
                }
                if self.conjugate_momentum {
                    self.add_momentum_correction(particles, bins, &mut grid.momentum);
                }
            }
        }
    }

    fn strain_increments<B: Basis>(
        &mut self,
        basis: &B,
        particles: &Particles,
        velocity: &[f64],
        dt: f64,
        deps: &mut Vec<f64>,
    ) -> bool {
        if !self.adjoint_strain {
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
        let lumped = self.consistent_velocity_mass().is_none();
        if !(self.conjugate_momentum && lumped && basis.name() == "linear") {
            return false;
        }
        self.conjugate_accelerations(particles, acceleration, out);
        true
    }

    fn remedies(&self) -> RemedyCounts {
        self.remedies
    }
}

/// The fit at a point as a functional of the data: the value is linear in
/// `b_k = sum_p w_p s_p^k f_p`, `value = l_0 b_0 + l_1 b_1 + l_2 b_2`, so every particle
/// enters with the weight `w_p (l_0 + l_1 s_p + l_2 s_p^2)`. Found by fitting the unit
/// right-hand sides (same degree decisions as the fit itself, which depend on `mu` only).
fn functional(kind: MlsKind, mu: &[f64; 5]) -> [f64; 3] {
    let unit = Moments::<3> {
        mu: *mu,
        rhs: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
    };
    unit.fit(kind, 2, &mut RemedyCounts::default())
}

pub mod adjoint;
pub mod conjugate;
#[cfg(test)]
mod tests;
