"""gonio for Python: precision rotary-encoder metrology.

The same certificates, budgets and detector results as the ``gonio`` command line, as plain
dicts with the keys and values of its JSON, on files or numpy arrays::

    import gonio
    cert = gonio.shift_angle("lab/readings.csv")           # gonio.certificate/1, as a dict
    r = gonio.budget("examples/budgets/hsieh2022-shift-angle.toml")   # r["U"] == 0.1495…
    c = gonio.detect(frame)["c_px"]                         # frame: 2-D uint8 numpy array

Errors are :class:`GonioError` (a ``ValueError``) with the command line's one-line message.
See docs/python.md.
"""

from ._gonio import (
    GonioError,
    __version__,
    budget,
    compare,
    dcc,
    detect,
    detect_many,
    eccentricity,
    joint,
    selfcal,
    shift_angle,
)

__all__ = [
    "GonioError",
    "__version__",
    "budget",
    "compare",
    "dcc",
    "detect",
    "detect_many",
    "eccentricity",
    "joint",
    "selfcal",
    "shift_angle",
]
