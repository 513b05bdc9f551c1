//! The calibrations: `shift_angle`, `selfcal`, `joint` (certificates, `gonio.certificate/1`),
//! `compare` (two certificates) and `dcc` (a certificate as a Digital Calibration Certificate).
//! The first four are the commands' own code path (`gonio_io::results`: `gonio shift-angle`,
//! `selfcal`, `joint`, `compare`), given Python's arguments: paths, texts, dicts or arrays.
//! Each call reads its files through an `Inputs` of its own, forgotten when it returns.

use crate::convert::{self, OrGonio, Source, refuse};
use anyhow::anyhow;
use gonio_calib::joint::{HeadAngles, Interpolation};
use gonio_calib::selfcal::{Method as SelfcalMethod, NoiseModel};
use gonio_calib::shift_angle::Method;
use gonio_io::formats::source::{Document, Table};
use gonio_io::formats::{self, heads};
use gonio_io::input::Inputs;
use gonio_io::results;
use pyo3::prelude::*;
use std::str::FromStr;

/// A count (faces, an order): a whole number from 0 to 2³² − 1, checked by the module (a
/// negative or huge int is `GonioError`, never the binding's `OverflowError`); what the
/// calibration accepts of it is the calibration's own check, as on the command line.
const COUNT: gonio_core::bound::Bound = gonio_core::bound::Bound::new(0.0, u32::MAX as f64, "");

/// A choice by name (`"least-squares"`); the error names the argument and the choices
/// (`method="magic": expected least-squares or paper`).
fn choice<T: FromStr<Err: std::fmt::Display>>(arg: &str, value: &str) -> PyResult<T> {
    value.parse().map_err(|e| refuse(format!("{arg}={e}")))
}

/// A path or a text as the document the results read.
fn document(src: Source) -> Document {
    match src {
        Source::Path(p) => Document::File(p),
        Source::Text { name, text } => Document::Given { name, text },
    }
}

/// An optional document argument (`instrument`, `meta`): a path or TOML text.
fn opt_document(obj: Option<&Bound<'_, PyAny>>, arg: &str) -> PyResult<Option<Document>> {
    Ok(convert::opt_source(obj, arg, false)?.map(document))
}

/// Polygon readings: a path, or an N×4 (N×5 with `repeat`) array.
fn polygon_table(obj: &Bound<'_, PyAny>, arg: &str) -> PyResult<Table> {
    if convert::is_path(obj) {
        return Ok(Table::File(obj.extract()?));
    }
    convert::table(obj, arg, |cols| {
        let mut h = vec!["shift_deg", "start_face", "step", "reading_arcsec"];
        match cols {
            4 => {}
            5 => h.push("repeat"),
            n => {
                return Err(format!(
                    "expected 4 columns (shift_deg, start_face, step, reading_arcsec) or 5 (… repeat), found {n}"
                ));
            }
        }
        Ok(h.into_iter().map(String::from).collect())
    })
    .map(Table::Given)
}

/// Head readings: a path, or an array of `position_deg` and the heads' columns (`head_2` …
/// `head_M`, with `raw` `head_1` … `head_M`), optionally a last `turn` column.
fn heads_table(obj: &Bound<'_, PyAny>, arg: &str, m: usize, raw: bool) -> PyResult<Table> {
    if convert::is_path(obj) {
        return Ok(Table::File(obj.extract()?));
    }
    let first = if raw { 1 } else { 2 };
    convert::table(obj, arg, |cols| {
        let mut h = vec!["position_deg".to_string()];
        h.extend((first..=m).map(|k| format!("head_{k}")));
        if cols == h.len() + 1 {
            h.push("turn".into());
        }
        if cols != h.len() {
            return Err(format!(
                "expected {} columns (position_deg, head_{first} … head_{m}, optionally turn), found {cols}",
                m + 2 - first
            ));
        }
        Ok(h)
    })
    .map(Table::Given)
}

