//! File formats and terminal plumbing shared by the commands: atomic writes, CSV reading with
//! line-and-column errors, JSON output.

use anyhow::{Context, Result, anyhow};
use serde::Serialize;
use std::io::Read;
use std::path::{Path, PathBuf};

/// Formats an error and its causes on one line.
pub fn one_line(e: &anyhow::Error) -> String {
    let mut s = String::new();
    for (i, c) in e.chain().enumerate() {
        if i > 0 {
            s.push_str(": ");
        }
        s.push_str(&c.to_string().replace('\n', " "));
    }
    s
}

/// Writes `data` to `path` atomically: a temporary file in the same directory, then a rename,
/// so a failure never leaves a half-written output. `-` writes to standard output.
pub fn write_atomic(path: &Path, data: &[u8]) -> Result<()> {
    use std::io::Write;
    if path.as_os_str() == "-" {
        let mut out = std::io::stdout().lock();
        out.write_all(data)?;
        return Ok(out.flush()?);
    }
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let mut tmp = tempfile::Builder::new()
        .prefix(".gonio-")
        .suffix(".tmp")
        .tempfile_in(&dir)
        .with_context(|| format!("cannot create a temporary file in {}", dir.display()))?;
    tmp.write_all(data)
        .and_then(|_| tmp.flush())
        .with_context(|| format!("cannot write {}", path.display()))?;
    tmp.persist(path)
        .map_err(|e| anyhow!("cannot write {}: {}", path.display(), e.error))?;
    Ok(())
}

/// A file written in pieces that appears whole, or not at all: a temporary file beside it,
/// renamed on [`AtomicFile::commit`] (dropped without it, the temporary file is removed).
pub struct AtomicFile {
    path: PathBuf,
    out: std::io::BufWriter<tempfile::NamedTempFile>,
}

impl AtomicFile {
    /// Starts writing `path`.
    ///
    /// # Errors
    /// When no temporary file can be made in its directory.
    pub fn create(path: &Path) -> Result<Self> {
        let dir = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let tmp = tempfile::Builder::new()
            .prefix(".gonio-")
            .suffix(".tmp")
            .tempfile_in(&dir)
            .with_context(|| format!("cannot create a temporary file in {}", dir.display()))?;
        Ok(AtomicFile {
            path: path.to_path_buf(),
            out: std::io::BufWriter::with_capacity(1 << 20, tmp),
        })
    }

    /// Appends `data`.
    ///
    /// # Errors
    /// When the disk refuses it.
    pub fn write_all(&mut self, data: &[u8]) -> Result<()> {
        use std::io::Write;
        self.out
            .write_all(data)
            .with_context(|| format!("cannot write {}", self.path.display()))
    }

    /// Finishes the file: it appears under its name, whole.
    ///
    /// # Errors
    /// When the last bytes or the rename fail.
    pub fn commit(self) -> Result<()> {
        let path = self.path;
        let tmp = self
            .out
            .into_inner()
            .map_err(|e| anyhow!("cannot write {}: {}", path.display(), e.error()))?;
        tmp.persist(&path)
            .map_err(|e| anyhow!("cannot write {}: {}", path.display(), e.error))?;
        Ok(())
    }
}

/// Serialises `value` as pretty JSON (with a final newline) and writes it atomically.
pub fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<()> {
    let mut s = serde_json::to_string_pretty(value)?;
    s.push('\n');
    write_atomic(path, s.as_bytes())
}

/// Writes text to standard output, ignoring a closed pipe (`gonio … | head`).
pub fn emit(text: &str) {
    use std::io::Write;
    let _ = std::io::stdout().lock().write_all(text.as_bytes());
}

/// Creates an output directory (and its parents) if needed.
pub fn ensure_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir)
        .with_context(|| format!("cannot create directory {}", dir.display()))
}

/// Reads a whole text file, or standard input for `-`.
pub fn read_text(path: &Path) -> Result<String> {
    if path.as_os_str() == "-" {
        let mut s = String::new();
        std::io::stdin()
            .read_to_string(&mut s)
            .context("cannot read standard input")?;
        return Ok(s);
    }
    std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))
}

/// Reads a whole file, or standard input for `-`, as bytes, refusing one of more than `limit`
/// bytes before reading it (a file by its size, a pipe after `limit` + 1 bytes).
pub fn read_bytes(path: &Path, limit: usize) -> Result<Vec<u8>> {
    let name = path.display();
    let too_big =
        |what: String| anyhow!("{name}:1:1: {what}, more than the limit of {limit} bytes");
    let mut data = Vec::new();
    if path.as_os_str() == "-" {
        std::io::stdin()
            .lock()
            .take(limit as u64 + 1)
            .read_to_end(&mut data)
            .context("cannot read standard input")?;
    } else {
        let f = std::fs::File::open(path).with_context(|| format!("cannot read {name}"))?;
        if let Ok(m) = f.metadata()
            && m.is_file()
            && m.len() > limit as u64
        {
            return Err(too_big(format!("the file is {} bytes", m.len())));
        }
        f.take(limit as u64 + 1)
            .read_to_end(&mut data)
            .with_context(|| format!("cannot read {name}"))?;
    }
    if data.len() > limit {
        return Err(too_big(format!("the input goes on beyond {limit} bytes")));
    }
    Ok(data)
}

/// Parses TOML text into `T`; errors read `NAME:LINE:COLUMN: what was wrong`.
pub fn parse_toml<T: serde::de::DeserializeOwned>(name: &str, text: &str) -> Result<T> {
    toml::from_str(text).map_err(|e| crate::formats::toml_error(Path::new(name), text, &e))
}

