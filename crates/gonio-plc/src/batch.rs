//! A batch of parts mounted through the PLC: wait for a part, mount it with the controller,
//! hand its record to the caller (the store, the terminal), send *part done*; stop at the first
//! device error (the link is not trusted after one) with the station left safe.
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

/// The batch's summary.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlcSummary {
    /// Parts mounted.
    pub parts: usize,
    /// Mean time per part over the parts that have one, s (`null`: none has).
    pub mean_time_s: Option<f64>,
    /// Mean final eccentricity as measured over the parts where it is defined, µm (`null`:
    /// none is).
    pub mean_final_e_um: Option<f64>,
    /// Mean pushes per part.
    pub mean_pushes: f64,
    /// Most pushes on one part.
    pub max_pushes: u32,
    /// Parts rejected.
    pub rejected: usize,
    /// Parts ended by a device error.
    pub device_errors: usize,
    /// Mean time per phase, s: focus, measure, push.
    pub mean_focus_s: f64,
    /// Mean measuring time per part, s.
    pub mean_measure_s: f64,
    /// Mean push time per part, s.
    pub mean_push_s: f64,
}

/// The batch's result.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlcBatchReport {
    /// The PLC's address.
    pub plc: String,
    /// Strategy name.
    pub strategy: String,
    /// Recipe name.
    pub recipe: String,
    /// What the controller learned by the end.
    pub learned: Learned,
    /// Every part, with the PLC's part number.
    pub parts: Vec<PlcPart>,
    /// Why the batch stopped early.
    pub stopped: Option<String>,
    /// Summary.
    pub summary: PlcSummary,
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
pub fn summarise(parts: &[PlcPart]) -> PlcSummary {
    let n = parts.len().max(1) as f64;
    let mean = |f: &dyn Fn(&PartRecord) -> f64| {
        parts
            .iter()
            .map(|p| f(&p.record))
            .filter(|x| x.is_finite())
            .sum::<f64>()
            / n
    };
    // The mean of the values defined (`None`: none is).
    let mean_of = |f: &dyn Fn(&PartRecord) -> Option<f64>| {
        let v: Vec<f64> = parts.iter().filter_map(|p| f(&p.record)).collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    };
    PlcSummary {
        parts: parts.len(),
        mean_time_s: mean_of(&|r| r.time_s),
        mean_final_e_um: mean_of(&|r| r.final_e_um),
        mean_pushes: mean(&|r| r.pushes as f64),
        max_pushes: parts.iter().map(|p| p.record.pushes).max().unwrap_or(0),
        rejected: parts
            .iter()
            .filter(|p| p.record.result != PartResult::Accepted)
            .count(),
        device_errors: parts
            .iter()
            .filter(|p| p.record.result == PartResult::RejectedDeviceError)
            .count(),
        mean_focus_s: mean(&|r| r.phase_times.focus_s),
        mean_measure_s: mean(&|r| r.phase_times.measure_s),
        mean_push_s: mean(&|r| r.phase_times.push_s),
    }
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
        let failed = record.device_error.is_some();
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
    station.safe_stop();
    let summary = summarise(&out);
    Ok(PlcBatchReport {
        plc: station.addr(),
        strategy: ctl.strategy.name().to_string(),
        recipe: ctl.recipe.name.clone(),
        learned: ctl.learned,
        parts: out,
        stopped,
        summary,
        link: station.link_figures(),
    })
}
