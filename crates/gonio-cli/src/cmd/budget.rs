//! `gonio budget`: evaluate a GUM uncertainty budget file.

use anyhow::{Result, bail};
use std::path::PathBuf;

/// Arguments of `gonio budget`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Budget file (TOML).
    pub budget: PathBuf,
}

/// Runs `gonio budget`.
pub fn run(_args: Args) -> Result<()> {
    bail!("gonio budget is not implemented yet")
}
