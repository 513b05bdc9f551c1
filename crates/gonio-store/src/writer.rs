//! A batch written to the store as it runs, whoever mounts it (the digital twin or a real
//! station): begun, or found again to be resumed; each part committed in one transaction as it
//! ends, with the wall-clock time it started ([`PartClock`], an observer of the controller);
//! its end written. Also the software version every record carries.
//!
//! Errors: [`StoreError`], each naming nothing but the store's failure; the caller says which
//! store and which part.
//!
//! ```
//! use gonio_station::{PartRecord, Recipe};
//! use gonio_station::strategy::Learned;
//! use gonio_store::writer::{BatchSpec, BatchWriter};
//! let dir = tempfile::tempdir().unwrap();
//! let store = gonio_store::open(dir.path().join("r.sqlite").to_str().unwrap()).unwrap();
//! let recipe = Recipe::default();
//! let spec = BatchSpec { station: "line-3", seed: None, config_json: "{}", parts: 1,
//!                        recipe: &recipe, simulated: false };
//! let mut w = BatchWriter::begin(store, &spec).unwrap();
//! let record = PartRecord::new("PLC-0001", "default", "live");
//! let id = w.commit(0, &record, &Learned::default(), None).unwrap();
//! w.end(None).unwrap();
//! assert!(id > 0);
//! ```

use crate::{BatchInfo, BatchStatus, NewBatch, NewPart, PartQuery, Store, StoreError, StoredPart};
use gonio_station::observe::Observer;
use gonio_station::strategy::Learned;
use gonio_station::{PartRecord, Recipe};
use std::sync::{Arc, Mutex, PoisonError};

/// The software that writes records (`gonio 0.1.0`).
///
/// `CARGO_PKG_VERSION` here is gonio-store's version, which is the `gonio` package's: every
/// crate of the workspace takes `version.workspace = true` (the workspace's
/// `[workspace.package]`).
pub fn software_version() -> String {
    format!("gonio {}", env!("CARGO_PKG_VERSION"))
}

/// What a batch is: where it runs, what was asked for, and whether it is the twin's.
#[derive(Debug, Clone, Copy)]
pub struct BatchSpec<'a> {
    /// The station's name in the store.
    pub station: &'a str,
    /// The seed of a simulated station (`None`: a real one).
    pub seed: Option<u64>,
    /// What was asked for, as JSON: the batch's identity for a resume.
    pub config_json: &'a str,
    /// Parts planned.
    pub parts: usize,
    /// The recipe every part is mounted with.
    pub recipe: &'a Recipe,
    /// Whether the parts come from the digital twin (the store's `simulated`).
    pub simulated: bool,
}

/// Notes the wall-clock start of each part (an observer of the controller) for its record in
/// the store; shared with the [`BatchWriter`] it came from.
#[derive(Debug, Clone)]
pub struct PartClock(Arc<Mutex<String>>);

impl Observer for PartClock {
    fn part_started(&mut self, _serial: &str) {
        *self.0.lock().unwrap_or_else(PoisonError::into_inner) = crate::time::now_utc();
    }
}

/// A batch in the store, written part by part.
pub struct BatchWriter {
    store: Box<dyn Store>,
    batch: i64,
    station: String,
    recipe: Recipe,
    version: String,
    simulated: bool,
    started_at: Arc<Mutex<String>>,
}

impl std::fmt::Debug for BatchWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BatchWriter")
            .field("batch", &self.batch)
            .field("station", &self.station)
            .field("simulated", &self.simulated)
            .finish_non_exhaustive()
    }
}

/// What [`BatchWriter::resume`] found.
#[derive(Debug)]
pub enum Resume {
    /// The batch, to go on with after its last stored part ([`BatchInfo::next_index`]).
    Found(Box<BatchWriter>, BatchInfo),
    /// The batch is complete: nothing to resume.
    Complete(BatchInfo),
    /// No batch of this station with this configuration.
    NotFound,
}

impl BatchWriter {
    /// Begins a new batch in `store`.
    ///
    /// # Errors
    /// The store cannot be written.
    pub fn begin(mut store: Box<dyn Store>, spec: &BatchSpec<'_>) -> Result<Self, StoreError> {
        let version = software_version();
        let batch = store.begin_batch(&NewBatch {
            station: spec.station,
            seed: spec.seed,
            config_json: spec.config_json,
            parts_planned: spec.parts,
            software_version: &version,
        })?;
        Ok(Self::with(store, batch, spec, version))
    }

    /// Finds the most recent batch of `spec.station` begun with `spec.config_json`, to go on
    /// with it.
    ///
    /// # Errors
    /// The store cannot be read.
    pub fn resume(mut store: Box<dyn Store>, spec: &BatchSpec<'_>) -> Result<Resume, StoreError> {
        let Some(info) = store.latest_batch(spec.station, spec.config_json)? else {
            return Ok(Resume::NotFound);
        };
        if info.next_index() >= info.parts_planned {
            return Ok(Resume::Complete(info));
        }
        let w = Self::with(store, info.batch, spec, software_version());
        Ok(Resume::Found(Box::new(w), info))
    }

    fn with(store: Box<dyn Store>, batch: i64, spec: &BatchSpec<'_>, version: String) -> Self {
        BatchWriter {
            store,
            batch,
            station: spec.station.to_string(),
            recipe: spec.recipe.clone(),
            version,
            simulated: spec.simulated,
            started_at: Arc::new(Mutex::new(crate::time::now_utc())),
        }
    }

    /// The batch's most recently stored part (`None`: none stored yet): where a resumed batch
    /// takes its carried state from (the focus the last part found, say).
    ///
    /// # Errors
    /// The store cannot be read.
    pub fn last_part(&mut self) -> Result<Option<StoredPart>, StoreError> {
        let q = PartQuery {
            batch: Some(self.batch),
            limit: Some(1),
            ..PartQuery::default()
        };
        Ok(self.store.parts(&q)?.pop())
    }

    /// The observer that notes when each part starts (until one does: when the batch was
    /// opened).
    pub fn clock(&self) -> PartClock {
        PartClock(self.started_at.clone())
    }

    /// Commits part `index` (0-based in the batch) in one transaction: its record, what the
    /// controller learned after it, and a simulated part's true initial and final
    /// eccentricity, µm. Returns its id.
    ///
    /// # Errors
    /// The store cannot be written ([`StoreError::Duplicate`]: the batch has a part there).
    pub fn commit(
        &mut self,
        index: usize,
        record: &PartRecord,
        learned: &Learned,
        truth: Option<(f64, f64)>,
    ) -> Result<i64, StoreError> {
        let ended_at = crate::time::now_utc();
        let started_at = self
            .started_at
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clone();
        self.store.insert_part(&NewPart {
            batch: self.batch,
            batch_index: index,
            station: &self.station,
            software_version: &self.version,
            recipe: &self.recipe,
            started_at: &started_at,
            ended_at: &ended_at,
            record,
            learned,
            truth,
            simulated: self.simulated,
        })
    }

    /// Ends the batch: complete, or stopped with its reason (resumable).
    ///
    /// # Errors
    /// The store cannot be written.
    pub fn end(&mut self, stopped: Option<&str>) -> Result<(), StoreError> {
        let status = match stopped {
            Some(_) => BatchStatus::Stopped,
            None => BatchStatus::Complete,
        };
        self.store.end_batch(self.batch, status, stopped)
    }
}
