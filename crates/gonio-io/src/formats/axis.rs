//! Readings of a rotary axis tested to ISO 230-2, the input of `gonio axis`:
//! `target_deg,direction,run,deviation_arcsec`, one approach a row (`direction` `+` or `-`,
//! `deviation_arcsec` the position reached less the target), or `reading_arcsec` instead of the
//! deviation for an autocollimator's readings of a polygon, corrected by the polygon's
//! calibration (`--polygon`); an optional `face` column names the face at the autocollimator
//! (default: face 1 at 0°). `#` comments, `-` for standard input; errors name the file, line and
//! column.
//!
//! ```
//! use gonio_io::formats::axis;
//! let text = "target_deg,direction,run,deviation_arcsec\n0,+,1,0.5\n0,x,2,0.5\n";
//! let e = axis::parse("a.csv", text, None).unwrap_err();
//! assert!(e.to_string().starts_with("a.csv:3:2: column 'direction'"), "{e}");
//! ```

use super::csv::CsvTable;
use anyhow::{Result, anyhow};
use gonio_calib::axis::TargetKey;
use gonio_calib::axis::{
    AxisError, AxisInput, AxisReading, AxisResult, Direction, FaceReading, MAX_DEVIATION_ARCSEC,
    MAX_RUNS, MAX_TARGET_DEG, Polygon, analyse,
};
use gonio_calib::certificate::{Certificate, Instrument};
use gonio_core::bound::Num;
use std::path::Path;

/// The readings file's header.
pub const HEADER: &str =
    "target_deg,direction,run,deviation_arcsec (or reading_arcsec with --polygon; optional face)";

/// Parsed readings, with the line of each.
#[derive(Debug, Clone)]
pub struct AxisFile {
    /// The file's name as given.
    pub name: String,
    /// Deviations, or readings with their polygon.
    pub input: AxisInput,
    /// The line of every reading, in input order.
    pub lines: Vec<u64>,
    /// The columns, 1-based.
    columns: Columns,
    /// The header's line.
    header_line: u64,
}

/// The 1-based columns of a readings file.
#[derive(Debug, Clone, Copy)]
struct Columns {
    target: usize,
    run: usize,
    value: usize,
    face: Option<usize>,
}

/// Reads readings and, for `reading_arcsec`, the polygon's certificate; evaluates them with the
/// reference instrument's terms. Errors name the file, line and column.
///
/// # Errors
/// As [`parse`], [`polygon`] and [`AxisFile::analyse`]; a file that cannot be read.
pub fn evaluate(
    inputs: &crate::input::Inputs,
    path: &Path,
    polygon_cert: Option<&Path>,
    instrument: &Instrument,
) -> Result<AxisResult> {
    let poly = polygon_cert
        .map(|p| {
            let cert = super::certificate::load(inputs, p)?;
            polygon(&cert, &p.display().to_string())
        })
        .transpose()?;
    let table = CsvTable::read(inputs, path)?;
    from_table(&table, poly)?.analyse(instrument)
}

/// The polygon of a certificate (its pitch deviations), named `name`.
///
/// # Errors
/// A certificate without a polygon (self-calibration), or pitch deviations that cannot correct
/// readings (not faces 1…N once each, a value or u missing).
pub fn polygon(cert: &Certificate, name: &str) -> Result<Polygon> {
    let Some(pitch) = cert.pitch_deviations() else {
        return Err(anyhow!(
            "{name}: a {} certificate has no polygon: --polygon takes the certificate of a shift-angle or joint calibration",
            cert.method
        ));
    };
    let n = pitch.len();
    let mut beta = vec![f64::NAN; n];
    let mut u = vec![f64::NAN; n];
    for p in pitch {
        if p.face < 1 || p.face > n || !beta[p.face - 1].is_nan() {
            return Err(anyhow!(
                "{name}: pitch_deviations: face {} of {n}: expected faces 1 to {n}, each once",
                p.face
            ));
        }
        beta[p.face - 1] = p.value_arcsec;
        u[p.face - 1] = p.u_arcsec;
    }
    Polygon::new(&beta, &u, cert.uncertainty.random_dof, name).map_err(|e| anyhow!("{name}: {e}"))
}

/// Parses readings text; `name` names it in errors; `polygon` corrects `reading_arcsec`.
///
/// # Errors
/// A malformed row or a number out of its bound (located); `reading_arcsec` without a polygon,
/// `deviation_arcsec` with one, both or neither column.
pub fn parse(name: &str, text: &str, polygon: Option<Polygon>) -> Result<AxisFile> {
    from_table(&CsvTable::parse(name, text)?, polygon)
}

