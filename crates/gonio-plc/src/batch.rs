//! A batch of parts mounted through the PLC: wait for a part, mount it with the controller,
//! hand its record to the caller (the store, the terminal), send *part done*; stop at the first
//! device error (the link is not trusted after one) or interrupt (the part in progress ends
//! `interrupted` and is handed over like any other) with the station left safe: retract, stop,
//! trigger off within the map's `timing.safe_state_ms` ([`PlcStation::safe_stop`]).
//!
//! ```no_run
//! use gonio_plc::batch::{run_batch, PartEnd};
//! # fn f(station: gonio_plc::PlcStation<impl gonio_plc::TriggeredCamera>) {
//! use gonio_station::{Controller, Recipe, Strategy};
//! let mut ctl = Controller::new(Recipe::default(), Strategy::Live);
//! let report = run_batch(&station, &mut ctl, 3, &mut |_p| PartEnd::Continue).unwrap();
//! println!("{} parts, {:.2} pushes", report.parts.len(), report.summary.mean_pushes);
//! # }
//! ```

pub use crate::station::LinkFigures;
use crate::station::PlcStation;
use crate::triggered::TriggeredCamera;
use gonio_station::observe::{NoObserver, Observer};
use gonio_station::strategy::Learned;
use gonio_station::summary::{BatchSummary, SummaryBuilder};
use gonio_station::{Controller, PartRecord, PartResult, StationError};
use serde::Serialize;
use std::time::Duration;

/// What the caller says after a part.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PartEnd {
    /// Go on.
    Continue,
    /// Stop the batch (e.g. the part could not be stored).
    Stop,
}

/// A part just finished.
#[derive(Debug, Clone, Copy)]
pub struct PlcPartDone<'a> {
    /// 0-based index in the batch.
    pub index: usize,
    /// The PLC's part number.
    pub part: u32,
    /// The record.
    pub record: &'a PartRecord,
    /// What the controller has learned after it.
    pub learned: &'a Learned,
}

/// The batch's result.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlcBatchReport {
    /// The PLC's address.
    pub plc: String,
    /// Whether the PLC said it is a simulation: the parts are the digital twin's.
    pub simulated: bool,
    /// Strategy name.
    pub strategy: String,
    /// Recipe name.
    pub recipe: String,
    /// What the controller learned by the end.
    pub learned: Learned,
    /// Every part, with the PLC's part number.
    pub parts: Vec<PlcPart>,
    /// Why the batch stopped early (and what the safe stop after it could not do).
    pub stopped: Option<String>,
    /// Summary.
    pub summary: BatchSummary,
    /// The link.
    pub link: LinkFigures,
}

/// One part.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlcPart {
    /// The PLC's part number.
    pub part: u32,
    /// The station's record.
    #[serde(flatten)]
    pub record: PartRecord,
}

/// Summarises records.
pub fn summarise(parts: &[PlcPart]) -> BatchSummary {
    let mut s = SummaryBuilder::default();
    for p in parts {
        s.add(&p.record, None);
    }
    s.finish()
}

/// Mounts `parts` parts through `station`, telling `on_part` each one as it ends.
///
/// # Errors
/// [`StationError::RecipeValue`] for an invalid recipe. A device error, waiting for a part
/// included, does not fail the batch: it ends the part (recorded) or the batch
/// ([`PlcBatchReport::stopped`]).
pub fn run_batch<C: TriggeredCamera>(
    station: &PlcStation<C>,
    ctl: &mut Controller,
    parts: usize,
    on_part: &mut dyn FnMut(&PlcPartDone<'_>) -> PartEnd,
) -> Result<PlcBatchReport, StationError> {
    run_batch_observed(station, ctl, parts, &mut NoObserver, on_part)
}

/// [`run_batch`], telling `observer` what the controller does as it does it (each part's
/// start, phases, frames, turns, pushes and end: what a live view shows), as
/// [`Controller::mount_observed`] does for one part.
///
/// # Errors
/// As [`run_batch`].
pub fn run_batch_observed<C: TriggeredCamera>(
    station: &PlcStation<C>,
    ctl: &mut Controller,
    parts: usize,
    observer: &mut dyn Observer,
    on_part: &mut dyn FnMut(&PlcPartDone<'_>) -> PartEnd,
) -> Result<PlcBatchReport, StationError> {
    let mut out = Vec::with_capacity(parts);
    let mut stopped = None;
    let mut devices = station.devices();
    for index in 0..parts {
        let part = match station.wait_part(Duration::from_secs(30)) {
            Ok(p) => p,
            Err(e) => {
                stopped = Some(format!("waiting for part {}: {e}", index + 1));
                break;
            }
        };
        let record = ctl.mount_observed(&mut devices, &format!("PLC-{part:04}"), observer)?;
        let failed = record.device_error.is_some() || record.result == PartResult::Interrupted;
        let end = on_part(&PlcPartDone {
            index,
            part,
            record: &record,
            learned: &ctl.learned,
        });
        let reason = record.reject_reason.clone();
        out.push(PlcPart { part, record });
        if failed {
            stopped = Some(format!(
                "stopped after part {} of {parts} (PLC-{part:04}): {}",
                index + 1,
                reason.as_deref().unwrap_or("device error")
            ));
            break;
        }
        if let Err(e) = station.part_done() {
            stopped = Some(format!("part done for PLC-{part:04}: {e}"));
            break;
        }
        if end == PartEnd::Stop {
            stopped = Some(format!("stopped after part {} of {parts}", index + 1));
            break;
        }
    }
    // Stopped: the link takes no motion command after this.
    if let Err(e) = station.safe_stop() {
        let safe = format!("safe stop: {e}");
        stopped = Some(match stopped {
            Some(why) => format!("{why}; {safe}"),
            None => safe,
        });
    }
    let summary = summarise(&out);
    Ok(PlcBatchReport {
        plc: station.addr(),
        simulated: station.simulated(),
        strategy: ctl.strategy.name().to_string(),
        recipe: ctl.recipe.name.clone(),
        learned: ctl.learned,
        parts: out,
        stopped,
        summary,
        link: station.link_figures(),
    })
}
