//! Conservative Taylor least squares (TLS) in `D` = 1, 2, 3 dimensions with Gauss
//! quadrature (`docs/tls.md`): the 1D mapping of [`super::tls`] on boxes.
//!
//! Per *active cell box* (the cell clipped to the material extent along every axis, see
//! below) and per field, a Taylor reconstruction of total degree `q <= 2`
//! ([`crate::numerics::taylor_nd`]) is fitted to the particles of the cell:
//!
//! * stress, each in-plane component: full least squares;
//! * density `rho_p = m_p / V_p`: conservative, `a_1 = c_e / |box_e|` with `c_e` the
//!   cell's mass;
//! * momentum density `rho_p v_p` (and a per-particle body force `rho_p b_p`), each
//!   component: conservative with the cell's momentum `sum m_p v_p`.
//!
//! Every term but the first has zero mean over the box, so `int_box rho_hat = c_e` in
//! every cell; the `(p + 2)^D`-point tensor Gauss rule integrates the reconstructions
//! against the basis exactly, and partition of unity makes `sum_I m_I = sum_p m_p` and
//! `sum_I p_I = sum_p m_p v_p` component by component, to round-off:
//!
//! ```text
//! m_I   = sum_g rho_hat(x_g) w_g phi_I(x_g)
//! f_I   = sum_g ( b rho_hat(x_g) phi_I(x_g) - sigma_hat(x_g) . grad phi_I(x_g) ) w_g
//! p_I   = sum_g (rho v)_hat(x_g) w_g phi_I(x_g)
//! M^C   = sum_g rho_hat(x_g) w_g phi(x_g) phi(x_g)^T
//! ```
//!
//! **Active boxes.** The material extent along axis `a` is
//! `[min_p (x_a - l_a), max_p (x_a + l_a)]` with the particle half-lengths
//! `l_a = l0_a |F_aa|` (`l0_a` the initial half spacing); a cell's box is the cell
//! clipped to it. With `method.cell_totals = "centres"` only cells holding a particle are
//! active, and each particle counts wholly in its cell; with `"domains"` (default) every
//! cell the extent overlaps is active, and each particle's mass and momentum are split
//! between the (up to `3^D`) cells its box domain `x +- min(l, h)` overlaps, axis by axis
//! with the 1D rule, so that cell totals do not jump when a particle crosses a face.
//!
//! **Degenerate cells** (fewer particles than terms, or all on one line / plane) drop the
//! degree 2 terms, then the degree 1 terms, counted in `summary.json`
//! (`reconstruction_remedies`). **Density limiter**: a density fit negative at a Gauss
//! point has its non-constant coefficients scaled by `theta = a_1 / (a_1 - min_g rho_hat)`,
//! which keeps the cell mass and makes the lumped masses non-negative and `M^C` positive
//! semi-definite.
//!
//! The fits are in `fits.rs`, their integration against the basis in `integrate.rs` (from
//! the per-axis 1D moments of the Taylor factors, `moments.rs`: the Gauss sums above,
//! rearranged), the box, share and limiter helpers in `cells.rs`.

// Index loops: the indices enter the formulas (terms, axes, LDL^T rows).
#![allow(clippy::needless_range_loop)]

use super::tensor::{SlabCells, TensorMapping};
use super::tensor_direct::{half_lengths, split_components, TensorBody, TensorGridFields};
use super::tensor_mass::{StencilAssembly, MAX_SUPPORT_NODES};
use super::tensor_scatter::TensorScatter;
use super::RemedyCounts;
use crate::config::CellTotals;
use crate::error::Result;
use crate::grid::tensor::with_fixed_support;
use crate::grid::{Basis, TensorBasis, TensorGrid, TensorShape};
use crate::linalg::CsrMatrix;
use crate::numerics::gauss::{GaussRule, MAX_POINTS};
use crate::numerics::taylor_nd::{TaylorBox, MAX_TERMS};
use crate::particles::TensorParticles;
use rayon::prelude::*;
use std::ops::Range;
use std::sync::Arc;

/// Cells per rayon task in the per-cell passes.
const CELLS_PER_TASK: usize = 64;
/// Layers of cells a particle may stray from its bin before the time stepper re-sorts the
/// particle arrays: the fits read each cell's particles from the mapping's own index lists
/// ([`bins`]), so the order of the arrays only sets the locality of those reads.
pub const TLS_BIN_SLACK: usize = 1;
/// Particles per rayon task in the velocity update.
const PARTICLES_PER_TASK: usize = 2048;
/// Highest total degree of the fits.
const MAX_DEGREE: usize = 2;

