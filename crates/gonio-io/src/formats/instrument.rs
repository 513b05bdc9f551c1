//! Instrument files (`--instrument`): the terms of a GUM budget combined with an estimator's
//! random part (`gonio_uncertainty::instrument`).

use anyhow::{Result, anyhow};
use gonio_calib::certificate::Instrument;
use gonio_uncertainty::instrument::InstrumentFile;
use std::path::Path;

/// Loads `--instrument` (or no terms), with `--coverage` overriding the file's p.
pub fn load(path: Option<&Path>, coverage: Option<f64>) -> Result<Instrument> {
    let inst = match path {
        Some(p) => {
            let bytes = crate::input::read_bytes(p, gonio_uncertainty::limits::MAX_FILE_BYTES)?;
            let file =
                InstrumentFile::parse_bytes(&bytes).map_err(|e| anyhow!("{}:{e}", p.display()))?;
            Instrument::new(file, Some(p.display().to_string()))
        }
        None => Instrument::default(),
    };
    match coverage {
        Some(c) => inst
            .with_coverage(c)
            .map_err(|e| anyhow!("--coverage {c}: {e}")),
        None => Ok(inst),
    }
}
