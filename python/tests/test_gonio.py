"""gonio for Python against the gonio command line on the same inputs.

Run by .ci/py.sh (a virtualenv with the module installed by `pip install .`); GONIO_BIN names
the CLI binary (default: target/release/gonio). Every result is compared with the CLI's JSON
after json.dumps(sort_keys=True), byte for byte.
"""

import json
import math
import os
import pathlib
import re
import subprocess
import tempfile

import numpy as np
import pytest

import gonio

ROOT = pathlib.Path(__file__).resolve().parents[2]
GONIO = os.environ.get("GONIO_BIN", str(ROOT / "target" / "release" / "gonio"))
EXAMPLES = ROOT / "examples"
# GUM Table 3 of Hsieh et al., 2022 (the shift-angle method's budget), as printed.
TABLE3_BUDGET = EXAMPLES / "budgets" / "hsieh2022-shift-angle.toml"
META = EXAMPLES / "certificate-meta.toml"
INSTRUMENT = EXAMPLES / "instrument-shift-angle.toml"


def cli(*args, check=True):
    """Runs the CLI; returns (exit code, stdout, stderr)."""
    p = subprocess.run([GONIO, *map(str, args)], capture_output=True, text=True, timeout=600)
    if check and p.returncode != 0:
        raise AssertionError(f"gonio {' '.join(map(str, args))}: {p.stderr}")
    return p.returncode, p.stdout, p.stderr


def cli_json(*args):
    """The JSON the CLI writes with `--json FILE`."""
    with tempfile.TemporaryDirectory() as d:
        out = pathlib.Path(d) / "out.json"
        cli(*args, "--json", out)
        return json.loads(out.read_text())


def cli_error(*args):
    """The CLI's one-line error (exit code 2), without its `error: ` prefix."""
    code, _, err = cli(*args, check=False)
    assert code == 2, err
    line = err.strip().splitlines()[-1]
    assert line.startswith("error: "), line
    return line[len("error: "):]


def canon(v):
    return json.dumps(v, sort_keys=True)


def read_csv(path, columns=None):
    """A gonio CSV's numbers (comments dropped) as a 2-D array, its columns in the order
    `columns` names (default: the file's)."""
    rows = [l for l in pathlib.Path(path).read_text().splitlines()
            if l.strip() and not l.lstrip().startswith("#")]
    header = [h.strip() for h in rows[0].split(",")]
    order = [header.index(c) for c in columns] if columns else range(len(header))
    return np.array([[float(r.split(",")[j]) for j in order] for r in rows[1:]])


READINGS = ["shift_deg", "start_face", "step", "reading_arcsec", "repeat"]


@pytest.fixture(scope="session")
def data(tmp_path_factory):
    d = tmp_path_factory.mktemp("gonio")
    cli("simulate", "encoder", "--seed", 7, "--out", d / "enc.json")
    cli("simulate", "shift-angle", "--encoder", d / "enc.json", "--faces", 24, "--shifts",
        "0:1:14", "--repeats", 2, "--sigma", 0.05, "--seed", 1, "--out", d / "lab")
    cli("simulate", "shift-angle", "--encoder", d / "enc.json", "--rows", "full", "--shifts",
        "0:1:14", "--seed", 1, "--out", d / "poly")
    cli("simulate", "selfcal", "--encoder", d / "enc.json", "--heads", "selfa12",
        "--positions", 3600, "--sigma", 0.01, "--seed", 2, "--out", d / "heads")
    cli("simulate", "frames", "--count", 6, "--eccentricity-um", 120, "--seed", 1, "--raw",
        "--out", d / "frames")
    return d


# --- the module -------------------------------------------------------------------------------


def test_version_is_the_crate_version():
    cargo = (ROOT / "Cargo.toml").read_text()
    version = re.search(r'\[workspace\.package\][^\[]*?version = "([^"]+)"', cargo).group(1)
    assert gonio.__version__ == version
    assert cli("--version")[1].split()[-1] == version


