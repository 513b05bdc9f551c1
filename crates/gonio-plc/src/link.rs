//! The Modbus TCP link to the PLC: blocking reads and writes with a reply timeout, the command
//! handshake (arguments, command word and sequence counter in one write; the PLC acknowledges
//! the sequence and reports busy → done, or a fault), gonio's heartbeat and a watchdog on the
//! PLC's, and the round-trip times of every request.
//!
//! A link that failed once (refused, closed or reset by the PLC, a reply timed out, the PLC's
//! heartbeat stopped) is down for good: every later call fails at once with
//! [`PlcError::LinkDown`], so a dead PLC costs one timeout, not one per call. A failure names
//! what happened on the wire ([`crate::transport`]): the PLC closed the connection, reset it,
//! or did not reply.
//!
//! After [`Link::abort`] (a device error, an interrupt, the batch's end) the link is in the safe
//! state ([`crate::abort`]): only the commands that leave the station safe are sent, all within
//! `timing.safe_state_ms` together. An [`Interrupt`] set by the caller (a signal) ends every wait
//! that is not one of those with [`PlcError::Interrupted`] within a poll period.
//!
//! Errors: [`PlcError`]; its [`DeviceError::kind`](gonio_station::hal::DeviceError::kind) says
//! timeout, communication, fault or interrupted.
//!
//! ```no_run
//! use gonio_plc::link::{Command, Link};
//! use gonio_plc::map::RegisterMap;
//! let mut link = Link::connect("127.0.0.1:1502", RegisterMap::default()).unwrap();
//! link.command(Command::ResetFault, 0, 0).unwrap();
//! let status = link.status().unwrap();
//! println!("PLC time {} s", status.time_s);
//! ```

pub use crate::error::PlcError;
pub use crate::protocol::{Command, FaultCode, Status, bits};
pub use crate::round_trips::RoundTrips;

pub use crate::abort::Interrupt;

use crate::abort::{SafeState, is_safe_command};
use crate::map::{RegisterMap, STATUS_BLOCK_REGS, i32_words, words_i32, words_u32, words_u64};
use crate::transport::{Client, Failure};
use std::net::{SocketAddr, ToSocketAddrs};
use std::time::{Duration, Instant};

/// The blocking Modbus TCP link.
pub struct Link {
    ctx: Client,
    addr: String,
    /// The register map.
    pub map: RegisterMap,
    seq: u16,
    beat: u16,
    last_beat: Instant,
    plc_beat: Option<(u16, Instant)>,
    down: Option<String>,
    rtt: RoundTrips,
    interrupt: Option<Interrupt>,
    safe: Option<SafeState>,
}

