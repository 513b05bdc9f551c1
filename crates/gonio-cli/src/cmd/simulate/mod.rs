//! `gonio simulate …`: the digital twin's instruments, writing readings and ground truth.

pub mod autocollimator;
pub mod axis;
pub mod camera;
pub mod encoder;
pub mod frames;
pub mod selfcal;
pub mod shift_angle;
pub mod station;

use anyhow::Result;
use gonio_cli::output::{OutId, Outputs};
use gonio_io::formats::encoder as encoder_file;
use gonio_sim::EncoderModel;
use std::path::Path;

/// The named scenes on the command line (`simulate frames`, `simulate camera`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SceneArg {
    /// The ring alone: noise and blur only.
    Clean,
    /// A typical grating near its ring: track-border groups, incremental lines, code bars,
    /// dust, vignetting (default).
    Realistic,
    /// Everything at once, close to the ring (several hundred edge components a frame).
    Dense,
    /// A new scene drawn from the whole family for every frame (docs/scenes.md).
    Random,
}

/// What to simulate.
#[derive(Debug, clap::Subcommand)]
pub enum Simulate {
    /// An encoder error model (harmonics + random graduation error), saved as JSON.
    Encoder(encoder::Args),
    /// Rendered camera frames of a rotating, eccentric grating (PNG) with ground truth.
    Frames(frames::Args),
    /// A GigE Vision camera showing a turning, eccentric grating (built with --features genicam).
    Camera(camera::Args),
    /// Polygon + autocollimator readings at shifted start angles.
    ShiftAngle(shift_angle::Args),
    /// One encoder scale read by several heads over full turns (self-calibration readings).
    Selfcal(selfcal::Args),
    /// An ELCOMAT-type autocollimator and polygon answering the serial protocol on a
    /// pseudo-terminal (for `gonio acquire shift-angle`).
    Autocollimator(autocollimator::Args),
    /// A rotary axis with a known error, backlash and repeatability: ISO 230-2 readings and
    /// its true parameters.
    Axis(axis::Args),
    /// The mounting station as its own process: a Modbus TCP PLC and the camera it triggers.
    Station(station::Args),
}

/// Runs `gonio simulate …`.
pub fn run(s: Simulate) -> Result<()> {
    match s {
        Simulate::Encoder(a) => encoder::run(a),
        Simulate::Frames(a) => frames::run(a),
        Simulate::Camera(a) => camera::run(a),
        Simulate::ShiftAngle(a) => shift_angle::run(a),
        Simulate::Selfcal(a) => selfcal::run(a),
        Simulate::Autocollimator(a) => autocollimator::run(a),
        Simulate::Station(a) => station::run(a),
        Simulate::Axis(a) => axis::run(a),
    }
}

/// The files of a simulated calibration lab in `--out`.
struct LabFiles {
    /// `readings.csv`.
    readings: OutId,
    /// `truth.json`.
    truth: OutId,
    /// `encoder.json`.
    encoder: OutId,
}

/// Claims the lab's files in the directory `dir` (new, or empty unless `force`), and loads the
/// encoder from `encoder_file` (default: the built-in model with `seed`).
fn lab(
    out: &mut Outputs,
    dir: &Path,
    force: bool,
    encoder_file: Option<&Path>,
    seed: u64,
) -> Result<(LabFiles, EncoderModel)> {
    out.dir("--out", dir, force)?;
    let files = LabFiles {
        readings: out.file("--out", &dir.join("readings.csv"))?,
        truth: out.file("--out", &dir.join("truth.json"))?,
        encoder: out.file("--out", &dir.join("encoder.json"))?,
    };
    let model = match encoder_file {
        Some(p) => encoder_file::load(out.inputs(), p)?,
        None => EncoderModel::default_with_seed(seed),
    };
    Ok((files, model))
}

/// A comma-separated list of angles in degrees given to `flag` (the whole value `shown` in the
/// message): every item a finite number, or a one-line error naming the item.
fn degrees_list(flag: &str, shown: &str, s: &str) -> anyhow::Result<Vec<f64>> {
    use anyhow::Context;
    s.split(',')
        .map(|p| {
            p.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .with_context(|| {
                    format!(
                        "{flag} {shown:?}: {:?} is not a number of degrees",
                        gonio_core::text::short(p)
                    )
                })
        })
        .collect()
}
