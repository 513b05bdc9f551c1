//! `budget`: a GUM uncertainty budget file evaluated, optionally with a JCGM 101 Monte Carlo run:
//! what `gonio budget --json` writes (`gonio_io::results::budget`).

use crate::convert::{self, OrGonio, Source, refuse};
use gonio_io::results::budget::{McRequest, Request, evaluate};
use gonio_uncertainty::limits::MAX_FILE_BYTES;
use pyo3::prelude::*;
use pyo3::types::PyBool;

/// `seed`: any 64-bit seed.
const SEED: gonio_core::bound::Bound = gonio_core::bound::Bound::new(0.0, u64::MAX as f64, "");

/// Evaluates a GUM uncertainty budget (TOML, docs/budget-format.md): what `gonio budget --json`
/// writes, as a dict (the reported budget's ``u_c``, ``nu_eff``, ``k``, ``U``, ``contributions``
/// … at the top level, every budget under ``budgets``).
///
/// ``toml_text_or_path`` is a path or the TOML text (a ``str`` with a line break).
/// ``monte_carlo``: ``True`` validates the GUM result by an adaptive JCGM 101 Monte Carlo run
/// (``seed``, ``ndig``), an ``int`` runs that many trials. ``budget`` names the budget to report
/// (default: the file's last); ``coverage`` overrides the file's.
///
/// Example::
///
///     r = gonio.budget("examples/budgets/hsieh2022-shift-angle.toml", monte_carlo=True)
///     print(r["u_c"], r["nu_eff"], r["k"], r["U"], r["monte_carlo"]["reported"])
#[pyfunction]
#[pyo3(signature = (toml_text_or_path, monte_carlo=None, coverage=None, budget=None, seed=None, ndig=None))]
pub fn budget<'py>(
    py: Python<'py>,
    toml_text_or_path: &Bound<'py, PyAny>,
    monte_carlo: Option<&Bound<'py, PyAny>>,
    coverage: Option<&Bound<'py, PyAny>>,
    budget: Option<String>,
    seed: Option<&Bound<'py, PyAny>>,
    ndig: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let coverage = convert::opt_real(coverage, "coverage", Some(gonio_uncertainty::COVERAGE))?;
    let seed = convert::opt_whole::<u64>(seed, "seed", SEED)?.unwrap_or(1);
    let ndig =
        convert::opt_whole::<u32>(ndig, "ndig", gonio_uncertainty::montecarlo::NDIG)?.unwrap_or(2);
    let mc = match monte_carlo {
        None => None,
        Some(m) if m.is_none() => None,
        Some(m) if m.is_instance_of::<PyBool>() => m.extract::<bool>()?.then_some(McRequest {
            seed,
            trials: None,
            ndig,
        }),
        Some(m) => Some(McRequest {
            seed,
            trials: Some(
                convert::opt_whole::<usize>(
                    Some(m),
                    "monte_carlo",
                    gonio_uncertainty::montecarlo::TRIALS,
                )?
                .ok_or_else(|| {
                    refuse("monte_carlo: expected True (adaptive), a number of trials, or None")
                })?,
            ),
            ndig,
        }),
    };
    let req = Request {
        coverage,
        name: budget,
        monte_carlo: mc,
    };
    let src = convert::source(toml_text_or_path, "budget", false)?;
    let file = src.name();
    let bytes = match src {
        Source::Path(p) => gonio_io::input::Inputs::new()
            .read_bytes(&p, MAX_FILE_BYTES)
            .or_gonio()?,
        Source::Text { text, .. } => text.into_bytes(),
    };
    let e = py
        .detach(|| evaluate(&bytes, &file, &req, |_| {}))
        .or_gonio()?;
    convert::to_python(py, &e.output(), &file)
}
