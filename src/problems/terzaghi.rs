//! Exact solution of 1D Terzaghi consolidation with compressible pore liquid (SPEC §6.6).
//!
//! Saturated column `[0, H]`, impermeable fixed bottom `x = 0`, drained top `x = H` loaded
//! by `q` (signed, negative in compression; the pore pressure `p` is positive in tension,
//! like stress). With `gamma_w = rho_w g`, `c_v = k / (gamma_w (1/E_c + n/K_w))`,
//! `T(j) = exp(-(2j-1)^2 pi^2 c_v t / (4 H^2))` and `S_j = (-1)^(j-1)`, summed over
//! `j = 1..=100_000`:
//!
//! ```text
//! p(x,t)      = (4 q / pi) sum_j S_j/(2j-1) cos((2j-1) pi x / (2H)) T(j)
//! sigma'(x,t) = q - p(x,t)
//! u_s(x,t)    = q x / E_c - (8 q H / (E_c pi^2)) sum_j S_j/(2j-1)^2 sin((2j-1) pi x/(2H)) T(j)
//! v_s(x,t)    = (2 q c_v / (E_c H)) sum_j S_j sin((2j-1) pi x/(2H)) T(j)
//! v_w(x,t)    = -(2 q c_v / H)(1/K_w + (1-n)/(n E_c)) sum_j S_j sin((2j-1) pi x/(2H)) T(j)
//! ```
//!
//! These satisfy `p_t = c_v p_xx`, `v_s = du_s/dt`, `du_s/dx = sigma'/E_c`, Darcy's law
//! `n (v_w - v_s) = (k / gamma_w) p_x` and the storage equation
//! `((1-n) v_s + n v_w)_x = (n / K_w) p_t`, with `p(H) = 0`, `p_x(0) = u_s(0) = v(0) = 0`.
//! At `t <= 0` the series is not summed (it converges slowly, or not at all for the
//! velocities): the initial undrained state `p = q`, `sigma' = 0`, `u_s = v_s = v_w = 0` is
//! returned at every `x`, including `x = H` (where every `t > 0` gives the boundary value
//! `p = 0`: the initial state is discontinuous there).
//! The 100 000 terms are converged (`T(100 000) < 1e-17`) for `c_v t / H^2 > 4e-10`; below
//! that the truncated series (as SPEC defines it) is returned, not the `t -> 0` limit.
//!
//! Evaluation ([`Terzaghi::profiles`]):
//! * the per-term coefficients `S_j T(j) [1/(2j-1), 1/(2j-1)^2, 1]` are computed once per
//!   call (per output time). `T(j)` decreases monotonically in `j`; the terms from the first
//!   `j` with `T(j) == 0.0` on are exactly zero and are skipped, so the sums are bitwise those
//!   of all 100 000 terms (the running sums start at `+0.0` and so are never `-0.0`: adding
//!   `+-0.0` leaves them unchanged);
//! * per position, `(sin, cos)` of the odd multiples `(2j-1) theta`, `theta = pi x / (2H)`,
//!   come from a rotation recurrence (multiplication by `e^{2 i theta}`), re-seeded exactly
//!   every `RESEED` = 64 terms: the seed is `sin_cos` of the exact product `(2j-1) theta`
//!   (its rounding error, from an FMA, applied to first order), so the drift stays ~1e-14;
//! * positions are evaluated 16 at a time (independent recurrences, which the CPU
//!   interleaves: ~1 ns per term and position instead of ~3 one at a time), the
//!   leftovers one at a time, in parallel over chunks of positions with rayon. Every
//!   position's sums run sequentially in `j` with the same arithmetic, so the result does
//!   not depend on the thread count or on the grouping.

use rayon::prelude::*;
use std::f64::consts::PI;

/// Terms between two exact re-seeds of the rotation recurrence.
const RESEED: usize = 64;
/// Positions evaluated together by one recurrence loop (interleaved independent recurrences).
const LANES: usize = 16;
/// Positions per rayon task (a multiple of [`LANES`]).
const TASK: usize = 4 * LANES;

