//! The dimension-generic core (`docs/dimensions.md`): the 1D benchmarks extruded to 2D and
//! 3D with roller side walls and Poisson's ratio 0 reproduce the 1D runs to round-off;
//! the mapping conserves mass and every momentum component to round-off for every basis;
//! results are bitwise identical for any thread count; VTU output reads back.

mod common;

use common::scenario;
use common::tensor::{bits, cross_dimension_difference, run_1d, run_nd};
use tlsmpm::particles::TensorParticles;

#[test]
fn extruded_column_and_bar_equal_the_1d_runs_to_round_off() {
    // 2 particles per axis: 2 in 1D, 4 in 2D, 8 in 3D. Column: linear law, 200 steps;
    // bar: 40 cells, quadratic B-splines, the published step.
    let cases: [(&str, &[&str]); 3] = [
        (
            "column_compaction",
            &[
                "material.model=\"linear\"",
                "time.end=0.02",
                "grid.cells=20",
            ],
        ),
        ("vibrating_bar", &["grid.cells=20"]),
        (
            "vibrating_bar",
            &[
                "grid.cells=20",
                "method.basis=\"bspline\"",
                "method.order=2",
            ],
        ),
    ];
    for (name, sets) in cases {
        let mut one_sets = sets.to_vec();
        one_sets.push("particles.per_cell=2");
        let one = run_1d(name, &one_sets);
        let mut two_sets = sets.to_vec();
        two_sets.extend(["particles.per_cell=4", "problem.dim=2"]);
        let (_, two) = run_nd::<2>(name, &two_sets, 2);
        let (du, ds, dt) = cross_dimension_difference(&one, &two.particles);
        assert!(
            du < 1e-12 && ds < 1e-12 && dt < 1e-12,
            "{name} {sets:?} 2D: {du:e} {ds:e} {dt:e}"
        );
        let mut three_sets = sets.to_vec();
        three_sets.extend(["particles.per_cell=8", "problem.dim=3"]);
        let (_, three) = run_nd::<3>(name, &three_sets, 2);
        let (du, ds, dt) = cross_dimension_difference(&one, &three.particles);
        assert!(
            du < 1e-12 && ds < 1e-12 && dt < 1e-12,
            "{name} {sets:?} 3D: {du:e} {ds:e} {dt:e}"
        );
        assert_eq!(three.particles.len(), 4 * one.len());
    }
}

#[test]
fn the_mapping_conserves_mass_and_momentum_to_round_off_for_every_basis() {
    for basis in [
        "method.basis=\"linear\"",
        "method.basis=\"gimp\"",
        "method.basis=\"bspline\"",
    ] {
        for scheme in ["method.scheme=\"musl\"", "method.scheme=\"usl\""] {
            let sets = [basis, scheme, "grid.cells=12", "time.end=0.004"];
            let (_, sim) = run_nd::<2>("axis_aligned_mms", &sets, 2);
            assert!(
                sim.grid_crossings > 0,
                "{sets:?}: the test needs grid crossings"
            );
            assert!(
                sim.max_mass_error <= 1e-13,
                "{sets:?}: mass {:e}",
                sim.max_mass_error
            );
            assert!(
                sim.max_momentum_error <= 1e-13,
                "{sets:?}: momentum {:e}",
                sim.max_momentum_error
            );
            let sets3 = [
                basis,
                scheme,
                "grid.cells=5",
                "time.end=0.004",
                "problem.dim=3",
                "particles.per_cell=8",
            ];
            let (_, sim) = run_nd::<3>("axis_aligned_mms", &sets3, 2);
            assert!(
                sim.max_mass_error <= 1e-13,
                "{sets3:?}: mass {:e}",
                sim.max_mass_error
            );
            assert!(
                sim.max_momentum_error <= 1e-13,
                "{sets3:?}: momentum {:e}",
                sim.max_momentum_error
            );
        }
    }
}

