//! `gonio simulate axis`: the readings of an ISO 230-2 test of a simulated rotary axis with a
//! known systematic error, backlash and repeatability, and its true parameters.

use anyhow::{Context, Result, bail};
use gonio_calib::axis::{Direction, MAX_RUNS, MAX_TARGET_DEG, TargetKey};
use gonio_cli::output::Outputs;
use gonio_core::bound::Num;
use gonio_sim::axis::{AxisModel, AxisTest, MAX_AXIS_ARCSEC, simulate};
use std::fmt::Write as _;
use std::path::PathBuf;

/// Arguments of `gonio simulate axis`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Writes DIR/readings.csv (target_deg,direction,run,deviation_arcsec, in the order of the standard's
test cycle: run 1 up through every target, back down, then run 2 …) and DIR/truth.json (the axis
model and its own ISO 230-2 parameters: the standard's definitions applied to x̄↑ = e + b/2,
x̄↓ = e − b/2, s = σ). The axis: e(P) = 3″·sin(P + 0.7) + 1.2″·sin(2P − 1.9) + 0.5″·sin(3P + 2.4)
+ 0.3″·sin(8P + 0.1) + the scale error per turn; each approach scattered with σ from the seed.

Examples:
  gonio simulate axis --seed 1 --out ax
  gonio simulate axis --targets 0:30:360 --runs 5 --backlash-arcsec 4 --repeatability-arcsec 0.5 --out ax
  gonio simulate axis --directions + --out unidirectional
  gonio axis ax/readings.csv --json axis.json")]
pub struct Args {
    /// Targets, degrees: a range `START:STEP:END` (end included) or a list `0,90,180`.
    #[arg(long, default_value = "0:45:360")]
    pub targets: String,
    /// Runs in each direction (the standard's cycle has 5).
    #[arg(long, default_value_t = 5)]
    pub runs: u32,
    /// `both` (default), `+` (positive approaches only) or `-`: a unidirectional test.
    #[arg(long, default_value = "both")]
    pub directions: String,
    // The axis: backlash, repeatability, scale error.
    #[command(flatten)]
    pub axis: AxisFlags,
    /// The reference's noise on each reading, arcsec.
    #[arg(long, default_value_t = 0.02, allow_negative_numbers = true)]
    pub reference_sigma_arcsec: f64,
    /// The reference's resolution, arcsec.
    #[arg(long, default_value_t = 0.001, allow_negative_numbers = true)]
    pub resolution_arcsec: f64,
    /// Seed of the approaches' scatter and the reference's noise.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output directory (new or empty; see --force).
    #[arg(long)]
    pub out: PathBuf,
    /// Write into a non-empty output directory, replacing the files of an earlier run.
    #[arg(long)]
    pub force: bool,
}

/// The simulated axis's flags, shared with `gonio simulate autocollimator --axis`.
#[derive(Debug, Clone, Copy, clap::Args)]
pub struct AxisFlags {
    /// The axis's backlash b = x̄↑ − x̄↓ at every target, arcsec [default: 1.5].
    #[arg(long, allow_negative_numbers = true)]
    pub backlash_arcsec: Option<f64>,
    /// The axis's repeatability σ of one approach, arcsec (R↑ = 4σ) [default: 0.3].
    #[arg(long, allow_negative_numbers = true)]
    pub repeatability_arcsec: Option<f64>,
    /// The axis's scale error: its systematic error grows by this much per turn, arcsec
    /// [default: 2].
    #[arg(long, allow_negative_numbers = true)]
    pub scale_arcsec_per_turn: Option<f64>,
}

impl AxisFlags {
    /// Whether any flag was given.
    pub fn any(&self) -> bool {
        self.backlash_arcsec.is_some()
            || self.repeatability_arcsec.is_some()
            || self.scale_arcsec_per_turn.is_some()
    }

    /// The default axis of `seed` with these flags, each within its bound (σ ≥ 0, |·| ≤
    /// [`MAX_AXIS_ARCSEC`]).
    pub fn model(&self, seed: u64) -> Result<AxisModel> {
        for (flag, v, low) in [
            ("--backlash-arcsec", self.backlash_arcsec, -MAX_AXIS_ARCSEC),
            ("--repeatability-arcsec", self.repeatability_arcsec, 0.0),
            (
                "--scale-arcsec-per-turn",
                self.scale_arcsec_per_turn,
                -MAX_AXIS_ARCSEC,
            ),
        ] {
            if let Some(v) = v
                && !(low..=MAX_AXIS_ARCSEC).contains(&v)
            {
                bail!(
                    "{flag} {}: expected {low} to {MAX_AXIS_ARCSEC} arcsec",
                    Num(v)
                );
            }
        }
        let d = AxisModel::default_with_seed(seed);
        let m = AxisModel {
            backlash_arcsec: self.backlash_arcsec.unwrap_or(d.backlash_arcsec),
            repeatability_arcsec: self.repeatability_arcsec.unwrap_or(d.repeatability_arcsec),
            scale_arcsec_per_turn: self
                .scale_arcsec_per_turn
                .unwrap_or(d.scale_arcsec_per_turn),
            ..d
        };
        m.validate()
            .map_err(|e| anyhow::anyhow!("the simulated axis: {e}"))?;
        Ok(m)
    }
}

