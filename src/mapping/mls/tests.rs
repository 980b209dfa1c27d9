//! Unit tests of the MLS / IMLS mapping.

use super::*;
use crate::grid::{BSplineBasis, LinearBasis};
use crate::mapping::spectrum::frozen_spectrum_of;
use proptest::prelude::*;

/// `counts[e]` particles in cell `e` at jittered positions, field values from `f`
/// (stress and density) and `v` (velocity); binned.
fn layout(
    grid: &Grid,
    counts: &[usize],
    jitter: &[f64],
    f: impl Fn(f64) -> f64,
    v: impl Fn(f64) -> f64,
) -> (Particles, CellBins) {
    let mut p = Particles::default();
    let mut k = 0;
    for (e, &n) in counts.iter().enumerate() {
        for j in 0..n {
            let t = (j as f64 + 0.05 + 0.9 * jitter[k % jitter.len()]) / n as f64;
            let x = grid.cell_left(e) + t * grid.h;
            let volume = grid.h / n as f64;
            p.id.push(k);
            p.x0.push(x);
            p.x.push(x);
            p.u.push(0.0);
            p.v.push(v(x));
            p.stress.push(f(x));
            p.volume.push(volume);
            p.density.push(f(x));
            p.mass.push(f(x) * volume);
            p.deformation_gradient.push(1.0);
            p.cell.push(e);
            k += 1;
        }
    }
    let mut bins = CellBins::default();
    bins.sort(&mut p, grid.cells);
    (p, bins)
}

/// Map mass, force and momentum; returns the fields.
fn map<B: Basis>(
    mapping: &mut MlsMapping,
    basis: &B,
    particles: &Particles,
    bins: &CellBins,
    consistent: bool,
) -> GridFields {
    let mut fields = GridFields::new(basis.num_dofs());
    if consistent {
        fields.consistent_mass = Some(CsrMatrix::band(basis.num_dofs(), basis.max_window() - 1));
    }
    mapping.map_mass_and_internal_force(basis, particles, bins, &mut fields);
    mapping.map_momentum(basis, particles, bins, &mut fields);
    fields
}

/// Every fitted `[stress, density]` at the Gauss points of the last mass mapping with
/// its position.
fn gauss_values(mapping: &MlsMapping) -> Vec<(f64, [f64; 2])> {
    let mut out = Vec::new();
    let ng = mapping.points.rule.len;
    for cell in 0..mapping.grid.cells {
        if !mapping.domains.is_active(cell) {
            continue;
        }
        let mut g = 0;
        let (lo, hi) = (mapping.domains.lo[cell], mapping.domains.hi[cell]);
        mapping.points.for_each(lo, hi, |x, _| {
            out.push((x, mapping.values[cell * ng + g]));
            g += 1;
        });
    }
    out
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    /// A quadratic density/stress is reproduced at every Gauss point and a linear
    /// velocity at every node, by MLS and IMLS, for random layouts of 3–6 particles
    /// per cell.
    #[test]
    fn polynomials_are_reproduced(cells in 2usize..9,
                                  counts in prop::collection::vec(3usize..7, 9),
                                  jitter in prop::collection::vec(0.0f64..1.0, 40),
                                  c in prop::array::uniform3(-1.0f64..1.0)) {
        let grid = Grid::new(3.0, cells);
        let q = |x: f64| 2.0 + c[0] + c[1] * x + c[2] * x * x;
        let l = |x: f64| c[2] - 0.5 * c[1] * x;
        let (particles, bins) = layout(&grid, &counts[..cells], &jitter, q, l);
        let basis = LinearBasis::new(grid);
        for kind in [MlsKind::Mls, MlsKind::Imls] {
            let mut mapping = MlsMapping::new(grid, 3, kind).unwrap();
            let fields = map(&mut mapping, &basis, &particles, &bins, false);
            for (x, [s, r]) in gauss_values(&mapping) {
                prop_assert!((s - q(x)).abs() < 1e-12, "{:?} stress at {}: {} vs {}", kind, x, s, q(x));
                prop_assert!((r - q(x)).abs() < 1e-12, "{:?} density at {}: {} vs {}", kind, x, r, q(x));
            }
            for (i, &vi) in mapping.nodal.iter().enumerate() {
                let xi = i as f64 * grid.h;
                prop_assert!((vi - l(xi)).abs() < 1e-12, "{:?} node {}: {} vs {}", kind, i, vi, l(xi));
                prop_assert_eq!(fields.momentum[i], fields.mass[i] * vi);
            }
            prop_assert_eq!(mapping.remedies(), RemedyCounts::default());
        }
    }
}

