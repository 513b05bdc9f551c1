//! The terminal: every byte gonio writes to standard output or standard error goes through here.
//!
//! - A closed pipe (`gonio … | head -1`) ends the output quietly: later writes are skipped and
//!   the command finishes with exit code 0 (its files are still written).
//! - Any other write error (`> /dev/full`: no space left on device) is an error, which the binary
//!   reports with exit code 2.
//! - Messages on standard error (`wrote …`, progress) never fail the command.

use anyhow::{Result, anyhow};
pub use gonio_io::output::os_message;
use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};

/// Set once standard output's reader has gone away.
static CLOSED: AtomicBool = AtomicBool::new(false);

/// Whether standard output was closed by its reader.
pub fn stdout_closed() -> bool {
    CLOSED.load(Ordering::Relaxed)
}

/// A write to standard output that failed (not a closed pipe).
fn failed(e: &std::io::Error) -> anyhow::Error {
    anyhow!("cannot write standard output: {}", os_message(e))
}

/// An error of a library that wrote to [`Stdout`]: a write error (an `std::io::Error`) as
/// [`out`] reports it, any other error as it is.
pub fn stdout_error(e: anyhow::Error) -> anyhow::Error {
    match e.downcast::<std::io::Error>() {
        Ok(io) => failed(&io),
        Err(e) => e,
    }
}

/// Writes bytes to standard output and flushes them.
///
/// # Errors
/// A write error other than a closed pipe.
pub fn out_bytes(data: &[u8]) -> Result<()> {
    let mut o = Stdout;
    o.write_all(data)
        .and_then(|()| o.flush())
        .map_err(|e| failed(&e))
}

/// Writes text to standard output.
///
/// # Errors
/// A write error other than a closed pipe.
pub fn out(text: &str) -> Result<()> {
    out_bytes(text.as_bytes())
}

/// Flushes standard output.
///
/// # Errors
/// A write error other than a closed pipe.
pub fn flush() -> Result<()> {
    Stdout.flush().map_err(|e| failed(&e))
}

/// Writes a message line to standard error (errors ignored: a message never fails a command).
pub fn note(text: &str) {
    let mut e = std::io::stderr().lock();
    let _ = e.write_all(text.as_bytes());
    let _ = e.write_all(b"\n");
}

/// Standard output as a writer with this module's rules: a closed pipe ends it quietly (every
/// write after it succeeds and writes nothing), every write is flushed (the output set's `-`).
#[derive(Debug, Clone, Copy)]
pub struct Stdout;

impl Stdout {
    fn with(
        f: impl FnOnce(&mut std::io::StdoutLock<'_>) -> std::io::Result<()>,
    ) -> std::io::Result<()> {
        if stdout_closed() {
            return Ok(());
        }
        match f(&mut std::io::stdout().lock()) {
            Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {
                CLOSED.store(true, Ordering::Relaxed);
                Ok(())
            }
            r => r,
        }
    }
}

impl Write for Stdout {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        Stdout::with(|o| o.write_all(buf).and_then(|()| o.flush()))?;
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Stdout::with(|o| o.flush())
    }
}

/// `println!` through [`out`]: `say!("{x} frames")?`.
#[macro_export]
macro_rules! say {
    () => { $crate::term::out("\n") };
    ($($t:tt)*) => { $crate::term::out(&format!("{}\n", format_args!($($t)*))) };
}

/// `eprintln!` through [`note`].
#[macro_export]
macro_rules! note {
    ($($t:tt)*) => { $crate::term::note(&format!($($t)*)) };
}
