//! The p-multigrid hierarchy (SPEC §5, §5.2): level operators `A_l` and the transfers
//! between B-spline orders on the same knot spans, finest level first (level `l` has order
//! `p - l`, the last level order 1).
//!
//! Transfers from order `q` (level `l`) to order `q - 1` (level `l + 1`), with the mixed mass
//! `P = int phi^q (phi^{q-1})^T` and the row-sum lumped masses `M^L_q = diag(sum_j (M_q)_ij)`:
//!
//! ```text
//! prolongation   I_l = (M^L_q)^-1 P                        (L2 projection, lumped)
//! restriction    R_l = (M^L_{q-1})^-1 P^T                  TransferKind::Published (G+Smo, Tielen)
//!                R_l = I_l^T                               TransferKind::Symmetric
//! ```
//!
//! Level operators ([`CoarseOperators`]):
//! * `Rediscretised`: `A_l` = the mass matrix of order `p - l` (SPEC §5.2, as published);
//! * `Galerkin`: `A_{l+1} = I_l^T A_l I_l`, recomputed from the fine matrix handed to every
//!   solve (the MPM stepper's matrix keeps its pattern but changes its values). Fine DOFs
//!   decoupled in `A_l` (all off-diagonal entries exactly 0: identity rows of DOFs
//!   eliminated by [`CsrMatrix::constrain`]) get zero rows in the prolongation. A coarse DOF
//!   is eliminated too (zero column of `I_l`, identity row of `A_{l+1}`) when no kept fine
//!   DOF reaches it, or when one of its *parents* is eliminated: the fine functions whose
//!   support contains its support (in 1D, fine `j` and `j + 1` for coarse `j`; tensor
//!   products in 2D). The first rule alone leaves `I_l` rank-deficient whenever fewer fine
//!   than coarse DOFs survive locally (first two and last fine DOFs of an order-2 space
//!   eliminated: 11 fine rows for 13 coarse columns, `A_1` singular); with the parent rule
//!   every kept coarse DOF `j` has its own kept fine DOF `j`, and in 1D the masked
//!   prolongation has full column rank, so `A_{l+1}` is SPD. The masked entries are kept
//!   as explicit zeros: the sparsity patterns never change, and a solve with a matrix of
//!   the same pattern recomputes the values without allocating.
//!
//!   SPD in exact arithmetic is not enough: the L2 prolongation maps the coarse zigzag
//!   mode (alternating signs, orthogonal to every fine B-spline of one order higher in the
//!   interior) to almost zero, so `I^T A I` is nearly singular, more so on every further
//!   Galerkin level (p >= 4 in 2D: Cholesky pivots of -1e-11 from round-off). The coarse
//!   operators are therefore `A_{l+1} = I^T A I + 1e-8 diag(I^T A I)`: the shift only
//!   matters for coarse vectors `v` with `||I v||_A < 1e-4 ||v||_D` (`D` the diagonal),
//!   which the coarse correction could not use anyway.
//!
//! Spline set-ups ([`Hierarchy::spline_1d`], [`Hierarchy::spline_2d`]) use unit density
//! (SPEC §5.1). Eliminated DOFs are dropped with [`CsrMatrix::submatrix`] from the full
//! matrices of every order; the lumped masses are the row sums of the *full* mass matrices
//! (`int phi_i`, partition of unity), restricted to the kept DOFs, so `I_l` maps the
//! constant to the constant away from the boundary. In 2D every piece is the Kronecker
//! product of the 1D ones (`P = P_y (x) P_x`, `M^L = M^L_y (x) M^L_x`, DOF
//! `i = i_y n_x + i_x`) before the restriction.

use super::galerkin::{transpose_with_positions, GalerkinProducts, GalerkinStencil};
use crate::error::{Error, Result};
use crate::linalg::assembly::{mass_1d, mixed_mass_1d, SplineSpace};
use crate::linalg::CsrMatrix;

