//! An input of a format as a front end gives it: a file the user named, or the same content in
//! memory (the Python module's arrays, texts and dicts). Both are read by one parser, through
//! the caller's [`Inputs`], so that the same content gives the same result and the same error
//! from the command line and from Python; a file's errors name the file, content in memory the
//! name it was given (`<readings>`, `<meta>`).
//!
//! ```
//! use gonio_io::formats::source::Document;
//! use gonio_io::input::Inputs;
//! let doc = Document::Given { name: "<meta>".into(), text: "x = [".into() };
//! let e = doc.parse(&Inputs::new(), gonio_io::formats::parse_toml::<toml::Value>).unwrap_err();
//! assert!(e.to_string().starts_with("<meta>:1:"), "{e}");
//! ```

use super::csv::CsvTable;
use crate::input::Inputs;
use anyhow::Result;
use std::path::PathBuf;

/// A table: a CSV file, or a table already in memory (an array's rows, its header made by the
/// front end).
#[derive(Debug)]
pub enum Table {
    /// A CSV file (`-` for standard input).
    File(PathBuf),
    /// A table in memory; its `name` names it in errors.
    Given(CsvTable),
}

impl Table {
    /// The name errors give it: the path as given, or the table's name.
    pub fn name(&self) -> String {
        match self {
            Table::File(p) => p.display().to_string(),
            Table::Given(t) => t.name.clone(),
        }
    }

    /// The table, a file read through `inputs`.
    ///
    /// # Errors
    /// As [`CsvTable::read`].
    pub fn read(self, inputs: &Inputs) -> Result<CsvTable> {
        match self {
            Table::File(p) => CsvTable::read(inputs, &p),
            Table::Given(t) => Ok(t),
        }
    }
}

/// A text document (TOML, JSON): a file, or its text in memory.
#[derive(Debug, Clone)]
pub enum Document {
    /// A file (`-` for standard input).
    File(PathBuf),
    /// The document's text; `name` names it in errors.
    Given {
        /// Its name in errors (`<meta>`).
        name: String,
        /// The text.
        text: String,
    },
}

impl Document {
    /// The name errors give it.
    pub fn name(&self) -> String {
        match self {
            Document::File(p) => p.display().to_string(),
            Document::Given { name, .. } => name.clone(),
        }
    }

    /// Parses it with a format's parser (`parse(name, text)`), a file read through `inputs`
    /// (at most [`crate::input::MAX_TEXT_BYTES`]).
    ///
    /// # Errors
    /// As [`Inputs::load`] and `parse`.
    pub fn parse<T>(
        &self,
        inputs: &Inputs,
        parse: impl FnOnce(&str, &str) -> Result<T>,
    ) -> Result<T> {
        match self {
            Document::File(p) => inputs.load(p, parse),
            Document::Given { name, text } => parse(name, text),
        }
    }

    /// Its bytes, a file read through `inputs` with the limit `limit` (text in memory has no
    /// limit: it is already read).
    ///
    /// # Errors
    /// As [`Inputs::read_bytes`].
    pub fn bytes(&self, inputs: &Inputs, limit: usize) -> Result<Vec<u8>> {
        match self {
            Document::File(p) => inputs.read_bytes(p, limit),
            Document::Given { text, .. } => Ok(text.as_bytes().to_vec()),
        }
    }
}
