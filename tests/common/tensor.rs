//! Helpers of the 2D / 3D integration tests: 1D and 2D / 3D runs of a built-in scenario,
//! the cross-dimension comparison of extruded runs, and bit patterns for thread-count
//! determinism.

use super::{pool, scenario};
use tlsmpm::app::build_simulation;
use tlsmpm::app::tensor_run::build_tensor_simulation;
use tlsmpm::particles::{Particles, TensorParticles};
use tlsmpm::physics::tensor::TensorSimulation;
use tlsmpm::problems::tensor::TensorProblem;

/// Run the 1D built-in `name` with overrides `sets` (2 threads).
pub fn run_1d(name: &str, sets: &[&str]) -> Particles {
    let s = scenario(name, sets);
    let (problem, mut sim) = build_simulation(&s, false).expect("build 1D");
    let steps = s.n_steps();
    pool(2)
        .install(|| sim.run(steps, &|t| problem.body_acceleration(t), &mut |_| Ok(())))
        .expect("1D run");
    sim.particles
}

/// Run the built-in `name` in `D` dimensions on `threads` threads.
pub fn run_nd<const D: usize>(
    name: &str,
    sets: &[&str],
    threads: usize,
) -> (TensorProblem<D>, TensorSimulation<D>) {
    let s = scenario(name, sets);
    let (problem, mut sim) = build_tensor_simulation::<D>(&s, false).expect("build 2D/3D");
    pool(threads)
        .install(|| sim.run(&problem, &mut |_| Ok(true)))
        .expect("2D/3D run");
    (problem, sim)
}

/// Largest relative difference (to the largest 1D magnitude) of `u_x` and `sigma_xx`
/// between the 1D particle at `X` and every extruded particle with the same `X`, and the
/// largest transverse displacement.
pub fn cross_dimension_difference<const D: usize>(
    one: &Particles,
    many: &TensorParticles<D>,
) -> (f64, f64, f64) {
    let scale_u = one.u.iter().fold(0.0f64, |m, u| m.max(u.abs()));
    let scale_s = one.stress.iter().fold(0.0f64, |m, s| m.max(s.abs()));
    let mut by_x0 = std::collections::HashMap::new();
    for k in 0..one.len() {
        by_x0.insert(one.x0[k].to_bits(), k);
    }
    let (mut du, mut ds, mut transverse) = (0.0f64, 0.0f64, 0.0f64);
    for k in 0..many.len() {
        let j = by_x0[&many.x0[0][k].to_bits()];
        du = du.max((many.u[0][k] - one.u[j]).abs() / scale_u);
        ds = ds.max((many.stress[0][k] - one.stress[j]).abs() / scale_s);
        for a in 1..D {
            transverse = transverse.max(many.u[a][k].abs() / scale_u);
        }
    }
    (du, ds, transverse)
}

/// The bit patterns of ids, positions, displacements, velocities, stresses and volumes.
pub fn bits<const D: usize>(p: &TensorParticles<D>) -> Vec<u64> {
    let mut out: Vec<u64> = p.id.iter().map(|&i| i as u64).collect();
    for field in [&p.x[..], &p.u[..], &p.v[..], &p.stress[..]] {
        for component in field {
            out.extend(component.iter().map(|v| v.to_bits()));
        }
    }
    out.extend(p.volume.iter().map(|v| v.to_bits()));
    out
}
