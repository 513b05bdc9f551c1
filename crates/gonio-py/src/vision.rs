//! The mounting side: `detect` (one frame through the ring detector, read where numpy holds
//! it), `detect_many` (a stack of frames on worker threads, without the GIL) and `eccentricity`
//! (one turn's fit and the station's quality verdict).

use crate::convert::{self, OrGonio, Source, refuse};
use anyhow::anyhow;
use gonio_io::formats::{frames, samples};
use gonio_io::results::detect::Line;
use gonio_io::results::eccentricity::{Settings, evaluate};
use gonio_station::fit::FitMethod;
use gonio_station::{Recipe, recipe};
use gonio_vision::{
    DetectInOrderError, Detector, FrameHeader, FrameSource, FrameStamp, Optics, SourceError,
    detect_in_order,
};
use numpy::{PyReadonlyArray2, PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyList;
use std::sync::Mutex;

/// Detectors made for earlier calls, with their optics: a detector is sized once for its
/// optics, and a call takes one (or makes one) and gives it back.
static DETECTORS: Mutex<Vec<(Optics, Detector)>> = Mutex::new(Vec::new());

/// `threads` of `detect_many`: as `gonio detect --threads`.
const THREADS: gonio_core::bound::Bound = gonio_core::bound::Bound::new(1.0, 256.0, "");

/// At most this many detectors are kept.
const KEPT_DETECTORS: usize = 8;

fn take_detector(optics: &Optics) -> anyhow::Result<Detector> {
    let mut pool = DETECTORS.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(k) = pool.iter().position(|(o, _)| o == optics) {
        return Ok(pool.swap_remove(k).1);
    }
    drop(pool);
    Ok(Detector::new(optics)?)
}

fn give_back(optics: Optics, det: Detector) {
    let mut pool = DETECTORS.lock().unwrap_or_else(|e| e.into_inner());
    if pool.len() < KEPT_DETECTORS {
        pool.push((optics, det));
    }
}

/// The optics: a TOML file (or its text), or the station of Yu et al., 2024.
fn optics(obj: Option<&Bound<'_, PyAny>>) -> PyResult<Optics> {
    match convert::opt_source(obj, "optics", false)? {
        None => Ok(Optics::default()),
        Some(Source::Path(p)) => {
            frames::load_optics(&gonio_io::input::Inputs::new(), Some(&p)).or_gonio()
        }
        Some(s) => s.parse(frames::parse_optics).or_gonio(),
    }
}

/// A frame as `gonio detect` reports it (the line's JSON) for frame `index`.
fn line_json(
    index: usize,
    r: &gonio_vision::FrameResult,
    um_per_px: f64,
) -> anyhow::Result<Vec<u8>> {
    let line = Line::new(index, None, None, None, r, um_per_px);
    gonio_io::json::check_finite(&line).map_err(|e| anyhow!("frame {index}: {e}"))?;
    Ok(serde_json::to_vec(&line)?)
}

/// Finds the alignment ring's column c in one 8-bit grey frame: the keys of one line of
/// `gonio detect` (``c_px``, ``c_um``, ``valid``, ``reason``, ``score``, ``margin``, ``edges``
/// …; ``frame`` is 0, ``theta_deg`` and ``time_s`` None).
///
/// ``frame`` is a 2-D ``uint8`` array (height × width) of the optics' window (default 1440×540)
/// or sensor size (the window is cut out). A C-contiguous array is read where it lies, not
/// copied; any other (Fortran order, a strided view) is copied once into C order, so that rows
/// are always rows. ``optics`` is an optics TOML file (or its text); default: the station of Yu
/// et al., 2024.
///
/// Example::
///
///     import numpy as np
///     from PIL import Image
///     frame = np.asarray(Image.open("frames/frame_00000.png").convert("L"))
///     r = gonio.detect(frame)
///     print(r["valid"], r["c_px"], r["score"])
#[pyfunction]
#[pyo3(signature = (frame, optics=None))]
pub fn detect<'py>(
    py: Python<'py>,
    frame: &Bound<'py, PyAny>,
    optics: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let optics = self::optics(optics)?;
    let a: PyReadonlyArray2<'py, u8> = frame
        .extract()
        .map_err(|_| refuse("frame: expected a 2-D numpy array of uint8 (height × width)"))?;
    let (h, w) = (a.shape()[0], a.shape()[1]);
    let mut copy = Vec::new();
    let pixels = convert::c_order(&a, &mut copy);
    let um_per_px = optics
        .params()
        .map_err(|e| refuse(e.to_string()))?
        .um_per_px;
    let mut det = take_detector(&optics).or_gonio()?;
    let mut scratch = Vec::new();
    let r = optics
        .crop_window(w, h, pixels, &mut scratch)
        .and_then(|f| det.detect(f))
        .map_err(|e| refuse(format!("frame: {e}")));
    give_back(optics, det);
    let json = line_json(0, &r?, um_per_px).or_gonio()?;
    convert::from_json(py, &json)
}

