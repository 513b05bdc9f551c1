//! The automatic grating mounting station (Yu et al., 2024, §2–3): the eccentricity fit, the
//! hardware traits, and the controller that runs autofocus → measure → align → approach → push →
//! verify.
//!
//! - [`fit`]: e and θ_max from one turn's ring columns, the seed's extreme-point method
//!   ([`spline`]) and the default robust least-squares sinusoid.
//! - [`interval`]: mid-exposure angle stamping from the servo's angle log; the frame-interval
//!   error ε = e(1 − cos(v/FPS)) as a planning helper.
//! - [`hal`]: small fallible traits for the servo, camera, focus drive, push rod and clock.
//! - [`camera`]: [`DetectorCamera`], a frame source with the streaming detector behind it: the
//!   station's camera, the one typed path from a frame to a push.
//! - [`quality`]: the quality gate on every turn: may the station push on this measurement?
//! - [`ring`]: the ring's roundness carried from a full turn to the part's later, shorter turns.
//! - [`recipe`]: per-grating-type settings (TOML).
//! - [`strategy`]: the push strategies, the live-feedback loop, the push model's prediction
//!   and what is learned from each push.
//! - [`controller`]: the mounting sequence, one part at a time, pushing only on trusted turns.
//! - [`record`]: what is recorded about every part (turns, pushes, verdicts, reasons, times);
//!   [`summary`]: a batch's summary, the same sums for the twin's parts and the wire's.
//! - [`turn`]: one measuring turn from its frames and angle log (the controller's and the
//!   replay's one code path).
//! - [`observe`]: the station's events as they happen, for a live view (no-op by default).
//! - [`published`]: the figures of Yu et al., 2024 every batch is compared with.
//! - [`tap`]: each frame as the station's camera saw it (pixels and the detector's result), for
//!   a recorder and the live thumbnail.
//!
//! ```
//! use gonio_station::interval::frame_interval_error_um;
//! // Yu et al., 2024, §3: 500 µm at 180°/s and 100 fps → 0.25 µm.
//! assert!((frame_interval_error_um(500.0, 180.0, 100.0) - 0.25).abs() < 0.005);
//! ```
#![deny(missing_docs)]

pub mod camera;
pub mod controller;
pub mod error;
pub mod fit;
pub mod hal;
pub mod interval;
pub mod observe;
pub mod published;
pub mod quality;
pub mod recipe;
pub mod record;
pub mod replay;
pub mod ring;
pub mod sample;
pub mod spline;
pub mod strategy;
pub mod summary;
pub mod tap;
pub mod turn;

pub use camera::{DetectorCamera, DetectorCameraError, RingReading};
pub use controller::{Controller, Devices, Trusted};
pub use error::StationError;
pub use fit::{EccentricityFit, FitMethod, FitOptions, Sample};
pub use quality::{QualityLimits, QualitySettings, QualityVerdict};
pub use recipe::{DeviceErrorPolicy, Recipe};
pub use record::{PartRecord, PartResult};
pub use strategy::Strategy;
