//! Core types of gonio: angles and units as types, Fourier series and the general harmonic
//! least-squares fit, circle-closure helpers, special functions, the one quantile definition of
//! gonio's reports, bounds of numeric settings with their units, and the shared error kinds.
//!
//! Nothing here does I/O. Every angle that crosses a crate boundary carries its unit in its type
//! ([`Arcsec`], [`Degrees`], [`Radians`]) or in its name (`_arcsec`, `_deg`, `_rad`, `_um`, `_px`).
//!
//! ```
//! use gonio_core::{Arcsec, Degrees};
//! let a = Degrees(1.0 / 3600.0);
//! assert!((Arcsec::from(a).0 - 1.0).abs() < 1e-12);
//! ```
#![deny(missing_docs)]

pub mod angle;
pub mod bound;
pub mod choice;
pub mod closure;
pub mod error;
pub mod fourier;
pub mod harmonic;
pub mod quantile;
pub mod special;
pub mod text;

pub use angle::{
    ARCSEC_PER_DEGREE, ARCSEC_PER_RADIAN, Arcsec, Degrees, Micrometres, Pixels, Radians,
};
pub use error::CoreError;
pub use fourier::{Harmonic, HarmonicSeries};
pub use harmonic::{HarmonicFit, HarmonicFitSpec, HarmonicTerm};