def test_gonio_error_is_a_value_error():
    assert issubclass(gonio.GonioError, ValueError)
    assert gonio.GonioError.__module__ == "gonio"


# --- calibration ------------------------------------------------------------------------------


def test_shift_angle_equals_the_cli(data):
    p = data / "lab" / "readings.csv"
    assert canon(gonio.shift_angle(str(p))) == canon(cli_json("shift-angle", p))
    assert canon(gonio.shift_angle(p, method="paper", sigma=0.05)) == canon(
        cli_json("shift-angle", p, "--method", "paper", "--sigma", 0.05))
    ours = gonio.shift_angle(p, instrument=INSTRUMENT, coverage=None, meta=META)
    assert canon(ours) == canon(
        cli_json("shift-angle", p, "--instrument", INSTRUMENT, "--meta", META))
    assert ours["encoder_errors"][0]["U_arcsec"] > 0


def test_shift_angle_array_and_path_agree(data):
    p = data / "lab" / "readings.csv"
    from_file = gonio.shift_angle(p)
    a = read_csv(p, READINGS)
    assert a.shape[1] == 5  # with the repeat column
    from_array = gonio.shift_angle(a)
    assert canon(from_array) == canon(from_file)
    # N×4: the same readings without repeats (repeat 1 only).
    first = a[a[:, 4] == 1][:, :4]
    lines = ["shift_deg,start_face,step,reading_arcsec"] + [
        ",".join(repr(float(v)) if j in (0, 3) else str(int(v)) for j, v in enumerate(r))
        for r in first
    ]
    q = data / "first.csv"
    q.write_text("\n".join(lines) + "\n")
    assert canon(gonio.shift_angle(first)) == canon(cli_json("shift-angle", q))
    # Integer arrays and lists are numbers too.
    assert canon(gonio.shift_angle(first.tolist())) == canon(gonio.shift_angle(first))


def test_selfcal_equals_the_cli_and_arrays_agree(data):
    p = data / "heads" / "readings.csv"
    ours = gonio.selfcal(p, heads="selfa12")
    assert canon(ours) == canon(cli_json("selfcal", p, "--heads", "selfa12"))
    assert canon(gonio.selfcal(read_csv(p))) == canon(ours)
    assert canon(gonio.selfcal(p, method="eda", reference=[1, 7])) == canon(
        cli_json("selfcal", p, "--heads", "selfa12", "--method", "eda", "--reference", "1,7"))


def test_joint_equals_the_cli(data):
    poly, heads = data / "poly" / "readings.csv", data / "heads" / "readings.csv"
    ours = gonio.joint(poly, heads, faces=24, heads="selfa12")
    assert canon(ours) == canon(
        cli_json("joint", poly, heads, "--faces", 24, "--heads", "selfa12"))
    assert canon(gonio.joint(read_csv(poly, READINGS[:4]), read_csv(heads), faces=24)) == canon(ours)


def test_compare_and_dcc_equal_the_cli(data):
    sa, sc = data / "sa.json", data / "sc.json"
    cli("shift-angle", data / "lab" / "readings.csv", "--json", sa)
    cli("selfcal", data / "heads" / "readings.csv", "--heads", "selfa12", "--json", sc)
    ours = gonio.compare(sa, sc)
    assert canon(ours) == canon(cli_json("compare", sa, sc))
    # A certificate dict compares as its file does (only the label, the input's name, differs).
    from_dicts = gonio.compare(json.loads(sa.read_text()), str(sc))
    assert from_dicts["points"] == ours["points"]

    xml = data / "cal.dcc.xml"
    cli("certificate", sa, "--meta", META, "--dcc", xml)
    assert gonio.dcc(sa, META) == xml.read_text()
    assert gonio.dcc(json.loads(sa.read_text()), META.read_text()) == xml.read_text()
    with pytest.raises(gonio.GonioError, match="draft=True"):
        gonio.dcc(sa)
    assert "DRAFT" in gonio.dcc(sa, draft=True)


