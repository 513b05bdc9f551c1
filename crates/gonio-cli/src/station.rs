//! The station commands' flags (`--strategy`, `--fidelity`, `--recipe`, `--parts`); the twin's
//! batch committed to the results store part by part, the one path of `gonio mount --sim` and
//! `gonio serve --station sim`, is `gonio_sim::station::stored`.

use anyhow::Result;
use gonio_core::bound::Bound;
use gonio_sim::station::stored::{self, Prepared};
pub use gonio_sim::station::stored::{Run, Start, Target};
use gonio_sim::station::{BatchConfig, BatchReport, Fidelity, PartDone};
use gonio_station::{Recipe, Strategy};
use std::path::Path;

/// Opens the store and starts the batch in it, or finds the batch to resume
/// ([`stored::prepare`]).
pub fn prepare(cfg: &BatchConfig, seed: u64, t: &Target<'_>) -> Result<Start> {
    Ok(stored::prepare(cfg, seed, t)?)
}

/// Runs the prepared batch, each part committed as it finishes ([`stored::run`]).
pub fn run(
    p: Prepared,
    cfg: &BatchConfig,
    seed: u64,
    run: Run<'_>,
    on_part: &mut dyn FnMut(&PartDone, Option<i64>),
) -> Result<BatchReport> {
    Ok(stored::run(p, cfg, seed, run, on_part)?)
}

/// Most parts in one batch: one limit for `gonio mount` and `gonio serve --station`.
pub const MAX_PARTS: usize = 1_000_000;

/// The station's name for its records when `--station-name` is not given: `sim` for the
/// simulated station in this process, this machine's host name for a station through its PLC
/// (`station` when the host has no name): never `sim` for a station on the wire.
pub fn station_name(given: Option<&str>, in_process_twin: bool) -> String {
    match given {
        Some(name) => name.to_string(),
        None if in_process_twin => "sim".into(),
        None => host_name().unwrap_or_else(|| "station".into()),
    }
}

/// This machine's host name.
fn host_name() -> Option<String> {
    #[cfg(target_os = "linux")]
    let name = rustix::system::uname()
        .nodename()
        .to_string_lossy()
        .into_owned();
    #[cfg(not(target_os = "linux"))]
    let name = std::env::var("HOSTNAME")
        .or_else(|_| std::env::var("COMPUTERNAME"))
        .unwrap_or_default();
    let name = name.trim();
    (!name.is_empty()).then(|| name.to_string())
}
/// `--parts`: parts in one batch.
pub const PARTS: Bound = Bound::new(1.0, MAX_PARTS as f64, "parts");

/// Push strategy on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum StrategyArg {
    /// The station of Yu et al., 2024: extreme-point fit, push by e.
    Paper,
    /// Least-squares fit, push by e.
    LeastSquares,
    /// Least squares + push model + learned gain and angle offset.
    Learned,
    /// Push under live-baseline feedback (the default of `gonio mount`).
    Live,
}

impl From<StrategyArg> for Strategy {
    fn from(s: StrategyArg) -> Self {
        match s {
            StrategyArg::Paper => Strategy::Paper,
            StrategyArg::LeastSquares => Strategy::LeastSquares,
            StrategyArg::Learned => Strategy::Learned,
            StrategyArg::Live => Strategy::Live,
        }
    }
}

/// Frame fidelity on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum FidelityArg {
    /// Ring column from the geometry plus detector noise.
    Fast,
    /// Frames rendered and run through the real detector.
    Frames,
}

impl From<FidelityArg> for Fidelity {
    fn from(f: FidelityArg) -> Self {
        match f {
            FidelityArg::Fast => Fidelity::Fast,
            FidelityArg::Frames => Fidelity::Frames,
        }
    }
}

/// Reads a recipe file; errors name the file, line and column.
pub fn load_recipe(inputs: &gonio_io::input::Inputs, path: &Path) -> Result<Recipe> {
    gonio_io::formats::recipe::load(inputs, path)
}
