//! The per-cell fits of the 1D TLS mapping and their repairs (`docs/tls.md`,
//! `docs/reconstruction.md`): the sums of one pass over a cell's particles
//! ([`CellSums`]), a field's coefficients and fit states ([`FieldFit`]), the plain fit of a
//! cell on its first `q + 1` Taylor functions and the repair of degenerate cells by virtual
//! points from the fitted neighbours or by order reduction ([`FitContext`]), the density
//! limiter and the conserved cell totals.

use super::super::quadrature::GaussPoints;
use super::super::RemedyCounts;
use crate::config::DegenerateRemedy;
use crate::grid::Grid;
use crate::numerics::taylor::{
    add_rhs, solve_reduced_with_spread, solve_with_spread, FitKind, NormalMatrix, TaylorCell,
    MIN_SPREAD, REPAIR_MIN_SPREAD,
};
use rayon::prelude::*;

/// Per-cell sums of one pass over the particles of a cell.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct CellSums {
    pub(super) normal: NormalMatrix,
    pub(super) stress_rhs: [f64; 3],
    pub(super) density_rhs: [f64; 3],
    pub(super) momentum_rhs: [f64; 3],
    /// Mass of the cell's particles: given to the left cell, kept, given to the right
    /// cell (all kept with `method.cell_totals = "centres"`).
    pub(super) mass_shares: [f64; 3],
    /// Momentum of the cell's particles, split like the mass.
    pub(super) momentum_shares: [f64; 3],
    /// Twice the kinetic energy `m_p v_p^2` of the cell's particles, split like the mass
    /// (only with `method.momentum_limiter = "kinetic_energy"`).
    pub(super) energy_shares: [f64; 3],
    /// `V_p sigma_p` of the cell's particles, split like the mass (only with
    /// `method.stress_fit = "conservative"`).
    pub(super) stress_shares: [f64; 3],
}

/// State of a cell's fit of one field.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) enum FitState {
    /// No particles: no reconstruction.
    #[default]
    Inactive,
    /// A well-posed fit from the cell's own particles (a source of virtual points).
    Fitted,
    /// Repaired from neighbours or by order reduction.
    Repaired,
}

impl FitState {
    /// The smallest scaled pivot a fit in this state must have: [`MIN_SPREAD`] for a cell
    /// fitted from its own points, the stricter [`REPAIR_MIN_SPREAD`] for a repaired one
    /// (virtual points or order reduction; docs/reconstruction.md, "The repair
    /// threshold"). The fits and the adjoint's pull-back through them both take it from
    /// here.
    pub(super) fn min_spread(self) -> f64 {
        match self {
            FitState::Repaired => REPAIR_MIN_SPREAD,
            FitState::Inactive | FitState::Fitted => MIN_SPREAD,
        }
    }
}

/// One reconstructed field: coefficients, fit states, and scratch for the repairs.
#[derive(Clone, Debug, Default)]
pub(super) struct FieldFit {
    pub(super) coefficients: Vec<[f64; 3]>,
    pub(super) state: Vec<FitState>,
    pub(super) repaired: Vec<(usize, [f64; 3], RemedyCounts)>,
}

impl FieldFit {
    pub(super) fn new(cells: usize) -> Self {
        Self {
            coefficients: vec![[0.0; 3]; cells],
            state: vec![FitState::Inactive; cells],
            repaired: Vec::new(),
        }
    }
}

/// What a fit needs to know about the cells.
pub(super) struct FitContext<'a> {
    pub(super) grid: &'a Grid,
    pub(super) remedy: DegenerateRemedy,
    pub(super) taylor: &'a [TaylorCell],
    pub(super) sums: &'a [CellSums],
    /// Taylor functions of the conservative fits (`method.conservative_degree + 1`).
    pub(super) conservative_terms: usize,
}

