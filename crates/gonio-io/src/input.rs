//! Reading input files: one size limit per kind of file, checked before reading and the same
//! from the command line and from Python (the table is in `docs/inputs-and-outputs.md`), UTF-8
//! text with the line of a bad byte, and [`Inputs`], the record of what one command or one
//! Python call read: the binary's output set (`gonio_cli::output::Outputs`) refuses an output
//! that is one of its inputs. Errors are one line naming the file (`NAME:1:1: …`).

use anyhow::{Context, Result, anyhow};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Largest text input, in bytes: 256 MiB. Every CSV (polygon readings; head readings, for
/// `selfcal` and `joint` alike; samples; angle logs), TOML and JSON file has this limit, from
/// the command line and from Python. The largest head readings gonio describes, 360 heads
/// (`formats::heads::MAX_HEADS`) at 36,000 positions over two turns, are a file of ≈ 237 MiB
/// (reading and solving it takes ≈ 2 GiB of memory); 10 turns of 12 heads ≈ 50 MB. Budget and instrument files have their own, smaller limit
/// (`gonio_uncertainty::limits::MAX_FILE_BYTES`), images one from the sensor's size.
pub const MAX_TEXT_BYTES: usize = 256 << 20;

/// Identity of a file: device and inode (Unix), so that two names of one file compare equal.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct FileId {
    /// Device.
    pub dev: u64,
    /// Inode.
    pub ino: u64,
}

impl FileId {
    /// The identity of the file at `path` (following symbolic links), if it exists.
    pub fn of(path: &Path) -> Option<FileId> {
        #[cfg(unix)]
        {
            use std::os::unix::fs::MetadataExt;
            std::fs::metadata(path).ok().map(|m| FileId {
                dev: m.dev(),
                ino: m.ino(),
            })
        }
        #[cfg(not(unix))]
        {
            let _ = path;
            None
        }
    }
}

/// The inputs of one command, or of one call of the Python module: the files it read (its
/// outputs may not overwrite them), the files it reserved (its results store), and whether it
/// read standard input (which can be read once). The caller holds it for as long as the command
/// or the call lasts, and everything it read is forgotten with it: a long Python process that
/// reads 10,000 files keeps none of them, and reads `-` again in its next call.
///
/// Shared by reference (`&Inputs`): the record is behind a lock, so that a file read on another
/// thread is recorded too.
///
/// ```
/// use gonio_io::input::Inputs;
/// let dir = tempfile::tempdir().unwrap();
/// let p = dir.path().join("a.csv");
/// std::fs::write(&p, "x\n1\n").unwrap();
/// let inputs = Inputs::new();
/// assert_eq!(inputs.read_text(&p).unwrap(), "x\n1\n");
/// let id = gonio_io::input::FileId::of(&p).unwrap();
/// assert_eq!(inputs.recorded(id).as_deref(), p.to_str());
/// assert_eq!(Inputs::new().recorded(id), None);
/// ```
#[derive(Debug, Default)]
pub struct Inputs {
    state: Mutex<State>,
}

#[derive(Debug, Default)]
struct State {
    /// Every file read: its identity and its name as the user gave it.
    read: Vec<(FileId, String)>,
    /// Files no output may name, even before they exist (the results store and its SQLite
    /// companions): the absolute path (its directory resolved) and what reserved it.
    reserved: Vec<(PathBuf, String)>,
    /// Standard input was read.
    stdin_read: bool,
}

/// `path` with its directory resolved (symbolic links, `.`, `..`), if the directory exists.
pub fn absolute(path: &Path) -> Option<PathBuf> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let name = path.file_name()?;
    std::fs::canonicalize(dir).ok().map(|d| d.join(name))
}

impl Inputs {
    /// Nothing read yet.
    pub fn new() -> Inputs {
        Inputs::default()
    }

