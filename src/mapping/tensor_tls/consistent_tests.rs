//! Unit tests of the consistent mass `M^C` of the 2D/3D TLS mapping.

use super::tests::map_at_rest;
use super::*;
use crate::grid::BSplineBasis;

#[test]
fn consistent_mass_is_symmetric_and_its_row_sums_are_the_lumped_masses() {
    let grid = TensorGrid::new([1.0, 1.0], [6, 5]);
    let basis = TensorBasis::new(grid, |g| BSplineBasis::new(g, 2).unwrap());
    let mut x = [Vec::new(), Vec::new()];
    for k in 0..90 {
        let t = k as f64 * 0.618_033_988_75;
        x[0].push(t.fract() * 0.8 + 0.1);
        x[1].push((t * 1.7).fract() * 0.9 + 0.05);
    }
    let n = x[0].len();
    let mut p =
        TensorParticles::<2>::at_rest(x, vec![0.011; n], 2.0, |x| grid.cell_of(x).unwrap_or(0));
    for k in 0..n {
        p.mass[k] *= 1.0 + 0.3 * (k as f64).sin();
    }
    let (mut start, mut order) = (Vec::new(), Vec::new());
    p.sort_by_cell(grid.num_cells(), &mut start, &mut order);
    let mut mapping = TensorTlsMapping::new(&basis, 4, CellTotals::Domains, [0.04, 0.05], false)
        .unwrap()
        .with_consistent_mass(&basis)
        .unwrap();
    let fields = map_at_rest(&mut mapping, &basis, &p, &start);
    let m = mapping.consistent_mass().unwrap();
    let dense = m.to_dense();
    let largest = fields.mass.iter().copied().fold(0.0, f64::max);
    for i in 0..m.rows {
        let row: f64 = dense[i].iter().sum();
        assert!((row - fields.mass[i]).abs() <= 1e-14 * largest, "row {i}");
        for j in 0..m.rows {
            assert!(
                (dense[i][j] - dense[j][i]).abs() <= 1e-15 * largest,
                "{i} {j}"
            );
        }
    }
}
