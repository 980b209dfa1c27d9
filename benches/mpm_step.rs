//! Throughput of one full MPM step, and a STREAM-like triad to compare it with.
//!
//! ```text
//! cargo bench --bench mpm_step                  # every group
//! cargo bench --bench mpm_step -- mpm_step/serial
//! cargo bench --bench mpm_step -- mpm_step_methods
//! cargo bench --bench mpm_step -- mpm_step_2d
//! cargo bench --bench mpm_step -- mpm_step_3d
//! cargo bench --bench mpm_step -- mpm_step_2d_tls
//! cargo bench --bench mpm_step -- 'mpm_step_2d/bspline2/.*/1000000|memory_bandwidth'
//! cargo bench --bench mpm_step -- --test mpm_step_2d   # each bench once (smoke test)
//! ```
//!
//! * `mpm_step/{serial,parallel}/N`: one `TimeStepper::step` of the vibrating bar
//!   (`scenarios/vibrating_bar.toml`: linear basis, lumped mass, MUSL, 12 particles per
//!   cell, `dt = 1e-7`) with `N` particles on `N / 12` cells. The throughput is in
//!   particle-steps per second ("elements"). `serial` runs in a 1-thread rayon pool,
//!   `parallel` in a pool of `std::thread::available_parallelism()` threads.
//! * `mpm_step_methods/{method}/t{threads}/1000000`: one whole step of the vibrating bar
//!   (12 PPC, `dt = 5e-8`, below the consistent mass's limit) through `Simulation::run`, so the per-step bookkeeping of
//!   `history.csv` (energies, conservation sums) is included as in a run, for `mpm`,
//!   `bspline2`, `bspline3`, `cpdi`, `mpm_tls`, `bsmpm_tls_consistent` (quadratic B-splines,
//!   TLS, consistent mass, banded solve) and `imls`; 1 thread and
//!   `available_parallelism()`. The simulation of a method is built once (lazily, so a
//!   filter that skips it costs nothing) and keeps stepping across the thread counts.
//! * `two_phase_step/{mpm,mpm_tls,bsmpm_tls}/N`: one step of the small consolidation
//!   (`scenarios/consolidation.toml`, SPEC §2.1: three mapped phases, 4 particles per
//!   cell) with `N` particles, in the parallel pool; compare with `mpm_step/parallel/N` for
//!   the cost of the second phase.
//! * `mms_step/{serial,parallel}/{method}/N`: one step of the manufactured-solution bar
//!   (`scenarios/mms_bar.toml`, SPEC §6.5: neo-Hookean, per-particle body force, 3
//!   particles per cell) with `N` particles, for plain MPM, CPDI, TLS and IMLS with the
//!   gradient and the adjoint strain (`method.strain`): the cost of the IMLS step.
//! * `mpm_step_2d/{basis}/t{threads}/N`: one `TensorTimeStepper::step_ahead` of the 2D (plane
//!   strain) core on the built-in `axis_aligned_mms` scenario (neo-Hookean, 4 particles per
//!   cell, `dt = 1e-7`, lumped mass) on `n x n` cells, `n = 50, 158, 500`, i.e. `N = 4 n^2`
//!   ≈ 1e4, 1e5, 1e6 particles. `basis` is `linear`, `bspline2`, `bspline3` (`method.basis =
//!   "bspline"`, `method.order = 2 | 3`) or `gimp`; `threads` is 1 and
//!   `available_parallelism()`. One iteration is exactly one call of
//!   `sim.stepper.step_ahead(&mut sim.particles, PerParticle(&body), Some(PerParticle(&body)), dt, step, t)`
//!   (as a run steps: the particle update maps the next step's mass and force where the
//!   mapping allows it): the per-particle body force `body` is the problem's `b(X_p, 0)`,
//!   computed once when the simulation is built (its transcendental evaluation is not part
//!   of the step cost).
//!   Each simulation is built once per (basis, size), lazily, so filtered-out sizes cost
//!   nothing, and keeps stepping across the thread counts. Throughput in particle-steps per
//!   second ("elements"); sizes from 1e6 use 10 flat samples.
//! * `mpm_step_3d/{basis}/t{threads}/N`: the same in 3D (`problem.dim = 3`, 8 particles per
//!   cell) on `n^3` cells, `n = 11, 23, 50`, i.e. `N = 8 n^3` ≈ 1e4, 1e5, 1e6.
//! * `mpm_step_2d_tls/{basis}/{method}/N`: the 2D step with TLS and the consistent mass
//!   per solver kind, next to the lumped steps it is compared with: `basis` is `bspline2` or
//!   `bspline3`, `method` one of `bsmpm_lumped` (no reconstruction), `tls_lumped`,
//!   `tls_{kron,pmg_cg,cg,pcg,direct}` (`method.mass = "consistent"`, `solver.kind`); the
//!   same scenario as `mpm_step_2d` but with the shipped `dt = 1e-5`, so that the warm
//!   starts see a real step's change; `n = 32, 158` (`N` ≈ 4e3, 1e5), the parallel pool
//!   only. `perf/profile_step.rs --dim 2` splits such a step into its phases.
//! * `memory_bandwidth/triad_{serial,parallel}`: `a[i] = b[i] + s c[i]` over three arrays
//!   of 2^24 `f64` (384 MiB), counted as `3 * 8` bytes per element (STREAM convention: no
//!   write-allocate traffic).
//!
//! See `perf/README.md` for the bytes moved per particle-step and the comparison.

