//! `gonio simulate …`: the digital twin's instruments, writing readings and ground truth.

pub mod encoder;
pub mod frames;
pub mod selfcal;
pub mod shift_angle;

use anyhow::Result;

/// What to simulate.
#[derive(Debug, clap::Subcommand)]
pub enum Simulate {
    /// An encoder error model (harmonics + random graduation error), saved as JSON.
    Encoder(encoder::Args),
    /// Rendered camera frames of a rotating, eccentric grating (PNG) with ground truth.
    Frames(frames::Args),
    /// Polygon + autocollimator readings at shifted start angles.
    ShiftAngle(shift_angle::Args),
    /// One encoder scale read by several heads over full turns (self-calibration readings).
    Selfcal(selfcal::Args),
}

/// Runs `gonio simulate …`.
pub fn run(s: Simulate) -> Result<()> {
    match s {
        Simulate::Encoder(a) => encoder::run(a),
        Simulate::Frames(a) => frames::run(a),
        Simulate::ShiftAngle(a) => shift_angle::run(a),
        Simulate::Selfcal(a) => selfcal::run(a),
    }
}
