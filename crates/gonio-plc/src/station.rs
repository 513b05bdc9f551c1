//! The station over the wire: one [`PlcStation`] (the Modbus link, the triggered camera and the
//! angle pairing) behind five thin device handles that implement `gonio_station::hal`, so the
//! controller mounts through a PLC exactly as it does on its twin.
//!
//! - [`PlcServo`]: moves, turns and stops through commands; its angle log is the latched
//!   (mid-exposure time, angle) of every frame the camera gave, so each frame is stamped with
//!   its own latched angle.
//! - [`PlcCamera`]: the next frame triggered after the last motion finished, paired with its
//!   latched angle (a frame with none ends the part: `device_error`).
//! - [`PlcFocus`]: the focus drive through commands.
//! - [`PlcRod`]: approach with contact seen in the ring's column ([`crate::contact`]), push,
//!   retract.
//! - [`PlcClock`]: the PLC's clock (every time the controller sees is PLC time).
//!
//! The frames come from a [`TriggeredCamera`]: a GigE Vision camera's frames through the
//! detector ([`DetectorTriggered`] over any `FrameSource`), or a test's stand-in.
//!
//! Errors: [`PlcError`].

use crate::contact::{ContactDetector, Verdict};
use crate::link::{Command, Link, PlcError, Status, bits};
use crate::map::{LATCH_ENTRY_REGS, Pairing, SAMPLE_ENTRY_REGS, words_i32, words_u32, words_u64};
use crate::pairing::{AnglePairing, Interpolated, LatchedRing};
use gonio_station::Devices;
use gonio_station::hal::{
    ApproachSpeed, Camera, CameraFrame, Clock, DeviceError, DeviceErrorKind, FocusDrive, PushRod,
    Servo,
};
use gonio_station::interval::AngleSample;
use gonio_vision::{FrameResult, FrameSource, Optics, SourceDetector, SourceError, VisionError};
use std::cell::RefCell;
use std::rc::Rc;
use std::time::{Duration, Instant};

/// One frame of a triggered camera, through the detector.
#[derive(Debug, Clone, PartialEq)]
pub struct TriggeredFrame {
    /// The camera's frame number (= the PLC's trigger count).
    pub frame_id: u64,
    /// The camera's timestamp of the exposure start, s, on the PLC's clock when the clocks are
    /// synchronised (`None`: unknown).
    pub timestamp_s: Option<f64>,
    /// The detector's result; `start_s` is replaced by the paired PLC time.
    pub frame: CameraFrame,
}

/// A camera triggered by the PLC: frames in order, each with its number.
pub trait TriggeredCamera {
    /// The camera's error.
    type Error: DeviceError + std::fmt::Display;
    /// The next frame, waiting at most `timeout`; `Ok(None)` when none came in time.
    ///
    /// # Errors
    /// The camera failed.
    fn next_frame(&mut self, timeout: Duration) -> Result<Option<TriggeredFrame>, Self::Error>;
}

/// A `FrameSource` (e.g. a GigE Vision camera) through the streaming detector: frame numbers
/// from the source's stamps; optionally every frame shown to a [`FrameTap`].
pub struct DetectorTriggered<S> {
    det: SourceDetector<S>,
    tap: Option<FrameTap>,
}

impl<S: std::fmt::Debug> std::fmt::Debug for DetectorTriggered<S> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DetectorTriggered")
            .field("det", &self.det)
            .field("tap", &self.tap.is_some())
            .finish()
    }
}

/// One frame as a [`FrameTap`] sees it: the camera window's pixels as the detector saw them
/// (borrowed from its buffers, no copy) and what it found.
#[derive(Debug, Clone, Copy)]
pub struct TappedFrame<'a> {
    /// The camera's frame number (= the PLC's trigger count).
    pub frame_id: u64,
    /// Width, px (the optics' window).
    pub width: usize,
    /// Height, px.
    pub height: usize,
    /// 8-bit grey pixels, row-major, `width` × `height`.
    pub pixels: &'a [u8],
    /// The detector's result (edge columns and `c_px` in the window's pixels).
    pub result: &'a FrameResult,
}