/// Reads a TOML file (or `-`) into `T`; errors name the file, line and column.
pub fn read_toml<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T> {
    let text = read_text(path)?;
    parse_toml(&path.display().to_string(), &text)
}

/// A CSV file read whole, with the line number of every record, for precise error messages.
#[derive(Debug)]
pub struct CsvTable {
    /// The file's name as given (`-` for standard input).
    pub name: String,
    /// Column names from the header, trimmed.
    pub headers: Vec<String>,
    /// Line of the header.
    pub header_line: u64,
    /// Records: (line number, fields trimmed).
    pub rows: Vec<(u64, Vec<String>)>,
}

impl CsvTable {
    /// Reads a CSV file (or `-`): header required, `#` comment lines and blank lines skipped.
    ///
    /// Ragged rows are an error naming the line.
    pub fn read(path: &Path) -> Result<CsvTable> {
        let text = read_text(path)?;
        Self::parse(&path.display().to_string(), &text)
    }

    /// Parses CSV text; `name` is used in error messages.
    pub fn parse(name: &str, text: &str) -> Result<CsvTable> {
        // Line numbers are counted here, not by the csv reader (which reports a record at the
        // end of whatever it skipped before it): keep the data lines with their numbers and
        // parse those. Fields spanning lines are not part of gonio's formats.
        let kept: Vec<(u64, &str)> = text
            .lines()
            .enumerate()
            .filter(|(_, l)| {
                let t = l.trim();
                !t.is_empty() && !t.starts_with('#')
            })
            .map(|(i, l)| (i as u64 + 1, l))
            .collect();
        let joined = kept.iter().map(|(_, l)| *l).collect::<Vec<_>>().join("\n");
        let mut rdr = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .trim(csv::Trim::All)
            .from_reader(joined.as_bytes());
        let mut headers: Option<(u64, Vec<String>)> = None;
        let mut rows = Vec::new();
        for (k, rec) in rdr.records().enumerate() {
            let line = kept.get(k).map_or(0, |x| x.0);
            let rec = rec.map_err(|e| anyhow!("{name}:{line}: not valid CSV: {e}"))?;
            if rec.iter().all(|f| f.is_empty()) {
                continue;
            }
            let fields: Vec<String> = rec.iter().map(|f| f.to_string()).collect();
            match &headers {
                None => headers = Some((line, fields)),
                Some((_, h)) => {
                    if fields.len() != h.len() {
                        return Err(anyhow!(
                            "{name}:{line}: expected {} fields (as in the header), found {}",
                            h.len(),
                            fields.len()
                        ));
                    }
                    rows.push((line, fields));
                }
            }
        }
        let (header_line, headers) =
            headers.ok_or_else(|| anyhow!("{name}:1: empty file: expected a header line"))?;
        Ok(CsvTable {
            name: name.to_string(),
            headers,
            header_line,
            rows,
        })
    }

    /// Index of a column by name.
    pub fn column(&self, name: &str) -> Option<usize> {
        self.headers.iter().position(|h| h == name)
    }

    /// Index of a required column, or an error naming the header line and what was expected.
    pub fn require(&self, name: &str, expected_header: &str) -> Result<usize> {
        self.column(name).ok_or_else(|| {
            anyhow!(
                "{}:{}: missing column '{}': expected header {}, found {}",
                self.name,
                self.header_line,
                name,
                expected_header,
                self.headers.join(",")
            )
        })
    }

    /// An error at a record's line and column.
    pub fn error_at(&self, line: u64, col: usize, msg: impl std::fmt::Display) -> anyhow::Error {
        anyhow!(
            "{}:{}:{}: column '{}': {}",
            self.name,
            line,
            col + 1,
            self.headers.get(col).map_or("?", |s| s.as_str()),
            msg
        )
    }

    /// Parses a finite number from a field.
    pub fn f64_at(&self, line: u64, fields: &[String], col: usize) -> Result<f64> {
        let s = &fields[col];
        match s.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            Ok(v) => Err(self.error_at(line, col, format!("expected a finite number, found {v}"))),
            Err(_) => Err(self.error_at(line, col, format!("expected a number, found {s:?}"))),
        }
    }

    /// Parses a whole number from a field.
    pub fn int_at(&self, line: u64, fields: &[String], col: usize) -> Result<i64> {
        let s = &fields[col];
        s.parse::<i64>()
            .map_err(|_| self.error_at(line, col, format!("expected a whole number, found {s:?}")))
    }
}

/// Writes CSV text: a header and rows, atomically.
pub fn write_csv(path: &Path, header: &[&str], rows: &[Vec<String>]) -> Result<()> {
    let mut s = header.join(",");
    s.push('\n');
    for r in rows {
        s.push_str(&r.join(","));
        s.push('\n');
    }
    write_atomic(path, s.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_errors_name_line_and_column() {
        let t = CsvTable::parse("r.csv", "# c\na,b\n1,2\n\n3,x\n").unwrap();
        assert_eq!(t.rows.len(), 2);
        assert_eq!(t.header_line, 2);
        assert_eq!(t.rows[0].0, 3, "{:?}", t.rows);
        let (line, f) = &t.rows[1];
        let e = t.f64_at(*line, f, 1).unwrap_err().to_string();
        assert_eq!(e, "r.csv:5:2: column 'b': expected a number, found \"x\"");
        let e = CsvTable::parse("r.csv", "a,b\n1,2,3\n")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("r.csv:2:"), "{e}");
    }

    #[test]
    fn atomic_write_replaces_whole_file() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("o.json");
        write_atomic(&p, b"one").unwrap();
        write_atomic(&p, b"two").unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "two");
        assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 1);
    }
}