use criterion::{
    criterion_group, criterion_main, BenchmarkId, Criterion, SamplingMode, Throughput,
};
use rayon::prelude::*;
use std::hint::black_box;
use std::time::Duration;
use tlsmpm::app::build::build_simulation;
use tlsmpm::app::tensor_run::build_tensor_simulation;
use tlsmpm::mapping::tensor_direct::TensorBody;
use tlsmpm::physics::tensor::{TensorBodySource, TensorSimulation};
use tlsmpm::physics::{Body, Simulation};
use tlsmpm::problems::{Problem, ProblemBody};

const SCENARIO: &str = include_str!("../scenarios/vibrating_bar.toml");
const PER_CELL: usize = 12;
const SIZES: [usize; 4] = [1_000, 10_000, 100_000, 1_000_000];

/// A vibrating bar with `particles` particles (rounded down to a multiple of 12), its
/// problem and the number of steps taken so far.
struct Bar {
    problem: Box<dyn Problem>,
    sim: Simulation,
}

impl Bar {
    fn new(particles: usize) -> Self {
        let cells = (particles / PER_CELL).max(1);
        let overrides = vec![
            format!("grid.cells={cells}"),
            format!("particles.per_cell={PER_CELL}"),
            "method.basis=\"linear\"".to_string(),
            "method.reconstruction=\"none\"".to_string(),
            "method.mass=\"lumped\"".to_string(),
            "method.scheme=\"musl\"".to_string(),
            "time.dt=1.0e-7".to_string(),
        ];
        let bar = Self::from_scenario(SCENARIO, &overrides);
        assert_eq!(bar.sim.particles.len(), cells * PER_CELL);
        bar
    }

    /// Any scenario text with overrides.
    fn from_scenario(text: &str, overrides: &[String]) -> Self {
        let scenario = tlsmpm::config::from_str(text, "bench", overrides)
            .unwrap_or_else(|e| panic!("bench scenario: {e}"));
        let (problem, sim) =
            build_simulation(&scenario, false).unwrap_or_else(|e| panic!("bench build: {e}"));
        Self { problem, sim }
    }

