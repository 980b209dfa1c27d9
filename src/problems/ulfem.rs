//! Updated-Lagrangian finite-element (ULFEM) reference solution of the 1D one-phase
//! continuum (SPEC §1.1), the reference of the large-deformation vibrating bar (SPEC §6.3;
//! 120 DOFs there) and a check of the column compaction (SPEC §6.4).
//!
//! The bar `[0, L]` is cut into `nodes - 1` linear two-node elements of initial length
//! `h0 = L / (nodes - 1)`, with nodes at the material positions `X_i = i h0`. The mesh moves
//! with the material, so no material ever crosses an element boundary: the only errors
//! are the `O(h0^2)` error of the linear elements and the time error. Nodes carry
//! `x, u, v` and a constant lumped mass; elements carry the stress `sigma_e` and the
//! current length `len_e`. One step `t_n -> t_{n+1} = t_n + dt_fe` is the explicit
//! Euler–Cromer step of the MPM (SPEC §2) on this Lagrangian mesh:
//!
//! ```text
//! m_i    = sum over the elements e next to node i of rho0 h0 / 2         (constant)
//! f_int  : element e = [node e, node e+1] adds -sigma_e to node e and +sigma_e to node e+1
//! f_ext_i = m_i b(t_{n+1}) + end tractions (Boundary::add_tractions, end DOFs (0, nodes-1))
//! a      = (f_ext - f_int) / m;          a_i = 0 on fixed DOFs
//! v     += dt_fe a;                      v_i = 0 on fixed DOFs
//! deps_e = dt_fe (v_{e+1} - v_e) / len_e (len_e before the update)
//! u     += dt_fe v;   x += dt_fe v
//! sigma_e = law.update(sigma_e, deps_e)  (the MPM laws: linear, Hill)
//! len_e  *= 1 + deps_e
//! ```
//! The body acceleration is evaluated at the end time `t_{n+1}` of each (sub)step, as in
//! the MPM time loop. Each scenario step `dt` is split into
//! `k = max(1, ceil(dt / (0.5 h0 / c)))` sub-steps `dt_fe = dt / k`, `c = sqrt(E / rho0)`,
//! so a reference finer than the MPM grid stays stable at the scenario time step (the
//! factor 0.5 leaves room for elements compressed to half their length).
//!
//! Fields are read at material positions `X` ([`Ulfem::value`]): `u`, `v` by linear
//! interpolation of the nodal values in `X`; the stress by linear interpolation of the
//! element values placed at the element midpoints in `X` (linear extrapolation in the two
//! end half-elements).

use crate::error::{Error, Result};
use crate::physics::{Boundary, ConstitutiveLaw, Material};
use crate::problems::Field;

/// Largest number of sub-steps per scenario step accepted by [`Ulfem::new`].
const MAX_SUBSTEPS: f64 = 1e9;

/// What the reference solves.
#[derive(Clone, Copy, Debug)]
pub struct UlfemSetup {
    /// Length `L` of the bar `[0, L]`.
    pub length: f64,
    /// Number of nodes = DOFs (scenario key `problem.reference_dofs`, default 120), >= 2.
    pub nodes: usize,
    /// Initial density `rho0`.
    pub density: f64,
    /// Constitutive law (the same laws as the MPM).
    pub material: Material,
    /// Fixed and traction ends.
    pub boundary: Boundary,
    /// The scenario time step; the reference sub-steps it when needed for stability.
    pub dt: f64,
}

/// The ULFEM reference: a Lagrangian mesh of linear elements, stored as structure of
/// arrays (nodal `X, x, u, v, m`; element `sigma, len`).
#[derive(Clone, Debug)]
pub struct Ulfem {
    setup: UlfemSetup,
    /// Initial element length `h0 = L / (nodes - 1)`.
    h0: f64,
    /// Sub-step `dt_fe = dt / substeps`.
    dt_fe: f64,
    substeps: usize,
    /// Sub-steps completed.
    steps_done: usize,
    /// Material (initial) node positions `X_i = i L / (nodes - 1)`.
    x0: Vec<f64>,
    /// Current node positions.
    x: Vec<f64>,
    /// Nodal displacements.
    u: Vec<f64>,
    /// Nodal velocities.
    v: Vec<f64>,
    /// Lumped nodal masses (constant).
    mass: Vec<f64>,
    /// Element stresses.
    stress: Vec<f64>,
    /// Current element lengths.
    len: Vec<f64>,
    /// Scratch: net nodal force, then acceleration (allocated once).
    force: Vec<f64>,
}

