//! `gonio simulate autocollimator --pty`: a simulated ELCOMAT-type autocollimator and polygon
//! on a simulated encoder (or, with `--axis`, also on a rotary axis under an ISO 230-2 test),
//! answering the serial protocol on a pseudo-terminal.
//!
//! Glue only: the instrument and the pseudo-terminal are `gonio_lab::simulator`'s.

use anyhow::{Result, anyhow, bail};
use gonio_calib::axis::Direction;
use gonio_cli::flag;
use gonio_cli::output::Outputs;
use gonio_cli::{note, say};
use gonio_core::bound::{Bound, duration_s};
use gonio_io::formats::encoder as encoder_file;
use gonio_io::input::Inputs;
use gonio_lab::axis::AxisPlan;
use gonio_lab::plan::Plan;
use gonio_lab::simulator::{Approach, Position, Pty, SimConfig, SimulatedAutocollimator};
use gonio_sim::EncoderModel;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Arguments of `gonio simulate autocollimator`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Opens a pseudo-terminal and prints its path (the serial port to give `gonio acquire
shift-angle --port`) as the first line of standard output, then answers `a` (absolute, `4 003 X
Y`) and `r` (relative, `2 103 X Y`) requests with the simulated polygon's reading, arcseconds,
CR ended; a --flagged fraction of answers carries status 013 (113) instead. The reading is
α(θ) + the polygon's pitch sum + the run's setup error + drift + noise, the model of `gonio
simulate shift-angle`, at the position the operator set: a line `NEXT shift_deg=S start_face=F
step=I …` (as `gonio acquire` prints it) or `SET …` on standard input sets the bench and is
answered `SET shift_deg=S start_face=F step=I`; `quit` ends. With --truth and --plan the true α
at the plan's shifts is written as `gonio simulate shift-angle` writes it (truth.json).

With --axis the polygon also sits on a rotary axis with a known error, backlash and repeatability
(the axis of `gonio simulate axis`): a line `NEXT target_deg=T direction=D run=J face=F …` (as
`gonio acquire axis` prints it) moves the axis there and is answered `SET target_deg=T
direction=D run=J face=F`; the reading is where the axis stopped less T, plus the pitch sum to
face F and the setup error. With --truth and --plan AXIS.toml the axis's own ISO 230-2
parameters at the plan's targets are written (as truth.json of `gonio simulate axis`).

Examples:
  gonio simulate autocollimator --pty --faces 12 --seed 1 --truth truth.json --plan plan.toml
  gonio simulate autocollimator --pty --faces 12 --axis --backlash-arcsec 3 --truth t.json --plan axis.toml
  gonio simulate autocollimator --pty --flagged 0.05 --drift-arcsec-per-reading 0.001 --duration-s 600")]
pub struct Args {
    /// Answer on a new pseudo-terminal (the only transport).
    #[arg(long, required = true)]
    pub pty: bool,
    /// Encoder model file (from `gonio simulate encoder`); default: the built-in model with
    /// graduation error from --seed.
    #[arg(long)]
    pub encoder: Option<PathBuf>,
    /// Polygon faces N.
    #[arg(long, default_value_t = 24, value_parser = flag::whole::<usize>(flag::SIM_FACES))]
    pub faces: usize,
    /// Seed of the encoder, polygon, setup errors, noise and flagged answers.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Noise of one answer (standard deviation), arcsec.
    #[arg(long, default_value_t = 0.05, value_parser = flag::real(flag::SIM_SIGMA_ARCSEC))]
    pub sigma: f64,
    /// Resolution, arcsec (the answers' decimals follow it; 0.000001 to 3600).
    #[arg(long, default_value_t = 0.001, value_parser = flag::real(RESOLUTION_ARCSEC))]
    pub resolution: f64,
    /// Standard deviation of the polygon's pitch deviations, arcsec.
    #[arg(long, default_value_t = 0.3, value_parser = flag::real(flag::SIM_SIGMA_ARCSEC))]
    pub pitch_sigma: f64,
    /// Standard deviation of each run's setup error, arcsec.
    #[arg(long, default_value_t = 1.0, value_parser = flag::real(flag::SIM_SIGMA_ARCSEC))]
    pub setup_sigma: f64,
    /// Drift of the reading per answer, arcsec.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = flag::real(DRIFT_ARCSEC))]
    pub drift_arcsec_per_reading: f64,
    /// Fraction of answers flagged with a bad status (013 / 113).
    #[arg(long, default_value_t = 0.02, value_parser = flag::real(flag::FRACTION))]
    pub flagged: f64,
    /// Write the true α at the shifts of --plan here (JSON, as truth.json of `gonio simulate
    /// shift-angle`).
    #[arg(long, requires = "plan")]
    pub truth: Option<PathBuf>,
    /// The measuring plan whose shifts --truth covers (with --axis: the axis's plan, whose
    /// targets it covers).
    #[arg(long)]
    pub plan: Option<PathBuf>,
    /// Stop after this many seconds (default: run until quit, the end of a killed session or
    /// Ctrl-C).
    #[arg(long, value_parser = flag::real(flag::DURATION_S))]
    pub duration_s: Option<f64>,
    /// The polygon also sits on a rotary axis under test (`NEXT target_deg=…` lines move it).
    #[arg(long)]
    pub axis: bool,
    // The axis (with --axis).
    #[command(flatten)]
    pub axis_flags: super::axis::AxisFlags,
}

