//! What the station records about every part: each turn with its samples and the quality
//! gate's verdict, each push with the push model's prediction and what the verify turn found,
//! the result with its reason, and the time spent in each phase. Complete enough for a results
//! database and an offline replay.

use crate::StationError;
use crate::hal::{ApproachSpeed, DeviceErrorKind};
use crate::quality::QualityVerdict;
use crate::ring::RoundnessPrior;
use crate::sample::Sample;
use serde::{Deserialize, Serialize};

/// How a part ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum PartResult {
    /// Eccentricity below the threshold: cured.
    Accepted,
    /// The maximum number of pushes was reached.
    RejectedMaxPushes,
    /// Too few frames with a valid ring in a turn (and in its re-measurement).
    RejectedRingLost,
    /// Autofocus found no peak.
    RejectedFocusFailure,
    /// The part took longer than the recipe's timeout.
    RejectedTimeout,
    /// A turn and its re-measurements all failed the quality gate: no push was made on them.
    MeasurementUntrusted,
    /// The verify turn after a push disagreed with the push model's prediction: pushing stopped.
    PushInconsistent,
    /// A device failed during the part ([`PartRecord::device_error`] says which and why).
    RejectedDeviceError,
    /// The run was asked to stop during the part (Ctrl-C, SIGTERM): the station was left safe
    /// and the part keeps what was measured until then.
    Interrupted,
}

impl PartResult {
    /// Short name (`accepted`, `rejected_max_pushes`, `measurement_untrusted`, …).
    pub fn name(self) -> &'static str {
        match self {
            PartResult::Accepted => "accepted",
            PartResult::RejectedMaxPushes => "rejected_max_pushes",
            PartResult::RejectedRingLost => "rejected_ring_lost",
            PartResult::RejectedFocusFailure => "rejected_focus_failure",
            PartResult::RejectedTimeout => "rejected_timeout",
            PartResult::MeasurementUntrusted => "measurement_untrusted",
            PartResult::PushInconsistent => "push_inconsistent",
            PartResult::RejectedDeviceError => "rejected_device_error",
            PartResult::Interrupted => "interrupted",
        }
    }
}

/// Why a turn was measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TurnKind {
    /// The part's first turn.
    Initial,
    /// The turn after a push.
    Verify,
    /// A turn measured again because the previous one failed the quality gate or lost the ring.
    Remeasure,
}

/// One measuring turn.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TurnRecord {
    /// Start of the turn, s since the part started.
    pub t_start_s: f64,
    /// Why the turn was measured.
    pub kind: TurnKind,
    /// Frames taken in the turn.
    pub frames_taken: usize,
    /// The valid frames' samples.
    pub samples: Vec<Sample>,
    /// Frames without a valid ring.
    pub invalid_frames: usize,
    /// Eccentricity, µm (`None`, JSON `null`: the ring was lost or the fit failed).
    pub e_um: Option<f64>,
    /// Standard uncertainty of e, µm (`None`, JSON `null`: the paper's extreme-point method
    /// defines none, or the ring was lost or the fit failed).
    pub u_e_um: Option<f64>,
    /// θ_max, degrees (`None`: no fit).
    pub theta_max_deg: Option<f64>,
    /// Mean column, px (`None`: no fit).
    pub c0_px: Option<f64>,
    /// Residual RMS, px (`None`: no fit).
    pub residual_rms_px: Option<f64>,
    /// Outliers rejected by the fit.
    pub outliers: usize,
    /// Focus position during the turn, µm (`None`, JSON `null`: autofocus never succeeded).
    #[serde(default)]
    pub focus_um: Option<f64>,
    /// The quality gate's verdict (`None` when the ring was lost and nothing was fitted).
    pub quality: Option<QualityVerdict>,
    /// The ring's roundness this turn's fit carried from the part's earlier full turn (a verify
    /// turn over part of a revolution); `None`: the turn fitted its own.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub carried_roundness: Option<RoundnessPrior>,
}

/// One push.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PushRecord {
    /// Start, s since the part started.
    pub t_start_s: f64,
    /// Eccentricity before, µm.
    pub e_before_um: f64,
    /// Commanded push distance, µm (sum of the steps under live feedback).
    pub commanded_um: f64,
    /// Commanded push direction (servo angle facing the rod), degrees.
    pub angle_deg: f64,
    /// Approach speed.
    pub approach: ApproachSpeed,
    /// Feedback steps (live strategy; 1 otherwise).
    pub steps: u32,
    /// Push gain the strategy assumed.
    pub gain: f64,
    /// The push model's predicted move, µm.
    pub predicted_move_um: f64,
    /// The push model's predicted eccentricity after the push, µm.
    pub predicted_e_after_um: f64,
    /// How far the verify turn may lie from the prediction, µm.
    pub tolerance_um: f64,
    /// Eccentricity measured by the trusted verify turn, µm (`None`, JSON `null`: there was
    /// no trusted verify turn).
    pub e_after_um: Option<f64>,
    /// Distance of the measured eccentricity vector from the predicted one, µm (`None`: no
    /// trusted verify turn).
    pub deviation_um: Option<f64>,
    /// Whether the verify turn agreed with the prediction (`None`: no trusted verify turn).
    pub consistent: Option<bool>,
    /// Duration of the push cycle (align, approach, push, retract), s (`None`: not recorded,
    /// in records older than the field).
    #[serde(default)]
    pub duration_s: Option<f64>,
}