/// The in-plane stress components `(a, c)`, `a <= c`, fitted in `D` dimensions.
fn stress_components<const D: usize>() -> Vec<(usize, usize)> {
    let mut pairs = Vec::new();
    for a in 0..D {
        pairs.push((a, a));
    }
    for a in 0..D {
        for c in a + 1..D {
            pairs.push((a, c));
        }
    }
    pairs
}

/// The Gauss points of one box: per axis the points and weights of the rule mapped onto
/// `[lo_a, hi_a]`.
#[derive(Clone, Copy)]
struct BoxRule<const D: usize> {
    x: [[f64; MAX_POINTS]; D],
    w: [[f64; MAX_POINTS]; D],
    n: usize,
}

impl<const D: usize> BoxRule<D> {
    fn new(rule: &GaussRule, lo: [f64; D], hi: [f64; D]) -> Self {
        let mut out = Self {
            x: [[0.0; MAX_POINTS]; D],
            w: [[0.0; MAX_POINTS]; D],
            n: rule.len,
        };
        for a in 0..D {
            for (g, (x, w)) in rule.mapped(lo[a], hi[a]).enumerate() {
                out.x[a][g] = x;
                out.w[a][g] = w;
            }
        }
        out
    }

    /// `f(x_g, w_g)` for every point, x fastest; `w_g = w_x w_y w_z`.
    #[inline]
    fn for_each(&self, mut f: impl FnMut([f64; D], f64)) {
        let total = self.n.pow(D as u32);
        for g in 0..total {
            let mut rest = g;
            let mut x = [0.0; D];
            let mut w = 1.0;
            for a in 0..D {
                let i = rest % self.n;
                rest /= self.n;
                x[a] = self.x[a][i];
                w *= self.w[a][i];
            }
            f(x, w);
        }
    }
}

/// One active cell's Taylor box, axis indices and Gauss points.
struct GaussCell<const D: usize> {
    taylor: TaylorBox<D>,
    index: [usize; D],
    points: BoxRule<D>,
}

impl<const D: usize> GaussCell<D> {
    /// The cell `cell` of `grid` with box `[lo, hi]` and `rule` mapped onto it.
    #[inline]
    fn new(
        grid: &TensorGrid<D>,
        rule: &GaussRule,
        cell: usize,
        lo: [f64; D],
        hi: [f64; D],
    ) -> Self {
        Self {
            taylor: TaylorBox::new(lo, hi),
            index: cell_axes(grid, cell),
            points: BoxRule::new(rule, lo, hi),
        }
    }
}

/// The TLS mapping of the dimension-generic core.
#[derive(Clone, Debug)]
pub struct TensorTlsMapping<const D: usize> {
    grid: TensorGrid<D>,
    rule: GaussRule,
    totals: CellTotals,
    /// Initial half spacing of the particles (material extent, shares).
    half_length0: [f64; D],
    /// GIMP: the same half spacing for the basis at the particles; `None` for point bases.
    particle_domains: Option<[f64; D]>,
    lo: Vec<[f64; D]>,
    hi: Vec<[f64; D]>,
    active: Vec<bool>,
    /// Per axis, the moments of the Taylor factors against the basis on the boxes of the
    /// last mapping (`moments.rs`).
    moments: [AxisMoments; D],
    /// Conserved totals per cell (mass, or the `D` components of a vector).
    cell_totals: Vec<[f64; 4]>,
    /// The particles of each cell, by index (rebuilt at every mass and force map).
    bins: CellParticles,
    /// Stress coefficients, `stress_components` per cell.
    stress: Vec<[f64; MAX_TERMS]>,
    density: Vec<[f64; MAX_TERMS]>,
    /// Momentum-density (or body-force density) coefficients, `D` per cell.
    vector: Vec<[f64; MAX_TERMS]>,
    mass_force: TensorScatter<4>,
    vector_scatter: TensorScatter<D>,
    remedies: RemedyCounts,
    /// The consistent mass matrix (`method.mass` or `method.acceleration_mass` =
    /// `"consistent"`).
    consistent: Option<StencilAssembly<D>>,
    /// Seconds spent in [`Self::assemble_consistent_mass`] so far.
    assembly_seconds: f64,
    /// This rank's part of a distributed run: only its cells are fitted and integrated,
    /// the material extent is taken over all ranks, and cell totals that a particle's
    /// domain carries across a slab face are completed with the neighbour.
    slab: Option<Arc<dyn SlabCells>>,
    /// Highest total degree of the conservative fits (`method.conservative_degree`).
    conservative_degree: usize,
}

