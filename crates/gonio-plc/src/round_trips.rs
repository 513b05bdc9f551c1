//! [`RoundTrips`]: the round-trip times of a link's requests, every request counted in bounded
//! memory, with their quantiles in ms (nearest rank, [`gonio_core::quantile`]).

/// Width of a round-trip histogram bin, ms.
const RTT_BIN_MS: f64 = 0.01;
/// Bins of [`RTT_BIN_MS`] from 0 up to 100 ms; longer round trips are kept one by one.
const RTT_BINS: usize = 10_000;
/// Round trips over 100 ms kept one by one (beyond these, the slowest are kept).
const RTT_SLOW_KEPT: usize = 100_000;

/// Round-trip times of the link's requests: every request counted, however long the link runs,
/// in bounded memory. Times under 100 ms fall in bins of 10 µs (a quantile is its bin's middle,
/// within 5 µs); slower ones are kept as measured (at most 100,000; then the slowest of them).
#[derive(Debug, Clone)]
pub struct RoundTrips {
    bins: Vec<u64>,
    slow_ms: Vec<f64>,
    /// Slow round trips not kept (the fastest of the slow ones are dropped first).
    slow_dropped: u64,
    count: u64,
}

impl Default for RoundTrips {
    fn default() -> Self {
        RoundTrips {
            bins: vec![0; RTT_BINS],
            slow_ms: Vec::new(),
            slow_dropped: 0,
            count: 0,
        }
    }
}

impl RoundTrips {
    pub(crate) fn add(&mut self, ms: f64) {
        self.count += 1;
        let bin = (ms.max(0.0) / RTT_BIN_MS) as usize;
        if bin < RTT_BINS {
            self.bins[bin] += 1;
        } else if self.slow_ms.len() < RTT_SLOW_KEPT {
            self.slow_ms.push(ms);
        } else {
            // Keep the slowest: replace the fastest kept one if this one is slower.
            self.slow_dropped += 1;
            if let Some((i, &min)) = self
                .slow_ms
                .iter()
                .enumerate()
                .min_by(|a, b| a.1.total_cmp(b.1))
                && ms > min
            {
                self.slow_ms[i] = ms;
            }
        }
    }

    /// Requests timed.
    pub fn count(&self) -> usize {
        self.count as usize
    }

    /// The `q` quantile (0–1), ms: the nearest-rank quantile ([`gonio_core::quantile`]) of
    /// every request timed, within half a bin below 100 ms; `None` when nothing was timed.
    pub fn quantile_ms(&self, q: f64) -> Option<f64> {
        if self.count == 0 {
            return None;
        }
        let rank = gonio_core::quantile::rank(self.count as usize, q) as u64;
        let mut seen = 0u64;
        for (i, &n) in self.bins.iter().enumerate() {
            seen += n;
            if rank < seen {
                return Some((i as f64 + 0.5) * RTT_BIN_MS);
            }
        }
        // Among the slow ones: those dropped were the fastest of them.
        let mut slow = self.slow_ms.clone();
        slow.sort_by(f64::total_cmp);
        let k = (rank - seen).saturating_sub(self.slow_dropped) as usize;
        Some(
            slow.get(k)
                .or(slow.first())
                .copied()
                .unwrap_or(RTT_BINS as f64 * RTT_BIN_MS),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::RoundTrips;
    use rand::{RngExt, SeedableRng};

    /// The nearest-rank quantile of a sorted copy.
    fn exact(v: &[f64], q: f64) -> f64 {
        gonio_core::quantile::quantile(&mut v.to_vec(), q).unwrap()
    }

    #[test]
    fn quantiles_are_within_half_a_bin_of_the_exact_ones_and_slow_ones_exact() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let mut r = RoundTrips::default();
        let mut all = Vec::new();
        for _ in 0..20_000 {
            // Mostly around 1 ms, a tail up to 400 ms.
            let ms = if rng.random::<f64>() < 0.995 {
                0.5 + rng.random::<f64>() * 2.0
            } else {
                100.0 + rng.random::<f64>() * 300.0
            };
            r.add(ms);
            all.push(ms);
        }
        assert_eq!(r.count(), 20_000);
        for q in [0.0, 0.1, 0.5, 0.9, 0.99] {
            let (got, want) = (r.quantile_ms(q).unwrap(), exact(&all, q));
            assert!(
                (got - want).abs() <= 0.005 + 1e-12,
                "q {q}: {got} vs {want}"
            );
        }
        // In the slow tail every sample is kept: exact.
        for q in [0.996, 0.999, 1.0] {
            assert_eq!(r.quantile_ms(q), Some(exact(&all, q)), "q {q}");
        }
        assert_eq!(RoundTrips::default().quantile_ms(0.5), None);
    }

    #[test]
    fn every_request_is_counted_in_bounded_memory() {
        let mut r = RoundTrips::default();
        for i in 0..1_500_000u64 {
            r.add(1.0 + (i % 7) as f64 * 0.1);
        }
        assert_eq!(r.count(), 1_500_000);
        assert!((r.quantile_ms(0.5).unwrap() - 1.305).abs() < 1e-9);
        assert_eq!(r.bins.len(), super::RTT_BINS);
    }
}
