//! Global cubic-spline interpolation with not-a-knot end conditions (SPEC §4.2, the
//! non-conservative comparator of TLS).
//!
//! Through sorted data `(x_k, y_k)`, `k = 0..n-1`, the spline is the C² piecewise cubic
//! that interpolates every point and whose third derivative is continuous at `x_1` and
//! `x_{n-2}` (*not-a-knot*, the default of MATLAB's `spline`): it reproduces cubics
//! exactly and converges at 4th order for smooth data, ends included. On
//! `[x_k, x_{k+1}]`, with `h_k = x_{k+1} - x_k`, `d_k = (y_{k+1} - y_k) / h_k`, the slopes
//! `s_k` at the knots and `t = x - x_k`,
//!
//! ```text
//! S(x) = y_k + s_k t + c2_k t^2 + c3_k t^3
//! c2_k = (3 d_k - 2 s_k - s_{k+1}) / h_k,      c3_k = (s_k + s_{k+1} - 2 d_k) / h_k^2
//! ```
//!
//! The slopes solve one tridiagonal system (Thomas algorithm, O(n)):
//!
//! ```text
//! interior k:  h_k s_{k-1} + 2 (h_{k-1} + h_k) s_k + h_{k-1} s_{k+1} = 3 (h_k d_{k-1} + h_{k-1} d_k)
//! first row:   h_1 s_0 + (x_2 - x_0) s_1 = ((h_0 + 2 (x_2 - x_0)) h_1 d_0 + h_0^2 d_1) / (x_2 - x_0)
//! last row:    (x_{n-1} - x_{n-3}) s_{n-2} + h_{n-3} s_{n-1}
//!                = (h_{n-2}^2 d_{n-3} + (2 (x_{n-1} - x_{n-3}) + h_{n-2}) h_{n-3} d_{n-2}) / (x_{n-1} - x_{n-3})
//! ```
//!
//! Elimination needs no pivoting: after the first row the pivots stay above the
//! off-diagonal entries.
//!
//! **Few or repeated points.** Abscissae closer than [`MERGE_TOLERANCE`] times the data
//! span are merged into one knot carrying the mean of their ordinates (equal positions
//! never produce a zero `h_k`, hence no NaN). With 3 distinct knots the spline is the
//! interpolating parabola (not-a-knot's limit), with 2 the line, with 1 the constant and
//! with none the zero function. Outside `[x_0, x_{n-1}]` the end pieces are extrapolated.
//!
//! **Evaluation.** [`CubicSpline::interval`] finds the piece of `x` by binary search;
//! [`CubicSpline::interval_from`] scans forward from a known piece (a monotone cursor:
//! O(1) amortised for increasing evaluation points).

/// Abscissae whose distance is at most this fraction of the data span are merged.
pub const MERGE_TOLERANCE: f64 = 1e-13;

/// A not-a-knot cubic spline; its buffers are reused by every [`CubicSpline::fit`].
#[derive(Clone, Debug, Default)]
pub struct CubicSpline {
    /// Distinct knots `x_k`, increasing.
    knots: Vec<f64>,
    /// Ordinates at the knots (means of merged points).
    values: Vec<f64>,
    /// Per piece `[y_k, s_k, c2_k, c3_k]`; one entry (the constant) with a single knot.
    coefficients: Vec<[f64; 4]>,
    /// Tridiagonal scratch: sub-, main and super-diagonal, right-hand side / slopes.
    sub: Vec<f64>,
    diag: Vec<f64>,
    sup: Vec<f64>,
    rhs: Vec<f64>,
}

impl CubicSpline {
    /// An empty spline (the zero function).
    pub fn new() -> Self {
        Self::default()
    }

