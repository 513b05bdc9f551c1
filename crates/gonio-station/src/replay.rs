//! Replaying a recorded measuring turn: its frames run again through a camera (a detector over
//! the recorded pixels), the turn evaluated again by the controller's own code
//! ([`crate::turn::evaluate_turn`]) with the recorded angle log, and everything compared with
//! what the station recorded, bit for bit. A replay of the same frames with the same software
//! gives no difference; a changed detector, fit or recipe shows where it changes the result.
//!
//! ```
//! use gonio_station::hal::{Camera, CameraFrame, DeviceError, DeviceErrorKind};
//! use gonio_station::interval::AngleSample;
//! use gonio_station::record::TurnKind;
//! use gonio_station::replay::{RecordedTurn, replay_turn};
//! use gonio_station::turn::evaluate_turn;
//! use gonio_station::{Recipe, Strategy};
//!
//! /// A camera that gives back recorded frames (a stand-in for a detector over pixels).
//! struct Again(std::vec::IntoIter<CameraFrame>);
//! #[derive(Debug)]
//! struct Ended;
//! impl std::fmt::Display for Ended {
//!     fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result { f.write_str("ended") }
//! }
//! impl DeviceError for Ended {
//!     fn kind(&self) -> DeviceErrorKind { DeviceErrorKind::Other }
//! }
//! impl Camera for Again {
//!     type Error = Ended;
//!     fn capture(&mut self) -> Result<CameraFrame, Ended> { self.0.next().ok_or(Ended) }
//! }
//!
//! let r = Recipe::default();
//! let frames: Vec<CameraFrame> = (0..200)
//!     .map(|i| CameraFrame {
//!         start_s: i as f64 * 0.01,
//!         exposure_s: 0.001,
//!         c_px: Some(720.0 + 40.0 * (1.8 * i as f64 + 0.09).to_radians().cos()),
//!         invalid_reason: None,
//!         focus_measure: 40.0,
//!     })
//!     .collect();
//! let log: Vec<AngleSample> =
//!     (0..=2002).map(|k| AngleSample { t_s: k as f64 * 1e-3, theta_deg: 0.18 * k as f64 }).collect();
//! let (stored, _) =
//!     evaluate_turn(&r, Strategy::Learned, &frames, log.clone(), 0.0, TurnKind::Initial, Some(0.0), None);
//! let rec = RecordedTurn { t_start_s: 0.0, kind: TurnKind::Initial, focus_um: Some(0.0),
//!                          frames: frames.clone(), log, camera: Vec::new() };
//! let out = replay_turn(&mut Again(frames.into_iter()), &r, Strategy::Learned, &rec, &stored).unwrap();
//! assert!(out.differences.is_empty());
//! assert_eq!(out.frames, 200);
//! ```

use crate::StationError;
use crate::hal::{Camera, CameraFrame, DeviceError};
use crate::interval::AngleSample;
use crate::recipe::Recipe;
use crate::record::{TurnKind, TurnRecord};
use crate::strategy::Strategy;
use crate::turn::evaluate_turn;
use serde::{Deserialize, Serialize};

/// What the station saw during one measuring turn, as recorded.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RecordedTurn {
    /// Start of the turn, s since the part started.
    pub t_start_s: f64,
    /// Why the turn was measured.
    pub kind: TurnKind,
    /// Focus position during the turn, µm (`None`, JSON `null`: autofocus never succeeded).
    #[serde(default)]
    pub focus_um: Option<f64>,
    /// Every frame the camera gave during the turn (its detector's result live).
    pub frames: Vec<CameraFrame>,
    /// The servo's angle log of the turn.
    pub log: Vec<AngleSample>,
    /// Each frame's number and time as its camera gave them, in the order of `frames` (empty
    /// when the record holds none).
    #[serde(default)]
    pub camera: Vec<CameraStamp>,
}

/// A frame's number and time as its camera gave them: a triggered camera's frame id is the
/// PLC's trigger count, its time the camera's own clock, s (the station stamps the frame with
/// the PLC's time of its trigger instead).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CameraStamp {
    /// The camera's frame number.
    pub frame_id: u64,
    /// The camera's time of the exposure's start, s (`None`, JSON `null`: unknown).
    pub timestamp_s: Option<f64>,
}

/// One value that differs between the record and the replay.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Difference {
    /// What: `frame 17 c_px`, `e_um`, `samples`, …
    pub field: String,
    /// As recorded.
    pub recorded: String,
    /// As replayed.
    pub replayed: String,
}

/// A replayed turn.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TurnReplay {
    /// Frames run through the camera again.
    pub frames: usize,
    /// Frames whose detector result differs (all of them are counted; at most
    /// [`MAX_LISTED`] are listed in `differences`).
    pub frames_differing: usize,
    /// Every difference (frame differences up to [`MAX_LISTED`]); empty when the replay is
    /// bit-identical.
    pub differences: Vec<Difference>,
    /// The turn as replayed.
    pub turn: TurnRecord,
}

/// Frame differences listed per turn (the rest are counted).
pub const MAX_LISTED: usize = 10;

