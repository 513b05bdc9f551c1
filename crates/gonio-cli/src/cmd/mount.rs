//! `gonio mount`: mount a batch of gratings on the (simulated) automatic mounting station.

use crate::station::{self, FidelityArg, StrategyArg};
use crate::table::{self, fixed};
use anyhow::{Result, bail};
use gonio_cli::output::{OutId, Outputs};
use gonio_cli::say;
use gonio_io::formats::frames::load_scene;
use gonio_io::formats::recipe;
use gonio_io::recorder::{self, Recorder};
use gonio_sim::frames::{GratingScene, ScenePreset};
use gonio_sim::station::{BatchConfig, BatchReport, PartDone};
use gonio_station::Recipe;
use gonio_station::observe::NoObserver;
use gonio_station::published::YU_2024;
use gonio_station::tap::{FrameTap, SeenFrame};
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
al., 2024) and prints a table like their Table 3, on the simulated station (--sim) or through a
station's PLC (--plc modbus://HOST:PORT, docs/plc-interface.md) with its GenICam camera
(--camera ID): the same controller, quality gates, records and store either way.
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

With --record DIR, the chosen parts' measuring turns are kept for `gonio replay DIR`: raw
frames, stamps (the camera's frame ids and times too), live detector results and angle logs
(through --plc: the angles the PLC latched), and the record; the simulated station needs
--fidelity frames for it. Records carry --station-name (default: sim for --sim, this machine's
host name for --plc) and say whether the parts are the digital twin's (with --plc: when the PLC
says it is simulated, as `gonio simulate station` does).

Examples:
  gonio mount --sim --seed 1
  gonio mount --sim --parts 200 --strategy paper --seed 7 --json batch.json
  gonio mount --sim --parts 500 --seed 7 --db results.sqlite
  gonio mount --sim --parts 500 --seed 7 --db results.sqlite --resume
  gonio mount --sim --seed 7 --db postgres://gonio@/results?host=/run/postgresql --station-name line3-s2
  gonio mount --sim --recipe examples/recipes/r40-standard.toml --strategy live --seed 3
  gonio mount --sim --parts 5 --fidelity frames --scene dense --seed 4
  gonio mount --sim --parts 20 --fidelity frames --seed 4 --record rec --record-parts 3,17
  gonio mount --plc modbus://plc.line3:502 --camera Basler-acA1440-220um-40123456 --station-name line-3 --parts 50 --db results.sqlite
  gonio mount --plc modbus://plc.line3:502 --camera Basler-acA1440-220um-40123456 --station-name line-3 --record rejects --record-parts 7,12

