//! DDMPM with sub-points (SPEC §3.3; Dhakal & Zhang 2016): the particle quadrature of the
//! direct mapping spread over `N = method.subpoints` points per particle.
//!
//! Sub-point `k` of particle `p` lies evenly inside the particle domain
//! `[x_p - V_p/2, x_p + V_p/2]`, clipped to the grid `[0, L]`,
//!
//! ```text
//! x_pk = clip(x_p + ((k + 1/2)/N - 1/2) V_p),     k = 0 .. N-1,
//! ```
//!
//! and carries `m_p/N`, `V_p/N` and the particle's stress and velocity:
//!
//! ```text
//! m_i     = sum_p sum_k (m_p/N) phi_i(x_pk)
//! f_int_i = sum_p sum_k sigma_p grad_i(x_pk) V_p/N        (grad_bar for DDMPM)
//! p_i     = sum_p sum_k (m_p/N) v_p phi_i(x_pk)
//! M^C_ij  = sum_p sum_k (m_p/N) phi_i(x_pk) phi_j(x_pk)
//! ```
//!
//! Each sub-point is evaluated in its own cell (`Basis::eval_particle` with the sub-domain
//! half-length `V_p/(2N)`, which only matters for GIMP/CPDI), so the particle velocity and
//! strain updates (SPEC §2 steps 3 and 6) stay at the particle positions as in DDMPM. With
//! a partition-of-unity basis, `sum_i m_i = sum_p m_p` and `sum_i p_i = sum_p m_p v_p` to
//! round-off; `N = 1` is the direct mapping bit for bit.
//!
//! **Race-free scatter**: a sub-point may fall in a neighbouring cell, whose DOFs lie
//! outside the particle cell's window. Instead of widening the window, sub-points are
//! binned by *their own* cell: the [`CellScatter`] kernel of cell `c` scans the particles
//! of cells `c - r ..= c + r` (a contiguous range of the sorted bins, `r` the largest
//! particle half-length in cells, plus one) and keeps exactly the sub-points whose clipped
//! position lies in `c` (the same `Grid::cell_of` test for every cell, so each sub-point
//! is counted once). All contributions of a cell are summed in particle then sub-point
//! order and the cells are reduced in increasing order: bitwise identical results for any
//! thread count, and no per-particle allocation.
//!
//! [`Mapping::name`] is `"subpoints"` (the summary and plots say which mapping ran;
//! the scenario key stays `method.reconstruction = "none"` with `method.subpoints = N`).

use super::points::{map_mass_and_force, map_momentum, PointSet};
use super::{CellScatter, GridFields, Mapping};
use crate::grid::{Basis, Grid};
use crate::particles::{CellBins, Particles};

/// Direct particle quadrature over `N` sub-points per particle.
#[derive(Clone, Debug)]
pub struct SubpointMapping {
    grid: Grid,
    subpoints: usize,
    scatter: CellScatter,
}

impl SubpointMapping {
    /// `subpoints` sub-points per particle on `grid` (0 is taken as 1).
    pub fn new(grid: Grid, subpoints: usize) -> Self {
        Self {
            grid,
            subpoints: subpoints.max(1),
            scatter: CellScatter::default(),
        }
    }

    /// Sub-points per particle.
    pub fn subpoints(&self) -> usize {
        self.subpoints
    }
}

/// The sub-points of the particles, found cell by cell (see the module doc).
#[derive(Clone, Copy)]
struct Subpoints<'a> {
    grid: Grid,
    n: usize,
    /// `1 / N` (exact for `N = 1`, so one sub-point is the direct mapping bit for bit).
    inv_n: f64,
    /// Cells scanned on each side of a cell.
    reach: usize,
    x: &'a [f64],
    volume: &'a [f64],
    cell_start: &'a [usize],
}

impl<'a> Subpoints<'a> {
    fn new(grid: Grid, n: usize, particles: &'a Particles, bins: &'a CellBins) -> Self {
        // Largest half-length in cells, plus one for rounding; sub-points lie strictly
        // inside the particle domain. (A non-finite volume gives non-finite sub-points,
        // which belong to no cell; the stepper reports the non-finite state.)
        let largest =
            particles.volume.iter().fold(
                0.0f64,
                |m, &v| if v.is_finite() { m.max(v.abs()) } else { m },
            );
        let cells = grid.cells;
        let reach = 0.5 * largest * grid.inv_h + 1.0;
        let reach = if reach < cells as f64 {
            reach as usize
        } else {
            cells
        };
        Self {
            grid,
            n,
            inv_n: 1.0 / n as f64,
            reach,
            x: &particles.x,
            volume: &particles.volume,
            cell_start: &bins.cell_start,
        }
    }

