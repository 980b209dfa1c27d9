//! The direct (standard MPM) particle-to-grid mapping of the dimension-generic core
//! (`docs/dimensions.md`), with the deterministic slab scatter of
//! [`super::tensor_scatter`]:
//!
//! ```text
//! m_I   = sum_p m_p phi_I(x_p)
//! f_I   = sum_p ( -V_p sigma_p . grad phi_I(x_p) + m_p b_p phi_I(x_p) )
//! p_I   = sum_p m_p v_p phi_I(x_p)
//! ```
//! Particle-domain bases (GIMP) are evaluated over the domain of half-lengths
//! `l_a = l0_a F_aa` (the initial half spacing stretched with the particle).
//! Partition of unity makes `sum_I m_I = sum_p m_p` and `sum_I p_I = sum_p m_p v_p`: mass
//! and every momentum component are conserved by the mapping to round-off.

use super::tensor::TensorMapping;
use super::tensor_kernels::{add_mass_and_force, scatter_momentum};
use super::tensor_next::NextMassForce;
use super::tensor_scatter::TensorScatter;
use crate::error::Result;
use crate::grid::shape_cache::with_shape_source;
use crate::grid::tensor::with_fixed_support;
use crate::grid::{
    Basis, EvaluateTensor, ShapeSlots, TensorBasis, TensorShape, TensorShapeCache,
    TensorShapeSource,
};
use crate::particles::TensorParticles;
use std::ops::Range;

/// Grid vectors of a step: one value or `[f64; D]` per node.
#[derive(Clone, Debug)]
pub struct TensorGridFields<const D: usize> {
    pub mass: Vec<f64>,
    /// Total force `f_ext - f_int`.
    pub force: Vec<[f64; D]>,
    pub momentum: Vec<[f64; D]>,
    pub acceleration: Vec<[f64; D]>,
    pub velocity: Vec<[f64; D]>,
    /// Scatter output `[m, f_x, f_y, f_z]`.
    pub(crate) mass_force: Vec<[f64; 4]>,
}

impl<const D: usize> TensorGridFields<D> {
    /// Zeroed vectors for `num_dofs` nodes.
    pub fn new(num_dofs: usize) -> Self {
        Self {
            mass: vec![0.0; num_dofs],
            force: vec![[0.0; D]; num_dofs],
            momentum: vec![[0.0; D]; num_dofs],
            acceleration: vec![[0.0; D]; num_dofs],
            velocity: vec![[0.0; D]; num_dofs],
            mass_force: vec![[0.0; 4]; num_dofs],
        }
    }
}

/// The body force of a step: one acceleration for all particles, or one per particle
/// (components `[a][p]`, in particle storage order).
#[derive(Clone, Copy, Debug)]
pub enum TensorBody<'a, const D: usize> {
    Uniform([f64; D]),
    PerParticle(&'a [Vec<f64>; D]),
}

/// The domain half-lengths of particle `p` (zero for point bases).
#[inline(always)]
pub fn half_lengths<const D: usize>(
    particles: &TensorParticles<D>,
    half_length0: &Option<[f64; D]>,
    p: usize,
) -> [f64; D] {
    half_lengths_of(half_length0, &particles.deformation_gradient, p)
}

/// The basis functions at particle `p` (its position, cell and domain), evaluated for
/// the fixed support `N` ([`TensorBasis::eval_particle_n`]).
#[inline(always)]
pub fn eval_at<const D: usize, B: Basis, const N: usize>(
    basis: &TensorBasis<D, B>,
    particles: &TensorParticles<D>,
    half_length0: &Option<[f64; D]>,
    p: usize,
    shape: &mut TensorShape<D>,
) {
    let x = particles.position(p);
    let cell = basis.grid.axis_cells(x);
    basis.eval_particle_n::<N>(cell, x, half_lengths(particles, half_length0, p), shape);
}

/// Layers of cells a particle of the direct mapping may stray from its bin before the
/// particles are re-sorted. The direct mapping needs only that each scatter task's
/// particles touch the task's (widened) node range, not exact per-cell bins; with one
/// layer of slack a particle must travel at least a cell before it forces a sort, so a
/// step at CFL-limited `dt` sorts every ten or more steps instead of on every step with a
/// grid crossing.
pub const DIRECT_BIN_SLACK: usize = 1;

