//! The angle of every frame.
//!
//! With a trigger line ([`LatchedRing`]) the PLC triggers the camera and, for each trigger,
//! latches the servo angle at mid-exposure into a ring of input registers with the trigger
//! count and the PLC time; the camera numbers its frames the same way (frame `frame_id` is
//! trigger `frame_id`), so each frame gets its latched angle exactly, whatever the frame's delay
//! on the network. Without one ([`Interpolated`]) the PLC writes timestamped angle samples every
//! cycle and a frame's angle is interpolated at its timestamp (on the PLC's clock): its error is
//! the clock offset times the speed plus the curvature of the profile between samples
//! (`docs/plc-interface.md`).
//!
//! Both sit behind [`AnglePairing`], so the station's camera does not know which it has.
//!
//! ```
//! use gonio_plc::pairing::{AnglePairing, Interpolated};
//! use gonio_station::interval::AngleSample;
//! let mut p = Interpolated::default();
//! p.add(AngleSample { t_s: 1.0, theta_deg: 10.0 });
//! p.add(AngleSample { t_s: 1.002, theta_deg: 10.36 });
//! let (t, th) = p.lookup(7, Some(1.001)).unwrap().unwrap();
//! assert_eq!(t, 1.001);
//! assert!((th - 10.18).abs() < 1e-9);
//! ```

use gonio_station::interval::AngleSample;
use std::collections::BTreeMap;

/// Gives a frame its PLC time and angle.
pub trait AnglePairing {
    /// The mid-exposure PLC time (s) and servo angle (degrees) of frame `frame_id` taken at
    /// `time_s` (its mid-exposure on the PLC clock, when known). `Ok(None)`: not yet known (ask
    /// again after new data); `Err`: it never will be (overwritten, outside the samples).
    ///
    /// # Errors
    /// A message saying why the frame has no angle.
    fn lookup(&mut self, frame_id: u64, time_s: Option<f64>) -> Result<Option<(f64, f64)>, String>;
}

/// Latched angles by trigger count.
#[derive(Debug, Clone, Default)]
pub struct LatchedRing {
    latched: BTreeMap<u64, (f64, f64)>,
    /// The highest trigger count the PLC has reported.
    pub newest: u64,
    /// Ring entries.
    pub capacity: u64,
}

impl LatchedRing {
    /// An empty ring of `capacity` entries.
    pub fn new(capacity: u64) -> Self {
        LatchedRing {
            latched: BTreeMap::new(),
            newest: 0,
            capacity,
        }
    }

    /// Adds the latch of trigger `count`.
    pub fn add(&mut self, count: u64, t_s: f64, theta_deg: f64) {
        self.latched.insert(count, (t_s, theta_deg));
        self.newest = self.newest.max(count);
        while self.latched.len() > 4 * self.capacity as usize {
            self.latched.pop_first();
        }
    }

    /// The PLC time of the first latch after trigger `count` that is still known: a frame
    /// whose latch was overwritten was triggered before it.
    pub fn next_latch_s(&self, count: u64) -> Option<f64> {
        self.latched.range(count + 1..).next().map(|(_, v)| v.0)
    }

    /// Forgets everything (the trigger count restarted).
    pub fn clear(&mut self) {
        self.latched.clear();
        self.newest = 0;
    }
}

impl AnglePairing for LatchedRing {
    fn lookup(
        &mut self,
        frame_id: u64,
        _time_s: Option<f64>,
    ) -> Result<Option<(f64, f64)>, String> {
        if let Some(&v) = self.latched.get(&frame_id) {
            return Ok(Some(v));
        }
        if frame_id <= self.newest {
            let oldest = self.newest.saturating_sub(self.capacity - 1).max(1);
            return Err(format!(
                "frame {frame_id} has no latched angle: the PLC's latch ring holds triggers {oldest}–{} and none is {frame_id}",
                self.newest
            ));
        }
        Ok(None)
    }
}

/// Timestamped angle samples, interpolated linearly.
#[derive(Debug, Clone, Default)]
pub struct Interpolated {
    samples: Vec<AngleSample>,
}

impl Interpolated {
    /// Adds a sample (later than the ones before; an earlier or equal one is ignored).
    pub fn add(&mut self, s: AngleSample) {
        if self.samples.last().is_none_or(|l| s.t_s > l.t_s) {
            self.samples.push(s);
            if self.samples.len() > 100_000 {
                self.samples.drain(..50_000);
            }
        }
    }

    /// The newest sample's time, s.
    pub fn newest_s(&self) -> Option<f64> {
        self.samples.last().map(|s| s.t_s)
    }
}

impl AnglePairing for Interpolated {
    fn lookup(&mut self, frame_id: u64, time_s: Option<f64>) -> Result<Option<(f64, f64)>, String> {
        let Some(t) = time_s else {
            return Err(format!(
                "frame {frame_id} has no timestamp: interpolated pairing needs one"
            ));
        };
        let s = &self.samples;
        match (s.first(), s.last()) {
            (Some(f), _) if t < f.t_s => Err(format!(
                "frame {frame_id} at {t:.6} s is before the PLC's first angle sample ({:.6} s)",
                f.t_s
            )),
            (Some(_), Some(l)) if t <= l.t_s => {
                let i = s.partition_point(|x| x.t_s < t);
                if s[i].t_s == t || i == 0 {
                    return Ok(Some((t, s[i].theta_deg)));
                }
                let (a, b) = (s[i - 1], s[i]);
                let w = (t - a.t_s) / (b.t_s - a.t_s);
                Ok(Some((t, a.theta_deg + w * (b.theta_deg - a.theta_deg))))
            }
            _ => Ok(None),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn latched_exact_missing_and_pending() {
        let mut r = LatchedRing::new(16);
        r.add(5, 1.0, 30.0);
        r.add(7, 1.02, 33.6);
        assert_eq!(r.lookup(5, None).unwrap(), Some((1.0, 30.0)));
        assert_eq!(r.lookup(8, None).unwrap(), None);
        let e = r.lookup(6, None).unwrap_err();
        assert!(e.contains("frame 6 has no latched angle"), "{e}");
    }

    #[test]
    fn interpolation_error_is_the_profiles_curvature() {
        // A servo accelerating at 900°/s² sampled every 2 ms: the linear interpolation's error
        // is at most a·T²/8 = 900 · 4e-6 / 8 = 4.5e-4°.
        let mut p = Interpolated::default();
        for k in 0..100 {
            let t = k as f64 * 2e-3;
            p.add(AngleSample {
                t_s: t,
                theta_deg: 450.0 * t * t,
            });
        }
        let mut worst: f64 = 0.0;
        for k in 0..1000 {
            let t = 0.01 + k as f64 * 1.7e-4;
            let (_, th) = p.lookup(k, Some(t)).unwrap().unwrap();
            worst = worst.max((th - 450.0 * t * t).abs());
        }
        assert!(worst <= 4.5e-4 + 1e-12, "{worst}");
        assert!(worst > 3e-4, "{worst}");
        assert_eq!(p.lookup(1, Some(1.0)).unwrap(), None);
        assert!(p.lookup(1, Some(-1.0)).is_err());
    }
}
