//! Throughput of the particle → grid mapping: TLS reconstruction + Gauss quadrature against
//! the plain MPM particle quadrature (SPEC §4.1).
//!
//! ```text
//! cargo bench --bench reconstruction                          # everything (long)
//! cargo bench --bench reconstruction -- 'mapping/serial/.*/16ppc'
//! cargo bench --bench reconstruction -- mapping_mls
//! ```
//!
//! `mapping/{serial,parallel}/{direct,tls,tls_consistent}/{P}ppc/{N}`: one step's mapping
//! (`map_mass_and_internal_force` + `map_momentum`) of `N` particles, `P` per cell, on the
//! linear basis (3 Gauss points per cell). `tls` fits stress, density and momentum in every
//! cell and integrates lumped masses; `tls_consistent` also assembles the consistent mass
//! matrix. Throughput is in particles per second; the ratio `direct / tls` of two
//! throughputs is the cost of the reconstruction per particle.
//! `mapping_bspline2/...` is the same with quadratic B-splines (4 Gauss points per cell):
//! there the direct mapping pays a B-spline evaluation per particle, TLS one per Gauss
//! point.
//! `mapping_mls/{serial,parallel}/{direct,tls,mls,imls}/{P}ppc/100000`: the same step's
//! mapping of 1e5 particles at 3 and 12 per cell on the linear basis (3 Gauss points per
//! cell) for the moving-least-squares mappings (SPEC §4.3), which fit density and stress at
//! every Gauss point over the kernel support (`1.5 h` either side) and velocity at every node.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use std::hint::black_box;
use std::time::Duration;
use tlsmpm::config::{CellTotals, DegenerateRemedy};
use tlsmpm::grid::{BSplineBasis, Basis, Grid, LinearBasis};
use tlsmpm::linalg::CsrMatrix;
use tlsmpm::mapping::{DirectMapping, GridFields, Mapping, MlsKind, MlsMapping, TlsMapping};
use tlsmpm::particles::{CellBins, Particles};

const PER_CELL: [usize; 3] = [4, 16, 64];
const SIZES: [usize; 4] = [1_000, 10_000, 100_000, 1_000_000];

/// A binned bar of about `particles` particles, `per_cell` per cell, with smooth
/// velocity and stress.
fn setup(particles: usize, per_cell: usize) -> (Grid, Particles, CellBins) {
    let cells = (particles / per_cell).max(1);
    let grid = Grid::new(1.0, cells);
    let mut p = Particles::at_subcell_centres(&grid, per_cell, 2000.0);
    for k in 0..p.len() {
        p.v[k] = (3.0 * p.x[k]).sin();
        p.stress[k] = (2.0 * p.x[k]).cos();
    }
    let mut bins = CellBins::default();
    bins.sort(&mut p, grid.cells);
    (grid, p, bins)
}

fn map<M: Mapping, B: Basis>(
    mapping: &mut M,
    basis: &B,
    particles: &Particles,
    bins: &CellBins,
    fields: &mut GridFields,
) {
    mapping.map_mass_and_internal_force(basis, particles, bins, fields);
    mapping.map_momentum(basis, particles, bins, fields);
}

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap_or_else(|e| panic!("rayon pool with {threads} threads: {e}"))
}