/// Told every frame a [`DetectorTriggered`] detects, paired or not, as it is detected (e.g. the
/// live view's thumbnail). It runs on the camera's thread between frames: it should return at
/// once for most frames (rate-limit before any work).
pub type FrameTap = Box<dyn FnMut(&TappedFrame<'_>) + Send>;

impl<S: FrameSource> DetectorTriggered<S> {
    /// The source through the detector for `optics`.
    ///
    /// # Errors
    /// Invalid optics.
    pub fn new(source: S, optics: &Optics) -> Result<Self, VisionError> {
        Ok(DetectorTriggered {
            det: SourceDetector::new(source, optics)?,
            tap: None,
        })
    }

    /// Shows every frame detected from now on to `tap` (replacing any tap before).
    #[must_use]
    pub fn with_tap(mut self, tap: FrameTap) -> Self {
        self.tap = Some(tap);
        self
    }

    /// The source.
    pub fn source_mut(&mut self) -> &mut S {
        self.det.source_mut()
    }
}

/// An error of [`DetectorTriggered`].
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DetectorTriggeredError<E: std::error::Error + 'static> {
    /// The source failed.
    #[error(transparent)]
    Source(E),
    /// A frame could not be run through the detector.
    #[error("frame {index}: {error}")]
    Frame {
        /// The frame.
        index: u64,
        /// Why.
        error: VisionError,
    },
}

impl<E: std::error::Error + DeviceError + 'static> DeviceError for DetectorTriggeredError<E> {
    fn kind(&self) -> DeviceErrorKind {
        match self {
            DetectorTriggeredError::Source(e) => e.kind(),
            DetectorTriggeredError::Frame { .. } => DeviceErrorKind::Fault,
        }
    }
}

impl<S> TriggeredCamera for DetectorTriggered<S>
where
    S: FrameSource,
    S::Error: DeviceError,
{
    type Error = DetectorTriggeredError<S::Error>;

    fn next_frame(&mut self, _timeout: Duration) -> Result<Option<TriggeredFrame>, Self::Error> {
        // The source's own timeout bounds the wait (a GigE source ends with an error).
        let d = match self.det.detect_next() {
            Ok(Some(d)) => d,
            Ok(None) => return Ok(None),
            Err(SourceError::Source(e)) => return Err(DetectorTriggeredError::Source(e)),
            Err(SourceError::Frame { index, error }) => {
                return Err(DetectorTriggeredError::Frame { index, error });
            }
        };
        if let (Some(tap), Some(pixels)) = (self.tap.as_mut(), self.det.window()) {
            let optics = self.det.optics();
            tap(&TappedFrame {
                frame_id: d.stamp.index,
                width: optics.window_width_px as usize,
                height: optics.window_height_px as usize,
                pixels,
                result: &d.result,
            });
        }
        let r = d.result;
        Ok(Some(TriggeredFrame {
            frame_id: d.stamp.index,
            timestamp_s: d.stamp.start_s,
            frame: CameraFrame {
                start_s: d.stamp.start_s.unwrap_or(f64::NAN),
                exposure_s: d.stamp.exposure_s.unwrap_or(0.0),
                c_px: r.c_px.filter(|_| r.valid),
                invalid_reason: if r.valid { None } else { r.reason },
                focus_measure: r.focus,
            },
        }))
    }
}

/// A frame source whose frames carry their trigger count in their first pixels (the simulated
/// camera's embedded counter, [`crate::sim::stamp_trigger`]): each frame's stamp index becomes
/// its trigger count, for [`DetectorTriggered`].
#[derive(Debug)]
pub struct StampedSource<S>(pub S);

impl<S: FrameSource> FrameSource for StampedSource<S> {
    type Error = S::Error;
    fn next_frame(
        &mut self,
        pixels: &mut Vec<u8>,
    ) -> Result<Option<gonio_vision::FrameHeader>, S::Error> {
        let Some(mut h) = self.0.next_frame(pixels)? else {
            return Ok(None);
        };
        if let Some(k) = crate::sim::read_trigger(pixels) {
            h.stamp.index = k;
            // The counter's pixels back to their neighbours' grey, for the detector.
            let fill = pixels.get(crate::sim::STAMP_PIXELS).copied().unwrap_or(0);
            for p in pixels.iter_mut().take(crate::sim::STAMP_PIXELS) {
                *p = fill;
            }
        }
        Ok(Some(h))
    }
}

