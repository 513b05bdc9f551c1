//! The driver of an ELCOMAT-type autocollimator on a serial line: send `a` (absolute) or `r`
//! (relative) and CR LF, read one answer line ended by CR (`4 003 X Y`, `2 103 X Y`, arcsec).
//!
//! [`Autocollimator::open`] opens the port with `serialport` (8N1, no flow control, exclusive:
//! a port another program holds is refused as busy). [`Autocollimator::read`] returns the
//! exchange: the bytes the instrument sent and what they are ([`Reply`]: a reading, a reading
//! the instrument flagged with another status code, or garbage). A silent instrument (no
//! complete answer within the timeout), a port that fails or hangs up (a pulled USB adapter),
//! are [`InstrumentError`]s naming the port.
//!
//! Any `Read + Write` transport works ([`Transport`]), so the driver is tested on a pipe:
//!
//! ```
//! use gonio_lab::instrument::{Autocollimator, Transport};
//! use gonio_lab::log::{Mode, Reply};
//! use std::io::{Cursor, Read, Write};
//! struct Canned(Cursor<Vec<u8>>, Vec<u8>);
//! impl Read for Canned { fn read(&mut self, b: &mut [u8]) -> std::io::Result<usize> { self.0.read(b) } }
//! impl Write for Canned {
//!     fn write(&mut self, b: &[u8]) -> std::io::Result<usize> { self.1.extend_from_slice(b); Ok(b.len()) }
//!     fn flush(&mut self) -> std::io::Result<()> { Ok(()) }
//! }
//! impl Transport for Canned {}
//! let port = Canned(Cursor::new(b"4 003 +1.250 -0.004\r".to_vec()), Vec::new());
//! let mut ac = Autocollimator::new(port, "test", std::time::Duration::from_secs(1));
//! let e = ac.read(Mode::Absolute).unwrap();
//! assert!(matches!(e.reply, Reply::Reading { x_arcsec: 1.25, .. }));
//! assert_eq!(e.raw, b"4 003 +1.250 -0.004");
//! ```

use crate::log::{self, Mode, Reply};
use gonio_core::bound::Bound;
use std::io::{ErrorKind, Read, Write};
use std::time::{Duration, Instant};

/// The baud rates a serial line is opened at: from the slowest teleprinter rate to what USB
/// adapters reach.
pub const BAUD: Bound = Bound::new(50.0, 4_000_000.0, "baud");

/// Longest answer line read (an answer is about 25 bytes); a longer one is garbage.
pub const MAX_LINE_BYTES: usize = 256;

/// A byte stream to the instrument.
pub trait Transport: Read + Write {
    /// Drops whatever the instrument sent that was not read (a late answer to an earlier
    /// request), so that the next answer belongs to the next request.
    ///
    /// # Errors
    /// The port failed.
    fn discard_input(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Transport for Box<dyn serialport::SerialPort> {
    fn discard_input(&mut self) -> std::io::Result<()> {
        self.clear(serialport::ClearBuffer::Input)
            .map_err(std::io::Error::from)
    }
}

/// What went wrong with the instrument or its port.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum InstrumentError {
    /// No such device.
    #[error("port {port}: no such device (is the adapter plugged in? {reason})")]
    Missing {
        /// The port.
        port: String,
        /// What the system said.
        reason: String,
    },
    /// Another program holds the port.
    #[error("port {port} is busy: another program has it open ({reason})")]
    Busy {
        /// The port.
        port: String,
        /// What the system said.
        reason: String,
    },
    /// The port could not be opened or set up.
    #[error("port {port}: cannot open it at {baud} baud: {reason}")]
    Open {
        /// The port.
        port: String,
        /// Baud rate asked for.
        baud: u32,
        /// What the system said.
        reason: String,
    },
    /// No complete answer within the timeout.
    #[error(
        "port {port}: the autocollimator did not answer `{request}` within {:.1} s (is it on, and at the port's baud rate?){}",
        timeout.as_secs_f64(),
        if partial.is_empty() { String::new() } else { format!("; it sent {partial:?} and no CR") }
    )]
    Silent {
        /// The port.
        port: String,
        /// The request sent (`a` or `r`).
        request: &'static str,
        /// The timeout.
        timeout: Duration,
        /// What came without a line end, if anything.
        partial: String,
    },
    /// The port failed or hung up while in use (a pulled USB adapter, the other end closed).
    #[error("port {port}: the connection to the autocollimator is lost ({reason})")]
    Disconnected {
        /// The port.
        port: String,
        /// What the system said.
        reason: String,
    },
}