impl std::fmt::Debug for Link {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Link")
            .field("addr", &self.addr)
            .field("seq", &self.seq)
            .field("down", &self.down)
            .field("safe", &self.safe)
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
        let ctx = Client::connect(sa, map.unit, timeout).map_err(conn)?;
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
            interrupt: None,
            safe: None,
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
        f: impl FnOnce(&mut Client) -> Result<T, Failure>,
    ) -> Result<T, PlcError> {
        self.check_up()?;
        let t = Instant::now();
        let r = f(&mut self.ctx);
        self.rtt.add(t.elapsed().as_secs_f64() * 1e3);
        let (addr, what) = (self.addr.clone(), what.to_string());
        let err = match r {
            Ok(v) => return Ok(v),
            // The PLC answered: the link is fine.
            Err(Failure::Exception(code)) => return Err(PlcError::Exception { addr, code, what }),
            Err(Failure::NoReply) => PlcError::NoReply {
                addr,
                timeout_ms: self.map.timing.reply_timeout_ms,
            },
            Err(Failure::Closed) => PlcError::Closed { addr, what },
            Err(Failure::Reset) => PlcError::Reset { addr, what },
            Err(f) => PlcError::Io {
                addr,
                message: format!("{what}: {f}"),
            },
        };
        Err(self.fail(err))
    }

    /// Reads input registers.
    ///
    /// # Errors
    /// Link failures.
    pub fn read_input(&mut self, addr: u16, n: u16) -> Result<Vec<u16>, PlcError> {
        self.heartbeat(false)?;
        let w = self.wire("read input registers", |c| c.read_input(addr, n))?;
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
        self.wire("write heartbeat", |c| c.write_one(a, v))
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
    /// Link failures; [`PlcError::Aborted`] for a command that is not a safe-state one after
    /// [`Link::abort`].
    pub fn send(&mut self, cmd: Command, arg0: i32, arg1: i32) -> Result<u16, PlcError> {
        if self.safe.is_some() && !is_safe_command(cmd, arg0) {
            return Err(PlcError::Aborted {
                addr: self.addr.clone(),
                what: format!("{cmd:?}"),
            });
        }
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
            self.wire("write command", |c| c.write_many(lo, &words))?;
        } else {
            // Arguments first, the sequence last (the PLC acts when the sequence changes).
            for (a, v) in regs.iter().filter(|r| r.0 != h.sequence) {
                let (a, v) = (*a, *v);
                self.wire("write command", |c| c.write_one(a, v))?;
            }
            self.wire("write sequence", |c| c.write_one(h.sequence, seq))?;
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
    /// Link failures, e-stop, faults, [`PlcError::CommandTimeout`]; in the safe state
    /// [`PlcError::SafeStateTimeout`] at its deadline; [`PlcError::Interrupted`] when the
    /// caller's [`Interrupt`] came (outside the safe state).
    pub fn wait_done(&mut self, seq: u16, what: &str) -> Result<Status, PlcError> {
        let t0 = Instant::now();
        let limit = gonio_core::bound::saturating_duration_s(self.map.timing.command_timeout_s);
        let poll = Duration::from_millis(self.map.timing.poll_ms);
        loop {
            let s = self.status()?;
            self.check(&s, what)?;
            if s.ack == seq && s.has(bits::DONE) && !s.has(bits::BUSY) {
                return Ok(s);
            }
            self.check_interrupt()?;
            let now = Instant::now();
            if let Some(safe) = &self.safe {
                if now >= safe.deadline() {
                    return Err(PlcError::SafeStateTimeout {
                        addr: self.addr.clone(),
                        what: what.to_string(),
                        budget_ms: safe.budget().as_millis() as u64,
                    });
                }
            } else if now.duration_since(t0) > limit {
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
        let s = self.wait_done(seq, &format!("{cmd:?}"))?;
        if let Some(safe) = self.safe.as_mut() {
            safe.done(cmd, arg0);
        }
        Ok(s)
    }

    /// Stops every wait of the link when `interrupt` is raised (outside the safe state):
    /// the wait ends with [`PlcError::Interrupted`] and the link enters the safe state.
    pub fn set_interrupt(&mut self, interrupt: Interrupt) {
        self.interrupt = Some(interrupt);
    }

    /// [`PlcError::Interrupted`] (and the safe state) once the caller's [`Interrupt`] came;
    /// nothing in the safe state, whose commands are what an interrupt asks for.
    ///
    /// # Errors
    /// [`PlcError::Interrupted`].
    pub fn check_interrupt(&mut self) -> Result<(), PlcError> {
        if self.safe.is_some() {
            return Ok(());
        }
        match self.interrupt.as_ref().and_then(Interrupt::signal) {
            Some(signal) => {
                self.abort();
                Err(PlcError::Interrupted { signal })
            }
            None => Ok(()),
        }
    }

    /// Aborts the sequence: from now on only safe-state commands are sent, all of them within
    /// `timing.safe_state_ms` from now (the first abort's deadline stands).
    pub fn abort(&mut self) {
        if self.safe.is_none() {
            self.safe = Some(SafeState::begin(Duration::from_millis(
                self.map.timing.safe_state_ms,
            )));
        }
    }

    /// Whether the link is in the safe state ([`Link::abort`]).
    pub fn aborted(&self) -> bool {
        self.safe.is_some()
    }

    /// Leaves the station safe: rod home, servo stopped, trigger off, each unless it was done
    /// already since the abort, all within the safe state's deadline. Best effort: the first
    /// failure is returned after every command was tried.
    ///
    /// # Errors
    /// The first command's failure (a dead link fails each at once).
    pub fn safe_state(&mut self) -> Result<(), PlcError> {
        self.abort();
        let mut first = None;
        for cmd in [Command::Retract, Command::StopServo, Command::Trigger] {
            if self.safe.as_ref().is_some_and(|s| s.was_done(cmd, 0)) {
                continue;
            }
            if let Err(e) = self.command(cmd, 0, 0) {
                first.get_or_insert(e);
            }
        }
        first.map_or(Ok(()), Err)
    }
}