/// Settings of the station besides the register map.
#[derive(Debug, Clone, PartialEq)]
pub struct StationOptions {
    /// Frame rate of the trigger, fps.
    pub fps: f64,
    /// Exposure, s (the latched angle is at mid-exposure).
    pub exposure_s: f64,
    /// Pixel scale, µm/px.
    pub um_per_px: f64,
}

/// Counts of the pairing.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PairingCounts {
    /// Frames paired with an angle.
    pub paired: u64,
    /// Frames skipped because they were triggered before the last motion finished.
    pub stale: u64,
}

struct Inner<C> {
    link: Link,
    camera: C,
    latched: LatchedRing,
    samples: Interpolated,
    sample_read: u64,
    log: Vec<AngleSample>,
    fresh_after_s: f64,
    opts: StationOptions,
    counts: PairingCounts,
}

/// The station behind the PLC; clone the device handles out with [`PlcStation::devices`].
pub struct PlcStation<C>(Rc<RefCell<Inner<C>>>);

impl<C> Clone for PlcStation<C> {
    fn clone(&self) -> Self {
        PlcStation(self.0.clone())
    }
}

impl<C> std::fmt::Debug for PlcStation<C> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PlcStation").finish_non_exhaustive()
    }
}

/// The servo through the PLC.
pub type PlcServo<C> = PlcStation<C>;

/// A device handle: which device the trait methods drive.
#[derive(Debug)]
pub struct Handle<C, const D: u8>(PlcStation<C>);

/// The camera handle.
pub type PlcCamera<C> = Handle<C, 1>;
/// The focus-drive handle.
pub type PlcFocus<C> = Handle<C, 2>;
/// The push-rod handle.
pub type PlcRod<C> = Handle<C, 3>;
/// The clock handle.
pub type PlcClock<C> = Handle<C, 4>;

/// The controller's devices over one PLC station.
pub type PlcDevices<C> = Devices<PlcServo<C>, PlcCamera<C>, PlcFocus<C>, PlcRod<C>, PlcClock<C>>;

impl<C: TriggeredCamera> PlcStation<C> {
    /// A station over a connected link and a camera: clears a latched fault and starts the
    /// camera trigger at `opts.fps`.
    ///
    /// # Errors
    /// Link failures; the e-stop pressed.
    pub fn new(mut link: Link, camera: C, opts: StationOptions) -> Result<Self, PlcError> {
        let s = link.status()?;
        if s.has(bits::ESTOP) {
            link.check(&s, "start")?;
        }
        if s.has(bits::FAULT) || s.has(bits::WATCHDOG) {
            link.command(Command::ResetFault, 0, 0)?;
        }
        let cap = link.map.input.latch_ring_len as u64;
        link.command(Command::Trigger, (opts.fps * 1000.0).round() as i32, 0)?;
        let s = link.status()?;
        Ok(PlcStation(Rc::new(RefCell::new(Inner {
            link,
            camera,
            latched: LatchedRing::new(cap),
            samples: Interpolated::default(),
            sample_read: s.sample_count as u64,
            log: Vec::new(),
            fresh_after_s: s.time_s,
            opts,
            counts: PairingCounts::default(),
        }))))
    }

    /// The five device handles for the controller.
    pub fn devices(&self) -> PlcDevices<C> {
        Devices {
            servo: self.clone(),
            camera: Handle(self.clone()),
            focus: Handle(self.clone()),
            rod: Handle(self.clone()),
            clock: Handle(self.clone()),
        }
    }

    /// The PLC's address.
    pub fn addr(&self) -> String {
        self.0.borrow().link.addr().to_string()
    }

    /// The PLC's status now.
    ///
    /// # Errors
    /// Link failures.
    pub fn status(&self) -> Result<Status, PlcError> {
        self.0.borrow_mut().link.status()
    }