    /// One time step; panics with the solver's message on failure.
    fn step(&mut self) -> tlsmpm::physics::step::StepReport {
        let step = self.sim.steps_done + 1;
        let time = step as f64 * self.sim.stepper.dt();
        let body = self.problem.body_acceleration(time);
        let report = self
            .sim
            .stepper
            .step(&mut self.sim.particles, Body::Uniform(body), step, time)
            .unwrap_or_else(|e| panic!("step {step} failed: {e}"));
        self.sim.steps_done = step;
        report
    }
}

impl Bar {
    /// One time step with the problem's body force (per particle where it varies in space).
    fn step_with_problem_body(&mut self) -> usize {
        let body = ProblemBody(self.problem.as_ref());
        self.sim
            .run(1, &body, &mut |_| Ok(()))
            .unwrap_or_else(|e| panic!("step {} failed: {e}", self.sim.steps_done + 1));
        self.sim.steps_done
    }
}

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap_or_else(|e| panic!("rayon pool with {threads} threads: {e}"))
}

fn parallel_threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

fn mpm_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("mpm_step");
    let pools = [("serial", pool(1)), ("parallel", pool(parallel_threads()))];
    for n in SIZES {
        if n >= 100_000 {
            group
                .sample_size(10)
                .warm_up_time(Duration::from_millis(1000))
                .measurement_time(Duration::from_secs(3));
        } else {
            group
                .sample_size(30)
                .warm_up_time(Duration::from_millis(500))
                .measurement_time(Duration::from_secs(2));
        }
        group.throughput(Throughput::Elements(n as u64));
        for (name, pool) in &pools {
            // Built (and first-touched) inside the pool, stepped only inside it.
            let mut bar = pool.install(|| Bar::new(n));
            group.bench_function(BenchmarkId::new(*name, n), |b| {
                pool.install(|| b.iter(|| black_box(bar.step())));
            });
        }
    }
    group.finish();
}

const CONSOLIDATION: &str = include_str!("../scenarios/consolidation.toml");

fn two_phase_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("two_phase_step");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    let pool = pool(parallel_threads());
    let methods = [
        ("mpm", "linear", "none", "lumped"),
        ("mpm_tls", "linear", "tls", "lumped"),
        ("bsmpm_tls", "bspline", "tls", "consistent"),
    ];
    for n in [10_000, 100_000] {
        group.throughput(Throughput::Elements(n as u64));
        for (name, basis, reconstruction, mass) in methods {
            let overrides = vec![
                format!("grid.cells={}", n / 4),
                format!("method.basis=\"{basis}\""),
                format!("method.reconstruction=\"{reconstruction}\""),
                format!("method.mass=\"{mass}\""),
            ];
            let mut column = pool.install(|| Bar::from_scenario(CONSOLIDATION, &overrides));
            group.bench_function(BenchmarkId::new(name, n), |b| {
                pool.install(|| b.iter(|| black_box(column.step())));
            });
        }
    }
    group.finish();
}

const MMS_BAR: &str = include_str!("../scenarios/mms_bar.toml");

fn mms_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("mms_step");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    let pools = [("serial", pool(1)), ("parallel", pool(parallel_threads()))];
    let methods: [(&str, &[&str]); 5] = [
        ("mpm", &[]),
        ("cpdi", &["method.basis=\"cpdi\""]),
        ("mpm_tls", &["method.reconstruction=\"tls\""]),
        (
            "imls_gradient",
            &[
                "method.reconstruction=\"imls\"",
                "method.strain=\"gradient\"",
            ],
        ),
        (
            "imls_adjoint",
            &[
                "method.reconstruction=\"imls\"",
                "method.strain=\"adjoint\"",
            ],
        ),
    ];
    for n in [30_000, 300_000] {
        group.throughput(Throughput::Elements(n as u64));
        for (pool_name, pool) in &pools {
            for (name, sets) in methods {
                let mut overrides = vec![format!("grid.cells={}", n / 3), "time.dt=1e-8".into()];
                overrides.extend(sets.iter().map(|s| s.to_string()));
                let mut bar = pool.install(|| Bar::from_scenario(MMS_BAR, &overrides));
                let id = BenchmarkId::new(format!("{pool_name}/{name}"), n);
                group.bench_function(id, |b| {
                    pool.install(|| b.iter(|| black_box(bar.step_with_problem_body())));
                });
            }
        }
    }
    group.finish();
}

