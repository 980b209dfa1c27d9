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
//! **Batches.** One parallel pass over the cells builds every cell's normal matrix
//! `D = sum psi psi^T` (shared by all fields) and right-hand sides; one pass solves every
//! cell's 3x3 (full) or 2x2 (conservative) system; the result is a flat `[N_e][3]`
//! coefficient array per field.
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

use super::quadrature::{integrate_mass_and_force, integrate_momentum, CellDomains, GaussPoints};
use super::{CellScatter, GridFields, Mapping, RemedyCounts};
use crate::config::{CellTotals, DegenerateRemedy};
use crate::grid::{Basis, Grid};
use crate::numerics::gauss::GaussRule;
use crate::numerics::taylor::{add_rhs, solve, solve_reduced, FitKind, NormalMatrix, TaylorCell};
use crate::particles::{CellBins, Particles};
use rayon::prelude::*;

/// Cells per rayon task in the batched passes.
const CELLS_PER_TASK: usize = 128;

/// Per-cell sums of one pass over the particles.
#[derive(Clone, Copy, Debug, Default)]
struct CellSums {
    normal: NormalMatrix,
    stress_rhs: [f64; 3],
    density_rhs: [f64; 3],
    /// The cell's conserved mass total `c_e`.
    mass: f64,
    /// Mass of the cell's particles given to the left cell, kept, given to the right cell
    /// (`method.cell_totals = "domains"`).
    mass_shares: [f64; 3],
}

/// Per-cell sums of the momentum pass.
#[derive(Clone, Copy, Debug, Default)]
struct MomentumSums {
    rhs: [f64; 3],
    /// The cell's conserved momentum total `c_e`.
    total: f64,
    /// Like [`CellSums::mass_shares`].
    shares: [f64; 3],
}

