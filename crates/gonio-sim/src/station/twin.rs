//! The simulated station: one shared state (plant, part, simulated clock) behind five devices
//! that implement `gonio_station::hal`.
//!
//! The clock is discrete-event: every device action takes its duration from the plant's
//! [`Timing`](super::plant::Timing) and moves the simulated time forward to the action's end,
//! so a part that takes 25 s on the real station simulates in microseconds. The servo's angle is
//! a function of that time (ramps and constant speed), logged every millisecond with a random
//! phase; each frame's ring column is computed at mid-exposure.

use super::pace::Pace;
use super::plant::{PartTruth, PlantConfig, StationTruth};
use gonio_station::hal::{
    ApproachSpeed, Camera, CameraFrame, Clock, DeviceError, DeviceErrorKind, FocusDrive, PushRod,
    Servo,
};
use gonio_station::interval::AngleSample;
use gonio_vision::InvalidReason;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};
use std::cell::RefCell;
use std::rc::Rc;

/// Which device.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DeviceId {
    /// The servo.
    Servo,
    /// The camera.
    Camera,
    /// The focus drive.
    Focus,
    /// The push rod.
    Rod,
    /// The clock.
    Clock,
}

/// Faults to inject through the traits (for testing the controller's paths).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Faults {
    /// The `n`-th call (1-based, counted over the whole batch) to this device fails.
    pub device_error: Option<(DeviceId, u64)>,
    /// The ring is lost (no valid frames) after this many pushes on a part.
    pub ring_lost_after_pushes: Option<u32>,
    /// The focus measure is flat (no peak): autofocus fails.
    pub focus_dead: bool,
}

/// An error of a simulated device.
#[derive(Debug, Clone, PartialEq)]
pub struct SimDeviceError {
    /// Which device.
    pub device: DeviceId,
    /// Its kind.
    pub kind: DeviceErrorKind,
    /// What happened.
    pub message: String,
}

impl std::fmt::Display for SimDeviceError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "simulated {:?}: {}", self.device, self.message)
    }
}

impl std::error::Error for SimDeviceError {}

impl DeviceError for SimDeviceError {
    fn kind(&self) -> DeviceErrorKind {
        self.kind
    }
}

/// One exposure of the simulated camera: when, at what servo angle and pose, with what seed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Exposure {
    /// Start of the exposure, s (simulated clock).
    pub start_s: f64,
    /// Exposure time, s.
    pub exposure_s: f64,
    /// Servo angle at mid-exposure, degrees.
    pub theta_deg: f64,
    /// The grating centre's offset from the shaft in servo-angle coordinates (the camera sees
    /// `offset·(cos θ, sin θ)`), µm.
    pub offset_um: [f64; 2],
    /// Focus position relative to the part's best focus, µm.
    pub dz_um: f64,
    /// Seed of the frame's noise and dust.
    pub seed: u64,
    /// The ring is lost (fault injection): the frame shows no ring.
    pub ring_lost: bool,
}

#[derive(Debug, Clone, Copy)]
struct Motion {
    /// Start of the current motion segment, s.
    t0: f64,
    /// Angle at t0, degrees.
    theta0: f64,
    /// Speed at the end of the ramp, °/s.
    v: f64,
    /// Ramp duration (accelerating from 0 when starting, decelerating to 0 when stopping), s.
    ramp: f64,
    /// Starting (true) or stopping (false).
    starting: bool,
}

impl Motion {
    fn angle(&self, t: f64) -> f64 {
        let dt = (t - self.t0).max(0.0);
        if self.starting {
            if dt < self.ramp {
                self.theta0 + 0.5 * self.v / self.ramp * dt * dt
            } else {
                self.theta0 + 0.5 * self.v * self.ramp + self.v * (dt - self.ramp)
            }
        } else {
            let d = dt.min(self.ramp);
            self.theta0 + self.v * d - 0.5 * self.v / self.ramp.max(1e-12) * d * d
        }
    }
    fn speed(&self, t: f64) -> f64 {
        let dt = (t - self.t0).max(0.0);
        if self.starting {
            self.v * (dt / self.ramp.max(1e-12)).min(1.0)
        } else {
            (self.v * (1.0 - dt / self.ramp.max(1e-12))).max(0.0)
        }
    }
}

