//! Direct particle quadrature (standard MPM, SPEC §2 step 1 and 4):
//!
//! ```text
//! m_i     = sum_p m_p phi_i(x_p)
//! f_int_i = sum_p sigma_p dphi_i(x_p) V_p
//! p_i     = sum_p m_p v_p phi_i(x_p)
//! ```
//! With a partition-of-unity basis, `sum_i m_i = sum_p m_p` and `sum_i p_i = sum_p m_p v_p`
//! up to round-off (the lumped mapping conserves mass and momentum). The consistent mass
//! matrix, when asked for, is `M^C_ij = sum_p m_p phi_i(x_p) phi_j(x_p)`.

use super::next::NextMassForce;
use super::points::{
    map_mass_and_force, map_momentum, update_velocities_and_map_momentum, ParticlePoints,
};
use super::{CellScatter, GridFields, Mapping};
use crate::grid::shape_cache::with_shape_source;
use crate::grid::{Basis, Evaluate, ShapeCache};
use crate::particles::{CellBins, Particles};

/// Standard MPM mapping by particle quadrature.
#[derive(Clone, Debug, Default)]
pub struct DirectMapping {
    scatter: CellScatter,
    next: NextMassForce,
}

impl Mapping for DirectMapping {
    fn name(&self) -> &'static str {
        "none"
    }

    fn map_mass_and_internal_force<B: Basis>(
        &mut self,
        basis: &B,
        particles: &Particles,
        bins: &CellBins,
        grid: &mut GridFields,
    ) {
        let points = ParticlePoints::new(particles, bins);
        map_mass_and_force(&mut self.scatter, basis, &points, particles, bins, grid);
    }

    fn map_momentum<B: Basis>(
        &mut self,
        basis: &B,
        particles: &Particles,
        bins: &CellBins,
        grid: &mut GridFields,
    ) {
        let points = ParticlePoints::new(particles, bins);
        map_momentum(&mut self.scatter, basis, &points, particles, bins, grid);
    }

    fn map_mass_and_internal_force_reusing<B: Basis>(
        &mut self,
        basis: &B,
        particles: &Particles,
        bins: &CellBins,
        grid: &mut GridFields,
        shapes: &ShapeCache,
    ) {
        let points = ParticlePoints::with_source(particles, bins, shapes);
        map_mass_and_force(&mut self.scatter, basis, &points, particles, bins, grid);
    }

    fn map_momentum_reusing<B: Basis>(
        &mut self,
        basis: &B,
        particles: &Particles,
        bins: &CellBins,
        grid: &mut GridFields,
        shapes: &ShapeCache,
    ) {
        let points = ParticlePoints::with_source(particles, bins, shapes);
        map_momentum(&mut self.scatter, basis, &points, particles, bins, grid);
    }

    fn update_velocities_and_map_momentum<B: Basis>(
        &mut self,
        basis: &B,
        particles: &mut Particles,
        bins: &CellBins,
        dt: f64,
        grid: &mut GridFields,
        shapes: Option<&ShapeCache>,
    ) -> Option<[f64; 2]> {
        let scatter = &mut self.scatter;
        Some(with_shape_source!(shapes, Evaluate, source => {
            update_velocities_and_map_momentum(scatter, basis, source, particles, bins, dt, grid)
        }))
    }

    fn next_mass_and_force(&mut self) -> Option<&mut NextMassForce> {
        Some(&mut self.next)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{Grid, LinearBasis};

    #[test]
    fn lumped_mapping_conserves_mass_and_momentum() {
        let grid = Grid::new(1.0, 7);
        let basis = LinearBasis::new(grid);
        let mut particles = Particles::at_subcell_centres(&grid, 5, 3.0);
        for (k, v) in particles.v.iter_mut().enumerate() {
            *v = (k as f64 * 0.7).sin();
        }
        let mut bins = CellBins::default();
        bins.sort(&mut particles, grid.cells);
        let mut fields = GridFields::new(basis.num_dofs());
        let mut mapping = DirectMapping::default();
        mapping.map_mass_and_internal_force(&basis, &particles, &bins, &mut fields);
        mapping.map_momentum(&basis, &particles, &bins, &mut fields);
        let m_p: f64 = particles.mass.iter().sum();
        let m_i: f64 = fields.mass.iter().sum();
        assert!((m_p - m_i).abs() <= 1e-14 * m_p);
        let p_p: f64 = particles
            .mass
            .iter()
            .zip(&particles.v)
            .map(|(m, v)| m * v)
            .sum();
        let p_i: f64 = fields.momentum.iter().sum();
        assert!((p_p - p_i).abs() <= 1e-14 * particles.mass.iter().sum::<f64>());
        // Constant stress gives zero interior internal force (divergence-free).
        let mut constant = particles.clone();
        constant.stress.fill(5.0);
        mapping.map_mass_and_internal_force(&basis, &constant, &bins, &mut fields);
        for f in &fields.internal_force[1..grid.cells] {
            assert!(f.abs() < 1e-12, "{f}");
        }
    }
}