impl<const D: usize> TensorTlsMapping<D> {
    /// TLS on the grid of `basis` with a `gauss_points`-point rule per axis (`None` if no
    /// such rule or fewer than 2 points), particles of initial half spacing
    /// `half_length0`; `particle_domain` for GIMP.
    pub fn new<B: Basis>(
        basis: &TensorBasis<D, B>,
        gauss_points: usize,
        totals: CellTotals,
        half_length0: [f64; D],
        particle_domain: bool,
    ) -> Option<Self> {
        if gauss_points < 2 {
            return None;
        }
        let rule = GaussRule::new(gauss_points)?;
        let cells = basis.grid.num_cells();
        Some(Self {
            grid: basis.grid,
            rule,
            totals,
            half_length0,
            particle_domains: particle_domain.then_some(half_length0),
            lo: vec![[0.0; D]; cells],
            hi: vec![[0.0; D]; cells],
            active: vec![false; cells],
            moments: std::array::from_fn(|_| AxisMoments::default()),
            cell_totals: vec![[0.0; 4]; cells],
            bins: CellParticles::default(),
            stress: vec![[0.0; MAX_TERMS]; cells * stress_components::<D>().len()],
            density: vec![[0.0; MAX_TERMS]; cells],
            vector: vec![[0.0; MAX_TERMS]; cells * D],
            mass_force: TensorScatter::new(basis),
            vector_scatter: TensorScatter::new(basis),
            remedies: RemedyCounts::default(),
            consistent: None,
            assembly_seconds: 0.0,
            slab: None,
            conservative_degree: MAX_DEGREE,
        })
    }

    /// Conservative fits (density, momentum, body force) of total degree at most
    /// `degree` (`method.conservative_degree`; at most 2, the default of [`Self::new`]).
    /// Stress fits stay of degree 2.
    pub fn with_conservative_degree(mut self, degree: usize) -> Self {
        self.conservative_degree = degree.min(MAX_DEGREE);
        self
    }

    /// Also assemble the consistent mass matrix in every
    /// [`TensorMapping::map_mass_and_force`]; `None` if the basis' support is too large
    /// for the stencil assembly.
    pub fn with_consistent_mass<B: Basis>(mut self, basis: &TensorBasis<D, B>) -> Option<Self> {
        let reach = max_len(basis) - 1;
        if (reach + 1).pow(D as u32) > MAX_SUPPORT_NODES {
            return None;
        }
        self.consistent = Some(StencilAssembly::new(basis, reach));
        Some(self)
    }

    /// `M^C = sum_g rho_hat w_g phi phi^T` into the stencil assembly.
    fn assemble_consistent_mass<B: Basis>(&mut self, basis: &TensorBasis<D, B>) {
        let Some(assembly) = self.consistent.as_mut() else {
            return;
        };
        let start = std::time::Instant::now();
        let strides = *basis.strides();
        let (lo, hi, active, density, rule) =
            (&self.lo, &self.hi, &self.active, &self.density, &self.rule);
        let (moments, grid) = (&self.moments, &basis.grid);
        let len = max_len(basis);
        assembly.assemble(|cells, rows| {
            let mut shape = TensorShape::<D>::default();
            // Per task: the scratch of the contractions and the cell block.
            let mut scratch = vec![0.0; moments::scratch_len(len * len)];
            let mut block = vec![0.0; len.pow(2 * D as u32)];
            for cell in cells {
                if !active[cell] {
                    continue;
                }
                if let Some(cell_moments) = CellMoments::new(moments, cell_axes(grid, cell)) {
                    let n = cell_moments.nodes();
                    let block = &mut block[..n * n];
                    cell_moments.contract_mass(&density[cell], &mut scratch, block);
                    let (first, lens) = cell_moments.support();
                    rows.add_block(&first, &lens, &strides, block);
                    continue;
                }
                let GaussCell {
                    taylor,
                    index,
                    points,
                } = GaussCell::new(grid, rule, cell, lo[cell], hi[cell]);
                points.for_each(|x, w| {
                    basis.eval_particle(index, x, [0.0; D], &mut shape);
                    let rw = dot::<D>(&density[cell], &taylor.terms(x)) * w;
                    rows.add_outer(&shape, &strides, rw);
                });
            }
        });
        self.assembly_seconds += start.elapsed().as_secs_f64();
    }