/// Targets `START:STEP:END` or `A,B,C` in degrees, ascending, each once, within ±36 000°.
pub fn parse_targets(flag: &str, s: &str) -> Result<Vec<f64>> {
    let shown = gonio_core::text::short(s);
    let mut v: Vec<f64> = if s.contains(':') {
        gonio_calib::shift_angle::shift_range(s).with_context(|| {
            format!(
                "{flag} {shown:?}: expected START:STEP:END with STEP > 0, END ≥ START and at most {} targets, e.g. 0:45:360",
                gonio_calib::shift_angle::MAX_SHIFTS
            )
        })?
    } else {
        super::degrees_list(flag, &shown, s)?
    };
    if let Some(t) = v.iter().find(|t| t.abs() > MAX_TARGET_DEG) {
        bail!(
            "{flag} {shown:?}: {}° is out of range: expected −{MAX_TARGET_DEG} to {MAX_TARGET_DEG} degrees",
            Num(*t)
        );
    }
    v.sort_by(f64::total_cmp);
    if let Some(w) = v
        .windows(2)
        .find(|w| TargetKey::of(w[0]) == TargetKey::of(w[1]))
    {
        bail!(
            "{flag} {shown:?}: {}° is given twice: expected each target once",
            w[0]
        );
    }
    if v.len() < 2 {
        bail!("{flag} {shown:?}: expected at least 2 targets");
    }
    Ok(v)
}

/// Runs `gonio simulate axis`.
pub fn run(args: Args) -> Result<()> {
    let targets = parse_targets("--targets", &args.targets)?;
    if !(2..=MAX_RUNS).contains(&args.runs) {
        bail!("--runs {}: expected 2 to {MAX_RUNS}", args.runs);
    }
    let directions = match args.directions.as_str() {
        "both" => Direction::BOTH.to_vec(),
        d => vec![Direction::parse(d).with_context(|| {
            format!(
                "--directions {:?}: expected both, + or -",
                gonio_core::text::short(d)
            )
        })?],
    };
    let model = args.axis.model(args.seed)?;
    let test = AxisTest {
        targets_deg: targets.clone(),
        runs: args.runs,
        directions,
        reference_sigma_arcsec: args.reference_sigma_arcsec,
        resolution_arcsec: args.resolution_arcsec,
    };
    let (sigma, res) = (args.reference_sigma_arcsec, args.resolution_arcsec);
    if !(0.0..=MAX_AXIS_ARCSEC).contains(&sigma) {
        bail!(
            "--reference-sigma-arcsec {}: expected 0 to {MAX_AXIS_ARCSEC} arcsec",
            Num(sigma)
        );
    }
    if !(1e-6..=1.0).contains(&res) {
        bail!(
            "--resolution-arcsec {}: expected 0.000001 to 1 arcsec",
            Num(res)
        );
    }
    let readings = simulate(&model, &test)?;
    let mut out = Outputs::new();
    out.dir("--out", &args.out, args.force)?;
    let csv_id = out.file("--out", &args.out.join("readings.csv"))?;
    let truth_id = out.file("--out", &args.out.join("truth.json"))?;
    let decimals = (-args.resolution_arcsec.log10()).ceil().clamp(0.0, 6.0) as usize;
    let mut csv = format!(
        "# gonio simulate axis --seed {} ({} targets, {} runs, backlash {}″, repeatability σ {}″)\ntarget_deg,direction,run,deviation_arcsec\n",
        args.seed,
        targets.len(),
        args.runs,
        model.backlash_arcsec,
        model.repeatability_arcsec
    );
    for r in &readings {
        let _ = writeln!(
            csv,
            "{},{},{},{:.decimals$}",
            r.target_deg,
            r.direction.sign(),
            r.run,
            r.deviation_arcsec
        );
    }
    out.write(csv_id, csv.as_bytes())?;
    out.json(truth_id, &model.truth(&targets))?;
    out.commit()?;
    gonio_cli::note!(
        "wrote {} readings and the axis's true parameters to {}",
        readings.len(),
        args.out.display()
    );
    Ok(())
}
