//! The Modbus TCP link to the PLC: blocking reads and writes with a reply timeout, the command
//! handshake (arguments, command word and sequence counter in one write; the PLC acknowledges
//! the sequence and reports busy → done, or a fault), gonio's heartbeat and a watchdog on the
//! PLC's, and the round-trip times of every request.
//!
//! A link that failed once (refused, reset, a reply timed out, the PLC's heartbeat stopped) is
//! down for good: every later call fails at once with [`PlcError::LinkDown`], so a dead PLC
//! costs one timeout, not one per call.
//!
//! Errors: [`PlcError`]; its [`DeviceError::kind`] says timeout, communication or fault.
//!
//! ```no_run
//! use gonio_plc::link::{Command, Link};
//! use gonio_plc::map::RegisterMap;
//! let mut link = Link::connect("127.0.0.1:1502", RegisterMap::default()).unwrap();
//! link.command(Command::ResetFault, 0, 0).unwrap();
//! let status = link.status().unwrap();
//! println!("PLC time {} s", status.time_s);
//! ```

use crate::map::{RegisterMap, STATUS_BLOCK_REGS, i32_words, words_i32, words_u32, words_u64};
use gonio_station::hal::{DeviceError, DeviceErrorKind};
use std::net::{SocketAddr, ToSocketAddrs};
use std::time::{Duration, Instant};
use thiserror::Error;
use tokio_modbus::client::sync::{self, Reader, Writer};
use tokio_modbus::prelude::SlaveContext;

/// Status word bits.
pub mod bits {
    /// A command is running.
    pub const BUSY: u16 = 1 << 0;
    /// The acknowledged command has finished.
    pub const DONE: u16 = 1 << 1;
    /// A fault is latched (see the fault code); cleared by [`super::Command::ResetFault`].
    pub const FAULT: u16 = 1 << 2;
    /// The emergency stop is pressed.
    pub const ESTOP: u16 = 1 << 3;
    /// The watchdog on gonio's heartbeat expired (also a fault).
    pub const WATCHDOG: u16 = 1 << 4;
    /// A part is on the shaft, ready to mount.
    pub const PART_PRESENT: u16 = 1 << 5;
    /// The camera trigger is running.
    pub const TRIGGERING: u16 = 1 << 6;
}

/// The PLC's fault codes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum FaultCode {
    /// No fault.
    None,
    /// gonio's heartbeat stopped (watchdog).
    Watchdog,
    /// The servo drive faulted.
    ServoDrive,
    /// The push-rod drive faulted.
    RodDrive,
    /// The focus drive faulted.
    FocusDrive,
    /// The rod reached its travel limit without contact.
    TravelLimit,
    /// Emergency stop.
    EStop,
    /// A command word the PLC does not know, or a bad argument.
    BadCommand,
    /// A motion was asked with no part on the shaft.
    NoPart,
    /// Another code.
    Other(u16),
}

impl FaultCode {
    /// From the wire.
    pub fn from_u16(c: u16) -> Self {
        match c {
            0 => FaultCode::None,
            1 => FaultCode::Watchdog,
            2 => FaultCode::ServoDrive,
            3 => FaultCode::RodDrive,
            4 => FaultCode::FocusDrive,
            5 => FaultCode::TravelLimit,
            6 => FaultCode::EStop,
            7 => FaultCode::BadCommand,
            8 => FaultCode::NoPart,
            x => FaultCode::Other(x),
        }
    }

    /// To the wire.
    pub fn to_u16(self) -> u16 {
        match self {
            FaultCode::None => 0,
            FaultCode::Watchdog => 1,
            FaultCode::ServoDrive => 2,
            FaultCode::RodDrive => 3,
            FaultCode::FocusDrive => 4,
            FaultCode::TravelLimit => 5,
            FaultCode::EStop => 6,
            FaultCode::BadCommand => 7,
            FaultCode::NoPart => 8,
            FaultCode::Other(x) => x,
        }
    }

    /// What it means, for a message.
    pub fn describe(self) -> String {
        match self {
            FaultCode::None => "no fault".into(),
            FaultCode::Watchdog => "watchdog expired (gonio's heartbeat stopped)".into(),
            FaultCode::ServoDrive => "servo drive fault".into(),
            FaultCode::RodDrive => "push-rod drive fault".into(),
            FaultCode::FocusDrive => "focus drive fault".into(),
            FaultCode::TravelLimit => "push rod at its travel limit without contact".into(),
            FaultCode::EStop => "emergency stop".into(),
            FaultCode::BadCommand => "bad command or argument".into(),
            FaultCode::NoPart => "no part on the shaft".into(),
            FaultCode::Other(x) => format!("fault code {x}"),
        }
    }
}

