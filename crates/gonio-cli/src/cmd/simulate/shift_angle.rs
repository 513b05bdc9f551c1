//! `gonio simulate shift-angle`: polygon + autocollimator readings with ground truth.

use anyhow::{Context, Result, bail};
use gonio_cli::flag;
use gonio_cli::output::Outputs;
use gonio_core::bound::Bound;
use gonio_io::formats::readings;
use gonio_lab::log::{self as elcomat, Mode};
use gonio_lab::plan::{Level, ModeRule, Plan, ShiftPlan};
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
    #[arg(long, default_value_t = 24, value_parser = flag::whole::<usize>(flag::SIM_FACES))]
    pub faces: usize,
    /// Shift angles in degrees: a list `0,5,10` or a range `START:STEP:END` (`0:1:14`).
    #[arg(long, default_value = "0,5,10")]
    pub shifts: String,
    /// Runs per shift: `full` (every start face), `one` (start face 1 only), `seed` (full matrix
    /// at the first shift, start face 1 at the others, as in Hsieh et al., 2022).
    #[arg(long, value_enum, default_value_t, hide_possible_values = true)]
    pub rows: Rows,
    /// Autocollimator noise per reading (standard deviation), arcsec.
    #[arg(long, default_value_t = 0.05, value_parser = flag::real(flag::SIM_SIGMA_ARCSEC))]
    pub sigma: f64,
    /// Autocollimator resolution, arcsec (0: no quantisation).
    #[arg(long, default_value_t = 0.001, value_parser = flag::real(flag::RESOLUTION_ARCSEC))]
    pub resolution: f64,
    /// Standard deviation of the polygon's pitch deviations, arcsec.
    #[arg(long, default_value_t = 0.3, value_parser = flag::real(flag::SIM_SIGMA_ARCSEC))]
    pub pitch_sigma: f64,
    /// Standard deviation of each run's setup error, arcsec.
    #[arg(long, default_value_t = 1.0, value_parser = flag::real(flag::SIM_SIGMA_ARCSEC))]
    pub setup_sigma: f64,
    /// Readings of every (shift, face, step).
    #[arg(long, default_value_t = 1, value_parser = flag::whole::<u32>(REPEATS))]
    pub repeats: u32,
    /// Fraction of readings dropped at random (0 to below 1).
    #[arg(long, default_value_t = 0.0, value_parser = flag::real(DROP))]
    pub drop: f64,
    /// Seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output directory (new or empty; see --force).
    #[arg(long)]
    pub out: PathBuf,
    /// Write into a non-empty output directory, replacing the files of an earlier run.
    #[arg(long)]
    pub force: bool,
    /// Also write the readings as an ELCOMAT-type autocollimator log (`4 003 X Y` lines, CR
    /// ended) here, and the measuring plan it follows as DIR/plan.toml (for `gonio import
    /// elcomat`).
    #[arg(long)]
    pub elcomat_log: Option<PathBuf>,
    /// Readings of the log: `absolute` (`4 003`) or `relative` (`2 103`).
    #[arg(
        long,
        value_enum,
        default_value_t = Mode::Absolute,
        hide_possible_values = true,
        requires = "elcomat_log"
    )]
    pub elcomat_mode: Mode,
}

/// `--repeats`: readings of each (shift, face, step).
const REPEATS: Bound = Bound::new(1.0, 1e6, "");
/// `--drop`: a fraction of the readings, never all of them.
const DROP: Bound = Bound::new(0.0, 1.0, "").hi_excluded();

/// Parses `0,5,10` or `0:1:14` (inclusive end); a shift given twice is refused (its readings
/// would conflict in the readings file).
pub fn parse_shifts(s: &str) -> Result<Vec<f64>> {
    let shown = gonio_core::text::short(s);
    let v: Vec<f64> = if s.contains(':') {
        readings::shift_range(s).with_context(|| {
            format!(
                "--shifts {shown:?}: expected START:STEP:END with STEP > 0, END ≥ START and at most {} shifts, e.g. 0:1:14",
                readings::MAX_SHIFTS
            )
        })?
    } else {
        super::degrees_list("--shifts", &shown, s)?
    };
    if let Some((x, e)) = v.iter().find_map(|&x| {
        gonio_calib::shift_angle::SHIFT_DEG
            .check(x)
            .err()
            .map(|e| (x, e))
    }) {
        bail!(
            "--shifts {shown:?}: {}°: a shift of {e}",
            gonio_core::bound::Num(x)
        );
    }
    if v.len() > readings::MAX_SHIFTS {
        bail!(
            "--shifts: {} shifts, at most {}",
            v.len(),
            readings::MAX_SHIFTS
        );
    }
    let mut seen = std::collections::HashSet::new();
    if let Some(d) = v
        .iter()
        .find(|&&x| !seen.insert(gonio_calib::shift_angle::ShiftKey::of(x)))
    {
        bail!("--shifts {shown:?}: {d}° is given twice: expected each shift once");
    }
    Ok(v)
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
    let mut out = Outputs::new();
    let model = args.encoder.as_deref();
    let (files, encoder) = super::lab(&mut out, &args.out, args.force, model, args.seed)?;
    let cfg = ShiftAngleConfig {
        faces: args.faces,
        shifts_deg: parse_shifts(&args.shifts)?,
        rows: args.rows,
        pitch_sigma_arcsec: args.pitch_sigma,
        setup_sigma_arcsec: args.setup_sigma,
        noise_sigma_arcsec: args.sigma,
        resolution_arcsec: args.resolution,
        repeats: args.repeats,
        drop_fraction: args.drop,
        seed: args.seed,
    };
    let sim = simulate(&encoder, &cfg)?;
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
    out.write(files.readings, csv.as_bytes())?;
    if let Some(log) = &args.elcomat_log {
        write_elcomat(&mut out, &args, &cfg, &sim.readings, log)?;
    }
    out.json(files.truth, &sim.truth)?;
    out.write(files.encoder, encoder.to_json().as_bytes())?;
    out.commit()?;
    if let Some(log) = &args.elcomat_log {
        gonio_cli::note!(
            "wrote {} and {}",
            log.display(),
            args.out.join("plan.toml").display()
        );
    }
    gonio_cli::note!(
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
    out: &mut Outputs,
    args: &Args,
    cfg: &ShiftAngleConfig,
    readings: &[gonio_calib::shift_angle::Reading],
    log: &std::path::Path,
) -> Result<()> {
    let mode = args.elcomat_mode;
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
    let log_id = out.file("--elcomat-log", log)?;
    out.write(log_id, elcomat::write(&xy, mode, decimals).as_bytes())?;
    let plan_path = args.out.join("plan.toml");
    let plan_id = out.file("--out", &plan_path)?;
    let comment = format!(
        "Measuring plan of {} (gonio simulate shift-angle --faces {} --shifts {} --rows {} --repeats {} --seed {})",
        log.display(),
        args.faces,
        args.shifts,
        args.rows,
        args.repeats,
        args.seed
    );
    out.write(plan_id, plan.to_toml(&comment).as_bytes())?;
    Ok(())
}
