#!/usr/bin/env python3
"""The ring detector's stages in OpenCV, timed frame by frame: the peer for gonio's detector.

The same stages as the seed (Yu et al., 2024, Fig. 6), on one thread:

  1. closing with a disk of diameter 2d + 1 (d = 11 px: 23 x 23), subtract the input (black
     top-hat), opening with a disk of diameter ~d/2 (5 x 5), 5 x 5 Gaussian (binomial, sigma ~ 1);
  2. Sobel Gx, Gy; non-maximum suppression with hysteresis (Canny on those gradients, L1
     magnitude, the detector's thresholds); direction filter (|Gy| <= tan(tol) |Gx|);
  3. edge filling (the seed's Algorithm 1: an empty pixel between two edge pixels whose
     directions differ by less than 45 degrees); 8-connected labelling with statistics;
  4. features: per component the pixel count, the sums of row, column and direction and the
     strong-pixel count, components without a strong pixel dropped (hysteresis), the two
     largest taken, c = the mean of their centroid columns.

Each stage uses OpenCV's fastest call for it found here (e.g. findNonZero rather than
numpy.nonzero, connectedComponents with the statistics from the edge pixels rather than
connectedComponentsWithStats over the whole frame), and numpy only on the sparse edge pixels.

The disks, the thresholds and the direction range are gonio's (Optics::default(): ring width
8 um at 0.75 um/px). Frames are raw 8-bit, back to back (`gonio simulate frames --raw`).

The script installs what it needs (numpy, opencv-python-headless) into a virtual environment
beside it (bench/.venv) on first use, then runs itself there.

Usage:
  python3 bench/opencv_reference.py FRAMES.raw [--width 1440] [--height 540] [--count N]
                                     [--repeat K] [--json]
Prints per-stage and per-frame times (ms, median over the frames), or one JSON object. Times are
the thread's CPU time (time.thread_time), so that other work on the machine does not count.
"""

import os
import subprocess
import sys
import venv
from pathlib import Path

HERE = Path(__file__).resolve().parent
VENV = HERE / ".venv"
PACKAGES = ["numpy", "opencv-python-headless"]


def ensure_venv():
    """Re-runs this script under the virtual environment, creating it when missing."""
    py = VENV / "bin" / "python3"
    if Path(sys.prefix).resolve() == VENV.resolve():
        return
    if not py.exists():
        print(f"creating {VENV} and installing {' '.join(PACKAGES)}", file=sys.stderr)
        venv.EnvBuilder(with_pip=True).create(VENV)
        subprocess.run(
            [str(py), "-m", "pip", "install", "--quiet", *PACKAGES], check=True
        )
    os.execv(str(py), [str(py), str(Path(__file__).resolve()), *sys.argv[1:]])


# One thread everywhere, before numpy and OpenCV load.
for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[var] = "1"
ensure_venv()

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import time  # noqa: E402

import cv2  # noqa: E402
import numpy as np  # noqa: E402

cv2.setNumThreads(1)


def disk(r):
    """gonio's disk of radius r: the pixels with dx^2 + dy^2 <= r^2 + r."""
    y, x = np.mgrid[-r : r + 1, -r : r + 1]
    return (x * x + y * y <= r * r + r).astype(np.uint8)


