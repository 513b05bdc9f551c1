//! The calibrations: `shift_angle`, `selfcal`, `joint` (certificates, `gonio.certificate/1`),
//! `compare` (two certificates) and `dcc` (a certificate as a Digital Calibration Certificate).
//! Each takes the steps of its command (`gonio shift-angle`, `selfcal`, `joint`, `compare`,
//! `certificate --dcc`) through the same parsers and library calls.

use crate::convert::{self, OrGonio, Source, refuse};
use anyhow::anyhow;
use gonio_calib::certificate::{Certificate, CertificateMeta, Instrument};
use gonio_calib::joint::{HeadAngles, Interpolation, JointError, JointOptions};
use gonio_calib::selfcal::{Method as SelfcalMethod, NoiseModel, SelfcalOptions};
use gonio_calib::shift_angle::{Method, Options};
use gonio_io::formats::csv::CsvTable;
use gonio_io::formats::heads::{self, locate, read_turns};
use gonio_io::formats::{self, curve, readings};
use pyo3::prelude::*;
use std::path::{Path, PathBuf};

/// Most harmonic orders in a table (`max_order`), as the commands allow.
const MAX_ORDER: u32 = 100_000;

/// One of `choices` by name; the error names the argument and the choices.
fn choice<T: Copy>(arg: &str, value: &str, choices: &[(&str, T)]) -> PyResult<T> {
    choices
        .iter()
        .find(|(n, _)| *n == value)
        .map(|(_, v)| *v)
        .ok_or_else(|| {
            let names: Vec<&str> = choices.iter().map(|(n, _)| *n).collect();
            refuse(format!("{arg}={value:?}: expected {}", names.join(" or ")))
        })
}

/// A readings input: a file, or a table built from an array.
enum Table {
    File(PathBuf),
    Array(CsvTable),
}

impl Table {
    fn name(&self) -> String {
        match self {
            Table::File(p) => p.display().to_string(),
            Table::Array(t) => t.name.clone(),
        }
    }

    fn read(self) -> anyhow::Result<CsvTable> {
        match self {
            Table::File(p) => CsvTable::read(&p),
            Table::Array(t) => Ok(t),
        }
    }
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
    .map(Table::Array)
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
    .map(Table::Array)
}

/// The instrument terms (a TOML file or text) with the coverage asked for.
fn instrument(src: Option<Source>, coverage: Option<f64>) -> anyhow::Result<Instrument> {
    match src {
        Some(Source::Path(p)) => formats::instrument::load(Some(&p), coverage),
        Some(Source::Text { name, text }) => {
            let file = gonio_uncertainty::instrument::InstrumentFile::parse_bytes(text.as_bytes())
                .map_err(|e| anyhow!("{name}:{e}"))?;
            let inst = Instrument::new(file, Some(name));
            match coverage {
                Some(c) => inst
                    .with_coverage(c)
                    .map_err(|e| anyhow!("--coverage {c}: {e}")),
                None => Ok(inst),
            }
        }
        None => formats::instrument::load(None, coverage),
    }
}

fn meta(src: Option<Source>) -> anyhow::Result<Option<CertificateMeta>> {
    src.map(|s| s.parse(formats::meta::parse)).transpose()
}

/// The certificate with its metadata, checked finite (as the commands do before any output),
/// as Python objects.
fn certificate<'py>(
    py: Python<'py>,
    mut cert: Certificate,
    meta: Option<CertificateMeta>,
    input: &str,
) -> PyResult<Bound<'py, PyAny>> {
    if let Some(m) = meta {
        cert = cert.with_meta(m);
    }
    gonio_io::json::finite_result(&cert, Path::new(input), "the calibration").or_gonio()?;
    convert::to_python(py, &cert, input)
}

