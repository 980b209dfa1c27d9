//! The ULFEM reference (SPEC §6.3): second-order convergence against the exact small-strain
//! vibrating bar (SPEC §6.2), self-convergence on the large-deformation bar (Hill law, the
//! reference the MPM errors of SPEC §6.3 are measured against), and the quasi-static stress
//! of the column compaction (SPEC §6.4).

use std::f64::consts::PI;
use tlsmpm::numerics::norms::relative_l2;
use tlsmpm::physics::{Boundary, Hill, LinearElastic, Material};
use tlsmpm::problems::ulfem::{Ulfem, UlfemSetup};
use tlsmpm::problems::{ColumnCompaction, Field, Problem, VibratingBar};

/// Run a reference to `end` and return it.
fn solve(
    setup: UlfemSetup,
    initial_velocity: &dyn Fn(f64) -> f64,
    body: &dyn Fn(f64) -> f64,
    end: f64,
) -> Ulfem {
    let mut fe = Ulfem::new(setup, initial_velocity).expect("valid set-up");
    fe.advance_to(end, body).expect("finite run");
    assert!(
        (fe.time() - end).abs() < 1e-9 * end,
        "{} vs {end}",
        fe.time()
    );
    fe
}

fn order(coarse: f64, fine: f64) -> f64 {
    (coarse / fine).log2()
}

/// Element midpoints of a mesh of `nodes` nodes on `[0, length]`.
fn midpoints(nodes: usize, length: f64) -> Vec<f64> {
    let h = length / (nodes - 1) as f64;
    (0..nodes - 1).map(|e| (e as f64 + 0.5) * h).collect()
}

#[test]
fn small_deformation_bar_converges_at_second_order_to_the_exact_solution() {
    let bar = VibratingBar {
        length: 1.0,
        v0: 0.28,
        density: 2000.0,
        youngs_modulus: 7e6,
        small_strain: true,
    };
    let (dt, end) = (1e-7, 1.9e-6);
    let exact = |field, x: &[f64]| -> Vec<f64> {
        x.iter()
            .map(|&x| bar.exact(field, x, end).expect("exact solution"))
            .collect()
    };
    println!("nodes | u rel L2 at nodes | u rel L2 at midpoints | stress rel L2 at midpoints");
    let mut errors = Vec::new();
    for nodes in [20, 40, 80] {
        let setup = UlfemSetup {
            length: bar.length,
            nodes,
            density: bar.density,
            material: Material::Linear(LinearElastic {
                youngs_modulus: bar.youngs_modulus,
            }),
            boundary: bar.boundary(),
            dt,
        };
        let fe = solve(
            setup,
            &|x| bar.v0 * (PI * x / bar.length).sin(),
            &|t| bar.body_acceleration(t),
            end,
        );
        assert_eq!(fe.substeps(), 1);
        let nodal = fe.material_positions().to_vec();
        let mid = midpoints(nodes, bar.length);
        let u_nodes = relative_l2(
            &fe.values(Field::Displacement, &nodal),
            &exact(Field::Displacement, &nodal),
        );
        let u_mid = relative_l2(
            &fe.values(Field::Displacement, &mid),
            &exact(Field::Displacement, &mid),
        );
        let s_mid = relative_l2(fe.stresses(), &exact(Field::Stress, &mid));
        println!("{nodes:5} | {u_nodes:17.3e} | {u_mid:21.3e} | {s_mid:26.3e}");
        errors.push((u_nodes, u_mid, s_mid));
    }
    for k in 0..2 {
        let (u_nodes, u_mid, s_mid) = errors[k];
        let (_, u_mid_fine, s_mid_fine) = errors[k + 1];
        let (pu, ps) = (order(u_mid, u_mid_fine), order(s_mid, s_mid_fine));
        println!("orders {k}: displacement {pu:.3}, stress {ps:.3}");
        assert!(pu > 1.8 && pu < 2.2, "displacement order {pu}");
        assert!(ps > 1.8 && ps < 2.2, "stress order {ps}");
        // At the nodes (which carry the exact initial velocity) the displacement is far more
        // accurate than its interpolant: what is left is the O(h^2 w^2 t^2) spatial error and
        // the Euler–Cromer time error, relative w^2 dt^2 / 6 ~ 5.8e-11.
        let time_error = bar.omega().powi(2) * dt * dt / 6.0;
        assert!(u_nodes < 3.0 * time_error, "{u_nodes} vs {time_error}");
    }
}

