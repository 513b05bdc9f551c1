//! Polygon + autocollimator readings (`shift_deg,start_face,step,reading_arcsec[,repeat]`), the
//! input of `gonio shift-angle` and `gonio joint`.

use super::csv::CsvTable;
use crate::input::Inputs;
use anyhow::{Result, anyhow};
use gonio_calib::shift_angle::{MAX_FACES, Reading, ReadingSet, ShiftAngleError};
use std::path::Path;

/// The readings file's header.
pub const HEADER: &str = "shift_deg,start_face,step,reading_arcsec[,repeat]";

/// Largest repeat number of a reading.
pub const MAX_REPEAT: i64 = 1_000_000;

/// Reads and validates a readings file; errors name the file, line and column.
///
/// # Errors
/// As [`parse`], and the file cannot be read.
pub fn read(inputs: &Inputs, path: &Path, faces: Option<usize>) -> Result<ReadingSet> {
    let table = CsvTable::read(inputs, path)?;
    let rows = rows_of(&table, faces)?;
    // The table (a String per field) is dropped before the set is indexed: with a million
    // readings the two at once were the peak of the whole calibration.
    let name = table.name;
    drop(table.rows);
    into_set(&name, rows)
}

/// Parses readings text; `name` names it in errors.
///
/// # Errors
/// A malformed row, a face or step out of range (or implying more than
/// [`MAX_FACES`] faces), a conflicting duplicate, fewer than 3 faces.
pub fn parse(name: &str, text: &str, faces: Option<usize>) -> Result<ReadingSet> {
    from_table(&CsvTable::parse(name, text)?, faces)
}

/// Checks `--faces` (3 to [`MAX_FACES`]).
///
/// # Errors
/// Out of range.
pub fn check_faces(faces: usize) -> Result<()> {
    if !(3..=MAX_FACES).contains(&faces) {
        return Err(anyhow!(
            "--faces {faces}: expected a polygon of 3 to {MAX_FACES} faces"
        ));
    }
    Ok(())
}

/// Validates a readings table (from a file, or built from an array); errors name the table's
/// lines and columns.
///
/// # Errors
/// As [`parse`].
pub fn from_table(table: &CsvTable, faces: Option<usize>) -> Result<ReadingSet> {
    into_set(&table.name, rows_of(table, faces)?)
}

/// The readings of a validated table, with their lines, and the polygon's face count.
struct Rows {
    readings: Vec<Reading>,
    lines: Vec<u64>,
    faces: usize,
}

/// Validates a table's rows (errors name the table's lines and columns).
fn rows_of(table: &CsvTable, faces: Option<usize>) -> Result<Rows> {
    if let Some(n) = faces {
        check_faces(n)?;
    }
    let c_shift = table.require("shift_deg", HEADER)?;
    let c_face = table.require("start_face", HEADER)?;
    let c_step = table.require("step", HEADER)?;
    let c_value = table.require("reading_arcsec", HEADER)?;
    let c_repeat = table.column("repeat");
    let mut readings = Vec::with_capacity(table.rows.len());
    let mut lines = Vec::with_capacity(table.rows.len());
    let mut max_index = 0i64;
    for (line, f) in &table.rows {
        let shift = table.f64_at(*line, f, c_shift)?;
        if !(0.0..360.0).contains(&shift) {
            return Err(table.error_at(
                *line,
                c_shift,
                format!(
                    "shift {}° is out of range: expected 0 ≤ shift_deg < 360",
                    f[c_shift].trim()
                ),
            ));
        }
        let face = table.int_at(*line, f, c_face)?;
        let step = table.int_at(*line, f, c_step)?;
        for (c, what, v) in [(c_face, "start_face", face), (c_step, "step", step)] {
            if v < 1 {
                return Err(table.error_at(
                    *line,
                    c,
                    format!("{v} is out of range: expected 1 or more"),
                ));
            }
            match faces {
                Some(n) if v > n as i64 => {
                    return Err(table.error_at(
                        *line,
                        c,
                        format!("{v} is out of range: expected 1..={n} (--faces {n})"),
                    ));
                }
                None if v > MAX_FACES as i64 => {
                    return Err(table.error_at(
                        *line,
                        c,
                        format!("{what} {v} implies a {v}-face polygon; at most {MAX_FACES} faces"),
                    ));
                }
                _ => {}
            }
        }
        max_index = max_index.max(face).max(step);
        let repeat = match c_repeat {
            Some(c) => {
                let r = table.int_at(*line, f, c)?;
                if !(1..=MAX_REPEAT).contains(&r) {
                    return Err(table.error_at(
                        *line,
                        c,
                        format!("{r} is out of range: expected 1..={MAX_REPEAT}"),
                    ));
                }
                r as u32
            }
            None => 1,
        };
        readings.push(Reading {
            shift_deg: shift,
            start_face: face as usize,
            step: step as usize,
            repeat,
            value_arcsec: table.f64_at(*line, f, c_value)?,
        });
        lines.push(*line);
    }
    if readings.is_empty() {
        return Err(anyhow!(
            "{}:{}: no readings after the header",
            table.name,
            table.header_line
        ));
    }
    Ok(Rows {
        readings,
        lines,
        faces: faces.unwrap_or(max_index as usize),
    })
}

/// Indexes validated readings; `name` names the table in errors.
fn into_set(name: &str, rows: Rows) -> Result<ReadingSet> {
    let Rows {
        readings,
        lines,
        faces: n,
    } = rows;
    ReadingSet::new(n, readings).map_err(|e| match e {
        ShiftAngleError::ConflictingDuplicate {
            index,
            first,
            first_value,
            value,
            ..
        } => anyhow!(
            "{}:{}: conflicting duplicate: reading {value} for the same shift, start_face, step and repeat as line {} ({first_value}); add a repeat column to keep both",
            name,
            lines[index],
            lines[first]
        ),
        ShiftAngleError::TooFewFaces { faces } => anyhow!(
            "{}: {faces} faces: expected a polygon with at least 3 faces (largest face/step number in the file, or --faces)",
            name
        ),
        e => anyhow!("{name}: {e}"),
    })
}

pub use gonio_calib::shift_angle::{MAX_SHIFTS, shift_range};
