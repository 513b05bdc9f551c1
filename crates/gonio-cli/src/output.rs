//! A command's outputs: [`gonio_io::output::Outputs`] (the atomic output set that never
//! overwrites an input) writing `-` through [`crate::term`] (a closed pipe ends the output
//! quietly), and the signal handler that removes what an interrupted command leaves
//! ([`gonio_io::output::pending`]) and exits with status 128 + the signal.
//!
//! A command that drives devices takes the first SIGINT or SIGTERM itself
//! ([`defer_interrupts`]) to leave them safe and end with [`Interrupted`]; a second signal
//! removes the pending outputs and exits at once.

use gonio_io::output::pending;
pub use gonio_io::output::{OutId, os_message};
use std::path::Path;
use std::sync::atomic::AtomicI32;
use std::sync::atomic::Ordering::SeqCst;
use std::sync::{Arc, Mutex};

/// The outputs of one command, written as a set; every method of
/// [`gonio_io::output::Outputs`] through `Deref`.
#[derive(Debug)]
pub struct Outputs(gonio_io::output::Outputs);

impl Outputs {
    /// An empty set (and the signal handler that removes temporary files, installed once).
    pub fn new() -> Outputs {
        Outputs::with_inputs(gonio_io::input::Inputs::new())
    }

    /// An empty set whose command has read `inputs` already (the signal handler installed
    /// once).
    pub fn with_inputs(inputs: gonio_io::input::Inputs) -> Outputs {
        install_signal_cleanup();
        Outputs(gonio_io::output::Outputs::with_inputs(
            inputs,
            Box::new(crate::term::Stdout),
        ))
    }

    /// Renames every output into place ([`gonio_io::output::Outputs::commit`]).
    ///
    /// # Errors
    /// A write, flush or rename error, naming the user's path.
    pub fn commit(self) -> anyhow::Result<()> {
        self.0.commit()
    }
}

impl Default for Outputs {
    fn default() -> Self {
        Outputs::new()
    }
}

impl std::ops::Deref for Outputs {
    type Target = gonio_io::output::Outputs;
    fn deref(&self) -> &Self::Target {
        &self.0
    }
}

impl std::ops::DerefMut for Outputs {
    fn deref_mut(&mut self) -> &mut Self::Target {
        &mut self.0
    }
}

/// Installs (once) the handler that removes pending temporary files and directories on SIGINT,
/// SIGTERM and SIGHUP and then exits with status 128 + the signal. A set being committed
/// finishes its renames first (the handler waits for the same lock), so a signal never leaves
/// half a set in place. While a command defers interrupts ([`defer_interrupts`]), the first
/// SIGINT or SIGTERM is handed to it instead, and only a second one ends the process so.
pub fn install_signal_cleanup() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        #[cfg(unix)]
        {
            use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
            if let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP])
            {
                std::thread::spawn(move || {
                    for sig in signals.forever() {
                        if sig != SIGHUP
                            && deferred()
                                .as_ref()
                                .is_some_and(|f| f.compare_exchange(0, sig, SeqCst, SeqCst).is_ok())
                        {
                            continue;
                        }
                        pending::clean_up_interrupted();
                        std::process::exit(128 + sig);
                    }
                });
            }
        }
    });
}

/// The flag of the command that ends itself on the first SIGINT or SIGTERM ([`defer_interrupts`]).
static DEFERRED: Mutex<Option<Arc<AtomicI32>>> = Mutex::new(None);

fn deferred() -> std::sync::MutexGuard<'static, Option<Arc<AtomicI32>>> {
    DEFERRED.lock().unwrap_or_else(|e| e.into_inner())
}

/// While held, interrupts are the command's to handle ([`defer_interrupts`]).
#[derive(Debug)]
#[must_use = "interrupts are deferred only while this is held"]
pub struct DeferredInterrupts(());

impl Drop for DeferredInterrupts {
    fn drop(&mut self) {
        deferred().take();
    }
}

/// Hands the first SIGINT or SIGTERM to the command: its number is stored in `flag` (which
/// must hold 0), and the command ends itself, leaving its devices safe; a second signal (or
/// SIGHUP) removes the pending outputs and exits at once with 128 + the signal. Until the
/// guard is dropped.
pub fn defer_interrupts(flag: Arc<AtomicI32>) -> DeferredInterrupts {
    install_signal_cleanup();
    *deferred() = Some(flag);
    DeferredInterrupts(())
}

/// A command that ended because it was interrupted (SIGINT, SIGTERM) after leaving its
/// devices safe: the binary prints the message and exits with 128 + the signal.
#[derive(Debug)]
pub struct Interrupted {
    /// The signal's number.
    pub signal: i32,
    /// What was done (one line).
    pub message: String,
}

impl std::fmt::Display for Interrupted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for Interrupted {}

/// [`pending::guard_temporary_dir`] with the signal handler installed.
///
/// # Errors
/// Those of `make`.
pub fn guard_temporary_dir(
    make: &mut gonio_io::recorder::TempDirMaker<'_>,
) -> std::io::Result<tempfile::TempDir> {
    install_signal_cleanup();
    pending::guard_temporary_dir(make)
}

/// [`pending::guard_created_dir`] with the signal handler installed.
///
/// # Errors
/// Those of `make` (nothing is registered then).
pub fn guard_created_dir(
    dir: &Path,
    make: &mut dyn FnMut() -> std::io::Result<()>,
) -> std::io::Result<()> {
    install_signal_cleanup();
    pending::guard_created_dir(dir, make)
}

/// [`pending::release_dir`].
pub fn release_dir(dir: &Path) {
    pending::release_dir(dir);
}
