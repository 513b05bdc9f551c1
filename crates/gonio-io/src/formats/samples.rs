//! One turn's eccentricity samples (`theta_deg,c_px`), the input of `gonio eccentricity`.

use super::csv::CsvTable;
use anyhow::{Result, anyhow};
use gonio_station::StationError;
use gonio_station::fit::{Sample, validate};

/// The samples of one turn with the CSV line of each.
#[derive(Debug)]
pub struct Samples {
    /// The table read.
    pub table: CsvTable,
    /// The samples, in file order.
    pub samples: Vec<Sample>,
}

impl Samples {
    /// The CSV line of sample `i` (the header's line when out of range).
    pub fn line_of(&self, i: usize) -> u64 {
        self.table
            .rows
            .get(i)
            .map_or(self.table.header_line, |r| r.0)
    }
}

/// Parses and validates the samples (angles increasing, finite values, enough of them).
///
/// # Errors
/// Located: a missing column, a bad number, angles not increasing, too few samples.
pub fn from_table(t: CsvTable) -> Result<Samples> {
    let expected = "theta_deg,c_px";
    let ct = t.require("theta_deg", expected)?;
    let cc = t.require("c_px", expected)?;
    let mut samples = Vec::with_capacity(t.rows.len());
    for (line, f) in &t.rows {
        samples.push(Sample {
            theta_deg: t.f64_at(*line, f, ct)?,
            c_px: t.f64_at(*line, f, cc)?,
        });
    }
    let line_of = |i: usize| t.rows.get(i).map_or(t.header_line, |r| r.0);
    if let Err(e) = validate(&samples) {
        return Err(match e {
            StationError::NotIncreasing { index, .. } => t.error_at(
                line_of(index),
                ct,
                format!("{e}: angles must increase within a turn"),
            ),
            StationError::NotFinite { index, what, .. } => {
                t.error_at(line_of(index), if what == "c_px" { cc } else { ct }, e)
            }
            StationError::TooFewSamples { .. } => {
                let last = t.rows.last().map_or(t.header_line, |r| r.0);
                anyhow!("{}:{}: {e}", t.name, last)
            }
            other => anyhow!("{}: {other}", t.name),
        });
    }
    Ok(Samples { table: t, samples })
}

/// Parses samples text; `name` names it in errors.
///
/// # Errors
/// As [`from_table`].
pub fn parse(name: &str, text: &str) -> Result<Samples> {
    from_table(CsvTable::parse(name, text)?)
}
