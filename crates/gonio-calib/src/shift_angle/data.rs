//! Readings of the shift-angle method and their validation.

use super::ShiftAngleError;
use std::collections::HashMap;

/// One autocollimator reading.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reading {
    /// Shift angle S of the run, degrees.
    pub shift_deg: f64,
    /// Start face j (1-based): the face at the autocollimator at step 1.
    pub start_face: usize,
    /// Rotation step i (1-based): table angle (i−1)·360°/N + S.
    pub step: usize,
    /// Repeat number (1-based) of this (S, j, i) reading.
    pub repeat: u32,
    /// The autocollimator reading, arcsec.
    pub value_arcsec: f64,
}

impl Reading {
    /// A first (repeat 1) reading.
    pub fn new(shift_deg: f64, start_face: usize, step: usize, value_arcsec: f64) -> Self {
        Reading {
            shift_deg,
            start_face,
            step,
            repeat: 1,
            value_arcsec,
        }
    }
}

/// Most faces of a polygon (real ones have 8 to 72): the unknowns and the normal equations grow
/// with the faces, so a face or step number from a file is checked against this before anything
/// is sized by it.
pub const MAX_FACES: usize = 1000;

/// A shift angle as an exact key: micro-degrees.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ShiftKey(pub i64);

impl ShiftKey {
    /// The key of a shift angle in degrees (rounded to 1 µ°).
    pub fn of(shift_deg: f64) -> Self {
        ShiftKey((shift_deg * 1e6).round() as i64)
    }
}

/// One observation, indexed for the solvers (0-based shift, step, face).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Obs {
    pub s: usize,
    pub i: usize,
    pub j: usize,
    pub value: f64,
}

/// Refuses two shifts whose difference is a multiple of the pitch 360°/N (to 1 µ°): they put
/// the table at the same N angles.
fn same_angles(keys: &[ShiftKey], faces: usize) -> Result<(), ShiftAngleError> {
    let pitch_deg = 360.0 / faces as f64;
    // Each shift's place within one pitch, in µ°; equal places (or places a pitch apart, at
    // the wrap) are the same angles.
    let pitch = pitch_deg * 1e6;
    let mut place: Vec<(f64, i64)> = keys
        .iter()
        .map(|k| ((k.0 as f64).rem_euclid(pitch), k.0))
        .collect();
    place.sort_by(|a, b| a.0.total_cmp(&b.0));
    let n = place.len();
    if n < 2 {
        return Ok(());
    }
    for i in 0..n {
        let (a, b) = (place[i], place[(i + 1) % n]);
        let gap = if i + 1 == n {
            b.0 + pitch - a.0
        } else {
            b.0 - a.0
        };
        if gap < 0.5 {
            let (lo, hi) = (a.1.min(b.1), a.1.max(b.1));
            return Err(ShiftAngleError::SameAngles {
                first_deg: lo as f64 * 1e-6,
                second_deg: hi as f64 * 1e-6,
                pitch_deg,
            });
        }
    }
    Ok(())
}

/// A validated set of readings for an N-faced polygon.
#[derive(Debug, Clone, PartialEq)]
pub struct ReadingSet {
    faces: usize,
    shifts_deg: Vec<f64>,
    pub(crate) obs: Vec<Obs>,
    duplicates_ignored: usize,
}

