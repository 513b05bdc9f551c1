//! CSV tables read whole, with the line of every record, for errors that name the file, line and
//! column, and hints for the usual mistakes (a `;` separator, a decimal comma).

use crate::input;
use anyhow::{Result, anyhow};
use gonio_core::text::short;
use std::path::Path;

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

/// A hint for a line that does not split as expected: a `;`-separated file or decimal commas.
fn separator_hint(line: &str, expected: usize, found: usize) -> &'static str {
    let decimal_comma = line
        .as_bytes()
        .windows(3)
        .any(|w| w[0].is_ascii_digit() && w[1] == b',' && w[2].is_ascii_digit());
    if line.contains(';') && found < expected {
        " (the line has `;`: gonio reads comma-separated CSV with a decimal point, e.g. 0,1.5,-0.25)"
    } else if found > expected && decimal_comma {
        " (a decimal comma? gonio reads numbers with a decimal point, 1.5 not 1,5, and `,` between fields)"
    } else {
        ""
    }
}

impl CsvTable {
    /// Reads a CSV file (or `-`): header required, `#` comment lines and blank lines skipped.
    ///
    /// # Errors
    /// The file cannot be read, is not UTF-8, or a row has another number of fields than the
    /// header (naming the line).
    pub fn read(inputs: &input::Inputs, path: &Path) -> Result<CsvTable> {
        let text = inputs.read_text(path)?;
        Self::parse(&path.display().to_string(), &text)
    }

    /// Parses CSV text; `name` is used in error messages.
    ///
    /// # Errors
    /// As [`CsvTable::read`].
    pub fn parse(name: &str, text: &str) -> Result<CsvTable> {
        // Line numbers are counted here, not by the csv reader (which reports a record at the
        // end of whatever it skipped before it): keep the data lines with their numbers and
        // parse those. Fields spanning lines are not part of gonio's formats.
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
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
            let (line, raw) = kept.get(k).copied().unwrap_or((1, ""));
            let rec = rec.map_err(|e| anyhow!("{name}:{line}: not valid CSV: {e}"))?;
            if rec.iter().all(|f| f.is_empty()) {
                continue;
            }
            let fields: Vec<String> = rec.iter().map(|f| f.to_string()).collect();
            match &headers {
                None => {
                    if fields.len() == 1 && fields[0].contains(';') {
                        return Err(anyhow!(
                            "{name}:{line}: the header {:?} is one field{}",
                            short(&fields[0]),
                            separator_hint(raw, 2, 1)
                        ));
                    }
                    headers = Some((line, fields))
                }
                Some((_, h)) => {
                    if fields.len() != h.len() {
                        return Err(anyhow!(
                            "{name}:{line}: expected {} fields (as in the header), found {}{}",
                            h.len(),
                            fields.len(),
                            separator_hint(raw, h.len(), fields.len())
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
    ///
    /// # Errors
    /// The column is missing.
    pub fn require(&self, name: &str, expected_header: &str) -> Result<usize> {
        self.column(name).ok_or_else(|| {
            let found: Vec<String> = self.headers.iter().take(12).map(|h| short(h)).collect();
            anyhow!(
                "{}:{}: missing column '{}': expected header {}, found {}{}",
                self.name,
                self.header_line,
                name,
                expected_header,
                found.join(","),
                if self.headers.len() > 12 { ",…" } else { "" }
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
            self.headers.get(col).map_or("?".into(), |s| short(s)),
            msg
        )
    }

    /// Parses a finite number from a field.
    ///
    /// # Errors
    /// Not a number, or not finite (located).
    pub fn f64_at(&self, line: u64, fields: &[String], col: usize) -> Result<f64> {
        let s = &fields[col];
        match s.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            Ok(v) => Err(self.error_at(line, col, format!("expected a finite number, found {v}"))),
            Err(_) => {
                let hint = if s.replace(',', ".").parse::<f64>().is_ok() {
                    " (a decimal comma? write 1.5, not 1,5)"
                } else {
                    ""
                };
                Err(self.error_at(
                    line,
                    col,
                    format!("expected a number, found {:?}{hint}", short(s)),
                ))
            }
        }
    }

    /// Parses a whole number from a field.
    ///
    /// # Errors
    /// Not a whole number (located).
    pub fn int_at(&self, line: u64, fields: &[String], col: usize) -> Result<i64> {
        let s = &fields[col];
        s.parse::<i64>().map_err(|_| {
            self.error_at(
                line,
                col,
                format!("expected a whole number, found {:?}", short(s)),
            )
        })
    }
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
    fn a_bom_before_a_comment_and_separator_hints() {
        let t = CsvTable::parse("r.csv", "\u{feff}# note\na,b\n1,2\n").unwrap();
        assert_eq!(t.headers, ["a", "b"]);
        let e = CsvTable::parse("r.csv", "a;b\n1;2\n")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("r.csv:1:") && e.contains("`;`"), "{e}");
        let e = CsvTable::parse("r.csv", "a,b\n1,5,2,5\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("decimal comma"), "{e}");
        let t = CsvTable::parse("r.csv", "a,b\n\"1,5\",2\n").unwrap();
        let e = t.f64_at(2, &t.rows[0].1, 0).unwrap_err().to_string();
        assert!(e.contains("decimal comma"), "{e}");
    }
}
