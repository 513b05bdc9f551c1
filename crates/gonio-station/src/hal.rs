//! Hardware traits of the station: servo, camera (the near-sensor detector), focus drive, push
//! rod and clock.
//!
//! Small, capability-named traits in the style of `embedded-hal`: every method is fallible, each
//! trait has an associated error type that maps to a [`DeviceErrorKind`], nothing is configured
//! through a trait, and `&mut T` implements a trait when `T` does. Every call blocks until the
//! device has done it (the controller is sequential, like the seed's PLC program); a simulated
//! device advances the simulated clock instead of sleeping.

use crate::interval::AngleSample;
use gonio_vision::InvalidReason;
use serde::{Deserialize, Serialize};

/// What kind of failure a device reported.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[non_exhaustive]
pub enum DeviceErrorKind {
    /// The device did not answer in time.
    Timeout,
    /// The link to the device failed (bus, cable).
    Communication,
    /// The device reports a fault (drive fault, limit switch, overload).
    Fault,
    /// Anything else.
    Other,
    /// Not a failure: the run was asked to stop (a signal, the operator) while the device
    /// worked; the part ends `interrupted`.
    Interrupted,
}

/// An error of a device: describes itself and says what kind it is.
pub trait DeviceError: core::fmt::Debug + core::fmt::Display {
    /// The kind of the error.
    fn kind(&self) -> DeviceErrorKind;
}

/// A time source that can wait.
pub trait Clock {
    /// The clock's error.
    type Error: DeviceError;
    /// The current time, s, from an arbitrary origin.
    fn now_s(&mut self) -> Result<f64, Self::Error>;
    /// Waits `dt_s` seconds.
    fn wait_s(&mut self, dt_s: f64) -> Result<(), Self::Error>;
}

/// The servo that turns the shaft and the grating, with its angle log (every 1 ms in the seed).
pub trait Servo {
    /// The servo's error.
    type Error: DeviceError;
    /// The current angle, degrees (continuous: it keeps counting past 360°).
    fn angle_deg(&mut self) -> Result<f64, Self::Error>;
    /// Moves to `target_deg` and waits until there; called while turning, the servo brakes
    /// into the move (one motion, no stop in between).
    fn move_to_deg(&mut self, target_deg: f64) -> Result<(), Self::Error>;
    /// Accelerates to a constant speed and keeps turning (returns once at speed).
    fn start_turn(&mut self, speed_deg_per_s: f64) -> Result<(), Self::Error>;
    /// Starts accelerating to a constant speed and returns at once, so that a measuring turn's
    /// frames can be taken during the ramp (each frame's angle comes from the angle log). The
    /// default waits until at speed, as [`Servo::start_turn`].
    fn begin_turn(&mut self, speed_deg_per_s: f64) -> Result<(), Self::Error> {
        self.start_turn(speed_deg_per_s)
    }
    /// Stops turning (returns once stopped).
    fn stop(&mut self) -> Result<(), Self::Error>;
    /// The angle log from time `since_s` on.
    fn angle_log(&mut self, since_s: f64) -> Result<Vec<AngleSample>, Self::Error>;
}

/// What the detector reports for one frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CameraFrame {
    /// Start of the exposure, s (on the station's clock).
    pub start_s: f64,
    /// Exposure time, s.
    pub exposure_s: f64,
    /// The ring's column, px, or `None` when the frame has no valid ring.
    pub c_px: Option<f64>,
    /// Why the frame has no valid ring (`None` when valid): the detector's reasons, the same for
    /// a real camera and for either fidelity of the simulated station.
    pub invalid_reason: Option<InvalidReason>,
    /// The frame's focus measure (mean gradient energy; the autofocus maximises it).
    pub focus_measure: f64,
}

/// The camera with its near-sensor detector: one call, one frame's result.
pub trait Camera {
    /// The camera's error.
    type Error: DeviceError;
    /// Waits for the next frame and returns the detector's result for it.
    fn capture(&mut self) -> Result<CameraFrame, Self::Error>;
}

/// The focus motor that moves the camera along its axis.
pub trait FocusDrive {
    /// The drive's error.
    type Error: DeviceError;
    /// The current position, µm.
    fn position_um(&mut self) -> Result<f64, Self::Error>;
    /// Moves to `z_um` and waits until there.
    fn move_to_um(&mut self, z_um: f64) -> Result<(), Self::Error>;
}

/// How fast the rod approaches the grating's edge.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ApproachSpeed {
    /// Fast: quicker, with a larger overshoot on contact.
    Fast,
    /// Slow: smaller overshoot, takes longer.
    Slow,
}

/// The push-rod motor.
pub trait PushRod {
    /// The rod's error.
    type Error: DeviceError;
    /// Moves the rod toward the grating's edge until contact (the ring starts to move).
    fn approach(&mut self, speed: ApproachSpeed) -> Result<(), Self::Error>;
    /// Pushes a further `d_um` after contact (may be called repeatedly under feedback).
    fn push_um(&mut self, d_um: f64) -> Result<(), Self::Error>;
    /// Withdraws the rod clear of the grating.
    fn retract(&mut self) -> Result<(), Self::Error>;
}

impl<T: Clock + ?Sized> Clock for &mut T {
    type Error = T::Error;
    fn now_s(&mut self) -> Result<f64, Self::Error> {
        (**self).now_s()
    }
    fn wait_s(&mut self, dt_s: f64) -> Result<(), Self::Error> {
        (**self).wait_s(dt_s)
    }
}

impl<T: Servo + ?Sized> Servo for &mut T {
    type Error = T::Error;
    fn angle_deg(&mut self) -> Result<f64, Self::Error> {
        (**self).angle_deg()
    }
    fn move_to_deg(&mut self, target_deg: f64) -> Result<(), Self::Error> {
        (**self).move_to_deg(target_deg)
    }
    fn start_turn(&mut self, speed_deg_per_s: f64) -> Result<(), Self::Error> {
        (**self).start_turn(speed_deg_per_s)
    }
    fn begin_turn(&mut self, speed_deg_per_s: f64) -> Result<(), Self::Error> {
        (**self).begin_turn(speed_deg_per_s)
    }
    fn stop(&mut self) -> Result<(), Self::Error> {
        (**self).stop()
    }
    fn angle_log(&mut self, since_s: f64) -> Result<Vec<AngleSample>, Self::Error> {
        (**self).angle_log(since_s)
    }
}

impl<T: Camera + ?Sized> Camera for &mut T {
    type Error = T::Error;
    fn capture(&mut self) -> Result<CameraFrame, Self::Error> {
        (**self).capture()
    }
}

impl<T: FocusDrive + ?Sized> FocusDrive for &mut T {
    type Error = T::Error;
    fn position_um(&mut self) -> Result<f64, Self::Error> {
        (**self).position_um()
    }
    fn move_to_um(&mut self, z_um: f64) -> Result<(), Self::Error> {
        (**self).move_to_um(z_um)
    }
}

impl<T: PushRod + ?Sized> PushRod for &mut T {
    type Error = T::Error;
    fn approach(&mut self, speed: ApproachSpeed) -> Result<(), Self::Error> {
        (**self).approach(speed)
    }
    fn push_um(&mut self, d_um: f64) -> Result<(), Self::Error> {
        (**self).push_um(d_um)
    }
    fn retract(&mut self) -> Result<(), Self::Error> {
        (**self).retract()
    }
}