/// The commands of the command word.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Command {
    /// Nothing.
    None,
    /// Servo to `arg0` (angle counts), done when there and settled.
    MoveServo,
    /// Servo accelerates to `arg0` (speed counts), done when at speed; keeps turning.
    Turn,
    /// Servo decelerates to a stop, done when stopped.
    StopServo,
    /// Focus drive to `arg0` (length counts), done when there.
    MoveFocus,
    /// Rod: fast to `arg1` (length counts), then creeps at `arg0` (length counts per s) until
    /// [`Command::StopRod`] or the travel limit (fault). Busy while moving.
    Approach,
    /// Rod stops where it is (contact seen), done when stopped.
    StopRod,
    /// Rod pushes a further `arg0` (length counts), done when there.
    Push,
    /// Rod back home, done when there.
    Retract,
    /// Clears a latched fault (not while the e-stop is pressed).
    ResetFault,
    /// The part is finished: the PLC unloads it and loads the next (part present again).
    PartDone,
    /// Camera trigger at `arg0` (frames per 1000 s; 0 = off); the trigger count restarts at 0.
    Trigger,
}

impl Command {
    /// To the wire.
    pub fn to_u16(self) -> u16 {
        match self {
            Command::None => 0,
            Command::MoveServo => 1,
            Command::Turn => 2,
            Command::StopServo => 3,
            Command::MoveFocus => 4,
            Command::Approach => 5,
            Command::StopRod => 6,
            Command::Push => 7,
            Command::Retract => 8,
            Command::ResetFault => 9,
            Command::PartDone => 10,
            Command::Trigger => 11,
        }
    }

    /// From the wire.
    pub fn from_u16(c: u16) -> Option<Self> {
        Some(match c {
            0 => Command::None,
            1 => Command::MoveServo,
            2 => Command::Turn,
            3 => Command::StopServo,
            4 => Command::MoveFocus,
            5 => Command::Approach,
            6 => Command::StopRod,
            7 => Command::Push,
            8 => Command::Retract,
            9 => Command::ResetFault,
            10 => Command::PartDone,
            11 => Command::Trigger,
            _ => return None,
        })
    }
}

/// An error of the PLC link.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum PlcError {
    /// The connection could not be made (refused, unreachable).
    #[error("PLC at {addr}: cannot connect: {message}")]
    Connect {
        /// The PLC's address.
        addr: String,
        /// Why.
        message: String,
    },
    /// A request failed on the wire (reset, closed).
    #[error("PLC at {addr}: {message}")]
    Io {
        /// The PLC's address.
        addr: String,
        /// Why.
        message: String,
    },
    /// No reply in time.
    #[error("PLC at {addr}: no reply within {timeout_ms} ms")]
    NoReply {
        /// The PLC's address.
        addr: String,
        /// The reply timeout.
        timeout_ms: u64,
    },
    /// The PLC answered with a Modbus exception.
    #[error("PLC at {addr}: Modbus exception {code} on {what}")]
    Exception {
        /// The PLC's address.
        addr: String,
        /// The exception.
        code: String,
        /// The request.
        what: String,
    },
    /// The PLC's heartbeat stopped while it still answered.
    #[error("PLC at {addr}: its heartbeat has not changed for {ms} ms")]
    Silent {
        /// The PLC's address.
        addr: String,
        /// How long.
        ms: u64,
    },
    /// The PLC reports a fault.
    #[error("PLC at {addr}: {what}: {}", code.describe())]
    Fault {
        /// The PLC's address.
        addr: String,
        /// During what.
        what: String,
        /// The fault.
        code: FaultCode,
    },
    /// The emergency stop is pressed.
    #[error("PLC at {addr}: emergency stop pressed during {what}")]
    EStop {
        /// The PLC's address.
        addr: String,
        /// During what.
        what: String,
    },
    /// A command stayed busy too long.
    #[error("PLC at {addr}: {what} not done within {timeout_s} s")]
    CommandTimeout {
        /// The PLC's address.
        addr: String,
        /// The command.
        what: String,
        /// The limit.
        timeout_s: f64,
    },
    /// An earlier failure took the link down.
    #[error("PLC at {addr}: link down after an earlier failure ({first})")]
    LinkDown {
        /// The PLC's address.
        addr: String,
        /// The first failure.
        first: String,
    },
    /// A frame could not be given an angle.
    #[error("{message}")]
    Pairing {
        /// Why.
        message: String,
    },
    /// The camera failed.
    #[error("camera: {message}")]
    Camera {
        /// The camera's message.
        message: String,
        /// The camera error's kind.
        kind: DeviceErrorKind,
    },
    /// The push rod found no contact.
    #[error("push rod: {message}")]
    NoContact {
        /// Why.
        message: String,
    },
}

