//! The simulated PLC's scan: motion profiles of the servo, focus drive and push rod on the wall
//! clock, the push rod's contact with the grating (the plant of `gonio_sim::station`), the
//! camera trigger with its latch ring, angle samples, the watchdog, faults and the part
//! handshake. The Modbus server ([`super::SimServer`]) reads and writes its registers.

use crate::link::{Command, FaultCode, bits};
use crate::map::{
    LATCH_ENTRY_REGS, RegisterMap, SAMPLE_ENTRY_REGS, STATUS_BLOCK_REGS, i32_words, u32_words,
    u64_words, words_i32,
};
use gonio_sim::station::{Exposure, PartTruth, PlantConfig, StationTruth};
use gonio_station::RingReading;
use gonio_vision::InvalidReason;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

/// Faults the simulated station injects, at PLC times (s since it started).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SimFaults {
    /// A drive faults at this time: `(code, t_s)` with code 2 (servo), 3 (rod) or 4 (focus).
    pub drive_fault: Option<(u16, f64)>,
    /// The emergency stop is pressed at this time.
    pub estop_at_s: Option<f64>,
    /// The PLC stops answering (requests are never replied to) from this time.
    pub silent_at_s: Option<f64>,
    /// The PLC's heartbeat stops (it still answers) from this time.
    pub heartbeat_stops_at_s: Option<f64>,
    /// The PLC resets: every connection is closed and the port stops listening.
    pub reset_at_s: Option<f64>,
    /// The camera stops sending frames from this time.
    pub camera_lost_at_s: Option<f64>,
    /// No angle is latched for triggers from this count on (one trigger, every 50th after).
    pub no_latch_from: Option<u64>,
}

/// The simulated station's settings.
#[derive(Debug, Clone, PartialEq)]
pub struct SimConfig {
    /// Seed: the station's constants and every part's mounting.
    pub seed: u64,
    /// The plant (the twin's).
    pub plant: PlantConfig,
    /// The register map served.
    pub map: RegisterMap,
    /// Pixel scale of the camera, µm/px.
    pub um_per_px: f64,
    /// Exposure, s.
    pub exposure_s: f64,
    /// Delay added to every reply, ms (the link's latency).
    pub latency_ms: f64,
    /// The true rod travel from home to a centred grating's edge, µm (the map's value ± the
    /// station's error).
    pub gap_centred_um: f64,
    /// Fast rod speed (to the standoff, and retract), µm/s.
    pub rod_fast_um_per_s: f64,
    /// Time to unload a part and load the next, s.
    pub unload_s: f64,
    /// The PLC's cycle: angle samples and heartbeat, s.
    pub cycle_s: f64,
    /// Faults to inject.
    pub faults: SimFaults,
}

impl SimConfig {
    /// The defaults for `seed`: the twin's plant, the default map.
    pub fn new(seed: u64) -> Self {
        SimConfig {
            seed,
            plant: PlantConfig::default(),
            map: RegisterMap::default(),
            um_per_px: 0.75,
            exposure_s: 0.5e-3,
            latency_ms: 0.5,
            gap_centred_um: 600.0 + 4.0 * (((seed % 7) as f64) / 3.0 - 1.0),
            rod_fast_um_per_s: 400.0,
            unload_s: 0.5,
            cycle_s: 2e-3,
            faults: SimFaults::default(),
        }
    }
}

/// One exposure the PLC triggered, for a rendering camera or the column-only stand-in: the
/// twin's exposure (start on the PLC's clock, s) with its trigger count.
#[derive(Debug, Clone, PartialEq)]
pub struct TriggeredExposure {
    /// The trigger count (the camera's frame id).
    pub frame_id: u64,
    /// What the camera sees.
    pub exposure: Exposure,
    /// What the detector reads in it at the twin's fast fidelity (the column from the geometry
    /// plus the detector's noise).
    pub fast: RingReading,
}

/// One part's truth, as TRUTH.json lists it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TruthPart {
    /// 1-based part number (the PLC's part register).
    pub part: u32,
    /// True eccentricity when loaded, µm.
    pub true_initial_e_um: f64,
    /// True eccentricity when unloaded (or now, for the part on the shaft), µm.
    pub true_final_e_um: f64,
}