fn from_table(table: &CsvTable, polygon: Option<Polygon>) -> Result<AxisFile> {
    let name = &table.name;
    let c_target = table.require("target_deg", HEADER)?;
    let c_dir = table.require("direction", HEADER)?;
    let c_run = table.require("run", HEADER)?;
    let c_face = table.column("face");
    let (c_value, readings) = match (
        table.column("deviation_arcsec"),
        table.column("reading_arcsec"),
        polygon.is_some(),
    ) {
        (Some(_), Some(_), _) => {
            return Err(anyhow!(
                "{name}:{}: both deviation_arcsec and reading_arcsec: give one",
                table.header_line
            ));
        }
        (Some(_), None, true) => {
            return Err(anyhow!(
                "{name}:{}: --polygon corrects an autocollimator's readings (a reading_arcsec column); this file has deviation_arcsec, already deviations",
                table.header_line
            ));
        }
        (None, Some(_), false) => {
            return Err(anyhow!(
                "{name}:{}: reading_arcsec: an autocollimator's readings become deviations with the polygon's calibration: give --polygon CERT.json (or a deviation_arcsec column)",
                table.header_line
            ));
        }
        (Some(c), None, false) => (c, false),
        (None, Some(c), true) => (c, true),
        (None, None, _) => {
            // The column is missing: its error names the header.
            table.require("deviation_arcsec", HEADER)?;
            return Err(anyhow!("{name}: no deviation_arcsec column"));
        }
    };
    let mut deviations = Vec::new();
    let mut rows = Vec::new();
    let mut lines = Vec::with_capacity(table.rows.len());
    for (line, f) in &table.rows {
        let target = table.f64_at(*line, f, c_target)?;
        if target.abs() > MAX_TARGET_DEG {
            return Err(table.error_at(
                *line,
                c_target,
                format!(
                    "{}° is out of range: expected −{MAX_TARGET_DEG} to {MAX_TARGET_DEG} degrees",
                    Num(target)
                ),
            ));
        }
        let direction = Direction::parse(&f[c_dir]).ok_or_else(|| {
            table.error_at(
                *line,
                c_dir,
                format!(
                    "expected + (positive) or - (negative), found {:?}",
                    gonio_core::text::short(&f[c_dir])
                ),
            )
        })?;
        let run = table.int_at(*line, f, c_run)?;
        if !(1..=i64::from(MAX_RUNS)).contains(&run) {
            return Err(table.error_at(
                *line,
                c_run,
                format!("{run} is out of range: expected 1 to {MAX_RUNS}"),
            ));
        }
        let value = table.f64_at(*line, f, c_value)?;
        if value.abs() > MAX_DEVIATION_ARCSEC {
            return Err(table.error_at(
                *line,
                c_value,
                format!("{} is out of range: expected −{MAX_DEVIATION_ARCSEC} to {MAX_DEVIATION_ARCSEC} arcsec", Num(value)),
            ));
        }
        let face = c_face.map(|c| table.int_at(*line, f, c)).transpose()?;
        if let (Some(face), Some(p), Some(c)) = (face, &polygon, c_face)
            && !(1..=p.faces() as i64).contains(&face)
        {
            return Err(table.error_at(
                *line,
                c,
                format!(
                    "face {face} is out of range: the polygon has {} faces",
                    p.faces()
                ),
            ));
        }
        let run = run as u32;
        if readings {
            rows.push(FaceReading {
                target_deg: target,
                direction,
                run,
                reading_arcsec: value,
                face,
            });
        } else {
            deviations.push(AxisReading {
                target_deg: target,
                direction,
                run,
                deviation_arcsec: value,
            });
        }
        lines.push(*line);
    }
    if lines.is_empty() {
        return Err(anyhow!(
            "{name}:{}: no readings after the header",
            table.header_line
        ));
    }
    let input = match polygon {
        Some(polygon) if readings => AxisInput::Readings { rows, polygon },
        _ => AxisInput::Deviations(deviations),
    };
    Ok(AxisFile {
        name: name.clone(),
        input,
        lines,
        columns: Columns {
            target: c_target + 1,
            run: c_run + 1,
            value: c_value + 1,
            face: c_face.map(|c| c + 1),
        },
        header_line: table.header_line,
    })
}

impl AxisFile {
    /// Evaluates the readings with the reference instrument's terms; an error names the file
    /// and, where it is about one reading, its line.
    ///
    /// # Errors
    /// The [`AxisError`]s of `gonio_calib::axis::analyse`.
    pub fn analyse(&self, instrument: &Instrument) -> Result<AxisResult> {
        analyse(&self.input, instrument).map_err(|e| self.locate(e))
    }

