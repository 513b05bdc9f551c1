//! One frame's measurement as the eccentricity fit ([`crate::fit`]) and the quality gate
//! ([`crate::quality`]) read it: the servo angle (degrees) and the ring's column (pixels).
//! Plain data below both.
//!
//! ```
//! use gonio_station::Sample;
//! let s = Sample { theta_deg: 90.0, c_px: 512.25 };
//! assert_eq!(s.theta_deg, 90.0);
//! ```

use serde::{Deserialize, Serialize};

/// One frame's measurement: the servo angle and the ring's column.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Sample {
    /// Servo angle at the frame's mid-exposure, degrees.
    pub theta_deg: f64,
    /// The ring's column, pixels.
    pub c_px: f64,
}