/// How the restriction is built from the prolongation's pieces.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransferKind {
    /// `R = (M^L_{q-1})^-1 P^T` (SPEC §5.2, G+Smo): not the transpose of the prolongation.
    Published,
    /// `R = I^T`: a symmetric V-cycle (preconditioner) and Galerkin coarse operators.
    Symmetric,
}

/// Where the coarse level operators come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CoarseOperators {
    /// Given: re-discretised mass matrices of the lower orders.
    Rediscretised,
    /// `A_{l+1} = I_l^T A_l I_l`, recomputed from the fine matrix of every solve.
    Galerkin,
}

/// Level operators and transfers of a p-multigrid V-cycle, finest level first.
#[derive(Clone, Debug)]
pub struct Hierarchy {
    coarse_operators: CoarseOperators,
    transfers: TransferKind,
    sizes: Vec<usize>,
    /// The re-discretised finest operator, when known.
    fine: Option<CsrMatrix>,
    /// `A_1, ..., A_{L-1}`.
    coarse: Vec<CsrMatrix>,
    /// `I_l`: level `l + 1` -> level `l` (masked in Galerkin mode).
    prolongations: Vec<CsrMatrix>,
    /// `R_l`: level `l` -> level `l + 1`.
    restrictions: Vec<CsrMatrix>,
    galerkin: Option<GalerkinProducts>,
}

pub(super) fn failure(reason: String) -> Error {
    Error::Solver {
        solver: "pmg".into(),
        reason,
    }
}

impl Hierarchy {
    /// Re-discretised levels: `operators[l]` is `A_l` (finest first), `prolongations[l]`
    /// maps level `l + 1` to level `l`, `restrictions[l]` level `l` to level `l + 1`;
    /// `None` takes `R_l = I_l^T` (symmetric), explicit restrictions count as
    /// [`TransferKind::Published`]. The finest operator is only kept for reference: every
    /// solve uses the matrix it is given on level 0.
    pub fn rediscretised(
        operators: Vec<CsrMatrix>,
        prolongations: Vec<CsrMatrix>,
        restrictions: Option<Vec<CsrMatrix>>,
    ) -> Result<Self> {
        if operators.is_empty() {
            return Err(failure("a hierarchy needs at least one level".into()));
        }
        let sizes: Vec<usize> = operators.iter().map(|a| a.rows).collect();
        for (l, a) in operators.iter().enumerate() {
            if a.cols != a.rows {
                return Err(failure(format!(
                    "level {l} operator is {}x{}, not square",
                    a.rows, a.cols
                )));
            }
        }
        let (transfers, restrictions) = match restrictions {
            Some(r) => (TransferKind::Published, r),
            None => (
                TransferKind::Symmetric,
                prolongations.iter().map(CsrMatrix::transpose).collect(),
            ),
        };
        check_transfers(&sizes, &prolongations, &restrictions)?;
        let mut operators = operators;
        let coarse = operators.split_off(1);
        Ok(Self {
            coarse_operators: CoarseOperators::Rediscretised,
            transfers,
            sizes,
            fine: operators.pop(),
            coarse,
            prolongations,
            restrictions,
            galerkin: None,
        })
    }

    /// Galerkin levels from the prolongations (`prolongations[l]`: level `l + 1` -> level
    /// `l`, `R_l = I_l^T`); the operators are computed from the fine matrix of each solve.
    /// `parents[l]` (rows: level `l + 1` DOFs, columns: level `l` DOFs), if given, marks
    /// the fine DOFs whose elimination eliminates a coarse DOF (see the module doc); without
    /// it only coarse DOFs that no kept fine DOF reaches are eliminated, and a coarse
    /// operator may be singular (fine for the CG coarse solve, not for Cholesky).
    pub fn galerkin(
        prolongations: Vec<CsrMatrix>,
        parents: Option<Vec<CsrMatrix>>,
    ) -> Result<Self> {
        let mut sizes = Vec::with_capacity(prolongations.len() + 1);
        match prolongations.first() {
            Some(i) => sizes.push(i.rows),
            None => {
                return Err(failure(
                    "a Galerkin hierarchy needs at least one prolongation (use \
                     Hierarchy::single_level for one level)"
                        .into(),
                ))
            }
        }
        sizes.extend(prolongations.iter().map(|i| i.cols));
        let parents = match parents {
            Some(p) => p.into_iter().map(Some).collect(),
            None => vec![None; prolongations.len()],
        };
        Self::galerkin_with_sizes(sizes, prolongations, parents, None)
    }