/// The group `name/{serial,parallel}` for the basis `make_basis(grid)` with a
/// `gauss_points`-point rule.
fn group<B: Basis, F: Fn(Grid) -> B>(
    c: &mut Criterion,
    name: &str,
    make_basis: F,
    gauss_points: usize,
) {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    for (label, threads) in [("serial", 1), ("parallel", cores)] {
        let pool = pool(threads);
        let mut group = c.benchmark_group(format!("{name}/{label}"));
        group
            .sample_size(10)
            .warm_up_time(Duration::from_millis(300))
            .measurement_time(Duration::from_secs(1));
        for per_cell in PER_CELL {
            for size in SIZES {
                let (grid, particles, bins) = setup(size, per_cell);
                let basis = make_basis(grid);
                group.throughput(Throughput::Elements(particles.len() as u64));
                let id = |name: &str| BenchmarkId::new(format!("{name}/{per_cell}ppc"), size);
                let mut fields = GridFields::new(basis.num_dofs());
                let mut direct = DirectMapping::default();
                group.bench_function(id("direct"), |b| {
                    b.iter(|| {
                        pool.install(|| map(&mut direct, &basis, &particles, &bins, &mut fields));
                        black_box(fields.momentum[0])
                    })
                });
                let mut tls = TlsMapping::new(
                    grid,
                    gauss_points,
                    DegenerateRemedy::VirtualPoints,
                    CellTotals::Domains,
                )
                .unwrap_or_else(|| panic!("{gauss_points}-point rule"));
                group.bench_function(id("tls"), |b| {
                    b.iter(|| {
                        pool.install(|| map(&mut tls, &basis, &particles, &bins, &mut fields));
                        black_box(fields.momentum[0])
                    })
                });
                let mut consistent = GridFields::new(basis.num_dofs());
                consistent.consistent_mass =
                    Some(CsrMatrix::band(basis.num_dofs(), basis.max_window() - 1));
                group.bench_function(id("tls_consistent"), |b| {
                    b.iter(|| {
                        pool.install(|| map(&mut tls, &basis, &particles, &bins, &mut consistent));
                        black_box(consistent.momentum[0])
                    })
                });
            }
        }
        group.finish();
    }
}

/// Time one step's mapping by `mapping` as `name` in `group`.
fn bench_one<M: Mapping>(
    group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    id: BenchmarkId,
    pool: &rayon::ThreadPool,
    mut mapping: M,
    (basis, particles, bins): (&LinearBasis, &Particles, &CellBins),
) {
    let mut fields = GridFields::new(basis.num_dofs());
    group.bench_function(id, |b| {
        b.iter(|| {
            pool.install(|| map(&mut mapping, basis, particles, bins, &mut fields));
            black_box(fields.momentum[0])
        })
    });
}

/// Direct, TLS, MLS and IMLS mappings of the same 1e5 particles (linear basis).
fn mls_group(c: &mut Criterion) {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    for (label, threads) in [("serial", 1), ("parallel", cores)] {
        let pool = pool(threads);
        let mut group = c.benchmark_group(format!("mapping_mls/{label}"));
        group
            .sample_size(10)
            .warm_up_time(Duration::from_millis(300))
            .measurement_time(Duration::from_secs(1));
        for per_cell in [3, 12] {
            let size = 100_000;
            let (grid, particles, bins) = setup(size, per_cell);
            let basis = LinearBasis::new(grid);
            let data = (&basis, &particles, &bins);
            group.throughput(Throughput::Elements(particles.len() as u64));
            let id = |name: &str| BenchmarkId::new(format!("{name}/{per_cell}ppc"), size);
            bench_one(
                &mut group,
                id("direct"),
                &pool,
                DirectMapping::default(),
                data,
            );
            let tls = TlsMapping::new(
                grid,
                3,
                DegenerateRemedy::VirtualPoints,
                CellTotals::Domains,
            );
            bench_one(
                &mut group,
                id("tls"),
                &pool,
                tls.expect("3-point rule"),
                data,
            );
            for (name, kind) in [("mls", MlsKind::Mls), ("imls", MlsKind::Imls)] {
                let mls = MlsMapping::new(grid, 3, kind).expect("3-point rule");
                bench_one(&mut group, id(name), &pool, mls, data);
            }
        }
        group.finish();
    }
}

fn mapping(c: &mut Criterion) {
    group(c, "mapping", LinearBasis::new, 3);
    group(
        c,
        "mapping_bspline2",
        |grid| BSplineBasis::new(grid, 2).unwrap_or_else(|| panic!("order 2")),
        4,
    );
}

criterion_group!(benches, mapping, mls_group);
criterion_main!(benches);