/// Calibrates an encoder from polygon and autocollimator readings by the shift-angle method
/// (Hsieh et al., 2022): the certificate `gonio shift-angle --json` writes, as a dict.
///
/// ``readings`` is a CSV path (``shift_deg,start_face,step,reading_arcsec[,repeat]``) or an
/// N×4 (N×5 with ``repeat``) array with those columns. ``method`` is ``"least-squares"`` or
/// ``"paper"``; ``sigma`` the σ of one reading (arcsec) if known; ``instrument`` a TOML file
/// (or its text) of instrument terms; ``coverage`` the p of U (None: the instrument file's,
/// else 0.95).
///
/// Example::
///
///     cert = gonio.shift_angle("lab/readings.csv", sigma=0.05)
///     alpha = [(p["angle_deg"], p["value_arcsec"]) for p in cert["encoder_errors"]]
#[pyfunction]
#[pyo3(signature = (readings, method="least-squares", sigma=None, instrument=None, coverage=None, faces=None, check_order=None, meta=None))]
#[allow(clippy::too_many_arguments)]
pub fn shift_angle<'py>(
    py: Python<'py>,
    readings: &Bound<'py, PyAny>,
    method: &str,
    sigma: Option<f64>,
    instrument: Option<&Bound<'py, PyAny>>,
    coverage: Option<f64>,
    faces: Option<&Bound<'py, PyAny>>,
    check_order: Option<&Bound<'py, PyAny>>,
    meta: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let faces = convert::opt_whole::<usize>(faces, "faces", COUNT)?;
    let check_order = convert::opt_whole::<u32>(check_order, "check_order", COUNT)?.unwrap_or(2);
    let method: Method = choice("method", method)?;
    let instrument = opt_document(instrument, "instrument")?;
    let meta = opt_document(meta, "meta")?;
    let request = results::shift_angle::Request {
        readings: polygon_table(readings, "readings")?,
        faces,
        method,
        sigma_arcsec: sigma,
        check_order,
        instrument,
        coverage,
        meta,
    };
    let name = request.readings.name();
    let cert = py
        .detach(|| results::shift_angle::evaluate(&Inputs::new(), request))
        .or_gonio()?;
    convert::to_python(py, &cert, &name)
}

/// Head numbers (1-based): `"1,7"` or a sequence of ints, as the command line's `--reference`.
fn reference(obj: Option<&Bound<'_, PyAny>>) -> PyResult<String> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Ok("1".into());
    };
    if let Ok(s) = obj.extract::<String>() {
        return Ok(s);
    }
    let list = obj
        .extract::<Vec<i64>>()
        .map_err(|_| refuse("reference: expected \"1,7\" or a list of head numbers"))?;
    Ok(list
        .iter()
        .map(i64::to_string)
        .collect::<Vec<_>>()
        .join(","))
}

/// Self-calibrates an encoder from several read heads: the certificate `gonio selfcal --json`
/// writes, as a dict.
///
/// ``readings`` is a CSV path (``position_deg,head_2,…,head_M``, arcsec, relative to head 1;
/// with ``raw=True`` ``position_deg,head_1,…,head_M`` in degrees; optional ``turn``; at most
/// 256 MiB, as on the command line) or an array with those columns. ``heads`` is
/// ``"selfa12"``, ``"eda:N"`` or a heads file (TOML/JSON); ``method`` ``"fourier"`` or
/// ``"eda"``; ``noise_model`` ``"readings"`` or ``"differences"``; ``reference`` the heads
/// (1-based) whose average is calibrated.
///
/// Example::
///
///     cert = gonio.selfcal("heads/readings.csv", heads="selfa12")
///     print(cert["uncertainty"]["coverage"], len(cert["errors"]))
#[pyfunction]
#[pyo3(signature = (readings, heads="selfa12", method="fourier", raw=false, noise_model="readings", reference=None, max_order=None, instrument=None, coverage=None, meta=None))]
#[allow(clippy::too_many_arguments)]
pub fn selfcal<'py>(
    py: Python<'py>,
    readings: &Bound<'py, PyAny>,
    heads: &str,
    method: &str,
    raw: bool,
    noise_model: &str,
    reference: Option<&Bound<'py, PyAny>>,
    max_order: Option<&Bound<'py, PyAny>>,
    instrument: Option<&Bound<'py, PyAny>>,
    coverage: Option<f64>,
    meta: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let max_order = convert::opt_whole::<u32>(max_order, "max_order", COUNT)?.unwrap_or(360);
    let method: SelfcalMethod = choice("method", method)?;
    let noise_model: NoiseModel = choice("noise_model", noise_model)?;
    let reference = self::reference(reference)?;
    let instrument = opt_document(instrument, "instrument")?;
    let meta = opt_document(meta, "meta")?;
    let inputs = Inputs::new();
    let (heads, _) = heads::load(&inputs, heads).or_gonio()?;
    let request = results::selfcal::Request {
        readings: heads_table(readings, "readings", heads.len(), raw)?,
        heads,
        method,
        raw,
        noise_model,
        reference,
        max_order,
        instrument,
        coverage,
        meta,
    };
    let name = request.readings.name();
    let cert = py
        .detach(|| results::selfcal::evaluate(&inputs, request))
        .or_gonio()?;
    convert::to_python(py, &cert, &name)
}