    /// A single Galerkin level of `size` DOFs (order 1: the V-cycle is the coarse solve).
    pub fn single_level(size: usize) -> Self {
        Self {
            coarse_operators: CoarseOperators::Galerkin,
            transfers: TransferKind::Symmetric,
            sizes: vec![size],
            fine: None,
            coarse: Vec::new(),
            prolongations: Vec::new(),
            restrictions: Vec::new(),
            galerkin: None,
        }
    }

    fn galerkin_with_sizes(
        sizes: Vec<usize>,
        prolongations: Vec<CsrMatrix>,
        parents: Vec<Option<CsrMatrix>>,
        stencils: Option<Vec<CsrMatrix>>,
    ) -> Result<Self> {
        let mut transpose_position = Vec::with_capacity(prolongations.len());
        let mut restrictions = Vec::with_capacity(prolongations.len());
        for i in &prolongations {
            let (r, position) = transpose_with_positions(i);
            restrictions.push(r);
            transpose_position.push(position);
        }
        check_transfers(&sizes, &prolongations, &restrictions)?;
        for (l, p) in parents.iter().enumerate() {
            if let Some(p) = p
                .as_ref()
                .filter(|p| (p.rows, p.cols) != (sizes[l + 1], sizes[l]))
            {
                return Err(failure(format!(
                    "level {l}: parents are {}x{}, the levels have {} and {} DOFs",
                    p.rows,
                    p.cols,
                    sizes[l + 1],
                    sizes[l]
                )));
            }
        }
        Ok(Self {
            coarse_operators: CoarseOperators::Galerkin,
            transfers: TransferKind::Symmetric,
            coarse: sizes[1..].iter().map(|&n| CsrMatrix::identity(n)).collect(),
            sizes,
            fine: None,
            restrictions,
            galerkin: Some(GalerkinProducts::new(
                prolongations.clone(),
                parents,
                stencils,
                transpose_position,
            )?),
            prolongations,
        })
    }

    /// The SPEC §5.1 set-up in 1D: unit-density B-splines of orders `space.order, ..., 1`
    /// on the spans of `space`, the DOFs with `keep(n)[i]` kept at every order (`n` = the
    /// order's number of functions; [`crate::linalg::assembly::interior`] drops the first
    /// and last, `|n| vec![true; n]` keeps all), re-discretised operators.
    pub fn spline_1d(
        space: &SplineSpace,
        keep: impl Fn(usize) -> Vec<bool>,
        transfers: TransferKind,
    ) -> Result<Self> {
        let levels = SplineLevels::one_dimensional(space);
        let keeps: Vec<Vec<bool>> = levels.functions.iter().map(|&n| keep(n)).collect();
        levels.hierarchy(&keeps, transfers)
    }

    /// The SPEC §5.1 set-up in 2D: tensor products of `x` and `y` (equal orders), DOF
    /// `i = i_y n_x + i_x`, kept where `keep(n_x)[i_x] && keep(n_y)[i_y]`, re-discretised
    /// operators `M_y (x) M_x` restricted to the kept DOFs.
    pub fn spline_2d(
        x: &SplineSpace,
        y: &SplineSpace,
        keep: impl Fn(usize) -> Vec<bool>,
        transfers: TransferKind,
    ) -> Result<Self> {
        let levels = SplineLevels::two_dimensional(x, y)?;
        let keeps = levels.tensor_keeps(x, y, keep);
        levels.hierarchy(&keeps, transfers)
    }

