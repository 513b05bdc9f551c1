//! Calibration of rotary encoders: cross-calibration with a polygon and an autocollimator
//! ([`shift_angle`], the shift-angle method of Hsieh et al., 2022), self-calibration with several
//! read heads ([`selfcal`]), the [`certificate`] every method's result becomes, and the
//! comparison of two certificates ([`compare`]); rotary axes tested to ISO 230-2 with the same
//! polygon and autocollimator ([`axis`]).
//!
//! Every estimator returns its estimates with their covariance (the random part of the
//! uncertainty); [`certificate`] adds the instrument terms (through `gonio-uncertainty`) in one
//! place for every method.
#![deny(missing_docs)]

pub mod axis;
pub mod certificate;
pub mod compare;
pub mod joint;
pub mod selfcal;
pub mod shift_angle;
