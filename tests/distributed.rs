//! The 2D / 3D step split over ranks (slabs of the last axis), lumped or consistent mass,
//! direct or TLS mapping, run as threads of this process through `LocalRanks`: the same
//! particles as one process to round-off,
//! every particle on exactly one rank after migrations, conservation summed over ranks,
//! bitwise repeatable, and clear errors for what it does not do.

mod common;

use common::tensor::run_nd;
use common::{pool, scenario};
use tlsmpm::app::tensor_run::build_tensor_simulation;
use tlsmpm::physics::distributed::{LocalRanks, RankExchange};
use tlsmpm::physics::{tensor::TensorSimulation, HistoryRow};

/// The particles of a finished run, by id: `(x, v, stress)` per particle.
type State = Vec<Option<Vec<f64>>>;

fn state_of<const D: usize>(sim: &TensorSimulation<D>, into: &mut State) {
    let p = &sim.particles;
    for k in 0..p.len() {
        let mut values: Vec<f64> = (0..D).map(|a| p.x[a][k]).collect();
        values.extend((0..D).map(|a| p.v[a][k]));
        values.extend((0..4).map(|s| p.stress[s][k]));
        assert!(into[p.id[k]].is_none(), "particle {} on two ranks", p.id[k]);
        into[p.id[k]] = Some(values);
    }
}