    /// Galerkin hierarchy over all DOFs of `space` (orders `space.order, ..., 1`), for a fine
    /// matrix assembled on `space` with any density and constraints; an order-1 (or 0)
    /// space gives a single level.
    pub fn galerkin_1d(space: &SplineSpace) -> Result<Self> {
        Self::galerkin_spline_1d(space, |n| vec![true; n], GalerkinStencil::Exact)
    }

    /// Galerkin hierarchy over all DOFs of the tensor product of `x` and `y`.
    pub fn galerkin_2d(x: &SplineSpace, y: &SplineSpace, stencil: GalerkinStencil) -> Result<Self> {
        Self::galerkin_spline_2d(x, y, |n| vec![true; n], stencil)
    }

    /// Galerkin hierarchy over the DOFs with `keep(n)[i]` of every order (as in
    /// [`Hierarchy::spline_1d`]), for a fine matrix of any density on those DOFs, with
    /// coarse operators of `stencil` (see `galerkin.rs`).
    pub fn galerkin_spline_1d(
        space: &SplineSpace,
        keep: impl Fn(usize) -> Vec<bool>,
        stencil: GalerkinStencil,
    ) -> Result<Self> {
        let levels = SplineLevels::one_dimensional(space);
        let keeps: Vec<Vec<bool>> = levels.functions.iter().map(|&n| keep(n)).collect();
        levels.galerkin(&keeps, stencil)
    }

    /// Galerkin hierarchy over the tensor-product DOFs kept by `keep` (as in
    /// [`Hierarchy::spline_2d`]).
    pub fn galerkin_spline_2d(
        x: &SplineSpace,
        y: &SplineSpace,
        keep: impl Fn(usize) -> Vec<bool>,
        stencil: GalerkinStencil,
    ) -> Result<Self> {
        let levels = SplineLevels::two_dimensional(x, y)?;
        let keeps = levels.tensor_keeps(x, y, keep);
        levels.galerkin(&keeps, stencil)
    }

    /// Number of levels.
    pub fn levels(&self) -> usize {
        self.sizes.len()
    }

    /// Number of DOFs of every level, finest first.
    pub fn sizes(&self) -> &[usize] {
        &self.sizes
    }

    pub fn transfers(&self) -> TransferKind {
        self.transfers
    }

    pub fn coarse_operators(&self) -> CoarseOperators {
        self.coarse_operators
    }

    /// The re-discretised finest operator (`None` in Galerkin mode).
    pub fn fine_operator(&self) -> Option<&CsrMatrix> {
        self.fine.as_ref()
    }

    /// `A_l` for a coarse level `l >= 1` (Galerkin: as of the last solve).
    pub fn coarse_operator(&self, level: usize) -> Option<&CsrMatrix> {
        level.checked_sub(1).and_then(|l| self.coarse.get(l))
    }

    /// `I_l`: level `l + 1` -> level `l`.
    pub fn prolongation(&self, level: usize) -> Option<&CsrMatrix> {
        self.prolongations.get(level)
    }

    /// `R_l`: level `l` -> level `l + 1`.
    pub fn restriction(&self, level: usize) -> Option<&CsrMatrix> {
        self.restrictions.get(level)
    }

    /// Galerkin mode: mask the transfers and recompute `A_1, ...` from the fine matrix `a`
    /// (`a` must have `sizes()[0]` rows; checked by the caller). No-op when re-discretised.
    pub(crate) fn update(&mut self, a: &CsrMatrix) -> Result<()> {
        let Some(g) = self.galerkin.as_mut() else {
            return Ok(());
        };
        g.update(
            a,
            &mut self.coarse,
            &mut self.prolongations,
            &mut self.restrictions,
        )
    }
}