#[derive(Debug, Clone)]
struct Contact {
    gain: f64,
    dir_deg: f64,
    moved_um: f64,
    pushes: u32,
}

/// The shared state of the simulated station.
pub struct Twin {
    /// Plant parameters.
    pub plant: PlantConfig,
    /// Pixel scale, µm per px.
    pub um_per_px: f64,
    /// Frame rate, fps.
    pub fps: f64,
    /// Exposure, s.
    pub exposure_s: f64,
    /// The station's constants.
    pub station: StationTruth,
    /// The current part.
    pub part: PartTruth,
    /// Pushes made on the current part.
    pub part_pushes: u32,
    /// Faults to inject.
    pub faults: Faults,
    /// Simulated time, s.
    pub t_s: f64,
    rng: ChaCha8Rng,
    /// Motion segments, latest last (a few kept: enough for the last turn's log).
    history: Vec<Motion>,
    focus_um: f64,
    contact: Option<Contact>,
    calls: [u64; 5],
    pace: Option<Pace>,
}

impl std::fmt::Debug for Twin {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Twin")
            .field("t_s", &self.t_s)
            .field("station", &self.station)
            .field("part", &self.part)
            .finish_non_exhaustive()
    }
}

impl Twin {
    /// A station with constants drawn from `seed`, empty until [`Twin::load_part`].
    pub fn new(plant: PlantConfig, um_per_px: f64, fps: f64, exposure_s: f64, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let station = StationTruth::draw(&plant, &mut rng);
        let part = PartTruth::draw(&plant, seed, 0);
        Twin {
            plant,
            um_per_px,
            fps,
            exposure_s,
            station,
            part,
            part_pushes: 0,
            faults: Faults::default(),
            t_s: 0.0,
            rng,
            history: vec![Motion {
                t0: 0.0,
                theta0: 0.0,
                v: 0.0,
                ramp: 0.0,
                starting: false,
            }],
            focus_um: 0.0,
            contact: None,
            calls: [0; 5],
            pace: None,
        }
    }

    /// Puts the focus drive at `z_um` without a move (no time passes): where the part before
    /// left it, for a batch resumed after that part.
    pub fn place_focus(&mut self, z_um: f64) {
        self.focus_um = z_um;
    }

    /// Runs in step with the wall clock from now on (see [`Pace`]).
    pub fn set_pace(&mut self, pace: Pace) {
        self.pace = Some(pace);
    }

    /// Places a new part on the shaft.
    ///
    /// Each part starts on its own clock at 0 s with its own random stream (its
    /// [`PartTruth::noise_seed`]), so part `i` of a batch depends only on the seed, its index
    /// and what the controller learned before it: a batch resumed at part `i` gives the same
    /// records as one run without a break.
    pub fn load_part(&mut self, part: PartTruth) {
        let th = part.start_angle_deg;
        self.rng = ChaCha8Rng::seed_from_u64(part.noise_seed);
        self.t_s = 0.0;
        if let Some(p) = self.pace.as_mut() {
            p.rebase(0.0);
        }
        self.part = part;
        self.part_pushes = 0;
        self.contact = None;
        self.history.clear();
        self.set_motion(Motion {
            t0: self.t_s,
            theta0: th,
            v: 0.0,
            ramp: 0.0,
            starting: false,
        });
    }

    /// The true eccentricity of the current part, µm.
    pub fn true_e_um(&self) -> f64 {
        self.part.e_um()
    }

    /// Counts a call to device `d` and fails it when a fault is injected on this call.
    ///
    /// # Errors
    /// The injected [`SimDeviceError`].
    pub fn call(&mut self, d: DeviceId) -> Result<(), SimDeviceError> {
        let i = d as usize;
        self.calls[i] += 1;
        if let Some((dev, n)) = self.faults.device_error
            && dev == d
            && self.calls[i] == n
        {
            return Err(SimDeviceError {
                device: d,
                kind: DeviceErrorKind::Fault,
                message: format!("injected fault on call {n}"),
            });
        }
        Ok(())
    }

    /// Simulated time moved on: in paced mode, wait for the wall clock.
    fn advanced(&mut self) {
        let t = self.t_s;
        if let Some(p) = self.pace.as_mut() {
            p.wait_until(t);
        }
    }