/// Parameters of the Terzaghi column.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Terzaghi {
    /// Column height `H`.
    pub height: f64,
    /// Signed top load `q` (negative in compression).
    pub load: f64,
    /// Porosity `n`.
    pub porosity: f64,
    /// Constrained (oedometric) modulus of the skeleton `E_c`.
    pub constrained_modulus: f64,
    /// Bulk modulus of the pore liquid `K_w`.
    pub bulk_modulus_liquid: f64,
    /// Hydraulic conductivity `k` (m/s).
    pub permeability: f64,
    /// Unit weight of the liquid `gamma_w = rho_w g`.
    pub unit_weight_liquid: f64,
}

/// Exact fields at one position and time.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TerzaghiPoint {
    pub pore_pressure: f64,
    pub effective_stress: f64,
    pub displacement: f64,
    pub solid_velocity: f64,
    pub liquid_velocity: f64,
}

/// Exact fields at a set of positions, one Vec per field, same order as the positions.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TerzaghiProfiles {
    pub pore_pressure: Vec<f64>,
    pub effective_stress: Vec<f64>,
    pub displacement: Vec<f64>,
    pub solid_velocity: Vec<f64>,
    pub liquid_velocity: Vec<f64>,
}

impl Terzaghi {
    /// Number of series terms (SPEC §6.6).
    pub const TERMS: usize = 100_000;

    /// Consolidation coefficient `c_v = k / (gamma_w (1/E_c + n/K_w))`.
    pub fn consolidation_coefficient(&self) -> f64 {
        self.permeability
            / (self.unit_weight_liquid
                * (1.0 / self.constrained_modulus + self.porosity / self.bulk_modulus_liquid))
    }

    /// `a` in `T(j) = exp(-(2j-1)^2 a)`: `a = pi^2 c_v t / (4 H^2)`.
    fn decay_rate(&self, t: f64) -> f64 {
        PI * PI * self.consolidation_coefficient() * t / (4.0 * self.height * self.height)
    }

    /// All fields at all positions `x` (meant for `0 <= x <= H`) at time `t`; `t <= 0`
    /// gives the initial state (module doc).
    pub fn profiles(&self, x: &[f64], t: f64) -> TerzaghiProfiles {
        let mut sums = vec![[0.0; 3]; x.len()];
        if t > 0.0 || t.is_nan() {
            let coefs = term_coefficients(self.decay_rate(t));
            let scale = PI / (2.0 * self.height);
            sums.par_chunks_mut(TASK)
                .zip(x.par_chunks(TASK))
                .for_each(|(sums, x)| {
                    let full = x.len() - x.len() % LANES;
                    let (head, tail) = sums.split_at_mut(full);
                    for (sums, x) in head.chunks_mut(LANES).zip(x.chunks(LANES)) {
                        lane_sums::<LANES>(x, scale, &coefs, sums);
                    }
                    for (sums, x) in tail.chunks_mut(1).zip(x[full..].chunks(1)) {
                        lane_sums::<1>(x, scale, &coefs, sums);
                    }
                });
        }
        let mut out = TerzaghiProfiles::default();
        for (&x, sums) in x.iter().zip(&sums) {
            let f = self.fields(x, t, *sums);
            out.pore_pressure.push(f.pore_pressure);
            out.effective_stress.push(f.effective_stress);
            out.displacement.push(f.displacement);
            out.solid_velocity.push(f.solid_velocity);
            out.liquid_velocity.push(f.liquid_velocity);
        }
        out
    }

