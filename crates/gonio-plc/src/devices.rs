//! The five devices of a [`PlcStation`] for the controller (`gonio_station::hal`), each a thin
//! handle over the one station: the servo is the station itself ([`PlcServo`]: moves, turns and
//! stops through commands; its angle log is the latched angle of every frame the camera gave);
//! the other four are [`Handle`]s told apart by a marker type ([`marker`]): [`PlcCamera`] (the
//! next frame triggered after the last motion, with its latched angle), [`PlcFocus`] (the focus
//! drive), [`PlcRod`] (approach with contact seen in the ring's column, push, retract) and
//! [`PlcClock`] (the PLC's clock: every time the controller sees is PLC time, s).
//!
//! Errors: [`PlcError`].

use crate::link::{Command, PlcError};
use crate::station::{Inner, PlcStation};
use crate::triggered::TriggeredCamera;
use gonio_station::Devices;
use gonio_station::hal::{ApproachSpeed, Camera, CameraFrame, Clock, FocusDrive, PushRod, Servo};
use gonio_station::interval::AngleSample;
use std::marker::PhantomData;
use std::time::{Duration, Instant};

/// The devices a [`Handle`] drives, as types (never made: markers only).
pub mod marker {
    /// The camera.
    #[derive(Debug)]
    pub enum Camera {}
    /// The focus drive.
    #[derive(Debug)]
    pub enum Focus {}
    /// The push rod.
    #[derive(Debug)]
    pub enum Rod {}
    /// The clock.
    #[derive(Debug)]
    pub enum Clock {}
}

/// The servo through the PLC.
pub type PlcServo<C> = PlcStation<C>;

/// A device handle of the station: which device the trait methods drive is `D`, a [`marker`].
pub struct Handle<C, D> {
    station: PlcStation<C>,
    device: PhantomData<fn() -> D>,
}

impl<C, D> Handle<C, D> {
    fn new(station: &PlcStation<C>) -> Self {
        Handle {
            station: station.clone(),
            device: PhantomData,
        }
    }
}

impl<C, D> std::fmt::Debug for Handle<C, D> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Handle")
            .field("device", &std::any::type_name::<D>())
            .finish_non_exhaustive()
    }
}

/// The camera handle.
pub type PlcCamera<C> = Handle<C, marker::Camera>;
/// The focus-drive handle.
pub type PlcFocus<C> = Handle<C, marker::Focus>;
/// The push-rod handle.
pub type PlcRod<C> = Handle<C, marker::Rod>;
/// The clock handle.
pub type PlcClock<C> = Handle<C, marker::Clock>;

/// The controller's devices over one PLC station.
pub type PlcDevices<C> = Devices<PlcServo<C>, PlcCamera<C>, PlcFocus<C>, PlcRod<C>, PlcClock<C>>;

impl<C: TriggeredCamera> PlcStation<C> {
    /// The five device handles for the controller.
    pub fn devices(&self) -> PlcDevices<C> {
        Devices {
            servo: self.clone(),
            camera: Handle::new(self),
            focus: Handle::new(self),
            rod: Handle::new(self),
            clock: Handle::new(self),
        }
    }
}

/// Runs `f` on the station's state; a device error aborts the sequence to the safe state
/// ([`Link::abort`](crate::Link::abort)): the controller's safe stop after it, and the batch's,
/// then share one deadline instead of a command timeout each.
fn step<C, T>(
    station: &PlcStation<C>,
    f: impl FnOnce(&mut Inner<C>) -> Result<T, PlcError>,
) -> Result<T, PlcError> {
    let mut i = station.0.borrow_mut();
    let r = f(&mut i);
    if r.is_err() {
        i.link.abort();
    }
    r
}

impl<C: TriggeredCamera> Servo for PlcStation<C> {
    type Error = PlcError;
    fn angle_deg(&mut self) -> Result<f64, PlcError> {
        step(self, |i| Ok(i.link.status()?.angle_deg))
    }
    fn move_to_deg(&mut self, target_deg: f64) -> Result<(), PlcError> {
        step(self, |i| {
            let a = i.link.map.angle_counts(target_deg);
            i.motion(Command::MoveServo, a, 0).map(|_| ())
        })
    }
    fn start_turn(&mut self, speed_deg_per_s: f64) -> Result<(), PlcError> {
        step(self, |i| {
            let v = i.link.map.speed_counts(speed_deg_per_s);
            i.motion(Command::Turn, v, 0)?;
            i.camera.restart_tracking();
            Ok(())
        })
    }
    fn begin_turn(&mut self, speed_deg_per_s: f64) -> Result<(), PlcError> {
        // The turn command is not waited for: the frames of the ramp count (each has its
        // latched angle); frames triggered before the PLC took it are stale.
        step(self, |i| {
            let v = i.link.map.speed_counts(speed_deg_per_s);
            i.link.send(Command::Turn, v, 0)?;
            let s = i.link.status()?;
            i.link.check(&s, "turn")?;
            i.fresh_after_s = s.time_s;
            i.camera.restart_tracking();
            Ok(())
        })
    }
    fn stop(&mut self) -> Result<(), PlcError> {
        step(self, |i| i.motion(Command::StopServo, 0, 0).map(|_| ()))
    }
    fn angle_log(&mut self, since_s: f64) -> Result<Vec<AngleSample>, PlcError> {
        let i = self.0.borrow();
        let k = i.log.partition_point(|s| s.t_s < since_s);
        Ok(i.log[k..].to_vec())
    }
}

impl<C: TriggeredCamera> Camera for PlcCamera<C> {
    type Error = PlcError;
    fn capture(&mut self) -> Result<CameraFrame, PlcError> {
        step(&self.station, Inner::capture)
    }
}

impl<C: TriggeredCamera> FocusDrive for PlcFocus<C> {
    type Error = PlcError;
    fn position_um(&mut self) -> Result<f64, PlcError> {
        step(&self.station, |i| Ok(i.link.status()?.focus_um))
    }
    fn move_to_um(&mut self, z_um: f64) -> Result<(), PlcError> {
        step(&self.station, |i| {
            let z = i.link.map.length_counts(z_um);
            i.motion(Command::MoveFocus, z, 0).map(|_| ())
        })
    }
}

impl<C: TriggeredCamera> PushRod for PlcRod<C> {
    type Error = PlcError;
    fn approach(&mut self, speed: ApproachSpeed) -> Result<(), PlcError> {
        step(&self.station, |i| i.approach(speed))
    }
    fn push_um(&mut self, d_um: f64) -> Result<(), PlcError> {
        step(&self.station, |i| {
            let d = i.link.map.length_counts(d_um.max(0.0));
            i.motion(Command::Push, d, 0).map(|_| ())
        })
    }
    fn retract(&mut self) -> Result<(), PlcError> {
        step(&self.station, |i| {
            i.motion(Command::Retract, 0, 0).map(|_| ())
        })
    }
}

impl<C: TriggeredCamera> Clock for PlcClock<C> {
    type Error = PlcError;
    fn now_s(&mut self) -> Result<f64, PlcError> {
        step(&self.station, |i| Ok(i.link.status()?.time_s))
    }
    fn wait_s(&mut self, dt_s: f64) -> Result<(), PlcError> {
        let t0 = Instant::now();
        let dt = gonio_core::bound::saturating_duration_s(dt_s.clamp(0.0, 3600.0));
        while t0.elapsed() < dt {
            step(&self.station, |i| {
                i.link.check_interrupt()?;
                i.link.heartbeat(false)
            })?;
            std::thread::sleep((dt - t0.elapsed().min(dt)).min(Duration::from_millis(50)));
        }
        Ok(())
    }
}