/// Calibrates an encoder from polygon and autocollimator readings by the shift-angle method
/// (Hsieh et al., 2022): the certificate `gonio shift-angle --json` writes, as a dict.
///
/// ``readings`` is a CSV path (``shift_deg,start_face,step,reading_arcsec[,repeat]``) or an
/// N×4 (N×5 with ``repeat``) array with those columns. ``method`` is ``"least-squares"`` or
/// ``"paper"``; ``sigma`` the σ of one reading (arcsec) if known; ``instrument`` a TOML file
/// (or its text) of instrument terms; ``coverage`` the p of U (None: the instrument file's).
///
/// Example::
///
///     cert = gonio.shift_angle("lab/readings.csv", sigma=0.05)
///     alpha = [(p["angle_deg"], p["value_arcsec"]) for p in cert["encoder_errors"]]
#[pyfunction]
#[pyo3(signature = (readings, method="least-squares", sigma=None, instrument=None, coverage=Some(0.95), faces=None, check_order=2, meta=None))]
#[allow(clippy::too_many_arguments)]
pub fn shift_angle<'py>(
    py: Python<'py>,
    readings: &Bound<'py, PyAny>,
    method: &str,
    sigma: Option<f64>,
    instrument: Option<&Bound<'py, PyAny>>,
    coverage: Option<f64>,
    faces: Option<usize>,
    check_order: u32,
    meta: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let method = choice(
        "method",
        method,
        &[
            ("least-squares", Method::LeastSquares),
            ("ls", Method::LeastSquares),
            ("paper", Method::Paper),
        ],
    )?;
    let inst = convert::opt_source(instrument, "instrument", false)?;
    let meta_src = convert::opt_source(meta, "meta", false)?;
    let table = polygon_table(readings, "readings")?;
    let name = table.name();
    let (cert, meta) = py
        .detach(|| -> anyhow::Result<_> {
            let instrument = self::instrument(inst, coverage)?;
            let meta = self::meta(meta_src)?;
            let set = match table {
                Table::File(p) => readings::read(&p, faces)?,
                Table::Array(t) => readings::from_table(&t, faces)?,
            };
            let opts = Options {
                method,
                sigma_arcsec: sigma,
                ..Options::default()
            };
            let cal = gonio_calib::shift_angle::calibrate(&set, &opts)
                .map_err(|e| anyhow!("{name}: {e}"))?;
            let cert = Certificate::from_shift_angle(
                &cal,
                &set,
                sigma.is_some(),
                check_order,
                &instrument,
            )?;
            Ok((cert, meta))
        })
        .or_gonio()?;
    certificate(py, cert, meta, &name)
}

/// Head numbers (1-based, `"1,7"` or a sequence of ints) as 0-based indices.
fn reference_heads(obj: &Bound<'_, PyAny>, m: usize) -> PyResult<Vec<usize>> {
    let list: Vec<String> = match obj.extract::<String>() {
        Ok(s) => s.split(',').map(|p| p.trim().to_string()).collect(),
        Err(_) => obj
            .extract::<Vec<i64>>()
            .map_err(|_| refuse("reference: expected \"1,7\" or a list of head numbers"))?
            .iter()
            .map(i64::to_string)
            .collect(),
    };
    list.iter()
        .map(|p| {
            p.parse::<usize>()
                .ok()
                .filter(|h| (1..=m).contains(h))
                .map(|h| h - 1)
                .ok_or_else(|| refuse(format!("reference: {p:?} is not a head number in 1..={m}")))
        })
        .collect()
}

