//! Contact without a twin: while the rod creeps toward the grating's edge the ring's column
//! stands still (up to the detector's noise); when the rod touches and starts to move the
//! grating, c starts to move. [`ContactDetector`] learns the column's baseline and noise from
//! the first frames, then reports contact when the column leaves the baseline by more than
//! `sigmas` standard deviations (and at least `min_px`) in `frames` frames in a row.
//!
//! Units: px. No errors: frames without a ring are skipped (they neither confirm nor break a
//! run).
//!
//! ```
//! use gonio_plc::contact::{ContactDetector, Verdict};
//! let mut d = ContactDetector::new(5, 6.0, 0.6, 2);
//! for c in [720.1, 719.9, 720.0, 720.2, 719.8] {
//!     assert_eq!(d.update(Some(c)), Verdict::Learning);
//! }
//! assert_eq!(d.update(Some(720.1)), Verdict::Free);
//! assert_eq!(d.update(Some(722.5)), Verdict::Free); // one frame is not enough
//! assert_eq!(d.update(Some(723.5)), Verdict::Contact);
//! ```

/// What the detector makes of a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// Still learning the baseline.
    Learning,
    /// No contact yet.
    Free,
    /// The column has started to move: contact.
    Contact,
}

/// Contact from the ring's column.
#[derive(Debug, Clone)]
pub struct ContactDetector {
    baseline_frames: usize,
    sigmas: f64,
    min_px: f64,
    frames: usize,
    base: Vec<f64>,
    /// The baseline's mean and threshold, px, once learned.
    learned: Option<(f64, f64)>,
    run: usize,
}

impl ContactDetector {
    /// A detector that learns from `baseline_frames` frames, then reports contact after
    /// `frames` frames in a row beyond `max(sigmas·σ, min_px)`.
    pub fn new(baseline_frames: usize, sigmas: f64, min_px: f64, frames: usize) -> Self {
        ContactDetector {
            baseline_frames: baseline_frames.max(2),
            sigmas,
            min_px,
            frames: frames.max(1),
            base: Vec::new(),
            learned: None,
            run: 0,
        }
    }

    /// The baseline column, px (`None` while learning).
    pub fn baseline_px(&self) -> Option<f64> {
        self.learned.map(|(mean, _)| mean)
    }

    /// The threshold, px (`None` while learning).
    pub fn threshold_px(&self) -> Option<f64> {
        self.learned.map(|(_, threshold)| threshold)
    }

    /// Takes the next frame's column (`None`: no ring in the frame).
    pub fn update(&mut self, c_px: Option<f64>) -> Verdict {
        let Some(c) = c_px.filter(|c| c.is_finite()) else {
            return if self.base.len() < self.baseline_frames {
                Verdict::Learning
            } else {
                Verdict::Free
            };
        };
        let Some((mean, threshold)) = self.learned else {
            self.base.push(c);
            if self.base.len() == self.baseline_frames {
                let n = self.base.len() as f64;
                let mean = self.base.iter().sum::<f64>() / n;
                let var = self.base.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
                self.learned = Some((mean, (self.sigmas * var.sqrt()).max(self.min_px)));
            }
            return Verdict::Learning;
        };
        if (c - mean).abs() > threshold {
            self.run += 1;
        } else {
            self.run = 0;
        }
        if self.run >= self.frames {
            Verdict::Contact
        } else {
            Verdict::Free
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_alone_is_not_contact() {
        // 0.3 px Gaussian-like noise from a fixed sequence: 2000 frames never trip 6 σ twice.
        let mut d = ContactDetector::new(10, 6.0, 0.6, 2);
        let mut x: u64 = 12345;
        let mut noise = || {
            let mut s = 0.0;
            for _ in 0..12 {
                x = x
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                s += (x >> 11) as f64 / (1u64 << 53) as f64;
            }
            0.3 * (s - 6.0)
        };
        for _ in 0..2000 {
            assert_ne!(d.update(Some(720.0 + noise())), Verdict::Contact);
        }
        let thr = d.threshold_px().expect("learned");
        assert!((0.6..3.0).contains(&thr));
        // A ramp of 0.5 px a frame is found within a few frames of crossing the threshold.
        let mut n = 0;
        loop {
            n += 1;
            if d.update(Some(720.0 + 0.5 * n as f64 + noise())) == Verdict::Contact {
                break;
            }
            assert!(n < 100);
        }
        assert!(
            (n as f64) < thr / 0.5 + 6.0,
            "{n} frames for threshold {thr}"
        );
    }
}