/// Outcome of the first fit of a cell.
#[derive(Clone, Copy, Debug, PartialEq)]
enum FirstFit {
    Inactive,
    Fitted([f64; 3]),
    Degenerate,
}

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
    /// Per cell the momentum right-hand side and `sum_p m_p v_p`.
    momentum_sums: Vec<MomentumSums>,
    first_fit: Vec<FirstFit>,
    /// Stress coefficients `[N_e][3]`.
    pub stress: Vec<[f64; 3]>,
    /// Density coefficients `[N_e][3]`.
    pub density: Vec<[f64; 3]>,
    /// Momentum-density coefficients `[N_e][3]`.
    pub momentum: Vec<[f64; 3]>,
    remedies: RemedyCounts,
    scatter: CellScatter,
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
            momentum_sums: vec![MomentumSums::default(); cells],
            first_fit: vec![FirstFit::Inactive; cells],
            stress: vec![[0.0; 3]; cells],
            density: vec![[0.0; 3]; cells],
            momentum: vec![[0.0; 3]; cells],
            remedies: RemedyCounts::default(),
            scatter: CellScatter::default(),
        })
    }

    /// The active part of each cell used by the last mapping.
    pub fn domains(&self) -> &CellDomains {
        &self.domains
    }

    /// The Taylor basis of cell `cell` in the last mapping.
    pub fn taylor_cell(&self, cell: usize) -> &TaylorCell {
        &self.taylor[cell]
    }

    /// Bin-wise sums for stress and density, and the cell domains.
    fn accumulate(&mut self, particles: &Particles, bins: &CellBins) {
        let by_domains = self.totals == CellTotals::Domains;
        self.domains
            .update(&self.grid, particles, bins, !by_domains);
        let (domains, grid) = (&self.domains, &self.grid);
        let (x, stress, mass, volume) = (
            &particles.x,
            &particles.stress,
            &particles.mass,
            &particles.volume,
        );
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
                *taylor = TaylorCell::new(domains.lo[cell], domains.hi[cell]);
                for p in bins.range(cell) {
                    let psi = taylor.psi(x[p]);
                    sums.normal.add(&psi);
                    add_rhs(&mut sums.stress_rhs, &psi, stress[p]);
                    add_rhs(&mut sums.density_rhs, &psi, mass[p] / volume[p]);
                    sums.mass += mass[p];
                    if by_domains {
                        add_shares(&mut sums.mass_shares, grid, cell, x[p], volume[p], mass[p]);
                    }
                }
            });
        if by_domains {
            let sums = &mut self.sums;
            for cell in 0..sums.len() {
                let [left, right] =
                    neighbour_shares(cell, sums.len(), |e, k| sums[e].mass_shares[k]);
                sums[cell].mass = left + sums[cell].mass_shares[1] + right;
            }
        }
    }

    /// Scale the density fits towards their mean where they dip below zero at a Gauss
    /// point (conservative positivity limiter).
    fn limit_density(&mut self) -> u64 {
        let (domains, taylor, points) = (&self.domains, &self.taylor, &self.points);
        self.density
            .par_iter_mut()
            .with_min_len(CELLS_PER_TASK)
            .enumerate()
            .map(|(cell, a)| {
                if !domains.is_active(cell) || a[0] <= 0.0 {
                    return 0;
                }
                let mut lowest = f64::INFINITY;
                points.for_each(domains.lo[cell], domains.hi[cell], |x, _| {
                    lowest = lowest.min(taylor[cell].eval(a, x));
                });
                if lowest >= 0.0 {
                    return 0;
                }
                let theta = a[0] / (a[0] - lowest);
                a[1] *= theta;
                a[2] *= theta;
                1
            })
            .sum()
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

/// What the neighbours of `cell` give it: `[left cell's right share, right cell's left
/// share]`, with `share(e, k)` reading cell `e`'s shares.
#[inline]
fn neighbour_shares(cell: usize, cells: usize, share: impl Fn(usize, usize) -> f64) -> [f64; 2] {
    [
        if cell > 0 { share(cell - 1, 2) } else { 0.0 },
        if cell + 1 < cells {
            share(cell + 1, 0)
        } else {
            0.0
        },
    ]
}

/// Fit one field in every active cell, in two batched passes: plain fits, then the
/// remedies of the degenerate cells from their well-posed neighbours. `rhs(cell)` is the
/// field's right-hand side, `kind(cell)` full or conservative.
#[allow(clippy::too_many_arguments)]
fn fit_field<R, K>(
    grid: &Grid,
    remedy: DegenerateRemedy,
    domains: &CellDomains,
    taylor: &[TaylorCell],
    sums: &[CellSums],
    rhs: R,
    kind: K,
    first_fit: &mut [FirstFit],
    coefficients: &mut [[f64; 3]],
) -> RemedyCounts
where
    R: Fn(usize) -> [f64; 3] + Sync,
    K: Fn(usize) -> FitKind + Sync,
{
    first_fit
        .par_iter_mut()
        .with_min_len(CELLS_PER_TASK)
        .enumerate()
        .for_each(|(cell, first)| {
            *first = if !domains.is_active(cell) {
                FirstFit::Inactive
            } else {
                match solve(&sums[cell].normal, &rhs(cell), kind(cell), 3) {
                    Some(a) => FirstFit::Fitted(a),
                    None => FirstFit::Degenerate,
                }
            };
        });
    let first_fit = &*first_fit;
    coefficients
        .par_iter_mut()
        .with_min_len(CELLS_PER_TASK)
        .enumerate()
        .map(|(cell, a)| {
            let mut counts = RemedyCounts::default();
            *a = match first_fit[cell] {
                FirstFit::Inactive => [0.0; 3],
                FirstFit::Fitted(fitted) => fitted,
                FirstFit::Degenerate => {
                    counts.degenerate_fits = 1;
                    let mut normal = sums[cell].normal;
                    let mut b = rhs(cell);
                    let mut repaired = None;
                    if remedy == DegenerateRemedy::VirtualPoints {
                        // Neighbour cells and the faces they share with `cell`.
                        let left = cell.checked_sub(1).map(|n| (n, grid.cell_left(cell)));
                        let right =
                            (cell + 1 < grid.cells).then(|| (cell + 1, grid.cell_left(cell + 1)));
                        for (neighbour, face) in left.into_iter().chain(right) {
                            if let FirstFit::Fitted(an) = first_fit[neighbour] {
                                let value = taylor[neighbour].eval(&an, face);
                                let psi = taylor[cell].psi(face);
                                normal.add(&psi);
                                add_rhs(&mut b, &psi, value);
                            }
                        }
                        repaired = solve(&normal, &b, kind(cell), 3);
                    }
                    match repaired {
                        Some(fitted) => {
                            counts.virtual_point_fits = 1;
                            fitted
                        }
                        None => {
                            counts.order_reduced_fits = 1;
                            solve_reduced(&normal, &b, kind(cell)).0
                        }
                    }
                }
            };
            counts
        })
        .reduce(RemedyCounts::default, |mut a, b| {
            a += b;
            a
        })
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
        self.accumulate(particles, bins);
        let Self {
            grid: mesh,
            remedy,
            domains,
            taylor,
            sums,
            first_fit,
            stress,
            density,
            ..
        } = self;
        let sums_ref = &*sums;
        let mut counts = fit_field(
            mesh,
            *remedy,
            domains,
            taylor,
            sums_ref,
            |cell| sums_ref[cell].stress_rhs,
            |_| FitKind::Full,
            first_fit,
            stress,
        );
        let domains_ref = &*domains;
        counts += fit_field(
            mesh,
            *remedy,
            domains,
            taylor,
            sums_ref,
            |cell| sums_ref[cell].density_rhs,
            |cell| FitKind::Conservative(sums_ref[cell].mass / domains_ref.length(cell)),
            first_fit,
            density,
        );
        counts.density_limited_fits = self.limit_density();
        self.remedies += counts;
        let (taylor, stress, density) = (&self.taylor, &self.stress, &self.density);
        integrate_mass_and_force(
            &mut self.scatter,
            basis,
            &self.domains,
            &self.points,
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
        let (x, mass, volume, v) = (
            &particles.x,
            &particles.mass,
            &particles.volume,
            &particles.v,
        );
        let (domains, taylor, mesh) = (&self.domains, &self.taylor, &self.grid);
        let by_domains = self.totals == CellTotals::Domains;
        self.momentum_sums
            .par_iter_mut()
            .with_min_len(CELLS_PER_TASK)
            .enumerate()
            .for_each(|(cell, sums)| {
                *sums = MomentumSums::default();
                if !domains.is_active(cell) {
                    return;
                }
                for p in bins.range(cell) {
                    let psi = taylor[cell].psi(x[p]);
                    let momentum = mass[p] * v[p];
                    add_rhs(&mut sums.rhs, &psi, momentum / volume[p]);
                    sums.total += momentum;
                    if by_domains {
                        add_shares(&mut sums.shares, mesh, cell, x[p], volume[p], momentum);
                    }
                }
            });
        if by_domains {
            let sums = &mut self.momentum_sums;
            for cell in 0..sums.len() {
                let [left, right] = neighbour_shares(cell, sums.len(), |e, k| sums[e].shares[k]);
                sums[cell].total = left + sums[cell].shares[1] + right;
            }
        }
        let momentum_sums = &self.momentum_sums;
        let counts = fit_field(
            &self.grid,
            self.remedy,
            domains,
            taylor,
            &self.sums,
            |cell| momentum_sums[cell].rhs,
            |cell| FitKind::Conservative(momentum_sums[cell].total / domains.length(cell)),
            &mut self.first_fit,
            &mut self.momentum,
        );
        self.remedies += counts;
        let (taylor, momentum) = (&self.taylor, &self.momentum);
        integrate_momentum(
            &mut self.scatter,
            basis,
            &self.domains,
            &self.points,
            |cell, x| taylor[cell].eval(&momentum[cell], x),
            grid,
        );
    }

    fn remedies(&self) -> RemedyCounts {
        self.remedies
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{BSplineBasis, DdmpmBasis, LinearBasis, ParticleQuadrature};
    use crate::linalg::CsrMatrix;
    use proptest::prelude::*;

    /// Particles with `counts[e]` particles in cell `e` at relative positions from
    /// `jitter`, random-ish masses, volumes, stresses and velocities; binned.
    fn layout(grid: &Grid, counts: &[usize], jitter: &[f64]) -> (Particles, CellBins) {
        let mut p = Particles::default();
        let mut k = 0;
        for (e, &n) in counts.iter().enumerate() {
            for j in 0..n {
                let t = (j as f64 + 0.05 + 0.9 * jitter[k % jitter.len()]) / n as f64;
                let x = grid.cell_left(e) + t * grid.h;
                let volume = grid.h / n as f64 * (0.6 + 0.8 * jitter[(k + 7) % jitter.len()]);
                let density = 1.0 + jitter[(k + 3) % jitter.len()];
                p.id.push(k);
                p.x0.push(x);
                p.x.push(x);
                p.u.push(0.0);
                p.v.push((3.0 * x).sin() - 0.2);
                p.stress.push((2.0 * x).cos());
                p.volume.push(volume);
                p.density.push(density);
                p.mass.push(density * volume);
                p.cell.push(e);
                k += 1;
            }
        }
        let mut bins = CellBins::default();
        bins.sort(&mut p, grid.cells);
        (p, bins)
    }

    fn totals<B: Basis>(
        basis: &B,
        mapping: &mut TlsMapping,
        particles: &Particles,
        bins: &CellBins,
    ) -> ([f64; 3], [f64; 3]) {
        let mut fields = GridFields::new(basis.num_dofs());
        fields.consistent_mass = Some(CsrMatrix::band(basis.num_dofs(), basis.max_window() - 1));
        mapping.map_mass_and_internal_force(basis, particles, bins, &mut fields);
        mapping.map_momentum(basis, particles, bins, &mut fields);
        let grid_mass: f64 = fields.mass.iter().sum();
        let matrix_mass: f64 = fields
            .consistent_mass
            .as_ref()
            .map_or(0.0, |m| m.values.iter().sum());
        let grid_momentum: f64 = fields.momentum.iter().sum();
        let all_finite = fields
            .mass
            .iter()
            .chain(&fields.internal_force)
            .chain(&fields.momentum)
            .all(|v| v.is_finite());
        assert!(all_finite, "non-finite grid vector");
        let n = particles.len();
        let mass: f64 = (0..n).map(|p| particles.mass[p]).sum();
        let momentum: f64 = (0..n).map(|p| particles.mass[p] * particles.v[p]).sum();
        let scale: f64 = (0..n)
            .map(|p| particles.mass[p] * particles.v[p].abs())
            .sum();
        (
            [grid_mass, matrix_mass, grid_momentum],
            [mass, momentum, scale],
        )
    }

    fn check_conservation<B: Basis>(
        basis: &B,
        grid: Grid,
        particles: &Particles,
        bins: &CellBins,
    ) -> Result<(), TestCaseError> {
        for totals_rule in [CellTotals::Centres, CellTotals::Domains] {
            for remedy in [
                DegenerateRemedy::VirtualPoints,
                DegenerateRemedy::OrderReduction,
            ] {
                let mut mapping = TlsMapping::new(grid, 4, remedy, totals_rule).unwrap();
                let ([m_grid, m_matrix, p_grid], [m, p, scale]) =
                    totals(basis, &mut mapping, particles, bins);
                prop_assert!(
                    (m_grid - m).abs() <= 1e-13 * m,
                    "{:?} mass {} vs {}",
                    totals_rule,
                    m_grid,
                    m
                );
                prop_assert!(
                    (m_matrix - m).abs() <= 1e-13 * m,
                    "{:?} M^C mass {} vs {}",
                    totals_rule,
                    m_matrix,
                    m
                );
                prop_assert!(
                    (p_grid - p).abs() <= 1e-13 * scale,
                    "{:?} momentum {} vs {}",
                    totals_rule,
                    p_grid,
                    p
                );
            }
        }
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// Mass (lumped and consistent) and momentum mapped by TLS equal the particle
        /// totals to round-off for random layouts with 3+ or 1–2 particles per cell, every
        /// basis, both cell-total rules and both degenerate-cell remedies.
        #[test]
        fn mapping_conserves_mass_and_momentum(cells in 2usize..10, sparse in any::<bool>(),
                                               counts in prop::collection::vec(0usize..6, 10),
                                               jitter in prop::collection::vec(0.0f64..1.0, 40),
                                               order in 1usize..4) {
            let grid = Grid::new(2.0, cells);
            let counts: Vec<usize> = counts[..cells]
                .iter()
                .map(|&c| if sparse { 1 + c % 2 } else { 3 + c })
                .collect();
            let (particles, bins) = layout(&grid, &counts, &jitter);
            check_conservation(&LinearBasis::new(grid), grid, &particles, &bins)?;
            check_conservation(&BSplineBasis::new(grid, order).unwrap(), grid, &particles, &bins)?;
            let mut ddmpm = DdmpmBasis::new(grid);
            ddmpm.update(ParticleQuadrature { x: &particles.x, volume: &particles.volume, cell_start: &bins.cell_start });
            check_conservation(&ddmpm, grid, &particles, &bins)?;
        }

        /// A quadratic stress field sampled at 3+ particles per cell is reconstructed
        /// exactly by the full fit.
        #[test]
        fn quadratic_fields_are_reconstructed_exactly(cells in 1usize..8,
                                                      counts in prop::collection::vec(3usize..7, 8),
                                                      jitter in prop::collection::vec(0.0f64..1.0, 40),
                                                      c in prop::array::uniform3(-1.0f64..1.0)) {
            let grid = Grid::new(3.0, cells);
            let (mut particles, bins) = layout(&grid, &counts[..cells], &jitter);
            let q = |x: f64| 2.0 + c[0] + c[1] * x + c[2] * x * x;
            for p in 0..particles.len() {
                particles.stress[p] = q(particles.x[p]);
            }
            let basis = LinearBasis::new(grid);
            let mut mapping = TlsMapping::new(grid, 3, DegenerateRemedy::VirtualPoints, CellTotals::Centres).unwrap();
            let mut fields = GridFields::new(basis.num_dofs());
            mapping.map_mass_and_internal_force(&basis, &particles, &bins, &mut fields);
            for e in 0..cells {
                let taylor = mapping.taylor_cell(e);
                for t in [0.0, 0.3, 1.0] {
                    let x = grid.cell_left(e) + t * grid.h;
                    let x = x.clamp(mapping.domains().lo[e], mapping.domains().hi[e]);
                    let value = taylor.eval(&mapping.stress[e], x);
                    prop_assert!((value - q(x)).abs() < 1e-9, "cell {} x {}: {} vs {}", e, x, value, q(x));
                }
            }
        }
    }

    #[test]
    fn one_particle_cells_are_repaired_without_nan() {
        let grid = Grid::new(1.0, 6);
        let (particles, bins) = layout(&grid, &[1, 1, 4, 1, 0, 2], &[0.3, 0.8, 0.1, 0.6, 0.5]);
        let basis = BSplineBasis::new(grid, 2).unwrap();
        let mut mapping = TlsMapping::new(
            grid,
            4,
            DegenerateRemedy::VirtualPoints,
            CellTotals::Centres,
        )
        .unwrap();
        let ([m_grid, _, _], [m, _, _]) = totals(&basis, &mut mapping, &particles, &bins);
        assert!((m_grid - m).abs() < 1e-14 * m);
        let remedies = mapping.remedies();
        assert!(remedies.degenerate_fits > 0, "{remedies:?}");
        assert!(remedies.virtual_point_fits > 0, "{remedies:?}");
        // The empty cell has no reconstruction.
        assert_eq!(mapping.stress[4], [0.0; 3]);
        assert!(!mapping.domains().is_active(4));
    }
}
