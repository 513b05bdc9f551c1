//! The one quantile definition of gonio's reports (latencies, round trips, frame lateness):
//! the **nearest-rank** quantile. The q-quantile of n samples is the sample of rank ⌈q·n⌉ in
//! ascending order (1-based, at least 1): the smallest sample with at least a fraction q of the
//! samples at or below it. It is always a measured value (no interpolation), the median of an
//! even count is the lower middle sample, and q = 1 is the largest. Undefined for no samples
//! (`None`).
//!
//! ```
//! use gonio_core::quantile::{quantile_sorted, rank};
//! let v = [1.0, 2.0, 3.0, 4.0];
//! assert_eq!(quantile_sorted(&v, 0.5), Some(2.0));
//! assert_eq!(quantile_sorted(&v, 0.99), Some(4.0));
//! assert_eq!(quantile_sorted(&[], 0.5), None);
//! assert_eq!(rank(100, 0.99), 98); // 0-based: the 99th smallest of 100
//! ```

/// The 0-based index of the q-quantile among `n` ≥ 1 sorted samples: ⌈q·n⌉ − 1, within
/// `0..n` (q is clamped to [0, 1]; NaN counts as 0).
pub fn rank(n: usize, q: f64) -> usize {
    let q = if q.is_nan() { 0.0 } else { q.clamp(0.0, 1.0) };
    ((q * n as f64).ceil() as usize).clamp(1, n.max(1)) - 1
}

/// The q-quantile of samples sorted in ascending order (`None`: no samples).
pub fn quantile_sorted(sorted: &[f64], q: f64) -> Option<f64> {
    (!sorted.is_empty()).then(|| sorted[rank(sorted.len(), q)])
}

/// The q-quantile of `samples` in any order, sorting them in place (`None`: no samples).
pub fn quantile(samples: &mut [f64], q: f64) -> Option<f64> {
    samples.sort_by(f64::total_cmp);
    quantile_sorted(samples, q)
}

/// The median, 99th percentile and largest of a set of samples (nearest rank), and how many:
/// what a timing report prints.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spread {
    /// The median (the lower middle sample of an even count).
    pub median: f64,
    /// The 99th percentile.
    pub p99: f64,
    /// The largest sample.
    pub max: f64,
    /// How many samples.
    pub n: usize,
}

impl Spread {
    /// The spread of `samples` in any order, sorting them in place (`None`: no samples).
    pub fn of(samples: &mut [f64]) -> Option<Spread> {
        samples.sort_by(f64::total_cmp);
        Some(Spread {
            median: quantile_sorted(samples, 0.5)?,
            p99: quantile_sorted(samples, 0.99)?,
            max: quantile_sorted(samples, 1.0)?,
            n: samples.len(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_nearest_rank_is_the_smallest_sample_with_a_fraction_q_at_or_below_it() {
        let v: Vec<f64> = (1..=10).map(f64::from).collect();
        for (q, want) in [
            (0.0, 1.0),
            (0.1, 1.0),
            (0.11, 2.0),
            (0.5, 5.0),
            (0.51, 6.0),
            (0.99, 10.0),
            (1.0, 10.0),
        ] {
            let got = quantile_sorted(&v, q).unwrap();
            assert_eq!(got, want, "q {q}");
            let at_or_below = v.iter().filter(|&&x| x <= got).count() as f64;
            assert!(at_or_below >= q * v.len() as f64, "q {q}");
        }
        assert_eq!(quantile(&mut [3.0, 1.0, 2.0], 0.5), Some(2.0));
        assert_eq!(rank(1, 0.5), 0);
        assert_eq!(rank(7, f64::NAN), 0);
        assert_eq!(rank(7, 2.0), 6);
        let s = Spread::of(&mut [4.0, 1.0, 3.0, 2.0]).unwrap();
        assert_eq!((s.median, s.p99, s.max, s.n), (2.0, 4.0, 4.0, 4));
        assert_eq!(Spread::of(&mut []), None);
    }
}