/// The 1D methods of the method-cost table: id and `method` overrides of the vibrating bar.
fn methods_1d() -> [(&'static str, &'static [&'static str]); 7] {
    [
        ("mpm", &[]),
        ("bspline2", &["method.basis=\"bspline\"", "method.order=2"]),
        ("bspline3", &["method.basis=\"bspline\"", "method.order=3"]),
        ("cpdi", &["method.basis=\"cpdi\""]),
        ("mpm_tls", &["method.reconstruction=\"tls\""]),
        (
            "bsmpm_tls_consistent",
            &[
                "method.basis=\"bspline\"",
                "method.order=2",
                "method.reconstruction=\"tls\"",
                "method.mass=\"consistent\"",
            ],
        ),
        ("imls", &["method.reconstruction=\"imls\""]),
    ]
}

/// `mpm_step_methods/{method}/t{threads}/N`: one whole step of the vibrating bar through
/// `Simulation::run` (the bookkeeping of `history.csv` included, as in a run), 12 PPC,
/// `dt = 5e-8`, per method of [`methods_1d`], 1 thread and `available_parallelism()`.
fn mpm_step_methods(c: &mut Criterion) {
    let mut group = c.benchmark_group("mpm_step_methods");
    group
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    let n = 1_000_000;
    group.throughput(Throughput::Elements(n as u64));
    let threads = [1, parallel_threads()];
    for (name, sets) in methods_1d() {
        let mut bar: Option<Bar> = None;
        for &t in &threads {
            let pool = pool(t);
            let id = BenchmarkId::new(format!("{name}/t{t}"), n);
            group.bench_function(id, |b| {
                pool.install(|| {
                    let bar = bar.get_or_insert_with(|| {
                        let mut overrides = vec![
                            format!("grid.cells={}", n / PER_CELL),
                            format!("particles.per_cell={PER_CELL}"),
                            // Below the consistent-mass stability limit (8.7e-8 s).
                            "time.dt=5.0e-8".to_string(),
                        ];
                        overrides.extend(sets.iter().map(|s| s.to_string()));
                        Bar::from_scenario(SCENARIO, &overrides)
                    });
                    b.iter(|| black_box(bar.step_with_problem_body()))
                });
            });
        }
    }
    group.finish();
}

/// A 2D / 3D simulation of the built-in `axis_aligned_mms` scenario with its body force at
/// `t = 0` (per particle, storage order at build time).
struct TensorBench<const D: usize> {
    sim: TensorSimulation<D>,
    body: [Vec<f64>; D],
}

impl<const D: usize> TensorBench<D> {
    fn new(cells: usize, per_cell: usize, basis: &[String]) -> Self {
        let builtin =
            tlsmpm::app::builtin::find("axis_aligned_mms").expect("built-in axis_aligned_mms");
        let mut overrides = vec![
            format!("problem.dim={D}"),
            format!("grid.cells={cells}"),
            format!("particles.per_cell={per_cell}"),
            "time.dt=1.0e-7".to_string(),
        ];
        overrides.extend_from_slice(basis);
        let scenario = tlsmpm::config::from_str(builtin.toml, "bench", &overrides)
            .unwrap_or_else(|e| panic!("bench scenario: {e}"));
        let (problem, sim) = build_tensor_simulation::<D>(&scenario, false)
            .unwrap_or_else(|e| panic!("bench build ({D}D): {e}"));
        assert_eq!(sim.particles.len(), per_cell * cells.pow(D as u32));
        let mut body: [Vec<f64>; D] = std::array::from_fn(|_| vec![0.0; sim.particles.len()]);
        problem.at_particles(&sim.particles.x0, 0.0, &mut body);
        Self { sim, body }
    }

    /// One time step (only `TensorTimeStepper::step`); panics with the solver's message.
    fn step(&mut self) -> usize {
        let step = self.sim.steps_done + 1;
        let dt = self.sim.dt;
        let time = step as f64 * dt;
        self.sim
            .stepper
            .step(
                &mut self.sim.particles,
                TensorBody::PerParticle(&self.body),
                dt,
                step,
                time,
            )
            .unwrap_or_else(|e| panic!("{D}D step {step} failed: {e}"));
        self.sim.steps_done = step;
        self.sim.time = time;
        step
    }
}

/// The bases of the 2D / 3D groups: id and `method` overrides.
fn tensor_bases() -> [(&'static str, Vec<String>); 4] {
    let set = |basis: &str, order: Option<usize>| {
        let mut v = vec![format!("method.basis=\"{basis}\"")];
        v.extend(order.map(|p| format!("method.order={p}")));
        v
    };
    [
        ("linear", set("linear", None)),
        ("bspline2", set("bspline", Some(2))),
        ("bspline3", set("bspline", Some(3))),
        ("gimp", set("gimp", None)),
    ]
}

/// Sampling of a 2D / 3D group at `particles`: 10 flat samples over `large_seconds`
/// from 1e5 particles, else 20 automatic samples over 1 s; throughput in particle-steps.
fn sample_by_size(
    group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    particles: usize,
    large_seconds: u64,
) {
    if particles >= 100_000 {
        group
            .sampling_mode(SamplingMode::Flat)
            .sample_size(10)
            .warm_up_time(Duration::from_millis(500))
            .measurement_time(Duration::from_secs(large_seconds));
    } else {
        group
            .sampling_mode(SamplingMode::Auto)
            .sample_size(20)
            .warm_up_time(Duration::from_millis(300))
            .measurement_time(Duration::from_secs(1));
    }
    group.throughput(Throughput::Elements(particles as u64));
}

/// `{name}/{basis}/t{threads}/N` for `N = per_cell * n^D`, `n` in `cells`.
fn tensor_group<const D: usize>(c: &mut Criterion, name: &str, per_cell: usize, cells: [usize; 3]) {
    let mut group = c.benchmark_group(name);
    let mut thread_counts = vec![1, parallel_threads()];
    thread_counts.dedup();
    let pools: Vec<(usize, rayon::ThreadPool)> =
        thread_counts.into_iter().map(|t| (t, pool(t))).collect();
    let (_, widest) = pools.last().expect("at least one pool");
    for n in cells {
        let particles = per_cell * n.pow(D as u32);
        let seconds = if particles >= 1_000_000 { 4 } else { 2 };
        sample_by_size(&mut group, particles, seconds);
        for (basis, overrides) in tensor_bases() {
            // Built on first use (so a filter that skips it costs nothing), first-touched
            // in the widest pool, then stepped on every thread count.
            let mut slot: Option<TensorBench<D>> = None;
            for (threads, pool) in &pools {
                let id = BenchmarkId::new(format!("{basis}/t{threads}"), particles);
                group.bench_function(id, |b| {
                    let bench = slot.get_or_insert_with(|| {
                        widest.install(|| TensorBench::new(n, per_cell, &overrides))
                    });
                    pool.install(|| b.iter(|| black_box(bench.step())));
                });
            }
        }
    }
    group.finish();
}

fn mpm_step_2d(c: &mut Criterion) {
    tensor_group::<2>(c, "mpm_step_2d", 4, [50, 158, 500]);
}

fn mpm_step_3d(c: &mut Criterion) {
    tensor_group::<3>(c, "mpm_step_3d", 8, [11, 23, 50]);
}

/// The methods of `mpm_step_2d_tls`: id and overrides.
fn tls_methods() -> Vec<(String, Vec<String>)> {
    let mut methods = vec![
        (
            "bsmpm_lumped".to_string(),
            vec!["method.reconstruction=\"none\"".to_string()],
        ),
        (
            "tls_lumped".to_string(),
            vec!["method.reconstruction=\"tls\"".to_string()],
        ),
    ];
    for kind in ["kron", "pmg_cg", "cg", "pcg", "direct"] {
        methods.push((
            format!("tls_{kind}"),
            vec![
                "method.reconstruction=\"tls\"".to_string(),
                "method.mass=\"consistent\"".to_string(),
                format!("solver.kind=\"{kind}\""),
            ],
        ));
    }
    methods
}

fn mpm_step_2d_tls(c: &mut Criterion) {
    let mut group = c.benchmark_group("mpm_step_2d_tls");
    let parallel = pool(parallel_threads());
    for n in [32, 158] {
        let particles = 4 * n * n;
        sample_by_size(&mut group, particles, 3);
        for order in [2, 3] {
            for (method, mut overrides) in tls_methods() {
                overrides.push("method.basis=\"bspline\"".to_string());
                overrides.push(format!("method.order={order}"));
                overrides.push("time.dt=1.0e-5".to_string());
                let id = BenchmarkId::new(format!("bspline{order}/{method}"), particles);
                let mut slot: Option<TensorBench<2>> = None;
                group.bench_function(id, |b| {
                    let bench = slot.get_or_insert_with(|| {
                        parallel.install(|| TensorBench::new(n, 4, &overrides))
                    });
                    parallel.install(|| b.iter(|| black_box(bench.step())));
                });
            }
        }
    }
    group.finish();
}

const TRIAD_LEN: usize = 1 << 24;
const TRIAD_CHUNK: usize = 1 << 16;

fn triad_serial(a: &mut [f64], b: &[f64], c: &[f64], s: f64) {
    for ((a, b), c) in a.iter_mut().zip(b).zip(c) {
        *a = b + s * c;
    }
}

fn triad_parallel(a: &mut [f64], b: &[f64], c: &[f64], s: f64) {
    a.par_chunks_mut(TRIAD_CHUNK)
        .zip(b.par_chunks(TRIAD_CHUNK))
        .zip(c.par_chunks(TRIAD_CHUNK))
        .for_each(|((a, b), c)| triad_serial(a, b, c, s));
}

fn memory_bandwidth(c: &mut Criterion) {
    let mut group = c.benchmark_group("memory_bandwidth");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(1000))
        .measurement_time(Duration::from_secs(3))
        .throughput(Throughput::Bytes((3 * 8 * TRIAD_LEN) as u64));
    let parallel = pool(parallel_threads());
    // First touch in parallel so that pages are spread like the parallel accesses.
    let (mut a, b, cc) = parallel.install(|| {
        let fill = |value: f64| {
            let mut v = vec![0.0f64; TRIAD_LEN];
            v.par_chunks_mut(TRIAD_CHUNK).for_each(|c| c.fill(value));
            v
        };
        (fill(0.0), fill(1.0), fill(2.0))
    });
    let s = black_box(3.0);
    group.bench_function("triad_serial", |bench| {
        bench.iter(|| {
            triad_serial(&mut a, black_box(&b), black_box(&cc), s);
            black_box(&mut a);
        });
    });
    group.bench_function("triad_parallel", |bench| {
        parallel.install(|| {
            bench.iter(|| {
                triad_parallel(&mut a, black_box(&b), black_box(&cc), s);
                black_box(&mut a);
            })
        });
    });
    // Still zero when a filter skipped both triads.
    let written = a[TRIAD_LEN / 2];
    assert!(written == 7.0 || written == 0.0, "triad wrote {written}");
    group.finish();
}

criterion_group!(
    benches,
    mpm_step,
    mpm_step_methods,
    two_phase_step,
    mms_step,
    mpm_step_2d,
    mpm_step_3d,
    mpm_step_2d_tls,
    memory_bandwidth
);
criterion_main!(benches);
