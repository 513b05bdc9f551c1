//! The outputs of one command, written as a set: each to its own temporary file beside its
//! destination, all renamed into place only when every one has been written, so that a failure
//! (an error, a full disk, an interruption) leaves the old files as they were and no temporary
//! file behind.
//!
//! An output is refused before anything is computed when it cannot be replaced safely:
//! - it is one of the command's inputs (same device and inode, whatever the name: `shift-angle
//!   in.csv --json in.csv`, a hard link, `./in.csv`); checked again when the set is committed, for
//!   inputs read later;
//! - it is the command's results store (`--db X --json X`) or one of its SQLite companions,
//!   whether the store exists yet or not ([`Inputs::reserve`]);
//! - it is not a regular file: a directory, a device (`/dev/null`), a FIFO or a socket — writing
//!   one whole by rename would replace the node itself. Write to standard output with `-` and
//!   redirect it instead;
//! - it is a symbolic link: the rename would replace the link, not the file it points to; give
//!   the target's path;
//! - two outputs of the command name one file (`--json x --compensation x`), or both are `-`.
//!
//! New files are created with mode 0666 less the umask (as `>` in a shell would). A directory of
//! simulation outputs must be new or empty, or the command is given `--force`; with `--force` the
//! files of an earlier run that this run does not write (stale frames) are removed when the set
//! is committed. `-` is standard output as the caller gives it (a writer: nothing here prints);
//! what an interruption must remove is registered in [`pending`], whose cleanup the binary's
//! signal handler calls.
//!
//! Errors are `anyhow` errors naming the flag and the user's path, one line each.
//!
//! ```
//! use gonio_io::output::Outputs;
//! let d = tempfile::tempdir().unwrap();
//! let path = d.path().join("a.json");
//! let mut out = Outputs::new(Box::new(std::io::sink()));
//! let id = out.file("--json", &path).unwrap();
//! out.json(id, &[1.5, 2.0]).unwrap();
//! assert!(!path.exists()); // nothing in place before the commit
//! out.commit().unwrap();
//! assert_eq!(std::fs::read_to_string(&path).unwrap(), "[\n  1.5,\n  2.0\n]\n");
//! ```

pub mod pending;

use crate::input::{FileId, Inputs};
use crate::json;
use anyhow::{Result, anyhow, bail};
use serde::Serialize;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// An operating-system error without the temporary file's name (`No space left on device (os
/// error 28)`).
pub fn os_message(e: &std::io::Error) -> String {
    match e.raw_os_error() {
        Some(code) => std::io::Error::from_raw_os_error(code).to_string(),
        None => e.kind().to_string(),
    }
}

/// A write to standard output that failed.
fn stdout_error(e: &std::io::Error) -> anyhow::Error {
    anyhow!("cannot write standard output: {}", os_message(e))
}

/// A handle to one output of a set.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OutId(usize);

#[derive(Debug)]
enum Target {
    Stdout,
    /// Standard output held in an unnamed temporary file until the commit (see
    /// [`Outputs::spool`]).
    Spool(BufWriter<File>),
    File {
        tmp: PathBuf,
        file: Option<BufWriter<File>>,
    },
}

#[derive(Debug)]
struct Item {
    /// The flag that named it (`--json`), for messages.
    flag: String,
    /// The user's path.
    path: PathBuf,
    /// Where the set compares destinations: the file's identity or its absolute path.
    key: Key,
    target: Target,
}

#[derive(Debug, PartialEq, Eq)]
enum Key {
    Stdout,
    Id(FileId),
    Path(PathBuf),
}

/// Files of an earlier run removed at commit: in `dir`, names starting with `prefix` and ending
/// with `suffix` that this set does not write.
#[derive(Debug)]
struct Stale {
    dir: PathBuf,
    prefix: String,
    suffix: String,
}

/// The outputs of one command, written as a set (see the module documentation), and its
/// inputs: what the command read through [`Outputs::inputs`] no output may overwrite.
pub struct Outputs {
    /// The command's inputs (files read, the results store reserved, standard input).
    inputs: Inputs,
    /// Standard output, as the caller gives it (`-`).
    stdout: Box<dyn Write + Send>,
    items: Vec<Item>,
    stale: Vec<Stale>,
    /// Directories this set created (removed again if it is not committed and they are empty).
    created: Vec<PathBuf>,
}

/// What kind of file system node an existing path is, for messages.
fn node_kind(m: &std::fs::Metadata) -> &'static str {
    let t = m.file_type();
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_block_device() || t.is_char_device() {
            return "a device";
        }
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if t.is_dir() {
        "a directory"
    } else if t.is_symlink() {
        "a symbolic link"
    } else {
        "not a regular file"
    }
}

