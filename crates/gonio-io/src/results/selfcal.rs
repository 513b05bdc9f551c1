//! The certificate of a self-calibration with several read heads: `gonio selfcal --json` and
//! `gonio.selfcal` in Python, from one code path: the options checked, the head readings read
//! (at most [`crate::input::MAX_TEXT_BYTES`], from the shell and from Python alike) and split
//! into turns, the estimator run, the instrument terms and the metadata added, the result
//! checked finite.
//!
//! Errors are one line naming the input and its line (`heads.csv:9: column 'position_deg': …`)
//! or the flag (`--reference "1,13": "13" is not a head number in 1..=12`), as the command
//! line prints them.
//!
//! ```
//! use gonio_io::formats::{csv::CsvTable, heads, source::Table};
//! use gonio_io::input::Inputs;
//! use gonio_io::results::selfcal::{Request, evaluate};
//! let inputs = Inputs::new();
//! let (h, _) = heads::load(&inputs, "eda:3").unwrap();
//! let mut csv = String::from("position_deg,head_2,head_3\n");
//! for i in 0..36 {
//!     csv.push_str(&format!("{},{},0.2\n", 10 * i, (i as f64).sin()));
//! }
//! let table = CsvTable::parse("r.csv", &csv).unwrap();
//! let cert = evaluate(&inputs, Request::new(Table::Given(table), h)).unwrap();
//! assert_eq!(cert.points.len(), 36);
//! ```

use crate::formats::heads::{locate, read_turns};
use crate::formats::source::{Document, Table};
use crate::formats::{instrument, meta};
use crate::input::Inputs;
use anyhow::{Context, Result, bail};
use gonio_calib::certificate::Certificate;
use gonio_calib::selfcal::{Heads, MAX_ORDER, Method, NoiseModel, SelfcalOptions, calibrate};

/// What a self-calibration reads and how it runs (the flags of `gonio selfcal`).
#[derive(Debug)]
pub struct Request {
    /// The head readings (`position_deg,head_2,…,head_M[,turn]`, or with `raw`
    /// `position_deg,head_1,…,head_M`).
    pub readings: Table,
    /// The head arrangement (`--heads`, loaded with [`crate::formats::heads::load`]).
    pub heads: Heads,
    /// The estimator (`--method`).
    pub method: Method,
    /// The readings are the heads' raw readings in degrees (`--raw`).
    pub raw: bool,
    /// The noise model of the uncertainty (`--noise-model`).
    pub noise_model: NoiseModel,
    /// Heads (1-based, `1,7`) whose averaged reading is calibrated (`--reference`).
    pub reference: String,
    /// Largest harmonic order of the table and the undetectable list (`--max-order`).
    pub max_order: u32,
    /// Instrument terms (`--instrument`).
    pub instrument: Option<Document>,
    /// Coverage probability of U (`--coverage`; default: the instrument file's, else 0.95).
    pub coverage: Option<f64>,
    /// ISO/IEC 17025 metadata (`--meta`).
    pub meta: Option<Document>,
}

impl Request {
    /// The readings and the heads with every option at the command line's default.
    pub fn new(readings: Table, heads: Heads) -> Request {
        Request {
            readings,
            heads,
            method: Method::default(),
            raw: false,
            noise_model: NoiseModel::default(),
            reference: "1".into(),
            max_order: 360,
            instrument: None,
            coverage: None,
            meta: None,
        }
    }
}

/// Checks a largest harmonic order (`flag` names it) against [`MAX_ORDER`].
///
/// # Errors
/// Above [`MAX_ORDER`].
pub fn check_max_order(flag: &str, k: u32) -> Result<()> {
    if k > MAX_ORDER {
        bail!("{flag} {k}: expected at most {MAX_ORDER}");
    }
    Ok(())
}

/// Parses head numbers (1-based, `1,7`) of `m` heads into 0-based indices (`--reference`).
///
/// # Errors
/// A number that is not one of the heads, naming it.
pub fn reference_heads(spec: &str, m: usize) -> Result<Vec<usize>> {
    spec.split(',')
        .map(|p| {
            let h: usize = p
                .trim()
                .parse()
                .ok()
                .filter(|h| (1..=m).contains(h))
                .with_context(|| {
                    format!(
                        "--reference {:?}: {:?} is not a head number in 1..={m}",
                        gonio_core::text::short(spec),
                        gonio_core::text::short(p)
                    )
                })?;
            Ok(h - 1)
        })
        .collect()
}

