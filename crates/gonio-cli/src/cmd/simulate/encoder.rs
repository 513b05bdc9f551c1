//! `gonio simulate encoder`: write an encoder error model file.

use anyhow::{Context, Result, bail};
use gonio_cli::flag;
use gonio_cli::output::Outputs;
use gonio_core::bound::Bound;
use gonio_sim::encoder::HarmonicArcsec;
use gonio_sim::{EncoderModel, Graduation};
use std::path::PathBuf;

/// Arguments of `gonio simulate encoder`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
The model is α(θ) = Σ A·sin(k·θ + φ) + g(θ), arcseconds, with g a random graduation error
(one normal value per line, mean removed, interpolated between lines).

Examples:
  gonio simulate encoder --seed 7 --out enc.json
  gonio simulate encoder --harmonic 2:1.0314:-2.4233 --harmonic 3:0.2:0 --graduation-sigma 0 --out h2.json")]
pub struct Args {
    /// Seed of the random graduation error.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output model file (JSON).
    #[arg(long)]
    pub out: PathBuf,
    /// A harmonic ORDER:AMPLITUDE_ARCSEC:PHASE_RAD; repeat for several. Replaces the default
    /// harmonics (orders 1, 2, 3, 4, 6, 12, 24, 84 with amplitudes like those in Hsieh et al., 2022).
    #[arg(long = "harmonic", value_name = "K:A:PHI")]
    pub harmonics: Vec<String>,
    /// No harmonics at all (graduation error only).
    #[arg(long, conflicts_with = "harmonics")]
    pub no_harmonics: bool,
    /// Standard deviation of one graduation line's error, arcsec (0 for none).
    #[arg(long, default_value_t = 0.01, value_parser = flag::real(flag::SIM_SIGMA_ARCSEC))]
    pub graduation_sigma: f64,
    /// Graduation lines on the circle (1 to 100000000).
    #[arg(long, default_value_t = 36_000, value_parser = flag::whole::<u32>(LINES))]
    pub lines: u32,
}

/// `--lines`: graduation lines on the circle.
const LINES: Bound = Bound::new(1.0, 1e8, "");

/// Parses `K:A:PHI`.
pub fn parse_harmonic(s: &str) -> Result<HarmonicArcsec> {
    let parts: Vec<&str> = s.split(':').collect();
    if parts.len() != 3 {
        bail!("--harmonic {s:?}: expected ORDER:AMPLITUDE_ARCSEC:PHASE_RAD, e.g. 2:1.0314:-2.4233");
    }
    let order: u32 = parts[0].trim().parse().with_context(|| {
        format!(
            "--harmonic {s:?}: order {:?} is not a whole number",
            parts[0]
        )
    })?;
    let num = |p: &str, what: &str| -> Result<f64> {
        p.trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .with_context(|| format!("--harmonic {s:?}: {what} {p:?} is not a number"))
    };
    Ok(HarmonicArcsec {
        order,
        amplitude_arcsec: num(parts[1], "amplitude")?,
        phase_rad: num(parts[2], "phase")?,
    })
}

/// Runs `gonio simulate encoder`.
pub fn run(args: Args) -> Result<()> {
    let mut out = Outputs::new();
    let model_json = out.file("--out", &args.out)?;
    let harmonics = if args.no_harmonics {
        Vec::new()
    } else if args.harmonics.is_empty() {
        EncoderModel::default_harmonics()
    } else {
        args.harmonics
            .iter()
            .map(|h| parse_harmonic(h))
            .collect::<Result<_>>()?
    };
    let model = EncoderModel::new(
        harmonics,
        Graduation {
            lines: args.lines,
            sigma_arcsec: args.graduation_sigma,
            seed: args.seed,
        },
    )?;
    out.write(model_json, model.to_json().as_bytes())?;
    out.commit()?;
    gonio_cli::note!(
        "wrote {} ({} harmonics, {} lines with {}″ graduation error, seed {})",
        args.out.display(),
        model.harmonics().len(),
        args.lines,
        args.graduation_sigma,
        args.seed
    );
    Ok(())
}