fn temp_name(dir: &Path) -> PathBuf {
    static COUNT: AtomicU64 = AtomicU64::new(0);
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    dir.join(format!(
        ".gonio-{}-{}-{nanos:08x}.tmp",
        std::process::id(),
        COUNT.fetch_add(1, Ordering::Relaxed)
    ))
}

/// Creates a new temporary file in `dir` with mode 0666 less the umask.
fn create_temp(dir: &Path) -> std::io::Result<(PathBuf, File)> {
    let mut opts = std::fs::OpenOptions::new();
    opts.write(true).create_new(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        opts.mode(0o666);
    }
    loop {
        let p = temp_name(dir);
        match opts.open(&p) {
            Ok(f) => return Ok((p, f)),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(e),
        }
    }
}

fn parent_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Refuses a destination that exists and is not a regular file, is a symbolic link, or is an
/// input of the command.
fn check_destination(inputs: &Inputs, flag: &str, path: &Path) -> Result<Option<FileId>> {
    let shown = path.display();
    if let Some(what) = inputs.reserved(path) {
        bail!(
            "{flag} {shown}: is the command's {what}: writing it would destroy the store; choose another output file"
        );
    }
    let Ok(m) = std::fs::symlink_metadata(path) else {
        return Ok(None);
    };
    if m.file_type().is_symlink() {
        bail!(
            "{flag} {shown}: is a symbolic link: gonio replaces an output whole (a new file renamed into place) and would replace the link; give the path of the file it points to"
        );
    }
    if !m.is_file() {
        bail!(
            "{flag} {shown}: is {}: expected a regular file (use - for standard output and redirect it)",
            node_kind(&m)
        );
    }
    let id = FileId::of(path);
    if let Some(id) = id
        && let Some(input) = inputs.recorded(id)
    {
        bail!(
            "{flag} {shown}: is also an input of this command ({input}): writing it would destroy the input; choose another output file"
        );
    }
    Ok(id)
}

impl std::fmt::Debug for Outputs {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Outputs")
            .field("inputs", &self.inputs)
            .field("items", &self.items)
            .field("stale", &self.stale)
            .field("created", &self.created)
            .finish_non_exhaustive()
    }
}

impl Outputs {
    /// An empty set writing `-` to `stdout`.
    pub fn new(stdout: Box<dyn Write + Send>) -> Outputs {
        Outputs::with_inputs(Inputs::new(), stdout)
    }

    /// An empty set whose command has read `inputs` already, writing `-` to `stdout`.
    pub fn with_inputs(inputs: Inputs, stdout: Box<dyn Write + Send>) -> Outputs {
        Outputs {
            inputs,
            stdout,
            items: Vec::new(),
            stale: Vec::new(),
            created: Vec::new(),
        }
    }

    /// The command's inputs: read every input through them (the formats' `load` and `read`
    /// take them), so that no output of the set overwrites one.
    pub fn inputs(&self) -> &Inputs {
        &self.inputs
    }

    /// Adds the output `path` named by `flag` (`--json`), `-` for standard output. The file is
    /// created as a temporary file beside its destination now, so that an unwritable directory
    /// is found before any work.
    ///
    /// # Errors
    /// The destination is an input, not a regular file, a symbolic link, the destination of
    /// another output of the set, or its directory cannot be written.
    pub fn file(&mut self, flag: &str, path: &Path) -> Result<OutId> {
        let shown = path.display();
        let key = if path.as_os_str() == "-" {
            Key::Stdout
        } else {
            match check_destination(&self.inputs, flag, path)? {
                Some(id) => Key::Id(id),
                None => {
                    let dir = parent_of(path);
                    let abs = std::fs::canonicalize(&dir).map_err(|e| {
                        anyhow!(
                            "{flag} {shown}: cannot write into {}: {}",
                            dir.display(),
                            os_message(&e)
                        )
                    })?;
                    Key::Path(abs.join(path.file_name().unwrap_or_default()))
                }
            }
        };
        if let Some(other) = self.items.iter().find(|i| i.key == key) {
            if key == Key::Stdout {
                bail!(
                    "{flag} - and {} -: two outputs to standard output; write one of them to a file",
                    other.flag
                );
            }
            bail!(
                "{flag} {shown}: the same file as {} {}: give each output its own file",
                other.flag,
                other.path.display()
            );
        }
        let target = if key == Key::Stdout {
            Target::Stdout
        } else {
            if path.file_name().is_none() {
                bail!("{flag} {shown}: expected a file name");
            }
            let dir = parent_of(path);
            // Created and listed under one lock: a signal's cleanup never misses a new file.
            let mut p = pending::files();
            let (tmp, f) = create_temp(&dir).map_err(|e| {
                anyhow!(
                    "cannot write {shown} (in {}): {}",
                    dir.display(),
                    os_message(&e)
                )
            })?;
            p.push(tmp.clone());
            drop(p);
            Target::File {
                tmp,
                file: Some(BufWriter::new(f)),
            }
        };
        self.items.push(Item {
            flag: flag.to_string(),
            path: path.to_path_buf(),
            key,
            target,
        });
        Ok(OutId(self.items.len() - 1))
    }

