//! Cost of evaluating a basis at a particle: all non-zero functions and gradients of one
//! point, as the P2G/G2P kernels do, for every basis and B-spline orders 1..5.
//!
//! ```text
//! cargo bench --bench basis_eval
//! cargo bench --bench basis_eval -- basis_eval/bspline
//! ```
//!
//! `basis_eval/<basis>` evaluates `Basis::eval_particle` at 100 000 particles (8 per cell on
//! 12 500 cells, half-length `V_p / 2`) and sums the results; the throughput is in
//! evaluations per second ("elements"), so `1 / throughput` is the cost per particle.
//! DDMPM includes nothing of its per-step node-integral update (measured separately as
//! `basis_update/ddmpm`, per particle).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use std::hint::black_box;
use tlsmpm::grid::{
    BSplineBasis, Basis, CpdiBasis, DdmpmBasis, GimpBasis, Grid, LinearBasis, ParticleQuadrature,
    Shape,
};
use tlsmpm::particles::{CellBins, Particles};

const CELLS: usize = 12_500;
const PER_CELL: usize = 8;

fn particles(grid: &Grid) -> (Particles, CellBins) {
    let mut p = Particles::at_subcell_centres(grid, PER_CELL, 1.0);
    // Perturb the positions inside their sub-cells so evaluations are not all alike.
    let sub = grid.h / PER_CELL as f64;
    for (k, x) in p.x.iter_mut().enumerate() {
        *x += 0.3 * sub * ((k as f64 * 0.618_034).fract() - 0.5);
    }
    let mut bins = CellBins::default();
    bins.sort(&mut p, grid.cells);
    (p, bins)
}

fn evaluate<B: Basis>(basis: &B, p: &Particles) -> f64 {
    let mut shape = Shape::default();
    let mut total = 0.0;
    for k in 0..p.len() {
        basis.eval_particle(p.cell[k], p.x[k], 0.5 * p.volume[k], &mut shape);
        total += shape.phi[shape.len - 1] + shape.dphi[0];
    }
    total
}

fn bench_basis<B: Basis>(
    group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    name: &str,
    parameter: usize,
    basis: &B,
    p: &Particles,
) {
    group.bench_with_input(BenchmarkId::new(name, parameter), p, |b, p| {
        b.iter(|| black_box(evaluate(black_box(basis), p)))
    });
}

fn basis_eval(c: &mut Criterion) {
    let grid = Grid::new(1.0, CELLS);
    let (p, bins) = particles(&grid);
    let quadrature = ParticleQuadrature {
        x: &p.x,
        volume: &p.volume,
        cell_start: &bins.cell_start,
    };
    let mut group = c.benchmark_group("basis_eval");
    group.throughput(Throughput::Elements(p.len() as u64));
    bench_basis(&mut group, "linear", 1, &LinearBasis::new(grid), &p);
    let mut ddmpm = DdmpmBasis::new(grid);
    ddmpm.update(quadrature);
    bench_basis(&mut group, "ddmpm", 1, &ddmpm, &p);
    bench_basis(&mut group, "gimp", 1, &GimpBasis::new(grid), &p);
    bench_basis(&mut group, "cpdi", 1, &CpdiBasis::new(grid), &p);
    for order in 1..=5 {
        let basis = BSplineBasis::new(grid, order).expect("order in range");
        bench_basis(&mut group, "bspline", order, &basis, &p);
    }
    group.finish();

    let mut group = c.benchmark_group("basis_update");
    group.throughput(Throughput::Elements(p.len() as u64));
    group.bench_function("ddmpm", |b| {
        b.iter(|| {
            ddmpm.update(black_box(quadrature));
        })
    });
    group.finish();
}

criterion_group!(benches, basis_eval);
criterion_main!(benches);
