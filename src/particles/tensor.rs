//! The dimension-generic particle store (`D` = 1, 2, 3): one `Vec<f64>` per component, and
//! its counting sort by cell.
//!
//! Stress is always the symmetric 3x3 Cauchy stress in the order
//! [`STRESS_COMPONENTS`] = `xx, yy, zz, xy, xz, yz` (plane strain carries `zz`; `xz`, `yz`
//! stay zero below 3D); `F` is the `D x D` deformation gradient (plane strain: `F_zz = 1`).

/// Names of the stored stress components, in storage order.
pub const STRESS_COMPONENTS: [&str; 6] = ["xx", "yy", "zz", "xy", "xz", "yz"];

/// Index into the stress storage of the symmetric component `(a, b)`, `a, b < 3`.
#[inline(always)]
pub const fn stress_index(a: usize, b: usize) -> usize {
    match (a, b) {
        (0, 0) => 0,
        (1, 1) => 1,
        (2, 2) => 2,
        (0, 1) | (1, 0) => 3,
        (0, 2) | (2, 0) => 4,
        _ => 5,
    }
}

/// The stress components a `D`-dimensional run writes (`xx, yy, zz, xy` in 2D; all six in
/// 3D; `xx` in 1D).
pub fn written_stress_components(dim: usize) -> &'static [usize] {
    match dim {
        1 => &[0],
        2 => &[0, 1, 2, 3],
        _ => &[0, 1, 2, 3, 4, 5],
    }
}

/// Particle fields, one array per component.
#[derive(Clone, Debug, PartialEq)]
pub struct TensorParticles<const D: usize> {
    /// Original index (stable across re-sorting).
    pub id: Vec<usize>,
    /// Initial (material) position `X_p`.
    pub x0: [Vec<f64>; D],
    /// Current position `x_p`.
    pub x: [Vec<f64>; D],
    /// Displacement `u_p`.
    pub u: [Vec<f64>; D],
    /// Velocity `v_p`.
    pub v: [Vec<f64>; D],
    /// Cauchy stress, components [`STRESS_COMPONENTS`].
    pub stress: [Vec<f64>; 6],
    /// Deformation gradient `F[a][b]`.
    pub deformation_gradient: [[Vec<f64>; D]; D],
    /// Current volume `V_p = det F V_p^0`.
    pub volume: Vec<f64>,
    /// Initial volume `V_p^0`.
    pub volume0: Vec<f64>,
    /// Constant mass `m_p`.
    pub mass: Vec<f64>,
    /// Lexicographic cell of each particle.
    pub cell: Vec<usize>,
}

impl<const D: usize> Default for TensorParticles<D> {
    fn default() -> Self {
        Self {
            id: Vec::new(),
            x0: std::array::from_fn(|_| Vec::new()),
            x: std::array::from_fn(|_| Vec::new()),
            u: std::array::from_fn(|_| Vec::new()),
            v: std::array::from_fn(|_| Vec::new()),
            stress: std::array::from_fn(|_| Vec::new()),
            deformation_gradient: std::array::from_fn(|_| std::array::from_fn(|_| Vec::new())),
            volume: Vec::new(),
            volume0: Vec::new(),
            mass: Vec::new(),
            cell: Vec::new(),
        }
    }
}

impl<const D: usize> TensorParticles<D> {
    /// Number of particles.
    pub fn len(&self) -> usize {
        self.id.len()
    }

    /// `true` without particles.
    pub fn is_empty(&self) -> bool {
        self.id.is_empty()
    }

    /// Position of particle `p`.
    #[inline(always)]
    pub fn position(&self, p: usize) -> [f64; D] {
        std::array::from_fn(|a| self.x[a][p])
    }

    /// Velocity of particle `p`.
    #[inline(always)]
    pub fn velocity(&self, p: usize) -> [f64; D] {
        std::array::from_fn(|a| self.v[a][p])
    }

    /// Density `rho_p = m_p / V_p` of particle `p` (derived, not stored: the particle
    /// update does not write it).
    #[inline(always)]
    pub fn density(&self, p: usize) -> f64 {
        self.mass[p] / self.volume[p]
    }

    /// Every particle's density [`Self::density`], for output.
    pub fn densities(&self) -> Vec<f64> {
        (0..self.len()).map(|p| self.density(p)).collect()
    }

    /// Initial position of particle `p`.
    #[inline(always)]
    pub fn material_position(&self, p: usize) -> [f64; D] {
        std::array::from_fn(|a| self.x0[a][p])
    }

