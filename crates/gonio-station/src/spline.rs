//! Natural cubic splines through sample points, with extremum search (the seed's fit, §3).
//!
//! Written here because no maintained crate offers a natural cubic spline together with an
//! exact search for its extrema (the roots of the piecewise-quadratic derivative), which is what
//! the seed's extreme-point method needs.
//!
//! On each interval `[x_i, x_{i+1}]` with `h = x_{i+1} − x_i` and second derivatives `M_i`
//! (natural: `M_0 = M_{n−1} = 0`), `s(x) = y_i + b_i t + M_i t²/2 + (M_{i+1} − M_i) t³/(6h)`,
//! `t = x − x_i`, `b_i = (y_{i+1} − y_i)/h − h(2M_i + M_{i+1})/6`. The `M_i` solve a tridiagonal
//! system (Thomas algorithm, O(n)).
//!
//! ```
//! use gonio_station::spline::NaturalSpline;
//! let x: Vec<f64> = (0..9).map(|i| i as f64 * 0.25).collect();
//! let y: Vec<f64> = x.iter().map(|v| -(v - 1.1f64).powi(2)).collect();
//! let s = NaturalSpline::new(&x, &y).unwrap();
//! let (xm, ym) = s.maximum();
//! assert!((xm - 1.1).abs() < 1e-3 && ym.abs() < 1e-4);
//! ```

use crate::StationError;

/// A natural cubic spline interpolating points with strictly increasing abscissae.
#[derive(Debug, Clone, PartialEq)]
pub struct NaturalSpline {
    x: Vec<f64>,
    y: Vec<f64>,
    m: Vec<f64>,
}

impl NaturalSpline {
    /// The spline through `(x_i, y_i)`.
    ///
    /// # Errors
    /// [`StationError::TooFewSamples`] for fewer than 2 points, [`StationError::NotFinite`],
    /// [`StationError::NotIncreasing`] when `x` does not increase strictly.
    pub fn new(x: &[f64], y: &[f64]) -> Result<Self, StationError> {
        let n = x.len().min(y.len());
        if n < 2 {
            return Err(StationError::TooFewSamples {
                expected: 2,
                found: n,
            });
        }
        for i in 0..n {
            if !x[i].is_finite() {
                return Err(StationError::NotFinite {
                    index: i,
                    what: "x",
                    value: x[i],
                });
            }
            if !y[i].is_finite() {
                return Err(StationError::NotFinite {
                    index: i,
                    what: "y",
                    value: y[i],
                });
            }
            if i > 0 && x[i] <= x[i - 1] {
                return Err(StationError::NotIncreasing {
                    index: i,
                    previous_deg: x[i - 1],
                    found_deg: x[i],
                });
            }
        }
        let mut m = vec![0.0; n];
        if n > 2 {
            // Interior equations i = 1..n-2:
            // h_{i-1} M_{i-1} + 2(h_{i-1}+h_i) M_i + h_i M_{i+1} = 6(d_i − d_{i-1}).
            let k = n - 2;
            let mut diag = vec![0.0; k];
            let mut upper = vec![0.0; k];
            let mut rhs = vec![0.0; k];
            for j in 0..k {
                let i = j + 1;
                let h0 = x[i] - x[i - 1];
                let h1 = x[i + 1] - x[i];
                diag[j] = 2.0 * (h0 + h1);
                upper[j] = h1;
                rhs[j] = 6.0 * ((y[i + 1] - y[i]) / h1 - (y[i] - y[i - 1]) / h0);
            }
            // Forward sweep (lower[j] = h_{j} = x[j+1]-x[j] for row j ≥ 1).
            for j in 1..k {
                let lower = x[j + 1] - x[j];
                let w = lower / diag[j - 1];
                diag[j] -= w * upper[j - 1];
                rhs[j] -= w * rhs[j - 1];
            }
            let mut sol = vec![0.0; k];
            sol[k - 1] = rhs[k - 1] / diag[k - 1];
            for j in (0..k - 1).rev() {
                sol[j] = (rhs[j] - upper[j] * sol[j + 1]) / diag[j];
            }
            m[1..(k + 1)].copy_from_slice(&sol);
        }
        Ok(NaturalSpline {
            x: x[..n].to_vec(),
            y: y[..n].to_vec(),
            m,
        })
    }

