//! Particle layouts for the mapping tests: particles anywhere in the grid, cells empty or
//! crowded, sorted into their bins.

use crate::grid::Grid;
use crate::particles::{CellBins, Particles};

/// One particle at `t_p * length` for each `t_p` in `[0, 1]`, with volumes
/// `h (0.1 + 0.8 t_p)`, masses `1 + |sin(0.37 p)|`, stresses `1e3 cos(1.3 p)` and velocities
/// `cos(0.91 p)`, sorted by cell, with its bins.
pub(crate) fn scattered_particles(grid: &Grid, t: &[f64]) -> (Particles, CellBins) {
    let mut particles = Particles::at_subcell_centres(grid, 1, 3.0);
    let n = t.len();
    particles.x = t.iter().map(|t| t * grid.length).collect();
    particles.cell = particles
        .x
        .iter()
        .map(|&x| grid.cell_of(x).unwrap_or(grid.cells - 1))
        .collect();
    particles.volume = t.iter().map(|t| grid.h * (0.1 + 0.8 * t)).collect();
    particles.mass = (0..n)
        .map(|p| 1.0 + (p as f64 * 0.37).sin().abs())
        .collect();
    particles.stress = (0..n).map(|p| (p as f64 * 1.3).cos() * 1e3).collect();
    particles.v = (0..n).map(|p| (p as f64 * 0.91).cos()).collect();
    for field in [&mut particles.u, &mut particles.density] {
        field.resize(n, 0.0);
    }
    particles.deformation_gradient.resize(n, 1.0);
    particles.x0.resize(n, 0.0);
    particles.id = (0..n).collect();
    let mut bins = CellBins::default();
    bins.sort(&mut particles, grid.cells);
    (particles, bins)
}
