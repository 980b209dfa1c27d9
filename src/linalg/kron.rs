//! Kronecker-product mass matrices and the scaled Kronecker preconditioner (SPEC §5.3).
//!
//! A constant-density tensor-product mass matrix is exactly `K = M_y (x) M_x` (DOF
//! `i = i_y n_x + i_x`), so its inverse is `M_y^{-1} (x) M_x^{-1}`: banded line solves in
//! `x` on every row, then in `y` on every column, `O(N p)` per application after two 1D
//! banded Cholesky factorisations ([`KroneckerFactors`]). One direction gives the 1D case;
//! three give `M_z (x) M_y (x) M_x` (DOF `i = (i_z n_y + i_y) n_x + i_x`) and a third sweep
//! of line solves in `z`.
//!
//! For a variable density (the MPM case) `K` still captures the B-spline coupling and only
//! misses the density. The diagonally scaled preconditioner of Loli, Sangalli & Tani (2020),
//!
//! ```text
//! P = D^{1/2} K D^{1/2},   D = diag(A) / diag(K),   P^{-1} r = D^{-1/2} K^{-1} D^{-1/2} r,
//! ```
//!
//! makes the PCG iteration count depend on the density contrast only, not on `p` or `h`
//! ([`KroneckerPreconditioner`]; `solver.kind = "kron"`). DOFs that are decoupled in `A`
//! (identity rows of eliminated Dirichlet or inactive DOFs, see [`CsrMatrix::constrain`])
//! are left out of the Kronecker solve and get `z_i = r_i / A_ii`, so `P` stays symmetric
//! positive definite on the remaining DOFs.

use super::cg::Preconditioner;
use super::vectors::update_each;
use super::{BandedCholesky, CsrMatrix};
use crate::error::{Error, Result};
use rayon::prelude::*;

/// Lines shorter than this are solved serially (the rayon split would cost more).
const PARALLEL_MIN_DOFS: usize = 16_384;

/// Rows per rayon task of the preconditioner set-up.
const SETUP_BLOCK: usize = 4096;

/// The factorised 1D matrices of a Kronecker product, fastest index first.
#[derive(Clone, Debug)]
pub struct KroneckerFactors {
    /// Size of each direction (`[n_x]`, `[n_x, n_y]` or `[n_x, n_y, n_z]`).
    dims: Vec<usize>,
    factors: Vec<BandedCholesky>,
    /// `diag(K)`.
    diagonal: Vec<f64>,
    line_work: Vec<f64>,
    transposed: Vec<f64>,
}

impl KroneckerFactors {
    /// Factor `matrices[0]` (acting on the fast index `x`) and, in 2D / 3D, `matrices[1]`
    /// (`y`) and `matrices[2]` (`z`); the product is `K = M_y (x) M_x` or
    /// `M_z (x) M_y (x) M_x`. Each must be square, banded and positive definite.
    pub fn new(matrices: &[CsrMatrix]) -> Result<Self> {
        if matrices.is_empty() || matrices.len() > 3 {
            return Err(failure(format!(
                "{} directions given; 1, 2 or 3 are supported",
                matrices.len()
            )));
        }
        let mut factors = Vec::with_capacity(matrices.len());
        for m in matrices {
            let mut factor = BandedCholesky::new();
            factor.factor(m)?;
            factors.push(factor);
        }
        let dims: Vec<usize> = matrices.iter().map(|m| m.rows).collect();
        // diag(K)_i = (d_z[i_z] d_y[i_y]) d_x[i_x], slowest direction first.
        let mut diagonal = vec![1.0];
        for m in matrices.iter().rev() {
            let d = m.diagonal();
            diagonal = diagonal
                .iter()
                .flat_map(|&outer| d.iter().map(move |&inner| outer * inner))
                .collect();
        }
        Ok(Self {
            dims,
            factors,
            diagonal,
            line_work: Vec::new(),
            transposed: Vec::new(),
        })
    }

    /// Number of DOFs, `n_x n_y n_z`.
    pub fn len(&self) -> usize {
        self.dims.iter().product()
    }

    /// Whether there are no DOFs.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// `diag(K)`.
    pub fn diagonal(&self) -> &[f64] {
        &self.diagonal
    }

