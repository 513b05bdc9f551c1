//! A simulated batch committed to the results store part by part: the one path of
//! `gonio mount` and `gonio serve` (opening or resuming the batch in the store, each part
//! stored in one transaction as it finishes, the batch's end status), and a batch through a
//! PLC in the store ([`PlcStore`]). Errors are `anyhow` errors with one-line texts for the
//! terminal; nothing here prints.

use crate::station::{
    BatchConfig, BatchReport, FrameTap, Pace, PartDone, RunOptions, run_batch_observed,
};
use anyhow::{Result, anyhow};
use gonio_station::Recipe;
use gonio_station::observe::Observer;
use gonio_station::strategy::Learned;
use gonio_store::{BatchStatus, NewBatch, NewPart, Store};
use std::cell::RefCell;
use std::ops::ControlFlow;
use std::rc::Rc;

/// Most parts in one batch: one limit for `gonio mount --sim` and `gonio serve --station sim`.
pub const MAX_PARTS: usize = 1_000_000;

/// The software that writes records (`gonio 0.1.0`).
///
/// `CARGO_PKG_VERSION` here is gonio-sim's version, which is the `gonio` package's: every crate
/// of the workspace takes `version.workspace = true` (the workspace's `[workspace.package]`).
pub fn software_version() -> String {
    format!("gonio {}", env!("CARGO_PKG_VERSION"))
}

/// Opens the store at `location` (a SQLite path or a `postgres://` URL), migrating it.
///
/// # Errors
/// The store cannot be opened (`results store LOCATION: …`).
pub fn open(location: &str) -> Result<Box<dyn Store>> {
    gonio_store::open(location).map_err(|e| {
        anyhow!(
            "results store {}: {e}",
            gonio_store::display_location(location)
        )
    })
}

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
    store: Option<Box<dyn Store>>,
    batch: Option<i64>,
    location: String,
    /// 0-based index of the first part to mount.
    pub first_part: usize,
    learned: Learned,
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
            store: None,
            batch: None,
            location: String::new(),
            first_part: 0,
            learned: Learned::default(),
            carried_focus_um: None,
            note: None,
        })));
    };
    let mut st = open(location)?;
    let loc = gonio_store::display_location(location);
    let config_json = batch_config_json(cfg, seed)?;
    let mut p = Prepared {
        store: None,
        batch: None,
        location: loc.clone(),
        first_part: 0,
        learned: Learned::default(),
        carried_focus_um: None,
        note: None,
    };
    if t.resume {
        let info = st
            .latest_batch(t.station, &config_json)
            .map_err(|e| anyhow!("{loc}: {e}"))?
            .ok_or_else(|| {
                anyhow!(
                    "{loc}: no batch of station {} with these settings (seed {seed}, {} parts, strategy {}, recipe {}) to resume: start it without --resume",
                    t.station,
                    cfg.parts,
                    cfg.strategy.name(),
                    cfg.recipe.name
                )
            })?;
        if info.next_index() >= info.parts_planned {
            return Ok(Start::Complete(format!(
                "batch {} in {loc} is complete ({} of {} parts stored): nothing to resume",
                info.batch, info.parts_stored, info.parts_planned
            )));
        }
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
        if info.parts_stored > 0 {
            p.carried_focus_um = st
                .parts(&gonio_store::PartQuery {
                    batch: Some(info.batch),
                    limit: Some(1),
                    ..gonio_store::PartQuery::default()
                })
                .map_err(|e| anyhow!("{loc}: {e}"))?
                .last()
                .and_then(|p| p.focus_um);
        }
        p.batch = Some(info.batch);
    } else {
        p.batch = Some(
            st.begin_batch(&NewBatch {
                station: t.station,
                seed: Some(seed),
                config_json: &config_json,
                parts_planned: cfg.parts,
                software_version: &software_version(),
            })
            .map_err(|e| anyhow!("{loc}: {e}"))?,
        );
    }
    p.store = Some(st);
    Ok(Start::Run(Box::new(p)))
}

/// Notes the wall-clock start of each part (for its record in the store).
struct WallClock {
    started_at: Rc<RefCell<String>>,
}

impl Observer for WallClock {
    fn part_started(&mut self, _serial: &str) {
        *self.started_at.borrow_mut() = gonio_store::time::now_utc();
    }
}

/// Where a batch writes its parts.
struct Sink<'a> {
    store: &'a mut dyn Store,
    batch: i64,
    station: &'a str,
    recipe: &'a Recipe,
    version: String,
    error: Option<anyhow::Error>,
}