    fn state(&self) -> std::sync::MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Records `path` as an input (outputs will refuse to overwrite it). `-` (standard input)
    /// and paths that do not exist are not recorded. Reading through [`Inputs::read_bytes`] or
    /// [`Inputs::read_text`] records the file; call this for inputs read otherwise (images,
    /// directories of frames).
    pub fn record(&self, path: &Path) {
        if path.as_os_str() == "-" {
            return;
        }
        if let Some(id) = FileId::of(path) {
            let mut s = self.state();
            if !s.read.iter().any(|(i, _)| *i == id) {
                s.read.push((id, path.display().to_string()));
            }
        }
    }

    /// The input file with identity `id`, if one was read and its name still names it: its
    /// name as given. (An input deleted since, whose inode a new file took, is not that input.)
    pub fn recorded(&self, id: FileId) -> Option<String> {
        self.state()
            .read
            .iter()
            .find(|(i, n)| *i == id && FileId::of(Path::new(n)) == Some(id))
            .map(|(_, n)| n.clone())
    }

    /// How many files were recorded.
    pub fn len(&self) -> usize {
        self.state().read.len()
    }

    /// Whether no file was recorded.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Reserves `path` (named by `what`, e.g. `results store (--db results.sqlite)`): no
    /// output may name it or its `-wal`, `-shm` and `-journal` companions, whether it exists
    /// yet or not (the command may create it). An existing file is also recorded as an input.
    pub fn reserve(&self, path: &Path, what: &str) {
        self.record(path);
        for suffix in ["", "-wal", "-shm", "-journal"] {
            let mut p = path.as_os_str().to_owned();
            p.push(suffix);
            let p = PathBuf::from(p);
            self.record(&p);
            if let Some(abs) = absolute(&p) {
                self.state().reserved.push((abs, what.to_string()));
            }
        }
    }

    /// What reserved `path` (see [`Inputs::reserve`]), if it is reserved.
    pub fn reserved(&self, path: &Path) -> Option<String> {
        let s = self.state();
        if s.reserved.is_empty() {
            return None;
        }
        let abs = absolute(path)?;
        let id = FileId::of(path);
        s.reserved
            .iter()
            .find(|(p, _)| *p == abs || (id.is_some() && FileId::of(p) == id))
            .map(|(_, w)| w.clone())
    }

    /// Reads a whole file, or standard input for `-`, as bytes, refusing one of more than
    /// `limit` bytes before reading it (a file by its size, a pipe after `limit` + 1 bytes),
    /// and records it as an input.
    ///
    /// # Errors
    /// As [`read_file`]; `-` when standard input was read before by this holder.
    pub fn read_bytes(&self, path: &Path, limit: usize) -> Result<Vec<u8>> {
        if path.as_os_str() != "-" {
            let data = read_file(path, limit)?;
            self.record(path);
            return Ok(data);
        }
        // Standard input can be read once: `-` for two inputs would give the second nothing.
        if std::mem::replace(&mut self.state().stdin_read, true) {
            return Err(anyhow!(
                "-: standard input is given for two inputs; it can be read only once: give the other input as a file"
            ));
        }
        let mut data = Vec::new();
        std::io::stdin()
            .lock()
            .take(limit as u64 + 1)
            .read_to_end(&mut data)
            .context("cannot read standard input")?;
        if data.len() > limit {
            return Err(too_big(
                "-",
                limit,
                format!("the input goes on beyond {limit} bytes"),
            ));
        }
        Ok(data)
    }

    /// Reads a whole text file (or standard input for `-`): at most [`MAX_TEXT_BYTES`], UTF-8,
    /// a byte-order mark skipped.
    ///
    /// # Errors
    /// As [`Inputs::read_bytes`] and [`decode`].
    pub fn read_text(&self, path: &Path) -> Result<String> {
        let bytes = self.read_bytes(path, MAX_TEXT_BYTES)?;
        decode(&path.display().to_string(), &bytes)
    }