    fn set_motion(&mut self, m: Motion) {
        if self.history.len() >= 8 {
            self.history.remove(0);
        }
        self.history.push(m);
    }

    fn motion_at(&self, t: f64) -> Motion {
        self.history
            .iter()
            .rev()
            .find(|m| m.t0 <= t)
            .or(self.history.first())
            .copied()
            .unwrap_or(Motion {
                t0: 0.0,
                theta0: 0.0,
                v: 0.0,
                ramp: 0.0,
                starting: false,
            })
    }

    fn angle(&self, t: f64) -> f64 {
        self.motion_at(t).angle(t)
    }

    /// Takes the next exposure: its time, the servo angle at mid-exposure, the part's pose and
    /// a frame seed; advances the clock by one frame interval.
    pub fn expose(&mut self) -> Exposure {
        self.exposure(true)
    }

    /// As [`Twin::expose`]; the fast fidelity draws no frame seed (its random stream stays the
    /// one the station's acceptance figures were made with).
    fn exposure(&mut self, draw_seed: bool) -> Exposure {
        let start = self.t_s;
        let mid = start + 0.5 * self.exposure_s;
        let e = Exposure {
            start_s: start,
            exposure_s: self.exposure_s,
            theta_deg: self.angle(mid),
            offset_um: self.part.offset_um,
            dz_um: self.focus_um - self.part.best_focus_um,
            seed: if draw_seed {
                self.rng.random::<u64>()
            } else {
                0
            },
            ring_lost: self
                .faults
                .ring_lost_after_pushes
                .is_some_and(|n| self.part_pushes >= n),
        };
        self.t_s += 1.0 / self.fps;
        let t = self.t_s;
        if let Some(p) = self.pace.as_mut() {
            p.frame_at(t, 1.0 / self.fps);
        }
        e
    }

    /// The fast fidelity's frame: the ring's column from the geometry plus the detector's noise,
    /// a Gaussian focus curve, and the detector's reasons for the frames it could not use.
    fn fast_frame(&mut self) -> CameraFrame {
        let x = self.exposure(false);
        let c_true = self
            .part
            .column_px(&self.plant, self.um_per_px, x.theta_deg);
        let p = &self.plant;
        let w = x.dz_um / p.focus_depth_um;
        let focus_measure = if self.faults.focus_dead {
            0.3 * p.focus_peak
        } else {
            0.05 * p.focus_peak + p.focus_peak * (-0.5 * w * w).exp()
        } * (1.0 + 0.01 * Normal::new(0.0, 1.0).unwrap().sample(&mut self.rng));
        let sigma = p.noise_px * (1.0 + w * w).sqrt();
        // A defocus so far out that σ overflows: the frame is out of focus anyway (its reason
        // below); its column gets no noise rather than an infinite one (and no panic).
        let z: f64 = rand_distr::StandardNormal.sample(&mut self.rng);
        let noise = if sigma.is_finite() { sigma * z } else { 0.0 };
        let reason = if x.ring_lost {
            Some(InvalidReason::NoRing)
        } else if w.abs() > 3.0 || self.faults.focus_dead {
            Some(InvalidReason::OutOfFocus)
        } else if !(0.0..p.window_width_px).contains(&c_true) {
            Some(InvalidReason::RingOutsideWindow)
        } else {
            None
        };
        CameraFrame {
            start_s: x.start_s,
            exposure_s: x.exposure_s,
            c_px: reason.is_none().then_some(c_true + noise),
            invalid_reason: reason,
            focus_measure,
        }
    }

    fn apply_move(&mut self, dir_deg: f64, m_um: f64) {
        let t = dir_deg.to_radians();
        self.part.offset_um[0] -= m_um * t.cos();
        self.part.offset_um[1] -= m_um * t.sin();
    }
}

/// The shared handle every simulated device holds.
pub type Shared = Rc<RefCell<Twin>>;

/// The simulated servo.
#[derive(Debug, Clone)]
pub struct SimServo(pub Shared);

