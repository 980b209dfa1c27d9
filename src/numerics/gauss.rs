//! Gauss–Legendre quadrature (SPEC §4.1): the `n`-point rule integrates polynomials of
//! degree `2n - 1` exactly.
//!
//! Nodes are the roots of the Legendre polynomial `P_n` on `[-1, 1]`, found by Newton's
//! method from the Chebyshev-like start `cos(pi (k + 3/4) / (n + 1/2))`; weights are
//! `w_k = 2 / ((1 - x_k^2) P_n'(x_k)^2)`.

/// Most points a rule may have.
pub const MAX_POINTS: usize = 32;

/// An `n`-point Gauss–Legendre rule on `[-1, 1]`, nodes in increasing order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GaussRule {
    pub len: usize,
    pub nodes: [f64; MAX_POINTS],
    pub weights: [f64; MAX_POINTS],
}

impl GaussRule {
    /// The `n`-point rule; `None` unless `1 <= n <= MAX_POINTS`.
    ///
    /// ```
    /// let rule = tlsmpm::numerics::gauss::GaussRule::new(2).unwrap();
    /// assert!((rule.nodes[1] - 1.0 / 3f64.sqrt()).abs() < 1e-15);
    /// assert!((rule.weights[0] - 1.0).abs() < 1e-15);
    /// ```
    pub fn new(n: usize) -> Option<Self> {
        if !(1..=MAX_POINTS).contains(&n) {
            return None;
        }
        let mut nodes = [0.0; MAX_POINTS];
        let mut weights = [0.0; MAX_POINTS];
        for k in 0..n {
            let mut x = (std::f64::consts::PI * (k as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut derivative = 1.0;
            for _ in 0..100 {
                let (p, dp) = legendre(n, x);
                derivative = dp;
                let step = p / dp;
                x -= step;
                if step.abs() < 1e-16 {
                    let (_, dp) = legendre(n, x);
                    derivative = dp;
                    break;
                }
            }
            // Roots come out in decreasing order; store increasing.
            nodes[n - 1 - k] = x;
            weights[n - 1 - k] = 2.0 / ((1.0 - x * x) * derivative * derivative);
        }
        Some(Self {
            len: n,
            nodes,
            weights,
        })
    }

    /// Points and weights mapped to `[a, b]`: `(x_g, w_g)` for `g < len`.
    #[inline]
    pub fn mapped(&self, a: f64, b: f64) -> impl Iterator<Item = (f64, f64)> + '_ {
        let (centre, half) = (0.5 * (a + b), 0.5 * (b - a));
        self.nodes[..self.len]
            .iter()
            .zip(&self.weights[..self.len])
            .map(move |(&t, &w)| (centre + half * t, half * w))
    }
}

/// `(P_n(x), P_n'(x))` by the three-term recurrence.
fn legendre(n: usize, x: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, x);
    if n == 0 {
        return (1.0, 0.0);
    }
    for k in 2..=n {
        let k = k as f64;
        let p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
    }
    let n = n as f64;
    (p1, n * (x * p1 - p0) / (x * x - 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_for_degree_two_n_minus_one() {
        for n in 1..=MAX_POINTS {
            let rule = GaussRule::new(n).unwrap();
            let weight_sum: f64 = rule.weights[..n].iter().sum();
            assert!((weight_sum - 2.0).abs() < 1e-13, "n {n}: {weight_sum}");
            assert!(rule.nodes[..n].windows(2).all(|w| w[0] < w[1]));
            for degree in 0..2 * n {
                let integral: f64 = rule
                    .mapped(0.0, 2.0)
                    .map(|(x, w)| w * x.powi(degree as i32))
                    .sum();
                let exact = 2f64.powi(degree as i32 + 1) / (degree as f64 + 1.0);
                assert!(
                    (integral - exact).abs() < 1e-12 * exact,
                    "n {n} degree {degree}: {integral} vs {exact}"
                );
            }
            // Degree 2n is not exact (the rule has exactly the advertised order).
            if n <= 6 {
                let d = 2 * n;
                let integral: f64 = rule
                    .mapped(-1.0, 1.0)
                    .map(|(x, w)| w * x.powi(d as i32))
                    .sum();
                assert!((integral - 2.0 / (d as f64 + 1.0)).abs() > 1e-6);
            }
        }
        assert!(GaussRule::new(0).is_none());
        assert!(GaussRule::new(MAX_POINTS + 1).is_none());
    }
}
