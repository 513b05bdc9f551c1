//! Calibration of rotary encoders: cross-calibration with a polygon and an autocollimator
//! ([`shift_angle`]), self-calibration with several read heads, and the comparison of results.
//!
//! Every estimator returns its estimates with their covariance (the random part of the
//! uncertainty); `gonio-uncertainty` adds the instrument terms.
#![deny(missing_docs)]

pub mod compare;
pub mod selfcal;
pub mod shift_angle;
