//! Assembly of B-spline mass matrices (SPEC §5): 1D banded and 2D tensor product with a
//! variable density (`rho = 1 + 0.9 sin 2 pi x sin 2 pi y`, `p + 2` Gauss points per span
//! and direction), against the constant-density shortcut `M_y (x) M_x`.
//!
//! ```text
//! cargo bench --bench assembly
//! ```
//!
//! `mass_assembly_2d/<kind>/p<order>`: 128^2 spans, `kind` = `quadrature` (parallel
//! sum-factorised assembly) or `kronecker` (two 1D assemblies and a Kronecker product);
//! `mass_assembly_1d/p<order>`: 1e5 spans. Throughput in DOFs per second.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use std::hint::black_box;
use std::time::Duration;
use tlsmpm::linalg::assembly::{mass_1d, mass_2d, SplineSpace};

fn two_dimensional(c: &mut Criterion) {
    let cells = 128;
    let mut group = c.benchmark_group("mass_assembly_2d");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(2));
    let tau = 2.0 * std::f64::consts::PI;
    for order in [1, 2, 3, 5] {
        let Some(space) = SplineSpace::new(order, cells, 1.0) else {
            continue;
        };
        let n = space.functions();
        group.throughput(Throughput::Elements((n * n) as u64));
        group.bench_with_input(
            BenchmarkId::new("quadrature", format!("p{order}")),
            &space,
            |b, s| {
                b.iter(|| {
                    black_box(mass_2d(s, s, order + 2, |q| {
                        1.0 + 0.9 * (tau * q.x[0]).sin() * (tau * q.x[1]).sin()
                    }))
                })
            },
        );
        group.bench_with_input(
            BenchmarkId::new("kronecker", format!("p{order}")),
            &space,
            |b, s| {
                b.iter(|| {
                    let m = mass_1d(s, order + 1, |_| 1.0);
                    black_box(m.kron(&m))
                })
            },
        );
    }
    group.finish();
}

fn one_dimensional(c: &mut Criterion) {
    let cells = 100_000;
    let mut group = c.benchmark_group("mass_assembly_1d");
    group.sample_size(10);
    for order in [1, 3, 5] {
        let Some(space) = SplineSpace::new(order, cells, 1.0) else {
            continue;
        };
        group.throughput(Throughput::Elements(space.functions() as u64));
        group.bench_with_input(
            BenchmarkId::from_parameter(format!("p{order}")),
            &space,
            |b, s| b.iter(|| black_box(mass_1d(s, order + 2, |q| 1.0 + q.x[0]))),
        );
    }
    group.finish();
}

criterion_group!(benches, two_dimensional, one_dimensional);
criterion_main!(benches);
