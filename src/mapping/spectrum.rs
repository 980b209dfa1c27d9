//! Test support: the spectrum of the frozen semi-discrete step of a mapping.
//!
//! For a fixed particle configuration the one-phase step is, with `rho = E = 1`, the linear
//! system `d/dt (v_p, sigma_p) = (P sigma, Q v)`: `P` maps particle stresses to particle
//! accelerations (`phi^T M^{-1} (-f_int)`, lumped mass, both ends fixed) and `Q` maps
//! particle velocities to particle strain rates (the mapped grid velocity, then the
//! mapping's own strain or the basis gradient); the particle accelerations are the grid
//! accelerations at the particles, or the mapping's own. Eigenvalues with a positive real part are
//! modes that grow whatever the time step; a method whose strain is work-conjugate to its
//! force has none. The columns are found by probing the real mapping with unit stresses
//! and unit velocities.

use super::{GridFields, Mapping};
use crate::grid::{Basis, Grid, LinearBasis, Shape};
use crate::particles::{CellBins, Particles};

/// Largest real part and largest magnitude of the eigenvalues of the frozen step on a bar
/// `[0, 1]` of `cells` linear cells, both ends fixed (`c / L = 1`), with `per_cell`
/// particles per cell at the MMS bar's deformed positions `x = X + A sin(2 pi X) sin(phase)`.
pub fn frozen_spectrum_of<M: Mapping>(
    mut mapping: M,
    cells: usize,
    per_cell: usize,
    amplitude: f64,
    phase: f64,
) -> (f64, f64) {
    use nalgebra::DMatrix;
    let grid = Grid::new(1.0, cells);
    let n = per_cell * cells;
    let mut p = Particles::default();
    for k in 0..n {
        let x0 = (k as f64 + 0.5) / n as f64;
        let two_pi = 2.0 * std::f64::consts::PI;
        let x = x0 + amplitude * (two_pi * x0).sin() * phase.sin();
        let stretch = 1.0 + amplitude * two_pi * (two_pi * x0).cos() * phase.sin();
        let volume = stretch / n as f64;
        p.id.push(k);
        p.x0.push(x0);
        p.x.push(x);
        p.u.push(x - x0);
        p.v.push(0.0);
        p.stress.push(0.0);
        p.volume.push(volume);
        p.mass.push(1.0 / n as f64);
        p.density.push(1.0 / (n as f64 * volume));
        p.deformation_gradient.push(stretch);
        p.cell.push(grid.cell_of(x).unwrap());
    }
    let mut bins = CellBins::default();
    bins.sort(&mut p, grid.cells);
    let basis = LinearBasis::new(grid);
    let dofs = basis.num_dofs();
    let free = |i: usize| i > 0 && i + 1 < dofs;
    let mut fields = GridFields::new(dofs);
    let mut shape = Shape::default();
    let mut jacobian = DMatrix::<f64>::zeros(2 * n, 2 * n);
    for q in 0..n {
        // Column q of P: unit stress at particle q.
        p.stress.iter_mut().for_each(|s| *s = 0.0);
        p.stress[q] = 1.0;
        mapping.map_mass_and_internal_force(&basis, &p, &bins, &mut fields);
        let a: Vec<f64> = (0..dofs)
            .map(|i| {
                if free(i) {
                    -fields.internal_force[i] / fields.mass[i]
                } else {
                    0.0
                }
            })
            .collect();
        // The mapping's own particle accelerations need its momentum fit at these
        // positions (the velocities do not matter: the fit is linear).
        mapping.map_momentum(&basis, &p, &bins, &mut fields);
        let mut accelerations = Vec::new();
        if !mapping.particle_accelerations(&basis, &p, &a, &mut accelerations) {
            accelerations = (0..n)
                .map(|k| {
                    basis.eval_particle(p.cell[k], p.x[k], 0.5 * p.volume[k], &mut shape);
                    shape.interpolate(&a)
                })
                .collect();
        }
        for k in 0..n {
            jacobian[(k, n + q)] = accelerations[k];
        }
        // Column q of Q: unit velocity at particle q.
        p.v.iter_mut().for_each(|v| *v = 0.0);
        p.v[q] = 1.0;
        mapping.map_momentum(&basis, &p, &bins, &mut fields);
        let v: Vec<f64> = (0..dofs)
            .map(|i| {
                if free(i) {
                    fields.momentum[i] / fields.mass[i]
                } else {
                    0.0
                }
            })
            .collect();
        let mut deps = Vec::new();
        if !mapping.strain_increments(&basis, &p, &v, 1.0, &mut deps) {
            deps = (0..n)
                .map(|k| {
                    basis.eval_particle(p.cell[k], p.x[k], 0.5 * p.volume[k], &mut shape);
                    shape.gradient(&v)
                })
                .collect();
        }
        for k in 0..n {
            jacobian[(n + k, q)] = deps[k];
        }
    }
    let eigenvalues = jacobian.complex_eigenvalues();
    let growth = eigenvalues.iter().map(|l| l.re).fold(f64::MIN, f64::max);
    let size = eigenvalues.iter().map(|l| l.norm()).fold(0.0, f64::max);
    (growth, size)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{AdjointMass, CellTotals, DegenerateRemedy};
    use crate::mapping::{DirectMapping, TlsMapping};

    /// Undeformed and deformed configurations (amplitude, phase) of the MMS bar.
    const CONFIGURATIONS: [(f64, f64); 4] = [(0.0, 0.0), (0.1, 0.3), (0.1, 1.57), (0.05, 1.0)];

    #[test]
    fn standard_mpm_is_neutrally_stable() {
        for (amplitude, phase) in CONFIGURATIONS {
            let (growth, size) =
                frozen_spectrum_of(DirectMapping::default(), 32, 3, amplitude, phase);
            assert!(
                growth < 1e-9 * size,
                "A {amplitude}, phase {phase}: {growth}"
            );
        }
    }

    #[test]
    fn tls_with_domain_totals_is_neutrally_stable_unless_virtual_points_couple_sparse_cells() {
        // Measured (32 cells, max Re / |l|max): neutral (~1e-15) at 4 and 6 PPC with either
        // remedy and at 3 PPC with order reduction; virtual points at 3 PPC give 0.15 and
        // 0.58 in two of the three deformed configurations (2 PPC: up to 1.0): a virtual
        // point makes a cell's stress depend on its neighbour's particles, which the
        // per-cell strain of the linear basis does not see. With `cell_totals = "centres"`
        // (the published split) there are growing modes even at 6 PPC (0.2, 0.4).
        let tls = |remedy, totals| {
            TlsMapping::new(Grid::new(1.0, 32), 3, remedy, totals).expect("3-point rule")
        };
        for (amplitude, phase) in CONFIGURATIONS {
            for (per_cell, remedy) in [
                (3, DegenerateRemedy::OrderReduction),
                (4, DegenerateRemedy::VirtualPoints),
                (4, DegenerateRemedy::OrderReduction),
                (6, DegenerateRemedy::VirtualPoints),
            ] {
                let mapping = tls(remedy, CellTotals::Domains);
                let (growth, size) = frozen_spectrum_of(mapping, 32, per_cell, amplitude, phase);
                assert!(
                    growth < 1e-9 * size,
                    "{per_cell} PPC, {remedy:?}, A {amplitude}, phase {phase}: {growth}"
                );
            }
        }
        let mapping = tls(DegenerateRemedy::VirtualPoints, CellTotals::Domains);
        let (growth, _) = frozen_spectrum_of(mapping, 32, 3, 0.1, 1.57);
        assert!(growth > 0.1, "virtual points, 3 PPC: {growth}");
    }

    /// The largest `max Re(lambda)` of TLS over the configurations, per totals rule, remedy
    /// and particles per cell (16 cells, `c / L = 1`).
    fn tls_growth(
        adjoint: bool,
        conservative_stress: bool,
        domain_weights: bool,
        metric: AdjointMass,
    ) -> Vec<(CellTotals, DegenerateRemedy, usize, f64)> {
        let mut table = Vec::new();
        for totals in [CellTotals::Domains, CellTotals::Centres] {
            for remedy in [
                DegenerateRemedy::VirtualPoints,
                DegenerateRemedy::OrderReduction,
            ] {
                for per_cell in [1, 2, 3, 4, 6] {
                    let mut worst = f64::MIN;
                    for (amplitude, phase) in CONFIGURATIONS {
                        let mapping = TlsMapping::new(Grid::new(1.0, 16), 3, remedy, totals)
                            .expect("3-point rule")
                            .with_adjoint(adjoint)
                            .with_conservative_stress(conservative_stress)
                            .with_domain_weights(domain_weights)
                            .with_particle_metric(metric);
                        let (growth, _) =
                            frozen_spectrum_of(mapping, 16, per_cell, amplitude, phase);
                        worst = worst.max(growth);
                    }
                    println!(
                        "{totals:?} {remedy:?} {per_cell} PPC adjoint {adjoint} \
                         conservative stress {conservative_stress} \
                         domain weights {domain_weights} \
                         particle metric {metric:?}: {worst:.2e}"
                    );
                    table.push((totals, remedy, per_cell, worst));
                }
            }
        }
        table
    }

    #[test]
    fn tls_with_the_adjoint_strain_and_acceleration_has_no_growing_mode() {
        // Every totals rule, remedy and particle count, with the full or the conservative
        // stress fit, one point per particle or domain-weighted fits, lumped or consistent
        // particle metric: max Re <= 1e-12 c/L (measured ~1e-15); the gradient strain
        // grows in some of the same configurations, with either stress fit and either
        // weighting.
        use AdjointMass::{Consistent, Lumped, Quadratic};
        for (conservative_stress, domain_weights, metric) in [
            (false, false, Lumped),
            (true, false, Lumped),
            (false, true, Lumped),
            (true, true, Lumped),
            (false, false, Consistent),
            (false, true, Consistent),
            (false, false, Quadratic),
            (false, true, Quadratic),
        ] {
            for (totals, remedy, per_cell, growth) in
                tls_growth(true, conservative_stress, domain_weights, metric)
            {
                assert!(
                    growth <= 1e-12,
                    "{totals:?} {remedy:?} {per_cell} PPC {conservative_stress} \
                     {domain_weights} {metric:?}: {growth:e}"
                );
            }
            if metric == Lumped {
                let gradient = tls_growth(false, conservative_stress, domain_weights, Lumped);
                assert!(gradient.iter().any(|row| row.3 > 0.1), "{gradient:?}");
            }
        }
    }

    #[test]
    fn domain_weighted_fits_keep_the_frequencies_of_mpm() {
        // The largest |lambda| (c / L = 1) sets the stable time step. Adjoint TLS with
        // domain-weighted fits at 3 PPC on the stretched MMS bar stays within 1.5x of
        // plain MPM's (measured: printed below).
        for phase in [0.3, 1.0, 1.57] {
            let (_, mpm) = frozen_spectrum_of(DirectMapping::default(), 32, 3, 0.1, phase);
            let mapping = TlsMapping::new(
                Grid::new(1.0, 32),
                3,
                DegenerateRemedy::VirtualPoints,
                CellTotals::Domains,
            )
            .expect("3-point rule")
            .with_adjoint(true)
            .with_domain_weights(true);
            let (growth, size) = frozen_spectrum_of(mapping, 32, 3, 0.1, phase);
            println!(
                "phase {phase}: |lambda| max MPM {mpm:.1}, TLS {size:.1}, growth {growth:.1e}"
            );
            assert!(size < 1.5 * mpm, "phase {phase}: {size} vs MPM {mpm}");
        }
    }
}