    /// Waits up to `timeout` for a part on the shaft; returns its number.
    ///
    /// # Errors
    /// Link failures, faults, [`PlcError::CommandTimeout`] when no part came.
    pub fn wait_part(&self, timeout: Duration) -> Result<u32, PlcError> {
        let t0 = Instant::now();
        let mut i = self.0.borrow_mut();
        loop {
            let s = i.link.status()?;
            i.link.check(&s, "waiting for a part")?;
            if s.has(bits::PART_PRESENT) && s.part > 0 {
                return Ok(s.part);
            }
            if t0.elapsed() > timeout {
                return Err(PlcError::CommandTimeout {
                    addr: i.link.addr().to_string(),
                    what: "waiting for a part".into(),
                    timeout_s: timeout.as_secs_f64(),
                });
            }
            std::thread::sleep(Duration::from_millis(i.link.map.timing.poll_ms.max(10)));
        }
    }

    /// Tells the PLC the part is finished (it unloads it and loads the next). Frames triggered
    /// before the next part is on the shaft are stale (a part's focus check may start without a
    /// move of its own).
    ///
    /// # Errors
    /// Link failures.
    pub fn part_done(&self) -> Result<(), PlcError> {
        let mut i = self.0.borrow_mut();
        i.motion(Command::PartDone, 0, 0)?;
        Ok(())
    }

    /// Leaves the station safe: rod home, servo stopped, trigger off (best effort).
    pub fn safe_stop(&self) {
        let mut i = self.0.borrow_mut();
        let _ = i.link.command(Command::Retract, 0, 0);
        let _ = i.link.command(Command::StopServo, 0, 0);
        let _ = i.link.command(Command::Trigger, 0, 0);
    }

    /// The link's round-trip times, p50 and p99, ms, and the requests timed.
    pub fn round_trip_ms(&self) -> (f64, f64, usize) {
        let i = self.0.borrow();
        let r = i.link.round_trips();
        (r.quantile_ms(0.5), r.quantile_ms(0.99), r.count())
    }

    /// Frames paired and skipped so far.
    pub fn pairing_counts(&self) -> PairingCounts {
        self.0.borrow().counts
    }

    /// The link's figures so far: [`PlcStation::round_trip_ms`] and
    /// [`PlcStation::pairing_counts`] together (a scan of the round trips' histogram: not for
    /// every frame).
    pub fn link_figures(&self) -> crate::batch::LinkFigures {
        let (p50, p99, n) = self.round_trip_ms();
        let counts = self.pairing_counts();
        crate::batch::LinkFigures {
            requests: n,
            round_trip_p50_ms: p50,
            round_trip_p99_ms: p99,
            frames_paired: counts.paired,
            frames_stale: counts.stale,
        }
    }
}

impl<C: TriggeredCamera> Inner<C> {
    fn motion(&mut self, cmd: Command, arg0: i32, arg1: i32) -> Result<Status, PlcError> {
        let s = self.link.command(cmd, arg0, arg1)?;
        self.fresh_after_s = s.time_s;
        Ok(s)
    }

    /// Reads the latch ring's entries up to the PLC's trigger count.
    fn read_latches(&mut self) -> Result<(), PlcError> {
        let s = self.link.status()?;
        self.link.check(&s, "reading the latch ring")?;
        let newest = s.trigger_count as u64;
        if newest < self.latched.newest {
            self.latched.clear();
        }
        let cap = self.latched.capacity;
        let first = (self.latched.newest + 1)
            .max(newest.saturating_sub(cap - 1))
            .max(1);
        let mut k = first;
        while k <= newest {
            let slot = (k - 1) % cap;
            let n = (newest - k + 1).min(cap - slot).min(15);
            let base = self.link.map.input.latch_ring + (slot as u16) * LATCH_ENTRY_REGS;
            let w = self.link.read_input(base, n as u16 * LATCH_ENTRY_REGS)?;
            for e in w.chunks(LATCH_ENTRY_REGS as usize) {
                let count = words_u32(&e[0..2]) as u64;
                let t = words_u64(&e[2..6]) as f64 * 1e-6;
                let th = self.link.map.angle_deg(words_i32(&e[6..8]));
                if count >= first && count <= newest {
                    self.latched.add(count, t, th);
                }
            }
            k += n;
        }
        self.latched.newest = self.latched.newest.max(newest);
        Ok(())
    }