fn require_positive(key: &str, value: f64) -> Result<()> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(Error::invalid(key, value, "must be positive and finite"))
    }
}

impl Ulfem {
    /// Nodes at `X_i = i L / (nodes - 1)`, at rest except `v(X, 0) = initial_velocity(X)`
    /// (0 at fixed ends), stress 0.
    ///
    /// Sub-steps: `k = max(1, ceil(dt / (0.5 h0 / c)))` with
    /// `c = sqrt(material.wave_modulus() / density)`, `dt_fe = dt / k`.
    ///
    /// Errors: [`Error::InvalidValue`] naming `problem.reference_dofs` for `nodes < 2`,
    /// `problem.length`, `material.density`, `material.youngs_modulus` or `time.dt` for a
    /// value that is not positive and finite (or a `dt` needing more than 1e9 sub-steps);
    /// [`Error::NonFinite`] (`reference velocity`, step 0) for a non-finite initial velocity.
    pub fn new(setup: UlfemSetup, initial_velocity: &dyn Fn(f64) -> f64) -> Result<Self> {
        let nodes = setup.nodes;
        if nodes < 2 {
            return Err(Error::invalid(
                "problem.reference_dofs",
                nodes,
                "must be at least 2",
            ));
        }
        require_positive("problem.length", setup.length)?;
        require_positive("material.density", setup.density)?;
        require_positive("material.youngs_modulus", setup.material.wave_modulus())?;
        require_positive("time.dt", setup.dt)?;

        let elements = nodes - 1;
        let h0 = setup.length / elements as f64;
        let c = (setup.material.wave_modulus() / setup.density).sqrt();
        let ratio = setup.dt / (0.5 * h0 / c);
        if !(ratio.is_finite() && ratio <= MAX_SUBSTEPS) {
            return Err(Error::invalid(
                "time.dt",
                setup.dt,
                format!(
                    "needs more than {MAX_SUBSTEPS:e} reference sub-steps per step \
                     (stability limit 0.5 h0 / c = {:e} s)",
                    0.5 * h0 / c
                ),
            ));
        }
        let substeps = (ratio.ceil() as usize).max(1);
        let dt_fe = setup.dt / substeps as f64;

        let mut x0: Vec<f64> = (0..nodes)
            .map(|i| i as f64 * setup.length / elements as f64)
            .collect();
        x0[elements] = setup.length;
        let mut v: Vec<f64> = x0.iter().map(|&x| initial_velocity(x)).collect();
        setup.boundary.zero_fixed((0, nodes - 1), &mut v);
        if v.iter().any(|v| !v.is_finite()) {
            return Err(Error::NonFinite {
                field: "reference velocity",
                step: 0,
                time: 0.0,
            });
        }
        let mut mass = vec![0.0; nodes];
        let element_mass = setup.density * h0;
        for e in 0..elements {
            mass[e] += 0.5 * element_mass;
            mass[e + 1] += 0.5 * element_mass;
        }
        Ok(Self {
            setup,
            h0,
            dt_fe,
            substeps,
            steps_done: 0,
            x: x0.clone(),
            x0,
            u: vec![0.0; nodes],
            v,
            mass,
            stress: vec![0.0; elements],
            len: vec![h0; elements],
            force: vec![0.0; nodes],
        })
    }

    /// Current time `steps_done * dt_fe` (sub-steps are counted, not accumulated).
    pub fn time(&self) -> f64 {
        self.steps_done as f64 * self.dt_fe
    }

    /// Number of nodes (DOFs).
    pub fn nodes(&self) -> usize {
        self.x0.len()
    }

    /// Sub-steps per scenario step, `k`.
    pub fn substeps(&self) -> usize {
        self.substeps
    }

    /// The sub-step `dt_fe = dt / k`.
    pub fn substep(&self) -> f64 {
        self.dt_fe
    }

    /// Sub-steps completed.
    pub fn steps_done(&self) -> usize {
        self.steps_done
    }