# --- budgets ----------------------------------------------------------------------------------


def test_budget_equals_the_cli():
    for path in sorted((EXAMPLES / "budgets").glob("*.toml")):
        assert canon(gonio.budget(path)) == canon(cli_json("budget", path)), path
    ours = gonio.budget(str(TABLE3_BUDGET), monte_carlo=True, seed=3)
    assert canon(ours) == canon(cli_json("budget", TABLE3_BUDGET, "--monte-carlo", "--seed", 3))
    assert ours["monte_carlo"]["reported"] in ("GUM", "Monte Carlo")
    assert ours["monte_carlo"]["trials"] >= 10_000
    fixed = gonio.budget(TABLE3_BUDGET, monte_carlo=50_000)
    assert fixed["monte_carlo"]["trials"] == 50_000
    # The TOML text gives the same result (only the file's name differs).
    text = gonio.budget(TABLE3_BUDGET.read_text())
    assert text["file"] == "<budget>"
    text.pop("file")
    from_path = gonio.budget(TABLE3_BUDGET)
    from_path.pop("file")
    assert canon(text) == canon(from_path)


def test_table3_through_gonio_and_gtc_agree():
    """GUM Table 3 (Hsieh et al., 2022) in one process: gonio's budget and GTC's propagation."""
    from GTC import dof, uncertainty, ureal
    from GTC import reporting as rp

    r = gonio.budget(TABLE3_BUDGET)
    nu = lambda rel: 1 / (2 * rel**2)  # ν from a relative uncertainty of u
    # u(ε): six rows combined first, then used as one row with its ν_eff truncated.
    eps_rows = [
        ureal(0, 0.13 / math.sqrt(6), 5),
        ureal(0, 0.001 / (2 * math.sqrt(3)), nu(0.10)),
        ureal(0, 0.01 / 2, 50),
        ureal(0, 0.07 / math.sqrt(3), nu(0.10)),
        ureal(0, 0.0101, nu(0.10)),
        ureal(0, 0.0001 / (2 * math.sqrt(3)), nu(0.10)),
    ]
    eps_sum = sum(eps_rows)
    eps = ureal(0, uncertainty(eps_sum), math.floor(dof(eps_sum)))
    beta = ureal(0, 0.12 / math.sqrt(6), 5)
    setup = ureal(0, 0.05 / (2 * math.sqrt(3)), nu(0.10))
    alpha = eps + 0.0401 * beta + setup
    u_c, nu_eff = uncertainty(alpha), dof(alpha)
    k = rp.k_factor(math.floor(nu_eff), p=95)
    assert r["u_c"] == pytest.approx(u_c, rel=1e-12)
    assert r["nu_eff_raw"] == pytest.approx(nu_eff, rel=1e-9)
    assert r["nu_eff"] == math.floor(nu_eff) == 13
    assert r["k"] == pytest.approx(k, rel=1e-9)
    assert r["U"] == pytest.approx(k * u_c, rel=1e-9)
    assert round(r["U"], 4) == 0.1495
    assert round(r["u_c"], 3) == 0.069


# --- mounting ---------------------------------------------------------------------------------


def frames_of(d):
    truth = json.loads((d / "truth.json").read_text())
    raw = np.fromfile(d / "frames.raw", dtype=np.uint8)
    return raw.reshape(-1, 540, 1440), truth


