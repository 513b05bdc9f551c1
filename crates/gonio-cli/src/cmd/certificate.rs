//! `gonio certificate`: check a certificate's metadata and export it as a Digital Calibration
//! Certificate (DCC v3.1.2 XML).

use anyhow::{Result, anyhow};
use gonio_cli::output::Outputs;
use gonio_cli::say;
use gonio_io::formats;
use std::path::PathBuf;

/// Arguments of `gonio certificate`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
CERT.json is a certificate from `gonio shift-angle --json` or `gonio selfcal --json`. The DCC
(namespace https://ptb.de/dcc, D-SI 2.1.0) carries the ISO/IEC 17025 metadata as its
administrativeData and every calibrated angle as si:real: θ in \\degree, α and its expanded
uncertainty in \\arcsecond (k and p with it). A certificate with required metadata missing is not
exported unless --draft is given (the DCC then says DRAFT). Schemas: schemas/dcc/.

Examples:
  gonio certificate cal.json --meta examples/certificate-meta.toml --dcc cal.dcc.xml
  gonio certificate cal.json                      # lists missing metadata fields
  gonio certificate cal.json --dcc draft.xml --draft")]
pub struct Args {
    /// The certificate (JSON).
    pub certificate: PathBuf,
    /// Certificate metadata (TOML), replacing what the certificate carries.
    #[arg(long)]
    pub meta: Option<PathBuf>,
    /// Write the Digital Calibration Certificate (XML) here.
    #[arg(long)]
    pub dcc: Option<PathBuf>,
    /// Export even with required metadata missing, marked DRAFT.
    #[arg(long)]
    pub draft: bool,
    /// Write the certificate JSON with the metadata attached here.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

/// Runs `gonio certificate`.
pub fn run(args: Args) -> Result<()> {
    let mut out = Outputs::new();
    let json = out.optional("--json", args.json.as_deref())?;
    let dcc = out.optional("--dcc", args.dcc.as_deref())?;
    let mut cert = formats::certificate::load(out.inputs(), &args.certificate)?;
    if let Some(p) = &args.meta {
        cert = cert.with_meta(formats::meta::load(out.inputs(), p)?);
    }
    let missing = cert.missing_meta();
    say!(
        "{}: {}, {} angles, largest |α| {:.4}″, largest U {}",
        args.certificate.display(),
        cert.method_title(),
        cert.points.len(),
        cert.max_abs_error_arcsec(),
        cert.max_expanded_arcsec()
            .map_or("–".into(), |u| format!("{u:.4}″"))
    )?;
    if missing.is_empty() {
        say!("metadata complete (ISO/IEC 17025 §7.8.2.1, §7.8.4.1)")?;
    } else {
        say!("DRAFT: missing metadata: {}", missing.join(", "))?;
    }
    if let Some(j) = json {
        out.json(j, &cert)?;
    }
    if let Some(d) = dcc {
        let xml = gonio_report::dcc::write(&cert, args.draft).map_err(|e| {
            anyhow!(
                "{}: {e} (give them with --meta, or --draft for a draft)",
                args.certificate.display()
            )
        })?;
        out.write(d, xml.as_bytes())?;
    }
    out.commit()?;
    if let Some(p) = &args.json {
        gonio_cli::note!("wrote {}", p.display());
    }
    if let Some(p) = &args.dcc {
        gonio_cli::note!(
            "wrote {}{}",
            p.display(),
            if missing.is_empty() { "" } else { " (DRAFT)" }
        );
    }
    Ok(())
}