/// Where a control line puts the bench.
enum Control {
    /// The table at a shift, the polygon at a step of a run.
    Bench(Position),
    /// The axis at a target.
    Axis(Approach),
}

/// `target_deg=T direction=D run=J face=F` out of a control line.
fn parse_approach(line: &str) -> Option<Approach> {
    let (mut t, mut d, mut r, mut f) = (None, None, None, None);
    for kv in line.split_whitespace().skip(1) {
        match kv.split_once('=') {
            Some(("target_deg", v)) => t = v.parse::<f64>().ok().filter(|x| x.is_finite()),
            Some(("direction", v)) => d = Direction::parse(v),
            Some(("run", v)) => r = v.parse::<u32>().ok().filter(|&x| x >= 1),
            Some(("face", v)) => f = v.parse::<usize>().ok().filter(|&x| x >= 1),
            _ => {}
        }
    }
    Some(Approach {
        target_deg: t?,
        direction: d?,
        run: r?,
        face: f?,
    })
}

fn parse_control(line: &str) -> Option<Control> {
    if line.contains("target_deg=") {
        parse_approach(line).map(Control::Axis)
    } else {
        parse_position(line).map(Control::Bench)
    }
}

/// The longest control line read (`NEXT shift_deg=… start_face=… step=… repeat=…`).
const MAX_CONTROL_LINE_BYTES: usize = 4096;

/// `--resolution`: the answers carry at most six decimals.
const RESOLUTION_ARCSEC: Bound = Bound::new(1e-6, 3600.0, "″");
/// `--drift-arcsec-per-reading`.
const DRIFT_ARCSEC: Bound = Bound::new(-3600.0, 3600.0, "″");

/// `shift_deg=S start_face=F step=I` out of a control line.
fn parse_position(line: &str) -> Option<Position> {
    let (mut s, mut f, mut i) = (None, None, None);
    for kv in line.split_whitespace().skip(1) {
        match kv.split_once('=') {
            Some(("shift_deg", v)) => s = v.parse::<f64>().ok().filter(|x| x.is_finite()),
            Some(("start_face", v)) => f = v.parse::<usize>().ok().filter(|&x| x >= 1),
            Some(("step", v)) => i = v.parse::<usize>().ok().filter(|&x| x >= 1),
            _ => {}
        }
    }
    Some(Position {
        shift_deg: s?,
        start_face: f?,
        step: i?,
    })
}