    /// The active box `[lo, hi]` of `cell` in the last mapping (`None` if inactive).
    pub fn active_box(&self, cell: usize) -> Option<([f64; D], [f64; D])> {
        self.active[cell].then(|| (self.lo[cell], self.hi[cell]))
    }

    /// Density coefficients of `cell` in the last mapping.
    pub fn density(&self, cell: usize) -> &[f64; MAX_TERMS] {
        &self.density[cell]
    }

    /// The particle half-lengths `l_a = l0_a |F_aa|` of particle `p`.
    #[inline]
    fn domain(&self, particles: &TensorParticles<D>, p: usize) -> [f64; D] {
        half_lengths(particles, &Some(self.half_length0), p)
    }

    /// Material extent (over all ranks), active boxes (of this rank's cells) and their
    /// moments from the current particles.
    fn update_boxes<B: Basis>(
        &mut self,
        basis: &TensorBasis<D, B>,
        particles: &TensorParticles<D>,
        bins: &CellParticles,
    ) -> Result<()> {
        let n = particles.len();
        let this = &*self;
        let (lo_ext, hi_ext) = (0..n)
            .into_par_iter()
            .with_min_len(4096)
            .fold(
                || ([f64::INFINITY; D], [f64::NEG_INFINITY; D]),
                |(mut lo, mut hi), p| {
                    let l = this.domain(particles, p);
                    for a in 0..D {
                        let x = particles.x[a][p];
                        lo[a] = if x - l[a] < lo[a] { x - l[a] } else { lo[a] };
                        hi[a] = if x + l[a] > hi[a] { x + l[a] } else { hi[a] };
                    }
                    (lo, hi)
                },
            )
            .reduce(
                || ([f64::INFINITY; D], [f64::NEG_INFINITY; D]),
                |a, b| {
                    (
                        std::array::from_fn(|k| a.0[k].min(b.0[k])),
                        std::array::from_fn(|k| a.1[k].max(b.1[k])),
                    )
                },
            );
        let (mut lo_ext, mut hi_ext) = (lo_ext, hi_ext);
        if let Some(slab) = &self.slab {
            let mut extent = [0.0; 6];
            for a in 0..D {
                extent[a] = lo_ext[a];
                extent[3 + a] = -hi_ext[a];
            }
            slab.min_over_ranks(&mut extent)?;
            for a in 0..D {
                lo_ext[a] = extent[a];
                hi_ext[a] = -extent[3 + a];
            }
        }
        for a in 0..D {
            self.moments[a].update(basis, a, &self.rule, lo_ext[a], hi_ext[a]);
        }
        let grid = self.grid;
        let require_particles = self.totals == CellTotals::Centres;
        let slab = self.slab.as_deref();
        (&mut self.lo, &mut self.hi, &mut self.active)
            .into_par_iter()
            .with_min_len(CELLS_PER_TASK)
            .enumerate()
            .for_each(|(cell, (lo, hi, active))| {
                let index = cell_axes(&grid, cell);
                let mut ok = slab.is_none_or(|s| s.owns_cell(cell))
                    && (!require_particles || !bins.is_empty(cell));
                for a in 0..D {
                    let g = &grid.axes[a];
                    let left = g.cell_left(index[a]);
                    let right = left + g.h;
                    lo[a] = if lo_ext[a] > left { lo_ext[a] } else { left };
                    hi[a] = if hi_ext[a] < right { hi_ext[a] } else { right };
                    ok &= hi[a] > lo[a];
                }
                *active = ok;
            });
        Ok(())
    }

