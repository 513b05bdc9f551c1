//! Watching the station work: the controller tells an [`Observer`] what happens as it happens
//! (each frame of a measuring turn, each finished turn with its fit, each push, each part), so a
//! live view, a logger or a recorder can follow it. The controller knows nothing of who listens;
//! every method has a no-op default (ripgrep's `Sink` shape) and an observer cannot change what
//! the station does.
//!
//! ```
//! use gonio_station::observe::{LiveFrame, Observer};
//! #[derive(Default)]
//! struct Count(usize);
//! impl Observer for Count {
//!     fn frame(&mut self, _f: &LiveFrame) {
//!         self.0 += 1;
//!     }
//! }
//! let mut c = Count::default();
//! c.frame(&LiveFrame { turn: 0, index: 0, frames: 200, t_s: 0.0, turn_deg: 0.0, c_px: Some(720.0) });
//! assert_eq!(c.0, 1);
//! ```

use crate::fit::EccentricityFit;
use crate::hal::CameraFrame;
use crate::interval::AngleSample;
use crate::record::{PartRecord, PushRecord, TurnKind, TurnRecord};
use serde::Serialize;

/// What the station is doing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Phase {
    /// Autofocus sweep.
    Focus,
    /// A measuring turn.
    Measure(TurnKind),
    /// Align, approach, push and retract.
    Push,
}

/// One frame of a measuring turn as it arrives (before the turn's angle log is read, so its
/// angle is the nominal one: the recipe's speed times the time since the turn started).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LiveFrame {
    /// 0-based index of the turn within the part.
    pub turn: usize,
    /// 0-based index of the frame within the turn.
    pub index: usize,
    /// Frames the turn will take.
    pub frames: usize,
    /// Mid-exposure time since the turn started, s.
    pub t_s: f64,
    /// Nominal angle turned since the turn started, degrees.
    pub turn_deg: f64,
    /// The ring's column, px (`None`: no valid ring in this frame).
    pub c_px: Option<f64>,
}

/// Receives the station's events. Every method defaults to doing nothing.
pub trait Observer {
    /// A part is about to be mounted.
    fn part_started(&mut self, _serial: &str) {}
    /// The station enters a phase.
    fn phase(&mut self, _phase: Phase) {}
    /// A frame of a measuring turn arrived.
    fn frame(&mut self, _frame: &LiveFrame) {}
    /// A measuring turn's inputs, before it is evaluated: every frame the camera gave and the
    /// servo's angle log (what a recorder keeps for a replay).
    fn turn_inputs(&mut self, _frames: &[CameraFrame], _log: &[AngleSample]) {}
    /// A measuring turn was evaluated; `fit` is `None` when the ring was lost.
    fn turn(&mut self, _turn: &TurnRecord, _fit: Option<&EccentricityFit>) {}
    /// A push was made (its verify turn follows).
    fn push(&mut self, _push: &PushRecord) {}
    /// The part ended; its record is final.
    fn part_finished(&mut self, _record: &PartRecord) {}
}

/// An observer that ignores everything.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoObserver;

impl Observer for NoObserver {}

impl<T: Observer + ?Sized> Observer for &mut T {
    fn part_started(&mut self, serial: &str) {
        (**self).part_started(serial)
    }
    fn phase(&mut self, phase: Phase) {
        (**self).phase(phase)
    }
    fn frame(&mut self, frame: &LiveFrame) {
        (**self).frame(frame)
    }
    fn turn_inputs(&mut self, frames: &[CameraFrame], log: &[AngleSample]) {
        (**self).turn_inputs(frames, log)
    }
    fn turn(&mut self, turn: &TurnRecord, fit: Option<&EccentricityFit>) {
        (**self).turn(turn, fit)
    }
    fn push(&mut self, push: &PushRecord) {
        (**self).push(push)
    }
    fn part_finished(&mut self, record: &PartRecord) {
        (**self).part_finished(record)
    }
}

/// Two observers, both told everything (first `.0`, then `.1`).
impl<A: Observer, B: Observer> Observer for (A, B) {
    fn part_started(&mut self, serial: &str) {
        self.0.part_started(serial);
        self.1.part_started(serial);
    }
    fn phase(&mut self, phase: Phase) {
        self.0.phase(phase);
        self.1.phase(phase);
    }
    fn frame(&mut self, frame: &LiveFrame) {
        self.0.frame(frame);
        self.1.frame(frame);
    }
    fn turn_inputs(&mut self, frames: &[CameraFrame], log: &[AngleSample]) {
        self.0.turn_inputs(frames, log);
        self.1.turn_inputs(frames, log);
    }
    fn turn(&mut self, turn: &TurnRecord, fit: Option<&EccentricityFit>) {
        self.0.turn(turn, fit);
        self.1.turn(turn, fit);
    }
    fn push(&mut self, push: &PushRecord) {
        self.0.push(push);
        self.1.push(push);
    }
    fn part_finished(&mut self, record: &PartRecord) {
        self.0.part_finished(record);
        self.1.part_finished(record);
    }
}