impl Sink<'_> {
    fn commit(&mut self, d: &PartDone, started_at: &str) -> Option<i64> {
        let ended_at = gonio_store::time::now_utc();
        let r = self.store.insert_part(&NewPart {
            batch: self.batch,
            batch_index: d.index,
            station: self.station,
            software_version: &self.version,
            recipe: self.recipe,
            started_at,
            ended_at: &ended_at,
            record: &d.part.record,
            learned: d.learned,
            truth: Some((d.part.true_initial_e_um, d.part.true_final_e_um)),
        });
        match r {
            Ok(id) => Some(id),
            Err(e) => {
                self.error = Some(anyhow!(
                    "storing part {} ({}): {e}",
                    d.index + 1,
                    d.part.record.serial
                ));
                None
            }
        }
    }
}

/// How the batch runs besides its parts.
pub struct Run<'a> {
    /// Told everything the station does (a live view).
    pub observer: &'a mut dyn Observer,
    /// In step with the wall clock (a live view); `None`: as fast as possible.
    pub pace: Option<Pace>,
    /// Told every rendered frame (full fidelity): a recorder, the live thumbnail.
    pub frame_tap: Option<FrameTap<'a>>,
    /// The station's name in the store.
    pub station: &'a str,
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
        mut store,
        batch,
        location,
        first_part,
        learned,
        carried_focus_um,
        ..
    } = p;
    let started = Rc::new(RefCell::new(gonio_store::time::now_utc()));
    let mut clock = WallClock {
        started_at: started.clone(),
    };
    let mut sink = match (store.as_mut(), batch) {
        (Some(st), Some(b)) => Some(Sink {
            store: st.as_mut(),
            batch: b,
            station: run.station,
            recipe: &cfg.recipe,
            version: software_version(),
            error: None,
        }),
        _ => None,
    };
    let mut both = (&mut clock, run.observer);
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
    let report = run_batch_observed(cfg, seed, opts, &mut |d: &PartDone| match sink.as_mut() {
        Some(s) => match s.commit(d, &started.borrow()) {
            Some(id) => {
                on_part(d, Some(id));
                ControlFlow::Continue(())
            }
            None => ControlFlow::Break(()),
        },
        None => {
            on_part(d, None);
            ControlFlow::Continue(())
        }
    })
    .map_err(|e| anyhow!("simulated station: {e}"))?;
    if let Some(e) = sink.and_then(|s| s.error) {
        return Err(e);
    }
    if let (Some(st), Some(b)) = (store.as_mut(), batch) {
        let (status, reason) = match &report.stopped {
            Some(why) => (BatchStatus::Stopped, Some(why.as_str())),
            None => (BatchStatus::Complete, None),
        };
        st.end_batch(b, status, reason)
            .map_err(|e| anyhow!("{location}: {e}"))?;
    }
    Ok(report)
}

/// A batch through a real (or simulated) PLC in the results store: opened before the first
/// part, each part committed in one transaction as it ends, the batch's status at the end.
pub struct PlcStore {
    store: Box<dyn Store>,
    batch: i64,
    location: String,
    station: String,
    recipe: Recipe,
    version: String,
    started_at: String,
}

impl PlcStore {
    /// Opens the store at `db` and begins a batch of `parts` parts with `config_json` (what
    /// was asked for: the PLC, strategy, recipe).
    ///
    /// # Errors
    /// The store cannot be opened or written.
    pub fn begin(
        db: &str,
        station: &str,
        recipe: &Recipe,
        config_json: &str,
        parts: usize,
    ) -> Result<Self> {
        let mut st = open(db)?;
        let location = gonio_store::display_location(db);
        let version = software_version();
        let batch = st
            .begin_batch(&NewBatch {
                station,
                seed: None,
                config_json,
                parts_planned: parts,
                software_version: &version,
            })
            .map_err(|e| anyhow!("{location}: {e}"))?;
        Ok(PlcStore {
            store: st,
            batch,
            location,
            station: station.to_string(),
            recipe: recipe.clone(),
            version,
            started_at: gonio_store::time::now_utc(),
        })
    }

    /// Commits one part (no truth: a real station has none).
    ///
    /// # Errors
    /// The store cannot be written.
    pub fn commit(
        &mut self,
        index: usize,
        record: &gonio_station::PartRecord,
        learned: &Learned,
    ) -> Result<i64> {
        let ended_at = gonio_store::time::now_utc();
        let id = self
            .store
            .insert_part(&NewPart {
                batch: self.batch,
                batch_index: index,
                station: &self.station,
                software_version: &self.version,
                recipe: &self.recipe,
                started_at: &self.started_at,
                ended_at: &ended_at,
                record,
                learned,
                truth: None,
            })
            .map_err(|e| anyhow!("{}: storing {}: {e}", self.location, record.serial))?;
        self.started_at = ended_at;
        Ok(id)
    }

    /// Ends the batch: complete, or stopped with its reason.
    ///
    /// # Errors
    /// The store cannot be written.
    pub fn end(&mut self, stopped: Option<&str>) -> Result<()> {
        let status = if stopped.is_some() {
            BatchStatus::Stopped
        } else {
            BatchStatus::Complete
        };
        self.store
            .end_batch(self.batch, status, stopped)
            .map_err(|e| anyhow!("{}: {e}", self.location))
    }
}
