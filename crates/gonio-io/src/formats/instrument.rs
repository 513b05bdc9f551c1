//! Instrument files (`--instrument`): the terms of a GUM budget combined with an estimator's
//! random part (`gonio_uncertainty::instrument`), at most
//! `gonio_uncertainty::limits::MAX_FILE_BYTES` (16 MiB).

use super::source::Document;
use crate::input::Inputs;
use anyhow::{Result, anyhow};
use gonio_calib::certificate::Instrument;
use gonio_uncertainty::instrument::InstrumentFile;
use gonio_uncertainty::limits::MAX_FILE_BYTES;
use std::path::{Path, PathBuf};

/// Loads `--instrument` (or no terms), with `--coverage` overriding the file's p.
///
/// # Errors
/// As [`from_document`].
pub fn load(inputs: &Inputs, path: Option<&Path>, coverage: Option<f64>) -> Result<Instrument> {
    let doc = path.map(|p| Document::File(PathBuf::from(p)));
    from_document(inputs, doc.as_ref(), coverage)
}

/// The instrument terms of a file or a text (or none), with `coverage` (`--coverage`)
/// overriding the file's p.
///
/// # Errors
/// The file cannot be read or is larger than 16 MiB; a syntax error or a value out of range
/// (`NAME:LINE:COL: …`); a coverage probability outside (0, 1) (`--coverage …`).
pub fn from_document(
    inputs: &Inputs,
    doc: Option<&Document>,
    coverage: Option<f64>,
) -> Result<Instrument> {
    let inst = match doc {
        Some(d) => {
            let bytes = d.bytes(inputs, MAX_FILE_BYTES)?;
            let name = d.name();
            let file = InstrumentFile::parse_bytes(&bytes).map_err(|e| anyhow!("{name}:{e}"))?;
            Instrument::new(file, Some(name))
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