    /// Polynomial coefficients `(y_i, b, c, d)` of interval `i` in `t = x − x_i`.
    fn coefficients(&self, i: usize) -> (f64, f64, f64, f64) {
        let h = self.x[i + 1] - self.x[i];
        let b = (self.y[i + 1] - self.y[i]) / h - h * (2.0 * self.m[i] + self.m[i + 1]) / 6.0;
        let c = self.m[i] / 2.0;
        let d = (self.m[i + 1] - self.m[i]) / (6.0 * h);
        (self.y[i], b, c, d)
    }

    fn interval(&self, x: f64) -> usize {
        let n = self.x.len();
        match self.x.partition_point(|&v| v <= x) {
            0 => 0,
            p if p >= n => n - 2,
            p => p - 1,
        }
    }

    /// The spline's value at `x` (extrapolated with the end cubics outside the knots).
    pub fn eval(&self, x: f64) -> f64 {
        let i = self.interval(x);
        let (a, b, c, d) = self.coefficients(i);
        let t = x - self.x[i];
        a + t * (b + t * (c + t * d))
    }

    /// Candidate extremum abscissae: the knots and the derivative's roots inside each interval.
    fn candidates(&self) -> Vec<f64> {
        let mut out = self.x.clone();
        for i in 0..self.x.len() - 1 {
            let h = self.x[i + 1] - self.x[i];
            let (_, b, c, d) = self.coefficients(i);
            // s'(t) = b + 2c t + 3d t².
            let (qa, qb, qc) = (3.0 * d, 2.0 * c, b);
            let mut roots = Vec::with_capacity(2);
            if qa.abs() < 1e-300 || (qa * h * h).abs() < 1e-14 * (qb * h).abs().max(qc.abs()) {
                if qb != 0.0 {
                    roots.push(-qc / qb);
                }
            } else {
                let disc = qb * qb - 4.0 * qa * qc;
                if disc >= 0.0 {
                    let sq = disc.sqrt();
                    // Numerically stable quadratic roots.
                    let q = -0.5 * (qb + qb.signum() * sq);
                    if q != 0.0 {
                        roots.push(q / qa);
                        roots.push(qc / q);
                    } else {
                        roots.push(0.0);
                    }
                }
            }
            for t in roots {
                if t > 0.0 && t < h {
                    out.push(self.x[i] + t);
                }
            }
        }
        out
    }

    /// The spline's largest value on `[x_0, x_{n−1}]` and where it is: `(x, s(x))`.
    pub fn maximum(&self) -> (f64, f64) {
        self.candidates()
            .into_iter()
            .map(|x| (x, self.eval(x)))
            .fold((f64::NAN, f64::NEG_INFINITY), |acc, p| {
                if p.1 > acc.1 { p } else { acc }
            })
    }

    /// The spline's smallest value on `[x_0, x_{n−1}]` and where it is: `(x, s(x))`.
    pub fn minimum(&self) -> (f64, f64) {
        self.candidates()
            .into_iter()
            .map(|x| (x, self.eval(x)))
            .fold(
                (f64::NAN, f64::INFINITY),
                |acc, p| {
                    if p.1 < acc.1 { p } else { acc }
                },
            )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolates_knots_and_reproduces_lines() {
        let x = [0.0, 1.0, 2.5, 3.0, 4.2];
        let y = [1.0, 3.0, 6.0, 7.0, 9.4];
        let s = NaturalSpline::new(&x, &y).unwrap();
        for (a, b) in x.iter().zip(&y) {
            assert!((s.eval(*a) - b).abs() < 1e-12);
        }
        // A straight line is reproduced exactly by a natural spline.
        assert!((s.eval(1.7) - (1.0 + 2.0 * 1.7)).abs() < 1e-12);
    }

    #[test]
    fn finds_the_peak_of_a_sampled_cosine() {
        let x: Vec<f64> = (0..11).map(|i| 80.0 + i as f64 * 1.8).collect();
        let y: Vec<f64> = x.iter().map(|t| (t - 88.3f64).to_radians().cos()).collect();
        let (xm, ym) = NaturalSpline::new(&x, &y).unwrap().maximum();
        assert!((xm - 88.3).abs() < 1e-3, "{xm}");
        // The natural end condition (s'' = 0) costs ~1e-7 near the middle of an 11-knot window.
        assert!((ym - 1.0).abs() < 1e-6, "{ym}");
    }

    #[test]
    fn rejects_bad_input() {
        assert!(matches!(
            NaturalSpline::new(&[0.0], &[1.0]),
            Err(StationError::TooFewSamples { .. })
        ));
        assert!(matches!(
            NaturalSpline::new(&[0.0, 0.0, 1.0], &[1.0, 2.0, 3.0]),
            Err(StationError::NotIncreasing { index: 1, .. })
        ));
    }
}
