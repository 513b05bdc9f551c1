//! What the store keeps and gives back: batches, parts with their turns and pushes, and
//! calibration certificates with their indexed fields.
//!
//! A stored part ([`StoredPart`]) is the station's [`PartRecord`] as the store keeps it, plus
//! where it came from (station, batch, recipe hash, software version, wall-clock times) and
//! the controller's learned state after it. Numbers that are not determined are `null` in
//! JSON (NaN in the station's record).

use gonio_station::record::{DeviceFault, PhaseTimes, PushRecord, TurnKind};
use gonio_station::strategy::Learned;
use gonio_station::{PartRecord, PartResult, Recipe};
use serde::Serialize;

/// A part passed or was rejected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// Accepted: centred below the threshold and cured.
    Pass,
    /// Rejected, for any reason (see the part's `result` and `reject_reason`).
    Reject,
}

impl Verdict {
    /// The verdict of a part that ended so.
    pub fn of(result: PartResult) -> Verdict {
        if result == PartResult::Accepted {
            Verdict::Pass
        } else {
            Verdict::Reject
        }
    }

    /// `pass` or `reject`.
    pub fn name(self) -> &'static str {
        match self {
            Verdict::Pass => "pass",
            Verdict::Reject => "reject",
        }
    }
}

/// A batch about to start.
#[derive(Debug, Clone)]
pub struct NewBatch<'a> {
    /// The station's name (`sim`, `line-3-station-2`).
    pub station: &'a str,
    /// The seed of a simulated station.
    pub seed: Option<u64>,
    /// What was asked for, as JSON (parts, strategy, recipe, plant, …); its hash identifies the
    /// batch for `--resume`.
    pub config_json: &'a str,
    /// Parts planned.
    pub parts_planned: usize,
    /// The software that runs it (`gonio 0.1.0`).
    pub software_version: &'a str,
}

/// A stored batch, as `--resume` needs it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BatchInfo {
    /// The batch's id.
    pub batch: i64,
    /// The station.
    pub station: String,
    /// The seed of a simulated station.
    pub seed: Option<u64>,
    /// Hash of the batch's configuration.
    pub config_hash: String,
    /// Parts planned.
    pub parts_planned: usize,
    /// Parts stored.
    pub parts_stored: usize,
    /// `running`, `complete` or `stopped`.
    pub status: String,
    /// Why the batch stopped.
    pub stop_reason: Option<String>,
    /// Started, UTC.
    pub started_at: String,
    /// The controller's learned state after the last stored part (`None`: no part yet).
    pub learned: Option<Learned>,
}

impl BatchInfo {
    /// 0-based index of the next part to mount.
    pub fn next_index(&self) -> usize {
        self.parts_stored
    }
}

/// A part to store: the station's record and where it came from.
#[derive(Debug, Clone)]
pub struct NewPart<'a> {
    /// The batch (from [`crate::Store::begin_batch`]).
    pub batch: i64,
    /// 0-based position of the part in its batch.
    pub batch_index: usize,
    /// The station's name.
    pub station: &'a str,
    /// The software that mounted it.
    pub software_version: &'a str,
    /// The recipe it was mounted with (stored once, by its hash).
    pub recipe: &'a Recipe,
    /// Wall-clock start, UTC (store form: [`crate::time::now_utc`]).
    pub started_at: &'a str,
    /// Wall-clock end, UTC.
    pub ended_at: &'a str,
    /// The station's record.
    pub record: &'a PartRecord,
    /// The controller's learned state after the part.
    pub learned: &'a Learned,
    /// True initial and final eccentricity of a simulated part, µm.
    pub truth: Option<(f64, f64)>,
    /// Whether the part came from the digital twin.
    pub simulated: bool,
}

/// One measuring turn as stored.
#[derive(Debug, Clone, Serialize)]
pub struct StoredTurn {
    /// Start of the turn, s since the part started.
    pub t_start_s: f64,
    /// Why the turn was measured.
    pub kind: TurnKind,
    /// Frames taken.
    pub frames_taken: usize,
    /// Frames with a valid ring (the samples).
    pub valid_frames: usize,
    /// Frames without a valid ring.
    pub invalid_frames: usize,
    /// Eccentricity, µm (`null`: the ring was lost or the fit failed).
    pub e_um: Option<f64>,
    /// Standard uncertainty of e, µm (`null`: the paper's extreme-point method defines none,
    /// or no fit).
    pub u_e_um: Option<f64>,
    /// θ_max, degrees (`null`: no fit).
    pub theta_max_deg: Option<f64>,
    /// Mean column, px (`null`: no fit).
    pub c0_px: Option<f64>,
    /// Residual RMS, px (`null`: no fit).
    pub residual_rms_px: Option<f64>,
    /// Outliers rejected by the fit.
    pub outliers: usize,
    /// Focus position during the turn, µm (`null`: autofocus never succeeded).
    pub focus_um: Option<f64>,
    /// The quality gate's verdict, as the station wrote it (`null`: ring lost, not judged).
    pub quality: Option<serde_json::Value>,
    /// The valid frames' (θ, c).
    pub samples: Vec<gonio_station::Sample>,
}

