//! `gonio demo`, the built-in simulated lab end to end with the truth to compare against: the
//! mounting of 25 gratings on the simulated station ([`mounting`]), the shift-angle calibration
//! scored against the simulated encoder ([`shift_angle`]), SelfA's self-calibration compared with
//! it ([`selfcal`]), the joint calibration of both rigs ([`joint`]) and a rotary axis to ISO 230-2
//! ([`axis`]). Angles in arcseconds (″), lengths in µm.
//!
//! [`run`] writes the narrative (tables of the errors against the truth) to a writer and puts the
//! certificates, the comparison, the axis, the batch and one HTML report into an output set that
//! the caller commits. Errors are `anyhow` errors: a refused output directory names `--out`; a
//! failed write to the narrative's writer is its `std::io::Error`.
//!
//! ```no_run
//! use gonio_io::demo::{self, Settings};
//! use gonio_io::output::Outputs;
//! let settings = Settings { seed: 1, sigma_arcsec: 0.05, out: "gonio-demo".into(), force: false };
//! demo::check_out(&settings)?;
//! let mut out = Outputs::new(Box::new(std::io::sink()));
//! let written = demo::run(&settings, &mut out, &mut std::io::stdout())?;
//! out.commit()?;
//! println!("{} ({} plots)", written.report.display(), written.figures);
//! # Ok::<(), anyhow::Error>(())
//! ```

pub mod axis;
pub mod joint;
pub mod mounting;
pub mod selfcal;
pub mod shift_angle;

use crate::formats::report::{self, ReportInput};
use crate::output::Outputs;
use anyhow::Result;
use gonio_calib::certificate::Certificate;
use gonio_sim::EncoderModel;
use gonio_sim::station::BatchReport;
use std::io::Write;
use std::path::PathBuf;

/// The example certificate metadata (fictitious laboratory and customer).
const META: &str = include_str!("../../../../examples/certificate-meta.toml");

/// The instrument terms of the shift-angle calibration (Table 3 of Hsieh et al., 2022, corrected).
const INSTRUMENT_SHIFT_ANGLE: &str =
    include_str!("../../../../examples/instrument-shift-angle.toml");
/// The instrument terms of the SelfA self-calibration.
const INSTRUMENT_SELFCAL: &str = include_str!("../../../../examples/instrument-selfcal.toml");

/// What the demo runs and where it writes.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    /// Seed of the simulated lab.
    pub seed: u64,
    /// Autocollimator noise per reading, arcsec.
    pub sigma_arcsec: f64,
    /// Directory for the report, the certificates, the comparison and the batch.
    pub out: PathBuf,
    /// Write into `out` even when it holds files (those of an earlier demo are replaced).
    pub force: bool,
}

/// The report the demo wrote.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Written {
    /// The HTML report's path (in the output set, in place once it is committed).
    pub report: PathBuf,
    /// How many plots it holds.
    pub figures: usize,
}

/// Refuses, before any work, an output directory that holds files unless `force` is given.
///
/// # Errors
/// `--out DIR: the directory is not empty: …`.
pub fn check_out(s: &Settings) -> Result<()> {
    if !s.force
        && let Ok(mut d) = std::fs::read_dir(&s.out)
        && d.next().is_some()
    {
        anyhow::bail!(
            "--out {}: the directory is not empty: choose a new directory, or give --force to replace the demo's files in it",
            s.out.display()
        );
    }
    Ok(())
}

/// Runs the demo: its narrative to `w`, its files into `out` (committed by the caller).
///
/// # Errors
/// A refused output (see [`check_out`]), a write error on `w`, or a step of the lab that fails.
pub fn run(s: &Settings, out: &mut Outputs, w: &mut dyn Write) -> Result<Written> {
    writeln!(
        w,
        "gonio demo: the built-in simulated lab and station (seed {})",
        s.seed
    )?;
    writeln!(w)?;
    let batch = mounting::run(s.seed, w)?;
    writeln!(w)?;
    let encoder = EncoderModel::default_with_seed(s.seed);
    let cfg = shift_angle::run(&encoder, s.seed, s.sigma_arcsec, w)?;
    writeln!(w)?;
    let (shift_cert, selfcal_cert, comparison) = selfcal::run(&encoder, &cfg, s.seed, w)?;
    writeln!(w)?;
    let joint_cert = joint::run(s.seed, w)?;
    writeln!(w)?;
    let axis = axis::run(s.seed, s.sigma_arcsec, w)?;
    write_files(
        s,
        out,
        &[&shift_cert, &selfcal_cert, &joint_cert],
        &comparison,
        &axis,
        &batch,
    )
}

/// Puts the certificates, the comparison, the axis, the batch and the HTML report into `out`.
fn write_files(
    s: &Settings,
    out: &mut Outputs,
    certs: &[&Certificate; 3],
    comparison: &gonio_calib::compare::Comparison,
    axis: &gonio_calib::axis::AxisResult,
    batch: &BatchReport,
) -> Result<Written> {
    let meta = crate::formats::meta::parse("examples/certificate-meta.toml", META)?;
    let with_meta = |c: &Certificate| {
        let mut m = meta.clone();
        m.remarks = Some(format!(
            "Simulated measurement (gonio demo, seed {}): the laboratory, customer and standards are fictitious.",
            s.seed
        ));
        c.clone().with_meta(m)
    };
    // A directory with files in it only with --force (checked before the work, again here).
    out.dir("--out", &s.out, s.force)?;
    let certs: Vec<Certificate> = certs.iter().map(|c| with_meta(c)).collect();
    let names = ["shift-angle.json", "selfcal.json", "joint.json"];
    let mut inputs = Vec::new();
    for (name, c) in names.iter().zip(&certs) {
        let p = s.out.join(name);
        let id = out.file("--out", &p)?;
        out.json(id, c)?;
        inputs.push((
            p.display().to_string(),
            ReportInput::Certificate(Box::new(c.clone())),
        ));
    }
    let p = s.out.join("compare.json");
    let id = out.file("--out", &p)?;
    out.json(id, comparison)?;
    inputs.push((
        p.display().to_string(),
        ReportInput::Comparison(Box::new(comparison.clone())),
    ));
    let p = s.out.join("axis.json");
    let id = out.file("--out", &p)?;
    out.json(id, axis)?;
    inputs.push((
        p.display().to_string(),
        ReportInput::Axis(Box::new(axis.clone())),
    ));
    let p = s.out.join("batch.json");
    let id = out.file("--out", &p)?;
    out.json(id, batch)?;
    // The report reads the batch as `gonio report batch.json` would: through its JSON.
    let view = serde_json::from_value(serde_json::to_value(batch)?)?;
    inputs.push((p.display().to_string(), ReportInput::Batch(Box::new(view))));
    let report = report::build(
        inputs,
        None,
        Some("gonio demo: simulated calibration and mounting"),
    )?;
    let html = s.out.join("report.html");
    let id = out.file("--out", &html)?;
    out.write(id, report.render().as_bytes())?;
    Ok(Written {
        report: html,
        figures: report.figures().len(),
    })
}