#[test]
fn sparse_supports_are_rank_adaptive_for_imls_and_degenerate_for_mls() {
    // One particle near the left end, two isolated in the middle (> 1.5 h apart).
    let grid = Grid::new(10.0, 10);
    let f = |x: f64| 1.0 + 0.25 * x;
    let (particles, bins) = layout(&grid, &[1, 0, 0, 0, 0, 2, 0, 0, 0, 0], &[0.4, 0.7], f, f);
    let basis = LinearBasis::new(grid);
    let mut imls = MlsMapping::new(grid, 3, MlsKind::Imls)
        .unwrap()
        .with_adjoint_strain(true);
    let fields = map(&mut imls, &basis, &particles, &bins, false);
    // The adjoint strain of the sparse layout is finite (exact for a uniform gradient).
    let velocity: Vec<f64> = (0..basis.num_dofs()).map(|i| 2.0 * i as f64).collect();
    let mut deps = Vec::new();
    assert!(imls.strain_increments(&basis, &particles, &velocity, 0.5, &mut deps));
    for d in &deps {
        assert!((d - 0.5 * 2.0 * grid.inv_h).abs() < 1e-12, "{deps:?}");
    }
    let values = gauss_values(&imls);
    assert!(!values.is_empty());
    for &(x, [s, r]) in &values {
        if x < 1.0 {
            // Constant fit of the single particle.
            assert_eq!([s, r], [particles.stress[0]; 2], "x = {x}");
        } else {
            // Linear fit through two points: exact for the linear field.
            assert!(
                (s - f(x)).abs() < 1e-12 && (r - f(x)).abs() < 1e-12,
                "x = {x}: {s}"
            );
        }
    }
    let remedies = imls.remedies();
    assert!(remedies.order_reduced_fits > 0, "{remedies:?}");
    assert_eq!(remedies.degenerate_fits, 0, "{remedies:?}");
    assert!(fields
        .momentum
        .iter()
        .chain(&fields.mass)
        .all(|v| v.is_finite()));
    let mut mls = MlsMapping::new(grid, 3, MlsKind::Mls).unwrap();
    let fields = map(&mut mls, &basis, &particles, &bins, false);
    let remedies = mls.remedies();
    assert!(remedies.degenerate_fits > 0, "{remedies:?}");
    assert!(fields
        .mass
        .iter()
        .chain(&fields.internal_force)
        .all(|v| v.is_finite()));
    assert!(fields.momentum.iter().all(|v| v.is_finite()));
    for (x, [s, _]) in gauss_values(&mls) {
        assert!(s.is_finite(), "x = {x}");
    }
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let grid = Grid::new(2.0, 301);
    let jitter: Vec<f64> = (0..97).map(|k| ((k * 37) % 97) as f64 / 97.0).collect();
    let counts: Vec<usize> = (0..grid.cells).map(|e| 1 + (e * 7) % 5).collect();
    let (particles, bins) = layout(
        &grid,
        &counts,
        &jitter,
        |x| 2.0 + (3.0 * x).sin(),
        |x| (5.0 * x).cos(),
    );
    let linear = LinearBasis::new(grid);
    let spline = BSplineBasis::new(grid, 2).unwrap();
    let run = |threads: usize, kind: MlsKind| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut mapping = MlsMapping::new(grid, 4, kind).unwrap();
            let a = map(&mut mapping, &linear, &particles, &bins, true);
            let b = map(&mut mapping, &spline, &particles, &bins, true);
            let mut all: Vec<f64> = Vec::new();
            for f in [a, b] {
                all.extend(f.mass.iter().chain(&f.internal_force).chain(&f.momentum));
                all.extend(&f.consistent_mass.unwrap().values);
            }
            (
                all.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                mapping.remedies(),
            )
        })
    };
    for kind in [MlsKind::Mls, MlsKind::Imls] {
        let (one, counts_one) = run(1, kind);
        let (three, counts_three) = run(3, kind);
        assert!(
            one == three,
            "{kind:?}: results differ between 1 and 3 threads"
        );
        assert_eq!(counts_one, counts_three);
    }
}

