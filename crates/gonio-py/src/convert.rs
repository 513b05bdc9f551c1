//! Between Python and gonio: errors as `GonioError`, results as Python objects (the command
//! line's JSON parsed by Python's `json`), paths, texts and numpy arrays as inputs, numbers
//! checked against their bounds ([`opt_whole`], [`opt_real`]) and frames read in C order
//! ([`c_order`]).

use crate::GonioError;
use gonio_core::bound::Bound as Range;
use gonio_io::formats::csv::CsvTable;
use numpy::{AllowTypeChange, PyArrayLike2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyInt, PyString};
use serde::Serialize;
use std::path::PathBuf;

/// An error as `GonioError` with the command line's one-line message.
pub fn error(e: anyhow::Error) -> PyErr {
    GonioError::new_err(gonio_io::input::one_line(&e))
}

/// A `GonioError` with this message.
pub fn refuse(msg: impl Into<String>) -> PyErr {
    GonioError::new_err(msg.into())
}

/// Converts a Rust result's error into `GonioError`.
pub trait OrGonio<T> {
    /// The value, or the error as `GonioError`.
    fn or_gonio(self) -> PyResult<T>;
}

impl<T> OrGonio<T> for anyhow::Result<T> {
    fn or_gonio(self) -> PyResult<T> {
        self.map_err(error)
    }
}

/// JSON text (as the command line writes it) as Python objects, keys in the same order.
pub fn from_json<'py>(py: Python<'py>, json: &[u8]) -> PyResult<Bound<'py, PyAny>> {
    let text = std::str::from_utf8(json).map_err(|e| refuse(e.to_string()))?;
    py.import("json")?.getattr("loads")?.call1((text,))
}

/// `value` through the command line's JSON emitter (which refuses a non-finite number, naming
/// it after `name`) as Python objects.
pub fn to_python<'py, T: Serialize + ?Sized>(
    py: Python<'py>,
    value: &T,
    name: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let bytes = gonio_io::json::to_bytes(value).map_err(|e| refuse(format!("{name}: {e}")))?;
    from_json(py, &bytes)
}

/// A file input given as a path or as its text.
pub enum Source {
    /// A file (`str` or `os.PathLike`).
    Path(PathBuf),
    /// The file's text, named in errors.
    Text {
        /// `<meta>`: the argument's name.
        name: String,
        /// The text.
        text: String,
    },
}

impl Source {
    /// The name errors give it.
    pub fn name(&self) -> String {
        match self {
            Source::Path(p) => p.display().to_string(),
            Source::Text { name, .. } => name.clone(),
        }
    }

    /// Parses it with a `gonio_io::formats` parser (`parse(name, text)`).
    pub fn parse<T>(
        &self,
        parse: impl FnOnce(&str, &str) -> anyhow::Result<T>,
    ) -> anyhow::Result<T> {
        match self {
            Source::Path(p) => gonio_io::input::Inputs::new().load(p, parse),
            Source::Text { name, text } => parse(name, text),
        }
    }
}

/// Whether `obj` names a file: a `str` or an `os.PathLike`.
pub fn is_path(obj: &Bound<'_, PyAny>) -> bool {
    obj.is_instance_of::<PyString>() || obj.hasattr("__fspath__").unwrap_or(false)
}

/// A path (`str`, `os.PathLike`) or, for a `str` with a line break, the file's text (TOML);
/// with `dicts`, a dict is the JSON file's content (a certificate as gonio returned it).
pub fn source(obj: &Bound<'_, PyAny>, arg: &str, dicts: bool) -> PyResult<Source> {
    let name = format!("<{arg}>");
    if let Ok(s) = obj.cast::<PyString>() {
        let s = s.to_str()?;
        if s.contains('\n') {
            return Ok(Source::Text {
                name,
                text: s.to_string(),
            });
        }
        return Ok(Source::Path(PathBuf::from(s)));
    }
    if obj.hasattr("__fspath__")? {
        return Ok(Source::Path(obj.extract()?));
    }
    if dicts && obj.is_instance_of::<PyDict>() {
        let text: String = obj
            .py()
            .import("json")?
            .getattr("dumps")?
            .call1((obj,))?
            .extract()?;
        return Ok(Source::Text { name, text });
    }
    Err(refuse(format!(
        "{arg}: expected a path{}, found {}",
        if dicts { " or a dict" } else { " or TOML text" },
        obj.get_type().name()?
    )))
}

/// An optional [`source`].
pub fn opt_source(
    obj: Option<&Bound<'_, PyAny>>,
    arg: &str,
    dicts: bool,
) -> PyResult<Option<Source>> {
    obj.filter(|o| !o.is_none())
        .map(|o| source(o, arg, dicts))
        .transpose()
}

/// A number as a CSV field: the shortest text that reads back as the same `f64` (a whole
/// number without a fraction, so that a face number `3.0` reads as `3`).
fn field(v: f64) -> String {
    format!("{v}")
}

/// A 2-D array of numbers (anything numpy converts to `float64`) as the table a CSV file would
/// hold: the header `headers(columns)`, row r (0-based) at line r + 1, so that errors read
/// `<arg>:ROW:COLUMN`, both 1-based.
pub fn table(
    obj: &Bound<'_, PyAny>,
    arg: &str,
    headers: impl FnOnce(usize) -> Result<Vec<String>, String>,
) -> PyResult<CsvTable> {
    let a: PyArrayLike2<'_, f64, AllowTypeChange> = obj.extract().map_err(|_| {
        refuse(format!(
            "{arg}: expected a path or a 2-D array of numbers (rows × columns)"
        ))
    })?;
    let (rows, cols) = (a.shape()[0], a.shape()[1]);
    let headers = headers(cols).map_err(|m| refuse(format!("<{arg}>: {m}")))?;
    let view = a.as_array();
    let rows = (0..rows)
        .map(|r| {
            (
                r as u64 + 1,
                (0..cols).map(|c| field(view[[r, c]])).collect::<Vec<_>>(),
            )
        })
        .collect();
    Ok(CsvTable {
        name: format!("<{arg}>"),
        headers,
        header_line: 0,
        rows,
    })
}