impl DeviceError for PlcError {
    fn kind(&self) -> DeviceErrorKind {
        match self {
            PlcError::Connect { .. } | PlcError::Io { .. } | PlcError::LinkDown { .. } => {
                DeviceErrorKind::Communication
            }
            PlcError::NoReply { .. }
            | PlcError::Silent { .. }
            | PlcError::CommandTimeout { .. } => DeviceErrorKind::Timeout,
            PlcError::Fault { .. }
            | PlcError::EStop { .. }
            | PlcError::NoContact { .. }
            | PlcError::Pairing { .. } => DeviceErrorKind::Fault,
            PlcError::Camera { kind, .. } => *kind,
            PlcError::Exception { .. } => DeviceErrorKind::Other,
        }
    }
}

/// One read of the status block.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Status {
    /// The status word ([`bits`]).
    pub word: u16,
    /// The last acknowledged sequence.
    pub ack: u16,
    /// The fault code.
    pub fault: FaultCode,
    /// The PLC's heartbeat counter.
    pub heartbeat: u16,
    /// PLC time, s.
    pub time_s: f64,
    /// Servo angle, degrees.
    pub angle_deg: f64,
    /// Focus position, µm.
    pub focus_um: f64,
    /// Rod position, µm.
    pub rod_um: f64,
    /// Triggers since the trigger was switched on.
    pub trigger_count: u32,
    /// The part number on the shaft (1-based; 0 before the first).
    pub part: u32,
    /// Angle samples written so far.
    pub sample_count: u32,
    /// Servo speed, °/s.
    pub speed_deg_per_s: f64,
}

impl Status {
    /// A bit of the status word.
    pub fn has(&self, bit: u16) -> bool {
        self.word & bit != 0
    }
}

/// Width of a round-trip histogram bin, ms.
const RTT_BIN_MS: f64 = 0.01;
/// Bins of [`RTT_BIN_MS`] from 0 up to 100 ms; longer round trips are kept one by one.
const RTT_BINS: usize = 10_000;
/// Round trips over 100 ms kept one by one (beyond these, the slowest are kept).
const RTT_SLOW_KEPT: usize = 100_000;

/// Round-trip times of the link's requests: every request counted, however long the link runs,
/// in bounded memory. Times under 100 ms fall in bins of 10 µs (a quantile is its bin's middle,
/// within 5 µs); slower ones are kept as measured (at most 100,000; then the slowest of them).
#[derive(Debug, Clone)]
pub struct RoundTrips {
    bins: Vec<u64>,
    slow_ms: Vec<f64>,
    /// Slow round trips not kept (the fastest of the slow ones are dropped first).
    slow_dropped: u64,
    count: u64,
}

impl Default for RoundTrips {
    fn default() -> Self {
        RoundTrips {
            bins: vec![0; RTT_BINS],
            slow_ms: Vec::new(),
            slow_dropped: 0,
            count: 0,
        }
    }
}

impl RoundTrips {
    fn add(&mut self, ms: f64) {
        self.count += 1;
        let bin = (ms.max(0.0) / RTT_BIN_MS) as usize;
        if bin < RTT_BINS {
            self.bins[bin] += 1;
        } else if self.slow_ms.len() < RTT_SLOW_KEPT {
            self.slow_ms.push(ms);
        } else {
            // Keep the slowest: replace the fastest kept one if this one is slower.
            self.slow_dropped += 1;
            if let Some((i, &min)) = self
                .slow_ms
                .iter()
                .enumerate()
                .min_by(|a, b| a.1.total_cmp(b.1))
                && ms > min
            {
                self.slow_ms[i] = ms;
            }
        }
    }

    /// Requests timed.
    pub fn count(&self) -> usize {
        self.count as usize
    }