    /// All fields at one position (see [`Terzaghi::profiles`]).
    ///
    /// ```
    /// use tlsmpm::problems::terzaghi::Terzaghi;
    /// let z = Terzaghi {
    ///     height: 1.0, load: -1e4, porosity: 0.4, constrained_modulus: 1e7,
    ///     bulk_modulus_liquid: 3e8, permeability: 1e-5, unit_weight_liquid: 9810.0,
    /// };
    /// let top = z.at(1.0, 5.0);
    /// assert!(top.pore_pressure.abs() < 1e-12 * 1e4); // drained top
    /// let mid = z.at(0.5, 5.0);
    /// assert!((mid.effective_stress + mid.pore_pressure + 1e4).abs() < 1e-9); // sigma' + p = q
    /// assert!(mid.pore_pressure < 0.0 && mid.pore_pressure > -1e4);
    /// ```
    pub fn at(&self, x: f64, t: f64) -> TerzaghiPoint {
        self.profiles(&[x], t).point(0)
    }

    /// Fields from the three series sums `[sum_p, sum_u, sum_v]` (coefficients applied).
    fn fields(&self, x: f64, t: f64, [sp, su, sv]: [f64; 3]) -> TerzaghiPoint {
        let (q, h, e) = (self.load, self.height, self.constrained_modulus);
        if t <= 0.0 {
            return TerzaghiPoint {
                pore_pressure: q,
                ..TerzaghiPoint::default()
            };
        }
        let (n, cv) = (self.porosity, self.consolidation_coefficient());
        let p = 4.0 * q / PI * sp;
        TerzaghiPoint {
            pore_pressure: p,
            effective_stress: q - p,
            displacement: q * x / e - 8.0 * q * h / (e * PI * PI) * su,
            solid_velocity: 2.0 * q * cv / (e * h) * sv,
            liquid_velocity: -2.0 * q * cv / h
                * (1.0 / self.bulk_modulus_liquid + (1.0 - n) / (n * e))
                * sv,
        }
    }
}

impl TerzaghiProfiles {
    /// The fields at position index `i`.
    fn point(&self, i: usize) -> TerzaghiPoint {
        TerzaghiPoint {
            pore_pressure: self.pore_pressure[i],
            effective_stress: self.effective_stress[i],
            displacement: self.displacement[i],
            solid_velocity: self.solid_velocity[i],
            liquid_velocity: self.liquid_velocity[i],
        }
    }
}

/// Coefficients of term `j`: `S_j T(j) [1/(2j-1), 1/(2j-1)^2, 1]` with `T(j) = exp(-(2j-1)^2 a)`.
fn term(j: usize, a: f64) -> [f64; 3] {
    let m = (2 * j - 1) as f64;
    let tj = (-(m * m) * a).exp();
    let st = if j % 2 == 1 { tj } else { -tj };
    [st / m, st / (m * m), st]
}

/// The terms up to the last one with `T(j) > 0` (at most [`Terzaghi::TERMS`]).
fn term_coefficients(a: f64) -> Vec<[f64; 3]> {
    (1..=Terzaghi::TERMS)
        .map(|j| term(j, a))
        .take_while(|c| c[2] != 0.0)
        .collect()
}

/// `(sin, cos)` of the exact product `m theta`: `fl(m theta)` plus its rounding error (FMA),
/// applied to first order (the neglected `lo^2 / 2` is below 1e-21).
fn seed(m: f64, theta: f64) -> (f64, f64) {
    let hi = m * theta;
    let lo = m.mul_add(theta, -hi);
    let (s, c) = hi.sin_cos();
    (s + lo * c, c - lo * s)
}

/// Rotates `(sin a, cos a)` by the angle whose `(sin, cos)` is `(ws, wc)`.
#[inline(always)]
fn rotate(s: f64, c: f64, ws: f64, wc: f64) -> (f64, f64) {
    (s * wc + c * ws, c * wc - s * ws)
}