/// Scatter buffers of the direct mapping.
#[derive(Clone, Debug)]
pub struct TensorDirectMapping<const D: usize> {
    mass_force: TensorScatter<4>,
    momentum: TensorScatter<D>,
    /// Initial half spacing of the particles for particle-domain bases, `None` for point
    /// bases.
    pub half_length0: Option<[f64; D]>,
    bin_slack: usize,
    /// The shapes the mass and force scatter evaluates, kept for the later passes of the
    /// step (bases that [`Basis::reuse_shapes`] with a fixed support), else `None`.
    shapes: Option<TensorShapeCache<D>>,
    /// Whether `shapes` holds the particles' current shapes: set by the mass and force
    /// scatter, cleared by [`TensorMapping::forget_shapes`] once the particles move.
    shapes_current: bool,
}

impl<const D: usize> TensorDirectMapping<D> {
    /// Buffers for `basis`, with [`DIRECT_BIN_SLACK`] layers of bin slack.
    pub fn new<B: Basis>(basis: &TensorBasis<D, B>, half_length0: Option<[f64; D]>) -> Self {
        Self::with_bin_slack(basis, half_length0, DIRECT_BIN_SLACK)
    }

    /// Buffers for `basis` that let a particle stray `slack` layers of cells from its bin
    /// before a sort (0: sort on every grid crossing).
    pub fn with_bin_slack<B: Basis>(
        basis: &TensorBasis<D, B>,
        half_length0: Option<[f64; D]>,
        slack: usize,
    ) -> Self {
        Self {
            mass_force: TensorScatter::with_slack(basis, slack),
            momentum: TensorScatter::with_slack(basis, slack),
            half_length0,
            bin_slack: slack,
            shapes: (basis.axis(0).reuse_shapes() && basis.fixed_support().is_some())
                .then(TensorShapeCache::default),
            shapes_current: false,
        }
    }

    /// The same mapping evaluating the basis in every pass instead of keeping the shapes of
    /// the first ([`crate::grid::tensor_shape_cache`]): bitwise the same results, for
    /// checks and measurements.
    pub fn evaluating_every_pass(mut self) -> Self {
        self.shapes = None;
        self
    }

    /// The shapes stored by the last mass and force scatter, while the particles have not
    /// moved since (see [`TensorMapping::shapes`]).
    fn current_shapes(&self) -> Option<&TensorShapeCache<D>> {
        self.shapes.as_ref().filter(|_| self.shapes_current)
    }

    /// `m_I` and `f_I = f_ext - f_int` into `fields.mass`, `fields.force`. Keeps the
    /// particles' shapes for the later passes of the step where the basis is worth it.
    pub fn map_mass_and_force<B: Basis>(
        &mut self,
        basis: &TensorBasis<D, B>,
        particles: &TensorParticles<D>,
        cell_start: &[usize],
        body: TensorBody<'_, D>,
        fields: &mut TensorGridFields<D>,
    ) {
        with_fixed_support!(basis, N => {
            self.map_mass_and_force_n::<B, N>(basis, particles, cell_start, body, fields)
        })
    }

