//! Reading input files: size limits checked before reading, UTF-8 text with the line of a bad
//! byte, and the record of every file read, which outputs may not overwrite (the binary's output
//! set, `gonio_cli::output::Outputs`, refuses an output that is one of these files).

use anyhow::{Context, Result, anyhow};
use std::io::Read;
use std::path::Path;
use std::sync::Mutex;

/// Largest text input (CSV readings, angle logs, TOML and JSON files), in bytes: 256 MiB. A
/// self-calibration over 10 turns of 36,000 positions with 12 heads is about 50 MB.
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

/// Every file read so far by this process: its identity and its name as the user gave it.
static READ: Mutex<Vec<(FileId, String)>> = Mutex::new(Vec::new());

/// Records `path` as an input (outputs will refuse to overwrite it). `-` (standard input) and
/// paths that do not exist are not recorded. Reading through [`read_bytes`] or [`read_text`]
/// records the file; call this for inputs read otherwise (images, directories of frames).
pub fn record(path: &Path) {
    if path.as_os_str() == "-" {
        return;
    }
    if let Some(id) = FileId::of(path) {
        let mut r = READ.lock().unwrap_or_else(|e| e.into_inner());
        if !r.iter().any(|(i, _)| *i == id) {
            r.push((id, path.display().to_string()));
        }
    }
}

/// The input file with identity `id`, if one was read and its name still names it: its name as
/// given. (An input deleted since, whose inode a new file took, is not that input.)
pub fn recorded(id: FileId) -> Option<String> {
    READ.lock()
        .unwrap_or_else(|e| e.into_inner())
        .iter()
        .find(|(i, n)| *i == id && FileId::of(Path::new(n)) == Some(id))
        .map(|(_, n)| n.clone())
}

/// Files the command keeps that no output may name, even before they exist (the results store
/// and its SQLite companions): the absolute path (its directory resolved) and the name as given.
static RESERVED: Mutex<Vec<(std::path::PathBuf, String)>> = Mutex::new(Vec::new());

/// `path` with its directory resolved (symbolic links, `.`, `..`), if the directory exists.
pub fn absolute(path: &Path) -> Option<std::path::PathBuf> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let name = path.file_name()?;
    std::fs::canonicalize(dir).ok().map(|d| d.join(name))
}

/// Reserves `path` (named by `what`, e.g. `--db results.sqlite`) for the command: no output may
/// name it or its `-wal`, `-shm` and `-journal` companions, whether it exists yet or not (the
/// command may create it). An existing file is also recorded as an input.
pub fn reserve(path: &Path, what: &str) {
    record(path);
    let mut r = RESERVED.lock().unwrap_or_else(|e| e.into_inner());
    for suffix in ["", "-wal", "-shm", "-journal"] {
        let mut p = path.as_os_str().to_owned();
        p.push(suffix);
        let p = std::path::PathBuf::from(p);
        record(&p);
        if let Some(abs) = absolute(&p) {
            r.push((abs, what.to_string()));
        }
    }
}

/// What reserved `path` (see [`reserve`]), if it is reserved.
pub fn reserved(path: &Path) -> Option<String> {
    let r = RESERVED.lock().unwrap_or_else(|e| e.into_inner());
    if r.is_empty() {
        return None;
    }
    let abs = absolute(path)?;
    let id = FileId::of(path);
    r.iter()
        .find(|(p, _)| *p == abs || (id.is_some() && FileId::of(p) == id))
        .map(|(_, w)| w.clone())
}

/// Reads a whole file, or standard input for `-`, as bytes, refusing one of more than `limit`
/// bytes before reading it (a file by its size, a pipe after `limit` + 1 bytes), and records it
/// as an input.
///
/// # Errors
/// The file cannot be read, or it is too large (`NAME:1:1: the file is … bytes, more than the
/// limit of …`).
pub fn read_bytes(path: &Path, limit: usize) -> Result<Vec<u8>> {
    let name = path.display();
    let too_big =
        |what: String| anyhow!("{name}:1:1: {what}, more than the limit of {limit} bytes");
    let mut data = Vec::new();
    if path.as_os_str() == "-" {
        // Standard input can be read once: `-` for two inputs would give the second nothing.
        static STDIN_READ: std::sync::atomic::AtomicBool =
            std::sync::atomic::AtomicBool::new(false);
        if STDIN_READ.swap(true, std::sync::atomic::Ordering::SeqCst) {
            return Err(anyhow!(
                "-: standard input is given for two inputs; it can be read only once: give the other input as a file"
            ));
        }
        std::io::stdin()
            .lock()
            .take(limit as u64 + 1)
            .read_to_end(&mut data)
            .context("cannot read standard input")?;
    } else {
        let f = std::fs::File::open(path).with_context(|| format!("cannot read {name}"))?;
        let m = f
            .metadata()
            .with_context(|| format!("cannot read {name}"))?;
        if m.is_dir() {
            return Err(anyhow!("{name}: is a directory: expected a file"));
        }
        if m.is_file() && m.len() > limit as u64 {
            return Err(too_big(format!("the file is {} bytes", m.len())));
        }
        record(path);
        f.take(limit as u64 + 1)
            .read_to_end(&mut data)
            .with_context(|| format!("cannot read {name}"))?;
    }
    if data.len() > limit {
        return Err(too_big(format!("the input goes on beyond {limit} bytes")));
    }
    Ok(data)
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

/// Reads a whole text file (or standard input for `-`): at most [`MAX_TEXT_BYTES`], UTF-8, a
/// byte-order mark skipped.
///
/// # Errors
/// As [`read_bytes`] and [`decode`].
pub fn read_text(path: &Path) -> Result<String> {
    let bytes = read_bytes(path, MAX_TEXT_BYTES)?;
    decode(&path.display().to_string(), &bytes)
}

/// Reads a text file and parses it with `parse(name, text)`, the file's name as given naming it
/// in errors (the `load` of every format).
///
/// # Errors
/// As [`read_text`] and `parse`.
pub fn load<T>(path: &Path, parse: impl FnOnce(&str, &str) -> Result<T>) -> Result<T> {
    let text = read_text(path)?;
    parse(&path.display().to_string(), &text)
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