impl FitContext<'_> {
    /// The context of the stress fit: a conservative stress fit
    /// (`method.stress_fit = "conservative"`) keeps every Taylor function, whatever
    /// `method.conservative_degree` says for density and momentum.
    pub(super) fn for_stress(&self) -> Self {
        FitContext {
            conservative_terms: 3,
            ..*self
        }
    }

    /// Taylor functions a fit of `kind` starts from: 3 for a full fit,
    /// `conservative_terms` for a conservative one.
    pub(super) fn terms(&self, kind: FitKind) -> usize {
        match kind {
            FitKind::Full => 3,
            FitKind::Conservative(_) => self.conservative_terms,
        }
    }

    /// The plain fit of one cell on its first [`Self::terms`] Taylor functions: its state
    /// and coefficients (the constant `a_1` for a refused conservative fit, 0 for a refused
    /// full fit, until repaired).
    #[inline]
    pub(super) fn plain_fit(
        &self,
        active: bool,
        normal: &NormalMatrix,
        rhs: &[f64; 3],
        kind: FitKind,
    ) -> (FitState, [f64; 3]) {
        if !active {
            return (FitState::Inactive, [0.0; 3]);
        }
        let spread = FitState::Fitted.min_spread();
        match solve_with_spread(normal, rhs, kind, self.terms(kind), spread) {
            Some(a) => (FitState::Fitted, a),
            None => {
                let a1 = match kind {
                    FitKind::Full => 0.0,
                    FitKind::Conservative(a1) => a1,
                };
                (FitState::Repaired, [a1, 0.0, 0.0])
            }
        }
    }

    /// Repair `cell` of `field` (whose plain fit was refused): virtual points from the
    /// fitted neighbours at the shared faces, else order reduction.
    pub(super) fn repair(
        &self,
        field: &FieldFit,
        cell: usize,
        mut rhs: [f64; 3],
        kind: FitKind,
    ) -> ([f64; 3], RemedyCounts) {
        let mut counts = RemedyCounts {
            degenerate_fits: 1,
            ..RemedyCounts::default()
        };
        let mut normal = self.sums[cell].normal;
        let spread = FitState::Repaired.min_spread();
        if self.remedy == DegenerateRemedy::VirtualPoints {
            for (neighbour, face) in self.virtual_points(field, cell).into_iter().flatten() {
                let value = self.taylor[neighbour].eval(&field.coefficients[neighbour], face);
                let psi = self.taylor[cell].psi(face);
                normal.add(&psi);
                add_rhs(&mut rhs, &psi, value);
            }
            if let Some(a) = solve_with_spread(&normal, &rhs, kind, self.terms(kind), spread) {
                counts.virtual_point_fits = 1;
                return (a, counts);
            }
        }
        counts.order_reduced_fits = 1;
        (
            solve_reduced_with_spread(&normal, &rhs, kind, self.terms(kind), spread).0,
            counts,
        )
    }

    /// The virtual points a repair of `cell` takes from its fitted neighbours: `(neighbour,
    /// shared face)`, left then right.
    pub(super) fn virtual_points(
        &self,
        field: &FieldFit,
        cell: usize,
    ) -> [Option<(usize, f64)>; 2] {
        let grid = self.grid;
        let left = cell.checked_sub(1).map(|n| (n, grid.cell_left(cell)));
        let right = (cell + 1 < grid.cells).then(|| (cell + 1, grid.cell_left(cell + 1)));
        [left, right].map(|point| point.filter(|&(n, _)| field.state[n] == FitState::Fitted))
    }

    /// Repair every cell of `field` marked [`FitState::Repaired`] by the plain pass, from
    /// the plain fits of its neighbours (parallel, deterministic), then apply `finish` to
    /// each repaired fit.
    pub(super) fn repair_all<R, K, F>(
        &self,
        field: &mut FieldFit,
        rhs: R,
        kind: K,
        finish: F,
    ) -> RemedyCounts
    where
        R: Fn(usize) -> [f64; 3] + Sync,
        K: Fn(usize) -> FitKind + Sync,
        F: Fn(usize, &mut [f64; 3]) -> u64 + Sync,
    {
        let mut repaired = std::mem::take(&mut field.repaired);
        repaired.clear();
        repaired.extend(
            field
                .state
                .iter()
                .enumerate()
                .filter(|(_, &s)| s == FitState::Repaired)
                .map(|(cell, _)| (cell, [0.0; 3], RemedyCounts::default())),
        );
        let view = &*field;
        repaired.par_iter_mut().for_each(|(cell, a, counts)| {
            let (fit, c) = self.repair(view, *cell, rhs(*cell), kind(*cell));
            *a = fit;
            *counts = c;
            counts.density_limited_fits = finish(*cell, a);
        });
        let mut total = RemedyCounts::default();
        for &(cell, a, counts) in &repaired {
            field.coefficients[cell] = a;
            total += counts;
        }
        field.repaired = repaired;
        total
    }
}

