//! Conjugate gradients with warm start (SPEC §5): stop when `||r_k|| / ||b|| < tolerance`.
//! For the zero initial guess this is SPEC's `||r_k|| / ||r_0||`; measuring against `||b||`
//! (not the warm start's `r_0`) lets a good initial guess from the previous step finish in
//! few or no iterations instead of chasing round-off.

use super::{CsrMatrix, LinearSolver, SolveStats};
use crate::error::{Error, Result};

/// Plain (unpreconditioned) conjugate gradients.
#[derive(Clone, Debug)]
pub struct ConjugateGradient {
    pub tolerance: f64,
    pub max_iterations: usize,
    residual: Vec<f64>,
    direction: Vec<f64>,
    product: Vec<f64>,
}

impl ConjugateGradient {
    pub fn new(tolerance: f64, max_iterations: usize) -> Self {
        Self {
            tolerance,
            max_iterations,
            residual: Vec::new(),
            direction: Vec::new(),
            product: Vec::new(),
        }
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

impl LinearSolver for ConjugateGradient {
    fn name(&self) -> &'static str {
        "cg"
    }

    fn solve(&mut self, a: &CsrMatrix, b: &[f64], x: &mut [f64]) -> Result<SolveStats> {
        let n = b.len();
        if a.rows != n || a.cols != n || x.len() != n {
            return Err(Error::Solver {
                solver: "cg".into(),
                reason: format!(
                    "dimension mismatch: matrix {}x{}, rhs {}, x {}",
                    a.rows,
                    a.cols,
                    n,
                    x.len()
                ),
            });
        }
        self.residual.resize(n, 0.0);
        self.direction.resize(n, 0.0);
        self.product.resize(n, 0.0);
        let (r, d, q) = (&mut self.residual, &mut self.direction, &mut self.product);
        a.mul_vec(x, q);
        for i in 0..n {
            r[i] = b[i] - q[i];
        }
        d.copy_from_slice(r);
        let mut rr = dot(r, r);
        let b_norm = dot(b, b).sqrt();
        if b_norm == 0.0 {
            x.fill(0.0);
            return Ok(SolveStats::default());
        }
        let initial = rr.sqrt() / b_norm;
        if initial < self.tolerance {
            return Ok(SolveStats {
                iterations: 0,
                relative_residual: initial,
            });
        }
        for k in 1..=self.max_iterations {
            a.mul_vec(d, q);
            let dq = dot(d, q);
            if dq.is_nan() || dq <= 0.0 {
                return Err(Error::Solver {
                    solver: "cg".into(),
                    reason: format!("non-positive curvature d^T A d = {dq:e} at iteration {k}"),
                });
            }
            let alpha = rr / dq;
            for i in 0..n {
                x[i] += alpha * d[i];
                r[i] -= alpha * q[i];
            }
            let rr_new = dot(r, r);
            let relative = rr_new.sqrt() / b_norm;
            if relative < self.tolerance {
                return Ok(SolveStats {
                    iterations: k,
                    relative_residual: relative,
                });
            }
            let beta = rr_new / rr;
            rr = rr_new;
            for i in 0..n {
                d[i] = r[i] + beta * d[i];
            }
        }
        Err(Error::Solver {
            solver: "cg".into(),
            reason: format!(
                "no convergence to {:e} in {} iterations",
                self.tolerance, self.max_iterations
            ),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn laplacian(n: usize) -> CsrMatrix {
        let mut t = Vec::new();
        for i in 0..n {
            t.push((i, i, 2.0));
            if i + 1 < n {
                t.push((i, i + 1, -1.0));
                t.push((i + 1, i, -1.0));
            }
        }
        CsrMatrix::from_triplets(n, n, &t)
    }

    #[test]
    fn solves_spd_system_within_n_iterations() {
        let n = 50;
        let a = laplacian(n);
        let exact: Vec<f64> = (0..n).map(|i| (i as f64 * 0.3).sin()).collect();
        let mut b = vec![0.0; n];
        a.mul_vec(&exact, &mut b);
        let mut x = vec![0.0; n];
        let stats = ConjugateGradient::new(1e-12, 1000)
            .solve(&a, &b, &mut x)
            .unwrap();
        assert!(stats.iterations <= n + 1, "{stats:?}");
        assert!(stats.relative_residual < 1e-12);
        let err = x
            .iter()
            .zip(&exact)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-9, "{err}");
        // Warm start from the solution: converged at once.
        let stats = ConjugateGradient::new(1e-8, 1000)
            .solve(&a, &b, &mut x)
            .unwrap();
        assert_eq!(stats.iterations, 0, "{stats:?}");
        // A zero right-hand side has the zero solution.
        let stats = ConjugateGradient::new(1e-8, 1000)
            .solve(&a, &vec![0.0; n], &mut x)
            .unwrap();
        assert_eq!(stats.iterations, 0);
        assert!(x.iter().all(|&v| v == 0.0));
    }

    #[test]
    fn indefinite_matrix_is_reported_not_panicked() {
        let a = CsrMatrix::from_triplets(2, 2, &[(0, 0, 1.0), (1, 1, -1.0)]);
        let mut x = vec![0.0; 2];
        let err = ConjugateGradient::new(1e-10, 10).solve(&a, &[0.0, 1.0], &mut x);
        assert!(matches!(err, Err(Error::Solver { .. })));
    }
}