class Params:
    """gonio's defaults (Optics::default().params())."""

    def __init__(self, height):
        um_per_px = 4.5 / 6.0
        d = round(8.0 / um_per_px)
        self.close = disk(d)
        self.open = disk(max(d // 4, 1))
        self.high = max(round(30.0 * 4.0 / 3.0), 2)
        self.low = max(self.high // 2, 1)
        half_um = height * um_per_px / 2.0
        tol = math.degrees(math.asin(min((half_um + 450.0) / 4500.0, 1.0))) + 10.0
        self.tan_tol = math.tan(math.radians(tol))


STAGES = [
    "top-hat (23x23 closing - input)",
    "opening (5x5)",
    "gaussian 5x5",
    "sobel",
    "nms + hysteresis (canny)",
    "direction filter",
    "edge filling",
    "labelling",
    "features",
]


def fill_edges(edge, ys, xs, dirs):
    """The seed's Algorithm 1: an empty pixel whose opposite neighbours (W-E, N-S, NW-SE, NE-SW,
    tried in that order) are both edge pixels with directions less than 45 degrees (32 of 256)
    apart becomes a weak edge with their mean direction. `edge` is the frame's edge mask (0/1),
    (ys, xs, dirs) its pixels; returns the filled pixels' rows, columns and directions."""
    h, w = edge.shape
    e = np.pad(edge, 1)
    v = lambda dy, dx: e[1 + dy : 1 + dy + h, 1 + dx : 1 + dx + w]  # noqa: E731
    pairs = [((0, -1), (0, 1)), ((-1, 0), (1, 0)), ((-1, -1), (1, 1)), ((-1, 1), (1, -1))]
    # Necessary condition on whole rows of bytes, then the directions at the few candidates.
    cand = v(0, -1) & v(0, 1)
    for (ay, ax), (by, bx) in pairs[1:]:
        cand |= v(ay, ax) & v(by, bx)
    pts = cv2.findNonZero(cand & (edge == 0))
    if pts is None:
        empty = np.zeros(0, np.int64)
        return empty, empty, np.zeros(0, np.int16)
    pts = pts.reshape(-1, 2)
    cx, cy = pts[:, 0], pts[:, 1]
    dmap = np.zeros((h + 2, w + 2), np.int16)
    dmap[ys + 1, xs + 1] = dirs
    todo = np.ones(len(cy), bool)
    fy, fx, fd = [], [], []
    for (ay, ax), (by, bx) in pairs:
        ea, eb = e[cy + 1 + ay, cx + 1 + ax], e[cy + 1 + by, cx + 1 + bx]
        da, db = dmap[cy + 1 + ay, cx + 1 + ax], dmap[cy + 1 + by, cx + 1 + bx]
        diff = (db - da + 128) % 256 - 128
        hit = todo & (ea != 0) & (eb != 0) & (np.abs(diff) < 32)
        fy.append(cy[hit])
        fx.append(cx[hit])
        fd.append((da[hit] + diff[hit] // 2) % 256)
        todo &= ~hit
    return np.concatenate(fy), np.concatenate(fx), np.concatenate(fd)


def detect(frame, p, times):
    t = [time.thread_time()]

    def lap():
        t.append(time.thread_time())

    tophat = cv2.morphologyEx(frame, cv2.MORPH_BLACKHAT, p.close)
    lap()
    opened = cv2.morphologyEx(tophat, cv2.MORPH_OPEN, p.open)
    lap()
    blurred = cv2.GaussianBlur(opened, (5, 5), 0, borderType=cv2.BORDER_REPLICATE)
    lap()
    gx = cv2.Sobel(blurred, cv2.CV_16S, 1, 0, ksize=3, borderType=cv2.BORDER_REPLICATE)
    gy = cv2.Sobel(blurred, cv2.CV_16S, 0, 1, ksize=3, borderType=cv2.BORDER_REPLICATE)
    lap()
    edges = cv2.Canny(gx, gy, p.low, p.high, L2gradient=False)
    lap()
    # Direction filter and directions on the edge pixels only.
    pts = cv2.findNonZero(edges)
    pts = np.zeros((0, 2), np.int32) if pts is None else pts.reshape(-1, 2)
    xs, ys = pts[:, 0], pts[:, 1]
    ex, ey = gx[ys, xs].astype(np.float32), gy[ys, xs].astype(np.float32)
    keep = np.abs(ey) <= p.tan_tol * np.abs(ex)
    ys, xs, ex, ey = ys[keep], xs[keep], ex[keep], ey[keep]
    mag = np.abs(ex) + np.abs(ey)
    dirs = (np.round(np.arctan2(ey, ex) * (128.0 / math.pi)).astype(np.int16) % 256).astype(np.int16)
    edge = np.zeros(edges.shape, np.uint8)
    edge[ys, xs] = 1
    lap()
    fy, fx, fd = fill_edges(edge, ys, xs, dirs)
    edge[fy, fx] = 1
    lap()
    n, labels = cv2.connectedComponents(edge, connectivity=8, ltype=cv2.CV_32S)
    lap()
    # Per component, from its pixels: pixel count, sums of row, column and direction deviation,
    # strong pixels; those without a strong pixel dropped (hysteresis).
    ay, ax = np.concatenate([ys, fy]), np.concatenate([xs, fx])
    ad = np.concatenate([dirs, fd])
    strong = np.concatenate([mag >= p.high, np.zeros(len(fy), bool)])
    lab = labels[ay, ax]
    area = np.bincount(lab, minlength=n).astype(np.float64)
    sum_row = np.bincount(lab, weights=ay, minlength=n)
    sum_col = np.bincount(lab, weights=ax, minlength=n)
    sum_dev = np.bincount(lab, weights=(ad + 64) % 128 - 64, minlength=n)
    n_strong = np.bincount(lab, weights=strong, minlength=n)
    ok = n_strong > 0
    ok[0] = False
    order = np.argsort(-np.where(ok, area, -1), kind="stable")[:2]
    c = None
    if len(order) == 2 and ok[order].all():
        c = float((sum_col[order] / area[order]).mean())
        _ = (sum_row[order] / area[order], sum_dev[order] / area[order])
    lap()
    for k in range(len(STAGES)):
        times[k].append(t[k + 1] - t[k])
    return c, int(n - 1)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("frames", help="raw 8-bit frames back to back")
    ap.add_argument("--width", type=int, default=1440)
    ap.add_argument("--height", type=int, default=540)
    ap.add_argument("--count", type=int, default=0, help="at most this many frames (0: all)")
    ap.add_argument("--repeat", type=int, default=1, help="passes over the frames")
    ap.add_argument("--json", action="store_true", help="one JSON object on standard output")
    a = ap.parse_args()
    size = a.width * a.height
    data = np.fromfile(a.frames, dtype=np.uint8)
    count = len(data) // size
    if count == 0:
        sys.exit(f"{a.frames}: no whole {a.width}x{a.height} frame")
    if a.count:
        count = min(count, a.count)
    frames = data[: count * size].reshape(count, a.height, a.width)
    p = Params(a.height)
    times = [[] for _ in STAGES]
    totals = []
    found = 0
    comps = 0
    # One frame first: warm-up (OpenCV's first call allocates), not counted.
    detect(np.ascontiguousarray(frames[0]), p, [[] for _ in STAGES])
    for _ in range(a.repeat):
        for f in frames:
            f = np.ascontiguousarray(f)
            t0 = time.thread_time()
            c, n = detect(f, p, times)
            totals.append(time.thread_time() - t0)
            found += c is not None
            comps += n
    med = lambda v: float(np.median(v)) * 1e3  # noqa: E731
    out = {
        "frames": len(totals),
        "width": a.width,
        "height": a.height,
        "opencv": cv2.__version__,
        "numpy": np.__version__,
        "threads": cv2.getNumThreads(),
        "per_frame_ms_median": med(totals),
        "per_frame_ms_mean": float(np.mean(totals)) * 1e3,
        "stages_ms_median": {s: med(v) for s, v in zip(STAGES, times)},
        "components_per_frame": comps / len(totals),
        "frames_with_two_edges": found,
    }
    if a.json:
        print(json.dumps(out))
        return
    print(f"OpenCV {out['opencv']}, {out['threads']} thread, {out['frames']} frames of {a.width}x{a.height}")
    for s, v in out["stages_ms_median"].items():
        print(f"  {s:34} {v:8.3f} ms")
    print(f"  {'per frame (median)':34} {out['per_frame_ms_median']:8.3f} ms")


if __name__ == "__main__":
    main()