/// Runs `gonio simulate autocollimator`.
pub fn run(args: Args) -> Result<()> {
    let inputs = Inputs::new();
    let model = match &args.encoder {
        Some(p) => encoder_file::load(&inputs, p)?,
        None => EncoderModel::default_with_seed(args.seed),
    };
    let cfg = SimConfig {
        faces: args.faces,
        seed: args.seed,
        sigma_arcsec: args.sigma,
        resolution_arcsec: args.resolution,
        pitch_sigma_arcsec: args.pitch_sigma,
        setup_sigma_arcsec: args.setup_sigma,
        drift_arcsec_per_reading: args.drift_arcsec_per_reading,
        flagged_fraction: args.flagged,
    };
    if args.axis_flags.any() && !args.axis {
        bail!(
            "--backlash-arcsec, --repeatability-arcsec and --scale-arcsec-per-turn describe the axis of --axis"
        );
    }
    let axis = args
        .axis
        .then(|| args.axis_flags.model(args.seed))
        .transpose()?;
    let mut sim = SimulatedAutocollimator::new(model, cfg)?;
    if let Some(a) = &axis {
        sim = sim.with_axis(a.clone())?;
    }
    if let (Some(truth), Some(plan_path), Some(axis)) = (&args.truth, &args.plan, &axis) {
        let plan = AxisPlan::parse(plan_path, &inputs.read_text(plan_path)?)?;
        if plan.faces != args.faces {
            bail!(
                "--plan {}: faces = {}, the simulated polygon has --faces {}",
                plan_path.display(),
                plan.faces,
                args.faces
            );
        }
        let mut out = Outputs::with_inputs(inputs);
        let id = out.file("--truth", truth)?;
        out.json(id, &axis.truth(&plan.targets_deg))?;
        out.commit()?;
    } else if let (Some(truth), Some(plan_path)) = (&args.truth, &args.plan) {
        let plan = Plan::parse(plan_path, &inputs.read_text(plan_path)?)?;
        if plan.faces != args.faces {
            bail!(
                "--plan {}: faces = {}, the simulated polygon has --faces {}",
                plan_path.display(),
                plan.faces,
                args.faces
            );
        }
        let shifts: Vec<f64> = plan.shifts.iter().map(|s| s.shift_deg).collect();
        let mut out = Outputs::with_inputs(inputs);
        let id = out.file("--truth", truth)?;
        out.json(
            id,
            &serde_json::json!({
                "faces": args.faces,
                "seed": args.seed,
                "encoder_errors": sim.truth(&shifts),
            }),
        )?;
        out.commit()?;
    }
    let pty = Pty::open().map_err(|e| anyhow!("cannot open a pseudo-terminal: {e}"))?;
    say!("{}", pty.path().display())?;
    note!(
        "simulated autocollimator on {} ({} faces, seed {}); set the bench with NEXT/SET lines on standard input",
        pty.path().display(),
        args.faces,
        args.seed
    );
    let sim = Arc::new(Mutex::new(sim));
    let stop = Arc::new(AtomicBool::new(false));
    {
        let (sim, stop) = (Arc::clone(&sim), Arc::clone(&stop));
        // Control lines: the operator turning the polygon. The end of input leaves the bench
        // where it is.
        std::thread::spawn(move || {
            let stdin = std::io::stdin();
            let mut stdin = stdin.lock();
            let mut bytes = Vec::new();
            loop {
                match gonio_core::text::read_line_bounded(
                    &mut stdin,
                    MAX_CONTROL_LINE_BYTES,
                    &mut bytes,
                ) {
                    Ok(true) => {}
                    Ok(false) => break,
                    Err(e) => {
                        // The bench stays where it is; the instrument goes on answering.
                        note!("standard input: {e}: control lines are no longer read");
                        break;
                    }
                }
                let line = String::from_utf8_lossy(&bytes);
                let line = line.trim();
                if line == "quit" {
                    stop.store(true, Ordering::Relaxed);
                    break;
                }
                if line.starts_with("NEXT ") || line.starts_with("SET ") {
                    let mut sim = sim.lock().unwrap_or_else(|e| e.into_inner());
                    match parse_control(line) {
                        Some(Control::Bench(p)) => {
                            sim.set(p);
                            let _ = say!(
                                "SET shift_deg={} start_face={} step={}",
                                p.shift_deg,
                                p.start_face,
                                p.step
                            );
                        }
                        Some(Control::Axis(a)) if sim.approach(a) => {
                            let _ = say!(
                                "SET target_deg={} direction={} run={} face={}",
                                a.target_deg,
                                a.direction.sign(),
                                a.run,
                                a.face
                            );
                        }
                        Some(Control::Axis(_)) => {
                            note!(
                                "{:?}: no axis under the polygon (--axis)",
                                gonio_core::text::short(line)
                            )
                        }
                        None => note!(
                            "{:?}: expected shift_deg=S start_face=F step=I, or target_deg=T direction=D run=J face=F",
                            gonio_core::text::short(line)
                        ),
                    }
                }
            }
        });
    }
    if let Some(d) = args.duration_s {
        let stop = Arc::clone(&stop);
        let end = Instant::now() + duration_s(d, &flag::DURATION_S)?;
        std::thread::spawn(move || {
            while Instant::now() < end && !stop.load(Ordering::Relaxed) {
                std::thread::sleep(Duration::from_millis(100));
            }
            stop.store(true, Ordering::Relaxed);
        });
    }
    let answers = pty
        .serve(&sim, &stop)
        .map_err(|e| anyhow!("{}: {e}", pty.path().display()))?;
    note!("simulated autocollimator: {answers} answers");
    Ok(())
}
