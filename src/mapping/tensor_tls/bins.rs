//! The particles of every cell, as lists of particle indices (a stable counting sort of
//! `cell`), for the per-cell fits of TLS.
//!
//! The fits need the exact particles of each cell, but not the particle arrays in cell
//! order: with its own index lists the mapping lets the time stepper re-sort the arrays
//! only when particles have strayed a layer of cells from their bin
//! ([`super::TLS_BIN_SLACK`]), instead of permuting every particle array on every step with
//! a grid crossing (a fifth of the particle update at 10⁶ particles). A cell's particles
//! are listed in storage order.

use crate::particles::counting_order;

/// Per-cell particle lists: `particles[start[c]..start[c + 1]]` are the particles of
/// cell `c`, in storage order.
#[derive(Clone, Debug, Default)]
pub(super) struct CellParticles {
    start: Vec<usize>,
    particles: Vec<usize>,
    /// Built from the current `cell` of the particles (cleared when they move).
    pub(super) fresh: bool,
}

impl CellParticles {
    /// Bin the particles by `cell` (each `< cells`).
    ///
    /// ```text
    /// cell = [2, 0, 2, 1]  ->  start = [0, 1, 2, 4], particles = [1, 3, 0, 2]
    /// ```
    pub(super) fn rebuild(&mut self, cells: usize, cell: &[usize]) {
        if counting_order(cell, cells, &mut self.start, &mut self.particles) {
            self.particles.clear();
            self.particles.extend(0..cell.len());
        }
        self.fresh = true;
    }

    /// The particles of cell `cell`, in storage order.
    #[inline]
    pub(super) fn of(&self, cell: usize) -> &[usize] {
        &self.particles[self.start[cell]..self.start[cell + 1]]
    }

    /// Whether cell `cell` holds no particle.
    #[inline]
    pub(super) fn is_empty(&self, cell: usize) -> bool {
        self.start[cell + 1] == self.start[cell]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bins_list_each_cells_particles_in_storage_order() {
        let mut bins = CellParticles::default();
        bins.rebuild(4, &[2, 0, 2, 1, 0]);
        assert_eq!(bins.of(0), &[1, 4]);
        assert_eq!(bins.of(1), &[3]);
        assert_eq!(bins.of(2), &[0, 2]);
        assert!(bins.is_empty(3) && !bins.is_empty(2));
        bins.rebuild(3, &[0, 1, 1, 2]);
        assert_eq!(bins.of(1), &[1, 2]);
        assert_eq!(bins.of(2), &[3]);
    }
}