    /// [`Outputs::file`] for an optional flag (`--json` given or not).
    ///
    /// # Errors
    /// As [`Outputs::file`].
    pub fn optional(&mut self, flag: &str, path: Option<&Path>) -> Result<Option<OutId>> {
        path.map(|p| self.file(flag, p)).transpose()
    }

    /// Whether an optional output goes to standard output.
    pub fn to_stdout(&self, id: Option<OutId>) -> bool {
        id.is_some_and(|i| self.is_stdout(i))
    }

    /// Prepares the output directory `dir` (named by `flag`): created when missing; an existing
    /// one must be empty unless `force` is set.
    ///
    /// # Errors
    /// `dir` is a file, or a non-empty directory without `force`, or cannot be created.
    pub fn dir(&mut self, flag: &str, dir: &Path, force: bool) -> Result<()> {
        let shown = dir.display();
        match std::fs::symlink_metadata(dir) {
            Ok(m) if m.is_dir() => {
                let n = std::fs::read_dir(dir)
                    .map_err(|e| anyhow!("{flag} {shown}: cannot read: {}", os_message(&e)))?
                    .count();
                if n > 0 && !force {
                    bail!(
                        "{flag} {shown}: the directory is not empty ({n} entries): choose a new directory, or give --force to write into it (files of an earlier run that this one does not write are then removed)"
                    );
                }
            }
            Ok(m) if m.file_type().is_symlink() && dir.is_dir() => {
                if std::fs::read_dir(dir).map_or(0, |d| d.count()) > 0 && !force {
                    bail!(
                        "{flag} {shown}: the directory is not empty: choose a new directory, or give --force"
                    );
                }
            }
            Ok(m) => bail!("{flag} {shown}: is {}: expected a directory", node_kind(&m)),
            Err(_) => {
                // Remember the first missing ancestor: it is removed again on failure.
                let mut first_missing = dir.to_path_buf();
                while let Some(p) = first_missing.parent() {
                    if p.as_os_str().is_empty() || p.exists() {
                        break;
                    }
                    first_missing = p.to_path_buf();
                }
                pending::guard_created_dir(&first_missing, &mut || std::fs::create_dir_all(dir))
                    .map_err(|e| {
                        anyhow!(
                            "{flag} {shown}: cannot create the directory: {}",
                            os_message(&e)
                        )
                    })?;
                self.created.push(first_missing);
            }
        }
        Ok(())
    }

    /// Removes, when the set is committed, the files of `dir` whose names start with `prefix`
    /// and end with `suffix` and that the set does not write (frames of an earlier, longer run).
    pub fn remove_stale(&mut self, dir: &Path, prefix: &str, suffix: &str) {
        self.stale.push(Stale {
            dir: dir.to_path_buf(),
            prefix: prefix.to_string(),
            suffix: suffix.to_string(),
        });
    }

    /// Whether the output goes to standard output (`-`).
    pub fn is_stdout(&self, id: OutId) -> bool {
        matches!(self.items[id.0].target, Target::Stdout | Target::Spool(_))
    }

    /// The user's path of an output.
    pub fn path(&self, id: OutId) -> &Path {
        &self.items[id.0].path
    }

    /// Appends `data` to the output (standard output: written and flushed now).
    ///
    /// # Errors
    /// A write error (a full disk), naming the user's path.
    pub fn write(&mut self, id: OutId, data: &[u8]) -> Result<()> {
        let item = &mut self.items[id.0];
        match &mut item.target {
            Target::Stdout => self
                .stdout
                .write_all(data)
                .and_then(|()| self.stdout.flush())
                .map_err(|e| stdout_error(&e)),
            Target::Spool(f) => f
                .write_all(data)
                .map_err(|e| anyhow!("cannot spool standard output: {}", os_message(&e))),
            Target::File { file, .. } => {
                let f = file
                    .as_mut()
                    .ok_or_else(|| anyhow!("{}: already closed", item.path.display()))?;
                f.write_all(data).map_err(|e| {
                    anyhow!("cannot write {}: {}", item.path.display(), os_message(&e))
                })
            }
        }
    }