fn check_transfers(
    sizes: &[usize],
    prolongations: &[CsrMatrix],
    restrictions: &[CsrMatrix],
) -> Result<()> {
    if prolongations.len() + 1 != sizes.len() || restrictions.len() + 1 != sizes.len() {
        return Err(failure(format!(
            "{} levels need {} prolongations and restrictions, got {} and {}",
            sizes.len(),
            sizes.len() - 1,
            prolongations.len(),
            restrictions.len()
        )));
    }
    for l in 0..prolongations.len() {
        let (i, r) = (&prolongations[l], &restrictions[l]);
        let (fine, coarse) = (sizes[l], sizes[l + 1]);
        if (i.rows, i.cols) != (fine, coarse) || (r.rows, r.cols) != (coarse, fine) {
            return Err(failure(format!(
                "level {l}: prolongation {}x{} and restriction {}x{} do not match levels of \
                 {fine} and {coarse} DOFs",
                i.rows, i.cols, r.rows, r.cols
            )));
        }
    }
    Ok(())
}

/// Full (unrestricted) unit-density matrices of the orders `p, p-1, ..., 1`.
struct SplineLevels {
    /// Number of functions of every order.
    functions: Vec<usize>,
    masses: Vec<CsrMatrix>,
    /// `mixed[l]`: order of level `l` x order of level `l + 1`.
    mixed: Vec<CsrMatrix>,
    /// `parents[l]`: level `l + 1` x level `l`, coarse `j` -> fine `j, j + 1` (1D).
    parents: Vec<CsrMatrix>,
}

impl SplineLevels {
    fn orders(top: usize) -> impl Iterator<Item = usize> {
        (top.min(1)..=top).rev()
    }

    fn one_dimensional(space: &SplineSpace) -> Self {
        let spaces: Vec<SplineSpace> = Self::orders(space.order)
            .map(|q| space.with_order(q))
            .collect();
        Self {
            functions: spaces.iter().map(SplineSpace::functions).collect(),
            masses: spaces
                .iter()
                .map(|s| mass_1d(s, s.order + 1, |_| 1.0))
                .collect(),
            mixed: spaces
                .windows(2)
                .map(|w| mixed_mass_1d(&w[0], &w[1]))
                .collect(),
            parents: spaces
                .windows(2)
                .map(|w| {
                    let (fine, coarse) = (w[0].functions(), w[1].functions());
                    let pairs: Vec<(usize, usize, f64)> = (0..coarse)
                        .flat_map(|j| [(j, j, 1.0), (j, j + 1, 1.0)])
                        .collect();
                    CsrMatrix::from_triplets(coarse, fine, &pairs)
                })
                .collect(),
        }
    }

    fn two_dimensional(x: &SplineSpace, y: &SplineSpace) -> Result<Self> {
        if x.order != y.order {
            return Err(failure(format!(
                "the 2D spline hierarchy needs equal orders, got {} in x and {} in y",
                x.order, y.order
            )));
        }
        let (lx, ly) = (Self::one_dimensional(x), Self::one_dimensional(y));
        Ok(Self {
            functions: lx
                .functions
                .iter()
                .zip(&ly.functions)
                .map(|(a, b)| a * b)
                .collect(),
            masses: ly
                .masses
                .iter()
                .zip(&lx.masses)
                .map(|(my, mx)| my.kron(mx))
                .collect(),
            mixed: ly
                .mixed
                .iter()
                .zip(&lx.mixed)
                .map(|(py, px)| py.kron(px))
                .collect(),
            parents: ly
                .parents
                .iter()
                .zip(&lx.parents)
                .map(|(py, px)| py.kron(px))
                .collect(),
        })
    }

    /// `keep` per level of the tensor product: `keep(n_x)[i_x] && keep(n_y)[i_y]`.
    fn tensor_keeps(
        &self,
        x: &SplineSpace,
        y: &SplineSpace,
        keep: impl Fn(usize) -> Vec<bool>,
    ) -> Vec<Vec<bool>> {
        Self::orders(x.order)
            .map(|q| {
                let kx = keep(x.with_order(q).functions());
                let ky = keep(y.with_order(q).functions());
                ky.iter()
                    .flat_map(|&a| kx.iter().map(move |&b| a && b))
                    .collect()
            })
            .collect()
    }

