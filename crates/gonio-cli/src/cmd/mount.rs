//! `gonio mount`: mount a batch of gratings on the (simulated) automatic mounting station.

use crate::recorder::{self, Recorder};
use crate::station::{self, FidelityArg, StrategyArg};
use anyhow::{Result, bail};
use gonio_cli::formats::frames::load_scene;
use gonio_cli::formats::recipe;
use gonio_cli::output::{OutId, Outputs};
use gonio_cli::say;
use gonio_sim::frames::{GratingScene, ScenePreset};
use gonio_sim::station::{BatchConfig, BatchReport, FrameTap, PartDone, SeenFrame};
use gonio_station::Recipe;
use gonio_station::observe::NoObserver;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;

/// The scene rendered at `--fidelity frames`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum MountSceneArg {
    /// The ring alone: noise and blur only.
    Clean,
    /// A typical grating near its ring (default).
    Realistic,
    /// Everything at once, close to the ring.
    Dense,
}

/// Arguments of `gonio mount`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Runs the sequence autofocus → measure → align → approach → push → verify for every part (Yu et
al., 2024) and prints a table like their Table 3. Only the simulated station (--sim) is available.
--fidelity frames renders every frame (the realistic scene unless --scene/--scene-file say
otherwise) and runs it through the station's camera path: the streaming detector, whose invalid
and ambiguous frames the fit skips.

The station pushes only on a turn that passes the quality gate (docs/quality-gates.md). A failing
turn is measured again after a refocus (recipe: quality.remeasure_turns); if it fails again the
part ends measurement_untrusted. A verify turn that disagrees with the push model's prediction
ends the part push_inconsistent. A device error ends the part rejected_device_error; the batch
then stops (exit code 2, records written) or goes on, as the recipe's on_device_error says.
Every part record keeps its turns, pushes, verdict, reject_reason and remeasured_turns.

With --db, every part is committed to the results store (SQLite file or postgres:// URL) in
one transaction as it finishes, with its recipe, times and the controller's learned state. If
the batch is interrupted (the process killed, a device error under on_device_error = \"stop\"),
the same command with --resume continues it after its last stored part: no part lost, none
duplicated, the same records as an uninterrupted run.

With --record DIR (and --fidelity frames), the chosen parts' measuring turns are kept for
`gonio replay DIR`: raw frames, stamps, live detector results and angle logs, and the record.

Examples:
  gonio mount --sim --seed 1
  gonio mount --sim --parts 200 --strategy paper --seed 7 --json batch.json
  gonio mount --sim --parts 500 --seed 7 --db results.sqlite
  gonio mount --sim --parts 500 --seed 7 --db results.sqlite --resume
  gonio mount --sim --seed 7 --db postgres://gonio@/results?host=/run/postgresql --station-name line3-s2
  gonio mount --sim --recipe examples/recipes/r40-standard.toml --strategy live --seed 3
  gonio mount --sim --parts 5 --fidelity frames --scene dense --seed 4
  gonio mount --sim --parts 20 --fidelity frames --seed 4 --record rec --record-parts 3,17")]
pub struct Args {
    /// Use the simulated station (the digital twin with the default plant).
    #[arg(long)]
    pub sim: bool,
    /// Number of parts.
    #[arg(long, default_value_t = 25)]
    pub parts: usize,
    /// Push strategy.
    #[arg(long, value_enum, default_value = "learned")]
    pub strategy: StrategyArg,
    /// Frame fidelity of the simulation.
    #[arg(long, value_enum, default_value = "fast")]
    pub fidelity: FidelityArg,
    /// The scene rendered with --fidelity frames (docs/scenes.md).
    #[arg(
        long,
        value_enum,
        default_value = "realistic",
        conflicts_with = "scene_file"
    )]
    pub scene: MountSceneArg,
    /// A scene TOML file rendered with --fidelity frames.
    #[arg(long, value_name = "SCENE.toml")]
    pub scene_file: Option<PathBuf>,
    /// Recipe (TOML) for the grating type; the defaults are the station of Yu et al., 2024.
    #[arg(long)]
    pub recipe: Option<PathBuf>,
    /// Seed of the simulation (same seed, same bytes).
    #[arg(long)]
    pub seed: u64,
    /// Write per-part records and the summary as JSON here (`-` for standard output).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Commit every part to this results store as it finishes: a SQLite file (created if
    /// missing) or a postgres:// URL.
    #[arg(long, value_name = "PATH|postgres://…")]
    pub db: Option<String>,
    /// Continue the most recent batch in --db started with the same settings, after its last
    /// stored part.
    #[arg(long, requires = "db")]
    pub resume: bool,
    /// The station's name in the results store.
    #[arg(long, default_value = "sim", value_name = "NAME")]
    pub station_name: String,
    /// Record the parts' measuring turns here for `gonio replay`: their raw frames (the raw
    /// stream format of `detect --raw`), stamps, live detector results and angle logs, and the
    /// station's record (needs --fidelity frames).
    #[arg(long, value_name = "DIR")]
    pub record: Option<PathBuf>,
    /// Record only these parts (1-based, e.g. 3,17); default: every part.
    #[arg(long, value_name = "N,N,…", requires = "record")]
    pub record_parts: Option<String>,
}

/// Most parts in one batch.
const MAX_PARTS: usize = 1_000_000;

