//! Errors of the shift-angle estimators.

use thiserror::Error;

/// An error of the shift-angle method.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum ShiftAngleError {
    /// The polygon has too few faces.
    #[error("{faces} faces: the shift-angle method needs a polygon with at least 3 faces")]
    TooFewFaces {
        /// Faces given.
        faces: usize,
    },
    /// The polygon has more faces than [`crate::shift_angle::MAX_FACES`].
    #[error(
        "{faces} faces: at most {max} faces (a polygon's faces set the size of the least squares)"
    )]
    TooManyFaces {
        /// Faces given.
        faces: usize,
        /// The limit.
        max: usize,
    },
    /// A face or step number is outside 1..=N.
    #[error("reading {index}: {what} {found} is out of range: expected 1..={faces}")]
    OutOfRange {
        /// Index of the reading (0-based, in input order).
        index: usize,
        /// "start_face" or "step".
        what: &'static str,
        /// The number found.
        found: i64,
        /// Number of faces N.
        faces: usize,
    },
    /// A reading is not a finite number.
    #[error("reading {index}: value {value} is not finite")]
    NotFinite {
        /// Index of the reading.
        index: usize,
        /// The value.
        value: f64,
    },
    /// Two readings for the same shift, face, step and repeat disagree.
    #[error(
        "reading {index} (shift {shift_deg}°, start_face {start_face}, step {step}, repeat {repeat}) conflicts with reading {first}: {first_value} vs {value}"
    )]
    ConflictingDuplicate {
        /// Index of the later reading.
        index: usize,
        /// Index of the first reading with the same key.
        first: usize,
        /// Shift, degrees.
        shift_deg: f64,
        /// Start face.
        start_face: usize,
        /// Step.
        step: usize,
        /// Repeat number.
        repeat: u32,
        /// The first value, arcsec.
        first_value: f64,
        /// The conflicting value, arcsec.
        value: f64,
    },
    /// A shift angle is not finite or outside [0°, 360°).
    #[error("reading {index}: shift {shift_deg}° is out of range: expected 0 ≤ shift < 360°")]
    ShiftOutOfRange {
        /// Index of the reading.
        index: usize,
        /// The shift, degrees.
        shift_deg: f64,
    },
    /// Two shifts differ by a multiple of the pitch 360°/N: they put the table at the same
    /// angles, and each angle would be calibrated twice with two corrections.
    #[error(
        "shifts {first_deg}° and {second_deg}° differ by a multiple of the pitch {pitch_deg}° (360°/N): they calibrate the same angles; give each set of angles once (repeat a shift's readings with the repeat column instead)"
    )]
    SameAngles {
        /// The smaller shift, degrees.
        first_deg: f64,
        /// The larger shift, degrees.
        second_deg: f64,
        /// The pitch 360°/N, degrees.
        pitch_deg: f64,
    },
    /// No readings at all.
    #[error("no readings")]
    Empty,
    /// The readings leave some unknowns undetermined.
    #[error("the readings do not determine {count} unknown(s): {names}")]
    Undetermined {
        /// How many output quantities are undetermined.
        count: usize,
        /// Their names (the first few), e.g. "β_3, α(20°) [shift 5°, step 2]".
        names: String,
    },
    /// The paper's algorithm lacks data it needs.
    #[error("the paper's algorithm needs {needs}; use --method least-squares for incomplete data")]
    PaperNeeds {
        /// What is missing.
        needs: String,
    },
    /// The given σ is not a positive number.
    #[error("sigma = {sigma_arcsec}: expected a positive number of arcseconds")]
    InvalidSigma {
        /// The value given.
        sigma_arcsec: f64,
    },
}