/// One request and the instrument's answer.
#[derive(Debug, Clone, PartialEq)]
pub struct Exchange {
    /// The answer line as sent, without its CR (or LF).
    pub raw: Vec<u8>,
    /// What it is.
    pub reply: Reply,
}

/// An autocollimator on a transport.
#[derive(Debug)]
pub struct Autocollimator<T> {
    port: T,
    name: String,
    timeout: Duration,
    pending: Vec<u8>,
}

impl Autocollimator<Box<dyn serialport::SerialPort>> {
    /// Opens the serial port `path` at `baud` (8 data bits, no parity, 1 stop bit, no flow
    /// control), exclusively; `timeout` bounds the wait for one answer.
    ///
    /// # Errors
    /// [`InstrumentError::Missing`], [`InstrumentError::Busy`] or [`InstrumentError::Open`] (also
    /// for a baud rate outside [`BAUD`]).
    pub fn open(path: &str, baud: u32, timeout: Duration) -> Result<Self, InstrumentError> {
        // 0 baud is B0 to the kernel: it hangs the line up instead of setting a speed.
        if let Err(e) = BAUD.check_int(baud) {
            return Err(InstrumentError::Open {
                port: path.to_string(),
                baud,
                reason: format!("the baud rate must be {e} (0 baud hangs up a real line)"),
            });
        }
        let port = serialport::new(path, baud)
            .timeout(timeout.min(Duration::from_millis(200)))
            .data_bits(serialport::DataBits::Eight)
            .parity(serialport::Parity::None)
            .stop_bits(serialport::StopBits::One)
            .flow_control(serialport::FlowControl::None)
            .open()
            .map_err(|e| {
                let reason = e.description.clone();
                match e.kind {
                    serialport::ErrorKind::NoDevice => InstrumentError::Busy {
                        port: path.to_string(),
                        reason,
                    },
                    serialport::ErrorKind::Io(ErrorKind::NotFound) => InstrumentError::Missing {
                        port: path.to_string(),
                        reason,
                    },
                    _ => InstrumentError::Open {
                        port: path.to_string(),
                        baud,
                        reason,
                    },
                }
            })?;
        Ok(Autocollimator::new(port, path, timeout))
    }
}

impl<T: Transport> Autocollimator<T> {
    /// The driver on an open transport; `name` names the port in errors.
    pub fn new(port: T, name: &str, timeout: Duration) -> Self {
        Autocollimator {
            port,
            name: name.to_string(),
            timeout,
            pending: Vec::new(),
        }
    }

    /// The port's name.
    pub fn port_name(&self) -> &str {
        &self.name
    }

    fn lost(&self, e: &std::io::Error) -> InstrumentError {
        InstrumentError::Disconnected {
            port: self.name.clone(),
            reason: if e.kind() == ErrorKind::UnexpectedEof {
                "end of file: the other end closed".into()
            } else {
                e.to_string()
            },
        }
    }

