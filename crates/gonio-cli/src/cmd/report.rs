//! `gonio report`: one self-contained HTML report (inline SVG plots) from certificates,
//! comparisons and mounting batches.

use anyhow::Result;
use gonio_cli::output::Outputs;
use gonio_io::formats::{self, report};
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

/// Runs `gonio report`.
pub fn run(args: Args) -> Result<()> {
    let mut out = Outputs::new();
    let html = out.file("--out", &args.out)?;
    let meta = args
        .meta
        .as_deref()
        .map(|p| formats::meta::load(out.inputs(), p))
        .transpose()?;
    let inputs = args
        .files
        .iter()
        .map(|f| Ok((f.display().to_string(), report::load(out.inputs(), f)?)))
        .collect::<Result<Vec<_>>>()?;
    let report = report::build(inputs, meta.as_ref(), args.title.as_deref())?;
    out.write(html, report.render().as_bytes())?;
    if let Some(dir) = &args.plots {
        // The SVG files of a plots directory are the report's own: replaced on every run.
        out.dir("--plots", dir, true)?;
        for (i, f) in report.figures().iter().enumerate() {
            let svg = out.file("--plots", &dir.join(format!("{:02}-{}.svg", i + 1, f.id)))?;
            out.write(svg, f.standalone_svg().as_bytes())?;
        }
    }
    out.commit()?;
    gonio_cli::say!(
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
    )
}
