//! What an interrupted command leaves behind and must remove: the output set's temporary files
//! not yet renamed into place, the temporary directories being written (a recorded part) and
//! the directories the command created. A process-wide registry, because the one who removes
//! them is a signal handler: the binary installs it (SIGINT, SIGTERM, SIGHUP) and calls
//! [`clean_up_interrupted`] before it exits; this module never installs a handler, prints or
//! exits. A command that drives devices takes the first SIGINT or SIGTERM itself
//! ([`defer_interrupts`]: the handler asks [`hand_over_interrupt`]) to leave them safe and end
//! with [`Interrupted`].
//!
//! ```
//! use gonio_io::output::pending;
//! let d = tempfile::tempdir().unwrap();
//! let made = d.path().join("run");
//! pending::guard_created_dir(&made, &mut || std::fs::create_dir(&made)).unwrap();
//! pending::release_dir(&made); // kept: an interruption no longer removes it
//! assert!(made.is_dir());
//! ```

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicI32;
use std::sync::atomic::Ordering::SeqCst;
use std::sync::{Arc, Mutex, MutexGuard};

/// Temporary files not yet renamed into place.
static FILES: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// The registry of temporary files, locked: an output set adds a file and lists it under one
/// lock, so that a signal's cleanup (which takes the same lock) never misses one.
pub(crate) fn files() -> MutexGuard<'static, Vec<PathBuf>> {
    FILES.lock().unwrap_or_else(|e| e.into_inner())
}

/// A directory to clean up on an interruption.
#[derive(Debug, PartialEq, Eq)]
enum Dir {
    /// A temporary directory: removed with its content.
    Temporary(PathBuf),
    /// A directory the command created: removed if empty.
    Created(PathBuf),
}

/// Directories not yet kept (removed on an interruption, after the temporary files, innermost
/// first).
static DIRS: Mutex<Vec<Dir>> = Mutex::new(Vec::new());

fn dirs() -> MutexGuard<'static, Vec<Dir>> {
    DIRS.lock().unwrap_or_else(|e| e.into_inner())
}

/// Makes a temporary directory with `make` (a part's record being written) and registers it:
/// if the process is interrupted before [`release_dir`], it is removed with its content. The
/// registry is locked while the directory is made, so a signal's cleanup (which takes the same
/// lock) runs before it exists or after it is registered, never between.
///
/// # Errors
/// Those of `make`.
pub fn guard_temporary_dir(
    make: &mut crate::recorder::TempDirMaker<'_>,
) -> std::io::Result<tempfile::TempDir> {
    let mut dirs = dirs();
    let dir = make()?;
    dirs.push(Dir::Temporary(dir.path().to_path_buf()));
    Ok(dir)
}

/// Creates the directory `dir` (the first missing one of a path) with `make` and registers it
/// as one step: if the process is interrupted before [`release_dir`], it is removed if it is
/// empty. The registry is locked while it is made, so a signal's cleanup runs before it exists
/// or after it is registered, never between.
///
/// # Errors
/// Those of `make` (nothing is registered then).
pub fn guard_created_dir(
    dir: &Path,
    make: &mut dyn FnMut() -> std::io::Result<()>,
) -> std::io::Result<()> {
    let mut dirs = dirs();
    make()?;
    dirs.push(Dir::Created(dir.to_path_buf()));
    Ok(())
}

/// The directory `dir` is kept (or already removed): an interruption no longer removes it.
pub fn release_dir(dir: &Path) {
    dirs().retain(|d| match d {
        Dir::Temporary(p) | Dir::Created(p) => p != dir,
    });
}

/// Removes what an interrupted command leaves: the temporary files, then the temporary
/// directories and the empty created ones, the latest first. Holds the locks until the process
/// exits: for the binary's signal handler only, which exits right after. An output set being
/// committed finishes its renames first (it holds the same lock), so an interruption never
/// leaves half a set in place.
pub fn clean_up_interrupted() {
    let mut p = files();
    for f in p.drain(..) {
        let _ = std::fs::remove_file(f);
    }
    let mut dirs = dirs();
    for d in dirs.drain(..).rev() {
        match d {
            Dir::Temporary(p) => {
                let _ = std::fs::remove_dir_all(p);
            }
            Dir::Created(p) => {
                let _ = std::fs::remove_dir(p);
            }
        }
    }
    // Locks held on purpose: nothing renames or creates after this.
    std::mem::forget(dirs);
    std::mem::forget(p);
}

/// The flag of the command that ends itself on the first SIGINT or SIGTERM ([`defer_interrupts`]).
static DEFERRED: Mutex<Option<Arc<AtomicI32>>> = Mutex::new(None);

fn deferred() -> MutexGuard<'static, Option<Arc<AtomicI32>>> {
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

/// For the binary's signal handler: hands SIGINT or SIGTERM `sig` to the command that defers
/// interrupts, if one does and has not had one yet (`true`: the handler leaves the process
/// running); `false`: the handler cleans up and exits.
pub fn hand_over_interrupt(sig: i32) -> bool {
    deferred()
        .as_ref()
        .is_some_and(|f| f.compare_exchange(0, sig, SeqCst, SeqCst).is_ok())
}