    /// The `q` quantile (0–1), ms (the sample of rank round((n − 1)·q)); NaN when nothing was
    /// timed.
    pub fn quantile_ms(&self, q: f64) -> f64 {
        if self.count == 0 {
            return f64::NAN;
        }
        let rank = ((self.count - 1) as f64 * q.clamp(0.0, 1.0)).round() as u64;
        let mut seen = 0u64;
        for (i, &n) in self.bins.iter().enumerate() {
            seen += n;
            if rank < seen {
                return (i as f64 + 0.5) * RTT_BIN_MS;
            }
        }
        // Among the slow ones: those dropped were the fastest of them.
        let mut slow = self.slow_ms.clone();
        slow.sort_by(f64::total_cmp);
        let k = (rank - seen).saturating_sub(self.slow_dropped) as usize;
        slow.get(k)
            .or(slow.first())
            .copied()
            .unwrap_or(RTT_BINS as f64 * RTT_BIN_MS)
    }
}

/// The blocking Modbus TCP link.
pub struct Link {
    ctx: sync::Context,
    addr: String,
    /// The register map.
    pub map: RegisterMap,
    seq: u16,
    beat: u16,
    last_beat: Instant,
    plc_beat: Option<(u16, Instant)>,
    down: Option<String>,
    rtt: RoundTrips,
}

impl std::fmt::Debug for Link {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Link")
            .field("addr", &self.addr)
            .field("seq", &self.seq)
            .field("down", &self.down)
            .finish_non_exhaustive()
    }
}

impl Link {
    /// Connects to the PLC at `addr` (`HOST:PORT`).
    ///
    /// # Errors
    /// [`PlcError::Connect`] when the address does not resolve or the PLC refuses; the first
    /// status read's errors.
    pub fn connect(addr: &str, map: RegisterMap) -> Result<Self, PlcError> {
        let conn = |message: String| PlcError::Connect {
            addr: addr.to_string(),
            message,
        };
        let sa: SocketAddr = addr
            .to_socket_addrs()
            .map_err(|e| conn(e.to_string()))?
            .next()
            .ok_or_else(|| conn("the address resolves to nothing".into()))?;
        let timeout = Duration::from_millis(map.timing.reply_timeout_ms);
        let mut ctx =
            sync::tcp::connect_slave_with_timeout(sa, tokio_modbus::Slave(map.unit), Some(timeout))
                .map_err(|e| conn(e.to_string()))?;
        ctx.set_timeout(timeout);
        ctx.set_slave(tokio_modbus::Slave(map.unit));
        let mut link = Link {
            ctx,
            addr: addr.to_string(),
            map,
            seq: 0,
            beat: 0,
            last_beat: Instant::now(),
            plc_beat: None,
            down: None,
            rtt: RoundTrips::default(),
        };
        let s = link.status()?;
        link.seq = s.ack;
        link.heartbeat(true)?;
        Ok(link)
    }

    /// The PLC's address.
    pub fn addr(&self) -> &str {
        &self.addr
    }

    /// Round-trip times so far.
    pub fn round_trips(&self) -> &RoundTrips {
        &self.rtt
    }

    fn fail(&mut self, e: PlcError) -> PlcError {
        if self.down.is_none() {
            self.down = Some(e.to_string());
        }
        e
    }

    fn check_up(&self) -> Result<(), PlcError> {
        match &self.down {
            Some(first) => Err(PlcError::LinkDown {
                addr: self.addr.clone(),
                first: first.clone(),
            }),
            None => Ok(()),
        }
    }

    fn wire<T>(
        &mut self,
        what: &str,
        f: impl FnOnce(&mut sync::Context) -> tokio_modbus::Result<T>,
    ) -> Result<T, PlcError> {
        self.check_up()?;
        let t = Instant::now();
        let r = f(&mut self.ctx);
        self.rtt.add(t.elapsed().as_secs_f64() * 1e3);
        match r {
            Ok(Ok(v)) => Ok(v),
            Ok(Err(code)) => Err(PlcError::Exception {
                addr: self.addr.clone(),
                code: format!("{code:?}"),
                what: what.to_string(),
            }),
            Err(e) => {
                let err = match e {
                    tokio_modbus::Error::Transport(io)
                        if io.kind() == std::io::ErrorKind::TimedOut =>
                    {
                        PlcError::NoReply {
                            addr: self.addr.clone(),
                            timeout_ms: self.map.timing.reply_timeout_ms,
                        }
                    }
                    other => PlcError::Io {
                        addr: self.addr.clone(),
                        message: format!("{what}: {other}"),
                    },
                };
                Err(self.fail(err))
            }
        }
    }