    fn check_keeps(&self, keeps: &[Vec<bool>]) -> Result<()> {
        for (l, (keep, &n)) in keeps.iter().zip(&self.functions).enumerate() {
            if keep.len() != n {
                return Err(failure(format!(
                    "level {l}: keep has {} entries for {n} functions",
                    keep.len()
                )));
            }
            if !keep.iter().any(|&k| k) {
                return Err(failure(format!("level {l}: no DOF is kept")));
            }
        }
        Ok(())
    }

    /// Restricted row-sum lumped mass of level `l`.
    fn lumped(&self, l: usize, keep: &[bool]) -> Result<Vec<f64>> {
        let lumped: Vec<f64> = self.masses[l]
            .row_sums()
            .into_iter()
            .zip(keep)
            .filter_map(|(m, &k)| k.then_some(m))
            .collect();
        if let Some(m) = lumped.iter().find(|m| !(**m > 0.0 && m.is_finite())) {
            return Err(failure(format!(
                "level {l}: lumped mass {m:e} is not positive"
            )));
        }
        Ok(lumped)
    }

    /// `I_l = (M^L_l)^-1 P_l` restricted to the kept DOFs, for every level pair.
    fn prolongations(&self, keeps: &[Vec<bool>]) -> Result<Vec<CsrMatrix>> {
        (0..self.mixed.len())
            .map(|l| {
                let mut i = self.mixed[l].submatrix(&keeps[l], &keeps[l + 1]);
                let inverse: Vec<f64> =
                    self.lumped(l, &keeps[l])?.iter().map(|m| 1.0 / m).collect();
                i.scale_rows(&inverse);
                Ok(i)
            })
            .collect()
    }

    fn hierarchy(&self, keeps: &[Vec<bool>], transfers: TransferKind) -> Result<Hierarchy> {
        self.check_keeps(keeps)?;
        let operators = self
            .masses
            .iter()
            .zip(keeps)
            .map(|(m, k)| m.submatrix(k, k))
            .collect();
        let prolongations = self.prolongations(keeps)?;
        let restrictions = match transfers {
            TransferKind::Symmetric => None,
            TransferKind::Published => Some(
                (0..self.mixed.len())
                    .map(|l| {
                        let mut r = self.mixed[l]
                            .submatrix(&keeps[l], &keeps[l + 1])
                            .transpose();
                        let inverse: Vec<f64> = self
                            .lumped(l + 1, &keeps[l + 1])?
                            .iter()
                            .map(|m| 1.0 / m)
                            .collect();
                        r.scale_rows(&inverse);
                        Ok(r)
                    })
                    .collect::<Result<Vec<_>>>()?,
            ),
        };
        Hierarchy::rediscretised(operators, prolongations, restrictions)
    }

    fn galerkin(&self, keeps: &[Vec<bool>], stencil: GalerkinStencil) -> Result<Hierarchy> {
        self.check_keeps(keeps)?;
        if self.mixed.is_empty() {
            return Ok(Hierarchy::single_level(
                keeps[0].iter().filter(|&&k| k).count(),
            ));
        }
        let sizes = keeps
            .iter()
            .map(|k| k.iter().filter(|&&k| k).count())
            .collect();
        let parents = (0..self.parents.len())
            .map(|l| Some(self.parents[l].submatrix(&keeps[l + 1], &keeps[l])))
            .collect();
        // The pattern of every coarse level's own (restricted) mass matrix.
        let stencils = (stencil == GalerkinStencil::Native).then(|| {
            (1..keeps.len())
                .map(|l| self.masses[l].submatrix(&keeps[l], &keeps[l]))
                .collect()
        });
        Hierarchy::galerkin_with_sizes(sizes, self.prolongations(keeps)?, parents, stencils)
    }
}
