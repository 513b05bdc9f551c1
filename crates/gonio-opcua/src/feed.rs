//! The hand-over from the station to the server: the station's thread tells a
//! [`FeedObserver`] (a `gonio_station::observe::Observer`) what it does, which keeps only the
//! latest state (phase, current part, last e and u(e), µm) in a one-slot channel; the server
//! reads that slot when it has time. Bounded (one value) and lossy (a state the server did
//! not read before the next is dropped), so the station never waits for the server, and a
//! slow or stuck OPC UA client, which only ever talks to the server, costs it nothing.
//!
//! The PLC link's round-trip figures are read by the server from a [`LinkSource`] about once
//! a second; a finished part is found in the results store, which [`Feed::part_stored`]
//! tells the server to look at now rather than at its next poll.
//!
//! ```
//! use gonio_opcua::feed::{Feed, LivePhase};
//! use gonio_station::observe::{Observer, Phase};
//! let feed = Feed::new();
//! let mut o = feed.observer();
//! o.part_started("A-1");
//! o.phase(Phase::Focus);
//! let live = feed.live();
//! assert_eq!((live.phase, live.serial.as_deref()), (LivePhase::Focus, Some("A-1")));
//! ```

use gonio_station::fit::EccentricityFit;
use gonio_station::observe::{Observer, Phase};
use gonio_station::record::{PartRecord, TurnKind, TurnRecord};
use std::sync::{Arc, Mutex};
use tokio::sync::{Notify, watch};

/// What the station is doing, as `Monitoring/Phase` says it.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum LivePhase {
    /// Between parts, or no station.
    #[default]
    Idle,
    /// Autofocus.
    Focus,
    /// A measuring turn (the first, or a re-measurement).
    Measure,
    /// Align, approach, push and retract.
    Push,
    /// The measuring turn after a push.
    Verify,
}

impl LivePhase {
    /// `idle`, `focus`, `measure`, `push` or `verify`.
    pub fn name(self) -> &'static str {
        match self {
            LivePhase::Idle => "idle",
            LivePhase::Focus => "focus",
            LivePhase::Measure => "measure",
            LivePhase::Push => "push",
            LivePhase::Verify => "verify",
        }
    }
}

/// The station's latest state.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Live {
    /// What it is doing.
    pub phase: LivePhase,
    /// The serial of the part being mounted (`None` between parts).
    pub serial: Option<String>,
    /// The last evaluated turn's eccentricity, µm (`None`: none yet, or the ring was lost).
    pub last_e_um: Option<f64>,
    /// Its standard uncertainty, µm (`None`: none defined).
    pub last_u_um: Option<f64>,
}

/// The PLC link's round trips (Modbus requests timed, median and 99th percentile, ms).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinkRoundTrips {
    /// Requests timed.
    pub requests: u64,
    /// Median round trip, ms.
    pub round_trip_p50_ms: f64,
    /// 99th percentile round trip, ms.
    pub round_trip_p99_ms: f64,
}

/// Where the server reads the link's figures (`None`: no link). Called about once a second
/// from the server's thread; it should read a snapshot, not the link.
pub type LinkSource = Box<dyn Fn() -> Option<LinkRoundTrips> + Send + Sync>;

/// The hand-over between one station and one server.
pub struct Feed {
    live: watch::Sender<Live>,
    stored: Notify,
    link: Mutex<Option<LinkSource>>,
}

impl std::fmt::Debug for Feed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Feed")
            .field("live", &*self.live.borrow())
            .finish_non_exhaustive()
    }
}

impl Feed {
    /// A feed with the station idle.
    pub fn new() -> Arc<Feed> {
        Arc::new(Feed {
            live: watch::Sender::new(Live::default()),
            stored: Notify::new(),
            link: Mutex::new(None),
        })
    }

    /// An observer for the station's thread.
    pub fn observer(self: &Arc<Self>) -> FeedObserver {
        FeedObserver { feed: self.clone() }
    }

    /// The latest state.
    pub fn live(&self) -> Live {
        self.live.borrow().clone()
    }

    /// A part was committed to the store: the server looks for it now (never blocks).
    pub fn part_stored(&self) {
        self.stored.notify_one();
    }

    /// Sets where the link's figures are read.
    pub fn set_link_source(&self, source: LinkSource) {
        if let Ok(mut l) = self.link.lock() {
            *l = Some(source);
        }
    }

    /// The link's figures now (`None` without a source or a link).
    pub(crate) fn link(&self) -> Option<LinkRoundTrips> {
        self.link
            .lock()
            .ok()
            .and_then(|l| l.as_ref().and_then(|f| f()))
    }

    pub(crate) fn subscribe(&self) -> watch::Receiver<Live> {
        self.live.subscribe()
    }

    pub(crate) async fn stored(&self) {
        self.stored.notified().await;
    }

    /// Changes the state with `f`; readers are woken only when it changed.
    fn update(&self, f: impl FnOnce(&mut Live)) {
        self.live.send_if_modified(|l| {
            let before = l.clone();
            f(l);
            *l != before
        });
    }
}

/// Tells a [`Feed`] what the station does (on the station's thread; every call returns at
/// once).
#[derive(Debug)]
pub struct FeedObserver {
    feed: Arc<Feed>,
}

impl Observer for FeedObserver {
    fn part_started(&mut self, serial: &str) {
        self.feed.update(|l| {
            l.serial = Some(serial.to_string());
            l.last_e_um = None;
            l.last_u_um = None;
        });
    }

    fn phase(&mut self, phase: Phase) {
        let p = match phase {
            Phase::Focus => LivePhase::Focus,
            Phase::Measure(TurnKind::Verify) => LivePhase::Verify,
            Phase::Measure(_) => LivePhase::Measure,
            Phase::Push => LivePhase::Push,
        };
        self.feed.update(|l| l.phase = p);
    }

    fn turn(&mut self, turn: &TurnRecord, _fit: Option<&EccentricityFit>) {
        self.feed.update(|l| {
            l.last_e_um = turn.e_um;
            l.last_u_um = turn.u_e_um;
        });
    }

    fn part_finished(&mut self, _record: &PartRecord) {
        self.feed.update(|l| {
            l.phase = LivePhase::Idle;
            l.serial = None;
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_observer_keeps_the_latest_state_and_wakes_readers_only_on_change() {
        let feed = Feed::new();
        let mut rx = feed.subscribe();
        let mut o = feed.observer();
        o.part_started("P-7");
        o.phase(Phase::Measure(TurnKind::Initial));
        o.phase(Phase::Push);
        o.phase(Phase::Measure(TurnKind::Verify));
        // Four changes, one slot: the reader sees the last.
        assert!(rx.has_changed().unwrap());
        let l = rx.borrow_and_update().clone();
        assert_eq!(l.phase, LivePhase::Verify);
        assert_eq!(l.serial.as_deref(), Some("P-7"));
        o.phase(Phase::Measure(TurnKind::Verify));
        assert!(!rx.has_changed().unwrap(), "no change, no wake-up");
        o.part_finished(&PartRecord::new("P-7", "r", "live"));
        let l = rx.borrow_and_update().clone();
        assert_eq!((l.phase, l.serial), (LivePhase::Idle, None));
    }

    #[test]
    fn no_link_source_no_figures() {
        let feed = Feed::new();
        assert_eq!(feed.link(), None);
        feed.set_link_source(Box::new(|| {
            Some(LinkRoundTrips {
                requests: 3,
                round_trip_p50_ms: 0.2,
                round_trip_p99_ms: 0.9,
            })
        }));
        assert_eq!(feed.link().map(|l| l.requests), Some(3));
    }
}