#[test]
fn consistent_mass_momentum_is_the_matrix_times_the_nodal_velocity() {
    let grid = Grid::new(1.0, 6);
    let (particles, bins) = layout(
        &grid,
        &[3; 6],
        &[0.2, 0.9, 0.5],
        |x| 1.0 + x * x,
        |x| 1.0 - 2.0 * x,
    );
    let basis = LinearBasis::new(grid);
    let mut mapping = MlsMapping::new(grid, 3, MlsKind::Imls)
        .unwrap()
        .with_consistent_velocity(true);
    let fields = map(&mut mapping, &basis, &particles, &bins, true);
    let mut expected = vec![0.0; basis.num_dofs()];
    let matrix = fields.consistent_mass.as_ref().unwrap();
    matrix.mul_vec(&mapping.nodal, &mut expected);
    assert_eq!(fields.momentum, expected);
    // A lumped velocity solve (consistent acceleration only): p = m v despite M^C.
    let mut lumped = MlsMapping::new(grid, 3, MlsKind::Imls).unwrap();
    let fields = map(&mut lumped, &basis, &particles, &bins, true);
    for ((p, m), v) in fields.momentum.iter().zip(&fields.mass).zip(&lumped.nodal) {
        assert_eq!(*p, m * v);
    }
    // The velocity field is linear: nodal values are exact.
    for (i, v) in mapping.nodal.iter().enumerate() {
        assert!((v - (1.0 - 2.0 * i as f64 * grid.h)).abs() < 1e-12);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]
    /// The adjoint strain is exact for a uniform velocity gradient (every particle,
    /// boundary cells included), for MLS and IMLS, linear and quadratic B-spline bases.
    #[test]
    fn adjoint_strain_reproduces_a_uniform_gradient(cells in 3usize..9,
                                                   per_cell in prop::collection::vec(2usize..6, 8),
                                                   jitter in prop::collection::vec(0.0f64..1.0, 48),
                                                   slope in -3.0f64..3.0) {
        let grid = Grid::new(2.0, cells);
        let counts = &per_cell[..cells];
        let f = |x: f64| 2.0 + 0.3 * x;
        let (particles, bins) = layout(&grid, counts, &jitter, f, f);
        let dt = 1e-3;
        for kind in [MlsKind::Mls, MlsKind::Imls] {
            for order in [1, 2] {
                let basis = BSplineBasis::new(grid, order).unwrap();
                let mut mapping = MlsMapping::new(grid, 3, kind).unwrap().with_adjoint_strain(true);
                let deps = adjoint_deps(&mut mapping, &basis, order, &particles, &bins, slope, dt);
                for (p, d) in deps.iter().enumerate() {
                    prop_assert!((d - dt * slope).abs() <= 1e-12 * (1.0 + slope.abs()),
                                 "{kind:?} particle {p}: {d} vs {}", dt * slope);
                }
                // A particle whose fit volume is small (a negative psi on a jittered,
                // uneven layout) falls back to the basis gradient, which is exact here
                // too; regular layouts never fall back (next test).
            }
        }
    }
}

/// On regular layouts (particles at the centres of equal sub-intervals, 2..5 per cell) no
/// particle falls back: every strain is the psi-weighted Gauss-point mean.
#[test]
fn regular_layouts_never_fall_back_to_the_particle_gradient() {
    for cells in 3..9 {
        for n in 2..6 {
            let grid = Grid::new(2.0, cells);
            let counts = vec![n; cells];
            let f = |x: f64| 2.0 + 0.3 * x;
            // t = (j + 0.05 + 0.9 * 0.5) / n = (j + 1/2) / n.
            let (particles, bins) = layout(&grid, &counts, &[0.5], f, f);
            for kind in [MlsKind::Mls, MlsKind::Imls] {
                for order in [1, 2] {
                    let basis = BSplineBasis::new(grid, order).unwrap();
                    let mut mapping = MlsMapping::new(grid, 3, kind)
                        .unwrap()
                        .with_adjoint_strain(true);
                    let deps =
                        adjoint_deps(&mut mapping, &basis, order, &particles, &bins, 1.5, 1e-3);
                    assert!(deps.iter().all(|d| (d - 1.5e-3).abs() <= 1e-12 * 2.5));
                    assert_eq!(
                        mapping.remedies().strain_fallbacks,
                        0,
                        "{kind:?} p = {order}, {cells} cells, {n} per cell"
                    );
                }
            }
        }
    }
}

/// Adjoint strain increments for the grid velocity `v(x) = 1 + slope x` in the
/// B-spline basis of order `order` (open uniform knots): the DOFs of a linear field are
/// its values at the Greville abscissae `(t_{i+1} + ... + t_{i+p}) / p`.
fn adjoint_deps<B: Basis>(
    mapping: &mut MlsMapping,
    basis: &B,
    order: usize,
    particles: &Particles,
    bins: &CellBins,
    slope: f64,
    dt: f64,
) -> Vec<f64> {
    map(mapping, basis, particles, bins, false);
    let grid = mapping.grid;
    let knot = |j: usize| (j as f64 - order as f64).clamp(0.0, grid.cells as f64);
    let velocity: Vec<f64> = (0..basis.num_dofs())
        .map(|i| {
            let greville = (1..=order).map(|k| knot(i + k)).sum::<f64>() / order as f64;
            1.0 + slope * (grid.origin + greville * grid.h)
        })
        .collect();
    let mut deps = Vec::new();
    assert!(mapping.strain_increments(basis, particles, &velocity, dt, &mut deps));
    deps
}

