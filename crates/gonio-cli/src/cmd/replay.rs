//! `gonio replay`: re-run a recorded part's detection and fit and compare with its record.

use anyhow::{Result, anyhow, bail};
use gonio_cli::say;
use gonio_io::formats::replay::{self, PartFile};
use gonio_io::input::Inputs;
use gonio_station::DetectorCamera;
use gonio_station::replay::{TurnReplay, replay_turn};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Arguments of `gonio replay`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Reads a record written by `gonio mount … --record DIR` (one directory per part: part.json, and per
measuring turn its raw frames turn-N.raw and its stamps and angle log turn-N.json), runs every
frame through the ring detector again, evaluates every turn again with the recorded angle log,
recipe and strategy (the controller's own code), and compares the frames' results and the turns
(samples, e, θ_max, c₀, residual, outliers, quality verdict) with the record, bit for bit.
Prints one line per part; any difference is listed and the command fails (exit code 2).

Examples:
  gonio mount --sim --fidelity frames --parts 20 --seed 4 --record rec --record-parts 3,17
  gonio replay rec
  gonio replay rec/part-0003 --json replay.json")]
pub struct Args {
    /// The record directory (or one part's directory in it).
    pub dir: PathBuf,
    /// Write the comparison as JSON here (`-` for standard output).
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
}

/// One part's replay.
#[derive(Debug, Serialize)]
struct PartReplay {
    dir: String,
    serial: String,
    batch_index: usize,
    turns: Vec<TurnReplay>,
}

fn replay_part(inputs: &Inputs, dir: &Path, part: &PartFile) -> Result<Vec<TurnReplay>> {
    if part.turns.len() != part.record.turns.len() {
        bail!(
            "{}: {} recorded turns, the part's record has {}",
            dir.join("part.json").display(),
            part.turns.len(),
            part.record.turns.len()
        );
    }
    let mut out = Vec::with_capacity(part.turns.len());
    for (files, stored) in part.turns.iter().zip(&part.record.turns) {
        let rec = replay::read_turn(inputs, dir, files)?;
        let frames = replay::open_raw(dir, part, files, &rec)?;
        let mut cam = DetectorCamera::new(frames, &part.optics)
            .map_err(|e| anyhow!("{}: optics: {e}", dir.join("part.json").display()))?;
        let r = replay_turn(&mut cam, &part.recipe, part.strategy, &rec, stored)
            .map_err(|e| anyhow!("{}: {e}", dir.join(&files.raw).display()))?;
        out.push(r);
    }
    Ok(out)
}

/// Runs `gonio replay`.
pub fn run(a: Args) -> Result<()> {
    let dirs = replay::part_dirs(&a.dir)?;
    let inputs = Inputs::new();
    let to_stdout = a.json.as_deref().is_some_and(|p| p.as_os_str() == "-");
    let mut parts = Vec::with_capacity(dirs.len());
    let (mut differing, mut turns, mut frames) = (0usize, 0usize, 0usize);
    for dir in &dirs {
        let part = replay::read_part(&inputs, dir)?;
        let replayed = replay_part(&inputs, dir, &part)?;
        let n_frames: usize = replayed.iter().map(|t| t.frames).sum();
        let diffs: usize = replayed.iter().map(|t| t.differences.len()).sum();
        turns += replayed.len();
        frames += n_frames;
        if !to_stdout {
            if diffs == 0 {
                say!(
                    "{} ({}): {} turns, {n_frames} frames: identical to the record",
                    part.serial,
                    dir.display(),
                    replayed.len()
                )?;
            } else {
                say!(
                    "{} ({}): DIFFERS from the record",
                    part.serial,
                    dir.display()
                )?;
                for (i, t) in replayed.iter().enumerate() {
                    if t.frames_differing > 0 {
                        say!(
                            "  turn {}: {} of {} frames give another detector result",
                            i + 1,
                            t.frames_differing,
                            t.frames
                        )?;
                    }
                    for d in &t.differences {
                        say!(
                            "  turn {} {}: recorded {}, replayed {}",
                            i + 1,
                            d.field,
                            d.recorded,
                            d.replayed
                        )?;
                    }
                }
            }
        }
        if diffs > 0 {
            differing += 1;
        }
        parts.push(PartReplay {
            dir: dir.display().to_string(),
            serial: part.serial.clone(),
            batch_index: part.batch_index,
            turns: replayed,
        });
    }
    if let Some(p) = &a.json {
        let mut out = gonio_cli::output::Outputs::with_inputs(inputs);
        let id = out.file("--json", p)?;
        out.json(id, &parts)?;
        out.commit()?;
    }
    if differing > 0 {
        bail!(
            "the replay differs from the record in {differing} of {} part(s)",
            parts.len()
        );
    }
    if !to_stdout {
        say!(
            "{} part(s), {turns} turns, {frames} frames replayed: bit-identical to the record",
            parts.len()
        )?;
    }
    Ok(())
}