    /// Particles at rest, stress free, undeformed, at the given initial positions with
    /// volumes `volume` and density `density`; `cell` from `cell_of`.
    pub fn at_rest(
        x0: [Vec<f64>; D],
        volume: Vec<f64>,
        density: f64,
        cell: impl Fn([f64; D]) -> usize,
    ) -> Self {
        let n = volume.len();
        let cells = (0..n)
            .map(|p| cell(std::array::from_fn(|a| x0[a][p])))
            .collect();
        Self {
            id: (0..n).collect(),
            x: x0.clone(),
            u: std::array::from_fn(|_| vec![0.0; n]),
            v: std::array::from_fn(|_| vec![0.0; n]),
            stress: std::array::from_fn(|_| vec![0.0; n]),
            deformation_gradient: std::array::from_fn(|a| {
                std::array::from_fn(|b| vec![if a == b { 1.0 } else { 0.0 }; n])
            }),
            mass: volume.iter().map(|v| density * v).collect(),
            volume0: volume.clone(),
            volume,
            cell: cells,
            x0,
        }
    }

    /// Every `f64` field, mutably (for permutations and [`records`]).
    /// The `f64` fields in the order of [`Self::fields_mut`], read only.
    pub(crate) fn fields(&self) -> Vec<&Vec<f64>> {
        let mut fields: Vec<&Vec<f64>> = Vec::with_capacity(6 * D + D * D + 10);
        fields.extend(self.x0.iter());
        fields.extend(self.x.iter());
        fields.extend(self.u.iter());
        fields.extend(self.v.iter());
        fields.extend(self.stress.iter());
        for row in self.deformation_gradient.iter() {
            fields.extend(row.iter());
        }
        fields.extend([&self.volume, &self.volume0, &self.mass]);
        fields
    }

    pub(crate) fn fields_mut(&mut self) -> Vec<&mut Vec<f64>> {
        let mut fields: Vec<&mut Vec<f64>> = Vec::with_capacity(6 * D + D * D + 10);
        fields.extend(self.x0.iter_mut());
        fields.extend(self.x.iter_mut());
        fields.extend(self.u.iter_mut());
        fields.extend(self.v.iter_mut());
        fields.extend(self.stress.iter_mut());
        for row in self.deformation_gradient.iter_mut() {
            fields.extend(row.iter_mut());
        }
        fields.extend([&mut self.volume, &mut self.volume0, &mut self.mass]);
        fields
    }

    /// Counting-sort the particles by `cell` into `cells` bins (stable); writes
    /// `cell_start` (`cells + 1` entries) and permutes the arrays only when the order
    /// changed (fields permuted in parallel). `order` is a reused buffer.
    pub fn sort_by_cell(
        &mut self,
        cells: usize,
        cell_start: &mut Vec<usize>,
        order: &mut Vec<usize>,
    ) {
        if super::bins::counting_order(&self.cell, cells, cell_start, order) {
            return;
        }
        use rayon::prelude::*;
        let order_ref: &[usize] = order;
        let n = self.len();
        self.fields_mut().into_par_iter().for_each(|field| {
            let mut permuted = Vec::with_capacity(n);
            permuted.extend(order_ref.iter().map(|&k| field[k]));
            *field = permuted;
        });
        let id: Vec<usize> = order.iter().map(|&k| self.id[k]).collect();
        self.id = id;
        let cell: Vec<usize> = order.iter().map(|&k| self.cell[k]).collect();
        self.cell = cell;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counting_sort_permutes_every_field_stably() {
        let x0 = [vec![0.9, 0.1, 0.6, 0.2], vec![0.5, 0.5, 0.1, 0.9]];
        let mut p = TensorParticles::<2>::at_rest(x0, vec![1.0, 2.0, 3.0, 4.0], 2.0, |x| {
            usize::from(x[0] > 0.5) + 2 * usize::from(x[1] > 0.5)
        });
        assert_eq!(p.cell, vec![1, 0, 1, 2]);
        p.stress[3] = vec![10.0, 11.0, 12.0, 13.0];
        let (mut start, mut order) = (Vec::new(), Vec::new());
        p.sort_by_cell(4, &mut start, &mut order);
        assert_eq!(start, vec![0, 1, 3, 4, 4]);
        assert_eq!(p.id, vec![1, 0, 2, 3]);
        assert_eq!(p.cell, vec![0, 1, 1, 2]);
        assert_eq!(p.x[0], vec![0.1, 0.9, 0.6, 0.2]);
        assert_eq!(p.stress[3], vec![11.0, 10.0, 12.0, 13.0]);
        assert_eq!(p.mass, vec![4.0, 2.0, 6.0, 8.0]);
        assert_eq!(p.deformation_gradient[1][1], vec![1.0; 4]);
    }

    #[test]
    fn stress_indices_are_symmetric() {
        for a in 0..3 {
            for b in 0..3 {
                assert_eq!(stress_index(a, b), stress_index(b, a));
            }
        }
        assert_eq!(STRESS_COMPONENTS[stress_index(0, 2)], "xz");
        assert_eq!(written_stress_components(2).len(), 4);
    }
}