    fn map_mass_and_force_n<B: Basis, const N: usize>(
        &mut self,
        basis: &TensorBasis<D, B>,
        particles: &TensorParticles<D>,
        cell_start: &[usize],
        body: TensorBody<'_, D>,
        fields: &mut TensorGridFields<D>,
    ) {
        let strides = *basis.strides();
        let half0 = self.half_length0;
        let p = particles;
        let tasks = self.mass_force.tasks().len();
        // The shapes evaluated here are stored for the later passes of the step.
        self.shapes_current = self.shapes.is_some();
        let slots: Vec<Option<ShapeSlots<'_, D>>> = match &mut self.shapes {
            Some(cache) => {
                cache.resize(p.len(), N);
                cache
                    .slots(&task_particles(self.mass_force.tasks(), cell_start))
                    .into_iter()
                    .map(Some)
                    .collect()
            }
            None => (0..tasks).map(|_| None).collect(),
        };
        self.mass_force.scatter_with(
            cell_start,
            slots,
            &mut fields.mass_force,
            |mut slots: Option<ShapeSlots<'_, D>>, range: Range<usize>, lo, local| {
                let mut shape = TensorShape::<D>::default();
                for k in range {
                    eval_at::<D, B, N>(basis, p, &half0, k, &mut shape);
                    if let Some(slots) = &mut slots {
                        slots.store::<N>(k, &shape);
                    }
                    add_mass_and_force::<D, N>(
                        &shape,
                        &strides,
                        p.mass[k],
                        p.volume[k],
                        |s| p.stress[s][k],
                        body.at(k),
                        lo,
                        local,
                    );
                }
                if let Some(slots) = &mut slots {
                    slots.finish();
                }
            },
        );
        unpack_mass_and_force(fields);
    }

    /// `p_I = sum_p m_p v_p phi_I` into `fields.momentum`.
    pub fn map_momentum<B: Basis>(
        &mut self,
        basis: &TensorBasis<D, B>,
        particles: &TensorParticles<D>,
        cell_start: &[usize],
        fields: &mut TensorGridFields<D>,
    ) {
        with_fixed_support!(basis, N => {
            self.map_momentum_n::<B, N>(basis, particles, cell_start, fields)
        })
    }

    fn map_momentum_n<B: Basis, const N: usize>(
        &mut self,
        basis: &TensorBasis<D, B>,
        particles: &TensorParticles<D>,
        cell_start: &[usize],
        fields: &mut TensorGridFields<D>,
    ) {
        let shapes = self.shapes.as_ref().filter(|_| self.shapes_current);
        with_shape_source!(shapes, EvaluateTensor, source => map_momentum_from::<D, B, N, _>(
            &mut self.momentum,
            source,
            &self.half_length0,
            basis,
            particles,
            cell_start,
            fields,
        ))
    }

    /// MUSL steps 3–4 fused: `v_p += dt sum_I phi_I a_I`, then `p_I = sum_p m_p v_p phi_I`
    /// with the updated velocities, in one pass (one shape evaluation per particle).
    /// Returns the particle momentum `sum_p m_p v_p` (components `0..D`) and
    /// `sum_p m_p |v_p|` (last entry) of the updated velocities, summed per task and then
    /// over the tasks in order (deterministic).
    pub fn update_velocities_and_map_momentum<B: Basis>(
        &mut self,
        basis: &TensorBasis<D, B>,
        particles: &mut TensorParticles<D>,
        cell_start: &[usize],
        dt: f64,
        fields: &mut TensorGridFields<D>,
    ) -> [f64; 4] {
        with_fixed_support!(basis, N => {
            self.update_velocities_and_map_momentum_n::<B, N>(
                basis, particles, cell_start, dt, fields,
            )
        })
    }

    fn update_velocities_and_map_momentum_n<B: Basis, const N: usize>(
        &mut self,
        basis: &TensorBasis<D, B>,
        particles: &mut TensorParticles<D>,
        cell_start: &[usize],
        dt: f64,
        fields: &mut TensorGridFields<D>,
    ) -> [f64; 4] {
        let shapes = self.shapes.as_ref().filter(|_| self.shapes_current);
        with_shape_source!(shapes, EvaluateTensor, source => {
            velocities_and_momentum::<D, B, N, _>(
                &mut self.momentum,
                source,
                &self.half_length0,
                basis,
                particles,
                cell_start,
                dt,
                fields,
            )
        })
    }
}

/// `fields.mass`, `fields.force` from the scatter output `fields.mass_force`.
pub(crate) fn unpack_mass_and_force<const D: usize>(fields: &mut TensorGridFields<D>) {
    for ((m, f), mf) in fields
        .mass
        .iter_mut()
        .zip(fields.force.iter_mut())
        .zip(&fields.mass_force)
    {
        *m = mf[0];
        f.copy_from_slice(&mf[1..=D]);
    }
}

impl<const D: usize> TensorBody<'_, D> {
    /// The body force (acceleration) of particle `k`.
    #[inline(always)]
    pub fn at(&self, k: usize) -> [f64; D] {
        match self {
            TensorBody::Uniform(b) => *b,
            TensorBody::PerParticle(b) => std::array::from_fn(|a| b[a][k]),
        }
    }
}

/// The particles of each scatter task (consecutive ranges from 0: the tasks' cells).
pub(crate) fn task_particles(
    tasks: &[super::tensor_scatter::ScatterTask],
    cell_start: &[usize],
) -> Vec<Range<usize>> {
    tasks
        .iter()
        .map(|t| cell_start[t.cells.start]..cell_start[t.cells.end])
        .collect()
}

/// [`half_lengths`] from the deformation gradients alone.
#[inline(always)]
pub fn half_lengths_of<const D: usize>(
    half_length0: &Option<[f64; D]>,
    deformation_gradient: &[[Vec<f64>; D]; D],
    k: usize,
) -> [f64; D] {
    match half_length0 {
        Some(l0) => std::array::from_fn(|a| l0[a] * deformation_gradient[a][a][k].abs()),
        None => [0.0; D],
    }
}