/// Frames of an N×H×W array, one after another (the stream `gonio detect --raw` reads).
struct Stack<'a> {
    pixels: &'a [u8],
    width: usize,
    height: usize,
    next: usize,
}

impl FrameSource for Stack<'_> {
    type Error = std::convert::Infallible;
    fn next_frame(&mut self, pixels: &mut Vec<u8>) -> Result<Option<FrameHeader>, Self::Error> {
        let n = self.width * self.height;
        let Some(frame) = self.pixels.get(self.next * n..(self.next + 1) * n) else {
            return Ok(None);
        };
        pixels.clear();
        pixels.extend_from_slice(frame);
        let index = self.next as u64;
        self.next += 1;
        Ok(Some(FrameHeader {
            width: self.width,
            height: self.height,
            stamp: FrameStamp {
                index,
                ..FrameStamp::default()
            },
        }))
    }
}

/// Finds the ring in every frame of an N×H×W ``uint8`` array on ``threads`` worker threads
/// (1 to 256, as ``gonio detect --threads``; default: every core, at most 256), without holding
/// the GIL: a list of what :func:`detect` returns, in frame order (``frame`` = the index), the
/// same values whatever the thread count. An array that is not C-contiguous is copied once into
/// C order, as for :func:`detect`.
///
/// Example::
///
///     stack = np.stack([frame0, frame1, frame2])
///     cs = [r["c_px"] for r in gonio.detect_many(stack, threads=2)]
#[pyfunction]
#[pyo3(signature = (frames, threads=None, optics=None))]
pub fn detect_many<'py>(
    py: Python<'py>,
    frames: &Bound<'py, PyAny>,
    threads: Option<&Bound<'py, PyAny>>,
    optics: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyList>> {
    let threads = convert::opt_whole::<usize>(threads, "threads", THREADS)?;
    let optics = self::optics(optics)?;
    let a: PyReadonlyArray3<'py, u8> = frames.extract().map_err(|_| {
        refuse("frames: expected a 3-D numpy array of uint8 (frames × height × width)")
    })?;
    let (h, w) = (a.shape()[1], a.shape()[2]);
    let mut copy = Vec::new();
    let pixels: &[u8] = convert::c_order3(&a, &mut copy);
    let threads = threads.unwrap_or_else(|| {
        std::thread::available_parallelism().map_or(1, |n| n.get().min(THREADS.hi() as usize))
    });
    let um_per_px = optics
        .params()
        .map_err(|e| refuse(e.to_string()))?
        .um_per_px;
    let lines = py
        .detach(|| -> anyhow::Result<Vec<Vec<u8>>> {
            let src = Stack {
                pixels,
                width: w,
                height: h,
                next: 0,
            };
            let mut lines = Vec::new();
            detect_in_order(src, &optics, threads, |_, item| -> anyhow::Result<()> {
                match item {
                    Ok(d) => {
                        lines.push(line_json(d.stamp.index as usize, &d.result, um_per_px)?);
                        Ok(())
                    }
                    Err(SourceError::Frame { index, error }) => {
                        Err(anyhow!("frames[{index}]: {error}"))
                    }
                    Err(e) => Err(anyhow!("frames: {e}")),
                }
            })
            .map_err(|e| match e {
                DetectInOrderError::Sink(e) => e,
                e => anyhow!(e.to_string()),
            })?;
            Ok(lines)
        })
        .or_gonio()?;
    let out = PyList::empty(py);
    for l in &lines {
        out.append(convert::from_json(py, l)?)?;
    }
    Ok(out)
}

