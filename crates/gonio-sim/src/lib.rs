//! The digital twin of gonio: simulated instruments that produce the same readings a lab's
//! hardware would, with their ground truth, for every estimator to be tested against.
//!
//! - [`axis`]: a rotary axis under an ISO 230-2 test: systematic error, backlash and
//!   repeatability, with its true parameters.
//! - [`encoder`]: an encoder's angle error (harmonics + random graduation error with circle
//!   closure), saved to and loaded from a JSON model file so every simulator calibrates the
//!   same encoder.
//! - [`selfcal`]: one scale read by several heads over full turns (Hsieh et al., 2022, §2.3).
//! - [`joint`]: one encoder on both rigs, for the joint calibration.
//! - [`shift_angle`]: a polygon on the encoder's table read by an autocollimator at shifted start
//!   angles (Hsieh et al., 2022, §2.2).
//!
//! Every simulation takes a seed; the same seed gives the same numbers, bit for bit
//! (ChaCha8 streams, no global state).
#![deny(missing_docs)]

pub mod axis;
pub mod encoder;
pub mod error;
pub mod frames;
pub mod joint;
pub mod selfcal;
pub mod shift_angle;
pub mod station;

pub use encoder::{EncoderModel, Graduation};
pub use error::SimError;

/// Independent stream `n` of the ChaCha8 generator seeded with `seed`: each random part of a
/// simulation draws from its own stream, so changing one part leaves the others' draws unchanged.
pub(crate) fn rng_stream(seed: u64, n: u64) -> rand_chacha::ChaCha8Rng {
    use rand::SeedableRng;
    let mut r = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    r.set_stream(n);
    r
}
