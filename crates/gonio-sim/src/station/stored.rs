//! The digital twin's batch in the results store (feature `store`), the one path of `gonio
//! mount --sim` and `gonio serve --station sim`: the twin's batch ([`run_batch_observed`]) with
//! each part committed through the store's batch writer (`gonio_store::writer`) as it finishes,
//! a batch resumed after its last stored part, and the batch's end status. Errors
//! ([`StoredError`]) name the store (as `gonio_store::display_location` shows it) or the part.
//!
//! ```
//! use gonio_sim::station::BatchConfig;
//! use gonio_sim::station::stored::{Run, Start, Target, prepare, run};
//! let d = tempfile::tempdir().unwrap();
//! let db = d.path().join("r.sqlite").display().to_string();
//! let cfg = BatchConfig { parts: 2, ..BatchConfig::default() };
//! let target = Target { db: Some(&db), resume: false, station: "sim" };
//! let Start::Run(p) = prepare(&cfg, 7, &target).unwrap() else { panic!("a new batch") };
//! let mut none = gonio_station::observe::NoObserver;
//! let run_opts = Run { observer: &mut none, pace: None, frame_tap: None, discard_parts: false };
//! let report = run(*p, &cfg, 7, run_opts, &mut |_, id| assert!(id.is_some())).unwrap();
//! assert_eq!(report.parts.len(), 2);
//! let again = Target { resume: true, ..target };
//! assert!(matches!(prepare(&cfg, 7, &again).unwrap(), Start::Complete(_)));
//! ```

use super::{BatchConfig, BatchReport, FrameTap, Pace, PartDone, RunOptions, run_batch_observed};
use gonio_station::StationError;
use gonio_station::observe::Observer;
use gonio_station::strategy::Learned;
use gonio_store::StoreError;
use gonio_store::writer::{BatchSpec, BatchWriter, Resume};
use std::ops::ControlFlow;

/// Why a batch in the store could not start, run or end.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum StoredError {
    /// The store cannot be opened.
    #[error("results store {location}")]
    Open {
        /// The store as shown to a person (a URL without its password).
        location: String,
        /// What the store said.
        #[source]
        source: StoreError,
    },
    /// The store failed while the batch was started, resumed or ended.
    #[error("{location}")]
    Store {
        /// The store as shown to a person.
        location: String,
        /// What the store said.
        #[source]
        source: StoreError,
    },
    /// `resume` found no batch of this station with these settings.
    #[error(
        "{location}: no batch of station {station} with these settings (seed {seed}, {parts} parts, strategy {strategy}, recipe {recipe}) to resume: start it without --resume"
    )]
    NotFound {
        /// The store as shown to a person.
        location: String,
        /// The station's name in the store.
        station: String,
        /// The batch's seed.
        seed: u64,
        /// Parts planned.
        parts: usize,
        /// The push strategy's name.
        strategy: String,
        /// The recipe's name.
        recipe: String,
    },
    /// A finished part could not be stored: the batch stops there and stays resumable.
    #[error("storing part {part} ({serial})")]
    Commit {
        /// 1-based number of the part in the batch.
        part: usize,
        /// The part's serial number.
        serial: String,
        /// What the store said.
        #[source]
        source: StoreError,
    },
    /// The simulated station failed.
    #[error("simulated station")]
    Station(#[source] StationError),
    /// The batch's settings could not be written as its identity in the store.
    #[error("the batch's settings as JSON")]
    Config(#[source] serde_json::Error),
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
fn batch_config_json(cfg: &BatchConfig, seed: u64) -> Result<String, StoredError> {
    serde_json::to_string(&serde_json::json!({
        "seed": seed,
        "config": cfg,
    }))
    .map_err(StoredError::Config)
}

/// Opens the store and starts the batch in it, or finds the batch to resume.
///
/// # Errors
/// The store cannot be opened or written; `--resume` finds no batch with these settings.
pub fn prepare(cfg: &BatchConfig, seed: u64, t: &Target<'_>) -> Result<Start, StoredError> {
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
    let loc = gonio_store::display_location(location);
    let st = gonio_store::open(location).map_err(|source| StoredError::Open {
        location: loc.clone(),
        source,
    })?;
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
        let in_store = |source| StoredError::Store {
            location: loc.clone(),
            source,
        };
        match BatchWriter::resume(st, &spec).map_err(in_store)? {
            Resume::NotFound => {
                return Err(StoredError::NotFound {
                    location: loc,
                    station: t.station.to_string(),
                    seed,
                    parts: cfg.parts,
                    strategy: cfg.strategy.name().to_string(),
                    recipe: cfg.recipe.name.clone(),
                });
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
                    .map_err(in_store)?
                    .and_then(|part| part.focus_um);
                p.writer = Some(*w);
            }
        }
    } else {
        p.writer = Some(
            BatchWriter::begin(st, &spec).map_err(|source| StoredError::Store {
                location: loc.clone(),
                source,
            })?,
        );
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
) -> Result<BatchReport, StoredError> {
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
                error = Some(StoredError::Commit {
                    part: d.index + 1,
                    serial: d.part.record.serial.clone(),
                    source: e,
                });
                ControlFlow::Break(())
            }
        }
    })
    .map_err(StoredError::Station)?;
    if let Some(e) = error {
        return Err(e);
    }
    if let Some(w) = writer.as_mut() {
        w.end(report.stopped.as_deref())
            .map_err(|source| StoredError::Store { location, source })?;
    }
    Ok(report)
}