/// The large-deformation bar of SPEC §6.3 (Hill, `E = 4e4`, `v0 = 0.8`, `dt = 1e-4`, end
/// 0.1 s) with `nodes` nodes.
fn large_bar(nodes: usize) -> Ulfem {
    let setup = UlfemSetup {
        length: 1.0,
        nodes,
        density: 2000.0,
        material: Material::Hill(Hill {
            youngs_modulus: 4e4,
        }),
        boundary: Boundary::fixed_both(),
        dt: 1e-4,
    };
    solve(setup, &|x| 0.8 * (PI * x).sin(), &|_| 0.0, 0.1)
}

#[test]
fn large_deformation_bar_self_converges_at_second_order() {
    let meshes = [120, 240, 480];
    let solutions: Vec<Ulfem> = meshes.iter().map(|&n| large_bar(n)).collect();
    // 200 common material points (cell centres of a 200-cell MPM-like layout).
    let points: Vec<f64> = (0..200).map(|k| (k as f64 + 0.5) / 200.0).collect();
    let fields = [Field::Displacement, Field::Velocity, Field::Stress];
    let values: Vec<Vec<Vec<f64>>> = solutions
        .iter()
        .map(|fe| fields.iter().map(|&f| fe.values(f, &points)).collect())
        .collect();

    // It is a large deformation: strains of several percent, |sigma| / E well above 1 %.
    let fine = &solutions[2];
    let max_stress = fine.stresses().iter().fold(0.0f64, |m, s| m.max(s.abs()));
    let max_strain = fine
        .element_lengths()
        .iter()
        .fold(0.0f64, |m, l| m.max((l * 479.0 - 1.0).abs()));
    // Hill's law integrates to J = E / (E - sigma) with J = len / h0; the discrete update
    // keeps (E - sigma) len / (E h0) = 1 up to the sum of deps^2 (a linear law would be off by
    // O(strain^2) ~ 3 % here).
    let hill_defect = fine
        .stresses()
        .iter()
        .zip(fine.element_lengths())
        .fold(0.0f64, |m, (s, l)| {
            m.max(((4e4 - s) * l * 479.0 / 4e4 - 1.0).abs())
        });
    println!(
        "large bar, 480 nodes: max |stress| / E = {:.4}, max |strain| = {max_strain:.4}, \
         max |(E - sigma) J / E - 1| = {hill_defect:.2e}",
        max_stress / 4e4
    );
    assert!(
        max_stress / 4e4 > 0.05,
        "max |stress| / E = {}",
        max_stress / 4e4
    );
    assert!(max_strain > 0.05, "max strain {max_strain}");
    assert!(hill_defect < 1e-3, "Hill closed form off by {hill_defect}");

    println!("field        | rel L2 (120 vs 240) | rel L2 (240 vs 480) | order");
    for (k, field) in fields.iter().enumerate() {
        let d1 = relative_l2(&values[0][k], &values[1][k]);
        let d2 = relative_l2(&values[1][k], &values[2][k]);
        let p = order(d1, d2);
        println!("{:12} | {d1:19.3e} | {d2:19.3e} | {p:.3}", field.name());
        assert!(p > 1.5, "{}: self-convergence order {p}", field.name());
        // Richardson estimate of the spatial error of the 120-DOF reference (SPEC §6.3).
        println!(
            "{:12}   estimated spatial error of the 120-node reference: {:.2e}",
            "",
            d1 / (1.0 - 0.5f64.powf(p))
        );
    }
}

