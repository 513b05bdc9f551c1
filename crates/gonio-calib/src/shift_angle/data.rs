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
    /// [`ShiftAngleError::NotFinite`], [`ShiftAngleError::ConflictingDuplicate`]. Each names the
    /// reading by its index in `readings`.
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
        let mut keys: Vec<ShiftKey> = readings.iter().map(|r| ShiftKey::of(r.shift_deg)).collect();
        keys.sort();
        keys.dedup();
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
