//! What the station records about every part: each turn with its samples and the quality
//! gate's verdict, each push with the push model's prediction and what the verify turn found,
//! the result with its reason, and the time spent in each phase. Complete enough for a results
//! database and an offline replay.

use crate::StationError;
use crate::hal::{ApproachSpeed, DeviceErrorKind};
use crate::quality::QualityVerdict;
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
    /// Eccentricity, µm (NaN when the turn failed).
    pub e_um: f64,
    /// Standard uncertainty of e, µm (NaN for the paper's method or a failed turn).
    pub u_e_um: f64,
    /// θ_max, degrees.
    pub theta_max_deg: f64,
    /// Mean column, px.
    pub c0_px: f64,
    /// Residual RMS, px.
    pub residual_rms_px: f64,
    /// Outliers rejected by the fit.
    pub outliers: usize,
    /// Focus position during the turn, µm (NaN when autofocus never succeeded).
    #[serde(default = "nan", deserialize_with = "nan_or")]
    pub focus_um: f64,
    /// The quality gate's verdict (`None` when the ring was lost and nothing was fitted).
    pub quality: Option<QualityVerdict>,
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
    /// Eccentricity measured by the trusted verify turn, µm (NaN when there was none).
    pub e_after_um: f64,
    /// Distance of the measured eccentricity vector from the predicted one, µm.
    pub deviation_um: f64,
    /// Whether the verify turn agreed with the prediction (`None`: no trusted verify turn).
    pub consistent: Option<bool>,
    /// Duration of the push cycle (align, approach, push, retract), s.
    #[serde(default = "nan", deserialize_with = "nan_or")]
    pub duration_s: f64,
}

fn nan() -> f64 {
    f64::NAN
}

/// Reads a number written as `null` (how JSON writes NaN) back as NaN.
fn nan_or<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

/// Time spent in each phase of a part, s.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct PhaseTimes {
    /// Autofocus (including refocusing before a re-measurement).
    pub focus_s: f64,
    /// Measuring turns, fits included.
    pub measure_s: f64,
    /// Align, approach, push and retract.
    pub push_s: f64,
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
    /// First trusted eccentricity, µm (NaN if never measured).
    pub initial_e_um: f64,
    /// Last trusted eccentricity, µm (NaN if never measured).
    pub final_e_um: f64,
    /// Pushes made.
    pub pushes: u32,
    /// Time from start to the end of the part, s.
    pub time_s: f64,
    /// How the part ended.
    pub result: PartResult,
    /// Why the part was rejected, in words (`None` when accepted).
    pub reject_reason: Option<String>,
    /// Turns measured again because a turn failed the quality gate or lost the ring.
    pub remeasured_turns: u32,
    /// Focus position found last, µm (NaN on focus failure).
    pub focus_um: f64,
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
            initial_e_um: f64::NAN,
            final_e_um: f64::NAN,
            pushes: 0,
            time_s: f64::NAN,
            result: PartResult::Accepted,
            reject_reason: None,
            remeasured_turns: 0,
            focus_um: f64::NAN,
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