/// Runs `gonio mount`.
pub fn run(a: Args) -> Result<()> {
    if !a.sim {
        bail!("no station hardware driver is available: use --sim for the simulated station");
    }
    if !(1..=MAX_PARTS).contains(&a.parts) {
        bail!("--parts {}: expected 1 to {MAX_PARTS}", a.parts);
    }
    let mut outputs = Outputs::new();
    let json = outputs.optional("--json", a.json.as_deref())?;
    let recipe = match &a.recipe {
        Some(p) => recipe::load(p)?,
        None => Recipe::default(),
    };
    let scene = match (&a.scene_file, a.scene) {
        (Some(p), _) => load_scene(p)?,
        (None, MountSceneArg::Clean) => GratingScene::preset(ScenePreset::Clean),
        (None, MountSceneArg::Realistic) => GratingScene::preset(ScenePreset::Realistic),
        (None, MountSceneArg::Dense) => GratingScene::preset(ScenePreset::Dense),
    };
    let cfg = BatchConfig {
        parts: a.parts,
        strategy: a.strategy.into(),
        fidelity: a.fidelity.into(),
        scene: Some(scene),
        recipe,
        ..BatchConfig::default()
    };
    if a.record.is_some() && a.fidelity != FidelityArg::Frames {
        bail!("--record needs --fidelity frames: the fast fidelity renders no frames to record");
    }
    let record_parts = a
        .record_parts
        .as_deref()
        .map(|s| recorder::parse_parts(s, a.parts))
        .transpose()?;
    let to_stdout = outputs.to_stdout(json);
    let target = station::Target {
        db: a.db.as_deref(),
        resume: a.resume,
        station: &a.station_name,
    };
    let prepared = match station::prepare(&cfg, a.seed, &target)? {
        station::Start::Run(p) => p,
        station::Start::Complete(note) => {
            gonio_cli::note!("{note}");
            return Ok(());
        }
    };
    if let Some(note) = &prepared.note {
        gonio_cli::note!("{note}");
    }
    let bar = ProgressBar::new(a.parts as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} parts {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.set_position(prepared.first_part as u64);
    let recorder = match &a.record {
        Some(dir) => Some(Recorder::new(recorder::Recording {
            dir: dir.clone(),
            parts: record_parts,
            first_part: prepared.first_part,
            seed: a.seed,
            recipe: cfg.recipe.clone(),
            strategy: cfg.strategy,
            software_version: crate::db::software_version(),
        })?),
        None => None,
    };
    let mut tap_to = recorder.clone();
    let mut tap = |f: &SeenFrame<'_>| {
        if let Some(r) = tap_to.as_mut() {
            r.tap(f);
        }
    };
    let mut observer = recorder.clone();
    let mut none = NoObserver;
    let report = station::run(
        *prepared,
        &cfg,
        a.seed,
        station::Run {
            observer: match observer.as_mut() {
                Some(r) => r,
                None => &mut none,
            },
            pace: None,
            frame_tap: recorder.is_some().then_some(&mut tap as FrameTap<'_>),
            station: &a.station_name,
        },
        &mut |d: &PartDone, _| {
            bar.inc(1);
            bar.set_message(format!(
                "{} {}",
                d.part.record.serial,
                d.part.record.result.name()
            ));
        },
    );
    let report = match report {
        Ok(r) => r,
        Err(e) => {
            bar.abandon();
            return Err(e);
        }
    };
    bar.finish_and_clear();
    drop(observer);
    if let Some(r) = recorder {
        let (written, error) = r.finish();
        if let Some(e) = error {
            return Err(e);
        }
        if let Some(dir) = &a.record {
            gonio_cli::note!(
                "recorded {} part(s) in {dir} (gonio replay {dir} re-runs them)",
                written.len(),
                dir = dir.display()
            );
        }
    }
    print_and_write(&report, to_stdout, outputs, json)
}

fn print_and_write(
    report: &BatchReport,
    to_stdout: bool,
    mut outputs: Outputs,
    json: Option<OutId>,
) -> Result<()> {
    if !to_stdout {
        say!(
            "{:<14} {:>12} {:>12} {:>7} {:>11} {:>8}  result",
            "serial",
            "initial e/µm",
            "final e/µm",
            "pushes",
            "remeasured",
            "time/s"
        )?;
        for p in &report.parts {
            let r = &p.record;
            say!(
                "{:<14} {:>12.1} {:>12.2} {:>7} {:>11} {:>8.1}  {}",
                r.serial,
                r.initial_e_um,
                r.final_e_um,
                r.pushes,
                r.remeasured_turns,
                r.time_s,
                r.result.name()
            )?;
            if let Some(why) = &r.reject_reason {
                say!("{:<14} why: {why}", "")?;
            }
        }
        let s = &report.summary;
        say!(
            "\n{} parts, strategy {}, recipe {}: mean {:.1} s, {:.2} pushes (max {}), final e {:.2} µm (true {:.2} µm), {} rejected",
            s.parts,
            report.strategy,
            report.recipe,
            s.mean_time_s,
            s.mean_pushes,
            s.max_pushes,
            s.mean_final_e_um,
            s.mean_true_final_e_um,
            s.rejected
        )?;
        say!(
            "quality gate: {} turns re-measured, {} parts measurement_untrusted, {} push_inconsistent, {} device errors",
            s.remeasured_turns,
            s.untrusted,
            s.push_inconsistent,
            s.device_errors
        )?;
        say!(
            "Yu et al., 2024, 25 real parts: mean 25.1 s, 2.1 pushes (max 5), final e 3.8 µm; manual: 13.7 µm in 30–40 s; Wang et al.: 6.0 µm in 32.4 s"
        )?;
        say!(
            "simulated station: push gain {:.3}, push-direction offset {:+.2}° (learned {:.3}, {:+.2}°)",
            report.station_truth.gain,
            report.station_truth.offset_deg,
            report.learned.gain,
            report.learned.offset_deg
        )?;
    }
    if let Some(j) = json {
        outputs.json(j, report)?;
    }
    outputs.commit()?;
    if let Some(why) = &report.stopped {
        bail!("the batch {why} (recipe on_device_error = \"stop\"); the records so far are kept");
    }
    Ok(())
}