    /// `cell_totals[e]` (the first `width` entries) of `quantity(p)`: per particle in its
    /// cell (`"centres"`), or split by domain overlap (`"domains"`).
    fn update_totals(
        &mut self,
        particles: &TensorParticles<D>,
        bins: &CellParticles,
        quantity: impl Fn(usize) -> [f64; 4] + Sync,
    ) -> Result<()> {
        match self.totals {
            CellTotals::Centres => {
                totals::centre_totals(bins, quantity, &mut self.cell_totals);
            }
            CellTotals::Domains => {
                let half0 = Some(self.half_length0);
                totals::domain_totals(
                    &self.grid,
                    particles,
                    bins,
                    |p| half_lengths(particles, &half0, p),
                    quantity,
                    &mut self.cell_totals,
                );
            }
        }
        match &self.slab {
            Some(slab) => slab.add_shared_cells(self.cell_totals.as_flattened_mut(), 4),
            None => Ok(()),
        }
    }

    /// Fit and integrate the vector field `values` into `out`.
    fn map_vector<B: Basis>(
        &mut self,
        basis: &TensorBasis<D, B>,
        particles: &TensorParticles<D>,
        values: &[Vec<f64>; D],
        out: &mut [[f64; D]],
    ) -> Result<()> {
        let bins = self.current_bins(particles);
        let fitted = self.fit_vector(particles, &bins, values);
        self.bins = bins;
        fitted?;
        with_fixed_support!(basis, N => self.integrate_vector::<B, N>(basis, out));
        Ok(())
    }

    /// [`TensorMapping::map_mass_and_force`] with the particles of each cell in `bins`.
    fn map_mass_and_force_in_bins<B: Basis>(
        &mut self,
        basis: &TensorBasis<D, B>,
        particles: &TensorParticles<D>,
        bins: &CellParticles,
        body: TensorBody<'_, D>,
        fields: &mut TensorGridFields<D>,
    ) -> Result<()> {
        self.update_boxes(basis, particles, bins)?;
        let per_particle = match body {
            TensorBody::PerParticle(b) => Some(b),
            TensorBody::Uniform(_) => None,
        };
        self.update_totals(particles, bins, |p| {
            let mut q = [particles.mass[p], 0.0, 0.0, 0.0];
            if let Some(b) = per_particle {
                for a in 0..D {
                    q[1 + a] = particles.mass[p] * b[a][p];
                }
            }
            q
        })?;
        // The body force int (rho b)_hat phi is mapped like a momentum, with the fits of
        // the same pass.
        self.fit_stress_and_density(particles, bins, per_particle);
        let mut mass_force = std::mem::take(&mut fields.mass_force);
        let with_body = per_particle.is_some();
        with_fixed_support!(basis, N => {
            self.integrate_mass_and_force::<B, N>(basis, &mut mass_force, with_body)
        });
        for ((m, f), mf) in fields
            .mass
            .iter_mut()
            .zip(fields.force.iter_mut())
            .zip(&mass_force)
        {
            *m = mf[0];
            f.copy_from_slice(&mf[1..=D]);
        }
        fields.mass_force = mass_force;
        self.assemble_consistent_mass(basis);
        if let TensorBody::Uniform(b) = body {
            if b.iter().any(|&b| b != 0.0) {
                for (f, &m) in fields.force.iter_mut().zip(&fields.mass) {
                    for a in 0..D {
                        f[a] += b[a] * m;
                    }
                }
            }
        }
        Ok(())
    }

    /// The bins of the particles' current cells, taken out of `self` (rebuilt unless the
    /// particles have not moved since the last build); put them back after use.
    fn current_bins(&mut self, particles: &TensorParticles<D>) -> CellParticles {
        let mut bins = std::mem::take(&mut self.bins);
        if !bins.fresh {
            bins.rebuild(self.grid.num_cells(), &particles.cell);
        }
        bins
    }
}

