//! The digital twin's batch in the results store, the one path of `gonio mount --sim` and
//! `gonio serve --station sim`: the twin's batch (`gonio_sim::station`) with each part
//! committed through the store's batch writer (`gonio_store::writer`) as it finishes, a
//! batch resumed after its last stored part, and the batch's end status. Errors are one-line
//! texts for the terminal.

use anyhow::{Result, anyhow};
use gonio_sim::station::{
    BatchConfig, BatchReport, FrameTap, Pace, PartDone, RunOptions, run_batch_observed,
};
use gonio_station::observe::Observer;
use gonio_station::strategy::Learned;
use gonio_store::writer::{BatchSpec, BatchWriter, Resume};
use std::ops::ControlFlow;

/// Where a batch's parts go.
#[derive(Debug, Clone)]
pub struct Target<'a> {
    /// The store: a SQLite path or a `postgres://` URL (`None`: no store).
    pub db: Option<&'a str>,
    /// Continue the most recent batch of this station with the same settings.
    pub resume: bool,
    /// The station's name in the store.
    pub station: &'a str,
}

/// A batch ready to run: its store and where it starts.
pub struct Prepared {
    writer: Option<BatchWriter>,
    location: String,
    /// 0-based index of the first part to mount.
    pub first_part: usize,
    learned: Learned,
    /// The focus drive's position the last stored part left it at, µm (a resumed batch).
    carried_focus_um: Option<f64>,
    /// What `--resume` found (a line for the terminal).
    pub note: Option<String>,
}

/// How [`prepare`] ended.
pub enum Start {
    /// The batch is ready to run.
    Run(Box<Prepared>),
    /// `--resume` found the batch complete: nothing to do (a line for the terminal).
    Complete(String),
}

/// The batch's identity in the store: what was asked for, so `--resume` finds the same batch.
fn batch_config_json(cfg: &BatchConfig, seed: u64) -> Result<String> {
    Ok(serde_json::to_string(&serde_json::json!({
        "seed": seed,
        "config": cfg,
    }))?)
}

/// Opens the store and starts the batch in it, or finds the batch to resume.
///
/// # Errors
/// The store cannot be opened or written; `--resume` finds no batch with these settings.
pub fn prepare(cfg: &BatchConfig, seed: u64, t: &Target<'_>) -> Result<Start> {
    let Some(location) = t.db else {
        return Ok(Start::Run(Box::new(Prepared {
            writer: None,
            location: String::new(),
            first_part: 0,
            learned: Learned::default(),
            carried_focus_um: None,
            note: None,
        })));
    };
    let st = crate::db::open(location)?;
    let loc = gonio_store::display_location(location);
    let config_json = batch_config_json(cfg, seed)?;
    let spec = BatchSpec {
        station: t.station,
        seed: Some(seed),
        config_json: &config_json,
        parts: cfg.parts,
        recipe: &cfg.recipe,
        simulated: true,
    };
    let mut p = Prepared {
        writer: None,
        location: loc.clone(),
        first_part: 0,
        learned: Learned::default(),
        carried_focus_um: None,
        note: None,
    };
    if t.resume {
        match BatchWriter::resume(st, &spec).map_err(|e| anyhow!("{loc}: {e}"))? {
            Resume::NotFound => {
                return Err(anyhow!(
                    "{loc}: no batch of station {} with these settings (seed {seed}, {} parts, strategy {}, recipe {}) to resume: start it without --resume",
                    t.station,
                    cfg.parts,
                    cfg.strategy.name(),
                    cfg.recipe.name
                ));
            }
            Resume::Complete(info) => {
                return Ok(Start::Complete(format!(
                    "batch {} in {loc} is complete ({} of {} parts stored): nothing to resume",
                    info.batch, info.parts_stored, info.parts_planned
                )));
            }
            Resume::Found(mut w, info) => {
                p.note = Some(format!(
                    "resuming batch {} in {loc} at part {} of {} ({} stored)",
                    info.batch,
                    info.next_index() + 1,
                    info.parts_planned,
                    info.parts_stored
                ));
                p.first_part = info.next_index();
                p.learned = info.learned.unwrap_or_default();
                // The focus the last stored part found: where the next part's focus check starts.
                p.carried_focus_um = w
                    .last_part()
                    .map_err(|e| anyhow!("{loc}: {e}"))?
                    .and_then(|part| part.focus_um);
                p.writer = Some(*w);
            }
        }
    } else {
        p.writer = Some(BatchWriter::begin(st, &spec).map_err(|e| anyhow!("{loc}: {e}"))?);
    }
    Ok(Start::Run(Box::new(p)))
}

/// How the batch runs besides its parts.
pub struct Run<'a> {
    /// Told everything the station does (a live view).
    pub observer: &'a mut dyn Observer,
    /// In step with the wall clock (a live view); `None`: as fast as possible.
    pub pace: Option<Pace>,
    /// Told every rendered frame (full fidelity): a recorder, the live thumbnail.
    pub frame_tap: Option<FrameTap<'a>>,
    /// Keep no part in the returned report (its summary still counts them all): a long batch
    /// whose parts go only to the store or to a table printed as they end.
    pub discard_parts: bool,
}

/// Runs the prepared batch: each part committed to the store as it finishes, then
/// `on_part(part, stored id)`; the batch marked complete or stopped at the end.
///
/// # Errors
/// The renderer cannot be set up; the station fails; a part cannot be stored (the batch stops
/// there and stays resumable).
pub fn run(
    p: Prepared,
    cfg: &BatchConfig,
    seed: u64,
    run: Run<'_>,
    on_part: &mut dyn FnMut(&PartDone, Option<i64>),
) -> Result<BatchReport> {
    let Prepared {
        mut writer,
        location,
        first_part,
        learned,
        carried_focus_um,
        ..
    } = p;
    let mut clock = writer.as_ref().map(BatchWriter::clock);
    let mut none = gonio_station::observe::NoObserver;
    let clock: &mut dyn Observer = match clock.as_mut() {
        Some(c) => c,
        None => &mut none,
    };
    let mut both = (clock, run.observer);
    let opts = RunOptions {
        first_part,
        learned,
        carried_focus_um,
        observer: Some(&mut both),
        pace: run.pace,
        // A shorter lifetime for the tap, as for the observers (a trait object's lifetime
        // shortens by coercion even behind `&mut`).
        frame_tap: run.frame_tap.map(|t| t as FrameTap<'_>),
        discard_parts: run.discard_parts,
    };
    let mut error = None;
    let report = run_batch_observed(cfg, seed, opts, &mut |d: &PartDone| {
        let Some(w) = writer.as_mut() else {
            on_part(d, None);
            return ControlFlow::Continue(());
        };
        let truth = Some((d.part.true_initial_e_um, d.part.true_final_e_um));
        match w.commit(d.index, &d.part.record, d.learned, truth) {
            Ok(id) => {
                on_part(d, Some(id));
                ControlFlow::Continue(())
            }
            Err(e) => {
                error = Some(anyhow!(
                    "storing part {} ({}): {e}",
                    d.index + 1,
                    d.part.record.serial
                ));
                ControlFlow::Break(())
            }
        }
    })
    .map_err(|e| anyhow!("simulated station: {e}"))?;
    if let Some(e) = error {
        return Err(e);
    }
    if let Some(w) = writer.as_mut() {
        w.end(report.stopped.as_deref())
            .map_err(|e| anyhow!("{location}: {e}"))?;
    }
    Ok(report)
}