/// Two 1-D arrays of numbers as the columns `names` of a table (row r at line r + 1).
pub fn columns(cols: [(&Bound<'_, PyAny>, &str); 2], name: &str) -> PyResult<CsvTable> {
    let mut data = Vec::new();
    for (obj, col) in cols {
        let a: numpy::PyArrayLike1<'_, f64, AllowTypeChange> = obj
            .extract()
            .map_err(|_| refuse(format!("{col}: expected a 1-D array of numbers")))?;
        data.push(a.as_array().to_vec());
    }
    if data[0].len() != data[1].len() {
        return Err(refuse(format!(
            "{} and {}: expected arrays of one length, found {} and {}",
            cols[0].1,
            cols[1].1,
            data[0].len(),
            data[1].len()
        )));
    }
    Ok(CsvTable {
        name: format!("<{name}>"),
        headers: cols.iter().map(|(_, c)| c.to_string()).collect(),
        header_line: 0,
        rows: (0..data[0].len())
            .map(|r| (r as u64 + 1, vec![field(data[0][r]), field(data[1][r])]))
            .collect(),
    })
}

/// A whole-number argument within `range`, or `None` when not given (or `None`): any Python
/// `int` or numpy integer, however large, and every refusal a `GonioError` naming the bound
/// (`threads=1000000: at most 256`), never pyo3's `OverflowError` for a negative or huge one.
pub fn opt_whole<T>(obj: Option<&Bound<'_, PyAny>>, arg: &str, range: Range) -> PyResult<Option<T>>
where
    T: TryFrom<i128> + TryInto<i128> + Copy,
{
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Ok(None);
    };
    let shown = || {
        obj.repr()
            .map(|r| gonio_core::text::short(&r.to_string_lossy()))
            .unwrap_or_default()
    };
    if obj.is_instance_of::<PyBool>() {
        return Err(refuse(format!(
            "{arg}={}: expected a whole number ({range})",
            shown()
        )));
    }
    let i: i128 = match obj.extract::<i128>() {
        Ok(i) => i,
        // An int beyond 128 bits: past one end of any bound.
        Err(_) if obj.is_instance_of::<PyInt>() => {
            let negative = obj.lt(0).unwrap_or(false);
            let end = range.check(if negative { f64::MIN } else { f64::MAX });
            return Err(refuse(match end {
                Err(e) => format!("{arg}={}: {e}", shown()),
                Ok(_) => format!("{arg}={}: expected a whole number ({range})", shown()),
            }));
        }
        Err(_) => {
            return Err(refuse(format!(
                "{arg}={}: expected a whole number ({range})",
                shown()
            )));
        }
    };
    range
        .check_int(i)
        .map_err(|e| refuse(format!("{arg}={i}: {e}")))?;
    T::try_from(i)
        .map(Some)
        .map_err(|_| refuse(format!("{arg}={i}: expected a whole number ({range})")))
}

/// A number argument, or `None` when not given (or `None`): any Python number (an `int` too
/// large for a float is refused as not finite), checked against `range` when one is given;
/// every refusal a `GonioError`, never an `OverflowError`.
pub fn opt_real(
    obj: Option<&Bound<'_, PyAny>>,
    arg: &str,
    range: Option<Range>,
) -> PyResult<Option<f64>> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Ok(None);
    };
    let shown = || {
        obj.repr()
            .map(|r| gonio_core::text::short(&r.to_string_lossy()))
            .unwrap_or_default()
    };
    if obj.is_instance_of::<PyBool>() {
        return Err(refuse(format!("{arg}={}: expected a number", shown())));
    }
    let v: f64 = match obj.extract::<f64>() {
        Ok(v) => v,
        Err(_) if obj.is_instance_of::<PyInt>() => f64::INFINITY,
        Err(_) => return Err(refuse(format!("{arg}={}: expected a number", shown()))),
    };
    if let Some(range) = range {
        range
            .check(v)
            .map_err(|e| refuse(format!("{arg}={}: {e}", shown())))?;
    } else if !v.is_finite() {
        return Err(refuse(format!(
            "{arg}={}: expected a finite number",
            shown()
        )));
    }
    Ok(Some(v))
}

/// A 2-D `uint8` frame's pixels in C order (row after row): read where numpy holds them when
/// the array is C-contiguous, else copied once into C order (a Fortran-ordered or strided view
/// is never read in the wrong order).
pub fn c_order<'a>(a: &'a numpy::PyReadonlyArray2<'_, u8>, copy: &'a mut Vec<u8>) -> &'a [u8] {
    if a.is_c_contiguous()
        && let Ok(s) = a.as_slice()
    {
        return s;
    }
    *copy = a.as_array().iter().copied().collect();
    copy
}

/// The frames of an N×H×W `uint8` array in C order, as [`c_order`].
pub fn c_order3<'a>(a: &'a numpy::PyReadonlyArray3<'_, u8>, copy: &'a mut Vec<u8>) -> &'a [u8] {
    if a.is_c_contiguous()
        && let Ok(s) = a.as_slice()
    {
        return s;
    }
    *copy = a.as_array().iter().copied().collect();
    copy
}