/// `p_I = sum_p m_p v_p phi_I` with the shapes of `source`.
fn map_momentum_from<const D: usize, B: Basis, const N: usize, S: TensorShapeSource<D>>(
    scatter: &mut TensorScatter<D>,
    source: &S,
    half_length0: &Option<[f64; D]>,
    basis: &TensorBasis<D, B>,
    particles: &TensorParticles<D>,
    cell_start: &[usize],
    fields: &mut TensorGridFields<D>,
) {
    let strides = *basis.strides();
    let p = particles;
    scatter.scatter(
        cell_start,
        &mut fields.momentum,
        |range: Range<usize>, lo, local| {
            let mut shape = TensorShape::<D>::default();
            for k in range {
                let half = half_lengths_of(half_length0, &p.deformation_gradient, k);
                source.shape_of::<B, N>(basis, k, p.position(k), half, &mut shape);
                let mv: [f64; D] = std::array::from_fn(|a| p.mass[k] * p.v[a][k]);
                scatter_momentum::<D, N>(&shape, &strides, mv, lo, local);
            }
        },
    );
}

/// MUSL steps 3–4 fused with the shapes of `source` (see
/// [`TensorDirectMapping::update_velocities_and_map_momentum`]).
#[allow(clippy::too_many_arguments)]
fn velocities_and_momentum<const D: usize, B: Basis, const N: usize, S: TensorShapeSource<D>>(
    scatter: &mut TensorScatter<D>,
    source: &S,
    half_length0: &Option<[f64; D]>,
    basis: &TensorBasis<D, B>,
    particles: &mut TensorParticles<D>,
    cell_start: &[usize],
    dt: f64,
    fields: &mut TensorGridFields<D>,
) -> [f64; 4] {
    let strides = *basis.strides();
    // Each task owns the velocity chunks of its particles.
    let ranges = task_particles(scatter.tasks(), cell_start);
    let TensorParticles {
        x,
        v,
        mass,
        deformation_gradient,
        ..
    } = particles;
    let (x, mass, deformation_gradient) = (&*x, &*mass, &*deformation_gradient);
    let mut sums = vec![[0.0; 4]; ranges.len()];
    let states: Vec<_> = split_components(v, &ranges)
        .into_iter()
        .zip(sums.iter_mut())
        .collect();
    let acceleration = &fields.acceleration;
    scatter.scatter_with(
        cell_start,
        states,
        &mut fields.momentum,
        |(v, sum): ([&mut [f64]; D], &mut [f64; 4]), range: Range<usize>, lo, local| {
            let mut shape = TensorShape::<D>::default();
            let start = range.start;
            for k in range {
                let position: [f64; D] = std::array::from_fn(|a| x[a][k]);
                let half = half_lengths_of(half_length0, deformation_gradient, k);
                source.shape_of::<B, N>(basis, k, position, half, &mut shape);
                let dv = shape.interpolate_n::<N>(&strides, acceleration);
                let mut mv = [0.0; D];
                let mut speed2 = 0.0;
                for a in 0..D {
                    let velocity = &mut v[a][k - start];
                    *velocity += dt * dv[a];
                    mv[a] = mass[k] * *velocity;
                    speed2 += *velocity * *velocity;
                    sum[a] += mv[a];
                }
                sum[3] += mass[k] * speed2.sqrt();
                scatter_momentum::<D, N>(&shape, &strides, mv, lo, local);
            }
        },
    );
    let mut total = [0.0; 4];
    for s in &sums {
        for (t, s) in total.iter_mut().zip(s) {
            *t += s;
        }
    }
    total
}

/// Split each component array into consecutive chunks of the lengths of `ranges` (which
/// tile `0..n` in order): one `[&mut [f64]; D]` per range.
pub fn split_components<'a, const D: usize>(
    components: &'a mut [Vec<f64>; D],
    ranges: &[Range<usize>],
) -> Vec<[&'a mut [f64]; D]> {
    let mut per_component: Vec<std::vec::IntoIter<&'a mut [f64]>> = components
        .iter_mut()
        .map(|c| {
            let mut chunks = Vec::with_capacity(ranges.len());
            let mut rest = c.as_mut_slice();
            for r in ranges {
                let (head, tail) = std::mem::take(&mut rest).split_at_mut(r.len());
                chunks.push(head);
                rest = tail;
            }
            chunks.into_iter()
        })
        .collect();
    (0..ranges.len())
        .map(|_| std::array::from_fn(|a| per_component[a].next().unwrap_or_default()))
        .collect()
}