#[test]
fn large_deformation_bar_time_error_is_first_order_and_small() {
    // The self-convergence above keeps dt = 1e-4 fixed; this measures what it leaves out.
    let bar = |dt: f64| {
        let setup = UlfemSetup {
            length: 1.0,
            nodes: 120,
            density: 2000.0,
            material: Material::Hill(Hill {
                youngs_modulus: 4e4,
            }),
            boundary: Boundary::fixed_both(),
            dt,
        };
        solve(setup, &|x| 0.8 * (PI * x).sin(), &|_| 0.0, 0.1)
    };
    let runs = [bar(1e-4), bar(1e-5), bar(1e-6)];
    let points: Vec<f64> = (0..200).map(|k| (k as f64 + 0.5) / 200.0).collect();
    println!("field        | rel L2 dt=1e-4 vs 1e-6 | dt=1e-5 vs 1e-6 | ratio");
    for field in [Field::Displacement, Field::Velocity, Field::Stress] {
        let reference = runs[2].values(field, &points);
        let e4 = relative_l2(&runs[0].values(field, &points), &reference);
        let e5 = relative_l2(&runs[1].values(field, &points), &reference);
        // Against dt = 1e-6 the true errors are e4 (1 - 0.01) and e5 (1 - 0.1).
        let ratio = (e4 / 0.99) / (e5 / 0.9);
        println!("{:12} | {e4:22.3e} | {e5:15.3e} | {ratio:.2}", field.name());
        assert!(
            (8.0..12.5).contains(&ratio),
            "{}: ratio {ratio}",
            field.name()
        );
        // Velocity carries the O(dt) half-step lag of Euler–Cromer (~4e-3); u and sigma less.
        let limit = if field == Field::Velocity { 1e-2 } else { 1e-3 };
        assert!(e4 < limit, "{}: time error {e4}", field.name());
    }
}

#[test]
fn column_compaction_stress_is_the_weight_above() {
    let column = ColumnCompaction {
        length: 50.0,
        gravity: -200.0,
        density: 1.0,
        ramp_time: 0.5,
    };
    let end = column.ramp_time;
    let youngs_modulus = 1e6;
    let setup = UlfemSetup {
        length: column.length,
        nodes: 100,
        density: column.density,
        material: Material::Hill(Hill { youngs_modulus }),
        boundary: column.boundary(),
        dt: 1e-4,
    };
    let fe = solve(setup, &|_| 0.0, &|t| column.body_acceleration(t), end);
    let points: Vec<f64> = (0..200)
        .map(|k| (k as f64 + 0.5) * column.length / 200.0)
        .collect();
    let exact: Vec<f64> = points
        .iter()
        .map(|&x| column.exact(Field::Stress, x, end).expect("exact stress"))
        .collect();
    let error = relative_l2(&fe.values(Field::Stress, &points), &exact);
    // Quasi-static Hill column: J - 1 = s / (1 - s), s = rho b (H - X) / E, so the top
    // settles by -H (1 - ln(1 + a) / a) with a = rho |b| H / E.
    let a = column.density * column.gravity.abs() * column.length / youngs_modulus;
    let settlement = -column.length * (1.0 - (1.0 + a).ln() / a);
    let top = fe.value(Field::Displacement, column.length);
    println!(
        "column, 100 nodes: stress rel L2 {error:.3e}; top displacement {top:.5} \
         (quasi-static Hill {settlement:.5})"
    );
    assert!(error < 0.02, "stress rel L2 {error}");
    assert!(
        (top - settlement).abs() < 0.01 * settlement.abs(),
        "top {top} vs {settlement}"
    );
    // Bottom fixed, top traction free.
    assert_eq!(fe.value(Field::Displacement, 0.0), 0.0);
    assert!(fe.stresses()[98].abs() < 0.02 * fe.stresses()[0].abs());
}