/// Calibrates an encoder from polygon readings and read-head readings in one least squares:
/// the certificate `gonio joint --json` writes, as a dict.
///
/// ``readings`` as for :func:`shift_angle`, ``heads_readings`` as for :func:`selfcal` (paths or
/// arrays); ``faces`` the polygon's N; ``sigma_polygon``/``sigma_heads`` each instrument's σ
/// (arcsec; default: from its own residuals).
///
/// Example::
///
///     cert = gonio.joint("poly/readings.csv", "heads/readings.csv", faces=24, heads="selfa12")
///     print(cert["joint"]["chi2"])
#[pyfunction]
#[pyo3(signature = (readings, heads_readings, faces, heads="selfa12", raw=false, sigma_polygon=None, sigma_heads=None, noise_model="readings", head_angles="measured", interpolation="linear", max_order=None, blind_max_order=None, instrument=None, coverage=None, meta=None))]
#[allow(clippy::too_many_arguments)]
pub fn joint<'py>(
    py: Python<'py>,
    readings: &Bound<'py, PyAny>,
    heads_readings: &Bound<'py, PyAny>,
    faces: &Bound<'py, PyAny>,
    heads: &str,
    raw: bool,
    sigma_polygon: Option<f64>,
    sigma_heads: Option<f64>,
    noise_model: &str,
    head_angles: &str,
    interpolation: &str,
    max_order: Option<&Bound<'py, PyAny>>,
    blind_max_order: Option<&Bound<'py, PyAny>>,
    instrument: Option<&Bound<'py, PyAny>>,
    coverage: Option<f64>,
    meta: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let faces = convert::opt_whole::<usize>(Some(faces), "faces", COUNT)?
        .ok_or_else(|| refuse("faces=None: expected the polygon's number of faces"))?;
    let max_order = convert::opt_whole::<u32>(max_order, "max_order", COUNT)?.unwrap_or(360);
    let blind_max_order = convert::opt_whole::<u32>(blind_max_order, "blind_max_order", COUNT)?;
    let noise_model: NoiseModel = choice("noise_model", noise_model)?;
    let head_angles: HeadAngles = choice("head_angles", head_angles)?;
    let interpolation: Interpolation = choice("interpolation", interpolation)?;
    results::joint::check(faces, max_order, blind_max_order).or_gonio()?;
    let instrument = opt_document(instrument, "instrument")?;
    let meta = opt_document(meta, "meta")?;
    let readings = polygon_table(readings, "readings")?;
    let inputs = Inputs::new();
    let (heads, _) = heads::load(&inputs, heads).or_gonio()?;
    let request = results::joint::Request {
        readings,
        heads_readings: heads_table(heads_readings, "heads_readings", heads.len(), raw)?,
        faces,
        heads,
        raw,
        sigma_polygon_arcsec: sigma_polygon,
        sigma_heads_arcsec: sigma_heads,
        noise_model,
        head_angles,
        interpolation,
        max_order,
        blind_max_order,
        instrument,
        coverage,
        meta,
    };
    let name = request.readings.name();
    let cert = py
        .detach(|| results::joint::evaluate(&inputs, request))
        .or_gonio()?;
    convert::to_python(py, &cert, &name)
}

/// Compares two calibration certificates of one encoder at their common angles (differences,
/// En): what `gonio compare --json` writes, as a dict.
///
/// ``cert_a`` and ``cert_b`` are certificate files or the dicts gonio returned (``cert_b`` may
/// also be a simulator's ``truth.json``).
///
/// Example::
///
///     c = gonio.compare(gonio.shift_angle("lab/readings.csv"), "heads/selfcal.json")
///     print(c["max_en"], c["all_en_pass"])
#[pyfunction]
pub fn compare<'py>(
    py: Python<'py>,
    cert_a: &Bound<'py, PyAny>,
    cert_b: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyAny>> {
    let a = document(convert::source(cert_a, "cert_a", true)?);
    let b = document(convert::source(cert_b, "cert_b", true)?);
    let c = results::compare::evaluate(&Inputs::new(), &a, &b).or_gonio()?;
    convert::to_python(py, &c, "the comparison")
}

/// A certificate as a Digital Calibration Certificate (DCC v3.1.2 XML, D-SI 2.1.0): the text
/// `gonio certificate --dcc` writes.
///
/// ``cert`` is a certificate file or the dict gonio returned; ``meta`` the ISO/IEC 17025
/// metadata (a TOML file or its text, see ``examples/certificate-meta.toml``), replacing what
/// the certificate carries. Missing required metadata is an error unless ``draft=True``.
///
/// Example::
///
///     xml = gonio.dcc(cert, "examples/certificate-meta.toml")
///     open("cal.dcc.xml", "w").write(xml)
#[pyfunction]
#[pyo3(signature = (cert, meta=None, draft=false))]
pub fn dcc(
    cert: &Bound<'_, PyAny>,
    meta: Option<&Bound<'_, PyAny>>,
    draft: bool,
) -> PyResult<String> {
    let src = convert::source(cert, "cert", true)?;
    let mut c = src.parse(formats::certificate::parse).or_gonio()?;
    let meta = opt_document(meta, "meta")?;
    if let Some(m) = meta
        .map(|d| d.parse(&Inputs::new(), formats::meta::parse))
        .transpose()
        .or_gonio()?
    {
        c = c.with_meta(m);
    }
    gonio_report::dcc::write(&c, draft)
        .map_err(|e| {
            anyhow!(
                "{}: {e} (give them with meta=…, or draft=True for a draft)",
                src.name()
            )
        })
        .or_gonio()
}