    /// The set-up this reference was built from.
    pub fn setup(&self) -> &UlfemSetup {
        &self.setup
    }

    /// Material (initial) node positions `X_i`.
    pub fn material_positions(&self) -> &[f64] {
        &self.x0
    }

    /// Current node positions `x_i`.
    pub fn positions(&self) -> &[f64] {
        &self.x
    }

    /// Nodal displacements `u_i`.
    pub fn displacements(&self) -> &[f64] {
        &self.u
    }

    /// Nodal velocities `v_i`.
    pub fn velocities(&self) -> &[f64] {
        &self.v
    }

    /// Lumped nodal masses `m_i` (constant).
    pub fn masses(&self) -> &[f64] {
        &self.mass
    }

    /// Element stresses `sigma_e` (element `e` spans nodes `e` and `e + 1`).
    pub fn stresses(&self) -> &[f64] {
        &self.stress
    }

    /// Current element lengths `len_e`.
    pub fn element_lengths(&self) -> &[f64] {
        &self.len
    }

    /// Advance until time `t`: take `round(t / dt_fe) - steps_done` sub-steps (none if `t`
    /// is not later than [`Ulfem::time`]). `body_acceleration(t)` is the signed body
    /// acceleration, evaluated at the end time of each sub-step.
    ///
    /// Errors: [`Error::NonFinite`] with field `reference velocity` or `reference stress`,
    /// the sub-step number and its end time, when a value stops being finite (the state is
    /// then that of the failing sub-step and [`Ulfem::time`] that of the last completed
    /// one); [`Error::InvalidValue`] (`time.end`) for a non-finite `t`.
    pub fn advance_to(&mut self, t: f64, body_acceleration: &dyn Fn(f64) -> f64) -> Result<()> {
        if !t.is_finite() {
            return Err(Error::invalid("time.end", t, "must be finite"));
        }
        let target = (t / self.dt_fe).round();
        if target <= self.steps_done as f64 {
            return Ok(());
        }
        // Saturating conversion; `target` is finite and positive here.
        let target = target as usize;
        match self.setup.material {
            Material::Linear(law) => self.run_steps(law, target, body_acceleration),
            Material::Hill(law) => self.run_steps(law, target, body_acceleration),
            Material::NeoHookean(law) => self.run_steps(law, target, body_acceleration),
        }
    }

    /// The sub-step loop, monomorphised per constitutive law; allocation-free.
    fn run_steps<L: ConstitutiveLaw>(
        &mut self,
        law: L,
        target: usize,
        body_acceleration: &dyn Fn(f64) -> f64,
    ) -> Result<()> {
        let dt = self.dt_fe;
        let boundary = self.setup.boundary;
        let ends = (0, self.x0.len() - 1);
        // Uniform initial elements: F_e = l_e / l_e^0.
        let initial_length = self.setup.length / (self.x0.len() - 1) as f64;
        let Self {
            x,
            u,
            v,
            mass,
            stress,
            len,
            force,
            steps_done,
            ..
        } = self;
        while *steps_done < target {
            let step = *steps_done + 1;
            let time = step as f64 * dt;
            let b = body_acceleration(time);

            // Net force f_ext - f_int.
            for (f, m) in force.iter_mut().zip(mass.iter()) {
                *f = m * b;
            }
            boundary.add_tractions(ends, force);
            for (e, &s) in stress.iter().enumerate() {
                force[e] += s;
                force[e + 1] -= s;
            }
            // Accelerations (in place), velocities.
            for (f, m) in force.iter_mut().zip(mass.iter()) {
                *f /= m;
            }
            boundary.zero_fixed(ends, force);
            for (v, a) in v.iter_mut().zip(force.iter()) {
                *v += dt * a;
            }
            boundary.zero_fixed(ends, v);

            // Strain increments, stresses and lengths (lengths before their update).
            let mut stress_ok = true;
            for (e, (s, l)) in stress.iter_mut().zip(len.iter_mut()).enumerate() {
                let deps = dt * (v[e + 1] - v[e]) / *l;
                *l *= 1.0 + deps;
                *s = law.update(*s, deps, *l / initial_length);
                stress_ok &= s.is_finite();
            }
            // Displacements and positions.
            let mut velocity_ok = true;
            for ((x, u), &v) in x.iter_mut().zip(u.iter_mut()).zip(v.iter()) {
                *u += dt * v;
                *x += dt * v;
                velocity_ok &= v.is_finite();
            }
            if !velocity_ok {
                return Err(Error::NonFinite {
                    field: "reference velocity",
                    step,
                    time,
                });
            }
            if !stress_ok {
                return Err(Error::NonFinite {
                    field: "reference stress",
                    step,
                    time,
                });
            }
            *steps_done = step;
        }
        Ok(())
    }