def test_detect_equals_the_cli_and_the_truth(data):
    d = data / "frames"
    stack, truth = frames_of(d)
    # gonio.detect measures each frame whole: the command as well (it tracks frames in order).
    p = subprocess.run([GONIO, "detect", "--raw", "1440x540", "--no-track"], stdin=open(d / "frames.raw", "rb"),
                       capture_output=True, text=True, timeout=600, check=True)
    lines = [json.loads(l) for l in p.stdout.splitlines()]
    assert len(lines) == len(stack) == 6
    for k, (frame, line) in enumerate(zip(stack, lines)):
        ours = gonio.detect(frame)
        ours["frame"] = k
        assert canon(ours) == canon(line)
    many = gonio.detect_many(stack, threads=2)
    assert [canon(r) for r in many] == [canon(l) for l in lines]
    assert [canon(r) for r in gonio.detect_many(stack, threads=1)] == [canon(r) for r in many]
    # The rendered ring's column (its centre line's mean over the window's rows), within 0.1 px.
    cols = [f["c_true_px"] for f in truth["frames"]]
    assert len(cols) == len(many)
    for r, c in zip(many, cols):
        assert r["valid"] and abs(r["c_px"] - c) < 0.1, (r["c_px"], c)


def test_detect_refuses_what_it_cannot_read(data):
    stack, _ = frames_of(data / "frames")
    with pytest.raises(gonio.GonioError, match="uint8"):
        gonio.detect(stack[0].astype(np.float32))
    # A strided view is read in C order (then its 720 columns are neither window nor sensor).
    with pytest.raises(gonio.GonioError, match="frame:"):
        gonio.detect(stack[0][:, ::2])
    with pytest.raises(gonio.GonioError, match="frame:"):
        gonio.detect(np.zeros((10, 10), np.uint8))
    # The sensor's full frame is cut to the window as `gonio detect` does.
    with pytest.raises(gonio.GonioError, match="uint8"):
        gonio.detect_many(stack[0])


def test_frames_in_any_memory_order_give_the_same_result(data):
    stack, truth = frames_of(data / "frames")
    want = gonio.detect(stack[0])
    assert want["valid"]
    # The same pixels in Fortran order, and as a transposed view of a transposed copy: the
    # same rows, whatever numpy's layout.
    fortran = np.asfortranarray(stack[0])
    assert not fortran.flags.c_contiguous
    assert canon(gonio.detect(fortran)) == canon(want)
    assert canon(gonio.detect(np.ascontiguousarray(stack[0].T).T)) == canon(want)
    many = gonio.detect_many(stack, threads=2)
    fortran_many = gonio.detect_many(np.asfortranarray(stack), threads=2)
    assert [canon(r) for r in fortran_many] == [canon(r) for r in many]
    # Every other frame: a strided view of the stack.
    def without_frame(r):
        return canon({k: v for k, v in r.items() if k != "frame"})
    every_other = gonio.detect_many(stack[::2], threads=1)
    assert [without_frame(r) for r in every_other] == [without_frame(r) for r in many[::2]]


def test_argument_errors_are_gonio_errors_never_overflow_errors(data):
    stack, _ = frames_of(data / "frames")
    small = stack[:1]
    for threads in (0, -1, 257, 2**70, -(2**70), 1_000_000):
        with pytest.raises(gonio.GonioError, match=r"^threads="):
            gonio.detect_many(small, threads=threads)
    with pytest.raises(gonio.GonioError, match=r"at most 256"):
        gonio.detect_many(small, threads=1_000_000)
    with pytest.raises(gonio.GonioError, match=r"whole number"):
        gonio.detect_many(small, threads=2.5)
    theta = np.arange(200) * 1.8
    c = 700 + 10 * np.cos(np.radians(theta - 40))
    for frames_taken in (-1, 10**30, 10**6):
        with pytest.raises(gonio.GonioError, match=r"^frames_taken="):
            gonio.eccentricity(theta, c, frames_taken=frames_taken)
    with pytest.raises(gonio.GonioError, match=r"^um_per_px="):
        gonio.eccentricity(theta, c, um_per_px=10**400)
    for kw in ({"seed": -1}, {"seed": 2**64}, {"ndig": -1}, {"ndig": 2**40},
               {"coverage": 10**400}, {"coverage": 1.5}, {"monte_carlo": -5}):
        with pytest.raises(gonio.GonioError):
            gonio.budget(TABLE3_BUDGET, **kw)
    # The calibrations' counts: checked by the module, never the binding's OverflowError.
    lab, poly, heads = data / "lab" / "readings.csv", data / "poly" / "readings.csv", data / "heads" / "readings.csv"
    for kw in ({"faces": -1}, {"faces": 2**70}, {"check_order": -2}, {"check_order": 2**40}):
        with pytest.raises(gonio.GonioError, match="^" + next(iter(kw)) + "="):
            gonio.shift_angle(lab, **kw)
    for order in (-1, 2**40):
        with pytest.raises(gonio.GonioError, match=r"^max_order="):
            gonio.selfcal(heads, max_order=order)
    for kw in ({"faces": -24}, {"faces": 2**70}, {"max_order": -1}, {"blind_max_order": 2**64}):
        kw = {"faces": 24, **kw}
        with pytest.raises(gonio.GonioError):
            gonio.joint(poly, heads, **kw)
    # A huge thread count never reaches the interpreter's allocator (it aborted Python).
    code = ("import gonio, numpy as np\n"
            "try:\n"
            "    gonio.detect_many(np.zeros((1, 540, 1440), np.uint8), threads=1_000_000)\n"
            "except gonio.GonioError as e:\n"
            "    print('refused:', e)\n")
    import sys
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0 and p.stdout.startswith("refused: threads=1000000"), p.stderr