/// One run of the built-in `name` with `sets` on `ranks` ranks (one thread each), every
/// particle checked to be on exactly one rank after every step: the particles by id, each
/// rank's history, how many particles ended on another rank than they started on.
fn run_ranks<const D: usize>(
    name: &str,
    sets: &[&str],
    ranks: usize,
) -> (State, Vec<Vec<HistoryRow>>, usize) {
    let s = scenario(name, sets);
    // A second group of the same ranks checks after every step that each particle is on
    // exactly one rank.
    let checks = LocalRanks::group(ranks);
    let results: Vec<_> = std::thread::scope(|scope| {
        let handles: Vec<_> = LocalRanks::group(ranks)
            .into_iter()
            .zip(checks)
            .map(|(exchange, check)| {
                let s = &s;
                scope.spawn(move || {
                    let (problem, mut sim) = build_tensor_simulation::<D>(s, false).expect("build");
                    let n = sim.particles.len();
                    sim.distribute(Box::new(exchange)).expect("distribute");
                    let started: Vec<usize> = sim.particles.id.clone();
                    let mut every_step = |sim: &TensorSimulation<D>| {
                        let ids: Vec<f64> = sim.particles.id.iter().map(|&i| i as f64).collect();
                        let mut seen = vec![0u8; n];
                        for part in check.all_gather(&ids)? {
                            for id in part {
                                seen[id as usize] += 1;
                            }
                        }
                        assert!(
                            seen.iter().all(|&c| c == 1),
                            "step {}: a particle is lost or on two ranks",
                            sim.steps_done
                        );
                        Ok(true)
                    };
                    pool(1)
                        .install(|| sim.run(&problem, &mut every_step))
                        .expect("run");
                    let moved = sim
                        .particles
                        .id
                        .iter()
                        .filter(|id| !started.contains(id))
                        .count();
                    (n, sim, moved)
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("rank thread"))
            .collect()
    });
    let n = results[0].0;
    let mut state = vec![None; n];
    let mut histories = Vec::new();
    let mut moved = 0;
    for (_, sim, m) in &results {
        state_of(sim, &mut state);
        histories.push(sim.history.clone());
        moved += m;
    }
    assert!(state.iter().all(Option::is_some), "a particle was lost");
    (state, histories, moved)
}

fn bits(state: &State) -> Vec<u64> {
    state
        .iter()
        .flatten()
        .flatten()
        .map(|x| x.to_bits())
        .collect()
}

/// Largest difference per quantity (position, velocity, stress), relative to the largest
/// magnitude of that quantity in `reference`.
fn relative_difference(reference: &State, other: &State, d: usize) -> [f64; 3] {
    let groups = [0..d, d..2 * d, 2 * d..2 * d + 4];
    let mut out = [0.0; 3];
    for (g, range) in groups.iter().enumerate() {
        let scale = reference
            .iter()
            .flatten()
            .flat_map(|v| v[range.clone()].iter())
            .fold(0.0f64, |m, x| m.max(x.abs()));
        for (a, b) in reference.iter().flatten().zip(other.iter().flatten()) {
            for i in range.clone() {
                out[g] = f64::max(out[g], (a[i] - b[i]).abs() / scale);
            }
        }
    }
    out
}

#[test]
fn two_and_three_ranks_give_the_one_process_particles_to_round_off() {
    let sets_2d = ["grid.cells=12", "time.end=0.004"];
    for basis in ["linear", "bspline", "gimp"] {
        let key = format!("method.basis=\"{basis}\"");
        let mut sets = sets_2d.to_vec();
        sets.push(&key);
        let (one, one_history, _) = run_ranks::<2>("axis_aligned_mms", &sets, 1);
        // One rank through the distributed path is the plain run, bit for bit.
        let (_, plain) = run_nd::<2>("axis_aligned_mms", &sets, 1);
        let mut plain_state = vec![None; one.len()];
        state_of(&plain, &mut plain_state);
        assert!(
            bits(&plain_state) == bits(&one),
            "{basis}: one rank differs from the plain run"
        );
        assert_eq!(plain.history.len(), one_history[0].len());
        for (a, b) in plain.history.iter().zip(&one_history[0]) {
            assert_eq!(a.mass_rel_error.to_bits(), b.mass_rel_error.to_bits());
            assert_eq!(a.strain_energy.to_bits(), b.strain_energy.to_bits());
        }
        for ranks in [2, 3] {
            let (many, histories, moved) = run_ranks::<2>("axis_aligned_mms", &sets, ranks);
            let [dx, dv, ds] = relative_difference(&one, &many, 2);
            assert!(
                dx < 1e-12 && dv < 1e-12 && ds < 1e-12,
                "{basis} {ranks} ranks: {dx:e} {dv:e} {ds:e}"
            );
            assert!(
                moved > 0,
                "{basis} {ranks} ranks: the test needs migrations"
            );
            // Every rank saw the same global diagnostics, at round-off.
            for h in &histories {
                assert_eq!(h.len(), one_history[0].len());
                for (row, first) in h.iter().zip(&histories[0]) {
                    assert_eq!(row.mass_rel_error.to_bits(), first.mass_rel_error.to_bits());
                    assert_eq!(row.kinetic_energy.to_bits(), first.kinetic_energy.to_bits());
                    assert!(
                        row.mass_rel_error < 1e-13,
                        "{basis} {ranks}: mass {:e}",
                        row.mass_rel_error
                    );
                    let momentum = row.momentum_rel_error.unwrap_or(0.0);
                    assert!(momentum < 1e-13, "{basis} {ranks}: momentum {momentum:e}");
                }
            }
            let last = (histories[0].last().unwrap(), one_history[0].last().unwrap());
            let energy =
                (last.0.kinetic_energy - last.1.kinetic_energy).abs() / last.1.kinetic_energy;
            assert!(energy < 1e-12, "{basis} {ranks}: kinetic energy {energy:e}");
            assert_eq!(last.0.grid_crossings, last.1.grid_crossings);
        }
    }
}

/// TLS (cell totals split across slab faces, the material extent over all ranks) with
/// the consistent mass solved by CG over ranks: one rank is the plain run bit for bit;
/// two and three ranks agree with it to the CG tolerance (1e-13 here).
#[test]
fn tls_and_the_consistent_mass_over_ranks_give_the_one_process_particles() {
    for (basis, mass) in [("bspline", "consistent"), ("linear", "lumped")] {
        let (b, m) = (
            format!("method.basis=\"{basis}\""),
            format!("method.mass=\"{mass}\""),
        );
        let sets = [
            "grid.cells=12",
            "time.end=0.002",
            "method.reconstruction=\"tls\"",
            "solver.kind=\"pcg\"",
            "solver.tolerance=1e-13",
            &b,
            &m,
        ];
        let (one, _, _) = run_ranks::<2>("axis_aligned_mms", &sets, 1);
        let (_, plain) = run_nd::<2>("axis_aligned_mms", &sets, 1);
        let mut plain_state = vec![None; one.len()];
        state_of(&plain, &mut plain_state);
        assert!(
            bits(&plain_state) == bits(&one),
            "{basis} {mass}: one rank differs from the plain run"
        );
        for ranks in [2, 3] {
            let (many, histories, moved) = run_ranks::<2>("axis_aligned_mms", &sets, ranks);
            let [dx, dv, ds] = relative_difference(&one, &many, 2);
            assert!(
                dx < 1e-12 && dv < 1e-12 && ds < 1e-12,
                "{basis} {mass} {ranks} ranks: {dx:e} {dv:e} {ds:e}"
            );
            assert!(moved > 0, "{basis} {mass} {ranks}: no migration");
            for row in &histories[0] {
                let momentum = row.momentum_rel_error.unwrap_or(0.0);
                assert!(
                    row.mass_rel_error < 1e-13 && momentum < 1e-13,
                    "{basis} {mass} {ranks}: mass {:e}, momentum {momentum:e}",
                    row.mass_rel_error
                );
            }
        }
    }
}

/// A grid longer in x is cut along x: strided shared layers, migration along x.
#[test]
fn a_wide_grid_is_cut_along_its_longest_axis() {
    for extra in ["method.mass=\"lumped\"", "method.mass=\"consistent\""] {
        let sets = [
            "grid.cells=[16, 6]",
            "time.end=0.002",
            "method.basis=\"bspline\"",
            "method.reconstruction=\"tls\"",
            "solver.kind=\"pcg\"",
            "solver.tolerance=1e-13",
            extra,
        ];
        let (one, _, _) = run_ranks::<2>("axis_aligned_mms", &sets, 1);
        let (two, histories, moved) = run_ranks::<2>("axis_aligned_mms", &sets, 2);
        let [dx, dv, ds] = relative_difference(&one, &two, 2);
        assert!(
            dx < 1e-12 && dv < 1e-12 && ds < 1e-12,
            "{extra}: {dx:e} {dv:e} {ds:e}"
        );
        assert!(moved > 0, "{extra}: no migration along x");
        let last = histories[0].last().expect("history");
        assert!(
            last.mass_rel_error < 1e-13,
            "{extra}: {:e}",
            last.mass_rel_error
        );
    }
}

#[test]
fn a_distributed_run_repeats_bit_for_bit_and_runs_in_3d() {
    let sets = [
        "grid.cells=12",
        "time.end=0.002",
        "method.basis=\"bspline\"",
    ];
    let (first, _, _) = run_ranks::<2>("axis_aligned_mms", &sets, 2);
    let (again, _, _) = run_ranks::<2>("axis_aligned_mms", &sets, 2);
    let bits =
        |s: &State| -> Vec<u64> { s.iter().flatten().flatten().map(|x| x.to_bits()).collect() };
    assert_eq!(bits(&first), bits(&again));
    let sets3 = [
        "problem.dim=3",
        "particles.per_cell=8",
        "grid.cells=[4, 4, 8]",
        "time.end=0.002",
    ];
    let (one, _, _) = run_ranks::<3>("axis_aligned_mms", &sets3, 1);
    let (two, _, _) = run_ranks::<3>("axis_aligned_mms", &sets3, 2);
    let [dx, dv, _] = relative_difference(&one, &two, 3);
    assert!(dx < 1e-12 && dv < 1e-12, "3D: {dx:e} {dv:e}");
}

#[test]
fn what_a_distributed_run_does_not_do_is_refused_naming_the_key() {
    let refused = |sets: &[&str], ranks: usize| -> Vec<String> {
        let s = scenario("axis_aligned_mms", sets);
        std::thread::scope(|scope| {
            let handles: Vec<_> = LocalRanks::group(ranks)
                .into_iter()
                .map(|exchange| {
                    let s = &s;
                    scope.spawn(move || {
                        let (_, mut sim) = build_tensor_simulation::<2>(s, false).expect("build");
                        sim.distribute(Box::new(exchange))
                            .expect_err("refused")
                            .to_string()
                    })
                })
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().expect("rank"))
                .collect()
        })
    };
    let thin = refused(&["grid.cells=4"], 5);
    assert!(
        thin.iter().all(
            |m| m.contains("grid.cells") && m.contains("5 ranks on 4 cell layers along axis y")
        ),
        "{thin:?}"
    );
    let thin = refused(&["grid.cells=4"], 3);
    assert!(
        thin[0].contains("thinner than the basis support"),
        "{thin:?}"
    );
    // The Kronecker preconditioner (the 2D / 3D default in one process) is not local.
    let kron = refused(
        &[
            "grid.cells=8",
            "method.reconstruction=\"tls\"",
            "method.mass=\"consistent\"",
            "solver.kind=\"kron\"",
        ],
        2,
    );
    assert!(
        kron.iter()
            .all(|m| m.contains("solver.kind") && m.contains("\"pcg\"")),
        "{kron:?}"
    );
    let usl = refused(&["grid.cells=8", "method.scheme=\"usl\""], 2);
    assert!(usl[0].contains("method.scheme"), "{usl:?}");
}
