//! TEMPORARY naive stub (replaced by the helper's module).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Terzaghi {
    pub height: f64,
    pub load: f64,
    pub porosity: f64,
    pub constrained_modulus: f64,
    pub bulk_modulus_liquid: f64,
    pub permeability: f64,
    pub unit_weight_liquid: f64,
}
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TerzaghiProfiles {
    pub pore_pressure: Vec<f64>,
    pub effective_stress: Vec<f64>,
    pub displacement: Vec<f64>,
    pub solid_velocity: Vec<f64>,
    pub liquid_velocity: Vec<f64>,
}
impl Terzaghi {
    pub const TERMS: usize = 100_000;
    pub fn consolidation_coefficient(&self) -> f64 {
        self.permeability
            / (self.unit_weight_liquid
                * (1.0 / self.constrained_modulus + self.porosity / self.bulk_modulus_liquid))
    }
    pub fn profiles(&self, x: &[f64], t: f64) -> TerzaghiProfiles {
        use std::f64::consts::PI;
        let (q, h, e, n, kw) = (
            self.load,
            self.height,
            self.constrained_modulus,
            self.porosity,
            self.bulk_modulus_liquid,
        );
        let cv = self.consolidation_coefficient();
        let mut out = TerzaghiProfiles::default();
        for &x in x {
            if t == 0.0 {
                out.pore_pressure.push(q);
                out.effective_stress.push(0.0);
                out.displacement.push(0.0);
                out.solid_velocity.push(0.0);
                out.liquid_velocity.push(0.0);
                continue;
            }
            let (mut sp, mut su, mut sv) = (0.0, 0.0, 0.0);
            for j in 1..=Self::TERMS {
                let m = (2 * j - 1) as f64;
                let tj = (-m * m * PI * PI * cv * t / (4.0 * h * h)).exp();
                if tj == 0.0 {
                    break;
                }
                let s = if j % 2 == 1 { 1.0 } else { -1.0 };
                let (sn, cs) = (m * PI * x / (2.0 * h)).sin_cos();
                sp += s / m * cs * tj;
                su += s / (m * m) * sn * tj;
                sv += s * sn * tj;
            }
            let p = 4.0 * q / PI * sp;
            out.pore_pressure.push(p);
            out.effective_stress.push(q - p);
            out.displacement
                .push(q * x / e - 8.0 * q * h / (e * PI * PI) * su);
            out.solid_velocity.push(2.0 * q * cv / (e * h) * sv);
            out.liquid_velocity
                .push(-2.0 * q * cv / h * (1.0 / kw + (1.0 - n) / (n * e)) * sv);
        }
        out
    }
}