    /// `z = K^{-1} r` by line solves, one direction after the other (in parallel over
    /// lines for large systems; each line is solved alone, so the result does not depend
    /// on the thread count). Direction `d > 0`: every slab of the directions above `d` is
    /// an `n_d x (n_0 ... n_{d-1})` array, transposed so that its lines are contiguous.
    pub fn solve(&mut self, r: &[f64], z: &mut [f64]) {
        solve_lines(&self.factors[0], self.dims[0], r, z);
        let total = self.len();
        for d in 1..self.dims.len() {
            let inner: usize = self.dims[..d].iter().product();
            let n = self.dims[d];
            self.line_work.resize(total, 0.0);
            self.transposed.resize(total, 0.0);
            transpose_slabs(z, inner, n, &mut self.line_work);
            solve_lines(&self.factors[d], n, &self.line_work, &mut self.transposed);
            transpose_slabs(&self.transposed, n, inner, z);
        }
    }
}

/// Lines solved together by [`BandedCholesky::solve_factored_lines`].
const LANES: usize = 4;

/// Solve `M x = b` on every contiguous line of length `n`, `LANES` lines at a time (each
/// line bitwise its own solve, so the result depends neither on the grouping nor on the
/// thread count).
fn solve_lines(factor: &BandedCholesky, n: usize, b: &[f64], x: &mut [f64]) {
    let group = LANES * n;
    let solve_group = |(x_group, b_group): (&mut [f64], &[f64])| {
        if x_group.len() == group {
            factor.solve_factored_lines::<LANES>(b_group, x_group);
        } else {
            for (xl, bl) in x_group.chunks_mut(n).zip(b_group.chunks(n)) {
                factor.solve_factored(bl, xl);
            }
        }
    };
    if b.len() >= PARALLEL_MIN_DOFS {
        x.par_chunks_mut(group)
            .zip(b.par_chunks(group))
            .for_each(solve_group);
    } else {
        x.chunks_mut(group)
            .zip(b.chunks(group))
            .for_each(solve_group);
    }
}

/// [`transpose`] of every slab of `rows x cols` entries of `a` into `out`: over the rayon
/// pool for long vectors, by slabs when there are several, by [`TRANSPOSE_TILE`] output
/// lines within the one slab otherwise (a copy: the same result for any split).
fn transpose_slabs(a: &[f64], cols: usize, rows: usize, out: &mut [f64]) {
    let slab = rows * cols;
    let (a, out) = (&a[..out.len()], &mut out[..]);
    if a.len() < PARALLEL_MIN_DOFS {
        for (a, out) in a.chunks(slab).zip(out.chunks_mut(slab)) {
            transpose(a, cols, rows, out, 0);
        }
    } else if a.len() > slab {
        a.par_chunks(slab)
            .zip(out.par_chunks_mut(slab))
            .for_each(|(a, out)| transpose(a, cols, rows, out, 0));
    } else {
        out.par_chunks_mut(TRANSPOSE_TILE * rows)
            .enumerate()
            .for_each(|(tile, out)| transpose(a, cols, rows, out, tile * TRANSPOSE_TILE));
    }
}

/// Output lines (columns of the input) per task of a parallel transpose.
const TRANSPOSE_TILE: usize = 32;

/// `out[(j - first) * rows + i] = a[i * cols + j]` for the row-major `rows x cols` array
/// `a` and the columns `j = first ..` that `out` holds, [`TRANSPOSE_TILE`] columns at a
/// time (each input row's stretch of the tile is one or two cache lines).
fn transpose(a: &[f64], cols: usize, rows: usize, out: &mut [f64], first: usize) {
    let columns = out.len() / rows;
    for tile_start in (0..columns).step_by(TRANSPOSE_TILE) {
        let width = TRANSPOSE_TILE.min(columns - tile_start);
        let j0 = first + tile_start;
        for (i, row) in a.chunks(cols).enumerate().take(rows) {
            for (t, &v) in row[j0..j0 + width].iter().enumerate() {
                out[(tile_start + t) * rows + i] = v;
            }
        }
    }
}

fn failure(reason: String) -> Error {
    Error::Solver {
        solver: "kron".into(),
        reason,
    }
}