    /// Reads the angle samples written since the last read.
    fn read_samples(&mut self) -> Result<(), PlcError> {
        let s = self.link.status()?;
        self.link.check(&s, "reading the angle samples")?;
        let newest = s.sample_count as u64;
        let cap = self.link.map.input.sample_ring_len as u64;
        let mut k = (self.sample_read + 1)
            .max(newest.saturating_sub(cap - 1))
            .max(1);
        while k <= newest {
            let slot = (k - 1) % cap;
            let n = (newest - k + 1).min(cap - slot).min(20);
            let base = self.link.map.input.sample_ring + (slot as u16) * SAMPLE_ENTRY_REGS;
            let w = self.link.read_input(base, n as u16 * SAMPLE_ENTRY_REGS)?;
            for e in w.chunks(SAMPLE_ENTRY_REGS as usize) {
                self.samples.add(AngleSample {
                    t_s: words_u64(&e[0..4]) as f64 * 1e-6,
                    theta_deg: self.link.map.angle_deg(words_i32(&e[4..6])),
                });
            }
            k += n;
        }
        self.sample_read = newest;
        Ok(())
    }

    /// The next frame triggered after the last motion, with its PLC time and angle.
    fn capture(&mut self) -> Result<CameraFrame, PlcError> {
        let timeout = Duration::from_millis(self.link.map.timing.frame_timeout_ms);
        let half = 0.5 * self.opts.exposure_s;
        let pairing = self.link.map.pairing;
        let t0 = Instant::now();
        loop {
            self.link.heartbeat(false)?;
            let f = self
                .camera
                .next_frame(timeout)
                .map_err(|e| PlcError::Camera {
                    message: e.to_string(),
                    kind: e.kind(),
                })?;
            let Some(f) = f else {
                return Err(PlcError::Camera {
                    message: format!("no frame within {} ms", timeout.as_millis()),
                    kind: DeviceErrorKind::Timeout,
                });
            };
            if f.frame_id == 0 && pairing == Pairing::Latched {
                // Not a trigger's frame (trigger counts start at 1): a frame the camera took
                // before the trigger ran.
                self.counts.stale += 1;
                if t0.elapsed() > 4 * timeout {
                    return Err(PlcError::Camera {
                        message: "no triggered frame (only frames numbered 0)".into(),
                        kind: DeviceErrorKind::Timeout,
                    });
                }
                continue;
            }
            let mid = f.timestamp_s.map(|t| t + half);
            let mut tries = 0;
            let (t_mid, theta) = loop {
                let r = match pairing {
                    Pairing::Latched => self.latched.lookup(f.frame_id, mid),
                    Pairing::Interpolated => self.samples.lookup(f.frame_id, mid),
                };
                match r {
                    Ok(Some(v)) => break v,
                    Ok(None) if tries < 50 => {
                        tries += 1;
                        if tries > 1 {
                            std::thread::sleep(Duration::from_millis(2));
                        }
                        match pairing {
                            Pairing::Latched => self.read_latches()?,
                            Pairing::Interpolated => self.read_samples()?,
                        }
                    }
                    Ok(None) => {
                        return Err(PlcError::Pairing {
                            message: format!(
                                "frame {} has no latched angle: the PLC reported none for it within {} tries",
                                f.frame_id, tries
                            ),
                        });
                    }
                    Err(message) => {
                        // A frame whose latch was overwritten while gonio waited for a motion:
                        // triggered before a later latch that is itself stale, so stale too.
                        let stale = pairing == Pairing::Latched
                            && self
                                .latched
                                .next_latch_s(f.frame_id)
                                .is_some_and(|t| t <= self.fresh_after_s);
                        if !stale {
                            return Err(PlcError::Pairing { message });
                        }
                        break (f64::NEG_INFINITY, f64::NAN);
                    }
                }
            };
            if t_mid <= self.fresh_after_s {
                self.counts.stale += 1;
                if t0.elapsed() > 4 * timeout {
                    return Err(PlcError::Camera {
                        message: format!(
                            "no frame triggered after {:.3} s (PLC time) within {} ms",
                            self.fresh_after_s,
                            (4 * timeout).as_millis()
                        ),
                        kind: DeviceErrorKind::Timeout,
                    });
                }
                continue;
            }
            self.counts.paired += 1;
            if self.log.last().is_none_or(|l| t_mid > l.t_s) {
                self.log.push(AngleSample {
                    t_s: t_mid,
                    theta_deg: theta,
                });
                if self.log.len() > 200_000 {
                    self.log.drain(..100_000);
                }
            }
            let mut frame = f.frame;
            frame.start_s = t_mid - half;
            frame.exposure_s = self.opts.exposure_s;
            return Ok(frame);
        }
    }