impl ReadingSet {
    /// Validates readings for an N-faced polygon.
    ///
    /// Identical duplicates (same shift, face, step, repeat and value) are counted and kept once.
    ///
    /// # Errors
    /// [`ShiftAngleError::TooFewFaces`], [`ShiftAngleError::Empty`],
    /// [`ShiftAngleError::OutOfRange`] for a face or step outside 1..=N,
    /// [`ShiftAngleError::NotFinite`], [`ShiftAngleError::ConflictingDuplicate`],
    /// [`ShiftAngleError::ShiftOutOfRange`] for a shift outside [0°, 360°); each names the
    /// reading by its index in `readings`. [`ShiftAngleError::SameAngles`] for two shifts a
    /// multiple of 360°/N apart.
    pub fn new(faces: usize, readings: Vec<Reading>) -> Result<Self, ShiftAngleError> {
        if faces < 3 {
            return Err(ShiftAngleError::TooFewFaces { faces });
        }
        if faces > MAX_FACES {
            return Err(ShiftAngleError::TooManyFaces {
                faces,
                max: MAX_FACES,
            });
        }
        if readings.is_empty() {
            return Err(ShiftAngleError::Empty);
        }
        if let Some((index, r)) = readings
            .iter()
            .enumerate()
            .find(|(_, r)| !(r.shift_deg.is_finite() && (0.0..360.0).contains(&r.shift_deg)))
        {
            return Err(ShiftAngleError::ShiftOutOfRange {
                index,
                shift_deg: r.shift_deg,
            });
        }
        let mut keys: Vec<ShiftKey> = readings.iter().map(|r| ShiftKey::of(r.shift_deg)).collect();
        keys.sort();
        keys.dedup();
        same_angles(&keys, faces)?;
        let shifts_deg: Vec<f64> = keys.iter().map(|k| k.0 as f64 * 1e-6).collect();
        let index_of: HashMap<ShiftKey, usize> =
            keys.iter().enumerate().map(|(i, k)| (*k, i)).collect();
        let mut seen: HashMap<(usize, usize, usize, u32), (usize, f64)> = HashMap::new();
        let mut obs = Vec::with_capacity(readings.len());
        let mut duplicates_ignored = 0;
        for (index, r) in readings.iter().enumerate() {
            for (what, v) in [("start_face", r.start_face), ("step", r.step)] {
                if v < 1 || v > faces {
                    return Err(ShiftAngleError::OutOfRange {
                        index,
                        what,
                        found: v as i64,
                        faces,
                    });
                }
            }
            if !r.value_arcsec.is_finite() {
                return Err(ShiftAngleError::NotFinite {
                    index,
                    value: r.value_arcsec,
                });
            }
            let s = index_of[&ShiftKey::of(r.shift_deg)];
            let key = (s, r.start_face, r.step, r.repeat);
            if let Some(&(first, first_value)) = seen.get(&key) {
                if first_value == r.value_arcsec {
                    duplicates_ignored += 1;
                    continue;
                }
                return Err(ShiftAngleError::ConflictingDuplicate {
                    index,
                    first,
                    shift_deg: shifts_deg[s],
                    start_face: r.start_face,
                    step: r.step,
                    repeat: r.repeat,
                    first_value,
                    value: r.value_arcsec,
                });
            }
            seen.insert(key, (index, r.value_arcsec));
            obs.push(Obs {
                s,
                i: r.step - 1,
                j: r.start_face - 1,
                value: r.value_arcsec,
            });
        }
        Ok(ReadingSet {
            faces,
            shifts_deg,
            obs,
            duplicates_ignored,
        })
    }

    /// Number of polygon faces N.
    pub fn faces(&self) -> usize {
        self.faces
    }

    /// Nominal pitch 360°/N, degrees.
    pub fn pitch_deg(&self) -> f64 {
        360.0 / self.faces as f64
    }

    /// The distinct shift angles, ascending, degrees.
    pub fn shifts_deg(&self) -> &[f64] {
        &self.shifts_deg
    }

    /// Number of readings used.
    pub fn len(&self) -> usize {
        self.obs.len()
    }

    /// Whether there are no readings (never true for a constructed set).
    pub fn is_empty(&self) -> bool {
        self.obs.is_empty()
    }

    /// Identical duplicate readings that were kept once.
    pub fn duplicates_ignored(&self) -> usize {
        self.duplicates_ignored
    }

    /// Table angle of step `i` (1-based) at shift index `s`, degrees in [0, 360).
    pub fn angle_deg(&self, s: usize, step: usize) -> f64 {
        gonio_core::Degrees(self.shifts_deg[s] + (step - 1) as f64 * self.pitch_deg())
            .normalized()
            .0
    }

    /// The start faces (1-based) measured at shift index `s`, ascending.
    pub fn runs(&self, s: usize) -> Vec<usize> {
        let mut r: Vec<usize> = self
            .obs
            .iter()
            .filter(|o| o.s == s)
            .map(|o| o.j + 1)
            .collect();
        r.sort_unstable();
        r.dedup();
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn runs(shifts: &[f64], faces: usize) -> Vec<Reading> {
        let mut v = Vec::new();
        for &s in shifts {
            for j in 1..=faces {
                for i in 1..=faces {
                    v.push(Reading::new(s, j, i, 0.01 * (i * j) as f64));
                }
            }
        }
        v
    }

    #[test]
    fn shifts_are_range_checked() {
        for bad in [1e300, -1.0, 360.0, f64::NAN, f64::INFINITY] {
            let mut r = runs(&[0.0], 3);
            r[4].shift_deg = bad;
            assert!(
                matches!(
                    ReadingSet::new(3, r),
                    Err(ShiftAngleError::ShiftOutOfRange { index: 4, .. })
                ),
                "{bad}"
            );
        }
        assert!(ReadingSet::new(3, runs(&[0.0, 359.999], 3)).is_ok());
    }

    #[test]
    fn shifts_a_pitch_apart_are_refused() {
        // N = 24: pitch 15°; 5° and 20° (and 20° and 35°… , 0° and 345°) give the same angles.
        for pair in [[5.0, 20.0], [0.0, 345.0], [2.5, 182.5], [0.0, 14.9999999]] {
            let e = ReadingSet::new(24, runs(&pair, 24)).unwrap_err();
            assert!(
                matches!(e, ShiftAngleError::SameAngles { .. }),
                "{pair:?}: {e}"
            );
            assert!(e.to_string().contains("pitch 15°"), "{e}");
        }
        assert!(ReadingSet::new(24, runs(&[0.0, 5.0, 10.0, 14.9], 24)).is_ok());
        // A 3-face polygon (the smallest the method allows) is valid.
        assert!(ReadingSet::new(3, runs(&[0.0, 40.0], 3)).is_ok());
    }
}
