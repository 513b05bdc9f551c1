//! The station over the wire: one [`PlcStation`] (the Modbus link, the triggered camera and the
//! angle pairing) whose device handles ([`crate::devices`]) implement `gonio_station::hal`, so
//! the controller mounts through a PLC exactly as it does on its twin.
//!
//! - Every frame the camera gives ([`crate::triggered`]) is paired with the servo angle the PLC
//!   latched at its trigger (or interpolated in its angle samples, [`crate::pairing`]); a frame
//!   triggered before the last motion finished is skipped as stale; the servo's angle log is the
//!   latched (mid-exposure time, angle) of every frame delivered.
//! - Contact is seen in the ring's column ([`crate::contact`]) while the rod creeps.
//! - Every time the controller sees is PLC time, s; angles in degrees, lengths in µm.
//!
//! Errors: [`PlcError`].

use crate::contact::{ContactDetector, Verdict};
use crate::link::{Command, Link, PlcError, Status, bits};
use crate::map::{LATCH_ENTRY_REGS, Pairing, SAMPLE_ENTRY_REGS, words_i32, words_u32, words_u64};
use crate::pairing::{AnglePairing, Interpolated, LatchedRing};
use crate::triggered::TriggeredCamera;
use gonio_station::hal::{ApproachSpeed, CameraFrame, DeviceError, DeviceErrorKind};
use gonio_station::interval::AngleSample;
use gonio_station::tap::FrameTap;
use serde::Serialize;
use std::cell::RefCell;
use std::rc::Rc;
use std::time::{Duration, Instant};

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

/// The station's state behind its handles: the link, the camera, the angle pairing.
pub(crate) struct Inner<C> {
    pub(crate) link: Link,
    pub(crate) camera: C,
    pub(crate) latched: LatchedRing,
    pub(crate) samples: Interpolated,
    pub(crate) sample_read: u64,
    pub(crate) log: Vec<AngleSample>,
    pub(crate) fresh_after_s: f64,
    pub(crate) opts: StationOptions,
    pub(crate) counts: PairingCounts,
    /// Told every frame delivered to the controller.
    pub(crate) tap: Option<FrameTap<'static>>,
    /// The PLC said it is a simulation ([`bits::SIMULATED`]).
    pub(crate) simulated: bool,
}

/// The station behind the PLC; clone the device handles out with [`PlcStation::devices`].
pub struct PlcStation<C>(pub(crate) Rc<RefCell<Inner<C>>>);

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