    fn approach(&mut self, speed: ApproachSpeed) -> Result<(), PlcError> {
        let rod = self.link.map.rod.clone();
        let mut det = ContactDetector::new(
            rod.baseline_frames,
            rod.contact_sigmas,
            rod.contact_min_px,
            rod.contact_frames,
        );
        // The baseline before the rod moves: where the edge is, and the column's noise.
        while det.update(self.capture()?.c_px) == Verdict::Learning {}
        let edge_um = (det.baseline_px() - rod.centre_column_px) * self.opts.um_per_px;
        let standoff = (rod.gap_centred_um - edge_um - rod.margin_um).max(0.0);
        let creep = match speed {
            ApproachSpeed::Fast => rod.creep_fast_um_per_s,
            ApproachSpeed::Slow => rod.creep_slow_um_per_s,
        };
        let m = &self.link.map;
        let seq = self.link.send(
            Command::Approach,
            m.length_counts(creep),
            m.length_counts(standoff),
        )?;
        // Bounded: the whole travel at creep speed, twice over, in frames.
        let max_frames = (2.0 * rod.travel_limit_um / creep * self.opts.fps) as usize + 1000;
        for _ in 0..max_frames {
            let f = self.capture()?;
            if det.update(f.c_px) == Verdict::Contact {
                self.motion(Command::StopRod, 0, 0)?;
                return Ok(());
            }
            let s = self.link.status()?;
            self.link.check(&s, "approach")?;
            if s.ack == seq && s.has(bits::DONE) {
                return Err(PlcError::NoContact {
                    message: format!("the approach ended at {:.1} µm without contact", s.rod_um),
                });
            }
        }
        let _ = self.link.command(Command::StopRod, 0, 0);
        Err(PlcError::NoContact {
            message: format!("no contact seen in {max_frames} frames"),
        })
    }
}

impl<C: TriggeredCamera> Servo for PlcStation<C> {
    type Error = PlcError;
    fn angle_deg(&mut self) -> Result<f64, PlcError> {
        Ok(self.0.borrow_mut().link.status()?.angle_deg)
    }
    fn move_to_deg(&mut self, target_deg: f64) -> Result<(), PlcError> {
        let mut i = self.0.borrow_mut();
        let a = i.link.map.angle_counts(target_deg);
        i.motion(Command::MoveServo, a, 0).map(|_| ())
    }
    fn start_turn(&mut self, speed_deg_per_s: f64) -> Result<(), PlcError> {
        let mut i = self.0.borrow_mut();
        let v = i.link.map.speed_counts(speed_deg_per_s);
        i.motion(Command::Turn, v, 0).map(|_| ())
    }
    fn begin_turn(&mut self, speed_deg_per_s: f64) -> Result<(), PlcError> {
        // The turn command is not waited for: the frames of the ramp count (each has its
        // latched angle); frames triggered before the PLC took it are stale.
        let mut i = self.0.borrow_mut();
        let v = i.link.map.speed_counts(speed_deg_per_s);
        i.link.send(Command::Turn, v, 0)?;
        let s = i.link.status()?;
        i.link.check(&s, "turn")?;
        i.fresh_after_s = s.time_s;
        Ok(())
    }
    fn stop(&mut self) -> Result<(), PlcError> {
        self.0
            .borrow_mut()
            .motion(Command::StopServo, 0, 0)
            .map(|_| ())
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
        self.0.0.borrow_mut().capture()
    }
}

impl<C: TriggeredCamera> FocusDrive for PlcFocus<C> {
    type Error = PlcError;
    fn position_um(&mut self) -> Result<f64, PlcError> {
        Ok(self.0.0.borrow_mut().link.status()?.focus_um)
    }
    fn move_to_um(&mut self, z_um: f64) -> Result<(), PlcError> {
        let mut i = self.0.0.borrow_mut();
        let z = i.link.map.length_counts(z_um);
        i.motion(Command::MoveFocus, z, 0).map(|_| ())
    }
}