/// The diagonally scaled Kronecker preconditioner `P = D^{1/2} K D^{1/2}` (module doc).
#[derive(Clone, Debug)]
pub struct KroneckerPreconditioner {
    kronecker: KroneckerFactors,
    /// `D^{-1/2}` on coupled DOFs, 0 on decoupled ones.
    inverse_sqrt_scaling: Vec<f64>,
    /// `1 / A_ii` on decoupled DOFs, 0 elsewhere.
    decoupled_inverse: Vec<f64>,
    scaled: Vec<f64>,
}

impl KroneckerPreconditioner {
    /// The preconditioner with the factorised constant-density matrix `K`.
    pub fn new(kronecker: KroneckerFactors) -> Self {
        Self {
            kronecker,
            inverse_sqrt_scaling: Vec::new(),
            decoupled_inverse: Vec::new(),
            scaled: Vec::new(),
        }
    }
}

impl Preconditioner for KroneckerPreconditioner {
    fn solver_name(&self) -> &'static str {
        "kron"
    }

    /// `D^{-1/2}` and the decoupled rows' `1 / A_ii`, row by row in fixed blocks over the
    /// rayon pool (each row alone, so the same for any thread count). With `active`, the
    /// inactive DOFs are identity rows (decoupled, `A_ii = 1`) and the active ones see
    /// only the active columns, as in the matrix [`CsrMatrix::constrain`] builds.
    fn setup(&mut self, a: &CsrMatrix, active: Option<&[bool]>) -> Result<()> {
        let n = a.rows;
        if n != self.kronecker.len() {
            return Err(failure(format!(
                "matrix has {n} rows, the Kronecker factors {} DOFs",
                self.kronecker.len()
            )));
        }
        super::check_mask("kron", "active", a, active)?;
        self.inverse_sqrt_scaling.resize(n, 0.0);
        self.decoupled_inverse.resize(n, 0.0);
        self.scaled.resize(n, 0.0);
        let reference = self.kronecker.diagonal();
        let bad_row = self
            .inverse_sqrt_scaling
            .par_chunks_mut(SETUP_BLOCK)
            .zip(self.decoupled_inverse.par_chunks_mut(SETUP_BLOCK))
            .enumerate()
            .filter_map(|(block, (scalings, decoupled))| {
                let first = block * SETUP_BLOCK;
                let rows = scalings.iter_mut().zip(decoupled.iter_mut()).enumerate();
                for (offset, (scaling, decoupled)) in rows {
                    let i = first + offset;
                    if active.is_some_and(|m| !m[i]) {
                        (*scaling, *decoupled) = (0.0, 1.0);
                        continue;
                    }
                    let (d, coupled) = a.diagonal_and_coupling(i, active);
                    if d.is_nan() || d <= 0.0 {
                        return Some((i, d));
                    }
                    (*scaling, *decoupled) = if coupled {
                        ((reference[i] / d).sqrt(), 0.0)
                    } else {
                        (0.0, 1.0 / d)
                    };
                }
                None
            })
            .min_by_key(|&(i, _)| i);
        match bad_row {
            Some((i, d)) => Err(failure(format!(
                "non-positive diagonal entry {d:e} in row {i}"
            ))),
            None => Ok(()),
        }
    }

    fn apply(&mut self, _a: &CsrMatrix, r: &[f64], z: &mut [f64]) {
        let (scaling, decoupled) = (&self.inverse_sqrt_scaling, &self.decoupled_inverse);
        update_each(&mut self.scaled, |i, _| scaling[i] * r[i]);
        self.kronecker.solve(&self.scaled, z);
        update_each(z, |i, zi| scaling[i] * zi + decoupled[i] * r[i]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linalg::assembly::{interior, load_1d, mass_1d, mass_2d, SplineSpace};
    use crate::linalg::{LinearSolver, Pcg};

    /// The slab transposes (serial below `PARALLEL_MIN_DOFS`, by slabs, or by tiles of one
    /// slab) are the plain index transpose, with column counts that are no multiple of the
    /// tile.
    #[test]
    fn slab_transposes_are_index_transposes() {
        for (slabs, rows, cols) in [(1, 7, 5), (1, 130, 203), (3, 70, 90), (40, 23, 31)] {
            let a: Vec<f64> = (0..slabs * rows * cols).map(|v| v as f64).collect();
            let mut out = vec![0.0; a.len()];
            transpose_slabs(&a, cols, rows, &mut out);
            for s in 0..slabs {
                for i in 0..rows {
                    for j in 0..cols {
                        let slab = s * rows * cols;
                        assert_eq!(out[slab + j * rows + i], a[slab + i * cols + j]);
                    }
                }
            }
        }
    }

    fn interior_mass(space: &SplineSpace) -> CsrMatrix {
        let keep = interior(space.functions());
        mass_1d(space, space.order + 1, |_| 1.0).submatrix(&keep, &keep)
    }

    /// `factors.solve(k x) = x` to `tolerance` for a smooth `x`.
    fn assert_solve_inverts(factors: &mut KroneckerFactors, k: &CsrMatrix, tolerance: f64) {
        let exact: Vec<f64> = (0..k.rows).map(|i| (i as f64 * 0.31).sin()).collect();
        let mut b = vec![0.0; k.rows];
        k.mul_vec(&exact, &mut b);
        let mut z = vec![0.0; k.rows];
        factors.solve(&b, &mut z);
        for (zi, ei) in z.iter().zip(&exact) {
            assert!((zi - ei).abs() < tolerance, "{zi} {ei}");
        }
    }

    #[test]
    fn kronecker_solve_inverts_the_three_dimensional_tensor_product_mass() {
        // Unequal sizes and orders per direction, so a wrong stride or transpose shows.
        let spaces = [
            SplineSpace::new(2, 5, 1.0).unwrap(),
            SplineSpace::new(3, 4, 2.0).unwrap(),
            SplineSpace::new(2, 3, 0.5).unwrap(),
        ];
        let [mx, my, mz] = spaces.map(|s| mass_1d(&s, s.order + 1, |_| 1.0));
        let k = mz.kron(&my.kron(&mx));
        let mut factors = KroneckerFactors::new(&[mx, my, mz]).unwrap();
        assert_eq!(factors.len(), k.rows);
        for (d, kd) in factors.diagonal().iter().zip(k.diagonal()) {
            assert!((d - kd).abs() <= 1e-15 * kd, "{d} {kd}");
        }
        assert_solve_inverts(&mut factors, &k, 1e-9);
        assert!(KroneckerFactors::new(&[k.clone(), k.clone(), k.clone(), k]).is_err());
    }

    #[test]
    fn kronecker_solve_inverts_the_tensor_product_mass() {
        let x = SplineSpace::new(3, 6, 1.0).unwrap();
        let y = SplineSpace::new(3, 5, 1.0).unwrap();
        let (mx, my) = (interior_mass(&x), interior_mass(&y));
        let k = my.kron(&mx);
        let mut factors = KroneckerFactors::new(&[mx, my]).unwrap();
        assert_solve_inverts(&mut factors, &k, 1e-10);
        assert_eq!(factors.diagonal(), k.diagonal().as_slice());
    }

    /// Iterations of the scaled Kronecker PCG for `rho = 1 + 0.9 sin 2 pi x sin 2 pi y`.
    fn variable_density_iterations(order: usize, spans: usize) -> usize {
        let space = SplineSpace::new(order, spans, 1.0).unwrap();
        let keep = interior(space.functions());
        let keep2: Vec<bool> = keep
            .iter()
            .flat_map(|&ky| keep.iter().map(move |&kx| kx && ky))
            .collect();
        let tau = 2.0 * std::f64::consts::PI;
        let a = mass_2d(&space, &space, order + 2, |q| {
            1.0 + 0.9 * (tau * q.x[0]).sin() * (tau * q.x[1]).sin()
        })
        .submatrix(&keep2, &keep2);
        let load: Vec<f64> = load_1d(&space, 9.81)
            .into_iter()
            .zip(&keep)
            .filter_map(|(f, &k)| k.then_some(f))
            .collect();
        let b: Vec<f64> = load
            .iter()
            .flat_map(|&fy| load.iter().map(move |&fx| fx * fy))
            .collect();
        let m = interior_mass(&space);
        let factors = KroneckerFactors::new(&[m.clone(), m]).unwrap();
        let mut solver =
            Pcg::with_preconditioner(KroneckerPreconditioner::new(factors), 1e-8, 1000);
        let mut x = vec![0.0; b.len()];
        let stats = solver.solve(&a, &b, &mut x).unwrap();
        assert!(stats.relative_residual < 1e-8);
        stats.iterations
    }

    #[test]
    fn scaled_kronecker_pcg_iterations_do_not_grow_with_order_or_refinement() {
        for order in 1..=5 {
            let coarse = variable_density_iterations(order, 16);
            let fine = variable_density_iterations(order, 32);
            // Bounded, and falling as h resolves the density (SPEC §5.3: 3-4 at 256^2).
            assert!(
                coarse <= 10 && fine <= coarse,
                "p = {order}: {coarse}, {fine}"
            );
        }
    }

    #[test]
    fn eliminated_dofs_keep_the_preconditioner_exact_elsewhere() {
        // 1D: constant density scaled by 3, the first two and the last DOF eliminated.
        let space = SplineSpace::new(2, 10, 1.0).unwrap();
        let unit = mass_1d(&space, 3, |_| 1.0);
        let mut a = mass_1d(&space, 3, |_| 3.0);
        let mut keep = vec![true; a.rows];
        keep[0] = false;
        keep[1] = false;
        keep[a.rows - 1] = false;
        a.constrain(&keep);
        let mut b: Vec<f64> = (0..a.rows).map(|i| 1.0 + i as f64).collect();
        for (bi, &k) in b.iter_mut().zip(&keep) {
            if !k {
                *bi = 0.0;
            }
        }
        let factors = KroneckerFactors::new(&[unit]).unwrap();
        let mut solver =
            Pcg::with_preconditioner(KroneckerPreconditioner::new(factors), 1e-10, 100);
        let mut x = vec![0.0; a.rows];
        let stats = solver.solve(&a, &b, &mut x).unwrap();
        let mut exact = vec![0.0; a.rows];
        crate::linalg::BandedCholesky::new()
            .solve(&a, &b, &mut exact)
            .unwrap();
        for (xi, ei) in x.iter().zip(&exact) {
            assert!((xi - ei).abs() < 1e-8 * (1.0 + ei.abs()));
        }
        assert!(stats.iterations <= 12, "{stats:?}");
    }

    #[test]
    fn an_active_mask_gives_the_solve_of_the_constrained_copy_bit_for_bit() {
        // Quadratic B-splines on 7 x 6 spans, a density that vanishes on a corner (the
        // massless nodes of a partly filled grid), a roller-like restriction on top.
        let (x, y) = (
            SplineSpace::new(2, 7, 1.0).unwrap(),
            SplineSpace::new(2, 6, 1.0).unwrap(),
        );
        let a = mass_2d(&x, &y, 4, |q| {
            if q.x[0] > 0.7 && q.x[1] > 0.6 {
                0.0
            } else {
                1.0 + 0.5 * q.x[0] * q.x[1]
            }
        });
        let nx = x.functions();
        let active: Vec<bool> = a.diagonal().iter().map(|&d| d > 1e-12).collect();
        assert!(active.iter().any(|&m| !m) && active.iter().any(|&m| m));
        let keep: Vec<bool> = (0..a.rows).map(|i| active[i] && i % nx != 0).collect();
        let mut constrained = a.clone();
        constrained.constrain(&active);
        let b: Vec<f64> = (0..a.rows)
            .map(|i| {
                if keep[i] {
                    1.0 + (i as f64 * 0.7).sin()
                } else {
                    0.0
                }
            })
            .collect();
        let solver = || {
            let unit = |s: &SplineSpace| mass_1d(s, s.order + 1, |_| 1.0);
            let factors = KroneckerFactors::new(&[unit(&x), unit(&y)]).unwrap();
            Pcg::with_preconditioner(KroneckerPreconditioner::new(factors), 1e-12, 200)
        };
        let all = vec![true; a.rows];
        // The copy, set up with every DOF active (its massless rows are identity rows).
        let mut copied = vec![0.0; a.rows];
        let want = solver()
            .solve_restricted(&constrained, &all, &keep, &b, &mut copied)
            .unwrap();
        let mut masked = vec![0.0; a.rows];
        let got = solver()
            .solve_restricted(&a, &active, &keep, &b, &mut masked)
            .unwrap();
        assert!(want.iterations > 2, "{want:?}");
        assert_eq!(got, want);
        assert_eq!(masked, copied);
    }
}