#[derive(Debug, Clone, Copy)]
enum Servo {
    Hold {
        th: f64,
    },
    Move {
        t0: f64,
        th0: f64,
        th1: f64,
        dur: f64,
    },
    Turn {
        t0: f64,
        th0: f64,
        v: f64,
        ramp: f64,
    },
    Stop {
        t0: f64,
        th0: f64,
        v: f64,
        ramp: f64,
    },
    /// A move commanded while turning: the stop's ramp, then the positioning move from where it
    /// came to rest.
    BrakeMove {
        t0: f64,
        th0: f64,
        v: f64,
        ramp: f64,
        th1: f64,
        dur: f64,
    },
}

impl Servo {
    /// A `BrakeMove`'s two parts: the stop, and the move that starts when it ends.
    fn brake_parts(t0: f64, th0: f64, v: f64, ramp: f64, th1: f64, dur: f64) -> (Servo, Servo) {
        let stop = Servo::Stop { t0, th0, v, ramp };
        let rest = th0 + 0.5 * v * ramp;
        let mv = Servo::Move {
            t0: t0 + ramp,
            th0: rest,
            th1,
            dur,
        };
        (stop, mv)
    }

    fn angle(&self, t: f64) -> f64 {
        match *self {
            Servo::BrakeMove {
                t0,
                th0,
                v,
                ramp,
                th1,
                dur,
            } => {
                let (stop, mv) = Servo::brake_parts(t0, th0, v, ramp, th1, dur);
                if t < t0 + ramp {
                    stop.angle(t)
                } else {
                    mv.angle(t)
                }
            }
            Servo::Hold { th } => th,
            Servo::Move { t0, th0, th1, dur } => {
                let u = ((t - t0) / dur).clamp(0.0, 1.0);
                th0 + (th1 - th0) * 0.5 * (1.0 - (std::f64::consts::PI * u).cos())
            }
            Servo::Turn { t0, th0, v, ramp } => {
                let dt = (t - t0).max(0.0);
                if dt < ramp {
                    th0 + 0.5 * v / ramp * dt * dt
                } else {
                    th0 + 0.5 * v * ramp + v * (dt - ramp)
                }
            }
            Servo::Stop { t0, th0, v, ramp } => {
                let d = (t - t0).clamp(0.0, ramp);
                th0 + v * d - 0.5 * v / ramp.max(1e-12) * d * d
            }
        }
    }
    fn speed(&self, t: f64) -> f64 {
        match *self {
            Servo::BrakeMove {
                t0,
                th0,
                v,
                ramp,
                th1,
                dur,
            } => {
                let (stop, mv) = Servo::brake_parts(t0, th0, v, ramp, th1, dur);
                if t < t0 + ramp {
                    stop.speed(t)
                } else {
                    mv.speed(t)
                }
            }
            Servo::Hold { .. } => 0.0,
            Servo::Move { t0, th0, th1, dur } => {
                let u = ((t - t0) / dur).clamp(0.0, 1.0);
                (th1 - th0) * 0.5 * std::f64::consts::PI / dur * (std::f64::consts::PI * u).sin()
            }
            Servo::Turn { t0, v, ramp, .. } => v * ((t - t0) / ramp.max(1e-12)).clamp(0.0, 1.0),
            Servo::Stop { t0, v, ramp, .. } => {
                (v * (1.0 - (t - t0) / ramp.max(1e-12))).clamp(v.min(0.0), v.max(0.0))
            }
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Rod {
    Idle,
    /// Fast to `standoff`, then creep at `creep` until stopped or the travel limit.
    Approach {
        standoff: f64,
        creep: f64,
    },
    /// Linear from `x0` to `x1` over `t0..t0+dur`.
    Move {
        t0: f64,
        x0: f64,
        x1: f64,
        dur: f64,
    },
}

#[derive(Debug, Clone)]
struct Engaged {
    x_c: f64,
    gain: f64,
    dir_deg: f64,
    moved_um: f64,
    pushes: u32,
}

#[derive(Debug, Clone, Copy)]
struct Running {
    cmd: Command,
    seq: u16,
    done_at: Option<f64>,
}

/// The simulated PLC.
pub struct Plc {
    cfg: SimConfig,
    station: StationTruth,
    rng: ChaCha8Rng,
    /// PLC time of the last scan, s.
    t: f64,
    holding: Vec<u16>,
    last_seq: u16,
    running: Option<Running>,
    ack: u16,
    done: bool,
    fault: FaultCode,
    estop: bool,
    watchdog: bool,
    hb: u16,
    hb_next: f64,
    gonio_beat: Option<(u16, f64)>,
    servo: Servo,
    focus: (f64, f64, f64, f64),
    rod_x: f64,
    rod: Rod,
    engaged: Option<Engaged>,
    part: PartTruth,
    part_no: u32,
    present: bool,
    load_at: Option<f64>,
    truth: Vec<TruthPart>,
    fps: f64,
    trig_next: f64,
    trig_count: u64,
    latch: Vec<u16>,
    samples: Vec<u16>,
    sample_count: u64,
    sample_next: f64,
    exposures: Vec<TriggeredExposure>,
}

impl std::fmt::Debug for Plc {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Plc")
            .field("t", &self.t)
            .field("part_no", &self.part_no)
            .finish_non_exhaustive()
    }
}

impl Plc {
    /// A PLC at time 0 with part 1 loaded.
    pub fn new(cfg: SimConfig) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
        let station = StationTruth::draw(&cfg.plant, &mut rng);
        let latch_len = cfg.map.input.latch_ring_len as usize * LATCH_ENTRY_REGS as usize;
        let sample_len = cfg.map.input.sample_ring_len as usize * SAMPLE_ENTRY_REGS as usize;
        let part = PartTruth::draw(&cfg.plant, cfg.seed, 1);
        let th = part.start_angle_deg;
        let mut plc = Plc {
            station,
            rng,
            t: 0.0,
            holding: vec![0; 65_536],
            last_seq: 0,
            running: None,
            ack: 0,
            done: true,
            fault: FaultCode::None,
            estop: false,
            watchdog: false,
            hb: 0,
            hb_next: 0.0,
            gonio_beat: None,
            servo: Servo::Hold { th },
            focus: (0.0, 0.0, 0.0, 0.0),
            rod_x: 0.0,
            rod: Rod::Idle,
            engaged: None,
            part: part.clone(),
            part_no: 0,
            present: false,
            load_at: Some(0.0),
            truth: Vec::new(),
            fps: 0.0,
            trig_next: 0.0,
            trig_count: 0,
            latch: vec![0; latch_len],
            samples: vec![0; sample_len],
            sample_count: 0,
            sample_next: 0.0,
            exposures: Vec::new(),
            cfg,
        };
        plc.load_next(0.0);
        plc
    }

    /// The station's true constants.
    pub fn station_truth(&self) -> StationTruth {
        self.station
    }

    /// The parts so far with their truth (the one on the shaft with its eccentricity now).
    pub fn truth(&self) -> Vec<TruthPart> {
        let mut v = self.truth.clone();
        if self.present {
            v.push(TruthPart {
                part: self.part_no,
                true_initial_e_um: self.part_initial_e(),
                true_final_e_um: self.part.e_um(),
            });
        }
        v
    }

    fn part_initial_e(&self) -> f64 {
        PartTruth::draw(&self.cfg.plant, self.cfg.seed, self.part_no as u64).e_um()
    }

    /// Exposures triggered since the last call.
    pub fn take_exposures(&mut self) -> Vec<TriggeredExposure> {
        std::mem::take(&mut self.exposures)
    }

    /// The PLC time of the last scan, s.
    pub fn time_s(&self) -> f64 {
        self.t
    }

    fn load_next(&mut self, t: f64) {
        self.part_no += 1;
        self.part = PartTruth::draw(&self.cfg.plant, self.cfg.seed, self.part_no as u64);
        self.rng = ChaCha8Rng::seed_from_u64(self.part.noise_seed);
        let th = self.servo.angle(t);
        // The new part sits at its own random angle relative to the servo's zero.
        self.servo = Servo::Hold { th };
        self.engaged = None;
        self.present = true;
        self.load_at = None;
    }

    fn apply_move(&mut self, dir_deg: f64, m_um: f64) {
        let t = dir_deg.to_radians();
        self.part.offset_um[0] -= m_um * t.cos();
        self.part.offset_um[1] -= m_um * t.sin();
    }

    fn faulted(&self) -> bool {
        self.fault != FaultCode::None || self.estop || self.watchdog
    }

    /// Stops every motion where it is (a fault or e-stop).
    fn halt(&mut self, t: f64) {
        let th = self.servo.angle(t);
        self.servo = Servo::Hold { th };
        self.rod = Rod::Idle;
        if let Some(r) = self.running.take() {
            self.ack = r.seq;
        }
        self.done = false;
    }

    fn set_fault(&mut self, code: FaultCode, t: f64) {
        if self.fault == FaultCode::None {
            self.fault = code;
        }
        self.halt(t);
    }

    /// Runs the scan up to PLC time `now`, in steps of at most 1 ms.
    pub fn advance(&mut self, now: f64) {
        while self.t < now {
            let t = (self.t + 1e-3).min(now);
            self.step(t);
            self.t = t;
        }
    }

    fn step(&mut self, t: f64) {
        let f = self.cfg.faults.clone();
        if f.estop_at_s.is_some_and(|x| t >= x) && !self.estop {
            self.estop = true;
            self.set_fault(FaultCode::EStop, t);
        }
        if let Some((code, at)) = f.drive_fault
            && t >= at
            && self.fault == FaultCode::None
            && !self.estop
        {
            self.set_fault(FaultCode::from_u16(code), t);
        }
        // Heartbeat and the watchdog on gonio's.
        if t >= self.hb_next {
            if !f.heartbeat_stops_at_s.is_some_and(|x| t >= x) {
                self.hb = self.hb.wrapping_add(1);
            }
            self.hb_next = t + self.cfg.cycle_s * 5.0;
        }
        let hb = self.holding[self.cfg.map.holding.heartbeat as usize];
        match self.gonio_beat {
            Some((b, _)) if b != hb => self.gonio_beat = Some((hb, t)),
            Some((_, since))
                if !self.watchdog && t - since > self.cfg.map.timing.watchdog_ms as f64 * 1e-3 =>
            {
                // The PLC's own safe reaction: servo stopped, rod home, trigger off.
                self.watchdog = true;
                self.set_fault(FaultCode::Watchdog, t);
                let dur = self.rod_x / self.cfg.rod_fast_um_per_s;
                self.rod = Rod::Move {
                    t0: t,
                    x0: self.rod_x,
                    x1: 0.0,
                    dur: dur.max(1e-3),
                };
                self.fps = 0.0;
            }
            _ => {}
        }
        // Part handshake.
        if let Some(at) = self.load_at
            && t >= at
        {
            self.load_next(t);
        }
        self.step_rod(t);
        // Command completion.
        if let Some(r) = self.running
            && let Some(at) = r.done_at
            && t >= at
        {
            if r.cmd == Command::Push
                && let Some(e) = self.engaged.as_mut()
            {
                e.pushes += 1;
                if e.pushes == 1 {
                    let p = &self.cfg.plant;
                    let slip = p.slip_max_um * self.rng.random::<f64>()
                        - Normal::new(0.0, p.contact_error_sd_um)
                            .map(|n| n.sample(&mut self.rng))
                            .unwrap_or(0.0);
                    let m = slip.max(-e.moved_um);
                    let dir = e.dir_deg;
                    e.moved_um += m;
                    self.apply_move(dir, m);
                }
            }
            if r.cmd == Command::PartDone {
                if self.present {
                    self.finish_command(r.seq);
                }
            } else {
                self.finish_command(r.seq);
            }
        }
        // Angle samples every cycle.
        if t >= self.sample_next {
            self.sample_next = t + self.cfg.cycle_s;
            let len = self.cfg.map.input.sample_ring_len as u64;
            let slot = (self.sample_count % len) as usize * SAMPLE_ENTRY_REGS as usize;
            let th = self.cfg.map.angle_counts(self.servo.angle(t));
            let tw = u64_words((t * 1e6).round() as u64);
            self.samples[slot..slot + 4].copy_from_slice(&tw);
            self.samples[slot + 4..slot + 6].copy_from_slice(&i32_words(th));
            self.sample_count += 1;
        }
        // Camera trigger.
        while self.fps > 0.0 && t >= self.trig_next {
            let start = self.trig_next;
            self.trig_next += 1.0 / self.fps;
            self.trigger(start);
        }
    }

    fn finish_command(&mut self, seq: u16) {
        self.running = None;
        self.ack = seq;
        self.done = true;
    }

    fn step_rod(&mut self, t: f64) {
        let dt = (t - self.t).max(0.0);
        match self.rod {
            Rod::Idle => {}
            Rod::Approach { standoff, creep } => {
                if self.rod_x < standoff {
                    self.rod_x = (self.rod_x + self.cfg.rod_fast_um_per_s * dt).min(standoff);
                } else {
                    self.rod_x += creep * dt;
                }
                if self.rod_x >= self.cfg.map.rod.travel_limit_um {
                    self.set_fault(FaultCode::TravelLimit, t);
                }
            }
            Rod::Move { t0, x0, x1, dur } => {
                let u = ((t - t0) / dur).clamp(0.0, 1.0);
                self.rod_x = x0 + (x1 - x0) * u;
                if u >= 1.0 {
                    self.rod = Rod::Idle;
                }
            }
        }
        let th = self.servo.angle(t);
        match self.engaged.clone() {
            None => {
                let u = th.to_radians();
                let gap = self.cfg.gap_centred_um
                    - (self.part.offset_um[0] * u.cos() + self.part.offset_um[1] * u.sin());
                if self.rod_x >= gap && self.present {
                    let p = self.cfg.plant.clone();
                    let dir = th
                        + self.station.offset_deg
                        + Normal::new(0.0, p.push_angle_sd_deg)
                            .map(|n| n.sample(&mut self.rng))
                            .unwrap_or(0.0);
                    let gain = Normal::new(self.station.gain, p.gain_sd)
                        .map(|n| n.sample(&mut self.rng))
                        .unwrap_or(self.station.gain);
                    self.engaged = Some(Engaged {
                        x_c: gap,
                        gain,
                        dir_deg: dir,
                        moved_um: 0.0,
                        pushes: 0,
                    });
                }
            }
            Some(mut e) => {
                if self.rod_x < e.x_c {
                    // Off the edge: the grating springs back a little.
                    let sb = self.cfg.plant.spring_back_max * self.rng.random::<f64>();
                    self.apply_move(e.dir_deg, -sb * e.moved_um);
                    self.engaged = None;
                } else {
                    let want = e.gain * (self.rod_x - e.x_c);
                    if want > e.moved_um {
                        let m = want - e.moved_um;
                        e.moved_um = want;
                        self.apply_move(e.dir_deg, m);
                    }
                    self.engaged = Some(e);
                }
            }
        }
    }

    fn trigger(&mut self, start: f64) {
        self.trig_count += 1;
        let k = self.trig_count;
        let mid = start + 0.5 * self.cfg.exposure_s;
        let th = self.servo.angle(mid);
        let skip = self
            .cfg
            .faults
            .no_latch_from
            .is_some_and(|n| k >= n && (k - n).is_multiple_of(50));
        if !skip {
            let len = self.cfg.map.input.latch_ring_len as u64;
            let slot = ((k - 1) % len) as usize * LATCH_ENTRY_REGS as usize;
            self.latch[slot..slot + 2].copy_from_slice(&u32_words(k as u32));
            self.latch[slot + 2..slot + 6].copy_from_slice(&u64_words((mid * 1e6).round() as u64));
            self.latch[slot + 6..slot + 8]
                .copy_from_slice(&i32_words(self.cfg.map.angle_counts(th)));
        }
        if self.cfg.faults.camera_lost_at_s.is_some_and(|x| start >= x) {
            return;
        }
        let (z0, z1, t0, dur) = self.focus;
        let z = z0 + (z1 - z0) * ((start - t0) / dur.max(1e-9)).clamp(0.0, 1.0);
        let dz = z - self.part.best_focus_um;
        let p = &self.cfg.plant;
        let w = dz / p.focus_depth_um;
        let present = self.present;
        let c_true = self.part.column_px(p, self.cfg.um_per_px, th);
        let n01 = Normal::new(0.0, 1.0).expect("unit normal");
        let focus_measure = (0.05 * p.focus_peak + p.focus_peak * (-0.5 * w * w).exp())
            * (1.0 + 0.01 * n01.sample(&mut self.rng));
        let noise = p.noise_px * (1.0 + w * w).sqrt() * n01.sample(&mut self.rng);
        let reason = if !present {
            Some(InvalidReason::NoRing)
        } else if w.abs() > 3.0 {
            Some(InvalidReason::OutOfFocus)
        } else if !(0.0..p.window_width_px).contains(&c_true) {
            Some(InvalidReason::RingOutsideWindow)
        } else {
            None
        };
        let seed = self.rng.random::<u64>();
        self.exposures.push(TriggeredExposure {
            frame_id: k,
            exposure: Exposure {
                start_s: start,
                exposure_s: self.cfg.exposure_s,
                theta_deg: th,
                offset_um: self.part.offset_um,
                dz_um: dz,
                seed,
                ring_lost: false,
            },
            fast: RingReading {
                c_px: reason.is_none().then_some(c_true + noise),
                invalid_reason: reason,
                focus_measure,
            },
        });
        if self.exposures.len() > 1000 {
            self.exposures.drain(..500);
        }
    }

    /// Reads input registers `addr..addr+n` (`None`: outside every block).
    pub fn read_input(&self, addr: u16, n: u16) -> Option<Vec<u16>> {
        let m = &self.cfg.map.input;
        let (a, n) = (addr as usize, n as usize);
        let within = |base: u16, len: usize| a >= base as usize && a + n <= base as usize + len;
        if within(m.status, STATUS_BLOCK_REGS as usize) {
            let s = self.status_block();
            let o = a - m.status as usize;
            return Some(s[o..o + n].to_vec());
        }
        if within(m.latch_ring, self.latch.len()) {
            let o = a - m.latch_ring as usize;
            return Some(self.latch[o..o + n].to_vec());
        }
        if within(m.sample_ring, self.samples.len()) {
            let o = a - m.sample_ring as usize;
            return Some(self.samples[o..o + n].to_vec());
        }
        None
    }

    fn status_block(&self) -> Vec<u16> {
        let t = self.t;
        let m = &self.cfg.map;
        let mut w = vec![0u16; STATUS_BLOCK_REGS as usize];
        let mut word = 0;
        if self.running.is_some() {
            word |= bits::BUSY;
        }
        if self.done && self.running.is_none() {
            word |= bits::DONE;
        }
        if self.faulted() {
            word |= bits::FAULT;
        }
        if self.estop {
            word |= bits::ESTOP;
        }
        if self.watchdog {
            word |= bits::WATCHDOG;
        }
        if self.present {
            word |= bits::PART_PRESENT;
        }
        if self.fps > 0.0 {
            word |= bits::TRIGGERING;
        }
        // This PLC is the twin: it says so, rather than leaving a client to guess from names.
        word |= bits::SIMULATED;
        w[0] = word;
        w[1] = self.ack;
        w[2] = self.fault.to_u16();
        w[3] = self.hb;
        w[4..8].copy_from_slice(&u64_words((t * 1e6).round() as u64));
        w[8..10].copy_from_slice(&i32_words(m.angle_counts(self.servo.angle(t))));
        let (z0, z1, t0, dur) = self.focus;
        let z = z0 + (z1 - z0) * ((t - t0) / dur.max(1e-9)).clamp(0.0, 1.0);
        w[10..12].copy_from_slice(&i32_words(m.length_counts(z)));
        w[12..14].copy_from_slice(&i32_words(m.length_counts(self.rod_x)));
        w[14..16].copy_from_slice(&u32_words(self.trig_count as u32));
        w[16..18].copy_from_slice(&u32_words(if self.present { self.part_no } else { 0 }));
        w[18..20].copy_from_slice(&u32_words(self.sample_count as u32));
        w[20..22].copy_from_slice(&i32_words(m.speed_counts(self.servo.speed(t))));
        w
    }

    /// Reads holding registers.
    pub fn read_holding(&self, addr: u16, n: u16) -> Option<Vec<u16>> {
        let (a, n) = (addr as usize, n as usize);
        (a + n <= self.holding.len()).then(|| self.holding[a..a + n].to_vec())
    }

    /// Writes holding registers and acts on a new sequence number.
    pub fn write_holding(&mut self, addr: u16, words: &[u16]) -> bool {
        let a = addr as usize;
        if a + words.len() > self.holding.len() {
            return false;
        }
        self.holding[a..a + words.len()].copy_from_slice(words);
        let h = self.cfg.map.holding.clone();
        let hb = self.holding[h.heartbeat as usize];
        if self.gonio_beat.is_none() && (a..a + words.len()).contains(&(h.heartbeat as usize)) {
            self.gonio_beat = Some((hb, self.t));
        }
        let seq = self.holding[h.sequence as usize];
        if (a..a + words.len()).contains(&(h.sequence as usize)) && seq != self.last_seq {
            self.last_seq = seq;
            let cmd = self.holding[h.command as usize];
            let arg0 = words_i32(&self.holding[h.arg0 as usize..h.arg0 as usize + 2]);
            let arg1 = words_i32(&self.holding[h.arg1 as usize..h.arg1 as usize + 2]);
            self.start(cmd, seq, arg0, arg1);
        }
        true
    }

    fn start(&mut self, cmd: u16, seq: u16, arg0: i32, arg1: i32) {
        let t = self.t;
        let m = self.cfg.map.clone();
        let tm = self.cfg.plant.timing.clone();
        let Some(cmd) = Command::from_u16(cmd) else {
            self.set_fault(FaultCode::BadCommand, t);
            self.ack = seq;
            return;
        };
        self.ack = seq;
        self.done = false;
        let run = |done_at: Option<f64>| Running { cmd, seq, done_at };
        match cmd {
            Command::ResetFault => {
                if !self.estop {
                    self.fault = FaultCode::None;
                    self.watchdog = false;
                    self.gonio_beat = None;
                }
                self.running = Some(run(Some(t)));
                return;
            }
            Command::Trigger => {
                self.fps = arg0.max(0) as f64 / 1000.0;
                self.trig_count = 0;
                self.trig_next = t;
                self.running = Some(run(Some(t)));
                return;
            }
            _ => {}
        }
        if self.faulted() {
            // Refused: the fault stays; gonio sees it.
            self.running = None;
            return;
        }
        match cmd {
            Command::None => self.running = Some(run(Some(t))),
            Command::MoveServo => {
                let (th0, v) = (self.servo.angle(t), self.servo.speed(t));
                let th1 = m.angle_deg(arg0);
                if v == 0.0 {
                    self.servo = Servo::Move {
                        t0: t,
                        th0,
                        th1,
                        dur: tm.align_s,
                    };
                    self.running = Some(run(Some(t + tm.align_s)));
                } else {
                    // Commanded while turning: the servo brakes into the move.
                    let ramp = tm.ramp_at(v);
                    self.servo = Servo::BrakeMove {
                        t0: t,
                        th0,
                        v,
                        ramp,
                        th1,
                        dur: tm.align_s,
                    };
                    self.running = Some(run(Some(t + ramp + tm.align_s)));
                }
            }
            Command::Turn => {
                let th0 = self.servo.angle(t);
                let v = m.speed_deg_per_s(arg0);
                self.servo = Servo::Turn {
                    t0: t,
                    th0,
                    v,
                    ramp: tm.ramp_at(v),
                };
                self.running = Some(run(Some(t + tm.spin_up_at(v))));
            }
            Command::StopServo => {
                let (th0, v) = (self.servo.angle(t), self.servo.speed(t));
                self.servo = Servo::Stop {
                    t0: t,
                    th0,
                    v,
                    ramp: tm.ramp_at(v),
                };
                self.running = Some(run(Some(t + tm.stop_at(v))));
            }
            Command::MoveFocus => {
                let (z0, z1, t0, dur) = self.focus;
                let z = z0 + (z1 - z0) * ((t - t0) / dur.max(1e-9)).clamp(0.0, 1.0);
                self.focus = (z, m.length_um(arg0), t, tm.focus_move_s);
                self.running = Some(run(Some(t + tm.focus_move_s)));
            }
            Command::Approach => {
                self.rod = Rod::Approach {
                    standoff: m.length_um(arg1).max(0.0),
                    creep: m.length_um(arg0).max(0.0),
                };
                self.running = Some(run(None));
            }
            Command::StopRod => {
                self.rod = Rod::Idle;
                self.running = Some(run(Some(t + 0.02)));
            }
            Command::Push => {
                let first = self.engaged.as_ref().is_none_or(|e| e.pushes == 0);
                let dur = if first { tm.push_s } else { tm.push_step_s };
                self.rod = Rod::Move {
                    t0: t,
                    x0: self.rod_x,
                    x1: self.rod_x + m.length_um(arg0).max(0.0),
                    dur,
                };
                self.running = Some(run(Some(t + dur)));
            }
            Command::Retract => {
                self.rod = Rod::Move {
                    t0: t,
                    x0: self.rod_x,
                    x1: 0.0,
                    dur: tm.retract_s,
                };
                self.running = Some(run(Some(t + tm.retract_s)));
            }
            Command::PartDone => {
                if self.present {
                    self.truth.push(TruthPart {
                        part: self.part_no,
                        true_initial_e_um: self.part_initial_e(),
                        true_final_e_um: self.part.e_um(),
                    });
                    self.present = false;
                    self.load_at = Some(t + self.cfg.unload_s);
                }
                self.running = Some(run(Some(t)));
            }
            Command::ResetFault | Command::Trigger => {}
        }
    }
}
