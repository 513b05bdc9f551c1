//! The server's two tasks that keep the address space current:
//!
//! - **live**: the station's latest state ([`crate::feed`]) into `Monitoring`, at most every
//!   [`MIN_UPDATE`] (changes in between are merged: the newest wins);
//! - **results**: this station's new parts from the results store, looked for when the
//!   station says one was stored and every [`POLL`] in any case (a part stored by another
//!   process is found too): for each, a `ResultReadyEventType` event and a variable in
//!   `Results` (the newest [`RESULTS_KEPT`] are kept), then the counters; and the PLC link's
//!   figures.
//!
//! Both only read the station's hand-over, so a client that is slow to take its
//! notifications delays neither the station nor the other clients' values.

use crate::event::{EventSource, ResultReady};
use crate::feed::Feed;
use crate::machine;
use crate::monitoring;
use crate::node_manager::{GonioNodeManager, Shared};
use crate::result;
use gonio_store::{PartQuery, StoredPart};
use opcua::nodes::Event;
use opcua::server::ServerHandle;
use opcua::types::{DataValue, DateTime, NodeId, ObjectId, Variant};
use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Duration;
use tokio_util::sync::CancellationToken;

/// Shortest time between two updates of the live values.
pub(crate) const MIN_UPDATE: Duration = Duration::from_millis(100);
/// Longest time before a part stored by another process is found.
pub(crate) const POLL: Duration = Duration::from_secs(1);
/// Results kept in the `Results` folder.
pub(crate) const RESULTS_KEPT: usize = 10;
/// Parts read from the store at a time.
const PAGE: usize = 50;

/// What the tasks work on.
#[derive(Clone)]
pub(crate) struct Pump {
    pub(crate) handle: ServerHandle,
    pub(crate) nodes: Arc<GonioNodeManager>,
    pub(crate) shared: Arc<Shared>,
    pub(crate) feed: Arc<Feed>,
    pub(crate) token: CancellationToken,
    /// The newest part of this station already in the store when the server started.
    pub(crate) last_part: i64,
}