impl SimServo {
    /// Starts a turn from the current angle; `wait`: return once at speed (the spin-up, its
    /// settling included), else at once (frames may follow during the ramp).
    fn turn(&mut self, speed_deg_per_s: f64, wait: bool) -> Result<(), SimDeviceError> {
        let mut t = self.0.borrow_mut();
        t.call(DeviceId::Servo)?;
        let now = t.t_s;
        let theta0 = t.angle(now);
        let ramp = t.plant.timing.ramp_at(speed_deg_per_s);
        t.set_motion(Motion {
            t0: now,
            theta0,
            v: speed_deg_per_s,
            ramp,
            starting: true,
        });
        if wait {
            t.t_s += t.plant.timing.spin_up_at(speed_deg_per_s);
            t.advanced();
        }
        Ok(())
    }
}
/// The simulated camera at fast fidelity (the column from the geometry); the full fidelity is a
/// `DetectorCamera` over [`TwinFrames`](super::frames::TwinFrames).
#[derive(Debug, Clone)]
pub struct SimCamera(pub Shared);
/// The simulated focus drive.
#[derive(Debug, Clone)]
pub struct SimFocus(pub Shared);
/// The simulated push rod.
#[derive(Debug, Clone)]
pub struct SimRod(pub Shared);
/// The simulated (discrete-event) clock.
#[derive(Debug, Clone)]
pub struct SimClock(pub Shared);

impl Clock for SimClock {
    type Error = SimDeviceError;
    fn now_s(&mut self) -> Result<f64, SimDeviceError> {
        let mut t = self.0.borrow_mut();
        t.call(DeviceId::Clock)?;
        Ok(t.t_s)
    }
    fn wait_s(&mut self, dt_s: f64) -> Result<(), SimDeviceError> {
        let mut t = self.0.borrow_mut();
        t.call(DeviceId::Clock)?;
        t.t_s += dt_s.max(0.0);
        t.advanced();
        Ok(())
    }
}

impl Servo for SimServo {
    type Error = SimDeviceError;
    fn angle_deg(&mut self) -> Result<f64, SimDeviceError> {
        let mut t = self.0.borrow_mut();
        t.call(DeviceId::Servo)?;
        Ok(t.angle(t.t_s))
    }
    fn move_to_deg(&mut self, target_deg: f64) -> Result<(), SimDeviceError> {
        let mut t = self.0.borrow_mut();
        t.call(DeviceId::Servo)?;
        if !target_deg.is_finite() {
            return Err(SimDeviceError {
                device: DeviceId::Servo,
                kind: DeviceErrorKind::Other,
                message: format!("target {target_deg}° is not finite"),
            });
        }
        // A turning servo brakes into the move: its ramp down, then the settle-limited
        // positioning move.
        let now = t.t_s;
        let v = t.motion_at(now).speed(now);
        if v != 0.0 {
            let theta0 = t.angle(now);
            let ramp = t.plant.timing.ramp_at(v);
            t.set_motion(Motion {
                t0: now,
                theta0,
                v,
                ramp,
                starting: false,
            });
            t.t_s += ramp;
        }
        t.t_s += t.plant.timing.align_s;
        let now = t.t_s;
        t.set_motion(Motion {
            t0: now,
            theta0: target_deg,
            v: 0.0,
            ramp: 0.0,
            starting: false,
        });
        t.advanced();
        Ok(())
    }
    fn start_turn(&mut self, speed_deg_per_s: f64) -> Result<(), SimDeviceError> {
        self.turn(speed_deg_per_s, true)
    }
    fn begin_turn(&mut self, speed_deg_per_s: f64) -> Result<(), SimDeviceError> {
        self.turn(speed_deg_per_s, false)
    }
    fn stop(&mut self) -> Result<(), SimDeviceError> {
        let mut t = self.0.borrow_mut();
        t.call(DeviceId::Servo)?;
        let now = t.t_s;
        let (theta0, v) = (t.angle(now), t.motion_at(now).speed(now));
        let ramp = t.plant.timing.ramp_at(v);
        t.set_motion(Motion {
            t0: now,
            theta0,
            v,
            ramp,
            starting: false,
        });
        t.t_s += t.plant.timing.stop_at(v);
        t.advanced();
        Ok(())
    }
    fn angle_log(&mut self, since_s: f64) -> Result<Vec<AngleSample>, SimDeviceError> {
        let mut t = self.0.borrow_mut();
        t.call(DeviceId::Servo)?;
        let period = t.plant.log_period_s;
        let phase = t.part.log_phase_s;
        let k0 = ((since_s - phase) / period).ceil() as i64;
        let k1 = ((t.t_s - phase) / period).floor() as i64;
        let mut out = Vec::with_capacity((k1 - k0 + 1).max(0) as usize);
        for k in k0..=k1 {
            let ts = phase + k as f64 * period;
            out.push(AngleSample {
                t_s: ts,
                theta_deg: t.angle(ts),
            });
        }
        Ok(out)
    }
}