/// The certificate (`gonio.certificate/1`), checked finite.
///
/// # Errors
/// An option out of range, an input that cannot be read or is malformed, readings the
/// estimator refuses (naming the file and line), a result that is not finite.
pub fn evaluate(inputs: &Inputs, r: Request) -> Result<Certificate> {
    check_max_order("--max-order", r.max_order)?;
    let reference_heads = reference_heads(&r.reference, r.heads.len())?;
    let name = r.readings.name();
    let table = r.readings.read(inputs)?;
    let rt = read_turns(&table, &r.heads, r.raw)?;
    let opts = SelfcalOptions {
        method: r.method,
        noise_model: r.noise_model,
        reference_heads,
        max_order: r.max_order,
    };
    let instrument = instrument::from_document(inputs, r.instrument.as_ref(), r.coverage)?;
    let meta = r
        .meta
        .as_ref()
        .map(|m| m.parse(inputs, meta::parse))
        .transpose()?;
    let result = calibrate(&r.heads, &rt.turns, &opts).map_err(|e| locate(e, &table, &rt.lines))?;
    let cert = Certificate::from_selfcal(&result, &instrument)?;
    super::finish(cert, meta, &name)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::csv::CsvTable;

    fn run_csv(text: &str, heads: &str, raw: bool) -> Result<Certificate> {
        let inputs = Inputs::new();
        let (heads, _) = crate::formats::heads::load(&inputs, heads)?;
        let table = CsvTable::parse("r.csv", text)?;
        let r = Request {
            raw,
            ..Request::new(Table::Given(table), heads)
        };
        evaluate(&inputs, r)
    }

    fn csv(rows: usize, step: f64, f: impl Fn(usize) -> String) -> String {
        let mut s = String::from("position_deg,head_2,head_3\n");
        for i in 0..rows {
            s.push_str(&format!("{},{}\n", i as f64 * step, f(i)));
        }
        s
    }

    fn error(text: &str, heads: &str, raw: bool) -> String {
        crate::input::one_line(&run_csv(text, heads, raw).unwrap_err())
    }

    #[test]
    fn good_file_and_one_line_errors_with_file_and_line() {
        let ok = csv(36, 10.0, |i| format!("{},0.2", (i as f64).sin()));
        assert_eq!(run_csv(&ok, "eda:3", false).unwrap().points.len(), 36);
        // Position 7 (file line 9) off the 10° grid.
        let bad = csv(36, 10.0, |_| "0.1,0.2".into()).replace("\n70,", "\n71,");
        let e = error(&bad, "eda:3", false);
        assert!(
            e.starts_with("r.csv:9: column 'position_deg': found 71°"),
            "{e}"
        );
        // Half a turn.
        let e = error(&csv(36, 5.0, |_| "0,0".into()), "eda:3", false);
        assert!(e.starts_with("r.csv:3: column 'position_deg'"), "{e}");
        // NaN and ragged rows.
        let nan = csv(
            36,
            10.0,
            |i| if i == 3 { "NaN,0".into() } else { "0,0".into() },
        );
        let e = error(&nan, "eda:3", false);
        assert!(e.starts_with("r.csv:5:2: column 'head_2'"), "{e}");
        let ragged = csv(36, 10.0, |i| if i == 2 { "0".into() } else { "0,0".into() });
        let e = crate::input::one_line(&CsvTable::parse("r.csv", &ragged).unwrap_err());
        assert!(e.starts_with("r.csv:4: expected 3 fields"), "{e}");
        // Head count not matching the heads.
        let e = error(&ok, "eda:4", false);
        assert!(e.starts_with("r.csv:1: 2 head columns for 4 heads"), "{e}");
        let e = error(&ok, "eda:3", true);
        assert!(e.contains("expected head_1,head_2,head_3"), "{e}");
        // Too few rows.
        let e = error(&csv(4, 90.0, |_| "0,0".into()), "eda:3", false);
        assert!(e.starts_with("r.csv:5: turn 1: expected at least 8"), "{e}");
    }

    #[test]
    fn turns_column_groups_rows() {
        let mut s = String::from("position_deg,head_2,turn\n");
        for t in [2, 1] {
            for i in 0..12 {
                s.push_str(&format!("{},{},{t}\n", i * 30, 0.01 * t as f64));
            }
        }
        let c = run_csv(&s, "eda:2", false).unwrap();
        assert_eq!(c.selfcal.as_ref().unwrap().turns, 2);
        assert_eq!(c.uncertainty.source, "repeated turns");
        let s = s.replace(",1\n", ",0\n");
        let e = error(&s, "eda:2", false);
        assert!(e.contains("turn number ≥ 1"), "{e}");
    }

    #[test]
    fn options_are_checked_before_anything_is_read() {
        let inputs = Inputs::new();
        let (heads, _) = crate::formats::heads::load(&inputs, "selfa12").unwrap();
        let missing = Table::File("no/such/readings.csv".into());
        let r = Request {
            max_order: MAX_ORDER + 1,
            ..Request::new(missing, heads.clone())
        };
        let e = evaluate(&inputs, r).unwrap_err().to_string();
        assert_eq!(e, "--max-order 100001: expected at most 100000");
        let r = Request {
            reference: "1,13".into(),
            ..Request::new(Table::File("no/such/readings.csv".into()), heads)
        };
        let e = evaluate(&inputs, r).unwrap_err().to_string();
        assert_eq!(
            e,
            "--reference \"1,13\": \"13\" is not a head number in 1..=12"
        );
        assert!(inputs.is_empty());
    }
}
