//! Unit tests of the 2D/3D TLS mapping: conservation, fits, remedies and cell shares.

use super::cells::split_shares;
use super::*;
use crate::grid::{BSplineBasis, GimpBasis, LinearBasis};
use proptest::prelude::*;

/// Particles of volume `volume` at `x` (2D) with velocities and stresses from `seed`.
/// Mass and force of `p` (no body force) on fresh grid fields.
pub(super) fn map_at_rest<B: Basis>(
    mapping: &mut TensorTlsMapping<2>,
    basis: &TensorBasis<2, B>,
    p: &TensorParticles<2>,
    start: &[usize],
) -> TensorGridFields<2> {
    let mut fields = TensorGridFields::new(basis.num_dofs());
    let body = TensorBody::Uniform([0.0; 2]);
    mapping
        .map_mass_and_force(basis, p, start, body, &mut fields)
        .unwrap();
    fields
}

fn particles(x: [Vec<f64>; 2], grid: &TensorGrid<2>, seed: &[f64]) -> TensorParticles<2> {
    let n = x[0].len();
    let mut p =
        TensorParticles::<2>::at_rest(x, vec![0.01; n], 2.0, |x| grid.cell_of(x).unwrap_or(0));
    for k in 0..n {
        let s = seed[k % seed.len()];
        p.v[0][k] = s;
        p.v[1][k] = 1.0 - 2.0 * s * s;
        p.stress[0][k] = 3.0 * s;
        p.stress[3][k] = s - 0.5;
        p.mass[k] *= 1.0 + s.abs();
    }
    p
}

fn check<B: Basis + Clone>(
    basis: TensorBasis<2, B>,
    mut p: TensorParticles<2>,
    totals: CellTotals,
    domain: bool,
    conservative_degree: usize,
) -> std::result::Result<(), TestCaseError> {
    let (mut start, mut order) = (Vec::new(), Vec::new());
    p.sort_by_cell(basis.grid.num_cells(), &mut start, &mut order);
    let mut mapping = TensorTlsMapping::new(&basis, 4, totals, [0.02, 0.02], domain)
        .unwrap()
        .with_conservative_degree(conservative_degree);
    let mut fields = map_at_rest(&mut mapping, &basis, &p, &start);
    mapping
        .map_momentum(&basis, &p, &start, &mut fields)
        .unwrap();
    let total: f64 = p.mass.iter().sum();
    let grid_mass: f64 = fields.mass.iter().sum();
    prop_assert!(
        (grid_mass - total).abs() <= 1e-13 * total,
        "mass {grid_mass} vs {total}"
    );
    prop_assert!(
        fields.mass.iter().all(|&m| m >= -1e-15 * total),
        "negative mass"
    );
    let scale: f64 = (0..p.len())
        .map(|k| p.mass[k] * (p.v[0][k].hypot(p.v[1][k])))
        .sum();
    for a in 0..2 {
        let particle: f64 = (0..p.len()).map(|k| p.mass[k] * p.v[a][k]).sum();
        let grid: f64 = fields.momentum.iter().map(|m| m[a]).sum();
        prop_assert!(
            (grid - particle).abs() <= 1e-13 * scale,
            "momentum {a}: {grid} vs {particle}"
        );
    }
    prop_assert!(fields
        .force
        .iter()
        .all(|f| f[0].is_finite() && f[1].is_finite()));
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    /// Random layouts with sparse and degenerate cells (1–3 particles, a row of
    /// particles on one line): mass and both momentum components are conserved to
    /// round-off, masses stay non-negative, nothing is NaN (conservative fits of
    /// degree 0, 1 and 2).
    #[test]
    fn random_and_degenerate_layouts_conserve(
        xs in proptest::collection::vec((0.0f64..1.0, 0.0f64..1.0), 1..40),
        line_y in 0.05f64..0.95,
        line in proptest::collection::vec(0.0f64..1.0, 0..12),
        seed in proptest::collection::vec(-1.0f64..1.0, 1..8),
        order in 1usize..4,
    ) {
        let grid = TensorGrid::new([1.0, 1.0], [5, 4]);
        let mut x = [Vec::new(), Vec::new()];
        for (a, b) in &xs {
            x[0].push(*a);
            x[1].push(*b);
        }
        for a in &line {
            x[0].push(*a);
            x[1].push(line_y);
        }
        for totals in [CellTotals::Domains, CellTotals::Centres] {
            for degree in 0..=2 {
                let b = TensorBasis::new(grid, |g| BSplineBasis::new(g, order).unwrap());
                check(b, particles(x.clone(), &grid, &seed), totals, false, degree)?;
            }
            check(TensorBasis::new(grid, LinearBasis::new), particles(x.clone(), &grid, &seed), totals, false, 1)?;
            check(TensorBasis::new(grid, GimpBasis::new), particles(x.clone(), &grid, &seed), totals, true, 2)?;
        }
    }
}

