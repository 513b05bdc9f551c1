//! `gonio simulate selfcal`: multi-head readings of one encoder scale, with ground truth.

use anyhow::{Result, bail};
use gonio_cli::flag;
use gonio_cli::output::Outputs;
use gonio_core::bound::Bound;
use gonio_io::formats::heads;
use gonio_sim::selfcal::{SelfcalSimConfig, simulate};
use std::fmt::Write as _;
use std::path::PathBuf;

/// Arguments of `gonio simulate selfcal`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Writes DIR/readings.csv (position_deg,head_2,…,head_M: head h minus head 1, arcsec; with --raw
position_deg,head_1,…,head_M in degrees; with --turns > 1 a `turn` column), DIR/truth.json
(a(θ) at every position, zero mean, shaped like a calibration result so `gonio compare` reads it;
the heads with their mounting offsets) and DIR/encoder.json (the model).

Examples:
  gonio simulate selfcal --heads selfa12 --positions 36000 --sigma 0.01 --seed 1 --out sc
  gonio simulate selfcal --encoder enc.json --heads eda:4 --positions 3600 --turns 6 --out sc4
  gonio simulate selfcal --heads heads.toml --raw --resolution 0.04 --out scraw")]
pub struct Args {
    /// Encoder model file (from `gonio simulate encoder`); default: the built-in model with
    /// graduation error from --seed (the same default the shift-angle simulator uses).
    #[arg(long)]
    pub encoder: Option<PathBuf>,
    /// Head arrangement: `selfa12`, `eda:N`, or a TOML/JSON heads file (`angles_deg`, optional
    /// `offsets_arcsec`, `sets`).
    #[arg(long, default_value = "selfa12")]
    pub heads: String,
    /// Rotation positions per turn NS (equally spaced).
    #[arg(long, default_value_t = 36_000, value_parser = flag::whole::<usize>(POSITIONS))]
    pub positions: usize,
    /// First rotation position, degrees.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = flag::real(flag::ANGLE_DEG))]
    pub start: f64,
    /// Noise per head reading (standard deviation), arcsec.
    #[arg(long, default_value_t = 0.01, value_parser = flag::real(flag::SIM_SIGMA_ARCSEC))]
    pub sigma: f64,
    /// Head resolution (quantisation of each reading), arcsec; 0 for none.
    #[arg(long, default_value_t = 0.0, value_parser = flag::real(flag::RESOLUTION_ARCSEC))]
    pub resolution: f64,
    /// Standard deviation of the heads' mounting offsets when the heads file gives none, arcsec.
    #[arg(long, default_value_t = 5.0, value_parser = flag::real(flag::SIM_SIGMA_ARCSEC))]
    pub offset_sigma: f64,
    /// Repeated turns.
    #[arg(long, default_value_t = 1, value_parser = flag::whole::<usize>(TURNS))]
    pub turns: usize,
    /// Write raw head readings in degrees instead of differences to head 1.
    #[arg(long)]
    pub raw: bool,
    /// Seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output directory (new or empty; see --force).
    #[arg(long)]
    pub out: PathBuf,
    /// Write into a non-empty output directory, replacing the files of an earlier run.
    #[arg(long)]
    pub force: bool,
}

/// `--positions`: rotation positions per turn.
const POSITIONS: Bound = Bound::new(8.0, 1e7, "");
/// `--turns`: repeated turns (their readings together are bounded by the simulator).
const TURNS: Bound = Bound::new(1.0, 1e6, "");

/// Runs `gonio simulate selfcal`.
pub fn run(args: Args) -> Result<()> {
    let mut out = Outputs::new();
    let model = args.encoder.as_deref();
    let (files, encoder) = super::lab(&mut out, &args.out, args.force, model, args.seed)?;
    let (heads, offsets) = heads::load(out.inputs(), &args.heads)?;
    if args.positions > 10_000_000 {
        bail!(
            "--positions {}: more than 10 000 000 per turn",
            args.positions
        );
    }
    let cfg = SelfcalSimConfig {
        offsets_arcsec: offsets,
        offset_sigma_arcsec: args.offset_sigma,
        positions: args.positions,
        start_deg: args.start,
        noise_sigma_arcsec: args.sigma,
        resolution_arcsec: args.resolution,
        turns: args.turns,
        seed: args.seed,
        ..SelfcalSimConfig::new(heads.clone(), args.seed)
    };
    let sim = simulate(&encoder, &cfg)?;
    let m = heads.len();
    let first = if args.raw { 1 } else { 2 };
    let mut s = String::with_capacity(args.positions * args.turns * m * 14);
    s.push_str("position_deg");
    for h in first..=m {
        write!(s, ",head_{h}")?;
    }
    if args.turns > 1 {
        s.push_str(",turn");
    }
    s.push('\n');
    for (t, turn) in sim.turns.iter().enumerate() {
        for (i, p) in turn.positions_deg.iter().enumerate() {
            write!(s, "{p:.9}")?;
            if args.raw {
                for col in &sim.raw_deg[t] {
                    write!(s, ",{:.12}", col[i])?;
                }
            } else {
                for col in &turn.differences_arcsec {
                    write!(s, ",{:.6}", col[i])?;
                }
            }
            if args.turns > 1 {
                write!(s, ",{}", t + 1)?;
            }
            s.push('\n');
        }
    }
    out.write(files.readings, s.as_bytes())?;
    out.json(files.truth, &sim.truth)?;
    out.write(files.encoder, encoder.to_json().as_bytes())?;
    out.commit()?;
    gonio_cli::say!(
        "wrote {} ({} heads × {} positions × {} turn(s)), truth.json and encoder.json",
        args.out.join("readings.csv").display(),
        m,
        args.positions,
        args.turns
    )
}
