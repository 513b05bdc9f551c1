//! The Modbus TCP connection under the [`Link`](crate::Link): tokio-modbus's client over a TCP
//! stream that remembers how it ended, driven by a single-threaded runtime so that every request
//! blocks with a reply timeout.
//!
//! Why not tokio-modbus's own blocking client: when the PLC closes the connection, its reader
//! reports the end of the stream as `io::Error::last_os_error()`, whatever `errno` the thread
//! last left behind ("Inappropriate ioctl for device (os error 25)"). The stream here
//! ([`Watched`]) sees the end itself, so a failure is told as what happened: the PLC closed the
//! connection, reset it, or did not reply ([`Failure`]).
//!
//! Errors: [`Failure`], turned into a [`PlcError`](crate::PlcError) naming the PLC by the link.
//!
//! ```no_run
//! use gonio_plc::transport::Client;
//! use std::time::Duration;
//! let mut c = Client::connect("127.0.0.1:1502".parse().unwrap(), 1, Duration::from_secs(1)).unwrap();
//! let status = c.read_input(0, 22).unwrap();
//! println!("status word {:#06x}", status[0]);
//! ```

use std::io;
use std::net::SocketAddr;
use std::pin::Pin;
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll};
use std::time::Duration;
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::net::TcpStream;
use tokio_modbus::client::{Reader, Writer};

/// How a request failed.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum Failure {
    /// The PLC closed the connection (the stream ended).
    Closed,
    /// The PLC (or the network) reset the connection.
    Reset,
    /// No reply within the reply timeout.
    NoReply,
    /// The PLC answered with a Modbus exception.
    Exception(String),
    /// Anything else on the wire, in words (a malformed reply, an unreachable network).
    Other(String),
}

impl std::fmt::Display for Failure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Failure::Closed => f.write_str("the PLC closed the connection"),
            Failure::Reset => f.write_str("the connection was reset (by the PLC or the network)"),
            Failure::NoReply => f.write_str("no reply"),
            Failure::Exception(e) => write!(f, "Modbus exception {e}"),
            Failure::Other(m) => f.write_str(m),
        }
    }
}

/// What the stream saw last: its end, or an error of the socket.
#[derive(Debug, Clone, Default)]
enum Seen {
    #[default]
    Open,
    Ended,
    Error(io::ErrorKind, String),
}

/// A TCP stream that records its end and its errors for the [`Client`] (module docs).
#[derive(Debug)]
pub struct Watched {
    stream: TcpStream,
    seen: Arc<Mutex<Seen>>,
}

impl Watched {
    fn note(&self, s: Seen) {
        let mut seen = self.seen.lock().unwrap_or_else(|e| e.into_inner());
        if matches!(*seen, Seen::Open) {
            *seen = s;
        }
    }

    fn error<T>(&self, r: Poll<io::Result<T>>) -> Poll<io::Result<T>> {
        if let Poll::Ready(Err(e)) = &r {
            self.note(Seen::Error(e.kind(), e.to_string()));
        }
        r
    }
}

impl AsyncRead for Watched {
    fn poll_read(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        let this = self.get_mut();
        let (before, room) = (buf.filled().len(), buf.remaining());
        let r = Pin::new(&mut this.stream).poll_read(cx, buf);
        if matches!(r, Poll::Ready(Ok(()))) && room > 0 && buf.filled().len() == before {
            // Zero bytes read into room for more: the peer closed its side.
            this.note(Seen::Ended);
        }
        this.error(r)
    }
}

impl AsyncWrite for Watched {
    fn poll_write(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<io::Result<usize>> {
        let this = self.get_mut();
        let r = Pin::new(&mut this.stream).poll_write(cx, buf);
        this.error(r)
    }

    fn poll_flush(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        let this = self.get_mut();
        let r = Pin::new(&mut this.stream).poll_flush(cx);
        this.error(r)
    }

    fn poll_shutdown(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        let this = self.get_mut();
        let r = Pin::new(&mut this.stream).poll_shutdown(cx);
        this.error(r)
    }
}

/// A blocking Modbus TCP client: one request at a time, each within the reply timeout.
pub struct Client {
    rt: tokio::runtime::Runtime,
    ctx: tokio_modbus::client::Context,
    seen: Arc<Mutex<Seen>>,
    timeout: Duration,
}

impl std::fmt::Debug for Client {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Client")
            .field("timeout", &self.timeout)
            .finish_non_exhaustive()
    }
}