#[test]
fn shares_add_up_to_the_particle_quantity() {
    let grid = TensorGrid::new([1.0, 1.0, 1.0], [4, 4, 4]);
    let mut out = vec![[0.0; 4]; 27];
    // Near the corner of cell (1, 1, 1): its domain reaches into 7 neighbours.
    split_shares(
        &grid,
        [1, 1, 1],
        [0.26, 0.49, 0.27],
        [0.05; 3],
        [1.0, 2.0, -3.0, 0.0],
        &mut out,
    );
    let sum: Vec<f64> = (0..3).map(|c| out.iter().map(|o| o[c]).sum()).collect();
    assert!(
        (sum[0] - 1.0).abs() < 1e-15
            && (sum[1] - 2.0).abs() < 1e-15
            && (sum[2] + 3.0).abs() < 1e-15
    );
    let touched = out.iter().filter(|o| o[0] != 0.0).count();
    assert_eq!(touched, 8);
    // Kept part: the overlap fractions of the cell along x, y, z.
    let kept = out[13][0];
    assert!((kept - 0.6 * 0.6 * 0.7).abs() < 1e-12, "{kept}");
}

/// The square terms are the ones worth -1/6 at the box centre.
#[test]
fn square_terms_are_found() {
    fn check<const D: usize>() {
        let t = crate::numerics::taylor_nd::terms_of([0.0; D]);
        for k in 1..crate::numerics::taylor_nd::terms(D, 2) {
            assert_eq!(
                cells::is_square_term::<D>(k),
                t[k] == -1.0 / 6.0,
                "D = {D}, k = {k}"
            );
        }
    }
    check::<1>();
    check::<2>();
    check::<3>();
}

proptest! {
    /// The limiter leaves a density fit alone only if it is non-negative at every Gauss
    /// point, and otherwise makes it so (2D, coefficients near the bound of its shortcut).
    #[test]
    fn limited_densities_are_non_negative_at_the_gauss_points(
        mean in 0.1f64..2.0,
        others in proptest::collection::vec(-1.0f64..1.0, 5),
        scale in 0.0f64..1.5,
    ) {
        let taylor = TaylorBox::new([0.0, 1.0], [0.5, 1.2]);
        let gauss = GaussRule::new(4).unwrap();
        let rule = BoxRule::new(&gauss, [0.0, 1.0], [0.5, 1.2]);
        let mut a = [0.0; MAX_TERMS];
        a[0] = mean;
        let norm: f64 = others.iter().map(|c| c.abs()).sum();
        for (k, c) in others.iter().enumerate() {
            a[1 + k] = c * scale * mean / norm.max(1e-12);
        }
        let before = a;
        let limited = cells::limit_density(&taylor, &gauss, ([0.0, 1.0], [0.5, 1.2]), &mut a);
        let mut lowest = f64::INFINITY;
        rule.for_each(|x, _| lowest = lowest.min(dot::<2>(&a, &taylor.terms(x))));
        prop_assert!(lowest >= -1e-14 * mean, "lowest {lowest}");
        if limited == 0 {
            prop_assert_eq!(a, before);
        }
    }
}
