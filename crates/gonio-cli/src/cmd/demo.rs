//! `gonio demo`: the built-in simulated lab, end to end, with the truth to compare against
//! (`gonio_io::demo`).

use anyhow::Result;
use gonio_cli::output::Outputs;
use gonio_cli::say;
use gonio_io::demo::{self, Settings};
use std::path::PathBuf;

/// Arguments of `gonio demo`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
1. Mounting (Yu et al., 2024): a batch of 25 gratings on the simulated station, with the paper's
   strategy and with gonio's default, against the paper's 25 real parts.
2. Calibration by the shift-angle method (Hsieh et al., 2022): the simulated encoder measured
   with a 24-face polygon at S = 0°…14° (the full matrix at 0°, one row at every other shift, as
   in the paper), calibrated by least squares and by the paper's algorithm, against the truth.
3. Self-calibration: the same encoder on SelfA's 12 heads, compared with the shift-angle result
   (each the average of six runs, as in the paper's Fig. 11–12), with En from each certificate's
   expanded uncertainty.
4. Joint calibration: an encoder with a planted order-24 term on both rigs, the polygon and the
   heads in one least squares: the polygon alone misses order 24, the joint estimate recovers it
   (and order 84, which the heads miss); only order 168 stays invisible.
5. A rotary axis to ISO 230-2: the simulated axis (error, backlash 1.5″, repeatability σ 0.3″)
   at the 24-face polygon's faces and 360°, 5 runs each way, against its own parameters.
It then writes the certificates, the comparison, the axis, the batch and one HTML report with every plot
into --out (gonio-demo/report.html by default; a directory that holds files only with --force)
and prints the report's path.

Example:
  gonio demo --seed 3 --out demo3")]
pub struct Args {
    /// Seed of the simulated lab.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Autocollimator noise per reading, arcsec.
    #[arg(long, default_value_t = 0.05, value_parser = gonio_cli::flag::real(gonio_cli::flag::SIGMA_ARCSEC))]
    pub sigma: f64,
    /// Directory for the report, the certificates, the comparison and the batch.
    #[arg(long, default_value = "gonio-demo")]
    pub out: PathBuf,
    /// Write into --out even when it holds files (those of an earlier demo are replaced).
    #[arg(long)]
    pub force: bool,
}

/// Runs `gonio demo`.
pub fn run(args: Args) -> Result<()> {
    let settings = Settings {
        seed: args.seed,
        sigma_arcsec: args.sigma,
        out: args.out,
        force: args.force,
    };
    // Before any work: a directory with files in it is only written into with --force.
    demo::check_out(&settings)?;
    let mut out = Outputs::new();
    let written = demo::run(&settings, &mut out, &mut gonio_cli::term::Stdout)
        .map_err(gonio_cli::term::stdout_error)?;
    out.commit()?;
    say!()?;
    say!(
        "Report: {} ({} plots; certificates, comparison, axis and batch as JSON beside it)",
        written.report.display(),
        written.figures
    )?;
    Ok(())
}