    /// The spline through `(x[k], y[k])`; `x` must be non-decreasing (ties are merged).
    /// Extra entries of the longer slice are ignored.
    ///
    /// ```
    /// use tlsmpm::numerics::cubic_spline::CubicSpline;
    /// let x = [0.0, 0.3, 1.0, 1.1, 2.0];
    /// let y: Vec<f64> = x.iter().map(|x| x * x * x - x).collect();
    /// let mut spline = CubicSpline::new();
    /// spline.fit(&x, &y);
    /// assert!((spline.eval(1.7) - (1.7f64.powi(3) - 1.7)).abs() < 1e-12);
    /// ```
    pub fn fit(&mut self, x: &[f64], y: &[f64]) {
        self.merge(x, y);
        self.coefficients.clear();
        let n = self.knots.len();
        match n {
            0 => {}
            1 => self.coefficients.push([self.values[0], 0.0, 0.0, 0.0]),
            2 => {
                let slope = (self.values[1] - self.values[0]) / (self.knots[1] - self.knots[0]);
                self.coefficients.push([self.values[0], slope, 0.0, 0.0]);
            }
            3 => {
                // The interpolating parabola: slopes p'(x_k).
                let (x, y) = (&self.knots, &self.values);
                let d0 = (y[1] - y[0]) / (x[1] - x[0]);
                let d1 = (y[2] - y[1]) / (x[2] - x[1]);
                let c = (d1 - d0) / (x[2] - x[0]);
                self.rhs.clear();
                self.rhs
                    .extend(x.iter().map(|&xk| d0 + c * (2.0 * xk - x[0] - x[1])));
                self.hermite();
            }
            _ => {
                self.assemble();
                self.solve_tridiagonal();
                self.hermite();
            }
        }
    }

    /// The distinct knots of the last fit.
    pub fn knots(&self) -> &[f64] {
        &self.knots
    }

    /// Number of polynomial pieces (0 for the zero function).
    pub fn pieces(&self) -> usize {
        self.coefficients.len()
    }

    /// The piece whose polynomial is used at `x` (binary search; end pieces extend to
    /// infinity). 0 when the spline has no piece.
    #[inline]
    pub fn interval(&self, x: f64) -> usize {
        let pieces = self.coefficients.len();
        if pieces <= 1 {
            return 0;
        }
        // Knots x_1..x_{pieces-1} split the pieces.
        let inner = &self.knots[1..pieces];
        inner.partition_point(|&k| k <= x)
    }

    /// [`CubicSpline::interval`] found by scanning forward from piece `start` (a cursor
    /// for increasing `x`); falls back to binary search when `x` lies before `start`.
    #[inline]
    pub fn interval_from(&self, start: usize, x: f64) -> usize {
        let pieces = self.coefficients.len();
        if pieces <= 1 {
            return 0;
        }
        if start >= pieces || (start > 0 && x < self.knots[start]) {
            return self.interval(x);
        }
        let mut k = start;
        while k + 1 < pieces && self.knots[k + 1] <= x {
            k += 1;
        }
        k
    }

    /// Evaluate piece `interval` at `x` (any piece index is accepted; out-of-range
    /// indices use the last piece).
    #[inline]
    pub fn eval_in(&self, interval: usize, x: f64) -> f64 {
        let pieces = self.coefficients.len();
        if pieces == 0 {
            return 0.0;
        }
        let k = interval.min(pieces - 1);
        let [y, s, c2, c3] = self.coefficients[k];
        let t = x - self.knots[k];
        ((c3 * t + c2) * t + s) * t + y
    }

    /// `S(x)`.
    #[inline]
    pub fn eval(&self, x: f64) -> f64 {
        self.eval_in(self.interval(x), x)
    }