    /// Asks for one reading and reads the answer line.
    ///
    /// # Errors
    /// [`InstrumentError::Silent`] when no line ends within the timeout,
    /// [`InstrumentError::Disconnected`] when the port fails.
    pub fn read(&mut self, mode: Mode) -> Result<Exchange, InstrumentError> {
        self.pending.clear();
        if let Err(e) = self.port.discard_input() {
            return Err(self.lost(&e));
        }
        let request = mode.request();
        let sent = self
            .port
            .write_all(request)
            .and_then(|()| self.port.flush());
        if let Err(e) = sent {
            return Err(self.lost(&e));
        }
        let deadline = Instant::now() + self.timeout;
        let mut byte = [0u8; 64];
        loop {
            // A line ends at CR or LF; empty lines (the LF of a CR LF) are skipped.
            if let Some(end) = self.pending.iter().position(|&b| b == b'\r' || b == b'\n') {
                if end == 0 {
                    self.pending.remove(0);
                    continue;
                }
                let raw: Vec<u8> = self.pending[..end].to_vec();
                self.pending.drain(..=end);
                let text = String::from_utf8_lossy(&raw);
                let reply =
                    if raw.iter().any(|&b| b < 0x20 && b != b'\t') || raw.len() > MAX_LINE_BYTES {
                        Reply::Garbage {
                            message: "control bytes or an overlong line".into(),
                        }
                    } else {
                        log::parse_reply(&text)
                    };
                return Ok(Exchange { raw, reply });
            }
            if self.pending.len() > MAX_LINE_BYTES {
                let raw = std::mem::take(&mut self.pending);
                return Ok(Exchange {
                    raw,
                    reply: Reply::Garbage {
                        message: format!("more than {MAX_LINE_BYTES} bytes without a line end"),
                    },
                });
            }
            if Instant::now() >= deadline {
                return Err(InstrumentError::Silent {
                    port: self.name.clone(),
                    request: if mode == Mode::Absolute { "a" } else { "r" },
                    timeout: self.timeout,
                    partial: gonio_core::text::short(&String::from_utf8_lossy(&self.pending)),
                });
            }
            match self.port.read(&mut byte) {
                Ok(0) => {
                    return Err(self.lost(&std::io::Error::from(ErrorKind::UnexpectedEof)));
                }
                Ok(n) => self.pending.extend_from_slice(&byte[..n]),
                Err(e)
                    if matches!(
                        e.kind(),
                        ErrorKind::TimedOut | ErrorKind::Interrupted | ErrorKind::WouldBlock
                    ) => {}
                Err(e) => return Err(self.lost(&e)),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An instrument that answers every request with bytes and never a line end.
    struct Endless(usize);

    impl Read for Endless {
        fn read(&mut self, b: &mut [u8]) -> std::io::Result<usize> {
            self.0 += b.len();
            b.fill(b'7');
            Ok(b.len())
        }
    }

    impl Write for Endless {
        fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
            Ok(b.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    impl Transport for Endless {}

    #[test]
    fn an_endless_answer_is_garbage_after_its_bound_not_collected() {
        let mut ac = Autocollimator::new(Endless(0), "endless", Duration::from_secs(5));
        let e = ac.read(Mode::Absolute).unwrap();
        match e.reply {
            Reply::Garbage { message } => {
                assert_eq!(message, "more than 256 bytes without a line end");
            }
            other => panic!("{other:?}"),
        }
        assert!(e.raw.len() <= MAX_LINE_BYTES + 64, "{}", e.raw.len());
        assert!(ac.port.0 <= MAX_LINE_BYTES + 64);
    }

    #[test]
    fn zero_baud_is_refused_before_the_port_is_touched() {
        // B0 would hang a real line up; the port need not exist to be refused.
        let e = Autocollimator::open("/nonexistent/tty", 0, Duration::from_secs(1)).unwrap_err();
        let m = e.to_string();
        assert!(
            m.contains("at least 50 baud") && m.contains("hangs up"),
            "{m}"
        );
        let e = Autocollimator::open("/nonexistent/tty", 9600, Duration::from_secs(1)).unwrap_err();
        assert!(!e.to_string().contains("baud rate must be"), "{e}");
    }
}