def test_eccentricity_equals_the_cli(data):
    rng = np.random.default_rng(5)
    theta = np.arange(200) * 1.8
    c = 700 + 10 * np.cos(np.radians(theta - 40)) + rng.normal(0, 0.05, theta.size)
    p = data / "turn.csv"
    p.write_text("theta_deg,c_px\n" + "".join(f"{float(t)!r},{float(v)!r}\n" for t, v in zip(theta, c)))
    for method in ("least-squares", "paper"):
        want = cli_json("eccentricity", p, "--method", method, "--um-per-px", 0.75)
        assert canon(gonio.eccentricity(str(p), um_per_px=0.75, method=method)) == canon(want)
        ours = gonio.eccentricity(theta, c, um_per_px=0.75, method=method)
        assert want["outliers"] == ours["outliers"] == 0
        assert canon(ours) == canon(want)
    assert gonio.eccentricity(theta, c, um_per_px=0.75)["e_um"] == pytest.approx(7.5, abs=0.05)


# --- errors -----------------------------------------------------------------------------------


def test_errors_carry_the_cli_message(data, tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("shift_deg,start_face,step,reading_arcsec\n0,1,1,0.5\n0,0,2,0.1\n")
    want = cli_error("shift-angle", bad)
    with pytest.raises(gonio.GonioError) as e:
        gonio.shift_angle(bad)
    assert str(e.value) == want
    assert want.startswith(f"{bad}:3:2: column 'start_face'")
    # The same value in an array: row 2, column 2.
    with pytest.raises(gonio.GonioError, match=r"^<readings>:2:2: column 'start_face'"):
        gonio.shift_angle(np.array([[0, 1, 1, 0.5], [0, 0, 2, 0.1]]))
    with pytest.raises(gonio.GonioError, match="4 columns"):
        gonio.shift_angle(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="method"):
        gonio.shift_angle(bad, method="magic")
    missing = tmp_path / "missing.csv"
    with pytest.raises(gonio.GonioError) as e:
        gonio.shift_angle(missing)
    assert str(e.value) == cli_error("shift-angle", missing)


def test_a_negative_u_is_named(tmp_path):
    b = tmp_path / "neg.toml"
    b.write_text('[[budget]]\nname = "y"\n[[budget.contribution]]\nname = "drift"\nu = -0.1\n')
    want = cli_error("budget", b)
    with pytest.raises(gonio.GonioError) as e:
        gonio.budget(b)
    assert str(e.value) == want
    assert "drift" in want and f"{b}:5:" in want
    with pytest.raises(gonio.GonioError, match=r"^<budget>:5:.*drift"):
        gonio.budget(b.read_text())