    /// Copy the data into `knots`/`values`, merging abscissae closer than
    /// [`MERGE_TOLERANCE`] times the span (mean ordinate) and dropping non-finite points.
    fn merge(&mut self, x: &[f64], y: &[f64]) {
        self.knots.clear();
        self.values.clear();
        let finite = || {
            x.iter()
                .zip(y)
                .filter(|(x, y)| x.is_finite() && y.is_finite())
        };
        let (lo, hi) = finite().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), (&x, _)| {
            (lo.min(x), hi.max(x))
        });
        let tolerance = MERGE_TOLERANCE * (hi - lo).max(0.0);
        let (mut sum, mut count) = (0.0, 0usize);
        for (&xk, &yk) in finite() {
            match self.knots.last() {
                Some(&last) if xk - last <= tolerance => {
                    sum += yk;
                    count += 1;
                }
                _ => {
                    if let Some(v) = self.values.last_mut() {
                        *v = sum / count as f64;
                    }
                    self.knots.push(xk);
                    self.values.push(yk);
                    sum = yk;
                    count = 1;
                }
            }
        }
        if let Some(v) = self.values.last_mut() {
            *v = sum / count as f64;
        }
    }

    /// The not-a-knot tridiagonal system for the slopes (n >= 4).
    fn assemble(&mut self) {
        let (x, y) = (&self.knots, &self.values);
        let n = x.len();
        let h = |k: usize| x[k + 1] - x[k];
        let d = |k: usize| (y[k + 1] - y[k]) / h(k);
        for v in [&mut self.sub, &mut self.diag, &mut self.sup, &mut self.rhs] {
            v.clear();
            v.resize(n, 0.0);
        }
        let x20 = x[2] - x[0];
        self.diag[0] = h(1);
        self.sup[0] = x20;
        self.rhs[0] = ((h(0) + 2.0 * x20) * h(1) * d(0) + h(0) * h(0) * d(1)) / x20;
        for k in 1..n - 1 {
            self.sub[k] = h(k);
            self.diag[k] = 2.0 * (h(k - 1) + h(k));
            self.sup[k] = h(k - 1);
            self.rhs[k] = 3.0 * (h(k) * d(k - 1) + h(k - 1) * d(k));
        }
        let xn = x[n - 1] - x[n - 3];
        self.sub[n - 1] = xn;
        self.diag[n - 1] = h(n - 3);
        self.rhs[n - 1] =
            (h(n - 2) * h(n - 2) * d(n - 3) + (2.0 * xn + h(n - 2)) * h(n - 3) * d(n - 2)) / xn;
    }

    /// Thomas algorithm; the slopes overwrite `rhs`.
    fn solve_tridiagonal(&mut self) {
        let n = self.diag.len();
        for k in 1..n {
            let factor = self.sub[k] / self.diag[k - 1];
            self.diag[k] -= factor * self.sup[k - 1];
            self.rhs[k] -= factor * self.rhs[k - 1];
        }
        self.rhs[n - 1] /= self.diag[n - 1];
        for k in (0..n - 1).rev() {
            self.rhs[k] = (self.rhs[k] - self.sup[k] * self.rhs[k + 1]) / self.diag[k];
        }
    }

    /// Piece coefficients from the slopes in `rhs`.
    fn hermite(&mut self) {
        let (x, y, s) = (&self.knots, &self.values, &self.rhs);
        self.coefficients.clear();
        self.coefficients.extend((0..x.len() - 1).map(|k| {
            let h = x[k + 1] - x[k];
            let d = (y[k + 1] - y[k]) / h;
            [
                y[k],
                s[k],
                (3.0 * d - 2.0 * s[k] - s[k + 1]) / h,
                (s[k] + s[k + 1] - 2.0 * d) / (h * h),
            ]
        }));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Non-uniform knots on `[a, b]`: a fixed, irregular layout.
    fn knots(a: f64, b: f64, n: usize) -> Vec<f64> {
        (0..n)
            .map(|k| {
                let t = k as f64 / (n - 1) as f64;
                let wobble = if k == 0 || k == n - 1 {
                    0.0
                } else {
                    0.3 * (k as f64 * 2.7).sin() / (n - 1) as f64
                };
                a + (b - a) * (t + wobble)
            })
            .collect()
    }

    #[test]
    fn reproduces_cubics_exactly_including_extrapolation() {
        let f = |x: f64| 2.0 - 0.5 * x + 1.5 * x * x - 0.7 * x * x * x;
        for n in [4, 5, 9, 30] {
            let x = knots(-1.0, 2.0, n);
            let y: Vec<f64> = x.iter().map(|&x| f(x)).collect();
            let mut s = CubicSpline::new();
            s.fit(&x, &y);
            for k in 0..=100 {
                let t = -1.2 + 3.4 * k as f64 / 100.0;
                assert!((s.eval(t) - f(t)).abs() < 1e-11, "n {n} x {t}");
            }
        }
        // Three points: the interpolating parabola.
        let p = |x: f64| 1.0 + x - 2.0 * x * x;
        let x = [0.0, 0.4, 1.0];
        let y = x.map(p);
        let mut s = CubicSpline::new();
        s.fit(&x, &y);
        for t in [-0.5, 0.2, 0.7, 1.5] {
            assert!((s.eval(t) - p(t)).abs() < 1e-13);
        }
    }

    #[test]
    fn interpolates_the_data() {
        let x = knots(0.0, 5.0, 17);
        let y: Vec<f64> = (0..17).map(|k| ((k * 7919) % 13) as f64 - 6.0).collect();
        let mut s = CubicSpline::new();
        s.fit(&x, &y);
        for (xk, yk) in x.iter().zip(&y) {
            assert!(
                (s.eval(*xk) - yk).abs() < 1e-12,
                "{xk}: {} vs {yk}",
                s.eval(*xk)
            );
        }
        // C1 continuity at an interior knot.
        let k = 8;
        let eps = 1e-7;
        let left = (s.eval(x[k]) - s.eval(x[k] - eps)) / eps;
        let right = (s.eval(x[k] + eps) - s.eval(x[k])) / eps;
        assert!((left - right).abs() < 1e-4 * (1.0 + left.abs()));
    }

    #[test]
    fn converges_at_fourth_order_for_a_smooth_function() {
        // Smoothly graded (non-uniform) knots, so the local spacing ratio is fixed per level.
        let error = |n: usize| {
            let x: Vec<f64> = (0..n)
                .map(|k| {
                    let t = k as f64 / (n - 1) as f64;
                    3.0 * (t + 0.1 * (std::f64::consts::PI * t).sin())
                })
                .collect();
            let y: Vec<f64> = x.iter().map(|x| x.sin() + (2.0 * x).cos()).collect();
            let mut s = CubicSpline::new();
            s.fit(&x, &y);
            (0..=1000)
                .map(|k| {
                    let t = 3.0 * k as f64 / 1000.0;
                    (s.eval(t) - t.sin() - (2.0 * t).cos()).abs()
                })
                .fold(0.0, f64::max)
        };
        let (e1, e2, e3) = (error(21), error(41), error(81));
        let (o1, o2) = ((e1 / e2).log2(), (e2 / e3).log2());
        assert!(o1 > 3.7 && o2 > 3.7, "orders {o1} {o2} ({e1} {e2} {e3})");
    }

    #[test]
    fn repeated_abscissae_are_merged_not_nan() {
        let x = [0.0, 1.0, 1.0, 2.0, 3.0, 3.0, 3.0, 4.0];
        let y = [0.0, 1.0, 3.0, 4.0, 8.0, 9.0, 10.0, 16.0];
        let mut s = CubicSpline::new();
        s.fit(&x, &y);
        assert_eq!(s.knots(), &[0.0, 1.0, 2.0, 3.0, 4.0]);
        assert!((s.eval(1.0) - 2.0).abs() < 1e-14);
        assert!((s.eval(3.0) - 9.0).abs() < 1e-14);
        assert!((0..=40).all(|k| s.eval(k as f64 * 0.1).is_finite()));
        // All points equal: the constant mean.
        s.fit(&[2.0, 2.0, 2.0], &[1.0, 2.0, 6.0]);
        assert_eq!(s.pieces(), 1);
        assert_eq!(s.eval(-5.0), 3.0);
        // Two distinct points: the line; none: zero; non-finite points dropped.
        s.fit(&[1.0, 3.0], &[1.0, 5.0]);
        assert!((s.eval(2.0) - 3.0).abs() < 1e-15 && (s.eval(4.0) - 7.0).abs() < 1e-15);
        s.fit(&[], &[]);
        assert_eq!(s.eval(1.0), 0.0);
        s.fit(&[0.0, f64::NAN, 1.0], &[1.0, 1.0, f64::INFINITY]);
        assert_eq!(s.eval(0.5), 1.0);
    }

    #[test]
    fn cursor_agrees_with_binary_search() {
        let x = knots(0.0, 1.0, 12);
        let y: Vec<f64> = x.iter().map(|x| x.exp()).collect();
        let mut s = CubicSpline::new();
        s.fit(&x, &y);
        let mut cursor = 0;
        for k in 0..=200 {
            let t = -0.1 + 1.2 * k as f64 / 200.0;
            cursor = s.interval_from(cursor, t);
            assert_eq!(cursor, s.interval(t), "x {t}");
        }
        // Going backwards falls back to the binary search.
        assert_eq!(s.interval_from(s.pieces() - 1, 0.05), s.interval(0.05));
        assert_eq!(s.interval(-1.0), 0);
        assert_eq!(s.interval(2.0), s.pieces() - 1);
    }
}
