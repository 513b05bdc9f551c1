//! The Modbus TCP link to the PLC: blocking reads and writes with a reply timeout, the command
//! handshake (arguments, command word and sequence counter in one write; the PLC acknowledges
//! the sequence and reports busy → done, or a fault), gonio's heartbeat and a watchdog on the
//! PLC's, and the round-trip times of every request.
//!
//! A link that failed once (refused, reset, a reply timed out, the PLC's heartbeat stopped) is
//! down for good: every later call fails at once with [`PlcError::LinkDown`], so a dead PLC
//! costs one timeout, not one per call.
//!
//! Errors: [`PlcError`]; its [`DeviceError::kind`](gonio_station::hal::DeviceError::kind) says
//! timeout, communication or fault.
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

use crate::map::{RegisterMap, STATUS_BLOCK_REGS, i32_words, words_i32, words_u32, words_u64};
use std::net::{SocketAddr, ToSocketAddrs};
use std::time::{Duration, Instant};
use tokio_modbus::client::sync::{self, Reader, Writer};
use tokio_modbus::prelude::SlaveContext;

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