/// A part as the store keeps it: `gonio parts --json` prints an array of these, and
/// `/api/parts` serves the same.
#[derive(Debug, Clone, Serialize)]
pub struct StoredPart {
    /// The part's id in the store.
    pub part: i64,
    /// Serial number.
    pub serial: String,
    /// The station.
    pub station: String,
    /// Whether the part came from the digital twin (`false`: a real station).
    pub simulated: bool,
    /// The batch's id.
    pub batch: i64,
    /// 0-based position in the batch.
    pub batch_index: usize,
    /// The recipe's name.
    pub recipe: String,
    /// SHA-256 of the recipe's canonical JSON, hex.
    pub recipe_hash: String,
    /// The push strategy.
    pub strategy: String,
    /// The software that mounted it.
    pub software_version: String,
    /// Wall-clock start, UTC.
    pub started_at: String,
    /// Wall-clock end, UTC.
    pub ended_at: String,
    /// First trusted eccentricity, µm (`null`: never measured by a trusted turn).
    pub initial_e_um: Option<f64>,
    /// Last trusted eccentricity, µm (`null`: never measured by a trusted turn).
    pub final_e_um: Option<f64>,
    /// Pushes made.
    pub pushes: u32,
    /// Station time for the part, s (`null`: the clock failed).
    pub time_s: Option<f64>,
    /// How the part ended (`accepted`, `rejected_max_pushes`, …).
    pub result: String,
    /// `pass` or `reject`.
    pub verdict: Verdict,
    /// Why it was rejected.
    pub reject_reason: Option<String>,
    /// Turns measured again.
    pub remeasured_turns: u32,
    /// Last focus position, µm (`null`: autofocus failed).
    pub focus_um: Option<f64>,
    /// Time in each phase, s.
    pub phase_times: PhaseTimes,
    /// The device error that ended it.
    pub device_error: Option<DeviceFault>,
    /// Every measuring turn.
    pub turns: Vec<StoredTurn>,
    /// Every push.
    pub push_log: Vec<PushRecord>,
    /// The controller's learned state after the part.
    pub learned: Learned,
    /// True initial eccentricity of a simulated part, µm (`null` for a real part).
    pub true_initial_e_um: Option<f64>,
    /// True final eccentricity of a simulated part, µm.
    pub true_final_e_um: Option<f64>,
}

/// A part without its turns and pushes (a table row).
#[derive(Debug, Clone, Serialize)]
pub struct PartSummary {
    /// The part's id.
    pub part: i64,
    /// Serial number.
    pub serial: String,
    /// The station.
    pub station: String,
    /// Whether the part came from the digital twin (`false`: a real station).
    pub simulated: bool,
    /// The batch.
    pub batch: i64,
    /// 0-based position in the batch.
    pub batch_index: usize,
    /// The recipe's name.
    pub recipe: String,
    /// The strategy.
    pub strategy: String,
    /// Wall-clock start, UTC.
    pub started_at: String,
    /// Wall-clock end, UTC.
    pub ended_at: String,
    /// First trusted eccentricity, µm (`null`: never measured by a trusted turn).
    pub initial_e_um: Option<f64>,
    /// Last trusted eccentricity, µm (`null`: never measured by a trusted turn).
    pub final_e_um: Option<f64>,
    /// Pushes.
    pub pushes: u32,
    /// Station time, s (`null`: the clock failed).
    pub time_s: Option<f64>,
    /// How it ended.
    pub result: String,
    /// `pass` or `reject`.
    pub verdict: Verdict,
    /// Why it was rejected.
    pub reject_reason: Option<String>,
    /// Turns measured again.
    pub remeasured_turns: u32,
}

/// Which parts to give back.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PartQuery {
    /// Started at or after this time (store form, [`crate::time::parse_since`]).
    pub since: Option<String>,
    /// `pass`, `reject`, or one result name (`rejected_ring_lost`, `measurement_untrusted`, …).
    pub verdict: Option<String>,
    /// Only this serial.
    pub serial: Option<String>,
    /// Only this station.
    pub station: Option<String>,
    /// Only this batch.
    pub batch: Option<i64>,
    /// Only the most recent this many (still in id order).
    pub limit: Option<usize>,
    /// Only parts with a greater id (paging: the last id of the previous page).
    pub after: Option<i64>,
    /// Only parts with this id or a smaller one.
    pub through: Option<i64>,
}

/// Counters over parts (the dashboard's).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PartStats {
    /// Parts.
    pub parts: u64,
    /// Passed.
    pub pass: u64,
    /// Rejected.
    pub reject: u64,
    /// Mean station time per part, s (`null` without parts).
    pub mean_time_s: Option<f64>,
    /// Mean pushes per part.
    pub mean_pushes: Option<f64>,
    /// Most pushes on one part.
    pub max_pushes: Option<u32>,
    /// Mean final eccentricity of the parts where it was measured, µm.
    pub mean_final_e_um: Option<f64>,
}

/// A calibration certificate as stored.
#[derive(Debug, Clone, Serialize)]
pub struct StoredCalibration {
    /// The record's id.
    pub calibration: i64,
    /// The item's identification.
    pub item: Option<String>,
    /// `shift-angle` or `self-calibration`.
    pub procedure: String,
    /// The estimator.
    pub method: String,
    /// Date of calibration (ISO 8601).
    pub calibration_date: Option<String>,
    /// Largest |α|, arcsec.
    pub max_abs_error_arcsec: f64,
    /// Largest U, arcsec.
    pub max_expanded_arcsec: Option<f64>,
    /// Where it came from (a file name).
    pub source: String,
    /// The software that stored it.
    pub software_version: String,
    /// When it was stored, UTC.
    pub stored_at: String,
    /// The whole certificate (`gonio.certificate/1`); absent in listings.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub certificate: Option<serde_json::Value>,
}
