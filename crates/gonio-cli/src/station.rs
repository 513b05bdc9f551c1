//! The station commands' flags (`--strategy`, `--fidelity`, `--recipe`); the batch committed to
//! the results store part by part, the one path of `gonio mount` and `gonio serve`, is
//! [`gonio_sim::station::store`].

use anyhow::Result;
use gonio_core::bound::Bound;
use gonio_sim::station::Fidelity;
pub use gonio_sim::station::store::{MAX_PARTS, PlcStore, Run, Start, Target, prepare, run};
use gonio_station::{Recipe, Strategy};
use std::path::Path;

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
pub fn load_recipe(path: &Path) -> Result<Recipe> {
    gonio_io::formats::recipe::load(path)
}