impl<const D: usize> TensorMapping<D> for TensorDirectMapping<D> {
    fn name(&self) -> &'static str {
        "none"
    }

    fn particle_domains(&self) -> &Option<[f64; D]> {
        &self.half_length0
    }

    fn bin_slack(&self) -> usize {
        self.bin_slack
    }

    fn shapes(&self) -> Option<&TensorShapeCache<D>> {
        self.current_shapes()
    }

    fn next_mass_and_force(&mut self) -> Option<NextMassForce<'_, D>> {
        let cache = self.shapes.as_mut()?;
        Some(NextMassForce {
            scatter: &mut self.mass_force,
            cache,
            shapes_current: &mut self.shapes_current,
            half_length0: self.half_length0,
        })
    }

    fn forget_shapes(&mut self) {
        self.shapes_current = false;
    }

    fn map_mass_and_force<B: Basis>(
        &mut self,
        basis: &TensorBasis<D, B>,
        particles: &TensorParticles<D>,
        cell_start: &[usize],
        body: TensorBody<'_, D>,
        fields: &mut TensorGridFields<D>,
    ) -> Result<()> {
        TensorDirectMapping::map_mass_and_force(self, basis, particles, cell_start, body, fields);
        Ok(())
    }

    fn map_momentum<B: Basis>(
        &mut self,
        basis: &TensorBasis<D, B>,
        particles: &TensorParticles<D>,
        cell_start: &[usize],
        fields: &mut TensorGridFields<D>,
    ) -> Result<()> {
        TensorDirectMapping::map_momentum(self, basis, particles, cell_start, fields);
        Ok(())
    }

    fn update_velocities_and_map_momentum<B: Basis>(
        &mut self,
        basis: &TensorBasis<D, B>,
        particles: &mut TensorParticles<D>,
        cell_start: &[usize],
        dt: f64,
        fields: &mut TensorGridFields<D>,
    ) -> Result<[f64; 4]> {
        Ok(TensorDirectMapping::update_velocities_and_map_momentum(
            self, basis, particles, cell_start, dt, fields,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{BSplineBasis, TensorGrid};

    /// Quadratic B-splines on 6 x 6 cells, 4 particles in each of a few cells, moving.
    fn setup() -> (TensorBasis<2, BSplineBasis>, TensorParticles<2>, Vec<usize>) {
        let grid = TensorGrid::new([1.0, 1.0], [6, 6]);
        let basis = TensorBasis::new(grid, |g| BSplineBasis::new(g, 2).expect("order 2"));
        let (mut x, mut y) = (Vec::new(), Vec::new());
        for j in 0..6 {
            for i in 0..6 {
                x.push(0.3 + 0.07 * i as f64);
                y.push(0.25 + 0.09 * j as f64);
            }
        }
        let volume = vec![1e-3; x.len()];
        let mut particles =
            TensorParticles::at_rest([x, y], volume, 1.0, |p| grid.cell_of(p).unwrap_or(0));
        for k in 0..particles.len() {
            particles.v[0][k] = 1.0 + 0.1 * k as f64;
            particles.v[1][k] = -0.5;
        }
        let (mut cell_start, mut order) = (Vec::new(), Vec::new());
        particles.sort_by_cell(grid.num_cells(), &mut cell_start, &mut order);
        (basis, particles, cell_start)
    }

    #[test]
    fn shapes_are_read_back_only_until_they_are_forgotten() {
        let (basis, mut particles, cell_start) = setup();
        let mut kept = TensorDirectMapping::new(&basis, None);
        let mut evaluated = TensorDirectMapping::new(&basis, None).evaluating_every_pass();
        let mut fields = TensorGridFields::<2>::new(basis.num_dofs());
        let body = TensorBody::Uniform([0.0, -9.81]);
        kept.map_mass_and_force(&basis, &particles, &cell_start, body, &mut fields);
        assert!(TensorMapping::shapes(&kept).is_some());
        // The particles move within their cells (bins stay valid); the kept shapes are now
        // stale, and after `forget_shapes` the momentum map must evaluate again.
        for k in 0..particles.len() {
            particles.x[0][k] += 0.01;
        }
        kept.forget_shapes();
        assert!(TensorMapping::shapes(&kept).is_none());
        let mut expected = TensorGridFields::<2>::new(basis.num_dofs());
        evaluated.map_momentum(&basis, &particles, &cell_start, &mut expected);
        kept.map_momentum(&basis, &particles, &cell_start, &mut fields);
        assert_eq!(fields.momentum, expected.momentum);
        // And before the move, the kept shapes give the evaluation's momentum bit for bit.
        for k in 0..particles.len() {
            particles.x[0][k] -= 0.01;
        }
        kept.map_mass_and_force(&basis, &particles, &cell_start, body, &mut fields);
        evaluated.map_momentum(&basis, &particles, &cell_start, &mut expected);
        kept.map_momentum(&basis, &particles, &cell_start, &mut fields);
        assert_eq!(fields.momentum, expected.momentum);
    }
}
