//! `gonio simulate shift-angle`: polygon + autocollimator readings with ground truth.

use crate::formats::elcomat::{self, Mode};
use crate::formats::plan::{Level, ModeRule, Plan, ShiftPlan};
use crate::io;
use anyhow::{Context, Result, bail};
use gonio_sim::EncoderModel;
use gonio_sim::shift_angle::{Rows, ShiftAngleConfig, simulate};
use std::path::PathBuf;

/// Arguments of `gonio simulate shift-angle`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Writes DIR/readings.csv (shift_deg,start_face,step,reading_arcsec[,repeat]), DIR/truth.json
(true α at every sampled angle after its shift's closure, β, U) and DIR/encoder.json (the model);
with --elcomat-log, the same readings as an autocollimator log and DIR/plan.toml.

Examples:
  gonio simulate shift-angle --faces 24 --shifts 0,5,10 --sigma 0.05 --seed 1 --out run1
  gonio simulate shift-angle --encoder enc.json --shifts 0:1:14 --rows seed --out seedlike
  gonio simulate shift-angle --faces 12 --shifts 0,10 --rows full --repeats 3 --drop 0.1 --out sparse
  gonio simulate shift-angle --shifts 0:1:14 --out lab --elcomat-log lab/elcomat.log")]
pub struct Args {
    /// Encoder model file (from `gonio simulate encoder`); default: the built-in model with
    /// graduation error from --seed.
    #[arg(long)]
    pub encoder: Option<PathBuf>,
    /// Polygon faces N (≥ 3).
    #[arg(long, default_value_t = 24)]
    pub faces: usize,
    /// Shift angles in degrees: a list `0,5,10` or a range `START:STEP:END` (`0:1:14`).
    #[arg(long, default_value = "0,5,10")]
    pub shifts: String,
    /// Runs per shift: `full` (every start face), `one` (start face 1 only), `seed` (full matrix
    /// at the first shift, start face 1 at the others, as in Hsieh et al., 2022).
    #[arg(long, default_value = "seed")]
    pub rows: String,
    /// Autocollimator noise per reading (standard deviation), arcsec.
    #[arg(long, default_value_t = 0.05)]
    pub sigma: f64,
    /// Autocollimator resolution, arcsec (0: no quantisation).
    #[arg(long, default_value_t = 0.001)]
    pub resolution: f64,
    /// Standard deviation of the polygon's pitch deviations, arcsec.
    #[arg(long, default_value_t = 0.3)]
    pub pitch_sigma: f64,
    /// Standard deviation of each run's setup error, arcsec.
    #[arg(long, default_value_t = 1.0)]
    pub setup_sigma: f64,
    /// Readings of every (shift, face, step).
    #[arg(long, default_value_t = 1)]
    pub repeats: u32,
    /// Fraction of readings dropped at random.
    #[arg(long, default_value_t = 0.0)]
    pub drop: f64,
    /// Seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output directory.
    #[arg(long)]
    pub out: PathBuf,
    /// Also write the readings as an ELCOMAT-type autocollimator log (`4 003 X Y` lines, CR
    /// ended) here, and the measuring plan it follows as DIR/plan.toml (for `gonio import
    /// elcomat`).
    #[arg(long)]
    pub elcomat_log: Option<PathBuf>,
    /// Readings of the log: `absolute` (`4 003`) or `relative` (`2 103`).
    #[arg(long, default_value = "absolute", requires = "elcomat_log")]
    pub elcomat_mode: String,
}

/// Parses `0,5,10` or `0:1:14` (inclusive end).
pub fn parse_shifts(s: &str) -> Result<Vec<f64>> {
    let num = |p: &str| -> Result<f64> {
        p.trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .with_context(|| format!("--shifts {s:?}: {p:?} is not a number of degrees"))
    };
    if s.contains(':') {
        let p: Vec<&str> = s.split(':').collect();
        if p.len() != 3 {
            bail!("--shifts {s:?}: expected START:STEP:END, e.g. 0:1:14");
        }
        let (a, st, b) = (num(p[0])?, num(p[1])?, num(p[2])?);
        if st <= 0.0 || b < a {
            bail!("--shifts {s:?}: expected STEP > 0 and END ≥ START");
        }
        let count = ((b - a) / st + 1e-9).floor() as usize + 1;
        if count > 100_000 {
            bail!("--shifts {s:?}: {count} shifts is more than 100000");
        }
        Ok((0..count).map(|k| a + k as f64 * st).collect())
    } else {
        s.split(',').map(num).collect()
    }
}

/// Formats a reading at the autocollimator's resolution (shortest exact form without one).
pub fn format_reading(v: f64, resolution: f64) -> String {
    if resolution > 0.0 {
        let decimals = (-resolution.log10()).ceil().clamp(0.0, 12.0) as usize;
        format!("{v:.decimals$}")
    } else {
        format!("{v}")
    }
}

/// Runs `gonio simulate shift-angle`.
pub fn run(args: Args) -> Result<()> {
    let encoder = match &args.encoder {
        Some(p) => super::encoder::load(p)?,
        None => EncoderModel::default_with_seed(args.seed),
    };
    let rows = Rows::parse(&args.rows)
        .with_context(|| format!("--rows {:?}: expected full, one or seed", args.rows))?;
    let cfg = ShiftAngleConfig {
        faces: args.faces,
        shifts_deg: parse_shifts(&args.shifts)?,
        rows,
        pitch_sigma_arcsec: args.pitch_sigma,
        setup_sigma_arcsec: args.setup_sigma,
        noise_sigma_arcsec: args.sigma,
        resolution_arcsec: args.resolution,
        repeats: args.repeats,
        drop_fraction: args.drop,
        seed: args.seed,
    };
    let sim = simulate(&encoder, &cfg)?;
    io::ensure_dir(&args.out)?;
    let with_repeat = args.repeats > 1;
    let mut csv = String::from("# gonio simulate shift-angle");
    csv.push_str(&format!(
        " faces={} shifts={} rows={} sigma={} resolution={} seed={}\n",
        args.faces, args.shifts, args.rows, args.sigma, args.resolution, args.seed
    ));
    csv.push_str(if with_repeat {
        "shift_deg,start_face,step,repeat,reading_arcsec\n"
    } else {
        "shift_deg,start_face,step,reading_arcsec\n"
    });
    for r in &sim.readings {
        let v = format_reading(r.value_arcsec, args.resolution);
        if with_repeat {
            csv.push_str(&format!(
                "{},{},{},{},{v}\n",
                r.shift_deg, r.start_face, r.step, r.repeat
            ));
        } else {
            csv.push_str(&format!(
                "{},{},{},{v}\n",
                r.shift_deg, r.start_face, r.step
            ));
        }
    }
    io::write_atomic(&args.out.join("readings.csv"), csv.as_bytes())?;
    if let Some(log) = &args.elcomat_log {
        write_elcomat(&args, &cfg, &sim.readings, log)?;
    }
    io::write_json(&args.out.join("truth.json"), &sim.truth)?;
    io::write_atomic(&args.out.join("encoder.json"), encoder.to_json().as_bytes())?;
    eprintln!(
        "wrote {} readings ({} faces, {} shifts) to {}/readings.csv, truth.json, encoder.json",
        sim.readings.len(),
        args.faces,
        cfg.shifts_deg.len(),
        args.out.display()
    );
    Ok(())
}

/// Writes the readings as an autocollimator log and the plan it follows (DIR/plan.toml).
fn write_elcomat(
    args: &Args,
    cfg: &ShiftAngleConfig,
    readings: &[gonio_calib::shift_angle::Reading],
    log: &std::path::Path,
) -> Result<()> {
    let mode = match args.elcomat_mode.as_str() {
        "absolute" => Mode::Absolute,
        "relative" => Mode::Relative,
        m => bail!("--elcomat-mode {m:?}: expected absolute or relative"),
    };
    if cfg.drop_fraction > 0.0 {
        bail!(
            "--elcomat-log: a measuring plan cannot say which readings --drop left out; use --drop 0"
        );
    }
    let all: Vec<usize> = (1..=cfg.faces).collect();
    let shifts = cfg
        .shifts_deg
        .iter()
        .enumerate()
        .map(|(i, &shift_deg)| ShiftPlan {
            shift_deg,
            start_faces: match cfg.rows {
                Rows::Full => all.clone(),
                Rows::Seed if i == 0 => all.clone(),
                Rows::One | Rows::Seed => vec![1],
            },
            steps: all.clone(),
            repeats: cfg.repeats,
        })
        .collect();
    let plan = Plan {
        faces: cfg.faces,
        shifts,
        order: [Level::Shift, Level::StartFace, Level::Step, Level::Repeat],
        closure: false,
        x_sign: 1.0,
        mode: match mode {
            Mode::Absolute => ModeRule::Absolute,
            Mode::Relative => ModeRule::Relative,
        },
    };
    let decimals = if args.resolution > 0.0 {
        (-args.resolution.log10()).ceil().clamp(0.0, 12.0) as usize
    } else {
        6
    };
    // The simulator's readings are in measuring order; the autocollimator has no Y here.
    let xy: Vec<(f64, f64)> = readings.iter().map(|r| (r.value_arcsec, 0.0)).collect();
    io::write_atomic(log, elcomat::write(&xy, mode, decimals).as_bytes())?;
    let plan_path = args.out.join("plan.toml");
    let comment = format!(
        "Measuring plan of {} (gonio simulate shift-angle --faces {} --shifts {} --rows {} --repeats {} --seed {})",
        log.display(),
        args.faces,
        args.shifts,
        args.rows,
        args.repeats,
        args.seed
    );
    io::write_atomic(&plan_path, plan.to_toml(&comment).as_bytes())?;
    eprintln!("wrote {} and {}", log.display(), plan_path.display());
    Ok(())
}