/// The same f64, bit for bit (every NaN equal to every NaN: "not determined" both times).
fn same(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

fn opt(x: Option<f64>) -> String {
    x.map_or("none".into(), |v| format!("{v:?}"))
}

/// Runs the turn's frames through `camera` (one capture per recorded frame), evaluates the turn
/// with `recipe` and `strategy` as the controller does, and compares the frames with the
/// recorded ones and the turn with `stored` (the station's record of it).
///
/// # Errors
/// [`StationError::Device`] when the camera fails (e.g. the recorded pixels end early).
pub fn replay_turn<C: Camera>(
    camera: &mut C,
    recipe: &Recipe,
    strategy: Strategy,
    rec: &RecordedTurn,
    stored: &TurnRecord,
) -> Result<TurnReplay, StationError> {
    let mut frames = Vec::with_capacity(rec.frames.len());
    let mut diffs = Vec::new();
    let mut differing = 0;
    for (i, was) in rec.frames.iter().enumerate() {
        let f = camera.capture().map_err(|e| StationError::Device {
            device: "camera",
            kind: e.kind(),
            message: format!("replaying frame {i}: {e}"),
        })?;
        let c_same = match (was.c_px, f.c_px) {
            (Some(a), Some(b)) => same(a, b),
            (None, None) => true,
            _ => false,
        };
        let mut fd = Vec::new();
        if !c_same {
            fd.push(("c_px", opt(was.c_px), opt(f.c_px)));
        }
        if was.invalid_reason != f.invalid_reason {
            fd.push((
                "invalid_reason",
                format!("{:?}", was.invalid_reason),
                format!("{:?}", f.invalid_reason),
            ));
        }
        if !same(was.focus_measure, f.focus_measure) {
            fd.push((
                "focus_measure",
                format!("{:?}", was.focus_measure),
                format!("{:?}", f.focus_measure),
            ));
        }
        if !same(was.start_s, f.start_s) || !same(was.exposure_s, f.exposure_s) {
            fd.push((
                "stamp",
                format!("{:?} + {:?} s", was.start_s, was.exposure_s),
                format!("{:?} + {:?} s", f.start_s, f.exposure_s),
            ));
        }
        if !fd.is_empty() {
            differing += 1;
            for (what, a, b) in fd {
                if diffs.len() < MAX_LISTED {
                    diffs.push(Difference {
                        field: format!("frame {i} {what}"),
                        recorded: a,
                        replayed: b,
                    });
                }
            }
        }
        frames.push(f);
    }
    let (turn, _) = evaluate_turn(
        recipe,
        strategy,
        &frames,
        rec.log.clone(),
        rec.t_start_s,
        rec.kind,
        rec.focus_um,
        stored.carried_roundness.as_ref(),
    );
    diffs.extend(compare_turns(stored, &turn));
    Ok(TurnReplay {
        frames: frames.len(),
        frames_differing: differing,
        differences: diffs,
        turn,
    })
}

/// The differences between two records of one turn (empty: bit-identical).
pub fn compare_turns(a: &TurnRecord, b: &TurnRecord) -> Vec<Difference> {
    let mut d = Vec::new();
    let mut num = |field: &str, x: f64, y: f64| {
        if !same(x, y) {
            d.push(Difference {
                field: field.into(),
                recorded: format!("{x:?}"),
                replayed: format!("{y:?}"),
            });
        }
    };
    num("t_start_s", a.t_start_s, b.t_start_s);
    let mut undefined = |field: &str, x: Option<f64>, y: Option<f64>| {
        let same = match (x, y) {
            (Some(x), Some(y)) => same(x, y),
            (None, None) => true,
            _ => false,
        };
        if !same {
            d.push(Difference {
                field: field.into(),
                recorded: opt(x),
                replayed: opt(y),
            });
        }
    };
    undefined("e_um", a.e_um, b.e_um);
    undefined("u_e_um", a.u_e_um, b.u_e_um);
    undefined("theta_max_deg", a.theta_max_deg, b.theta_max_deg);
    undefined("c0_px", a.c0_px, b.c0_px);
    undefined("residual_rms_px", a.residual_rms_px, b.residual_rms_px);
    undefined("focus_um", a.focus_um, b.focus_um);
    let mut count = |field: &str, x: usize, y: usize| {
        if x != y {
            d.push(Difference {
                field: field.into(),
                recorded: x.to_string(),
                replayed: y.to_string(),
            });
        }
    };
    count("frames_taken", a.frames_taken, b.frames_taken);
    count("invalid_frames", a.invalid_frames, b.invalid_frames);
    count("outliers", a.outliers, b.outliers);
    count("samples", a.samples.len(), b.samples.len());
    if let Some(i) = a
        .samples
        .iter()
        .zip(&b.samples)
        .position(|(s, t)| !same(s.theta_deg, t.theta_deg) || !same(s.c_px, t.c_px))
    {
        let (s, t) = (&a.samples[i], &b.samples[i]);
        d.push(Difference {
            field: format!("sample {i} (θ, c)"),
            recorded: format!("({:?}, {:?})", s.theta_deg, s.c_px),
            replayed: format!("({:?}, {:?})", t.theta_deg, t.c_px),
        });
    }
    if a.kind != b.kind {
        d.push(Difference {
            field: "kind".into(),
            recorded: format!("{:?}", a.kind),
            replayed: format!("{:?}", b.kind),
        });
    }
    // Debug prints every f64 exactly (shortest round trip) and NaN as NaN.
    let qa = format!("{:?}", a.quality);
    let qb = format!("{:?}", b.quality);
    if qa != qb {
        d.push(Difference {
            field: "quality".into(),
            recorded: qa,
            replayed: qb,
        });
    }
    d
}