/// Self-calibrates an encoder from several read heads: the certificate `gonio selfcal --json`
/// writes, as a dict.
///
/// ``readings`` is a CSV path (``position_deg,head_2,…,head_M``, arcsec, relative to head 1;
/// with ``raw=True`` ``position_deg,head_1,…,head_M`` in degrees; optional ``turn``) or an array
/// with those columns. ``heads`` is ``"selfa12"``, ``"eda:N"`` or a heads file (TOML/JSON);
/// ``method`` ``"fourier"`` or ``"eda"``; ``noise_model`` ``"readings"`` or ``"differences"``;
/// ``reference`` the heads (1-based) whose average is calibrated.
///
/// Example::
///
///     cert = gonio.selfcal("heads/readings.csv", heads="selfa12")
///     print(cert["uncertainty"]["coverage"], len(cert["errors"]))
#[pyfunction]
#[pyo3(signature = (readings, heads="selfa12", method="fourier", raw=false, noise_model="readings", reference=None, max_order=360, instrument=None, coverage=Some(0.95), meta=None))]
#[allow(clippy::too_many_arguments)]
pub fn selfcal<'py>(
    py: Python<'py>,
    readings: &Bound<'py, PyAny>,
    heads: &str,
    method: &str,
    raw: bool,
    noise_model: &str,
    reference: Option<&Bound<'py, PyAny>>,
    max_order: u32,
    instrument: Option<&Bound<'py, PyAny>>,
    coverage: Option<f64>,
    meta: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let (heads, _) = heads::load(heads).or_gonio()?;
    if max_order > MAX_ORDER {
        return Err(refuse(format!(
            "max_order={max_order}: expected at most {MAX_ORDER}"
        )));
    }
    let method = choice(
        "method",
        method,
        &[
            ("fourier", SelfcalMethod::Fourier),
            ("eda", SelfcalMethod::Eda),
            ("selfa", SelfcalMethod::Eda),
        ],
    )?;
    let noise_model = choice(
        "noise_model",
        noise_model,
        &[
            ("readings", NoiseModel::Readings),
            ("differences", NoiseModel::Differences),
        ],
    )?;
    let reference_heads = match reference {
        Some(r) if !r.is_none() => reference_heads(r, heads.len())?,
        _ => vec![0],
    };
    let table = heads_table(readings, "readings", heads.len(), raw)?;
    let name = table.name();
    let inst = convert::opt_source(instrument, "instrument", false)?;
    let meta_src = convert::opt_source(meta, "meta", false)?;
    let (cert, meta) = py
        .detach(|| -> anyhow::Result<_> {
            let table = table.read()?;
            let rt = read_turns(&table, &heads, raw)?;
            let opts = SelfcalOptions {
                method,
                noise_model,
                reference_heads,
                max_order,
            };
            let instrument = self::instrument(inst, coverage)?;
            let meta = self::meta(meta_src)?;
            let r = gonio_calib::selfcal::calibrate(&heads, &rt.turns, &opts)
                .map_err(|e| locate(e, &table, &rt.lines))?;
            Ok((Certificate::from_selfcal(&r, &instrument)?, meta))
        })
        .or_gonio()?;
    certificate(py, cert, meta, &name)
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
#[pyo3(signature = (readings, heads_readings, faces, heads="selfa12", raw=false, sigma_polygon=None, sigma_heads=None, noise_model="readings", head_angles="measured", interpolation="linear", max_order=360, blind_max_order=None, instrument=None, coverage=Some(0.95), meta=None))]
#[allow(clippy::too_many_arguments)]
pub fn joint<'py>(
    py: Python<'py>,
    readings: &Bound<'py, PyAny>,
    heads_readings: &Bound<'py, PyAny>,
    faces: usize,
    heads: &str,
    raw: bool,
    sigma_polygon: Option<f64>,
    sigma_heads: Option<f64>,
    noise_model: &str,
    head_angles: &str,
    interpolation: &str,
    max_order: u32,
    blind_max_order: Option<u32>,
    instrument: Option<&Bound<'py, PyAny>>,
    coverage: Option<f64>,
    meta: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let opts = JointOptions {
        sigma_polygon_arcsec: sigma_polygon,
        sigma_heads_arcsec: sigma_heads,
        noise_model: choice(
            "noise_model",
            noise_model,
            &[
                ("readings", NoiseModel::Readings),
                ("differences", NoiseModel::Differences),
            ],
        )?,
        head_angles: choice(
            "head_angles",
            head_angles,
            &[
                ("measured", HeadAngles::Measured),
                ("nominal", HeadAngles::Nominal),
            ],
        )?,
        interpolation: choice(
            "interpolation",
            interpolation,
            &[
                ("linear", Interpolation::Linear),
                ("trigonometric", Interpolation::Trigonometric),
            ],
        )?,
        max_order,
        blind_max_order,
        coverage: 0.95,
    };
    readings::check_faces(faces).or_gonio()?;
    if max_order > MAX_ORDER || blind_max_order.is_some_and(|k| k > MAX_ORDER) {
        return Err(refuse(format!(
            "max_order and blind_max_order: expected at most {MAX_ORDER}"
        )));
    }
    let inst = convert::opt_source(instrument, "instrument", false)?;
    let meta_src = convert::opt_source(meta, "meta", false)?;
    let poly = polygon_table(readings, "readings")?;
    let (heads, _) = heads::load(heads).or_gonio()?;
    let head_table = heads_table(heads_readings, "heads_readings", heads.len(), raw)?;
    let (poly_name, heads_name) = (poly.name(), head_table.name());
    let (cert, meta) = py
        .detach(|| -> anyhow::Result<_> {
            let instrument = self::instrument(inst, coverage)?;
            let meta = self::meta(meta_src)?;
            let opts = JointOptions {
                coverage: instrument.terms.coverage,
                ..opts
            };
            let set = match poly {
                Table::File(p) => readings::read(&p, Some(faces))?,
                Table::Array(t) => readings::from_table(&t, Some(faces))?,
            };
            let table = head_table.read()?;
            let rt = read_turns(&table, &heads, raw)?;
            let cal = gonio_calib::joint::calibrate(&set, &heads, &rt.turns, &opts).map_err(
                |e| match e {
                    JointError::Heads(h) => locate(h, &table, &rt.lines),
                    JointError::Polygon(p) => anyhow!("{poly_name}: {p}"),
                    e @ JointError::OffGrid { .. } => anyhow!("{poly_name} and {heads_name}: {e}"),
                    e => anyhow!("{e}"),
                },
            )?;
            Ok((Certificate::from_joint(&cal, &instrument)?, meta))
        })
        .or_gonio()?;
    certificate(py, cert, meta, &poly_name)
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
    let a = convert::source(cert_a, "cert_a", true)?;
    let b = convert::source(cert_b, "cert_b", true)?;
    let a = a.parse(curve::parse).or_gonio()?;
    let b = b.parse(curve::parse).or_gonio()?;
    let c = gonio_calib::compare::compare(&a, &b).map_err(|e| refuse(e.to_string()))?;
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
    if let Some(m) = self::meta(convert::opt_source(meta, "meta", false)?).or_gonio()? {
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