/// The link's figures over a batch.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LinkFigures {
    /// Modbus requests timed.
    pub requests: usize,
    /// Median round trip, ms (`null`: no request timed).
    pub round_trip_p50_ms: Option<f64>,
    /// 99th percentile round trip, ms (`null`: no request timed).
    pub round_trip_p99_ms: Option<f64>,
    /// Frames paired with a latched angle.
    pub frames_paired: u64,
    /// Frames skipped (triggered before the last motion finished).
    pub frames_stale: u64,
}

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
            tap: None,
            simulated: s.has(bits::SIMULATED),
        }))))
    }

    /// Shows every frame delivered to the controller from now on (paired with its angle, in
    /// the order the controller gets them) to `tap`, with its pixels as the camera's detector
    /// saw them: a recorder, the live thumbnail. A camera that keeps no pixels
    /// ([`TriggeredCamera::seen`]) shows nothing.
    pub fn set_tap(&self, tap: FrameTap<'static>) {
        self.0.borrow_mut().tap = Some(tap);
    }

    /// Whether the PLC said, when the station was opened, that it is a simulation (the status
    /// word's [`bits::SIMULATED`]): its parts are then the digital twin's.
    pub fn simulated(&self) -> bool {
        self.0.borrow().simulated
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
    /// Link failures, faults, [`PlcError::CommandTimeout`] when no part came,
    /// [`PlcError::Interrupted`].
    pub fn wait_part(&self, timeout: Duration) -> Result<u32, PlcError> {
        let t0 = Instant::now();
        let mut i = self.0.borrow_mut();
        loop {
            let s = i.link.status()?;
            i.link.check(&s, "waiting for a part")?;
            if s.has(bits::PART_PRESENT) && s.part > 0 {
                return Ok(s.part);
            }
            i.link.check_interrupt()?;
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

    /// Leaves the station safe: rod home, servo stopped, trigger off, each unless the
    /// controller did it already after the abort, all within the map's `timing.safe_state_ms`
    /// ([`Link::safe_state`](crate::Link::safe_state)). Best effort: the link takes no motion
    /// command after it.
    ///
    /// # Errors
    /// The first safe-state command that failed (all were tried).
    pub fn safe_stop(&self) -> Result<(), PlcError> {
        self.0.borrow_mut().link.safe_state()
    }

    /// Ends every wait of the station when `interrupt` is raised: the part in progress ends
    /// `interrupted` (the device's error is [`PlcError::Interrupted`]) and the station goes to
    /// its safe state.
    pub fn set_interrupt(&self, interrupt: crate::Interrupt) {
        self.0.borrow_mut().link.set_interrupt(interrupt);
    }

    /// Aborts the sequence to the safe state ([`Link::abort`](crate::Link::abort)): after a
    /// device error, only safe-state commands go out, within one deadline.
    pub fn abort(&self) {
        self.0.borrow_mut().link.abort();
    }

    /// The link's round-trip times, p50 and p99, ms, and the requests timed.
    pub fn round_trip_ms(&self) -> (Option<f64>, Option<f64>, usize) {
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
    pub fn link_figures(&self) -> LinkFigures {
        let (p50, p99, n) = self.round_trip_ms();
        let counts = self.pairing_counts();
        LinkFigures {
            requests: n,
            round_trip_p50_ms: p50,
            round_trip_p99_ms: p99,
            frames_paired: counts.paired,
            frames_stale: counts.stale,
        }
    }
}

impl<C: TriggeredCamera> Inner<C> {
    pub(crate) fn motion(
        &mut self,
        cmd: Command,
        arg0: i32,
        arg1: i32,
    ) -> Result<Status, PlcError> {
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
    pub(crate) fn capture(&mut self) -> Result<CameraFrame, PlcError> {
        let timeout = Duration::from_millis(self.link.map.timing.frame_timeout_ms);
        let half = 0.5 * self.opts.exposure_s;
        let pairing = self.link.map.pairing;
        let t0 = Instant::now();
        loop {
            self.link.check_interrupt()?;
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
                self.camera.restart_tracking();
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
            // The frame's mid-exposure time and angle; `None`: triggered before the last
            // motion's end, found out by its latch being overwritten.
            let paired = loop {
                let r = match pairing {
                    Pairing::Latched => self.latched.lookup(f.frame_id, mid),
                    Pairing::Interpolated => self.samples.lookup(f.frame_id, mid),
                };
                match r {
                    Ok(Some(v)) => break Some(v),
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
                        break None;
                    }
                }
            };
            let Some((t_mid, theta)) = paired.filter(|&(t, _)| t > self.fresh_after_s) else {
                self.counts.stale += 1;
                self.camera.restart_tracking();
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
            };
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
            if let (Some(tap), Some(seen)) = (self.tap.as_mut(), self.camera.seen()) {
                tap(&seen);
            }
            return Ok(f.reading.at(t_mid - half, self.opts.exposure_s));
        }
    }

    pub(crate) fn approach(&mut self, speed: ApproachSpeed) -> Result<(), PlcError> {
        let rod = self.link.map.rod.clone();
        let mut det = ContactDetector::new(
            rod.baseline_frames,
            rod.contact_sigmas,
            rod.contact_min_px,
            rod.contact_frames,
        );
        // The baseline before the rod moves: where the edge is, and the column's noise.
        while det.update(self.capture()?.c_px) == Verdict::Learning {}
        let Some(baseline_px) = det.baseline_px() else {
            return Err(PlcError::NoContact {
                message: "no baseline of the ring's column before the approach".into(),
            });
        };
        let edge_um = (baseline_px - rod.centre_column_px) * self.opts.um_per_px;
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