Through --plc a device error (the PLC refused, closed or reset the connection or went silent,
its watchdog, a drive fault, the e-stop, a command that stays busy past the map's
command_timeout_s, the camera lost, a frame without a latched angle) ends the part
rejected_device_error naming the device, leaves the station safe (rod retracted, servo stopped,
trigger off where the link allows, all within the map's safe_state_ms) and stops the batch with
exit code 2. Ctrl-C (or SIGTERM) does the same for the part in progress, which is stored as
interrupted with what was measured, and exits with 130 (143); a second Ctrl-C exits at once.
In --json a value that was never measured (a part that ended before its first turn) is null.")]
pub struct Args {
    /// Use the simulated station (the digital twin with the default plant).
    #[arg(long, conflicts_with = "plc")]
    pub sim: bool,
    /// The station's PLC: modbus://HOST:PORT (Modbus TCP, docs/plc-interface.md).
    #[arg(long, value_name = "modbus://HOST:PORT", requires = "camera")]
    pub plc: Option<String>,
    /// The station's camera (a GenICam id, as `gonio camera list` shows it), triggered by the
    /// PLC.
    #[arg(long, value_name = "ID", requires = "plc")]
    pub camera: Option<String>,
    /// The PLC's register map (TOML; default: examples/plc/modbus-map.toml's values).
    #[arg(long, value_name = "FILE", requires = "plc")]
    pub plc_map: Option<PathBuf>,
    /// Number of parts.
    #[arg(long, default_value_t = 25, value_parser = gonio_cli::flag::whole::<usize>(crate::station::PARTS))]
    pub parts: usize,
    /// Push strategy (default live: through the wire and in the twin it needs fewer pushes,
    /// ends closer and sooner than learned; BENCHMARKS.md, "Station over Modbus TCP").
    #[arg(long, value_enum, default_value = "live")]
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
    /// Seed of the simulation (same seed, same bytes); needed with --sim.
    #[arg(long, required_unless_present = "plc")]
    pub seed: Option<u64>,
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
    /// The station's name in its records and the results store [default: sim for the
    /// simulated station, this machine's host name for a station through its PLC].
    #[arg(long, value_name = "NAME")]
    pub station_name: Option<String>,
    /// Record the parts' measuring turns here for `gonio replay`: their raw frames (the raw
    /// stream format of `detect --raw`), stamps, live detector results and angle logs, and the
    /// station's record (with --sim: needs --fidelity frames).
    #[arg(long, value_name = "DIR")]
    pub record: Option<PathBuf>,
    /// Record only these parts (1-based, e.g. 3,17); default: every part.
    #[arg(long, value_name = "N,N,…", requires = "record")]
    pub record_parts: Option<String>,
}

/// Runs `gonio mount`.
pub fn run(a: Args) -> Result<()> {
    if let Some(plc) = a.plc.clone() {
        return run_plc(a, &plc);
    }
    if !a.sim {
        bail!("no station given: --sim for the simulated station, or --plc and --camera");
    }
    let Some(seed) = a.seed else {
        bail!("--sim needs --seed");
    };
    let mut outputs = Outputs::new();
    if let Some(db) = &a.db {
        crate::db::reserve(outputs.inputs(), db);
    }
    let json = outputs.optional("--json", a.json.as_deref())?;
    let recipe = match &a.recipe {
        Some(p) => recipe::load(outputs.inputs(), p)?,
        None => Recipe::default(),
    };
    let scene = match (&a.scene_file, a.scene) {
        (Some(p), _) => load_scene(outputs.inputs(), p)?,
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
    let station_name = station::station_name(a.station_name.as_deref(), true);
    let target = station::Target {
        db: a.db.as_deref(),
        resume: a.resume,
        station: &station_name,
    };
    let prepared = match station::prepare(&cfg, seed, &target)? {
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
    let recorder = start_recording(
        &a,
        record_parts,
        prepared.first_part,
        Some(seed),
        &station_name,
        true,
        &cfg.recipe,
        cfg.strategy,
    )?;
    let tap_to = recorder.clone();
    let mut observer = recorder.clone();
    let mut none = NoObserver;
    // The table's rows are printed as the parts end, so a batch without --json keeps no part
    // in memory (a million parts in a few MB).
    let table = !to_stdout;
    if table {
        say!("{}", table::mount::HEADER)?;
    }
    let mut printed: Result<()> = Ok(());
    let report = station::run(
        *prepared,
        &cfg,
        seed,
        station::Run {
            observer: match observer.as_mut() {
                Some(r) => r,
                None => &mut none,
            },
            pace: None,
            frame_tap: tap_to.map(|r| Box::new(move |f: &SeenFrame<'_>| r.tap(f)) as FrameTap<'_>),
            discard_parts: json.is_none(),
        },
        &mut |d: &PartDone, _| {
            if table && printed.is_ok() {
                printed = bar.suspend(|| print_row(&d.part.record));
            }
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
    printed?;
    drop(observer);
    finish_recording(recorder, a.record.as_deref())?;
    print_and_write(&report, to_stdout, outputs, json)
}

/// The recorder of `--record DIR` (`None` without it): the chosen parts (1-based) of a batch
/// starting at 0-based part `first_part`.
#[allow(clippy::too_many_arguments)]
fn start_recording(
    a: &Args,
    parts: Option<std::collections::BTreeSet<usize>>,
    first_part: usize,
    seed: Option<u64>,
    station: &str,
    simulated: bool,
    recipe: &Recipe,
    strategy: gonio_station::Strategy,
) -> Result<Option<Recorder>> {
    let Some(dir) = &a.record else {
        return Ok(None);
    };
    Ok(Some(Recorder::new(recorder::Recording {
        dir: dir.clone(),
        parts,
        first_part,
        seed,
        station: station.to_string(),
        simulated,
        recipe: recipe.clone(),
        strategy,
        software_version: crate::db::software_version(),
        guard: recorder::DirGuard {
            install: gonio_cli::output::install_signal_cleanup,
            created_dir: gonio_cli::output::guard_created_dir,
            temporary_dir: gonio_cli::output::guard_temporary_dir,
            release: gonio_cli::output::release_dir,
        },
    })?))
}

/// Ends the recording: its first error, or a line saying what was recorded in `dir`.
fn finish_recording(recorder: Option<Recorder>, dir: Option<&std::path::Path>) -> Result<()> {
    let (Some(r), Some(dir)) = (recorder, dir) else {
        return Ok(());
    };
    let (written, error) = r.finish();
    if let Some(e) = error {
        return Err(e);
    }
    gonio_cli::note!(
        "recorded {} part(s) in {dir} (gonio replay {dir} re-runs them)",
        written.len(),
        dir = dir.display()
    );
    Ok(())
}

/// One part's row of the table (and why it was rejected, on a line of its own).
fn print_row(r: &gonio_station::PartRecord) -> Result<()> {
    say!("{}", table::mount::row(r))
}

/// The summary lines (when stdout is not the JSON) and the JSON; the table's rows were
/// printed as the parts ended.
fn print_and_write(
    report: &BatchReport,
    to_stdout: bool,
    mut outputs: Outputs,
    json: Option<OutId>,
) -> Result<()> {
    if !to_stdout {
        let s = &report.summary;
        say!(
            "\n{} parts, strategy {}, recipe {}: mean {} s, {:.2} pushes (max {}), final e {} µm (true {} µm), {} rejected",
            s.parts,
            report.strategy,
            report.recipe,
            fixed(s.mean_time_s, 1),
            s.mean_pushes,
            s.max_pushes,
            fixed(s.mean_final_e_um, 2),
            fixed(s.mean_true_final_e_um, 2),
            s.rejected
        )?;
        say!(
            "quality gate: {} turns re-measured, {} parts measurement_untrusted, {} push_inconsistent, {} device errors",
            s.remeasured_turns,
            s.untrusted,
            s.push_inconsistent,
            s.device_errors
        )?;
        if let Some(line) = table::mount::phase_line(report.parts.iter().map(|p| &p.record)) {
            say!("{line}")?;
        }
        let y = &YU_2024;
        say!(
            "Yu et al., 2024, {} real parts: mean {} s, {} pushes (max {}), final e {} µm; manual: {} µm in {}–{} s; Wang et al.: {:.1} µm in {} s",
            y.parts,
            y.mean_time_s,
            y.mean_pushes,
            y.max_pushes,
            y.mean_final_e_um,
            y.manual_final_e_um,
            y.manual_time_s.0,
            y.manual_time_s.1,
            y.wang_final_e_um,
            y.wang_time_s
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

/// `gonio mount --plc`: the controller through the PLC and its triggered camera.
fn run_plc(a: Args, url: &str) -> Result<()> {
    if a.resume || a.fidelity != FidelityArg::Fast {
        bail!("--resume and --fidelity are for --sim; --plc mounts real parts");
    }
    let mut outputs = Outputs::new();
    if let Some(db) = &a.db {
        crate::db::reserve(outputs.inputs(), db);
    }
    let recipe = match &a.recipe {
        Some(p) => recipe::load(outputs.inputs(), p)?,
        None => Recipe::default(),
    };
    let record_parts = a
        .record_parts
        .as_deref()
        .map(|s| recorder::parse_parts(s, a.parts))
        .transpose()?;
    if let Some(p) = &a.plc_map {
        outputs.inputs().record(p);
    }
    let json = outputs.optional("--json", a.json.as_deref())?;
    let to_stdout = outputs.to_stdout(json);
    let station_name = station::station_name(a.station_name.as_deref(), false);
    let strategy = a.strategy.into();
    // From here the first Ctrl-C (or SIGTERM) ends the batch safely; a second exits at once.
    let interrupt = gonio_plc::Interrupt::new();
    let _deferred = gonio_cli::output::defer_interrupts(interrupt.flag());
    let batch = crate::plc::open(
        crate::plc::Request {
            url: url.to_string(),
            camera: a.camera.clone().unwrap_or_default(),
            plc_map: a.plc_map.clone(),
            recipe,
            strategy: a.strategy,
            parts: a.parts,
            db: a.db.clone(),
            station_name: station_name.clone(),
        },
        None,
    )
    .map_err(|e| match interrupt.signal() {
        // Interrupted while the station was being opened: nothing was mounted.
        Some(signal) => gonio_cli::output::Interrupted {
            signal,
            message: format!("before the station was open ({e})"),
        }
        .into(),
        None => e,
    })?;
    batch.set_interrupt(interrupt.clone());
    let recorder = start_recording(
        &a,
        record_parts,
        0,
        None,
        &station_name,
        batch.simulated(),
        batch.recipe(),
        strategy,
    )?;
    if let Some(r) = recorder.clone() {
        batch.set_tap(Box::new(move |f: &SeenFrame<'_>| r.tap(f)));
    }
    let mut observer = recorder.clone();
    let mut none = NoObserver;
    let bar = ProgressBar::new(a.parts as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} parts {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let table = !to_stdout;
    if table {
        say!("{}", table::mount::HEADER)?;
    }
    let mut printed: Result<()> = Ok(());
    let observer: &mut dyn gonio_station::observe::Observer = match observer.as_mut() {
        Some(r) => r,
        None => &mut none,
    };
    let report = batch.run(observer, &mut |d, _| {
        if table && printed.is_ok() {
            printed = bar.suspend(|| print_row(d.record));
        }
        bar.inc(1);
        bar.set_message(format!("{} {}", d.record.serial, d.record.result.name()));
    });
    let report = match report {
        Ok(r) => r,
        Err(e) => {
            bar.abandon();
            return Err(e);
        }
    };
    bar.finish_and_clear();
    printed?;
    if !to_stdout {
        let s = &report.summary;
        say!(
            "\n{} parts through {}, strategy {}: mean {} s (focus {}, measure {}, push {}), {:.2} pushes (max {}), final e {} µm, {} rejected, {} device errors",
            s.parts,
            report.plc,
            report.strategy,
            fixed(s.mean_time_s, 1),
            fixed(s.mean_focus_s, 1),
            fixed(s.mean_measure_s, 1),
            fixed(s.mean_push_s, 1),
            s.mean_pushes,
            s.max_pushes,
            fixed(s.mean_final_e_um, 2),
            s.rejected,
            s.device_errors
        )?;
        if let Some(line) = table::mount::phase_line(report.parts.iter().map(|p| &p.record)) {
            say!("{line}")?;
        }
        let l = &report.link;
        say!(
            "link: {} requests, round trip p50 {} ms, p99 {} ms; {} frames paired with latched angles, {} skipped as stale",
            l.requests,
            fixed(l.round_trip_p50_ms, 2),
            fixed(l.round_trip_p99_ms, 2),
            l.frames_paired,
            l.frames_stale
        )?;
    }
    finish_recording(recorder, a.record.as_deref())?;
    if let Some(j) = json {
        // The station's name first, as its records carry it.
        #[derive(serde::Serialize)]
        struct Named<'a> {
            station: &'a str,
            #[serde(flatten)]
            report: &'a gonio_plc::batch::PlcBatchReport,
        }
        let named = Named {
            station: &station_name,
            report: &report,
        };
        outputs.json_with_nulls(j, &named)?;
    }
    outputs.commit()?;
    if let Some(signal) = interrupt.signal() {
        return Err(gonio_cli::output::Interrupted {
            signal,
            message: format!(
                "the batch {}; the records so far are kept",
                report.stopped.as_deref().unwrap_or("stopped")
            ),
        }
        .into());
    }
    if let Some(why) = &report.stopped {
        bail!("the batch {why}; the records so far are kept");
    }
    Ok(())
}