    /// Reads input registers.
    ///
    /// # Errors
    /// Link failures.
    pub fn read_input(&mut self, addr: u16, n: u16) -> Result<Vec<u16>, PlcError> {
        self.heartbeat(false)?;
        let w = self.wire("read input registers", |c| c.read_input_registers(addr, n))?;
        if w.len() != n as usize {
            let e = PlcError::Io {
                addr: self.addr.clone(),
                message: format!("read {n} input registers at {addr}: got {}", w.len()),
            };
            return Err(self.fail(e));
        }
        Ok(w)
    }

    /// Writes gonio's heartbeat when it is due (or now, with `force`).
    ///
    /// # Errors
    /// Link failures.
    pub fn heartbeat(&mut self, force: bool) -> Result<(), PlcError> {
        if !force && self.last_beat.elapsed() < Duration::from_millis(self.map.timing.heartbeat_ms)
        {
            return Ok(());
        }
        self.beat = self.beat.wrapping_add(1);
        let (a, v) = (self.map.holding.heartbeat, self.beat);
        self.last_beat = Instant::now();
        self.wire("write heartbeat", |c| c.write_single_register(a, v))
    }

    /// Reads the status block and checks the PLC's heartbeat.
    ///
    /// # Errors
    /// Link failures; [`PlcError::Silent`] when the PLC's heartbeat stood still for the
    /// watchdog time.
    pub fn status(&mut self) -> Result<Status, PlcError> {
        let w = self.read_input(self.map.input.status, STATUS_BLOCK_REGS)?;
        let m = &self.map;
        let s = Status {
            word: w[0],
            ack: w[1],
            fault: FaultCode::from_u16(w[2]),
            heartbeat: w[3],
            time_s: words_u64(&w[4..8]) as f64 * 1e-6,
            angle_deg: m.angle_deg(words_i32(&w[8..10])),
            focus_um: m.length_um(words_i32(&w[10..12])),
            rod_um: m.length_um(words_i32(&w[12..14])),
            trigger_count: words_u32(&w[14..16]),
            part: words_u32(&w[16..18]),
            sample_count: words_u32(&w[18..20]),
            speed_deg_per_s: m.speed_deg_per_s(words_i32(&w[20..22])),
        };
        let now = Instant::now();
        match self.plc_beat {
            Some((b, _)) if b != s.heartbeat => self.plc_beat = Some((s.heartbeat, now)),
            Some((_, since)) => {
                let ms = since.elapsed().as_millis() as u64;
                if ms > self.map.timing.watchdog_ms {
                    let e = PlcError::Silent {
                        addr: self.addr.clone(),
                        ms,
                    };
                    return Err(self.fail(e));
                }
            }
            None => self.plc_beat = Some((s.heartbeat, now)),
        }
        Ok(s)
    }

    /// Sends a command (arguments, command word and the next sequence number in one write)
    /// and returns its sequence number, without waiting.
    ///
    /// # Errors
    /// Link failures.
    pub fn send(&mut self, cmd: Command, arg0: i32, arg1: i32) -> Result<u16, PlcError> {
        let h = self.map.holding.clone();
        self.seq = self.seq.wrapping_add(1);
        if self.seq == 0 {
            self.seq = 1;
        }
        let seq = self.seq;
        // A command is a beat too.
        self.beat = self.beat.wrapping_add(1);
        // The holding block from the lowest address written; registers in between (the
        // heartbeat) are rewritten with their current values.
        let mut regs: Vec<(u16, u16)> = vec![(h.command, cmd.to_u16()), (h.sequence, seq)];
        let [a, b] = i32_words(arg0);
        regs.extend([(h.arg0, a), (h.arg0 + 1, b)]);
        let [a, b] = i32_words(arg1);
        regs.extend([(h.arg1, a), (h.arg1 + 1, b)]);
        regs.push((h.heartbeat, self.beat));
        regs.sort_by_key(|r| r.0);
        let lo = regs[0].0;
        let hi = regs[regs.len() - 1].0;
        if (hi - lo) as usize + 1 == regs.len() {
            // Contiguous: one write, the sequence taken with its arguments.
            let words: Vec<u16> = regs.iter().map(|r| r.1).collect();
            self.wire("write command", |c| c.write_multiple_registers(lo, &words))?;
        } else {
            // Arguments first, the sequence last (the PLC acts when the sequence changes).
            for (a, v) in regs.iter().filter(|r| r.0 != h.sequence) {
                let (a, v) = (*a, *v);
                self.wire("write command", |c| c.write_single_register(a, v))?;
            }
            self.wire("write sequence", |c| {
                c.write_single_register(h.sequence, seq)
            })?;
        }
        self.last_beat = Instant::now();
        Ok(seq)
    }

