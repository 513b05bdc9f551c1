"""gonio.detect on a numpy frame against the same detector called from Rust.

Both sides are timed the same way: the CPU time of the calling thread per frame (so that other
processes on a shared machine count less), the median over the frames. The Rust side is
`gonio detect --raw WxH --timing` (crop + detect per frame, on one thread); the Python side is
`gonio.detect(frame)` on the same frames, all included: argument parsing, the array read in
place, the detection, the JSON line and its dict. Rounds alternate between the two.

    python crates/gonio-py/bench/detect.py [--gonio target/release/gonio] [--frames 64] [--rounds 5]
"""

import argparse
import pathlib
import re
import statistics
import subprocess
import tempfile
import time

import numpy as np

import gonio

ROOT = pathlib.Path(__file__).resolve().parents[3]


def rust_median_ms(binary, raw):
    with open(raw, "rb") as f:
        p = subprocess.run([binary, "detect", "--raw", "1440x540", "--timing"], stdin=f,
                           stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                           check=True)
    return float(re.search(r"median ([0-9.]+) ms/frame", p.stderr).group(1))


def python_median_ms(stack):
    times = []
    for frame in stack:
        t0 = time.thread_time()
        gonio.detect(frame)
        times.append(time.thread_time() - t0)
    return statistics.median(times) * 1e3


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gonio", default=str(ROOT / "target" / "release" / "gonio"))
    ap.add_argument("--frames", type=int, default=64)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        out = pathlib.Path(d) / "frames"
        subprocess.run([a.gonio, "simulate", "frames", "--count", str(a.frames), "--seed",
                        str(a.seed), "--raw", "--out", str(out)], check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        raw = out / "frames.raw"
        stack = np.fromfile(raw, np.uint8).reshape(-1, 540, 1440)
        gonio.detect(stack[0])  # the detector is made once, as a station would
        rust, py = [], []
        for r in range(a.rounds):
            rust.append(rust_median_ms(a.gonio, raw))
            py.append(python_median_ms(stack))
            print(f"round {r + 1}: Rust {rust[-1]:.3f} ms/frame, Python {py[-1]:.3f} ms/frame, "
                  f"ratio {py[-1] / rust[-1]:.3f}")
        rm, pm = statistics.median(rust), statistics.median(py)
        ratio = statistics.median(p / r for p, r in zip(py, rust))
        print(f"{a.rounds} rounds over {len(stack)} frames: Rust {rm:.3f} ms/frame, "
              f"gonio.detect {pm:.3f} ms/frame (medians); median ratio of a round "
              f"{ratio:.3f} ({100 * (ratio - 1):+.1f} %)")


if __name__ == "__main__":
    main()
