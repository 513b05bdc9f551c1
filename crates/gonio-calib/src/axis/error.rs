//! Errors of the ISO 230-2 evaluation.

use super::data::Direction;
use thiserror::Error;

/// Readings that cannot be evaluated, naming the reading (its 0-based index in input order)
/// or the target.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum AxisError {
    /// No readings at all.
    #[error("no readings")]
    Empty,
    /// A number outside its bound.
    #[error(
        "reading {index}: {what} {} is out of range: expected {expected}",
        gonio_core::bound::Num(*value)
    )]
    OutOfRange {
        /// The reading.
        index: usize,
        /// Which number (`target_deg`, `run`, `deviation_arcsec`, …).
        what: &'static str,
        /// Its value.
        value: f64,
        /// The bound.
        expected: String,
    },
    /// The same target, direction and run twice.
    #[error(
        "reading {index} (target {target_deg}°, direction {}, run {run}) repeats reading {first}",
        direction.sign()
    )]
    Duplicate {
        /// The later reading.
        index: usize,
        /// The earlier one.
        first: usize,
        /// Target, degrees.
        target_deg: f64,
        /// Direction.
        direction: Direction,
        /// Run.
        run: u32,
    },
    /// A target approached from one side while others are approached from both.
    #[error(
        "target {target_deg}°: no approach in the {} direction, while other targets have both: a bidirectional test approaches every target from both sides",
        direction.word()
    )]
    MissingDirection {
        /// The target, degrees.
        target_deg: f64,
        /// The direction without approaches.
        direction: Direction,
    },
    /// A run that the other targets have is missing at a target.
    #[error(
        "target {target_deg}°, {} direction: run {run} is missing (the test has runs {runs})",
        direction.word()
    )]
    MissingRun {
        /// The target, degrees.
        target_deg: f64,
        /// The direction.
        direction: Direction,
        /// The missing run.
        run: u32,
        /// Every run of the test, e.g. `1–5`.
        runs: String,
    },
    /// Fewer than two runs: no standard deviation.
    #[error(
        "{runs} run in each direction: a target's standard deviation needs at least 2 (ISO 230-2's standard test cycle has 5)"
    )]
    TooFewRuns {
        /// Runs found.
        runs: usize,
    },
    /// Fewer than two targets: no positioning error.
    #[error("{targets} target: the positioning errors need at least 2 targets")]
    TooFewTargets {
        /// Targets found.
        targets: usize,
    },
    /// More targets than [`super::MAX_TARGETS`].
    #[error("{targets} targets: at most {max}")]
    TooManyTargets {
        /// Targets found.
        targets: usize,
        /// The limit.
        max: usize,
    },
    /// A target that is not at one of the polygon's faces.
    #[error(
        "reading {index}: target {target_deg}° is not at a face of the {faces}-face polygon (a multiple of its pitch {pitch_deg}° from 0°): is the certificate of the polygon on the axis?"
    )]
    NotAtFace {
        /// The reading.
        index: usize,
        /// Its target, degrees.
        target_deg: f64,
        /// The polygon's faces.
        faces: usize,
        /// Its pitch, degrees.
        pitch_deg: f64,
    },
    /// A face that does not follow the polygon's pitch from the faces before it.
    #[error(
        "reading {index}: face {face} at target {target_deg}°, where reading {first}'s face puts face {expected}: the polygon's faces advance by one every {pitch_deg}° (is the certificate for the polygon on the axis?)"
    )]
    FaceOffTarget {
        /// The reading.
        index: usize,
        /// The face given.
        face: usize,
        /// Its target, degrees.
        target_deg: f64,
        /// The face the first reading's implies.
        expected: usize,
        /// The first reading with a face.
        first: usize,
        /// The pitch, degrees.
        pitch_deg: f64,
    },
    /// A face number outside the polygon.
    #[error("reading {index}: face {face} is out of range: expected 1..={faces}")]
    FaceOutOfRange {
        /// The reading.
        index: usize,
        /// The face given.
        face: i64,
        /// The polygon's faces.
        faces: usize,
    },
    /// The polygon's calibration cannot correct readings.
    #[error("the polygon's calibration: {reason}")]
    BadPolygon {
        /// What is wrong with it.
        reason: String,
    },
    /// The reference's uncertainty budget cannot be evaluated.
    #[error("the reference's uncertainty budget: {reason}")]
    Uncertainty {
        /// What went wrong.
        reason: String,
    },
}