impl<const D: usize> TensorMapping<D> for TensorTlsMapping<D> {
    fn name(&self) -> &'static str {
        "tls"
    }

    fn particle_domains(&self) -> &Option<[f64; D]> {
        &self.particle_domains
    }

    fn map_mass_and_force<B: Basis>(
        &mut self,
        basis: &TensorBasis<D, B>,
        particles: &TensorParticles<D>,
        _cell_start: &[usize],
        body: TensorBody<'_, D>,
        fields: &mut TensorGridFields<D>,
    ) -> Result<()> {
        // Rebuilt at every mass and force map, whatever `fresh` says: the stepper may have
        // re-sorted or exchanged the particles since the last map.
        self.bins.fresh = false;
        let bins = self.current_bins(particles);
        let mapped = self.map_mass_and_force_in_bins(basis, particles, &bins, body, fields);
        self.bins = bins;
        mapped
    }

    fn map_momentum<B: Basis>(
        &mut self,
        basis: &TensorBasis<D, B>,
        particles: &TensorParticles<D>,
        _cell_start: &[usize],
        fields: &mut TensorGridFields<D>,
    ) -> Result<()> {
        self.map_vector(basis, particles, &particles.v, &mut fields.momentum)
    }

    fn update_velocities_and_map_momentum<B: Basis>(
        &mut self,
        basis: &TensorBasis<D, B>,
        particles: &mut TensorParticles<D>,
        cell_start: &[usize],
        dt: f64,
        fields: &mut TensorGridFields<D>,
    ) -> Result<[f64; 4]> {
        let sums = with_fixed_support!(basis, N => update_velocities::<D, B, N>(
            basis,
            &self.particle_domains,
            particles,
            dt,
            &fields.acceleration,
        ));
        self.map_momentum(basis, particles, cell_start, fields)?;
        Ok(sums)
    }

    fn distribute(&mut self, slab: Arc<dyn SlabCells>) -> Result<()> {
        self.slab = Some(slab);
        Ok(())
    }

    fn bin_slack(&self) -> usize {
        TLS_BIN_SLACK
    }

    fn forget_shapes(&mut self) {
        self.bins.fresh = false;
    }

    fn remedies(&self) -> RemedyCounts {
        self.remedies
    }

    fn consistent_mass(&self) -> Option<&CsrMatrix> {
        self.consistent.as_ref().map(|a| &a.matrix)
    }

    fn assembly_seconds(&self) -> f64 {
        self.assembly_seconds
    }
}

/// `v_p += dt sum_I phi_I(x_p) a_I` for every particle, in parallel over fixed chunks;
/// returns `sum_p m_p v_p` and `sum_p m_p |v_p|` of the updated velocities (per chunk, then
/// in chunk order).
fn update_velocities<const D: usize, B: Basis, const N: usize>(
    basis: &TensorBasis<D, B>,
    domains: &Option<[f64; D]>,
    particles: &mut TensorParticles<D>,
    dt: f64,
    acceleration: &[[f64; D]],
) -> [f64; 4] {
    let n = particles.len();
    let strides = *basis.strides();
    let ranges: Vec<Range<usize>> = (0..n)
        .step_by(PARTICLES_PER_TASK)
        .map(|s| s..(s + PARTICLES_PER_TASK).min(n))
        .collect();
    let TensorParticles {
        x,
        v,
        mass,
        deformation_gradient,
        ..
    } = particles;
    let (x, mass, f) = (&*x, &*mass, &*deformation_gradient);
    let sums: Vec<[f64; 4]> = split_components(v, &ranges)
        .into_par_iter()
        .zip(ranges.par_iter())
        .map(|(v, range)| {
            let mut shape = TensorShape::<D>::default();
            let mut sum = [0.0; 4];
            for k in range.clone() {
                let position: [f64; D] = std::array::from_fn(|a| x[a][k]);
                let half = match domains {
                    Some(l0) => std::array::from_fn(|a| l0[a] * f[a][a][k].abs()),
                    None => [0.0; D],
                };
                basis.eval_particle(basis.grid.axis_cells(position), position, half, &mut shape);
                let dv = shape.interpolate_n::<N>(&strides, acceleration);
                let mut speed2 = 0.0;
                for a in 0..D {
                    let velocity = &mut v[a][k - range.start];
                    *velocity += dt * dv[a];
                    sum[a] += mass[k] * *velocity;
                    speed2 += *velocity * *velocity;
                }
                sum[3] += mass[k] * speed2.sqrt();
            }
            sum
        })
        .collect();
    let mut total = [0.0; 4];
    for s in &sums {
        for (t, s) in total.iter_mut().zip(s) {
            *t += s;
        }
    }
    total
}

mod bins;
mod cells;
mod fits;
mod integrate;
mod moments;
mod totals;
use bins::CellParticles;
use cells::{cell_axes, dot, max_len};
use moments::{AxisMoments, CellMoments};

#[cfg(test)]
mod consistent_tests;
#[cfg(test)]
mod tests;
