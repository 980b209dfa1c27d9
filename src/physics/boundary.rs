//! Boundary conditions of the 1D continuum: fixed (Dirichlet, `u = 0`) ends and traction
//! (Neumann, `sigma n = tau`) ends. A fixed DOF gets `a_i = 0` and `v_i = 0`; a traction
//! `tau` acts on the material surface `x_s` (`n = -1` left, `+1` right):
//! `f_ext_i += tau n phi_i(x_s)`, which is `tau n` on the end DOF while the surface is at
//! the grid end and follows the surface when the material moves away from it (a settling
//! loaded column), so the load never lands on a DOF that has lost its mass.

use crate::grid::{Basis, Grid, Shape};

/// What happens at the two ends of the domain.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Boundary {
    pub fixed_left: bool,
    pub fixed_right: bool,
    /// Traction `sigma(left)`; only used when the left end is free.
    pub traction_left: f64,
    /// Traction `sigma(right)`; only used when the right end is free.
    pub traction_right: f64,
}

impl Boundary {
    /// Both ends fixed.
    pub fn fixed_both() -> Self {
        Self {
            fixed_left: true,
            fixed_right: true,
            ..Self::default()
        }
    }

    /// Left (bottom) end fixed, right (top) end traction free.
    pub fn fixed_left_free_right() -> Self {
        Self {
            fixed_left: true,
            ..Self::default()
        }
    }

    /// Whether a free end carries a non-zero traction.
    pub fn has_tractions(&self) -> bool {
        (!self.fixed_left && self.traction_left != 0.0)
            || (!self.fixed_right && self.traction_right != 0.0)
    }

    /// Add the end tractions at the material surfaces `surfaces = (x_left, x_right)` (see
    /// the module doc) to `external_force`.
    pub fn add_surface_tractions<B: Basis>(
        &self,
        basis: &B,
        grid: &Grid,
        (left, right): (f64, f64),
        external_force: &mut [f64],
    ) {
        let mut shape = Shape::default();
        let ends = [
            (!self.fixed_left, left, -self.traction_left),
            (!self.fixed_right, right, self.traction_right),
        ];
        for (free, surface, force) in ends {
            if !free || force == 0.0 {
                continue;
            }
            let surface = surface.clamp(grid.origin, grid.origin + grid.length);
            let Some(cell) = grid.cell_of(surface) else {
                continue;
            };
            basis.eval(cell, surface, &mut shape);
            for k in 0..shape.len {
                external_force[shape.first + k] += force * shape.phi[k];
            }
        }
    }

    /// Add the end tractions to `external_force`, whose end DOFs are `(left, right)`.
    pub fn add_tractions(&self, (left, right): (usize, usize), external_force: &mut [f64]) {
        if !self.fixed_left {
            external_force[left] -= self.traction_left;
        }
        if !self.fixed_right {
            external_force[right] += self.traction_right;
        }
    }

    /// The fixed DOFs among the end DOFs `(left, right)`.
    pub fn fixed_dofs(&self, (left, right): (usize, usize)) -> FixedDofs {
        let mut fixed = FixedDofs::default();
        for (is_fixed, dof) in [(self.fixed_left, left), (self.fixed_right, right)] {
            if is_fixed {
                fixed.dofs[fixed.len] = dof;
                fixed.len += 1;
            }
        }
        fixed
    }

    /// Zero the fixed DOFs of a grid vector (accelerations, velocities).
    pub fn zero_fixed(&self, (left, right): (usize, usize), grid_vector: &mut [f64]) {
        if self.fixed_left {
            grid_vector[left] = 0.0;
        }
        if self.fixed_right {
            grid_vector[right] = 0.0;
        }
    }
}

/// Up to two fixed DOFs (no allocation).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FixedDofs {
    dofs: [usize; 2],
    len: usize,
}

impl FixedDofs {
    /// The fixed DOFs.
    pub fn as_slice(&self) -> &[usize] {
        &self.dofs[..self.len]
    }
}