#[test]
fn results_are_bitwise_identical_on_one_and_three_threads() {
    // Enough cells for several scatter tasks (slabs of >= 256 cells).
    for basis in ["linear", "gimp", "bspline"] {
        let key = format!("method.basis=\"{basis}\"");
        let sets = [
            key.as_str(),
            "grid.cells=48",
            "time.end=0.001",
            "method.order=3",
        ];
        let (_, serial) = run_nd::<2>("axis_aligned_mms", &sets, 1);
        let (_, parallel) = run_nd::<2>("axis_aligned_mms", &sets, 3);
        assert_eq!(
            bits(&serial.particles),
            bits(&parallel.particles),
            "2D {basis}"
        );
        let h: Vec<u64> = serial
            .history
            .iter()
            .map(|r| r.kinetic_energy.to_bits())
            .collect();
        let h3: Vec<u64> = parallel
            .history
            .iter()
            .map(|r| r.kinetic_energy.to_bits())
            .collect();
        assert_eq!(h, h3, "2D {basis} history");
        let sets3 = [
            key.as_str(),
            "grid.cells=[8, 8, 12]",
            "time.end=0.0005",
            "problem.dim=3",
            "particles.per_cell=8",
        ];
        let (_, serial) = run_nd::<3>("axis_aligned_mms", &sets3, 1);
        let (_, parallel) = run_nd::<3>("axis_aligned_mms", &sets3, 3);
        assert_eq!(
            bits(&serial.particles),
            bits(&parallel.particles),
            "3D {basis}"
        );
    }
}

#[test]
fn a_run_writes_vtu_snapshots_that_read_back_and_a_pvd_listing_them() {
    use tlsmpm::output::vtu::read_vtu_summary;
    let mut s = scenario(
        "axis_aligned_mms",
        &[
            "grid.cells=6",
            "time.end=0.001",
            "output.vtk=true",
            "output.snapshots=4",
        ],
    );
    s.output.plots = false;
    let dir = tempfile::tempdir().expect("temporary directory");
    let options = tlsmpm::app::RunOptions {
        out_dir: dir.path().to_path_buf(),
        threads: Some(2),
        force: false,
        stop: None,
        warnings: Vec::new(),
        ranks: None,
    };
    let summary = tlsmpm::app::run(&s, "vtk", &options, &mut |_, _| {}).expect("run");
    let pvd = std::fs::read_to_string(dir.path().join("particles.pvd")).expect("pvd");
    let listed: Vec<&str> = pvd
        .split("file=\"")
        .skip(1)
        .filter_map(|rest| rest.split('"').next())
        .collect();
    // The initial state, four snapshots (the last one is the final state).
    assert_eq!(listed.len(), 5, "{pvd}");
    for file in &listed {
        let text = std::fs::read_to_string(dir.path().join(file)).expect("vtu listed in the pvd");
        let vtu = read_vtu_summary(&text).expect("a valid VTU");
        assert_eq!(vtu.n_points, summary.n_particles, "{file}");
        assert_eq!(vtu.n_cells, summary.n_particles, "{file}");
        let names: Vec<(&str, usize)> = vtu
            .arrays
            .iter()
            .map(|(n, c, _)| (n.as_str(), *c))
            .collect();
        assert_eq!(
            names,
            [
                ("displacement", 2),
                ("velocity", 2),
                ("stress", 6),
                ("volume", 1),
                ("density", 1),
                ("mass", 1)
            ],
            "{file}"
        );
        for (_, components, values) in &vtu.arrays {
            assert_eq!(values.len(), components * summary.n_particles);
            assert!(values.iter().all(|v| v.is_finite()));
        }
    }
    // The final VTU holds the final particle masses (bitwise, in storage order, summed).
    let last = std::fs::read_to_string(dir.path().join(listed[4])).expect("last vtu");
    let vtu = read_vtu_summary(&last).expect("valid");
    let total: f64 = vtu.arrays[5].2.iter().sum();
    assert!((total - 1.0).abs() < 1e-12, "total mass {total}");
}