impl<C: TriggeredCamera> PushRod for PlcRod<C> {
    type Error = PlcError;
    fn approach(&mut self, speed: ApproachSpeed) -> Result<(), PlcError> {
        self.0.0.borrow_mut().approach(speed)
    }
    fn push_um(&mut self, d_um: f64) -> Result<(), PlcError> {
        let mut i = self.0.0.borrow_mut();
        let d = i.link.map.length_counts(d_um.max(0.0));
        i.motion(Command::Push, d, 0).map(|_| ())
    }
    fn retract(&mut self) -> Result<(), PlcError> {
        self.0
            .0
            .borrow_mut()
            .motion(Command::Retract, 0, 0)
            .map(|_| ())
    }
}

impl<C: TriggeredCamera> Clock for PlcClock<C> {
    type Error = PlcError;
    fn now_s(&mut self) -> Result<f64, PlcError> {
        Ok(self.0.0.borrow_mut().link.status()?.time_s)
    }
    fn wait_s(&mut self, dt_s: f64) -> Result<(), PlcError> {
        let t0 = Instant::now();
        let dt = Duration::from_secs_f64(dt_s.clamp(0.0, 3600.0));
        while t0.elapsed() < dt {
            self.0.0.borrow_mut().link.heartbeat(false)?;
            std::thread::sleep((dt - t0.elapsed().min(dt)).min(Duration::from_millis(50)));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gonio_vision::{FrameHeader, FrameStamp};
    use std::sync::{Arc, Mutex};

    /// Three 96 × 48 frames of a dark ring around column 40, numbered 10, 11, 12.
    #[derive(Debug)]
    struct Ring(u64);

    #[derive(Debug, thiserror::Error)]
    #[error("never")]
    struct Never;

    impl DeviceError for Never {
        fn kind(&self) -> DeviceErrorKind {
            DeviceErrorKind::Other
        }
    }

    impl FrameSource for Ring {
        type Error = Never;
        fn next_frame(&mut self, px: &mut Vec<u8>) -> Result<Option<FrameHeader>, Never> {
            if self.0 == 3 {
                return Ok(None);
            }
            px.clear();
            for _ in 0..48 {
                px.extend((0..96usize).map(|x| if x.abs_diff(40) <= 5 { 60 } else { 200 }));
            }
            self.0 += 1;
            Ok(Some(FrameHeader {
                width: 96,
                height: 48,
                stamp: FrameStamp {
                    index: 9 + self.0,
                    ..FrameStamp::default()
                },
            }))
        }
    }

    #[test]
    fn a_tap_sees_every_frame_with_its_window_and_the_detectors_result() {
        let optics = Optics {
            window_width_px: 96,
            window_height_px: 48,
            ..Optics::default()
        };
        let seen = Arc::new(Mutex::new(Vec::new()));
        let s = seen.clone();
        let mut cam = DetectorTriggered::new(Ring(0), &optics)
            .unwrap()
            .with_tap(Box::new(move |f: &TappedFrame<'_>| {
                let c = f.result.c_px.filter(|_| f.result.valid);
                s.lock().unwrap().push((
                    f.frame_id,
                    f.width,
                    f.height,
                    f.pixels[40],
                    f.pixels.len(),
                    c,
                ));
            }));
        let mut frames = Vec::new();
        while let Some(f) = cam.next_frame(Duration::from_secs(1)).unwrap() {
            frames.push((f.frame_id, f.frame.c_px));
        }
        let seen = seen.lock().unwrap();
        assert_eq!(seen.len(), 3);
        for ((id, w, h, px, n, c), (fid, fc)) in seen.iter().zip(&frames) {
            assert_eq!((*id, *w, *h, *px, *n), (*fid, 96, 48, 60, 96 * 48));
            assert_eq!(c, fc);
        }
        assert_eq!(frames.iter().map(|f| f.0).collect::<Vec<_>>(), [10, 11, 12]);
        assert!(format!("{cam:?}").contains("tap: true"));
    }
}
