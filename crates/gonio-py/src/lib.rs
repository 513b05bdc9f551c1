//! gonio for Python: the module `gonio` (built by maturin from the repository's
//! `pyproject.toml`; `python/gonio/__init__.py` re-exports this extension, `gonio._gonio`).
//!
//! Every function returns what the command line writes as JSON, as plain Python objects (dicts,
//! lists, floats, ints, strings, None) with the same keys and values: the results are made by
//! the library crates and shaped by `gonio_io` (its file formats, its result types and its one
//! JSON emitter, which refuses a non-finite number), then parsed by Python's `json` module.
//!
//! Inputs are file paths, as on the command line, or numpy arrays. An array is read as the
//! table a file would hold (the same parser checks it, so the same values give the same result
//! and a bad value the same message); in an array's errors the line and column are the row and
//! the column, both 1-based (`<readings>:3:2: column 'start_face': …`). A frame for the
//! detector is a 2-D `uint8` C-contiguous array, read where it lies, without a copy.
//!
//! Errors are `gonio.GonioError` (a `ValueError`) with the command line's one-line message.
//!
//! ```python
//! import gonio
//! cert = gonio.shift_angle("lab/readings.csv")
//! print(cert["encoder_errors"][0]["U_arcsec"])
//! ```

mod budget;
mod calib;
mod convert;
mod vision;

use pyo3::prelude::*;

pyo3::create_exception!(
    gonio,
    GonioError,
    pyo3::exceptions::PyValueError,
    "An input gonio refuses, with the command line's one-line message (file:line:column)."
);

/// The module `gonio._gonio`.
#[pymodule]
#[pyo3(name = "_gonio")]
fn gonio_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("GonioError", m.py().get_type::<GonioError>())?;
    m.add_function(wrap_pyfunction!(calib::shift_angle, m)?)?;
    m.add_function(wrap_pyfunction!(calib::selfcal, m)?)?;
    m.add_function(wrap_pyfunction!(calib::joint, m)?)?;
    m.add_function(wrap_pyfunction!(calib::compare, m)?)?;
    m.add_function(wrap_pyfunction!(calib::dcc, m)?)?;
    m.add_function(wrap_pyfunction!(budget::budget, m)?)?;
    m.add_function(wrap_pyfunction!(vision::detect, m)?)?;
    m.add_function(wrap_pyfunction!(vision::detect_many, m)?)?;
    m.add_function(wrap_pyfunction!(vision::eccentricity, m)?)?;
    Ok(())
}
