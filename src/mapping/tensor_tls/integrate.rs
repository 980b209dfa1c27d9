//! The Gauss integration of the 2D/3D TLS fits against the basis (`docs/tls.md`):
//!
//! ```text
//! m_I = sum_g rho_hat(x_g) w_g phi_I(x_g)
//! f_I = sum_g ( (rho b)_hat(x_g) phi_I(x_g) - sigma_hat(x_g) . grad phi_I(x_g) ) w_g
//! p_I = sum_g (rho v)_hat(x_g) w_g phi_I(x_g)
//! ```
//!
//! per active cell box, sum-factorised ([`CellQuadrature`]) where the basis is uniform over
//! the cell, point by point otherwise; scattered per task of cells in a fixed order.

// Index loops: the indices enter the formulas (axes).
#![allow(clippy::needless_range_loop)]

use super::cells::dot;
use super::{stress_components, GaussCell, TensorTlsMapping};
use crate::grid::{Basis, TensorBasis, TensorShape};
use crate::mapping::sum_factor::CellQuadrature;
use std::ops::Range;

impl<const D: usize> TensorTlsMapping<D> {
    /// `out_I = sum_g w_g v_hat(x_g) phi_I(x_g)` of the fitted vector density.
    pub(super) fn integrate_vector<B: Basis, const N: usize>(
        &mut self,
        basis: &TensorBasis<D, B>,
        out: &mut [[f64; D]],
    ) {
        let strides = *basis.strides();
        let (lo, hi, active, vector, rule) =
            (&self.lo, &self.hi, &self.active, &self.vector, &self.rule);
        self.vector_scatter
            .scatter_cells(out, |cells: Range<usize>, first, local| {
                let mut shape = TensorShape::<D>::default();
                let mut quadrature = CellQuadrature::<D>::default();
                let mut values = Vec::with_capacity(rule.len.pow(D as u32) * D);
                for cell in cells {
                    if !active[cell] {
                        continue;
                    }
                    let GaussCell {
                        taylor,
                        index,
                        points,
                        uniform,
                    } = GaussCell::new(basis, rule, cell, lo[cell], hi[cell], &mut quadrature);
                    let fits = &vector[cell * D..(cell + 1) * D];
                    if uniform {
                        values.clear();
                        points.for_each(|x, w| {
                            let t = taylor.terms(x);
                            values.extend((0..D).map(|a| dot::<D>(&fits[a], &t) * w));
                        });
                        quadrature.integrate(&values, D, None, &strides, |node, r| {
                            let o = &mut local[node - first];
                            for a in 0..D {
                                o[a] += r[a];
                            }
                        });
                        continue;
                    }
                    points.for_each(|x, w| {
                        basis.eval_particle(index, x, [0.0; D], &mut shape);
                        let t = taylor.terms(x);
                        let value: [f64; D] = std::array::from_fn(|a| dot::<D>(&fits[a], &t) * w);
                        shape.for_each_node_n::<N>(&strides, |node, phi, _| {
                            let o = &mut local[node - first];
                            for a in 0..D {
                                o[a] += value[a] * phi;
                            }
                        });
                    });
                }
            });
    }

    /// `m_I`, `f_I = int (rho b)_hat phi_I - sigma_hat . grad phi_I` (the body term with
    /// `with_body`, from the fits in `self.vector`) into the mass-force scatter output.
    pub(super) fn integrate_mass_and_force<B: Basis, const N: usize>(
        &mut self,
        basis: &TensorBasis<D, B>,
        out: &mut [[f64; 4]],
        with_body: bool,
    ) {
        let strides = *basis.strides();
        let components = stress_components::<D>();
        let ns = components.len();
        let (lo, hi, active, stress, density, vector, rule) = (
            &self.lo,
            &self.hi,
            &self.active,
            &self.stress,
            &self.density,
            &self.vector,
            &self.rule,
        );
        let components = &components;
        self.mass_force
            .scatter_cells(out, |cells: Range<usize>, first, local| {
                let mut shape = TensorShape::<D>::default();
                let mut quadrature = CellQuadrature::<D>::default();
                let count = rule.len.pow(D as u32);
                // Per point: mass and body weights (1 + D), then per derivative axis c the
                // stress column sigma_(a c) w (D each).
                let mut mass_values = Vec::with_capacity(count * (1 + D));
                let mut stress_values: [Vec<f64>; D] =
                    std::array::from_fn(|_| Vec::with_capacity(count * D));
                let mass_width = if with_body { 1 + D } else { 1 };
                for cell in cells {
                    if !active[cell] {
                        continue;
                    }
                    let GaussCell {
                        taylor,
                        index,
                        points,
                        uniform,
                    } = GaussCell::new(basis, rule, cell, lo[cell], hi[cell], &mut quadrature);
                    let fits = &stress[cell * ns..(cell + 1) * ns];
                    let body = &vector[cell * D..(cell + 1) * D];
                    mass_values.clear();
                    for column in stress_values.iter_mut() {
                        column.clear();
                    }
                    points.for_each(|x, w| {
                        let t = taylor.terms(x);
                        let mut sw = [[0.0; D]; D];
                        for (fit, &(a, c)) in fits.iter().zip(components) {
                            let s = dot::<D>(fit, &t) * w;
                            sw[a][c] = s;
                            sw[c][a] = s;
                        }
                        let rw = dot::<D>(&density[cell], &t) * w;
                        let bw: [f64; D] = std::array::from_fn(|a| {
                            if with_body {
                                dot::<D>(&body[a], &t) * w
                            } else {
                                0.0
                            }
                        });
                        if uniform {
                            mass_values.push(rw);
                            if with_body {
                                mass_values.extend_from_slice(&bw);
                            }
                            for c in 0..D {
                                stress_values[c].extend((0..D).map(|a| sw[a][c]));
                            }
                            return;
                        }
                        basis.eval_particle(index, x, [0.0; D], &mut shape);
                        shape.for_each_node_n::<N>(&strides, |node, phi, grad| {
                            let o = &mut local[node - first];
                            o[0] += rw * phi;
                            for a in 0..D {
                                let mut internal = 0.0;
                                for c in 0..D {
                                    internal += sw[a][c] * grad[c];
                                }
                                o[1 + a] += bw[a] * phi - internal;
                            }
                        });
                    });
                    if !uniform {
                        continue;
                    }
                    quadrature.integrate(&mass_values, mass_width, None, &strides, |node, r| {
                        let o = &mut local[node - first];
                        o[0] += r[0];
                        if with_body {
                            for a in 0..D {
                                o[1 + a] += r[1 + a];
                            }
                        }
                    });
                    for c in 0..D {
                        quadrature.integrate(&stress_values[c], D, Some(c), &strides, |node, r| {
                            let o = &mut local[node - first];
                            for a in 0..D {
                                o[1 + a] -= r[a];
                            }
                        });
                    }
                }
            });
    }
}