/// Scale `a_2, a_3` of a density fit towards its mean where it dips below zero at a Gauss
/// point of `[lo, hi]`; returns 1 if it did.
#[inline]
pub(super) fn limit_density(
    taylor: &TaylorCell,
    points: &GaussPoints,
    lo: f64,
    hi: f64,
    a: &mut [f64; 3],
) -> u64 {
    if a[0] <= 0.0 {
        return 0;
    }
    let mut lowest = f64::INFINITY;
    points.for_each(lo, hi, |x, _| {
        let value = taylor.eval(a, x);
        lowest = if value < lowest { value } else { lowest };
    });
    if lowest >= 0.0 {
        return 0;
    }
    let theta = a[0] / (a[0] - lowest);
    a[1] *= theta;
    a[2] *= theta;
    1
}

/// Kinetic-energy limiter of a conservative momentum fit (`method.momentum_limiter =
/// "kinetic_energy"`, docs/reconstruction.md "Energy-consistent TLS"): replace the
/// momentum fit `m` of the cell `[lo, hi]` by
///
/// ```text
/// m_theta = theta m + (1 - theta) v_bar rho,   v_bar = m_1 / rho_1 (the cell's mean velocity)
/// ```
///
/// with the largest `theta` in `[0, 1]` for which the kinetic energy of the reconstructed
/// velocity `u = m_theta / rho` at the Gauss points stays within that of the cell's
/// particles, `int rho u^2 <= energy_total = sum_p s_pc m_p v_p^2`. Both terms have the
/// cell's momentum as their integral, so `m_theta` conserves it for any `theta`, and
/// `int rho u^2 = M v_bar^2 + theta^2 int (m - v_bar rho)^2 / rho` (`M` the cell mass)
/// gives `theta` in closed form. With non-negative basis functions the mapped grid
/// velocities then carry no more kinetic energy than the particles (Jensen's inequality
/// at the Gauss points, lumped or consistent mass), as in plain MPM; this needs
/// `rho_hat >= 0` at the Gauss points, which the density limiter gives where the cell has
/// mass (the mapping clears the density fit of a cell without mass when the limiter is
/// on). A density that is not positive at a Gauss point where the fit carries momentum
/// gives `theta = 0`; a cell without mass gets no momentum (`theta = 0`). Returns `theta`
/// (1: the fit is kept).
#[inline]
pub(super) fn limit_momentum(
    taylor: &TaylorCell,
    points: &GaussPoints,
    lo: f64,
    hi: f64,
    density: &[f64; 3],
    energy_total: f64,
    momentum: &mut [f64; 3],
) -> f64 {
    if density[0] <= 0.0 {
        // No mass in the cell (an empty cell inside the material extent): no momentum
        // either (its total is 0, the slopes came from virtual points).
        *momentum = [0.0; 3];
        return 0.0;
    }
    let mean_velocity = momentum[0] / density[0];
    // int (m - v_bar rho)^2 / rho: the energy the fit adds to the mean motion.
    let mut excess = 0.0;
    let mut unbounded = false;
    points.for_each(lo, hi, |x, w| {
        let rho = taylor.eval(density, x);
        let deviation = taylor.eval(momentum, x) - mean_velocity * rho;
        if rho > 0.0 {
            excess += w * deviation * deviation / rho;
        } else if deviation != 0.0 {
            unbounded = true;
        }
    });
    let allowed = energy_total - (hi - lo) * momentum[0] * mean_velocity;
    let theta = if unbounded {
        0.0
    } else if excess <= allowed {
        return 1.0;
    } else if allowed > 0.0 {
        (allowed / excess).sqrt()
    } else {
        0.0
    };
    for j in 1..3 {
        momentum[j] = theta * momentum[j] + (1.0 - theta) * mean_velocity * density[j];
    }
    theta
}

/// The cell's conserved total from its own and its neighbours' shares.
#[inline]
pub(super) fn cell_total(
    sums: &[CellSums],
    cell: usize,
    shares: impl Fn(&CellSums) -> [f64; 3],
) -> f64 {
    let own = shares(&sums[cell])[1];
    let from_left = if cell > 0 {
        shares(&sums[cell - 1])[2]
    } else {
        0.0
    };
    let from_right = if cell + 1 < sums.len() {
        shares(&sums[cell + 1])[0]
    } else {
        0.0
    };
    from_left + own + from_right
}