    /// Sub-point `k` of particle `p`, clipped to the grid.
    #[inline]
    fn position(&self, p: usize, k: usize) -> f64 {
        let offset = (k as f64 + 0.5) * self.inv_n - 0.5;
        let x = self.x[p] + offset * self.volume[p];
        x.clamp(self.grid.origin, self.grid.origin + self.grid.length)
    }

    /// The sub-point indices of particle `p` that may lie in `cell` (a superset, one index
    /// wider on each side; every candidate is then tested with `Grid::cell_of`).
    #[inline]
    fn candidates(&self, p: usize, cell: usize) -> std::ops::Range<usize> {
        let n = self.n as f64;
        let (x, v) = (self.x[p], self.volume[p]);
        // Zero, negative or NaN volumes: test every sub-point.
        if v.is_nan() || v <= 0.0 {
            return 0..self.n;
        }
        // Real sub-point index at position y: k(y) = ((y - x_p)/V_p + 1/2) N - 1/2.
        let index = |y: f64| ((y - x) / v + 0.5) * n - 0.5;
        let left = self.grid.cell_left(cell);
        let (lo, hi) = (index(left), index(left + self.grid.h));
        if !(lo.is_finite() && hi.is_finite()) {
            return 0..self.n;
        }
        // Clipped sub-points belong to the end cells.
        let first = if cell == 0 {
            0
        } else {
            lo.floor().clamp(0.0, n) as usize
        };
        let last = if cell + 1 == self.grid.cells {
            self.n
        } else {
            (hi.floor() + 2.0).clamp(0.0, n) as usize
        };
        first..last.max(first)
    }
}

impl PointSet for Subpoints<'_> {
    #[inline]
    fn weight(&self) -> f64 {
        self.inv_n
    }

    /// Call `f(p, x_pk)` for every sub-point in `cell`, in particle then sub-point order.
    ///
    /// Fast paths (both decided with a margin far above round-off, so they agree with the
    /// exact `Grid::cell_of` test): a particle domain clearly outside the cell is skipped,
    /// one clearly inside it has all its sub-points there.
    #[inline]
    fn for_each_in<F: FnMut(usize, f64)>(&self, cell: usize, mut f: F) {
        let grid = &self.grid;
        let cells = grid.cells;
        let from = self.cell_start[cell.saturating_sub(self.reach)];
        let to = self.cell_start[(cell + self.reach + 1).min(cells)];
        let margin = 1e-9 * grid.h;
        let left = grid.cell_left(cell);
        // Clipped sub-points belong to the end cells: those extend to infinity.
        let lower = if cell == 0 { f64::NEG_INFINITY } else { left };
        let upper = if cell + 1 == cells {
            f64::INFINITY
        } else {
            left + grid.h
        };
        for p in from..to {
            // |V_p|: a (broken) negative volume mirrors the sub-points, same span.
            let half = 0.5 * self.volume[p].abs();
            let (lo, hi) = (self.x[p] - half, self.x[p] + half);
            if hi < lower - margin || lo > upper + margin {
                continue;
            }
            if lo > lower + margin && hi < upper - margin {
                for k in 0..self.n {
                    f(p, self.position(p, k));
                }
                continue;
            }
            for k in self.candidates(p, cell) {
                let x = self.position(p, k);
                if grid.cell_of(x) == Some(cell) {
                    f(p, x);
                }
            }
        }
    }
}

