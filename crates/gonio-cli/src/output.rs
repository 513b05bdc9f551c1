//! A command's outputs: [`gonio_io::output::Outputs`] (the atomic output set that never
//! overwrites an input) writing `-` through [`crate::term`] (a closed pipe ends the output
//! quietly), and the signal handler that removes what an interrupted command leaves
//! ([`gonio_io::output::pending`]) and exits with status 128 + the signal.
//!
//! A command that drives devices takes the first SIGINT or SIGTERM itself
//! ([`defer_interrupts`]) to leave them safe and end with [`Interrupted`]; a second signal
//! removes the pending outputs and exits at once.

use gonio_io::output::pending;
pub use gonio_io::output::pending::Interrupted;
pub use gonio_io::output::{OutId, os_message};
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::AtomicI32;

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
                        if sig != SIGHUP && pending::hand_over_interrupt(sig) {
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

/// [`pending::defer_interrupts`] with the signal handler installed.
pub fn defer_interrupts(flag: Arc<AtomicI32>) -> pending::DeferredInterrupts {
    install_signal_cleanup();
    pending::defer_interrupts(flag)
}

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