impl Camera for SimCamera {
    type Error = SimDeviceError;
    fn capture(&mut self) -> Result<CameraFrame, SimDeviceError> {
        let mut t = self.0.borrow_mut();
        t.call(DeviceId::Camera)?;
        Ok(t.fast_frame())
    }
}

impl FocusDrive for SimFocus {
    type Error = SimDeviceError;
    fn position_um(&mut self) -> Result<f64, SimDeviceError> {
        let mut t = self.0.borrow_mut();
        t.call(DeviceId::Focus)?;
        Ok(t.focus_um)
    }
    fn move_to_um(&mut self, z_um: f64) -> Result<(), SimDeviceError> {
        let mut t = self.0.borrow_mut();
        t.call(DeviceId::Focus)?;
        t.focus_um = z_um;
        t.t_s += t.plant.timing.focus_move_s;
        t.advanced();
        Ok(())
    }
}

impl PushRod for SimRod {
    type Error = SimDeviceError;
    fn approach(&mut self, speed: ApproachSpeed) -> Result<(), SimDeviceError> {
        let mut t = self.0.borrow_mut();
        t.call(DeviceId::Rod)?;
        let tm = t.plant.timing.clone();
        t.t_s += tm.approach_fast_s
            + if speed == ApproachSpeed::Slow {
                tm.slow_extra_s
            } else {
                0.0
            };
        // The rod faces the shaft's current angle; the actual push direction is off by the
        // station's offset plus a per-push scatter.
        let now = t.t_s;
        let facing = t.angle(now);
        let p = t.plant.clone();
        let station = t.station;
        let rng = &mut t.rng;
        let dir = facing
            + station.offset_deg
            + Normal::new(0.0, p.push_angle_sd_deg).unwrap().sample(rng);
        let gain = Normal::new(station.gain, p.gain_sd).unwrap().sample(rng);
        let sd = match speed {
            ApproachSpeed::Fast => p.overshoot_fast_sd_um,
            ApproachSpeed::Slow => p.overshoot_slow_sd_um,
        };
        let overshoot = Normal::new(0.0, sd).unwrap().sample(rng).abs();
        t.apply_move(dir, overshoot);
        t.contact = Some(Contact {
            gain,
            dir_deg: dir,
            moved_um: overshoot,
            pushes: 0,
        });
        t.advanced();
        Ok(())
    }
    fn push_um(&mut self, d_um: f64) -> Result<(), SimDeviceError> {
        let mut t = self.0.borrow_mut();
        t.call(DeviceId::Rod)?;
        let Some(mut c) = t.contact.clone() else {
            return Err(SimDeviceError {
                device: DeviceId::Rod,
                kind: DeviceErrorKind::Other,
                message: "push without contact".into(),
            });
        };
        let tm = t.plant.timing.clone();
        t.t_s += if c.pushes == 0 {
            tm.push_s
        } else {
            tm.push_step_s
        };
        let p = t.plant.clone();
        let mut m = c.gain * d_um.max(0.0);
        if m < p.stiction_um {
            m = 0.0;
        } else if c.pushes == 0 {
            let rng = &mut t.rng;
            m += p.slip_max_um * rng.random::<f64>()
                - Normal::new(0.0, p.contact_error_sd_um).unwrap().sample(rng);
            m = m.max(0.0);
        }
        t.apply_move(c.dir_deg, m);
        c.moved_um += m;
        c.pushes += 1;
        t.contact = Some(c);
        t.advanced();
        Ok(())
    }
    fn retract(&mut self) -> Result<(), SimDeviceError> {
        let mut t = self.0.borrow_mut();
        t.call(DeviceId::Rod)?;
        t.t_s += t.plant.timing.retract_s;
        if let Some(c) = t.contact.take() {
            let sb = t.plant.spring_back_max * t.rng.random::<f64>();
            t.apply_move(c.dir_deg, -sb * c.moved_um);
            t.part_pushes += 1;
        }
        t.advanced();
        Ok(())
    }
}