#[test]
fn the_generic_core_at_d_1_equals_the_1d_core() {
    // The same physics through the dimension-generic code with D = 1: the vibrating bar
    // with linear hats and quadratic B-splines, MUSL and USL.
    for sets in [
        &["grid.cells=20", "particles.per_cell=3"][..],
        &[
            "grid.cells=20",
            "particles.per_cell=3",
            "method.basis=\"bspline\"",
        ],
        &[
            "grid.cells=20",
            "particles.per_cell=3",
            "method.scheme=\"usl\"",
        ],
    ] {
        let one = run_1d("vibrating_bar", sets);
        let (_, generic) = run_nd::<1>("vibrating_bar", sets, 2);
        let (du, ds, _) = cross_dimension_difference(&one, &generic.particles);
        assert!(du < 1e-12 && ds < 1e-12, "{sets:?}: {du:e} {ds:e}");
    }
}

#[test]
fn automatic_time_steps_follow_the_cfl_number_and_agree_with_fixed_steps() {
    let fixed = ["grid.cells=16"];
    let (_, reference) = run_nd::<2>("axis_aligned_mms", &fixed, 2);
    let auto = ["grid.cells=16", "time.dt=\"auto\"", "time.cfl=0.2"];
    let (_, sim) = run_nd::<2>("axis_aligned_mms", &auto, 2);
    assert!(
        (sim.time - 0.02).abs() < 1e-15,
        "ends at time.end: {}",
        sim.time
    );
    // About cfl * limit per step: far fewer steps than the fixed 1e-5 s, more than 1 / limit.
    assert!(
        sim.steps_done > 20 && sim.steps_done < 2000,
        "{} steps",
        sim.steps_done
    );
    let (_, looser) = run_nd::<2>(
        "axis_aligned_mms",
        &["grid.cells=16", "time.dt=\"auto\"", "time.cfl=0.4"],
        2,
    );
    let ratio = looser.steps_done as f64 / sim.steps_done as f64;
    assert!(
        (ratio - 0.5).abs() < 0.05,
        "doubling the CFL number halves the steps: {ratio}"
    );
    // Same answer to within the time-discretisation error.
    let diff = (0..sim.particles.len())
        .map(|k| {
            let id = sim.particles.id[k];
            let j = reference
                .particles
                .id
                .iter()
                .position(|&i| i == id)
                .unwrap_or(0);
            (sim.particles.u[0][k] - reference.particles.u[0][j]).abs()
        })
        .fold(0.0f64, f64::max);
    assert!(diff < 2e-3, "largest u_x difference {diff:e}");
}

/// A block of particles translating and shearing across a 2D grid with free faces, stepped
/// `steps` times with the direct mapping of bin slack `slack` (keeping the shapes of the
/// first pass for the later ones when `keep_shapes`): the particles, and per step whether it
/// had a grid crossing and whether it sorted.
fn translating_block(
    slack: usize,
    steps: usize,
    keep_shapes: bool,
) -> (TensorParticles<2>, Vec<(bool, bool)>) {
    let (particles, log, _) = translating_block_with(
        slack,
        steps,
        keep_shapes,
        false,
        tlsmpm::config::Scheme::Musl,
        0.0,
    );
    (particles, log)
}

/// The particles, per step whether it crossed and whether it sorted, and the energies.
type BlockRun = (TensorParticles<2>, Vec<(bool, bool)>, Vec<(f64, f64)>);