impl Mapping for SubpointMapping {
    fn name(&self) -> &'static str {
        "subpoints"
    }

    fn map_mass_and_internal_force<B: Basis>(
        &mut self,
        basis: &B,
        particles: &Particles,
        bins: &CellBins,
        grid: &mut GridFields,
    ) {
        let points = Subpoints::new(self.grid, self.subpoints, particles, bins);
        map_mass_and_force(&mut self.scatter, basis, &points, particles, bins, grid);
    }

    fn map_momentum<B: Basis>(
        &mut self,
        basis: &B,
        particles: &Particles,
        bins: &CellBins,
        grid: &mut GridFields,
    ) {
        let points = Subpoints::new(self.grid, self.subpoints, particles, bins);
        map_momentum(&mut self.scatter, basis, &points, particles, bins, grid);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{DdmpmBasis, LinearBasis, ParticleQuadrature, Shape};
    use crate::linalg::CsrMatrix;
    use crate::mapping::DirectMapping;
    use proptest::prelude::*;

    /// `per_cell` particles per cell at jittered positions with volumes `scale * h /
    /// per_cell` (scale > 1 makes the domains overlap and reach into neighbouring cells),
    /// random velocities and stresses, binned.
    fn layout(grid: Grid, per_cell: usize, scale: f64, seed: u64) -> (Particles, CellBins) {
        let mut state = seed.wrapping_mul(6_364_136_223_846_793_005) | 1;
        let mut uniform = move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut p = Particles::at_subcell_centres(&grid, per_cell, 3.0);
        let sub = grid.h / per_cell as f64;
        for k in 0..p.len() {
            p.x[k] += 0.9 * sub * (uniform() - 0.5);
            p.cell[k] = grid.cell_of(p.x[k]).unwrap();
            p.volume[k] = scale * sub * (0.5 + uniform());
            p.mass[k] = p.volume[k] * (1.0 + uniform());
            p.v[k] = 2.0 * uniform() - 1.0;
            p.stress[k] = 10.0 * (uniform() - 0.5);
        }
        let mut bins = CellBins::default();
        bins.sort(&mut p, grid.cells);
        (p, bins)
    }

    fn ddmpm(grid: Grid, p: &Particles, bins: &CellBins) -> DdmpmBasis {
        let mut basis = DdmpmBasis::new(grid);
        basis.update(ParticleQuadrature {
            x: &p.x,
            volume: &p.volume,
            cell_start: &bins.cell_start,
        });
        basis
    }

    fn map<B: Basis, M: Mapping>(
        mapping: &mut M,
        basis: &B,
        p: &Particles,
        bins: &CellBins,
    ) -> GridFields {
        let mut fields = GridFields::new(basis.num_dofs());
        fields.consistent_mass = Some(CsrMatrix::band(basis.num_dofs(), basis.max_window() - 1));
        mapping.map_mass_and_internal_force(basis, p, bins, &mut fields);
        mapping.map_momentum(basis, p, bins, &mut fields);
        fields
    }

    /// Serial brute force over all sub-points: `(m_i, f_int_i, p_i, sum |f_int terms|)`.
    fn brute_force<B: Basis>(basis: &B, grid: Grid, p: &Particles, n: usize) -> [Vec<f64>; 4] {
        let mut out = [0; 4].map(|_| vec![0.0; basis.num_dofs()]);
        let mut shape = Shape::default();
        for q in 0..p.len() {
            for k in 0..n {
                let offset = (k as f64 + 0.5) / n as f64 - 0.5;
                let x = (p.x[q] + offset * p.volume[q]).clamp(0.0, grid.length);
                basis.eval(grid.cell_of(x).unwrap(), x, &mut shape);
                for j in 0..shape.len {
                    let i = shape.first + j;
                    out[0][i] += p.mass[q] / n as f64 * shape.phi[j];
                    out[1][i] += p.stress[q] * p.volume[q] / n as f64 * shape.dphi[j];
                    out[2][i] += p.mass[q] / n as f64 * p.v[q] * shape.phi[j];
                    out[3][i] += (p.stress[q] * p.volume[q] / n as f64 * shape.dphi[j]).abs();
                }
            }
        }
        out
    }

    fn bits(values: &[f64]) -> Vec<u64> {
        values.iter().map(|v| v.to_bits()).collect()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]
        /// Random layouts whose sub-points cross into neighbouring cells (and beyond the
        /// grid ends, where they are clipped): mass and momentum are conserved to
        /// round-off, the DDMPM forces of the interior sum to zero, every sub-point is
        /// counted once (brute-force comparison), and `M^C` has the lumped mass as row sums.
        #[test]
        fn conserves_mass_and_momentum(cells in 3usize..40, per_cell in 1usize..6,
                                       scale in 0.5f64..7.0, n in 1usize..40,
                                       seed in 0u64..1000) {
            let grid = Grid::new(2.5, cells);
            let (p, bins) = layout(grid, per_cell, scale, seed);
            let basis = ddmpm(grid, &p, &bins);
            let mut mapping = SubpointMapping::new(grid, n);
            let fields = map(&mut mapping, &basis, &p, &bins);
            let m_p: f64 = p.mass.iter().sum();
            let m_i: f64 = fields.mass.iter().sum();
            prop_assert!((m_i - m_p).abs() <= 1e-13 * m_p, "{} vs {}", m_i, m_p);
            let mv: f64 = p.mass.iter().zip(&p.v).map(|(m, v)| m * v).sum();
            let scale_p: f64 = p.mass.iter().zip(&p.v).map(|(m, v)| m * v.abs()).sum();
            let p_i: f64 = fields.momentum.iter().sum();
            prop_assert!((p_i - mv).abs() <= 1e-13 * scale_p, "{} vs {}", p_i, mv);
            let reference = brute_force(&basis, grid, &p, n);
            let f_scale: f64 = reference[3].iter().sum();
            let f_sum: f64 = fields.internal_force.iter().sum();
            prop_assert!(f_sum.abs() <= 1e-13 * f_scale, "{} of {}", f_sum, f_scale);
            let fields_and_scales = [
                (&fields.mass, m_p),
                (&fields.internal_force, f_scale),
                (&fields.momentum, scale_p),
            ];
            for ((field, size), exact) in fields_and_scales.into_iter().zip(&reference) {
                for (a, b) in field.iter().zip(exact) {
                    prop_assert!((a - b).abs() <= 1e-13 * size, "{} vs {}", a, b);
                }
            }
            let matrix = fields.consistent_mass.as_ref().unwrap();
            let mut ones = vec![0.0; basis.num_dofs()];
            matrix.mul_vec(&vec![1.0; basis.num_dofs()], &mut ones);
            for (row, m) in ones.iter().zip(&fields.mass) {
                prop_assert!((row - m).abs() <= 1e-13 * m_p);
            }
        }
    }

    #[test]
    fn domains_spread_mass_over_neighbouring_cells() {
        // One particle in the middle of cell 2 of 5, domain three cells long: its mass
        // reaches nodes 1..=4, linearly in the limit of many sub-points (hat averaged
        // over the domain), whereas the direct mapping puts it on nodes 2 and 3 only.
        let grid = Grid::new(5.0, 5);
        let mut p = Particles::at_subcell_centres(&grid, 1, 1.0);
        for k in 0..p.len() {
            p.volume[k] = if k == 2 { 3.0 } else { 0.0 };
            p.mass[k] = if k == 2 { 6.0 } else { 0.0 };
        }
        let mut bins = CellBins::default();
        bins.sort(&mut p, grid.cells);
        let basis = LinearBasis::new(grid);
        let fields = map(&mut SubpointMapping::new(grid, 3000), &basis, &p, &bins);
        // Average of the hat of node 1 over [1, 4]: (1/3) * 1/2 = 1/6 of the mass.
        let expected = [0.0, 1.0, 2.0, 2.0, 1.0, 0.0];
        for (m, e) in fields.mass.iter().zip(expected) {
            assert!((m - e).abs() < 1e-3, "{:?}", fields.mass);
        }
    }

    #[test]
    fn one_subpoint_is_the_direct_mapping_bit_for_bit() {
        let grid = Grid::new(1.0, 17);
        let (p, bins) = layout(grid, 5, 1.5, 7);
        let basis = ddmpm(grid, &p, &bins);
        let a = map(&mut SubpointMapping::new(grid, 1), &basis, &p, &bins);
        let b = map(&mut DirectMapping::default(), &basis, &p, &bins);
        assert_eq!(bits(&a.mass), bits(&b.mass));
        assert_eq!(bits(&a.internal_force), bits(&b.internal_force));
        assert_eq!(bits(&a.momentum), bits(&b.momentum));
        let (ma, mb) = (a.consistent_mass.unwrap(), b.consistent_mass.unwrap());
        assert_eq!(bits(&ma.values), bits(&mb.values));
    }

    #[test]
    fn same_bits_on_one_and_three_threads() {
        // Enough cells for several rayon tasks of the scatter.
        let grid = Grid::new(10.0, 700);
        let (p, bins) = layout(grid, 4, 3.0, 11);
        let basis = ddmpm(grid, &p, &bins);
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| map(&mut SubpointMapping::new(grid, 9), &basis, &p, &bins))
        };
        let (a, b) = (run(1), run(3));
        assert_eq!(bits(&a.mass), bits(&b.mass));
        assert_eq!(bits(&a.internal_force), bits(&b.internal_force));
        assert_eq!(bits(&a.momentum), bits(&b.momentum));
        let (ma, mb) = (a.consistent_mass.unwrap(), b.consistent_mass.unwrap());
        assert_eq!(bits(&ma.values), bits(&mb.values));
    }
}
