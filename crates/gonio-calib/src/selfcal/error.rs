//! Errors of self-calibration.

use thiserror::Error;

/// An error from self-calibration.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum SelfcalError {
    /// The head arrangement is invalid.
    #[error("heads: {message}")]
    Heads {
        /// What was wrong and what was expected.
        message: String,
    },
    /// No turn of readings was given.
    #[error("no readings: expected at least one turn")]
    NoReadings,
    /// A turn has the wrong number of difference channels for the heads.
    #[error(
        "turn {turn}: expected {expected} difference columns (heads 2..{heads}), found {found}"
    )]
    ChannelCount {
        /// 1-based turn.
        turn: usize,
        /// Channels expected (M − 1).
        expected: usize,
        /// Number of heads M.
        heads: usize,
        /// Channels found.
        found: usize,
    },
    /// A channel's length differs from the number of positions.
    #[error(
        "turn {turn}, head {head}: expected {expected} values (one per position), found {found}"
    )]
    ChannelLength {
        /// 1-based turn.
        turn: usize,
        /// 1-based head number.
        head: usize,
        /// Positions in the turn.
        expected: usize,
        /// Values found.
        found: usize,
    },
    /// Too few rotation positions.
    #[error("turn {turn}: expected at least {expected} positions, found {found}")]
    TooFewPositions {
        /// 1-based turn.
        turn: usize,
        /// Minimum needed.
        expected: usize,
        /// Positions given.
        found: usize,
    },
    /// Positions are not equally spaced over one full turn.
    #[error(
        "turn {turn}, position {index}: found {found_deg}°, expected {expected_deg}° (NS positions must be equally spaced by 360°/NS over one turn)"
    )]
    Spacing {
        /// 1-based turn.
        turn: usize,
        /// 0-based index of the position in the turn.
        index: usize,
        /// The position given.
        found_deg: f64,
        /// The position expected.
        expected_deg: f64,
    },
    /// A value is NaN or infinite.
    #[error("turn {turn}, head {head}, position {index}: expected a finite number, found {value}")]
    NotFinite {
        /// 1-based turn.
        turn: usize,
        /// 1-based head number (1 for the position column).
        head: usize,
        /// 0-based index of the position.
        index: usize,
        /// The value.
        value: f64,
    },
    /// The method needs equally spaced head sets and the arrangement has none.
    #[error("method eda: {message}")]
    NoEqualDivision {
        /// Explanation.
        message: String,
    },
    /// A reference head index is out of range, or the list is empty.
    #[error("reference heads: {message}")]
    Reference {
        /// Explanation.
        message: String,
    },
}