    /// Holds an output that is standard output in an unnamed temporary file (deleted by the
    /// system when the process ends, however it ends) and copies it to standard output only at
    /// the commit: for an output written a piece at a time from a source that can fail half-way
    /// (a store read page by page), so that a failure writes nothing. Other outputs are
    /// unchanged.
    ///
    /// # Errors
    /// The temporary file cannot be created.
    pub fn spool(&mut self, id: OutId) -> Result<()> {
        let item = &mut self.items[id.0];
        if matches!(item.target, Target::Stdout) {
            let f = tempfile::tempfile().map_err(|e| {
                anyhow!(
                    "cannot create a temporary file for standard output: {}",
                    os_message(&e)
                )
            })?;
            item.target = Target::Spool(BufWriter::new(f));
        }
        Ok(())
    }

    /// Adds the output `path` with its whole content `data`, written and closed now (for sets of
    /// many files: frames hold no open file until the commit).
    ///
    /// # Errors
    /// As [`Outputs::file`] and [`Outputs::write`].
    pub fn put(&mut self, flag: &str, path: &Path, data: &[u8]) -> Result<OutId> {
        let id = self.file(flag, path)?;
        self.write(id, data)?;
        self.close(id)?;
        Ok(id)
    }

    /// Flushes and closes an output's file now (it is still renamed only at the commit).
    ///
    /// # Errors
    /// A write error, naming the user's path.
    pub fn close(&mut self, id: OutId) -> Result<()> {
        let item = &mut self.items[id.0];
        if let Target::File { file, .. } = &mut item.target
            && let Some(mut f) = file.take()
        {
            f.flush()
                .and_then(|_| f.get_ref().sync_all())
                .map_err(|e| anyhow!("cannot write {}: {}", item.path.display(), os_message(&e)))?;
        }
        Ok(())
    }

    /// Writes `value` as pretty JSON with a final newline ([`json::to_bytes`]: every number
    /// finite).
    ///
    /// # Errors
    /// A number that is not finite (naming its field), or a write error.
    pub fn json<T: Serialize + ?Sized>(&mut self, id: OutId, value: &T) -> Result<()> {
        let bytes = json::to_bytes(value).map_err(|e| {
            anyhow!(
                "{}: nothing was written: {e}",
                self.items[id.0].path.display()
            )
        })?;
        self.write(id, &bytes)
    }

    /// Writes `value` as pretty JSON where a non-finite number means "undefined" and is written
    /// as `null` on purpose (a simulator's ground truth: the ring's column of a frame without a
    /// ring). Results use [`Outputs::json`].
    ///
    /// # Errors
    /// A write error.
    pub fn json_with_nulls<T: Serialize + ?Sized>(&mut self, id: OutId, value: &T) -> Result<()> {
        let mut v = serde_json::to_vec_pretty(value)?;
        v.push(b'\n');
        self.write(id, &v)
    }

    /// Writes a calibration's outputs, those asked for: the certificate (JSON) and its
    /// compensation table (CSV).
    ///
    /// # Errors
    /// A number that is not finite, or a write error.
    pub fn certificate(
        &mut self,
        json: Option<OutId>,
        compensation: Option<OutId>,
        cert: &gonio_calib::certificate::Certificate,
    ) -> Result<()> {
        if let Some(j) = json {
            self.json(j, cert)?;
        }
        if let Some(c) = compensation {
            self.write(c, crate::formats::compensation::csv(cert).as_bytes())?;
        }
        Ok(())
    }

    /// Writes CSV text: a header and rows.
    ///
    /// # Errors
    /// A write error.
    pub fn csv(&mut self, id: OutId, header: &[&str], rows: &[Vec<String>]) -> Result<()> {
        let mut s = header.join(",");
        s.push('\n');
        for r in rows {
            s.push_str(&r.join(","));
            s.push('\n');
        }
        self.write(id, s.as_bytes())
    }

