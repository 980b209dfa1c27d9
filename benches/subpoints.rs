//! Cost of the DDMPM sub-point mapping (SPEC §3.3) against the direct particle quadrature,
//! per particles-per-cell.
//!
//! ```text
//! cargo bench --bench subpoints
//! ```
//!
//! `subpoint_mapping/<mapping>/<ppc>`: one `map_mass_and_internal_force` plus one
//! `map_momentum` (the two mappings of a MUSL step) of the DDMPM basis on 2 000 cells with
//! `ppc` jittered particles per cell, serial (1-thread rayon pool). `<mapping>` is `direct`
//! or `n<N>` for `N` sub-points; the throughput is in particles per second, so the cost
//! per sub-point is `1 / (N * throughput)`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use std::hint::black_box;
use std::time::Duration;
use tlsmpm::grid::{Basis, DdmpmBasis, Grid, ParticleQuadrature};
use tlsmpm::mapping::{DirectMapping, GridFields, Mapping, SubpointMapping};
use tlsmpm::particles::{CellBins, Particles};

const CELLS: usize = 2_000;

fn setup(ppc: usize) -> (Grid, Particles, CellBins, DdmpmBasis) {
    let grid = Grid::new(CELLS as f64, CELLS);
    let mut p = Particles::at_subcell_centres(&grid, ppc, 1.0);
    let sub = grid.h / ppc as f64;
    for (k, x) in p.x.iter_mut().enumerate() {
        *x += 0.3 * sub * ((k as f64 * 0.618_034).fract() - 0.5);
        p.v[k] = (k as f64 * 0.1).sin();
        p.stress[k] = (k as f64 * 0.01).cos();
    }
    let mut bins = CellBins::default();
    bins.sort(&mut p, grid.cells);
    let mut basis = DdmpmBasis::new(grid);
    basis.update(ParticleQuadrature {
        x: &p.x,
        volume: &p.volume,
        cell_start: &bins.cell_start,
    });
    (grid, p, bins, basis)
}

fn map<M: Mapping>(
    mapping: &mut M,
    basis: &DdmpmBasis,
    p: &Particles,
    bins: &CellBins,
    fields: &mut GridFields,
) -> f64 {
    mapping.map_mass_and_internal_force(basis, p, bins, fields);
    mapping.map_momentum(basis, p, bins, fields);
    fields.internal_force[1] + fields.momentum[1]
}

fn subpoint_mapping(c: &mut Criterion) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap_or_else(|e| panic!("rayon pool: {e}"));
    let mut group = c.benchmark_group("subpoint_mapping");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(1));
    for ppc in [4, 20] {
        let (grid, p, bins, basis) = setup(ppc);
        let mut fields = GridFields::new(basis.num_dofs());
        group.throughput(Throughput::Elements(p.len() as u64));
        group.bench_function(BenchmarkId::new("direct", ppc), |b| {
            let mut mapping = DirectMapping::default();
            pool.install(|| {
                b.iter(|| black_box(map(&mut mapping, &basis, &p, &bins, &mut fields)))
            });
        });
        for n in [1, 8, 64] {
            group.bench_function(BenchmarkId::new(format!("n{n}"), ppc), |b| {
                let mut mapping = SubpointMapping::new(grid, n);
                pool.install(|| {
                    b.iter(|| black_box(map(&mut mapping, &basis, &p, &bins, &mut fields)))
                });
            });
        }
    }
    group.finish();
}

criterion_group!(benches, subpoint_mapping);
criterion_main!(benches);
