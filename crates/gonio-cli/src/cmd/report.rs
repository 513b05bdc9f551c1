//! `gonio report`: one self-contained HTML report (inline SVG plots) from certificates,
//! comparisons and mounting batches.

use crate::formats::{self, report::ReportInput};
use crate::io;
use anyhow::{Context, Result, bail};
use gonio_report::html::Report;
use std::path::PathBuf;

/// Arguments of `gonio report`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Inputs (any number, in order):
  a certificate        gonio shift-angle … --json cal.json, gonio selfcal … --json sc.json
  a comparison         gonio compare cal.json sc.json --json cmp.json
  a mounting batch     gonio mount --sim … --json batch.json
The HTML needs no network: the font and every plot are inside it. A certificate whose metadata
(--meta, or the one it carries) lacks a required ISO/IEC 17025 field is marked DRAFT, with the
missing fields named.

Examples:
  gonio report cal.json --meta examples/certificate-meta.toml --out report.html
  gonio report cal.json sc.json cmp.json batch.json --out report.html --plots plots/")]
pub struct Args {
    /// Input files (JSON).
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    /// The HTML file to write.
    #[arg(long, default_value = "report.html")]
    pub out: PathBuf,
    /// Also write every plot as its own SVG file into this directory.
    #[arg(long)]
    pub plots: Option<PathBuf>,
    /// Certificate metadata (TOML) for every certificate, replacing what they carry.
    #[arg(long)]
    pub meta: Option<PathBuf>,
    /// The report's title (default: from the inputs).
    #[arg(long)]
    pub title: Option<String>,
}

/// Builds the report of `files` (metadata from `meta` replacing the certificates' own).
pub fn build(
    files: &[PathBuf],
    meta: Option<&gonio_calib::certificate::CertificateMeta>,
    title: Option<&str>,
) -> Result<Report> {
    let inputs: Vec<(PathBuf, ReportInput)> = files
        .iter()
        .map(|f| Ok((f.clone(), formats::report::load(f)?)))
        .collect::<Result<_>>()?;
    let default_title = match inputs.first() {
        Some((_, ReportInput::Certificate(c))) => c
            .meta
            .as_ref()
            .and_then(|m| m.title.clone())
            .unwrap_or_else(|| "Calibration certificate".into()),
        Some((_, ReportInput::Comparison(_))) => "Comparison of calibrations".into(),
        Some((_, ReportInput::Batch(_))) => "Mounting batch".into(),
        None => bail!("no input files"),
    };
    let mut report = Report::new(title.unwrap_or(&default_title));
    for (path, input) in inputs {
        let name = path.display().to_string();
        match input {
            ReportInput::Certificate(c) => {
                let c = match meta {
                    Some(m) => c.with_meta(m.clone()),
                    None => *c,
                };
                report.add_certificate(&c, &name)
            }
            ReportInput::Comparison(c) => report.add_comparison(&c, &name),
            ReportInput::Batch(b) => report.add_batch(&b, &name),
        }
        .with_context(|| format!("{name}: drawing the report"))?;
    }
    Ok(report)
}

/// Writes the report and, with `plots`, every figure as its own SVG.
pub fn write(
    report: &Report,
    out: &std::path::Path,
    plots: Option<&std::path::Path>,
) -> Result<()> {
    io::write_atomic(out, report.render().as_bytes())?;
    if let Some(dir) = plots {
        io::ensure_dir(dir)?;
        for (i, f) in report.figures().iter().enumerate() {
            let p = dir.join(format!("{:02}-{}.svg", i + 1, f.id));
            io::write_atomic(&p, f.standalone_svg().as_bytes())?;
        }
    }
    Ok(())
}

/// Runs `gonio report`.
pub fn run(args: Args) -> Result<()> {
    let meta = args.meta.as_deref().map(formats::meta::load).transpose()?;
    let report = build(&args.files, meta.as_ref(), args.title.as_deref())?;
    write(&report, &args.out, args.plots.as_deref())?;
    println!(
        "wrote {} ({} plots{}){}",
        args.out.display(),
        report.figures().len(),
        args.plots.as_ref().map_or(String::new(), |d| format!(
            ", also as SVG files in {}",
            d.display()
        )),
        if report.is_draft() {
            "; DRAFT: required certificate metadata missing (see the report)"
        } else {
            ""
        }
    );
    Ok(())
}
