"""How gonio for Python reads its inputs, against the command line on the same files: one size
limit per kind of file, the same from the shell and from Python, and inputs that belong to one
call (a long process keeps nothing of the files it read, and reads standard input in every call).

Run by .ci/py.sh, like test_gonio.py (GONIO_BIN names the CLI binary).
"""

import json
import os
import pathlib
import subprocess
import sys

import pytest

import gonio

ROOT = pathlib.Path(__file__).resolve().parents[2]
GONIO = os.environ.get("GONIO_BIN", str(ROOT / "target" / "release" / "gonio"))
# The limit of every text input (gonio_io::input::MAX_TEXT_BYTES, docs/inputs-and-outputs.md).
TEXT_LIMIT = 256 << 20
MIB = 1 << 20


def cli(*args):
    """Runs the CLI; returns (exit code, stdout, stderr)."""
    p = subprocess.run([GONIO, *map(str, args)], capture_output=True, text=True, timeout=600)
    return p.returncode, p.stdout, p.stderr


def canon(v):
    return json.dumps(v, sort_keys=True)


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    d = tmp_path_factory.mktemp("inputs")
    for args in [
        ("simulate", "encoder", "--seed", 7, "--out", d / "enc.json"),
        ("simulate", "shift-angle", "--encoder", d / "enc.json", "--rows", "full", "--shifts",
         "0:1:14", "--seed", 1, "--out", d / "poly"),
        ("simulate", "shift-angle", "--encoder", d / "enc.json", "--faces", 12, "--shifts",
         "0,10", "--seed", 3, "--out", d / "small"),
        ("simulate", "selfcal", "--encoder", d / "enc.json", "--heads", "selfa12",
         "--positions", 3600, "--sigma", 0.01, "--seed", 2, "--out", d / "heads"),
    ]:
        code, _, err = cli(*args)
        assert code == 0, err
    return d


def padded(path, text, size):
    """Writes `text` (a CSV) followed by `#` comment lines, to exactly `size` bytes: a file of
    that size that every reader accepts, and whose readings are `text`'s."""
    body = text.encode()
    assert len(body) + 2 <= size
    line = b"#" + b"x" * 1022 + b"\n"  # 1 KiB
    block = line * 1024  # 1 MiB
    rest = size - len(body)
    with open(path, "wb") as f:
        f.write(body)
        while rest >= len(block) + len(line):
            f.write(block)
            rest -= len(block)
        while rest >= len(line) + 2:
            f.write(line)
            rest -= len(line)
        f.write(b"#" + b"x" * (rest - 2) + b"\n")
    assert path.stat().st_size == size
    return path


def test_selfcal_and_joint_accept_and_refuse_the_same_files_from_the_shell_and_python(lab, tmp_path):
    poly = lab / "poly" / "readings.csv"
    heads_text = (lab / "heads" / "readings.csv").read_text()
    big = padded(tmp_path / "big.csv", heads_text, 100 * MIB)
    runs = {
        "gonio selfcal": lambda p: cli("selfcal", p, "--heads", "selfa12", "--json", "-"),
        "gonio joint": lambda p: cli("joint", poly, p, "--faces", 24, "--heads", "selfa12",
                                     "--json", "-"),
    }
    calls = {
        "gonio.selfcal": lambda p: gonio.selfcal(p, heads="selfa12"),
        "gonio.joint": lambda p: gonio.joint(poly, p, faces=24, heads="selfa12"),
    }
    # 100 MiB: read by all four, and the same certificate from the shell and from Python.
    results = {}
    for name, run in runs.items():
        code, out, err = run(big)
        assert code == 0, f"{name} refused a 100 MiB file: {err}"
        results[name] = json.loads(out)
    for name, call in calls.items():
        results[name] = call(big)
    assert canon(results["gonio selfcal"]) == canon(results["gonio.selfcal"])
    assert canon(results["gonio joint"]) == canon(results["gonio.joint"])
    # One byte over the limit: refused by all four, before reading, with the same message.
    over = padded(tmp_path / "over.csv", heads_text, TEXT_LIMIT + 1)
    want = f"{over}:1:1: the file is {TEXT_LIMIT + 1} bytes, more than the limit of {TEXT_LIMIT} bytes"
    for name, run in runs.items():
        code, out, err = run(over)
        assert code == 2 and out == "", f"{name}: {code} {err}"
        assert err.strip() == f"error: {want}", name
    for name, call in calls.items():
        with pytest.raises(gonio.GonioError) as e:
            call(over)
        assert str(e.value) == want, name


def rss_bytes():
    """This process's resident set, from /proc/self/status."""
    for line in pathlib.Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) * 1024
    raise AssertionError("no VmRSS in /proc/self/status")


def test_ten_thousand_files_in_one_process_leave_nothing_behind(lab, tmp_path):
    # 10,000 distinct small files with long names (each name 200 characters or more): a record
    # of every file read, kept for the life of the process, would hold at least their names,
    # 10,000 × 200 bytes = 2 MB, and grow by that; the inputs of one call are forgotten with it.
    text = (lab / "small" / "readings.csv").read_text()
    d = tmp_path / ("d" * 120)
    d.mkdir()
    paths = []
    for i in range(11_000):
        p = d / f"{i:06d}-{'r' * 80}.csv"
        p.write_text(text)
        paths.append(p)
    first = gonio.shift_angle(paths[0])
    # Warm-up: the allocator's and the interpreter's own first growth.
    for p in paths[1:1000]:
        gonio.shift_angle(p)
    before = rss_bytes()
    for p in paths[1000:]:
        assert gonio.shift_angle(p)["encoder_errors"] == first["encoder_errors"]
    grown = rss_bytes() - before
    # Half the least that such a record would add; what this process adds otherwise (the
    # allocator's noise) was 86–94 kB in three runs of these 10,000 calls.
    assert grown < 1_000_000, f"the process grew by {grown} bytes over 10,000 files"


STDIN_TWICE = """
import json, os, sys
import gonio
got = []
for path in sys.argv[1:]:
    fd = os.open(path, os.O_RDONLY)
    os.dup2(fd, 0)
    os.close(fd)
    got.append(gonio.shift_angle("-"))
print(json.dumps(got, sort_keys=True))
"""


def test_standard_input_is_read_in_each_of_two_calls(lab):
    a, b = lab / "small" / "readings.csv", lab / "poly" / "readings.csv"
    p = subprocess.run([sys.executable, "-c", STDIN_TWICE, str(a), str(b)], capture_output=True,
                       text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    got = json.loads(p.stdout)
    assert canon(got) == canon([gonio.shift_angle(a), gonio.shift_angle(b)])