/// The eccentricity of a grating from one turn's samples: what `gonio eccentricity --json`
/// writes (``e_um``, ``u_e_um``, ``theta_max_deg``, ``c0_px``, ``residual_rms_px`` …,
/// ``quality_ok`` and ``quality_reasons``, the station's quality gate).
///
/// ``theta_deg`` and ``c_px`` are 1-D arrays (servo angle at mid-exposure in degrees,
/// increasing; the ring's column in px), or ``theta_deg`` is a CSV path (``theta_deg,c_px``)
/// and ``c_px`` None. ``method`` is ``"least-squares"`` or ``"paper"`` (Yu et al., 2024);
/// ``um_per_px`` and ``threshold_um`` default to the recipe's (a TOML file), else 0.75 and 5;
/// ``frames_taken`` to the number of samples. For arrays, ``outlier_lines`` are row numbers
/// (1-based).
///
/// Example::
///
///     theta = np.linspace(0, 358.2, 200)
///     c = 700 + 10 * np.cos(np.radians(theta - 40))
///     r = gonio.eccentricity(theta, c, um_per_px=0.75)
///     print(r["e_um"], r["theta_max_deg"], r["quality_ok"])
#[pyfunction]
#[pyo3(signature = (theta_deg, c_px=None, um_per_px=None, method="least-squares", frames_taken=None, threshold_um=None, recipe=None))]
#[allow(clippy::too_many_arguments)]
pub fn eccentricity<'py>(
    py: Python<'py>,
    theta_deg: &Bound<'py, PyAny>,
    c_px: Option<&Bound<'py, PyAny>>,
    um_per_px: Option<&Bound<'py, PyAny>>,
    method: &str,
    frames_taken: Option<&Bound<'py, PyAny>>,
    threshold_um: Option<&Bound<'py, PyAny>>,
    recipe: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let um_per_px = convert::opt_real(um_per_px, "um_per_px", Some(recipe::UM_PER_PX))?;
    let threshold_um = convert::opt_real(threshold_um, "threshold_um", Some(recipe::THRESHOLD_UM))?;
    let frames_taken =
        convert::opt_whole::<usize>(frames_taken, "frames_taken", recipe::FRAMES_PER_TURN)?;
    let method = match method {
        "least-squares" => FitMethod::LeastSquares,
        "paper" => FitMethod::Paper,
        m => {
            return Err(refuse(format!(
                "method={m:?}: expected least-squares or paper"
            )));
        }
    };
    let recipe = match convert::opt_source(recipe, "recipe", false)? {
        None => Recipe::default(),
        Some(s) => s.parse(gonio_io::formats::recipe::parse).or_gonio()?,
    };
    let settings = Settings::new(recipe, um_per_px, threshold_um).or_gonio()?;
    let read = match c_px.filter(|c| !c.is_none()) {
        None if convert::is_path(theta_deg) => {
            let p: std::path::PathBuf = theta_deg.extract()?;
            gonio_io::formats::csv::CsvTable::read(&gonio_io::input::Inputs::new(), &p)
                .and_then(samples::from_table)
                .or_gonio()?
        }
        None => {
            return Err(refuse(
                "c_px: expected an array beside theta_deg (or theta_deg a CSV path)",
            ));
        }
        Some(c) => {
            let t = convert::columns([(theta_deg, "theta_deg"), (c, "c_px")], "samples")?;
            samples::from_table(t).or_gonio()?
        }
    };
    let out = evaluate(&read, &settings, method, frames_taken).or_gonio()?;
    convert::to_python(py, &out, &read.table.name)
}
