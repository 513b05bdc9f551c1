//! Errors of the joint calibration.

use crate::selfcal::SelfcalError;
use crate::shift_angle::ShiftAngleError;
use thiserror::Error;

/// An error of the joint calibration.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum JointError {
    /// The polygon readings are invalid on their own (or the polygon-alone fit that estimates
    /// their σ failed).
    #[error("polygon readings: {0}")]
    Polygon(#[from] ShiftAngleError),
    /// The head readings are invalid on their own.
    #[error("head readings: {0}")]
    Heads(#[from] SelfcalError),
    /// A polygon angle does not fall on the encoder grid of the head readings.
    #[error(
        "polygon angle {angle_deg}° (shift {shift_deg}°, step {step}) is not on the encoder grid of the head readings ({positions} positions from {start_deg}°, a step of {step_deg}°): expected shifts that are whole multiples of the step"
    )]
    OffGrid {
        /// The polygon angle, degrees.
        angle_deg: f64,
        /// Its shift, degrees.
        shift_deg: f64,
        /// Its step (1-based).
        step: usize,
        /// Rotation positions per turn NS.
        positions: usize,
        /// First rotation position, degrees.
        start_deg: f64,
        /// Grid step 360°/NS.
        step_deg: f64,
    },
    /// A stated σ is not a positive number.
    #[error("{instrument}: sigma = {sigma_arcsec}: expected a positive number of arcseconds")]
    InvalidSigma {
        /// `polygon` or `heads`.
        instrument: &'static str,
        /// The value given.
        sigma_arcsec: f64,
    },
    /// σ of an instrument is neither stated nor estimable from its own residuals.
    #[error(
        "{instrument}: σ cannot be estimated from its own residuals ({reason}); state it (sigma_{instrument}_arcsec)"
    )]
    SigmaNeeded {
        /// `polygon` or `heads`.
        instrument: &'static str,
        /// Why it cannot be estimated.
        reason: String,
    },
    /// The readings of both instruments together leave unknowns undetermined.
    #[error("the joint readings do not determine {count} unknown(s): {names}")]
    Undetermined {
        /// How many unknowns.
        count: usize,
        /// The first few, e.g. "β_3, α(20°)".
        names: String,
    },
    /// An option is out of range.
    #[error("{name} = {found}: expected {expected}")]
    Option {
        /// The option.
        name: &'static str,
        /// The value given.
        found: String,
        /// What is accepted.
        expected: &'static str,
    },
}