impl Client {
    /// Connects to `addr` within `timeout` and talks to Modbus unit `unit`; every request
    /// waits at most `timeout` for its reply.
    ///
    /// # Errors
    /// The runtime cannot start, the PLC refuses or does not accept in time (the message).
    pub fn connect(addr: SocketAddr, unit: u8, timeout: Duration) -> Result<Client, String> {
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_io()
            .enable_time()
            .build()
            .map_err(|e| format!("cannot start the I/O runtime: {e}"))?;
        let stream = rt
            .block_on(async { tokio::time::timeout(timeout, TcpStream::connect(addr)).await })
            .map_err(|_| format!("no answer within {} ms", timeout.as_millis()))?
            .map_err(|e| e.to_string())?;
        // Requests are small and each waits for its reply: no Nagle delay.
        let _ = stream.set_nodelay(true);
        let seen = Arc::new(Mutex::new(Seen::Open));
        let transport = Watched {
            stream,
            seen: seen.clone(),
        };
        let ctx = tokio_modbus::client::tcp::attach_slave(transport, tokio_modbus::Slave(unit));
        Ok(Client {
            rt,
            ctx,
            seen,
            timeout,
        })
    }

    /// A request's outcome, told by what the stream saw: its reply, its timeout or its failure.
    fn outcome<T>(
        &self,
        r: Result<tokio_modbus::Result<T>, tokio::time::error::Elapsed>,
    ) -> Result<T, Failure> {
        let seen = self.seen.lock().unwrap_or_else(|e| e.into_inner()).clone();
        match r {
            Ok(Ok(Ok(v))) => Ok(v),
            Ok(Ok(Err(code))) => Err(Failure::Exception(format!("{code:?}"))),
            Err(_) => Err(Failure::NoReply),
            Ok(Err(e)) => Err(match seen {
                Seen::Ended => Failure::Closed,
                Seen::Error(kind, message) => match kind {
                    io::ErrorKind::ConnectionReset | io::ErrorKind::ConnectionAborted => {
                        Failure::Reset
                    }
                    io::ErrorKind::BrokenPipe | io::ErrorKind::UnexpectedEof => Failure::Closed,
                    io::ErrorKind::TimedOut => Failure::NoReply,
                    _ => Failure::Other(message),
                },
                // The stream saw nothing: the fault is in the reply itself.
                Seen::Open => match e {
                    tokio_modbus::Error::Protocol(p) => Failure::Other(p.to_string()),
                    tokio_modbus::Error::Transport(t) if t.kind() == io::ErrorKind::TimedOut => {
                        Failure::NoReply
                    }
                    tokio_modbus::Error::Transport(t) => Failure::Other(t.to_string()),
                },
            }),
        }
    }

    /// Reads `n` input registers from `addr` (function code 4).
    ///
    /// # Errors
    /// [`Failure`].
    pub fn read_input(&mut self, addr: u16, n: u16) -> Result<Vec<u16>, Failure> {
        let (timeout, ctx) = (self.timeout, &mut self.ctx);
        let r = self.rt.block_on(async move {
            tokio::time::timeout(timeout, ctx.read_input_registers(addr, n)).await
        });
        self.outcome(r)
    }

    /// Writes one holding register (function code 6).
    ///
    /// # Errors
    /// [`Failure`].
    pub fn write_one(&mut self, addr: u16, value: u16) -> Result<(), Failure> {
        let (timeout, ctx) = (self.timeout, &mut self.ctx);
        let r = self.rt.block_on(async move {
            tokio::time::timeout(timeout, ctx.write_single_register(addr, value)).await
        });
        self.outcome(r)
    }

    /// Writes consecutive holding registers from `addr` (function code 16).
    ///
    /// # Errors
    /// [`Failure`].
    pub fn write_many(&mut self, addr: u16, values: &[u16]) -> Result<(), Failure> {
        let (timeout, ctx) = (self.timeout, &mut self.ctx);
        let r = self.rt.block_on(async move {
            tokio::time::timeout(timeout, ctx.write_multiple_registers(addr, values)).await
        });
        self.outcome(r)
    }
}