    /// Reads a text file and parses it with `parse(name, text)`, the file's name as given
    /// naming it in errors (the `load` of every format).
    ///
    /// # Errors
    /// As [`Inputs::read_text`] and `parse`.
    pub fn load<T>(&self, path: &Path, parse: impl FnOnce(&str, &str) -> Result<T>) -> Result<T> {
        let text = self.read_text(path)?;
        parse(&path.display().to_string(), &text)
    }
}

/// Reads a whole file (not standard input) as bytes, refusing one of more than `limit` bytes
/// before reading it (a regular file by its size, anything else after `limit` + 1 bytes). It
/// records nothing: [`Inputs::read_bytes`] reads and records; a caller that reads its inputs
/// with this (the frames of a directory, read one at a time) records them with
/// [`Inputs::record`].
///
/// # Errors
/// The file cannot be read, is a directory, or is too large (`NAME:1:1: the file is … bytes,
/// more than the limit of … bytes`).
pub fn read_file(path: &Path, limit: usize) -> Result<Vec<u8>> {
    let name = path.display();
    let f = std::fs::File::open(path).with_context(|| format!("cannot read {name}"))?;
    let m = f
        .metadata()
        .with_context(|| format!("cannot read {name}"))?;
    if m.is_dir() {
        return Err(anyhow!("{name}: is a directory: expected a file"));
    }
    let shown = name.to_string();
    if m.is_file() && m.len() > limit as u64 {
        return Err(too_big(
            &shown,
            limit,
            format!("the file is {} bytes", m.len()),
        ));
    }
    let mut data = Vec::new();
    f.take(limit as u64 + 1)
        .read_to_end(&mut data)
        .with_context(|| format!("cannot read {name}"))?;
    if data.len() > limit {
        return Err(too_big(
            &shown,
            limit,
            format!("the input goes on beyond {limit} bytes"),
        ));
    }
    Ok(data)
}

fn too_big(name: &str, limit: usize, what: String) -> anyhow::Error {
    anyhow!("{name}:1:1: {what}, more than the limit of {limit} bytes")
}

/// The UTF-8 text of `bytes` (a leading byte-order mark skipped); `name` names the input in the
/// error, which gives the line and column of the first bad byte.
///
/// # Errors
/// UTF-16 or invalid UTF-8 (`NAME:LINE:COL: invalid UTF-8 (byte 0xE9): …`).
pub fn decode(name: &str, bytes: &[u8]) -> Result<String> {
    gonio_core::text::decode_utf8(bytes)
        .map(str::to_string)
        .map_err(|e| anyhow!("{name}:{e}"))
}

/// Formats an error and its causes on one line, at most [`MAX_ERROR_CHARS`] characters (echoed
/// input beyond that is cut).
pub fn one_line(e: &anyhow::Error) -> String {
    let mut s = String::new();
    for (i, c) in e.chain().enumerate() {
        if i > 0 {
            s.push_str(": ");
        }
        for ch in c.to_string().chars() {
            match ch {
                '\n' | '\r' | '\t' => s.push(' '),
                // Other control characters from the input (a DEL in a key) are shown escaped.
                ch if ch.is_control() => s.push_str(&ch.escape_unicode().to_string()),
                ch => s.push(ch),
            }
        }
    }
    cap(&s)
}

/// Longest error line, in characters.
pub const MAX_ERROR_CHARS: usize = 500;

/// `s` cut to at most [`MAX_ERROR_CHARS`] characters: its beginning (where the file, line and
/// column are) and its end (what was expected), the middle replaced by `… (N characters) …`.
pub fn cap(s: &str) -> String {
    let n = s.chars().count();
    if n <= MAX_ERROR_CHARS {
        return s.to_string();
    }
    let head: String = s.chars().take(300).collect();
    let tail: String = s.chars().skip(n - 150).collect();
    format!("{head} … ({n} characters) … {tail}")
}