impl Pump {
    /// Sets `Monitoring` variables by name.
    fn set(&self, values: impl IntoIterator<Item = (&'static str, Variant)>) {
        let ids: Vec<(NodeId, Variant)> = values
            .into_iter()
            .map(|(name, v)| (self.shared.ids.monitoring_var(name), v))
            .collect();
        // A variable that does not exist is a programming error the tests catch.
        let _ = self.nodes.set_values(
            self.handle.subscriptions(),
            ids.iter()
                .map(|(id, v)| (id, None, DataValue::new_now(v.clone()))),
        );
    }

    /// The live values, until cancelled.
    pub(crate) async fn live(self) {
        let mut rx = self.feed.subscribe();
        loop {
            let live = rx.borrow_and_update().clone();
            self.set(monitoring::live_values(&live));
            tokio::select! {
                _ = self.token.cancelled() => return,
                _ = tokio::time::sleep(MIN_UPDATE) => {}
            }
            tokio::select! {
                _ = self.token.cancelled() => return,
                changed = rx.changed() => if changed.is_err() { return },
            }
        }
    }

    /// The results, counters and link figures, until cancelled.
    pub(crate) async fn results(self) {
        let Some(codec) = self.codec().await else {
            return;
        };
        let mut shown = self.show_latest(&codec).await;
        let mut last = self.last_part;
        let mut tick = tokio::time::interval(POLL);
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        self.counters().await;
        loop {
            tokio::select! {
                _ = self.token.cancelled() => return,
                _ = self.feed.stored() => {}
                _ = tick.tick() => self.set(monitoring::link_values(self.feed.link())),
            }
            let new = self.new_parts(last).await;
            if new.is_empty() {
                continue;
            }
            for p in &new {
                last = last.max(p.part);
                self.publish(&codec, p, &mut shown);
            }
            self.counters().await;
        }
    }

    /// The structures' encodings, once the server's type tree is complete.
    async fn codec(&self) -> Option<Arc<crate::codec::Codec>> {
        loop {
            if let Ok(c) = self
                .shared
                .codec(self.handle.type_tree(), self.nodes.address_space())
            {
                return Some(c);
            }
            tokio::select! {
                _ = self.token.cancelled() => return None,
                _ = tokio::time::sleep(Duration::from_millis(50)) => {}
            }
        }
    }

    /// Fills `Results` with this station's newest results; their ids, oldest first.
    async fn show_latest(&self, codec: &crate::codec::Codec) -> VecDeque<String> {
        let station = self.shared.machine.station.clone();
        let parts = self
            .shared
            .stores
            .with(move |s| {
                s.parts(&PartQuery {
                    station: Some(station),
                    limit: Some(RESULTS_KEPT),
                    ..PartQuery::default()
                })
            })
            .await
            .unwrap_or_default();
        let mut shown = VecDeque::new();
        for p in &parts {
            self.show(codec, p, &mut shown);
        }
        shown
    }

    /// This station's parts stored after `last`, oldest first.
    async fn new_parts(&self, last: i64) -> Vec<StoredPart> {
        let station = self.shared.machine.station.clone();
        self.shared
            .stores
            .with(move |s| {
                let q = PartQuery {
                    station: Some(station),
                    after: Some(last),
                    ..PartQuery::default()
                };
                let mut out = Vec::new();
                s.for_each_page(&q, PAGE, &mut |page| {
                    out.extend(page);
                    true
                })?;
                Ok(out)
            })
            .await
            .unwrap_or_default()
    }

    /// Adds a result to `Results`, dropping the oldest beyond [`RESULTS_KEPT`].
    fn show(&self, codec: &crate::codec::Codec, p: &StoredPart, shown: &mut VecDeque<String>) {
        let (Ok(r), Ok(m)) = (result::result_data(codec, p), result::meta_data(codec, p)) else {
            return;
        };
        let id = result::result_id(p);
        let ids = &self.shared.ids;
        let mut space = self.nodes.address_space().write();
        machine::add_result(&mut space, ids, &id, r, m);
        shown.push_back(id);
        while shown.len() > RESULTS_KEPT {
            if let Some(old) = shown.pop_front() {
                machine::remove_result(&mut space, ids, &old);
            }
        }
    }

    /// A new part: its event, and its place in `Results`.
    fn publish(&self, codec: &crate::codec::Codec, p: &StoredPart, shown: &mut VecDeque<String>) {
        let Ok(r) = result::result_data(codec, p) else {
            return;
        };
        let ids = &self.shared.ids;
        let from = EventSource {
            event_type: ids.result_ready_event_type.clone(),
            result_ns: ids.result,
            source: ids.result_management.clone(),
            source_name: format!("{}/ResultManagement", self.shared.machine.station),
        };
        let time = DateTime::parse_from_rfc3339(&p.ended_at).unwrap_or_else(|_| DateTime::now());
        let message = match p.final_e_um {
            Some(e) => format!("part {} {}: e = {e:.3} µm", p.serial, p.result),
            None => format!("part {} {}", p.serial, p.result),
        };
        let severity = if p.verdict == gonio_store::Verdict::Pass {
            100
        } else {
            300
        };
        let event = ResultReady::new(&from, time, &message, severity, r);
        let server = NodeId::from(ObjectId::Server);
        let notifiers = [&ids.result_management, &ids.machine, &server];
        self.handle
            .subscriptions()
            .notify_events(notifiers.into_iter().map(|n| (&event as &dyn Event, n)));
        self.show(codec, p, shown);
    }

    /// The counters, from the store.
    async fn counters(&self) {
        let station = self.shared.machine.station.clone();
        let stats = self
            .shared
            .stores
            .with(move |s| {
                s.stats(&PartQuery {
                    station: Some(station),
                    ..PartQuery::default()
                })
            })
            .await;
        if let Ok(s) = stats {
            self.set(monitoring::counter_values(&s));
        }
    }
}