/// Series sums `[sum_p, sum_u, sum_v]` at `L` positions (`x.len() == out.len() == L`):
/// the odd multiples by the rotation recurrence, re-seeded every `RESEED` terms. The `L`
/// recurrences are independent (each lane does exactly the scalar arithmetic), so the
/// results do not depend on `L`; several lanes only keep more operations in flight.
fn lane_sums<const L: usize>(x: &[f64], scale: f64, coefs: &[[f64; 3]], out: &mut [[f64; 3]]) {
    let mut theta = [0.0; L];
    for (th, &x) in theta.iter_mut().zip(x) {
        *th = scale * x;
    }
    let (mut ws, mut wc) = ([0.0; L], [0.0; L]);
    let (mut s, mut c) = ([0.0; L], [0.0; L]);
    for l in 0..L {
        (ws[l], wc[l]) = (2.0 * theta[l]).sin_cos();
    }
    let (mut sp, mut su, mut sv) = ([0.0; L], [0.0; L], [0.0; L]);
    for (b, block) in coefs.chunks(RESEED).enumerate() {
        let m = (2 * b * RESEED + 1) as f64;
        for l in 0..L {
            (s[l], c[l]) = seed(m, theta[l]);
        }
        for k in block {
            for l in 0..L {
                sp[l] += k[0] * c[l];
                su[l] += k[1] * s[l];
                sv[l] += k[2] * s[l];
                (s[l], c[l]) = rotate(s[l], c[l], ws[l], wc[l]);
            }
        }
    }
    for (l, o) in out.iter_mut().enumerate() {
        *o = [sp[l], su[l], sv[l]];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Published small- and large-deformation sets (SPEC §6.6).
    const SMALL: Terzaghi = Terzaghi {
        height: 1.0,
        load: -1e4,
        porosity: 0.4,
        constrained_modulus: 1e7,
        bulk_modulus_liquid: 3e8,
        permeability: 1e-5,
        unit_weight_liquid: 1000.0 * 9.81,
    };
    const LARGE: Terzaghi = Terzaghi {
        load: -5e5,
        constrained_modulus: 1e6,
        bulk_modulus_liquid: 3e7,
        ..SMALL
    };
    /// (problem, time, interior positions, space step, time step) for finite differences;
    /// the large set at t = 0.01 s has a boundary layer of width sqrt(c_v t) ~ 3e-3 at the top.
    const CASES: [(Terzaghi, f64, [f64; 3], f64, f64); 2] = [
        (SMALL, 5.0, [0.3, 0.6, 0.9], 1e-4, 1e-3),
        (LARGE, 0.01, [0.99, 0.995, 0.999], 3e-6, 3e-7),
    ];
    /// Times with 39, 2740, 27 395 and all 100 000 nonzero terms.
    const TIMES: [(Terzaghi, f64); 4] = [(SMALL, 5.0), (LARGE, 0.01), (LARGE, 1e-4), (LARGE, 1e-8)];

    fn bits(f: TerzaghiPoint) -> [u64; 5] {
        [
            f.pore_pressure,
            f.effective_stress,
            f.displacement,
            f.solid_velocity,
            f.liquid_velocity,
        ]
        .map(f64::to_bits)
    }

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs()
    }

    /// `(sin, cos)` of the exact `m theta` by a Dekker split of `theta` (independent of `seed`).
    fn direct(m: f64, theta: f64) -> (f64, f64) {
        let hi = f64::from_bits(theta.to_bits() & !((1u64 << 27) - 1));
        let (a, b) = (m * hi, m * (theta - hi)); // m < 2^18: `m * hi` is exact
        let ((sa, ca), (sb, cb)) = (a.sin_cos(), b.sin_cos());
        (sa * cb + ca * sb, ca * cb - sa * sb)
    }

    /// Sums of all `TERMS` terms with the arithmetic of `lane_sums`, and the sums of the
    /// coefficients' magnitudes; `exact_trig` takes every `(sin, cos)` from `direct`.
    fn naive_sums(z: &Terzaghi, x: f64, t: f64, exact_trig: bool) -> ([f64; 3], [f64; 3]) {
        let (a, theta) = (z.decay_rate(t), PI / (2.0 * z.height) * x);
        let (ws, wc) = (2.0 * theta).sin_cos();
        let (mut s, mut c, mut sums, mut abs) = (0.0, 0.0, [0.0; 3], [0.0; 3]);
        for j in 1..=Terzaghi::TERMS {
            let m = (2 * j - 1) as f64;
            if exact_trig {
                (s, c) = direct(m, theta);
            } else if (j - 1) % RESEED == 0 {
                (s, c) = seed(m, theta);
            }
            let k = term(j, a);
            sums[0] += k[0] * c;
            sums[1] += k[1] * s;
            sums[2] += k[2] * s;
            (0..3).for_each(|i| abs[i] += k[i].abs());
            (s, c) = rotate(s, c, ws, wc);
        }
        (sums, abs)
    }

    #[test]
    fn consolidation_coefficient_matches_published_value() {
        assert!(rel(SMALL.consolidation_coefficient(), 1.006e-2) < 1e-3);
        assert!(rel(LARGE.consolidation_coefficient(), 1.006e-3) < 1e-3);
    }

    #[test]
    fn boundary_conditions() {
        for (z, t, ..) in CASES {
            let (q, h) = (z.load.abs(), 1e-4);
            let f = z.profiles(&[0.0, h, 2.0 * h, 1.0], t);
            let p = &f.pore_pressure;
            assert!(p[3].abs() < 1e-12 * q, "p(H) = {}", p[3]);
            let p_x = (-3.0 * p[0] + 4.0 * p[1] - p[2]) / (2.0 * h); // error ~ h^3 p_xxxx
            assert!(p_x.abs() < 1e-9 * q / z.height, "p_x(0) = {p_x}");
            assert_eq!(z.at(-h, t).pore_pressure, p[1], "p even about x = 0");
            let bottom = [f.displacement[0], f.solid_velocity[0], f.liquid_velocity[0]];
            assert_eq!(bottom, [0.0; 3]);
        }
    }

    /// `p_t = c_v p_xx`, `v_s = u_t`, Darcy, `u_x = sigma' / E_c` and the storage equation,
    /// by central differences (second order: the errors are 1e-9..1e-6 with these steps).
    #[test]
    fn field_equations() {
        for (z, t, xs, h, dt) in CASES {
            let (n, cv) = (z.porosity, z.consolidation_coefficient());
            let flux = |f: TerzaghiPoint| (1.0 - n) * f.solid_velocity + n * f.liquid_velocity;
            for x in xs {
                let (now, left, right) = (z.at(x, t), z.at(x - h, t), z.at(x + h, t));
                let (later, earlier) = (z.at(x, t + dt), z.at(x, t - dt));
                let p_t = (later.pore_pressure - earlier.pore_pressure) / (2.0 * dt);
                let p_x = (right.pore_pressure - left.pore_pressure) / (2.0 * h);
                let p_xx =
                    (right.pore_pressure - 2.0 * now.pore_pressure + left.pore_pressure) / (h * h);
                let u_t = (later.displacement - earlier.displacement) / (2.0 * dt);
                let u_x = (right.displacement - left.displacement) / (2.0 * h);
                let flux_x = (flux(right) - flux(left)) / (2.0 * h);
                let checks = [
                    ("diffusion", cv * p_xx, p_t),
                    ("solid velocity", u_t, now.solid_velocity),
                    (
                        "darcy",
                        n * (now.liquid_velocity - now.solid_velocity),
                        z.permeability / z.unit_weight_liquid * p_x,
                    ),
                    ("strain", u_x, now.effective_stress / z.constrained_modulus),
                    ("storage", flux_x, n / z.bulk_modulus_liquid * p_t),
                ];
                for (name, a, b) in checks {
                    assert!(rel(a, b) < 1e-5, "{name} at x {x}, t {t}: {a} vs {b}");
                }
            }
        }
    }

    #[test]
    fn limits() {
        let z = SMALL;
        let (q, e, x) = (z.load, z.constrained_modulus, [0.0, 0.25, 0.5, 0.75, 1.0]);
        let done = z.profiles(&x, 1e5);
        let slow = z.profiles(&x, 200.0); // T(2) / T(1) = e^-40: the first mode only
        let start = z.profiles(&x, 0.0);
        let decay = (-z.decay_rate(200.0)).exp();
        for (i, &x) in x.iter().enumerate() {
            assert!(done.pore_pressure[i].abs() < 1e-12 * q.abs());
            assert!(rel(done.effective_stress[i], q) < 1e-12);
            assert!((done.displacement[i] - q * x / e).abs() < 1e-15);
            let (sin, cos) = (PI * x / 2.0).sin_cos();
            let p1 = 4.0 * q / PI * cos * decay;
            assert!((slow.pore_pressure[i] - p1).abs() < 1e-12 * p1.abs().max(1e-3));
            let u1 = q * x / e - 8.0 * q / (e * PI * PI) * sin * decay;
            assert!((slow.displacement[i] - u1).abs() < 1e-12 * (q / e).abs());
            let initial = TerzaghiPoint {
                pore_pressure: q,
                ..TerzaghiPoint::default()
            };
            assert_eq!(bits(start.point(i)), bits(initial));
        }
        let early = z.at(0.5, 1e-3); // mid-column, not reached by the drainage yet
        assert!(
            rel(early.pore_pressure, q) < 1e-12,
            "{}",
            early.pore_pressure
        );
        assert!(early.displacement.abs() < 1e-12 * (q / e).abs());
    }

    #[test]
    fn skipped_terms_are_bitwise_the_full_series() {
        for (z, t) in TIMES {
            let x = [0.0, 0.1234, 0.5, 0.987, 0.9999, 1.0];
            let fast = z.profiles(&x, t);
            for (i, &x) in x.iter().enumerate() {
                let full = z.fields(x, t, naive_sums(&z, x, t, false).0);
                assert_eq!(bits(fast.point(i)), bits(full), "t {t} x {x}");
            }
        }
    }

    #[test]
    fn recurrence_sums_match_direct_trig() {
        for (z, t) in TIMES {
            let coefs = term_coefficients(z.decay_rate(t));
            for x in [0.05, 0.5, 0.987, 1.0] {
                let mut sums = [[0.0; 3]];
                lane_sums::<1>(&[x], PI / (2.0 * z.height), &coefs, &mut sums);
                let (exact, abs) = naive_sums(&z, x, t, true);
                for i in 0..3 {
                    let err = (sums[0][i] - exact[i]).abs() / abs[i];
                    assert!(err < 1e-13, "t {t} x {x} sum {i}: {err:e}");
                }
            }
        }
    }

    #[test]
    fn recurrence_matches_direct_sin_cos() {
        for x in [0.01, 0.3, 0.5, 0.777, 0.999, 1.0] {
            let theta = PI / 2.0 * x;
            let (ws, wc) = (2.0 * theta).sin_cos();
            let (mut s, mut c, mut worst) = (0.0, 0.0, 0.0_f64);
            for j in 1..=Terzaghi::TERMS {
                let m = (2 * j - 1) as f64;
                if (j - 1) % RESEED == 0 {
                    (s, c) = seed(m, theta);
                }
                let (ds, dc) = direct(m, theta);
                worst = worst.max((s - ds).abs()).max((c - dc).abs());
                (s, c) = rotate(s, c, ws, wc);
            }
            assert!(worst < 1e-13, "x {x}: {worst:e}"); // ~5e-15 observed
        }
    }

    #[test]
    fn independent_of_thread_count_and_grouping() {
        let x: Vec<f64> = (0..1001).map(|i| (i as f64 / 1000.0).powf(0.7)).collect();
        let run = |threads| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| LARGE.profiles(&x, 0.01))
        };
        let all = |f: TerzaghiProfiles| (0..x.len()).map(|i| bits(f.point(i))).collect::<Vec<_>>();
        let one = all(run(1));
        assert_eq!(one, all(run(3)));
        let alone: Vec<_> = x.iter().map(|&x| bits(LARGE.at(x, 0.01))).collect();
        assert_eq!(one, alone, "16-lane and one-at-a-time evaluation agree");
    }
}