    /// Renames every output into place (after checking again that none is an input read since
    /// it was added) and removes stale files. Nothing is renamed unless every output was written
    /// and flushed.
    ///
    /// # Errors
    /// A write, flush or rename error, naming the user's path; the temporary files are removed.
    pub fn commit(mut self) -> Result<()> {
        // Flush and close every file first: a full disk shows here.
        for k in 0..self.items.len() {
            match &mut self.items[k].target {
                Target::Stdout => self.stdout.flush().map_err(|e| stdout_error(&e))?,
                Target::Spool(f) => f
                    .flush()
                    .map_err(|e| anyhow!("cannot spool standard output: {}", os_message(&e)))?,
                Target::File { .. } => self.close(OutId(k))?,
            }
        }
        for item in &self.items {
            if matches!(item.target, Target::File { .. }) {
                check_destination(&self.inputs, &item.flag, &item.path)?;
            }
        }
        for item in &mut self.items {
            if let Target::Spool(f) = &mut item.target {
                copy_to_stdout(f.get_mut(), &mut self.stdout)?;
            }
        }
        let mut p = pending::files();
        for item in &self.items {
            if let Target::File { tmp, .. } = &item.target {
                std::fs::rename(tmp, &item.path).map_err(|e| {
                    anyhow!("cannot write {}: {}", item.path.display(), os_message(&e))
                })?;
                p.retain(|x| x != tmp);
            }
        }
        for s in &self.stale {
            let written: Vec<&Path> = self.items.iter().map(|i| i.path.as_path()).collect();
            if let Ok(entries) = std::fs::read_dir(&s.dir) {
                for e in entries.flatten() {
                    let name = e.file_name().to_string_lossy().to_string();
                    let path = e.path();
                    if name.starts_with(&s.prefix)
                        && name.ends_with(&s.suffix)
                        && !written.iter().any(|w| w.file_name() == path.file_name())
                    {
                        let _ = std::fs::remove_file(&path);
                    }
                }
            }
        }
        drop(p);
        self.items.clear();
        for d in self.created.drain(..) {
            pending::release_dir(&d);
        }
        Ok(())
    }
}

/// Copies a spooled standard output from its start to standard output, a block at a time.
fn copy_to_stdout(f: &mut File, stdout: &mut dyn Write) -> Result<()> {
    use std::io::{Read, Seek, SeekFrom};
    let spool =
        |e: std::io::Error| anyhow!("cannot read spooled standard output: {}", os_message(&e));
    f.seek(SeekFrom::Start(0)).map_err(spool)?;
    let mut buf = vec![0u8; 1 << 16];
    loop {
        let n = f.read(&mut buf).map_err(spool)?;
        if n == 0 {
            return stdout.flush().map_err(|e| stdout_error(&e));
        }
        stdout
            .write_all(&buf[..n])
            .and_then(|()| stdout.flush())
            .map_err(|e| stdout_error(&e))?;
    }
}

impl Drop for Outputs {
    /// An uncommitted set removes its temporary files (and the directories it created, if
    /// empty).
    fn drop(&mut self) {
        let mut p = pending::files();
        for item in &mut self.items {
            if let Target::File { tmp, file } = &mut item.target {
                drop(file.take());
                let _ = std::fs::remove_file(&*tmp);
                p.retain(|x| x != tmp);
            }
        }
        drop(p);
        for d in self.created.iter().rev() {
            let _ = std::fs::remove_dir(d);
            pending::release_dir(d);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_set_is_written_whole_or_not_at_all() {
        let d = tempfile::tempdir().unwrap();
        let a = d.path().join("a.json");
        std::fs::write(&a, "old").unwrap();
        {
            let mut o = Outputs::new(Box::new(std::io::sink()));
            let ia = o.file("--json", &a).unwrap();
            o.write(ia, b"new").unwrap();
            // The second output's directory is missing: refused before anything is written.
            assert!(
                o.file("--compensation", &d.path().join("no/c.csv"))
                    .is_err()
            );
        }
        assert_eq!(std::fs::read_to_string(&a).unwrap(), "old");
        assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 1, "temp left");
        let mut o = Outputs::new(Box::new(std::io::sink()));
        let ia = o.file("--json", &a).unwrap();
        let e = o.file("--compensation", &d.path().join("./a.json"));
        assert!(
            e.unwrap_err()
                .to_string()
                .contains("the same file as --json")
        );
        o.write(ia, b"two").unwrap();
        o.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&a).unwrap(), "two");
        assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 1);
    }

    #[test]
    fn directories_and_devices_are_refused() {
        let d = tempfile::tempdir().unwrap();
        let mut o = Outputs::new(Box::new(std::io::sink()));
        let e = o.file("--json", d.path()).unwrap_err().to_string();
        assert!(e.contains("is a directory"), "{e}");
        #[cfg(unix)]
        {
            let e = o
                .file("--json", Path::new("/dev/null"))
                .unwrap_err()
                .to_string();
            assert!(e.contains("is a device"), "{e}");
        }
    }
}
