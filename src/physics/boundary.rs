//! Boundary conditions of the 1D continuum: fixed (Dirichlet, `u = 0`) ends and traction
//! (Neumann, `sigma n = tau`) ends. A fixed DOF gets `a_i = 0` and `v_i = 0`; a traction
//! `tau` adds `tau n` to the external force of the end DOF (`n = -1` left, `+1` right).

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
