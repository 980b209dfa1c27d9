//! Consistent-mass solves (SPEC §5): every solver on the same B-spline mass matrix, from a
//! zero guess to relative residual 1e-8 (the `tlsmpm solver-study` set-up: boundary DOFs
//! eliminated, load `f_i = 9.81 int phi_i`, unit density unless the group says `sine`).
//!
//! ```text
//! cargo bench --bench mass_solve                       # default sizes
//! TLSMPM_BENCH_FULL=1 cargo bench --bench mass_solve   # 2D up to 256^2, 1D up to 1e6 DOFs
//! cargo bench --bench mass_solve -- 'mass_solve_2d/p3' # one group
//! ```
//!
//! Groups `mass_solve_<dim>d[_sine]/p<order>_n<cells>`, one `BenchmarkId` per solver; the
//! throughput is in DOFs per second. Solver construction (transfers, Kronecker factors,
//! symbolic analysis on the first call) happens outside the timed loop, as in a time
//! stepper; numeric factorisations and per-solve set-up are timed.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use std::hint::black_box;
use std::time::Duration;
use tlsmpm::app::solver_study::{StudyDensity, StudyProblem};
use tlsmpm::app::solvers::build_solver;
use tlsmpm::config::{SolverConfig, SolverKind};

fn full() -> bool {
    std::env::var_os("TLSMPM_BENCH_FULL").is_some()
}

fn group(c: &mut Criterion, dim: usize, order: usize, cells: usize, density: StudyDensity) {
    let Ok(problem) = StudyProblem::new(dim, order, cells, density) else {
        return;
    };
    let n = problem.rhs.len();
    let suffix = if density == StudyDensity::Sine {
        "_sine"
    } else {
        ""
    };
    let mut group = c.benchmark_group(format!("mass_solve_{dim}d{suffix}/p{order}_n{cells}"));
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(2))
        .throughput(Throughput::Elements(n as u64));
    for kind in SolverKind::ALL {
        // The 2D band is p (n + p) wide: a banded factorisation is O(N n^2 p^2).
        if dim == 2 && kind == SolverKind::Banded {
            continue;
        }
        let config = SolverConfig {
            kind: Some(kind),
            smoother: tlsmpm::config::Smoother::SymmetricGaussSeidel,
            ..SolverConfig::default()
        };
        let Ok(mut solver) = build_solver(&config, &problem.geometry) else {
            continue;
        };
        let mut x = vec![0.0; n];
        // Skip solvers that fail here (e.g. pmg with a weak smoother at high order).
        if solver.solve(&problem.matrix, &problem.rhs, &mut x).is_err() {
            continue;
        }
        group.bench_function(BenchmarkId::from_parameter(kind.name()), |b| {
            b.iter(|| {
                x.fill(0.0);
                let stats = solver.solve(&problem.matrix, black_box(&problem.rhs), &mut x);
                black_box(stats.map(|s| s.iterations).unwrap_or(usize::MAX))
            })
        });
    }
    group.finish();
}

fn two_dimensional(c: &mut Criterion) {
    let cells: &[usize] = if full() { &[128, 256] } else { &[64] };
    for &n in cells {
        for order in 1..=5 {
            group(c, 2, order, n, StudyDensity::Unit);
        }
    }
    let n = if full() { 256 } else { 64 };
    for order in [2, 5] {
        group(c, 2, order, n, StudyDensity::Sine);
    }
}

fn one_dimensional(c: &mut Criterion) {
    let cells: &[usize] = if full() {
        &[10_000, 100_000, 1_000_000]
    } else {
        &[10_000]
    };
    for &n in cells {
        for order in [1, 3, 5] {
            group(c, 1, order, n, StudyDensity::Unit);
        }
    }
}

criterion_group!(benches, two_dimensional, one_dimensional);
criterion_main!(benches);