/// [`translating_block`] under a per-particle body force
/// `b(X_p) = load (sin 2 pi X, -9.81)`, in `scheme`, with `ahead`: each step also maps the
/// next step's mass and force in its particle update (`TensorStepper::step_ahead`). Also
/// returns the energies per step.
fn translating_block_with(
    slack: usize,
    steps: usize,
    keep_shapes: bool,
    ahead: bool,
    scheme: tlsmpm::config::Scheme,
    load: f64,
) -> BlockRun {
    use tlsmpm::config::FaceCondition;
    use tlsmpm::grid::{BSplineBasis, TensorBasis, TensorGrid};
    use tlsmpm::mapping::tensor_direct::{TensorBody, TensorDirectMapping};
    use tlsmpm::physics::tensor::TensorStepper;
    use tlsmpm::physics::tensor::{NeoHookeanTensor, NodeConstraints, TensorMaterial};
    let cells = 20;
    let h = 1.0 / cells as f64;
    let grid = TensorGrid::new([1.0, 1.0], [cells, cells]);
    let basis = TensorBasis::new(grid, |g| BSplineBasis::new(g, 2).expect("order 2"));
    // 2 x 2 particles per cell in the cells [4, 10) x [4, 10).
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for j in 0..12 {
        for i in 0..12 {
            x.push((4.0 + 0.25 + 0.5 * i as f64) * h);
            y.push((4.0 + 0.25 + 0.5 * j as f64) * h);
        }
    }
    let volume = vec![0.25 * h * h; x.len()];
    let mut particles =
        TensorParticles::at_rest([x, y], volume, 1.0, |p| grid.cell_of(p).expect("inside"));
    for k in 0..particles.len() {
        let y = particles.x0[1][k];
        particles.v[0][k] = 15.0 + 2.0 * (std::f64::consts::PI * y).sin();
        particles.v[1][k] = 10.0;
    }
    let mut mapping = TensorDirectMapping::with_bin_slack(&basis, None, slack);
    if !keep_shapes {
        mapping = mapping.evaluating_every_pass();
    }
    let constraints = NodeConstraints::new(&basis, &[[FaceCondition::Free; 2]; 2]);
    let material = TensorMaterial::NeoHookean(NeoHookeanTensor {
        lambda: 5769.23,
        mu: 3846.15,
    });
    let mut stepper = TensorStepper::new(
        basis,
        mapping,
        material,
        scheme,
        constraints,
        &mut particles,
    );
    assert_eq!(stepper.maps_ahead(), keep_shapes);
    let body_of = |p: &TensorParticles<2>| -> [Vec<f64>; 2] {
        let tau = 2.0 * std::f64::consts::PI;
        [
            p.x0[0].iter().map(|x| load * (tau * x).sin()).collect(),
            vec![-9.81 * load; p.len()],
        ]
    };
    let dt = 1.0e-4;
    let (mut log, mut energies) = (Vec::new(), Vec::new());
    let mut body = body_of(&particles);
    for step in 1..=steps {
        // The body force depends on X_p only: the same for the next step while the
        // particles keep their order.
        let next = body.clone();
        let report = stepper
            .step_ahead(
                &mut particles,
                TensorBody::PerParticle(&body),
                ahead.then_some(TensorBody::PerParticle(&next)),
                dt,
                step,
                step as f64 * dt,
            )
            .expect("step");
        assert!(
            report.mass_error <= 1e-13,
            "mass error {}",
            report.mass_error
        );
        assert!(report.momentum_error.unwrap_or(0.0) <= 1e-13);
        log.push((report.crossings > 0, report.sorted));
        energies.push(report.energies);
        if report.sorted {
            body = body_of(&particles);
        }
    }
    (particles, log, energies)
}

/// Positions, velocities, deformation gradients and stresses, bit by bit.
fn particle_bits(p: &TensorParticles<2>) -> Vec<u64> {
    let mut all = Vec::new();
    for a in 0..2 {
        all.extend(p.x[a].iter().chain(&p.v[a]).map(|v| v.to_bits()));
        for b in 0..2 {
            all.extend(p.deformation_gradient[a][b].iter().map(|v| v.to_bits()));
        }
    }
    for s in &p.stress {
        all.extend(s.iter().map(|v| v.to_bits()));
    }
    all
}

