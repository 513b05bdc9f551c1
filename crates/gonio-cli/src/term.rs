//! The terminal: every byte gonio writes to standard output or standard error goes through here.
//!
//! - A closed pipe (`gonio … | head -1`) ends the output quietly: later writes are skipped and
//!   the command finishes with exit code 0 (its files are still written).
//! - Any other write error (`> /dev/full`: no space left on device) is an error, which the binary
//!   reports with exit code 2.
//! - Messages on standard error (`wrote …`, progress) never fail the command.

use anyhow::{Result, anyhow};
use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};

/// Set once standard output's reader has gone away.
static CLOSED: AtomicBool = AtomicBool::new(false);

/// Whether standard output was closed by its reader.
pub fn stdout_closed() -> bool {
    CLOSED.load(Ordering::Relaxed)
}

fn handle(r: std::io::Result<()>) -> Result<()> {
    match r {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {
            CLOSED.store(true, Ordering::Relaxed);
            Ok(())
        }
        Err(e) => Err(anyhow!("cannot write standard output: {}", os_message(&e))),
    }
}

/// Writes bytes to standard output and flushes them.
///
/// # Errors
/// A write error other than a closed pipe.
pub fn out_bytes(data: &[u8]) -> Result<()> {
    if stdout_closed() {
        return Ok(());
    }
    let mut o = std::io::stdout().lock();
    handle(o.write_all(data).and_then(|_| o.flush()))
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
    if stdout_closed() {
        return Ok(());
    }
    handle(std::io::stdout().lock().flush())
}

/// Writes a message line to standard error (errors ignored: a message never fails a command).
pub fn note(text: &str) {
    let mut e = std::io::stderr().lock();
    let _ = e.write_all(text.as_bytes());
    let _ = e.write_all(b"\n");
}

/// An operating-system error without the temporary file's name (`No space left on device (os
/// error 28)`).
pub fn os_message(e: &std::io::Error) -> String {
    match e.raw_os_error() {
        Some(code) => std::io::Error::from_raw_os_error(code).to_string(),
        None => e.kind().to_string(),
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
