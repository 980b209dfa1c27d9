//! The per-particle kernels of the direct mapping's scatters in 2D / 3D
//! (`docs/dimensions.md`): one particle's mass and force, or momentum, added to a scatter
//! task's buffer over the particle's tensor-product support, sum-factorised row by row
//! ([`TensorShape::for_each_row_n`]). Used by the passes of
//! [`super::tensor_direct`] and by the particle update that maps the next step
//! ([`super::tensor_next`]).

use crate::grid::TensorShape;
use crate::particles::tensor::stress_index;

/// Add one particle's mass and force to the scatter buffer `local` (whose first node is
/// `lo`): `m_I += m phi_I`, `f_I += m b phi_I - V sigma . grad phi_I`, with the particle's
/// `shape`, mass `m`, volume `vol`, stress components `stress(s)` (the order of
/// [`stress_index`]) and body force `b`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn add_mass_and_force<const D: usize, const N: usize>(
    shape: &TensorShape<D>,
    strides: &[usize; D],
    m: f64,
    vol: f64,
    stress: impl Fn(usize) -> f64,
    b: [f64; D],
    lo: usize,
    local: &mut [[f64; 4]],
) {
    let mut sigma = [[0.0; D]; D];
    for (a, row) in sigma.iter_mut().enumerate() {
        for (c, s) in row.iter_mut().enumerate() {
            *s = vol * stress(stress_index(a, c));
        }
    }
    // Per row: m phi_I = (m w) phi_i, and f_I,a = along_a phi_i + across_a dphi_i with
    // along_a = m b_a w - sum_{c >= 1} V sigma_ac dw_c, across_a = -V sigma_a0 w.
    let (phi_x, dphi_x) = shape.x_functions_n::<N>();
    shape.for_each_row_n::<N>(strides, |first, w, dw| {
        let row_mass = m * w;
        let mut along = [0.0; D];
        let mut across = [0.0; D];
        for a in 0..D {
            let mut internal = 0.0;
            for c in 1..D {
                internal += sigma[a][c] * dw[c];
            }
            along[a] = m * b[a] * w - internal;
            across[a] = -(sigma[a][0] * w);
        }
        let out = &mut local[first - lo..first - lo + phi_x.len()];
        for ((o, px), dx) in out.iter_mut().zip(phi_x).zip(dphi_x) {
            o[0] += row_mass * px;
            for a in 0..D {
                o[1 + a] += along[a] * px + across[a] * dx;
            }
        }
    });
}

/// `local[I - lo] += m_p v_p phi_I` over the support of `shape`, sum-factorised: per row
/// `(m_p v_p w) phi^0_i` ([`TensorShape::for_each_row_n`]).
#[inline(always)]
pub fn scatter_momentum<const D: usize, const N: usize>(
    shape: &TensorShape<D>,
    strides: &[usize; D],
    momentum: [f64; D],
    lo: usize,
    local: &mut [[f64; D]],
) {
    let (phi_x, _) = shape.x_functions_n::<N>();
    shape.for_each_row_n::<N>(strides, |first, w, _| {
        let row: [f64; D] = std::array::from_fn(|a| momentum[a] * w);
        let out = &mut local[first - lo..first - lo + phi_x.len()];
        for (o, px) in out.iter_mut().zip(phi_x) {
            for a in 0..D {
                o[a] += row[a] * px;
            }
        }
    });
}
