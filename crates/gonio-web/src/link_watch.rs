//! The snapshot of a station link's figures that `/api/status` reports as `plc` (requests, round
//! trips, frames paired and stale: whatever the link's figures serialise to, with its
//! `address`), kept up to date by a [`LinkWatch`]: an observer of the controller on the batch's
//! thread, where the station lives, that reads the figures at most every [`LinkWatch::EVERY`]
//! and at every part's end.
//!
//! ```
//! use gonio_station::observe::Observer;
//! use gonio_web::link_watch::{LinkWatch, snapshot};
//! let hub = gonio_web::live::Hub::new(true);
//! let mut watch = LinkWatch::new(|| serde_json::json!({"requests": 3}), "127.0.0.1:5020", snapshot(&hub));
//! watch.refresh(true);
//! assert_eq!(hub.plc_status()["address"], "127.0.0.1:5020");
//! ```

use crate::live::Hub;
use gonio_station::observe::{LiveFrame, Observer, Phase};
use gonio_station::record::PartRecord;
use serde::Serialize;
use serde_json::Value;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// A snapshot the hub reports as `/api/status`'s `plc` (`null` until a [`LinkWatch`] fills it).
pub fn snapshot(hub: &Hub) -> Arc<Mutex<Value>> {
    let snapshot = Arc::new(Mutex::new(Value::Null));
    let shared = snapshot.clone();
    hub.set_plc_source(Box::new(move || {
        shared.lock().map(|s| s.clone()).unwrap_or_default()
    }));
    snapshot
}

/// Keeps a snapshot of a link's figures (`figures()`, read on the calling thread) up to date
/// as the controller works.
#[derive(Debug)]
pub struct LinkWatch<F> {
    figures: F,
    address: String,
    snapshot: Arc<Mutex<Value>>,
    last: Option<Instant>,
}

impl<F, T> LinkWatch<F>
where
    F: Fn() -> T,
    T: Serialize,
{
    /// Fewest wall-clock time between two readings (each takes the station's lock and scans the
    /// round trips' histogram).
    pub const EVERY: Duration = Duration::from_secs(1);

    /// A watch of the link at `address` writing `figures()` into `snapshot` (see [`snapshot`]).
    pub fn new(figures: F, address: impl Into<String>, snapshot: Arc<Mutex<Value>>) -> Self {
        LinkWatch {
            figures,
            address: address.into(),
            snapshot,
            last: None,
        }
    }

    /// Reads the figures now if `now` or if the last reading is older than [`Self::EVERY`].
    pub fn refresh(&mut self, now: bool) {
        if !now && self.last.is_some_and(|t| t.elapsed() < Self::EVERY) {
            return;
        }
        self.last = Some(Instant::now());
        let mut v = serde_json::to_value((self.figures)()).unwrap_or_default();
        if let Some(o) = v.as_object_mut() {
            o.insert("address".into(), Value::from(self.address.as_str()));
        }
        if let Ok(mut s) = self.snapshot.lock() {
            *s = v;
        }
    }
}

impl<F, T> Observer for LinkWatch<F>
where
    F: Fn() -> T,
    T: Serialize,
{
    fn part_started(&mut self, _serial: &str) {
        self.refresh(false);
    }
    fn phase(&mut self, _phase: Phase) {
        self.refresh(false);
    }
    fn frame(&mut self, _frame: &LiveFrame) {
        self.refresh(false);
    }
    fn part_finished(&mut self, _record: &PartRecord) {
        self.refresh(true);
    }
}