    /// Value of `field` at material position `x0`, clamped to `[0, L]`: displacement and
    /// velocity by linear interpolation of the nodal values in `X`; stress by linear
    /// interpolation of the element values placed at the element midpoints in `X`,
    /// linearly extrapolated in the two end half-elements (a 1-element mesh gives its
    /// constant stress).
    pub fn value(&self, field: Field, x0: f64) -> f64 {
        let x0 = x0.clamp(0.0, self.setup.length);
        match field {
            Field::Displacement => self.nodal(&self.u, x0),
            Field::Velocity => self.nodal(&self.v, x0),
            Field::Stress => self.elemental(x0),
            // One-phase reference: no liquid.
            Field::LiquidVelocity | Field::PorePressure | Field::EffectiveStress => f64::NAN,
        }
    }

    /// [`Ulfem::value`] at each of the material positions `x0`.
    pub fn values(&self, field: Field, x0: &[f64]) -> Vec<f64> {
        x0.iter().map(|&x| self.value(field, x)).collect()
    }

    /// Linear interpolation of a nodal field at `x0` in `[0, L]`.
    fn nodal(&self, field: &[f64], x0: f64) -> f64 {
        let elements = self.x0.len() - 1;
        // `as usize` saturates (NaN -> 0); clamp to the last element.
        let mut i = ((x0 / self.h0).floor() as usize).min(elements - 1);
        // Correct the rounding of x0 / h0 so that X_i <= x0 <= X_{i+1}: exact at nodes.
        if i > 0 && x0 < self.x0[i] {
            i -= 1;
        } else if i + 1 < elements && x0 > self.x0[i + 1] {
            i += 1;
        }
        let t = (x0 - self.x0[i]) / (self.x0[i + 1] - self.x0[i]);
        (1.0 - t) * field[i] + t * field[i + 1]
    }