#[test]
fn mapping_the_next_step_in_the_particle_update_changes_no_particle_bit() {
    // With a per-particle body force, through 120 steps of grid crossings and re-sorts
    // (after which the next step maps as usual), MUSL and USL: the particles of steps that
    // map the next step's mass and force in their update equal those of plain steps bit
    // for bit; the energies, summed per scatter task instead of per fixed chunk, to
    // round-off.
    use tlsmpm::config::Scheme;
    for scheme in [Scheme::Musl, Scheme::Usl] {
        let (ahead, ahead_log, ahead_energies) =
            translating_block_with(1, 120, true, true, scheme, 1.0);
        let (plain, plain_log, plain_energies) =
            translating_block_with(1, 120, true, false, scheme, 1.0);
        assert_eq!(ahead_log, plain_log);
        assert!(ahead_log.iter().any(|&(_, sorted)| sorted), "a re-sort");
        assert!(
            ahead_log.iter().any(|&(_, sorted)| !sorted),
            "steps mapped ahead"
        );
        assert_eq!(particle_bits(&ahead), particle_bits(&plain), "{scheme:?}");
        for (a, p) in ahead_energies.iter().zip(&plain_energies) {
            assert!((a.0 - p.0).abs() <= 1e-13 * p.0.abs(), "{a:?} {p:?}");
            assert!(
                (a.1 - p.1).abs() <= 1e-13 * p.1.abs().max(1e-300),
                "{a:?} {p:?}"
            );
        }
        // Without a shape cache nothing is mapped ahead: the same particles again.
        let (evaluated, _, _) = translating_block_with(1, 120, false, true, scheme, 1.0);
        assert_eq!(
            particle_bits(&evaluated),
            particle_bits(&plain),
            "{scheme:?}"
        );
    }
}

#[test]
fn the_direct_mapping_sorts_only_when_a_particle_strays_a_layer_and_agrees_with_exact_bins() {
    // 200 steps move the block about 6 cells in x and 4 in y.
    let steps = 200;
    let (exact, exact_log) = translating_block(0, steps, true);
    let (lazy, lazy_log) = translating_block(1, steps, true);
    let crossing_steps = exact_log.iter().filter(|(c, _)| *c).count();
    let exact_sorts = exact_log.iter().filter(|(_, s)| *s).count();
    let lazy_sorts = lazy_log.iter().filter(|(_, s)| *s).count();
    assert_eq!(
        exact_sorts, crossing_steps,
        "exact bins sort on every crossing"
    );
    assert!(
        crossing_steps > steps / 5,
        "{crossing_steps} steps with crossings"
    );
    assert!(
        lazy_sorts > 0,
        "the block travels several cells: some sorts are needed"
    );
    assert!(
        4 * lazy_sorts < crossing_steps,
        "{lazy_sorts} sorts for {crossing_steps} steps with crossings"
    );
    // The same particles to round-off (only the order of the sums differs).
    let index: std::collections::HashMap<usize, usize> =
        lazy.id.iter().enumerate().map(|(k, &id)| (id, k)).collect();
    let scale_s = exact.stress[0].iter().fold(0.0f64, |m, s| m.max(s.abs()));
    let (mut dx, mut ds) = (0.0f64, 0.0f64);
    for k in 0..exact.len() {
        let j = index[&exact.id[k]];
        for a in 0..2 {
            dx = dx.max((exact.x[a][k] - lazy.x[a][j]).abs());
        }
        for c in 0..4 {
            ds = ds.max((exact.stress[c][k] - lazy.stress[c][j]).abs() / scale_s);
        }
    }
    assert!(dx < 1e-12 && ds < 1e-10, "position {dx}, stress {ds}");
    assert!(scale_s > 1.0, "the shear loads the block: {scale_s}");
}

#[test]
fn keeping_the_shapes_of_the_first_pass_changes_no_bit() {
    // Quadratic B-splines keep their shapes for the later passes of a step; through 120
    // steps of grid crossings and re-sorts the particles match a run that evaluates the
    // basis in every pass, bit for bit.
    let (kept, kept_log) = translating_block(1, 120, true);
    let (evaluated, evaluated_log) = translating_block(1, 120, false);
    assert_eq!(kept_log, evaluated_log);
    assert!(
        kept_log.iter().any(|&(_, sorted)| sorted),
        "a re-sort happened"
    );
    assert_eq!(particle_bits(&kept), particle_bits(&evaluated));
}