    /// Checks a status for e-stop and faults.
    ///
    /// # Errors
    /// [`PlcError::EStop`], [`PlcError::Fault`].
    pub fn check(&mut self, s: &Status, what: &str) -> Result<(), PlcError> {
        if s.has(bits::ESTOP) {
            return Err(PlcError::EStop {
                addr: self.addr.clone(),
                what: what.to_string(),
            });
        }
        if s.has(bits::FAULT) || s.has(bits::WATCHDOG) {
            let code = if s.fault == FaultCode::None && s.has(bits::WATCHDOG) {
                FaultCode::Watchdog
            } else {
                s.fault
            };
            return Err(PlcError::Fault {
                addr: self.addr.clone(),
                what: what.to_string(),
                code,
            });
        }
        Ok(())
    }

    /// Polls until command `seq` is done; returns the status at done.
    ///
    /// # Errors
    /// Link failures, e-stop, faults, [`PlcError::CommandTimeout`].
    pub fn wait_done(&mut self, seq: u16, what: &str) -> Result<Status, PlcError> {
        let t0 = Instant::now();
        let limit = Duration::from_secs_f64(self.map.timing.command_timeout_s);
        let poll = Duration::from_millis(self.map.timing.poll_ms);
        loop {
            let s = self.status()?;
            self.check(&s, what)?;
            if s.ack == seq && s.has(bits::DONE) && !s.has(bits::BUSY) {
                return Ok(s);
            }
            if t0.elapsed() > limit {
                return Err(PlcError::CommandTimeout {
                    addr: self.addr.clone(),
                    what: what.to_string(),
                    timeout_s: self.map.timing.command_timeout_s,
                });
            }
            std::thread::sleep(poll);
        }
    }

    /// Sends a command and waits until it is done.
    ///
    /// # Errors
    /// As [`Link::send`] and [`Link::wait_done`].
    pub fn command(&mut self, cmd: Command, arg0: i32, arg1: i32) -> Result<Status, PlcError> {
        let seq = self.send(cmd, arg0, arg1)?;
        self.wait_done(seq, &format!("{cmd:?}"))
    }
}

#[cfg(test)]
mod tests {
    use super::RoundTrips;
    use rand::{RngExt, SeedableRng};

    /// The sample of rank round((n − 1)·q) of a sorted copy.
    fn exact(v: &[f64], q: f64) -> f64 {
        let mut s = v.to_vec();
        s.sort_by(f64::total_cmp);
        s[((s.len() - 1) as f64 * q).round() as usize]
    }

    #[test]
    fn quantiles_are_within_half_a_bin_of_the_exact_ones_and_slow_ones_exact() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let mut r = RoundTrips::default();
        let mut all = Vec::new();
        for _ in 0..20_000 {
            // Mostly around 1 ms, a tail up to 400 ms.
            let ms = if rng.random::<f64>() < 0.995 {
                0.5 + rng.random::<f64>() * 2.0
            } else {
                100.0 + rng.random::<f64>() * 300.0
            };
            r.add(ms);
            all.push(ms);
        }
        assert_eq!(r.count(), 20_000);
        for q in [0.0, 0.1, 0.5, 0.9, 0.99] {
            let (got, want) = (r.quantile_ms(q), exact(&all, q));
            assert!(
                (got - want).abs() <= 0.005 + 1e-12,
                "q {q}: {got} vs {want}"
            );
        }
        // In the slow tail every sample is kept: exact.
        for q in [0.996, 0.999, 1.0] {
            assert_eq!(r.quantile_ms(q), exact(&all, q), "q {q}");
        }
        assert!(RoundTrips::default().quantile_ms(0.5).is_nan());
    }

    #[test]
    fn every_request_is_counted_in_bounded_memory() {
        let mut r = RoundTrips::default();
        for i in 0..1_500_000u64 {
            r.add(1.0 + (i % 7) as f64 * 0.1);
        }
        assert_eq!(r.count(), 1_500_000);
        assert!((r.quantile_ms(0.5) - 1.305).abs() < 1e-9);
        assert_eq!(r.bins.len(), super::RTT_BINS);
    }
}
