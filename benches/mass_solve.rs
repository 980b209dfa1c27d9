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
//!
//! Groups `mass_solve_2d_run/p<order>_n<cells>`: the matrix of a real run, not a model
//! problem. The 2D axis-aligned manufactured solution (4 particles per cell, TLS, consistent
//! mass) is stepped three times; the bench solves that step's constrained velocity system
//! of the x component (`M^C v_x = p_x`, roller walls and empty nodes eliminated, the TLS
//! density in `M^C`) from a zero guess to the run's tolerance, with the solvers the run
//! would build (Galerkin coarse levels for the p-multigrid kinds).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use std::hint::black_box;
use std::time::Duration;
use tlsmpm::app::solver_study::{StudyDensity, StudyProblem};
use tlsmpm::app::solvers::{build_solver, SolverGeometry};
use tlsmpm::app::tensor_run::build_tensor_simulation;
use tlsmpm::config::{SolverConfig, SolverKind};
use tlsmpm::linalg::assembly::SplineSpace;
use tlsmpm::linalg::{CoarseOperators, CsrMatrix};
use tlsmpm::mapping::tensor_direct::TensorBody;
use tlsmpm::physics::tensor::TensorBodySource;

fn full() -> bool {
    std::env::var_os("TLSMPM_BENCH_FULL").is_some()
}

fn group(c: &mut Criterion, dim: usize, order: usize, cells: usize, density: StudyDensity) {
    let Ok(problem) = StudyProblem::new(dim, order, cells, density) else {
        return;
    };
    let suffix = if density == StudyDensity::Sine {
        "_sine"
    } else {
        ""
    };
    // The 2D band is p (n + p) wide: a banded factorisation is O(N n^2 p^2).
    let kinds = SolverKind::ALL
        .into_iter()
        .filter(|&k| dim == 1 || k != SolverKind::Banded);
    let base = SolverConfig {
        smoother: tlsmpm::config::Smoother::SymmetricGaussSeidel,
        ..SolverConfig::default()
    };
    solver_group(
        c,
        &format!("mass_solve_{dim}d{suffix}/p{order}_n{cells}"),
        (&problem.matrix, &problem.rhs),
        &problem.geometry,
        &base,
        kinds,
    );
}

/// One group `name`: every solver of `kinds` (configured as `base`) on `matrix x = rhs`
/// from a zero guess. Solvers that cannot be built or fail the set-up solve (e.g. pmg with
/// a weak smoother at high order) are skipped; the set-up solve's iterations go to stderr.
fn solver_group(
    c: &mut Criterion,
    name: &str,
    (matrix, rhs): (&CsrMatrix, &[f64]),
    geometry: &SolverGeometry,
    base: &SolverConfig,
    kinds: impl Iterator<Item = SolverKind>,
) {
    let n = rhs.len();
    let mut group = c.benchmark_group(name);
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(2))
        .throughput(Throughput::Elements(n as u64));
    for kind in kinds {
        let config = SolverConfig {
            kind: Some(kind),
            ..base.clone()
        };
        let Ok(mut solver) = build_solver(&config, geometry) else {
            continue;
        };
        let mut x = vec![0.0; n];
        match solver.solve(matrix, rhs, &mut x) {
            Ok(stats) => eprintln!("{name}/{}: {} iterations", kind.name(), stats.iterations),
            Err(_) => continue,
        }
        group.bench_function(BenchmarkId::from_parameter(kind.name()), |b| {
            b.iter(|| {
                x.fill(0.0);
                let stats = solver.solve(matrix, black_box(rhs), &mut x);
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

/// The constrained velocity system of component x after three steps of the 2D
/// manufactured solution with TLS and the consistent mass on `cells`^2 cells, B-splines of
/// `order`; panics with the build or step error (a bench set-up, not user input).
fn run_system(order: usize, cells: usize) -> (CsrMatrix, Vec<f64>, SolverConfig) {
    let builtin =
        tlsmpm::app::builtin::find("axis_aligned_mms").expect("built-in axis_aligned_mms");
    let overrides = [
        format!("grid.cells={cells}"),
        format!("method.order={order}"),
        "method.reconstruction=\"tls\"".to_string(),
        "method.mass=\"consistent\"".to_string(),
        "solver.kind=\"cg\"".to_string(),
        "time.dt=1.0e-7".to_string(),
    ];
    let scenario = tlsmpm::config::from_str(builtin.toml, "bench", &overrides)
        .unwrap_or_else(|e| panic!("bench scenario: {e}"));
    let (problem, mut sim) =
        build_tensor_simulation::<2>(&scenario, false).unwrap_or_else(|e| panic!("{e}"));
    let mut body: [Vec<f64>; 2] = std::array::from_fn(|_| vec![0.0; sim.particles.len()]);
    problem.at_particles(&sim.particles.x0, 0.0, &mut body);
    for step in 1..=3 {
        let time = step as f64 * sim.dt;
        sim.stepper
            .step(
                &mut sim.particles,
                TensorBody::PerParticle(&body),
                sim.dt,
                step,
                time,
            )
            .unwrap_or_else(|e| panic!("step {step}: {e}"));
    }
    let (matrix, rhs) = sim
        .stepper
        .velocity_system(0)
        .expect("a consistent-mass run has a velocity system");
    (matrix.into_owned(), rhs, scenario.solver.clone())
}

fn run_matrices(c: &mut Criterion) {
    let cells = if full() { 256 } else { 64 };
    for order in [2, 3] {
        let (matrix, rhs, run_config) = run_system(order, cells);
        let geometry = SolverGeometry {
            directions: vec![SplineSpace::new(order, cells, 1.0).expect("spline space"); 2],
            boundary_dropped: false,
            coarse_operators: CoarseOperators::Galerkin,
            density: None,
        };
        // `banded` is 1D-only in a run (exit 2).
        solver_group(
            c,
            &format!("mass_solve_2d_run/p{order}_n{cells}"),
            (&matrix, &rhs),
            &geometry,
            &run_config,
            SolverKind::ALL
                .into_iter()
                .filter(|&k| k != SolverKind::Banded),
        );
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

criterion_group!(benches, two_dimensional, run_matrices, one_dimensional);
criterion_main!(benches);
