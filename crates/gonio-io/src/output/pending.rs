//! What an interrupted command leaves behind and must remove: the output set's temporary files
//! not yet renamed into place, the temporary directories being written (a recorded part) and
//! the directories the command created. A process-wide registry, because the one who removes
//! them is a signal handler: the binary installs it (SIGINT, SIGTERM, SIGHUP) and calls
//! [`clean_up_interrupted`] before it exits; this module never installs a handler, prints or
//! exits.
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
use std::sync::{Mutex, MutexGuard};

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
