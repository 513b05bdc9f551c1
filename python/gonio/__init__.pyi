"""Type stubs of gonio (the extension gonio._gonio, re-exported)."""

import os
from typing import Any, Literal, Sequence, Union

import numpy as np
import numpy.typing as npt

__version__: str

PathLike = Union[str, "os.PathLike[str]"]
# A path, or (a str with a line break) the file's TOML text.
PathOrText = Union[str, "os.PathLike[str]"]
# A certificate file, or the dict gonio returned.
CertLike = Union[str, "os.PathLike[str]", dict[str, Any]]
# A path, or a 2-D array of numbers (rows × the file's columns).
Table = Union[str, "os.PathLike[str]", npt.ArrayLike]

class GonioError(ValueError):
    """An input gonio refuses, with the command line's one-line message (file:line:column)."""

def shift_angle(
    readings: Table,
    method: Literal["least-squares", "ls", "paper"] = "least-squares",
    sigma: float | None = None,
    instrument: PathOrText | None = None,
    coverage: float | None = None,
    faces: int | None = None,
    check_order: int = 2,
    meta: PathOrText | None = None,
) -> dict[str, Any]:
    """The shift-angle certificate (``gonio shift-angle --json``) of polygon readings
    (``shift_deg, start_face, step, reading_arcsec[, repeat]``: a CSV path or an N×4/N×5 array).

    >>> cert = gonio.shift_angle("lab/readings.csv", sigma=0.05)
    >>> cert["encoder_errors"][0]["U_arcsec"]
    """

def selfcal(
    readings: Table,
    heads: str = "selfa12",
    method: Literal["fourier", "eda", "selfa"] = "fourier",
    raw: bool = False,
    noise_model: Literal["readings", "differences"] = "readings",
    reference: str | Sequence[int] | None = None,
    max_order: int = 360,
    instrument: PathOrText | None = None,
    coverage: float | None = None,
    meta: PathOrText | None = None,
) -> dict[str, Any]:
    """The self-calibration certificate (``gonio selfcal --json``) of read-head readings
    (``position_deg, head_2 … head_M`` or with ``raw`` ``head_1 … head_M``[, ``turn``]).

    >>> cert = gonio.selfcal("heads/readings.csv", heads="selfa12")
    """

def joint(
    readings: Table,
    heads_readings: Table,
    faces: int,
    heads: str = "selfa12",
    raw: bool = False,
    sigma_polygon: float | None = None,
    sigma_heads: float | None = None,
    noise_model: Literal["readings", "differences"] = "readings",
    head_angles: Literal["measured", "nominal"] = "measured",
    interpolation: Literal["linear", "trigonometric"] = "linear",
    max_order: int = 360,
    blind_max_order: int | None = None,
    instrument: PathOrText | None = None,
    coverage: float | None = None,
    meta: PathOrText | None = None,
) -> dict[str, Any]:
    """The polygon and the heads in one least squares (``gonio joint --json``).

    >>> cert = gonio.joint("poly/readings.csv", "heads/readings.csv", faces=24)
    """

def compare(cert_a: CertLike, cert_b: CertLike) -> dict[str, Any]:
    """Two certificates at their common angles: differences and En (``gonio compare --json``).

    >>> gonio.compare(cert, "sc/truth.json")["max_en"]
    """

def dcc(cert: CertLike, meta: PathOrText | None = None, draft: bool = False) -> str:
    """The certificate as a DCC v3.1.2 XML text (``gonio certificate --dcc``).

    >>> xml = gonio.dcc(cert, "examples/certificate-meta.toml")
    """

def budget(
    toml_text_or_path: PathOrText,
    monte_carlo: bool | int | None = None,
    coverage: float | None = None,
    budget: str | None = None,
    seed: int = 1,
    ndig: int = 2,
) -> dict[str, Any]:
    """A GUM budget evaluated (``gonio budget --json``), with a Monte Carlo run if asked.

    >>> gonio.budget("examples/budgets/hsieh2022-shift-angle.toml")["U"]
    0.1495…
    """

def detect(
    frame: npt.NDArray[np.uint8], optics: PathOrText | None = None
) -> dict[str, Any]:
    """One frame's ring detection (a ``gonio detect`` line); ``frame`` 2-D uint8 (a C-contiguous
    array is read in place, any other copied once into C order).

    >>> gonio.detect(frame)["c_px"]
    """

def detect_many(
    frames: npt.NDArray[np.uint8],
    threads: int | None = None,
    optics: PathOrText | None = None,
) -> list[dict[str, Any]]:
    """Every frame of an N×H×W uint8 array, on 1 to 256 worker threads without the GIL, in order.

    >>> [r["c_px"] for r in gonio.detect_many(stack)]
    """

def eccentricity(
    theta_deg: npt.ArrayLike | PathLike,
    c_px: npt.ArrayLike | None = None,
    um_per_px: float | None = None,
    method: Literal["least-squares", "paper"] = "least-squares",
    frames_taken: int | None = None,
    threshold_um: float | None = None,
    recipe: PathOrText | None = None,
) -> dict[str, Any]:
    """One turn's eccentricity fit and quality verdict (``gonio eccentricity --json``).

    >>> gonio.eccentricity(theta, c, um_per_px=0.75)["e_um"]
    """
