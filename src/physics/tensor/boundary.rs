//! Boundary conditions per grid face (`[boundary]` keys): `fixed` sets every velocity and
//! acceleration component of the face's nodes to zero, `roller` the normal one,
//! `free` nothing. The face nodes of axis `a` are the DOFs whose 1D index is the first /
//! last of that axis (the only non-zero functions at the face, for hats and open
//! B-splines alike).

use crate::config::FaceCondition;
use crate::grid::{Basis, TensorBasis};

/// `[axis][min, max]` conditions.
pub type FaceConditions<const D: usize> = [[FaceCondition; 2]; D];

/// The constrained nodes and, per node, which components are held at zero.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NodeConstraints<const D: usize> {
    pub nodes: Vec<(usize, [bool; D])>,
}

impl<const D: usize> NodeConstraints<D> {
    /// The constraints of `faces` on the nodes of `basis`.
    pub fn new<B: Basis>(basis: &TensorBasis<D, B>, faces: &FaceConditions<D>) -> Self {
        let dofs = basis.dofs();
        let strides = *basis.strides();
        let mut mask = vec![[false; D]; basis.num_dofs()];
        for (a, sides) in faces.iter().enumerate() {
            let (first, last) = basis.face_dofs(a);
            for (side, &condition) in sides.iter().enumerate() {
                let layer = if side == 0 { first } else { last };
                let held: [bool; D] = match condition {
                    FaceCondition::Fixed => [true; D],
                    FaceCondition::Roller => std::array::from_fn(|c| c == a),
                    FaceCondition::Free => continue,
                };
                for (node, m) in mask.iter_mut().enumerate() {
                    if (node / strides[a]) % dofs[a] == layer {
                        for c in 0..D {
                            m[c] |= held[c];
                        }
                    }
                }
            }
        }
        Self {
            nodes: mask
                .into_iter()
                .enumerate()
                .filter(|(_, m)| m.iter().any(|&held| held))
                .collect(),
        }
    }

    /// Zero the held components of `field`.
    pub fn apply(&self, field: &mut [[f64; D]]) {
        for (node, held) in &self.nodes {
            for c in 0..D {
                if held[c] {
                    field[*node][c] = 0.0;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{BSplineBasis, TensorGrid};
    use FaceCondition::*;

    #[test]
    fn rollers_hold_the_normal_component_and_fixed_faces_all() {
        let grid = TensorGrid::new([1.0, 1.0], [3, 2]);
        let basis = TensorBasis::new(grid, |g| BSplineBasis::new(g, 2).unwrap());
        // 5 x 4 nodes.
        let c = NodeConstraints::new(&basis, &[[Fixed, Free], [Roller, Roller]]);
        let mut field = vec![[1.0, 1.0]; basis.num_dofs()];
        c.apply(&mut field);
        let at = |i: usize, j: usize| field[i + 5 * j];
        assert_eq!(at(0, 1), [0.0, 0.0]);
        assert_eq!(at(2, 0), [1.0, 0.0]);
        assert_eq!(at(2, 3), [1.0, 0.0]);
        assert_eq!(at(4, 2), [1.0, 1.0]);
        assert_eq!(at(2, 2), [1.0, 1.0]);
        assert_eq!(at(0, 0), [0.0, 0.0]);
    }
}