#[test]
fn adjoint_strain_is_work_conjugate_to_the_internal_force() {
    // With a unit stress at particle q only, the internal force's work on any grid
    // velocity v is f_int . v = sum_g psi_q(x_g) w_g dv(x_g) = V~_q deps_q(v) / dt.
    // V~_q from a uniform gradient (deps = dt c): deps_q(v) = dt c (f.v) / (f.v_1).
    let grid = Grid::new(3.0, 12);
    let counts: Vec<usize> = (0..12).map(|e| 2 + (e * 5) % 3).collect();
    let jitter: Vec<f64> = (0..40).map(|k| ((k * 29) % 41) as f64 / 41.0).collect();
    let (mut particles, bins) = layout(&grid, &counts, &jitter, |_| 1.0, |_| 0.0);
    let basis = LinearBasis::new(grid);
    let dofs = basis.num_dofs();
    let v1: Vec<f64> = (0..dofs).map(|i| 0.5 + 2.0 * i as f64 * grid.h).collect();
    let v2: Vec<f64> = (0..dofs).map(|i| (1.7 * i as f64).sin()).collect();
    let dt = 1e-2;
    for q in [0, 7, 19, particles.len() - 1] {
        particles.stress.iter_mut().for_each(|s| *s = 0.0);
        particles.stress[q] = 1.0;
        let mut mapping = MlsMapping::new(grid, 3, MlsKind::Imls)
            .unwrap()
            .with_adjoint_strain(true);
        let fields = map(&mut mapping, &basis, &particles, &bins, false);
        let work = |v: &[f64]| -> f64 {
            fields
                .internal_force
                .iter()
                .zip(v)
                .map(|(f, v)| f * v)
                .sum()
        };
        let mut deps = Vec::new();
        assert!(mapping.strain_increments(&basis, &particles, &v2, dt, &mut deps));
        let expected = dt * 2.0 * work(&v2) / work(&v1);
        assert!(
            (deps[q] - expected).abs() < 1e-12 * expected.abs().max(1e-3),
            "particle {q}: {} vs {expected}",
            deps[q]
        );
    }
}

#[test]
fn adjoint_strain_does_not_depend_on_the_thread_count() {
    let grid = Grid::new(2.0, 301);
    let counts: Vec<usize> = (0..grid.cells).map(|e| 1 + (e * 7) % 5).collect();
    let jitter: Vec<f64> = (0..97).map(|k| ((k * 37) % 97) as f64 / 97.0).collect();
    let (particles, bins) = layout(&grid, &counts, &jitter, |x| 1.0 + x * x, |x| x.cos());
    let basis = LinearBasis::new(grid);
    let velocity: Vec<f64> = (0..basis.num_dofs())
        .map(|i| (0.3 * i as f64).sin())
        .collect();
    let deps_on = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut mapping = MlsMapping::new(grid, 3, MlsKind::Imls)
                .unwrap()
                .with_adjoint_strain(true);
            map(&mut mapping, &basis, &particles, &bins, false);
            let mut deps = Vec::new();
            mapping.strain_increments(&basis, &particles, &velocity, 1e-3, &mut deps);
            deps
        })
    };
    let serial = deps_on(1);
    assert!(serial.iter().all(|d| d.is_finite()));
    assert_eq!(serial, deps_on(3));
}

/// [`frozen_spectrum_of`] the IMLS mapping, 3 particles per cell.
fn frozen_spectrum(cells: usize, amplitude: f64, phase: f64, adjoint: bool) -> (f64, f64) {
    let grid = Grid::new(1.0, cells);
    let mapping = MlsMapping::new(grid, 3, MlsKind::Imls)
        .unwrap()
        .with_adjoint_strain(adjoint);
    frozen_spectrum_of(mapping, cells, 3, amplitude, phase)
}

#[test]
fn the_adjoint_strain_makes_the_frozen_step_neutrally_stable() {
    // Undeformed and deformed MMS-bar configurations (A = 0.1, 32 cells). With the
    // gradient strain of the paper's eq. 37 some eigenvalues have real parts of
    // 0.4 .. 0.6 c/L (measured: 0.38, 0.64): a growing mode. With the adjoint strain all
    // are imaginary to round-off.
    for phase in [0.3, std::f64::consts::FRAC_PI_2] {
        let (growth, size) = frozen_spectrum(32, 0.1, phase, false);
        assert!(
            growth > 0.1,
            "gradient, phase {phase}: max Re {growth} (|l| {size})"
        );
        let (growth, size) = frozen_spectrum(32, 0.1, phase, true);
        assert!(
            growth < 1e-9 * size,
            "adjoint, phase {phase}: max Re {growth} (|l| {size})"
        );
    }
    let (growth, size) = frozen_spectrum(32, 0.0, 0.0, false);
    assert!(growth < 1e-9 * size, "undeformed, gradient: {growth}");
}
