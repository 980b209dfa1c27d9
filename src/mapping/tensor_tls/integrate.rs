//! The integration of the 2D/3D TLS fits against the basis (`docs/tls.md`):
//!
//! ```text
//! m_I = int_box rho_hat phi_I
//! f_I = int_box (rho b)_hat phi_I - sigma_hat . grad phi_I
//! p_I = int_box (rho v)_hat phi_I
//! ```
//!
//! per active cell box, from the 1D moments of the Taylor factors ([`CellMoments`], exact
//! with the `(p + 2)`-point Gauss rule they are computed with), point by point over the
//! Gauss points where the basis changes within a box; scattered per task of cells in a
//! fixed order.

// Index loops: the indices enter the formulas (axes).
#![allow(clippy::needless_range_loop)]

use super::cells::{cell_axes, dot, max_len};
use super::moments::{scratch_len, CellMoments};
use super::{stress_components, GaussCell, TensorTlsMapping};
use crate::grid::{Basis, TensorBasis, TensorShape};
use std::ops::Range;

impl<const D: usize> TensorTlsMapping<D> {
    /// `out_I = int_box v_hat phi_I` of the fitted vector density.
    pub(super) fn integrate_vector<B: Basis, const N: usize>(
        &mut self,
        basis: &TensorBasis<D, B>,
        out: &mut [[f64; D]],
    ) {
        let strides = *basis.strides();
        let (lo, hi, active, vector, rule, moments) = (
            &self.lo,
            &self.hi,
            &self.active,
            &self.vector,
            &self.rule,
            &self.moments,
        );
        let grid = &basis.grid;
        let len = max_len(basis);
        self.vector_scatter
            .scatter_cells(out, |cells: Range<usize>, first, local| {
                let mut shape = TensorShape::<D>::default();
                let nodes = len.pow(D as u32);
                let mut scratch = vec![0.0; scratch_len(len)];
                let mut integral = vec![0.0; nodes];
                let mut node_values = vec![[0.0; D]; nodes];
                for cell in cells {
                    if !active[cell] {
                        continue;
                    }
                    let fits = &vector[cell * D..(cell + 1) * D];
                    if let Some(cell_moments) = CellMoments::new(moments, cell_axes(grid, cell)) {
                        let n = cell_moments.nodes();
                        let values = &mut node_values[..n];
                        for a in 0..D {
                            cell_moments.contract::<N>(&fits[a], None, &mut scratch, &mut integral);
                            for (v, &r) in values.iter_mut().zip(&integral) {
                                v[a] = r;
                            }
                        }
                        cell_moments.for_each_node(&strides, |k, node| {
                            let o = &mut local[node - first];
                            for a in 0..D {
                                o[a] += values[k][a];
                            }
                        });
                        continue;
                    }
                    let GaussCell {
                        taylor,
                        index,
                        points,
                    } = GaussCell::new(grid, rule, cell, lo[cell], hi[cell]);
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
        let (lo, hi, active, stress, density, vector, rule, moments) = (
            &self.lo,
            &self.hi,
            &self.active,
            &self.stress,
            &self.density,
            &self.vector,
            &self.rule,
            &self.moments,
        );
        let components = &components;
        let grid = &basis.grid;
        let len = max_len(basis);
        self.mass_force
            .scatter_cells(out, |cells: Range<usize>, first, local| {
                let mut shape = TensorShape::<D>::default();
                let nodes = len.pow(D as u32);
                let mut scratch = vec![0.0; scratch_len(len)];
                let mut integral = vec![0.0; nodes];
                // Per node: the mass, then the force components.
                let mut node_values = vec![[0.0; 4]; nodes];
                for cell in cells {
                    if !active[cell] {
                        continue;
                    }
                    let fits = &stress[cell * ns..(cell + 1) * ns];
                    let body = &vector[cell * D..(cell + 1) * D];
                    if let Some(cell_moments) = CellMoments::new(moments, cell_axes(grid, cell)) {
                        let n = cell_moments.nodes();
                        let values = &mut node_values[..n];
                        cell_moments.contract::<N>(
                            &density[cell],
                            None,
                            &mut scratch,
                            &mut integral,
                        );
                        for (v, &r) in values.iter_mut().zip(&integral) {
                            *v = [r, 0.0, 0.0, 0.0];
                        }
                        if with_body {
                            for a in 0..D {
                                cell_moments.contract::<N>(
                                    &body[a],
                                    None,
                                    &mut scratch,
                                    &mut integral,
                                );
                                for (v, &r) in values.iter_mut().zip(&integral) {
                                    v[1 + a] = r;
                                }
                            }
                        }
                        // sigma_(ac) enters f_a with d/dx_c and, off the diagonal, f_c
                        // with d/dx_a.
                        for (fit, &(a, c)) in fits.iter().zip(components) {
                            cell_moments.contract::<N>(fit, Some(c), &mut scratch, &mut integral);
                            for (v, &r) in values.iter_mut().zip(&integral) {
                                v[1 + a] -= r;
                            }
                            if a != c {
                                cell_moments.contract::<N>(
                                    fit,
                                    Some(a),
                                    &mut scratch,
                                    &mut integral,
                                );
                                for (v, &r) in values.iter_mut().zip(&integral) {
                                    v[1 + c] -= r;
                                }
                            }
                        }
                        cell_moments.for_each_node(&strides, |k, node| {
                            let o = &mut local[node - first];
                            for j in 0..=D {
                                o[j] += values[k][j];
                            }
                        });
                        continue;
                    }
                    let GaussCell {
                        taylor,
                        index,
                        points,
                    } = GaussCell::new(grid, rule, cell, lo[cell], hi[cell]);
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
                }
            });
    }
}