/// Time spent in each phase of a part, s.
///
/// `push_s` is the push cycles' align, approach, push and retract, each also given on its own
/// (`None`, JSON `null`: not recorded, in records older than the fields). An align straight
/// from a measuring turn includes the servo's braking.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct PhaseTimes {
    /// Autofocus (including refocusing before a re-measurement): checks and sweeps.
    pub focus_s: f64,
    /// Measuring turns, fits included.
    pub measure_s: f64,
    /// Align, approach, push and retract.
    pub push_s: f64,
    /// Of `push_s`: turning the part to the push angle.
    #[serde(default)]
    pub align_s: Option<f64>,
    /// Of `push_s`: the rod's approach to contact.
    #[serde(default)]
    pub approach_s: Option<f64>,
    /// Of `push_s`: the push itself (every feedback step).
    #[serde(default)]
    pub stroke_s: Option<f64>,
    /// Of `push_s`: the rod's retract.
    #[serde(default)]
    pub retract_s: Option<f64>,
}

impl PhaseTimes {
    /// Adds `dt_s` to one of the optional parts of the push phase (a `None` becomes `dt_s`).
    pub fn add(part: &mut Option<f64>, dt_s: f64) {
        *part = Some(part.unwrap_or(0.0) + dt_s);
    }
}

/// The device error that ended a part.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DeviceFault {
    /// Which device (`servo`, `camera`, `focus drive`, `push rod`, `clock`).
    pub device: String,
    /// The error's kind.
    pub kind: DeviceErrorKind,
    /// The device's message.
    pub message: String,
}

/// Everything the station knows about one part.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PartRecord {
    /// The part's serial number.
    pub serial: String,
    /// The recipe's name.
    pub recipe: String,
    /// The strategy's name.
    pub strategy: String,
    /// First trusted eccentricity, µm (`None`, JSON `null`: never measured by a trusted turn).
    pub initial_e_um: Option<f64>,
    /// Last trusted eccentricity, µm (`None`, JSON `null`: never measured by a trusted turn).
    pub final_e_um: Option<f64>,
    /// Pushes made.
    pub pushes: u32,
    /// Time from start to the end of the part, s (`None`, JSON `null`: the clock failed).
    pub time_s: Option<f64>,
    /// How the part ended.
    pub result: PartResult,
    /// Why the part was rejected, in words (`None` when accepted).
    pub reject_reason: Option<String>,
    /// Turns measured again because a turn failed the quality gate or lost the ring.
    pub remeasured_turns: u32,
    /// Focus position found last, µm (`None`, JSON `null`: autofocus failed).
    pub focus_um: Option<f64>,
    /// Focus checks around the focus carried from the last part (`focus.carry_from_last_part`).
    #[serde(default)]
    pub focus_checks: u32,
    /// Full focus sweeps (the first part, a check that found no peak, a refocus).
    #[serde(default)]
    pub focus_sweeps: u32,
    /// Every measuring turn, re-measurements included.
    pub turns: Vec<TurnRecord>,
    /// Every push.
    pub push_log: Vec<PushRecord>,
    /// Time in each phase.
    pub phase_times: PhaseTimes,
    /// The device error that ended the part, if one did.
    pub device_error: Option<DeviceFault>,
}

impl PartRecord {
    /// An empty record for a part about to be mounted.
    pub fn new(serial: &str, recipe: &str, strategy: &str) -> Self {
        PartRecord {
            serial: serial.to_string(),
            recipe: recipe.to_string(),
            strategy: strategy.to_string(),
            initial_e_um: None,
            final_e_um: None,
            pushes: 0,
            time_s: None,
            result: PartResult::Accepted,
            reject_reason: None,
            remeasured_turns: 0,
            focus_um: None,
            focus_checks: 0,
            focus_sweeps: 0,
            turns: Vec::new(),
            push_log: Vec::new(),
            phase_times: PhaseTimes::default(),
            device_error: None,
        }
    }

    /// The device error that ended the part as a [`StationError::Device`], for callers that
    /// treat it as an error.
    pub fn device_error(&self) -> Option<StationError> {
        self.device_error.as_ref().map(|f| StationError::Device {
            device: device_name(&f.device),
            kind: f.kind,
            message: f.message.clone(),
        })
    }
}

/// The station's device names, as `&'static str`.
pub(crate) const DEVICES: [&str; 5] = ["servo", "camera", "focus drive", "push rod", "clock"];

fn device_name(s: &str) -> &'static str {
    DEVICES.into_iter().find(|d| *d == s).unwrap_or("device")
}