    /// Linear inter-/extrapolation of the element stresses, placed at the midpoints.
    fn elemental(&self, x0: f64) -> f64 {
        let elements = self.stress.len();
        if elements == 1 {
            return self.stress[0];
        }
        // Midpoint of element j at (j + 1/2) h0.
        let s = x0 / self.h0 - 0.5;
        let j = (s.floor().max(0.0) as usize).min(elements - 2);
        let t = s - j as f64;
        (1.0 - t) * self.stress[j] + t * self.stress[j + 1]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::{Hill, LinearElastic};

    fn setup(nodes: usize, material: Material, boundary: Boundary, dt: f64) -> UlfemSetup {
        UlfemSetup {
            length: 2.0,
            nodes,
            density: 1500.0,
            material,
            boundary,
            dt,
        }
    }

    fn hill() -> Material {
        Material::Hill(Hill {
            youngs_modulus: 1e5,
        })
    }

    fn momentum(fe: &Ulfem) -> (f64, f64) {
        let p = fe.mass.iter().zip(&fe.v).map(|(m, v)| m * v).sum();
        let scale = fe.mass.iter().zip(&fe.v).map(|(m, v)| m * v.abs()).sum();
        (p, scale)
    }

    #[test]
    fn too_few_nodes_is_an_input_error_naming_the_key() {
        for nodes in [0, 1] {
            let s = setup(nodes, hill(), Boundary::fixed_both(), 1e-4);
            let err = Ulfem::new(s, &|_| 0.0).expect_err("nodes < 2 is rejected");
            assert!(err.is_input_error());
            let message = err.to_string();
            assert!(message.contains("problem.reference_dofs"), "{message}");
            assert!(message.contains("at least 2"), "{message}");
        }
        let mut s = setup(5, hill(), Boundary::fixed_both(), 1e-4);
        s.dt = f64::NAN;
        let err = Ulfem::new(s, &|_| 0.0).expect_err("NaN dt is rejected");
        assert!(err.to_string().contains("time.dt"), "{err}");
        assert!(Ulfem::new(setup(2, hill(), Boundary::fixed_both(), 1e-4), &|_| 0.0).is_ok());
    }

    #[test]
    fn mass_is_lumped_and_conserved() {
        let mut fe = Ulfem::new(setup(33, hill(), Boundary::default(), 1e-4), &|x: f64| {
            0.5 * (1.3 * x).sin() - 0.1
        })
        .unwrap();
        let total: f64 = fe.masses().iter().sum();
        assert!((total - 1500.0 * 2.0).abs() < 1e-10 * total);
        assert_eq!(fe.masses()[0], fe.masses()[1] / 2.0);
        fe.advance_to(0.05, &|_| 0.0).unwrap();
        assert_eq!(fe.masses().iter().sum::<f64>(), total);
        // Each element keeps its mass rho len = rho0 h0: its tracked length is the distance
        // of its nodes, and the deformation is large.
        let mut max_strain: f64 = 0.0;
        for (e, l) in fe.element_lengths().iter().enumerate() {
            let span = fe.positions()[e + 1] - fe.positions()[e];
            assert!(
                (l - span).abs() < 1e-12 * fe.h0,
                "element {e}: {l} vs {span}"
            );
            max_strain = max_strain.max((l / fe.h0 - 1.0).abs());
        }
        assert!(max_strain > 0.01, "max strain {max_strain}");
        for (i, (x, u)) in fe.positions().iter().zip(fe.displacements()).enumerate() {
            assert!((x - fe.material_positions()[i] - u).abs() < 1e-13);
        }
    }

    #[test]
    fn momentum_is_constant_with_free_ends_and_balances_external_forces() {
        // Free ends, no loads: total momentum constant to round-off.
        let initial = |x: f64| 0.6 * (2.1 * x).sin() + 0.05;
        let mut fe = Ulfem::new(setup(41, hill(), Boundary::default(), 1e-4), &initial).unwrap();
        let (p0, _) = momentum(&fe);
        fe.advance_to(0.1, &|_| 0.0).unwrap();
        let (p1, scale) = momentum(&fe);
        assert!(fe.stresses().iter().any(|s| s.abs() > 1e3));
        assert!((p1 - p0).abs() < 1e-13 * scale, "{p0} -> {p1}");

        // Free ends with body force and tractions: d/dt sum m v = M b + tau_r - tau_l.
        let boundary = Boundary {
            traction_left: -300.0,
            traction_right: 700.0,
            ..Boundary::default()
        };
        let mut fe = Ulfem::new(setup(41, hill(), boundary, 1e-4), &initial).unwrap();
        let (p0, _) = momentum(&fe);
        let t_end = 0.1;
        // b(t) = 3 t: sum over steps of dt * M * b(t_n) (end-time evaluation).
        let body = |t: f64| 3.0 * t;
        fe.advance_to(t_end, &body).unwrap();
        let dt = fe.substep();
        let total_mass: f64 = fe.masses().iter().sum();
        let impulse: f64 = (1..=fe.steps_done())
            .map(|n| dt * (total_mass * body(n as f64 * dt) + 700.0 + 300.0))
            .sum();
        let (p1, scale) = momentum(&fe);
        assert!(
            (p1 - p0 - impulse).abs() < 1e-12 * scale.max(impulse.abs()),
            "{} vs {impulse}",
            p1 - p0
        );
    }

    #[test]
    fn fixed_ends_stay_at_rest() {
        let mut fe = Ulfem::new(
            setup(21, hill(), Boundary::fixed_left_free_right(), 1e-4),
            &|x| x + 1.0,
        )
        .unwrap();
        assert_eq!(fe.velocities()[0], 0.0);
        fe.advance_to(0.02, &|_| -10.0).unwrap();
        assert_eq!(fe.displacements()[0], 0.0);
        assert_eq!(fe.velocities()[0], 0.0);
        assert!(fe.displacements()[20] != 0.0);
    }

    #[test]
    fn interpolation_reproduces_linear_fields() {
        for nodes in [2, 3, 7] {
            let mut fe =
                Ulfem::new(setup(nodes, hill(), Boundary::default(), 1e-4), &|x| x).unwrap();
            let h0 = fe.h0;
            for (u, x) in fe.u.iter_mut().zip(&fe.x0) {
                *u = 0.3 - 1.7 * x;
            }
            for (e, s) in fe.stress.iter_mut().enumerate() {
                *s = if nodes == 2 {
                    4.0
                } else {
                    -2.0 + 5.0 * (e as f64 + 0.5) * h0
                };
            }
            let points: Vec<f64> = (0..=37).map(|k| k as f64 * 2.0 / 37.0).collect();
            let u = fe.values(Field::Displacement, &points);
            let v = fe.values(Field::Velocity, &points);
            let s = fe.values(Field::Stress, &points);
            for (k, &x) in points.iter().enumerate() {
                assert!((u[k] - (0.3 - 1.7 * x)).abs() < 1e-14, "{nodes}: u({x})");
                assert!((v[k] - x).abs() < 1e-14, "{nodes}: v({x})");
                let exact = if nodes == 2 { 4.0 } else { -2.0 + 5.0 * x };
                assert!((s[k] - exact).abs() < 1e-13, "{nodes}: stress({x})");
            }
            // Clamped outside [0, L]; exact at the nodes.
            assert_eq!(fe.value(Field::Displacement, -1.0), fe.u[0]);
            assert_eq!(fe.value(Field::Displacement, 5.0), fe.u[nodes - 1]);
            for i in 0..nodes {
                assert_eq!(fe.value(Field::Displacement, fe.x0[i]), fe.u[i]);
            }
        }
    }

    #[test]
    fn sub_steps_and_time_are_counted() {
        let material = Material::Linear(LinearElastic {
            youngs_modulus: 1.5e7,
        });
        // c = 100, h0 = 0.1, 0.5 h0 / c = 5e-4: dt = 1.2e-3 needs 3 sub-steps.
        let mut s = setup(21, material, Boundary::fixed_both(), 1.2e-3);
        s.density = 1500.0;
        let mut fe = Ulfem::new(s, &|x: f64| (x * 1.5).sin()).unwrap();
        assert_eq!(fe.substeps(), 3);
        assert_eq!(fe.substep(), 1.2e-3 / 3.0);
        fe.advance_to(10.0 * 1.2e-3, &|_| 0.0).unwrap();
        assert_eq!(fe.steps_done(), 30);
        assert_eq!(fe.time(), 30.0 * (1.2e-3 / 3.0));
        // Earlier or equal times are no-ops.
        let before = fe.stresses().to_vec();
        fe.advance_to(5e-3, &|_| 0.0).unwrap();
        fe.advance_to(fe.time(), &|_| 0.0).unwrap();
        assert_eq!(fe.steps_done(), 30);
        assert_eq!(fe.stresses(), &before[..]);
        assert!(fe.advance_to(f64::INFINITY, &|_| 0.0).is_err());
        // A small dt is not sub-stepped.
        let fe = Ulfem::new(setup(21, material, Boundary::fixed_both(), 1e-5), &|_| 0.0).unwrap();
        assert_eq!(fe.substeps(), 1);
    }

    #[test]
    fn non_finite_values_are_reported_with_step_and_time() {
        let mut fe = Ulfem::new(setup(11, hill(), Boundary::fixed_both(), 1e-4), &|_| 0.0).unwrap();
        fe.advance_to(3e-4, &|_| 1.0).unwrap();
        let err = fe
            .advance_to(1e-3, &|t| if t > 4.5e-4 { f64::NAN } else { 1.0 })
            .unwrap_err();
        match err {
            Error::NonFinite { field, step, time } => {
                assert_eq!(field, "reference velocity");
                assert_eq!(step, 5);
                assert!((time - 5e-4).abs() < 1e-15);
            }
            other => panic!("unexpected error {other}"),
        }
        assert_eq!(fe.steps_done(), 4);
        let err = Ulfem::new(setup(11, hill(), Boundary::fixed_both(), 1e-4), &|_| {
            f64::NAN
        })
        .expect_err("NaN initial velocity");
        assert!(matches!(err, Error::NonFinite { step: 0, .. }));
    }
}