    /// The index of the first reading at `target_deg` (from `direction`, if given).
    fn first_at(&self, target_deg: f64, direction: Option<Direction>) -> Option<usize> {
        let key = TargetKey::of(target_deg);
        let at = |t: f64, d: Direction| {
            TargetKey::of(t) == key && direction.is_none_or(|want| want == d)
        };
        match &self.input {
            AxisInput::Deviations(r) => r.iter().position(|r| at(r.target_deg, r.direction)),
            AxisInput::Readings { rows, .. } => {
                rows.iter().position(|r| at(r.target_deg, r.direction))
            }
        }
    }

    fn locate(&self, e: AxisError) -> anyhow::Error {
        let name = &self.name;
        let c = self.columns;
        let line = |i: usize| self.lines.get(i).copied().unwrap_or(0);
        // A reading's line; for what a target lacks, the first reading at that target.
        let at_target =
            |t: f64, d: Option<Direction>| self.first_at(t, d).map_or(self.header_line, line);
        match &e {
            AxisError::Duplicate {
                index,
                first,
                target_deg,
                direction,
                run,
            } => anyhow!(
                "{name}:{}:{}: target {target_deg}°, direction {}, run {run} again (first on line {}): each approach once",
                line(*index),
                c.run,
                direction.sign(),
                line(*first)
            ),
            AxisError::NotAtFace { index, .. } => {
                anyhow!("{name}:{}:{}: {e}", line(*index), c.target)
            }
            AxisError::FaceOutOfRange { index, .. } => {
                anyhow!("{name}:{}:{}: {e}", line(*index), c.face.unwrap_or(1))
            }
            AxisError::FaceOffTarget {
                index,
                face,
                target_deg,
                expected,
                first,
                pitch_deg,
            } => anyhow!(
                "{name}:{}:{}: face {face} at target {target_deg}°, where line {}'s face puts face {expected}: the polygon's faces advance by one every {pitch_deg}° (is the certificate for the polygon on the axis?)",
                line(*index),
                c.face.unwrap_or(1),
                line(*first)
            ),
            AxisError::OutOfRange {
                index,
                what,
                value,
                expected,
            } => {
                let (col, what) = match *what {
                    "target_deg" => (c.target, "target_deg"),
                    "run" => (c.run, "run"),
                    // With a polygon, the deviation is the reading less its face's term.
                    _ if matches!(self.input, AxisInput::Readings { .. }) => {
                        (c.value, "reading_arcsec less the polygon's term")
                    }
                    _ => (c.value, "deviation_arcsec"),
                };
                anyhow!(
                    "{name}:{}:{col}: {what} {} is out of range: expected {expected}",
                    line(*index),
                    Num(*value)
                )
            }
            AxisError::MissingRun {
                target_deg,
                direction,
                ..
            } => anyhow!(
                "{name}:{}:{}: {e}",
                at_target(*target_deg, Some(*direction)),
                c.run
            ),
            AxisError::MissingDirection { target_deg, .. } => {
                anyhow!("{name}:{}:{}: {e}", at_target(*target_deg, None), c.target)
            }
            AxisError::TooFewRuns { .. } => {
                anyhow!("{name}:{}:{}: {e}", self.header_line, c.run)
            }
            AxisError::TooFewTargets { .. } => {
                anyhow!("{name}:{}:{}: {e}", self.header_line, c.target)
            }
            _ => anyhow!("{name}: {e}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const OK: &str = "# an axis\ntarget_deg,direction,run,deviation_arcsec\n\
        0,+,1,1.0\n0,+,2,1.2\n90,+,1,2.0\n90,+,2,2.4\n";

    #[test]
    fn a_file_evaluates_and_errors_are_located() {
        let doc = parse("a.csv", OK, None)
            .unwrap()
            .analyse(&Instrument::default())
            .unwrap();
        assert!((doc.parameters.e_up.unwrap() - 1.1).abs() < 1e-12);
        let e = |text: &str| {
            parse("a.csv", text, None)
                .and_then(|f| f.analyse(&Instrument::default()))
                .unwrap_err()
                .to_string()
        };
        assert_eq!(
            e(&format!("{OK}90,+,2,2.5\n")),
            "a.csv:7:3: target 90°, direction +, run 2 again (first on line 6): each approach once"
        );
        assert_eq!(
            e(&OK.replace("90,+,2", "90,+,3")),
            "a.csv:3:3: target 0°, positive direction: run 3 is missing (the test has runs 1–3)"
        );
        assert!(e(&OK.replace("0,+,2,1.2", "0,+,0,1.2")).starts_with("a.csv:4:3: column 'run'"));
        assert!(e(&OK.replace("90,+,1", "1e9,+,1")).starts_with("a.csv:5:1: column 'target_deg'"));
        assert!(e(&OK.replace("2.4", "1e7")).starts_with("a.csv:6:4: column 'deviation_arcsec'"));
        assert!(e(&OK.replace("deviation_arcsec", "reading_arcsec")).contains("--polygon"));
        assert!(
            e("target_deg,direction,run\n0,+,1\n").contains("missing column 'deviation_arcsec'")
        );
    }

    #[test]
    fn every_error_names_line_and_column() {
        let e = |text: &str| {
            parse("a.csv", text, None)
                .and_then(|f| f.analyse(&Instrument::default()))
                .unwrap_err()
                .to_string()
        };
        // Columns reordered: each error points at its own column.
        let both = "run,deviation_arcsec,direction,target_deg\n\
            1,1.0,+,0\n2,1.2,+,0\n1,0.5,-,0\n2,0.7,-,0\n\
            1,2.0,+,90\n2,2.4,+,90\n1,1.5,-,90\n2,1.5,-,90\n";
        assert!(
            parse("a.csv", both, None)
                .unwrap()
                .analyse(&Instrument::default())
                .is_ok()
        );
        // A run missing at a target: the first reading there, the run column.
        assert_eq!(
            e(&both.replace("2,1.5,-,90\n", "")),
            "a.csv:8:1: target 90°, negative direction: run 2 is missing (the test has runs 1, 2)"
        );
        // A direction missing at a target: its first reading, the target column.
        assert_eq!(
            e(&both.replace("1,1.5,-,90\n2,1.5,-,90\n", "")),
            "a.csv:6:4: target 90°: no approach in the negative direction, while other targets have both: a bidirectional test approaches every target from both sides"
        );
        // Unequal runs per direction are a run missing, named.
        assert!(
            e(&format!("{both}3,1.1,+,0\n3,2.2,+,90\n"))
                .starts_with("a.csv:4:1: target 0°, negative direction: run 3 is missing")
        );
        // One target, one run: the header's column.
        let keep = |f: &dyn Fn(&str) -> bool| -> String {
            both.lines()
                .filter(|l| f(l))
                .map(|l| format!("{l}\n"))
                .collect()
        };
        let one_target = keep(&|l| !l.ends_with(",90"));
        assert!(
            e(&one_target).starts_with("a.csv:1:4: 1 target"),
            "{}",
            e(&one_target)
        );
        let one_run = keep(&|l| !l.starts_with("2,"));
        assert!(
            e(&one_run).starts_with("a.csv:1:1: 1 run"),
            "{}",
            e(&one_run)
        );
        // Huge numbers the short way.
        assert_eq!(
            e(&both.replace("2,2.4,", "2,-1e300,")),
            "a.csv:7:2: column 'deviation_arcsec': -1e300 is out of range: expected −1000000 to 1000000 arcsec"
        );
    }

    #[test]
    fn the_worked_example_of_the_docs() {
        let text = include_str!("../../../../examples/axis-example.csv");
        let doc = parse("axis-example.csv", text, None)
            .unwrap()
            .analyse(&Instrument::default())
            .unwrap();
        // docs/iso230-2.md: E = 5, M = 3.5, A = 5 + 1.6·√2.5.
        let p = doc.parameters;
        assert_eq!((p.e, p.m, p.b), (Some(5.0), Some(3.5), Some(2.5)));
        assert!((p.a.unwrap() - (5.0 + 1.6 * 2.5f64.sqrt())).abs() < 1e-12);
    }

    #[test]
    fn readings_need_their_faces() {
        let p = Polygon::new(&[0.1, -0.1, 0.0, 0.0], &[0.01; 4], 10.0, "p.json").unwrap();
        let text =
            "target_deg,direction,run,reading_arcsec\n0,+,1,1\n0,+,2,1\n45,+,1,2\n45,+,2,2\n";
        let e = parse("a.csv", text, Some(p.clone()))
            .unwrap()
            .analyse(&Instrument::default())
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("a.csv:4:1: reading 2: target 45° is not at a face"),
            "{e}"
        );
        let text = "target_deg,direction,run,reading_arcsec,face\n0,+,1,1,1\n0,+,2,1,5\n";
        let e = parse("a.csv", text, Some(p.clone()))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("a.csv:3:5: column 'face'"), "{e}");
        // Face 2 at 0° is fine (a polygon mounted so); then 90° must be face 3, not 4.
        let text = "target_deg,direction,run,reading_arcsec,face\n0,+,1,1,2\n90,+,1,1,4\n";
        let e = parse("a.csv", text, Some(p))
            .unwrap()
            .analyse(&Instrument::default())
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "a.csv:3:5: face 4 at target 90°, where line 2's face puts face 3: the polygon's faces advance by one every 90° (is the certificate for the polygon on the axis?)"
        );
    }
}
