"""Tests of the fbgforge Python package: round trips against the command line's JSON on
the shipped designs and fixtures, numpy in and out, and an FbgforgeError (with the
command line's message) for each class of bad input."""

import ast
import json
import math
import os
import subprocess
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import fbgforge

ROOT = Path(__file__).resolve().parents[2]
DESIGNS = ROOT / "designs"
FIXTURES = ROOT / "fixtures"
MODULES = ["clip-on-10mm.toml", "clip-on-16mm.toml", "clip-on-22mm.toml", "clip-on-34mm.toml"]
ARRAY = DESIGNS / "tactile-array-60x80.toml"


@pytest.fixture(scope="session")
def cli():
    """The fbgforge command line: $FBGFORGE_BIN, or the release build `cargo test --release` made
    (built here if missing)."""
    exe = os.environ.get("FBGFORGE_BIN") or str(ROOT / "target" / "release" / "fbgforge")
    if not Path(exe).exists():
        subprocess.run(["cargo", "build", "--bin", "fbgforge"], cwd=ROOT, check=True)

    def run(*args, ok_codes=(0,)):
        p = subprocess.run([exe, *map(str, args)], cwd=ROOT, capture_output=True, text=True)
        assert p.returncode in ok_codes, f"{args}: {p.returncode}\n{p.stderr}"
        return p

    return run


def close(a, b, rel=1e-9, path="$"):
    """Recursive comparison of two JSON documents, floats to a relative tolerance."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and a.keys() == b.keys(), f"{path}: keys {a.keys()} vs {b.keys()}"
        for k in a:
            close(a[k], b[k], rel, f"{path}.{k}")
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), f"{path}: lengths"
        for i, (x, y) in enumerate(zip(a, b)):
            close(x, y, rel, f"{path}[{i}]")
    elif isinstance(a, float) or isinstance(b, float):
        assert a is not None and b is not None, f"{path}: {a} vs {b}"
        assert math.isclose(a, b, rel_tol=rel, abs_tol=1e-12), f"{path}: {a} vs {b}"
    else:
        assert a == b, f"{path}: {a!r} vs {b!r}"


def cli_error(cli, *args):
    """The message the command line prints after `error: `, exit status 1."""
    p = cli(*args, ok_codes=(1,))
    line = p.stderr.strip().splitlines()[-1]
    assert line.startswith("error: "), p.stderr
    return line[len("error: "):]


# ---------------------------------------------------------------- designs


@pytest.mark.parametrize("name", MODULES + ["tactile-array-60x80.toml"])
def test_load_design_reads_the_shipped_designs(name):
    d = fbgforge.load_design(DESIGNS / name)
    spec = d.to_dict()
    assert d.name == spec["name"] == name.removesuffix(".toml")
    assert Path(d.path) == DESIGNS / name
    if name.startswith("clip-on"):
        assert d.kind == "module"
        assert d.gratings == [g["name"] for g in spec["module"]["gratings"]]
    else:
        assert d.kind == "array"
        assert d.gratings == ["fbg1", "fbg2", "fbg3", "fbg4", "fbg5", "fbg6"]
        assert spec["array"]["cells_x"] == 4 and spec["array"]["cells_y"] == 2
    assert "Design(name=" in repr(d)


# ---------------------------------------------------------------- predict


@pytest.mark.parametrize("name", MODULES)
def test_predict_equals_the_cli_json(cli, name):
    path = DESIGNS / name
    want = json.loads(cli("predict", path, "--json", "--fidelity", "closed-form", "--force-n", "3", "--delta-t-k", "2").stdout)
    got = fbgforge.predict(path, force_n=3.0, delta_t_k=2.0, fidelity="closed-form")
    close(got, want)
    # A Design object and a path give the same answer.
    close(fbgforge.predict(fbgforge.load_design(path), force_n=3.0, delta_t_k=2.0, fidelity="closed-form"), want)


def test_predict_case_ii_auto_equals_the_cli_and_k_is_linear(cli):
    path = DESIGNS / "clip-on-34mm.toml"
    want = json.loads(cli("predict", path, "--json", "--case", "II").stdout)
    got = fbgforge.predict(path, case="II")
    close(got, want)
    one = fbgforge.predict(path, force_n=1.0, case="II")["predictions"]
    for r1, r10 in zip(one, got["predictions"]):
        assert r1["model"] == "closed-form"
        assert math.isclose(r10["shift_pm"], 10 * r1["shift_pm"], rel_tol=1e-12)


# ---------------------------------------------------------------- build


def test_build_writes_the_same_manifest_as_the_cli(cli, tmp_path):
    path = DESIGNS / "clip-on-10mm.toml"
    cli("build", path, "--out", tmp_path / "cli", "--parts", "cap,core")
    got = fbgforge.build(path, tmp_path / "py", parts=["cap", "core"])
    want = json.loads((tmp_path / "cli" / "manifest.json").read_text())
    assert got["manifest"] == want
    names = sorted(Path(f).name for f in got["files"])
    assert names == ["cap.step", "cap.stl", "core.step", "core.stl", "manifest.json", "parts.3mf"]
    for f in got["files"]:
        assert Path(f).stat().st_size > 0
    # The STL files are byte for byte those of the command line.
    for part in ["cap.stl", "core.stl"]:
        assert (tmp_path / "py" / part).read_bytes() == (tmp_path / "cli" / part).read_bytes()


# ---------------------------------------------------------------- logs


def test_read_log_gives_numpy_columns_a_dataframe_can_take():
    log = fbgforge.read_log(FIXTURES / "logs" / "plain.csv")
    assert log["format"] == "csv"
    assert log["clock"] == "relative"
    assert log["column_names"] == ["lambda_11", "lambda_12", "lambda_temp"]
    t = log["time_s"]
    assert isinstance(t, np.ndarray) and t.dtype == np.float64
    assert log["rows"] == len(t) and np.all(np.diff(t) > 0)
    assert t[:3].tolist() == [0.0, 0.05, 0.10]
    starts = log["row_start"]
    assert starts[0] == 0 and len(starts) == len(t) + 1
    peaks = log["peaks"]
    n = len(peaks["wavelength_nm"])
    assert starts[-1] == n
    assert all(len(c) == n for c in peaks.values())
    # Row 1 (t = 0.05) lacks lambda_12: two peaks, channels 0 and 2.
    row1 = peaks["row"] == 1
    assert peaks["channel"][row1].tolist() == [0, 2]
    assert peaks["wavelength_nm"][row1].tolist() == [1546.2953, 1560.1460]
    assert np.array_equal(peaks["time_s"], t[peaks["row"]])


def test_read_log_reads_every_fixture_format_and_counts_warnings():
    formats = {
        "enlight_peaks_bom_decimal_comma.txt": "enlight-peaks",
        "enlight_peaks_garbage_missing_channel.txt": "enlight-peaks",
        "enlight_sensors.txt": "enlight-sensors",
        "imon.txt": "imon",
        "plain.csv": "csv",
    }
    for name, fmt in formats.items():
        log = fbgforge.read_log(FIXTURES / "logs" / name)
        assert log["format"] == fmt, name
        assert log["rows"] >= 2
    garbage = fbgforge.read_log(FIXTURES / "logs" / "enlight_peaks_garbage_missing_channel.txt")
    assert sum(w["count"] for w in garbage["warnings"].values()) > 0
    assert all("first" in w for w in garbage["warnings"].values())


# ---------------------------------------------------------------- verify


@pytest.fixture(scope="session")
def synth_logs(cli, tmp_path_factory):
    """A synthetic log pair with known K, written by `fbgforge synth-log`."""
    out = tmp_path_factory.mktemp("synth")
    cli("synth-log", DESIGNS / "clip-on-34mm.toml", "--out", out, "--k-pm-per-n", "12", "--rate-hz", "10")
    return out


def test_verify_equals_the_cli_json_and_finds_the_synthetic_k(cli, synth_logs):
    args = [DESIGNS / "clip-on-34mm.toml", "--log", synth_logs / "log.txt", "--force", synth_logs / "force.csv"]
    want = json.loads(cli("verify", *args, "--json", ok_codes=(0, 2, 3)).stdout)
    got = fbgforge.verify(DESIGNS / "clip-on-34mm.toml", synth_logs / "log.txt", synth_logs / "force.csv")
    close(got, want)
    first = got["measurement"]["gratings"][0]
    assert abs(first["sensitivity_pm_per_n"] - 12.0) < 0.5
    assert got["measurement"]["wavelength_rows"] == fbgforge.read_log(synth_logs / "log.txt")["rows"]


# ---------------------------------------------------------------- reconstruct


def test_reconstruct_recovers_known_loads_numpy_in_and_out():
    m = fbgforge.sensing_matrix(ARRAY)
    a = m["sensitivity_pm_per_g"]
    assert a.shape == (6, 8) and m["cells"] == list("ABCDEFGH") and m["ulimit_g"] == 250.0
    x = np.zeros((4, 8))
    x[0, 1] = 100.0
    x[1, [0, 6]] = [200.0, 50.0]
    x[2, [2, 4, 7]] = [100.0, 50.0, 200.0]
    y = x @ a.T
    got = fbgforge.reconstruct(a, y)
    assert got.shape == (4, 8) and got.dtype == np.float64
    assert np.allclose(got, x, atol=0.5), got
    # One frame in, one frame out; lists and integer arrays are accepted.
    one = fbgforge.reconstruct(a.tolist(), y[0].tolist())
    assert one.shape == (8,) and np.allclose(one, x[0], atol=0.5)
    ints = fbgforge.reconstruct(a, np.rint(y * 1000).astype(np.int64) / 1000)
    assert np.allclose(ints, x, atol=1.0)
    loads, info = fbgforge.reconstruct(a, y, return_info=True)
    assert info["method"] in fbgforge.methods()
    assert info["converged"].dtype == np.bool_ and info["converged"].all()
    assert info["residual_pm"].shape == (4,) and (info["residual_pm"] < 0.1).all()
    # Noise-free frames of the model pass the residual test, no grating is left
    # out; a grating reading 25 pm below rest cannot be explained by loads.
    assert len(info["flags"]) == 4 and info["suspect_gratings"] == []
    assert not any("inconsistent" in f for f in info["flags"]), info["flags"]
    assert info["certified"].dtype == np.bool_ and info["chi2"].shape == (4,)
    bad = y[0].copy()
    bad[0] -= 25.0
    _, info = fbgforge.reconstruct(a, bad, return_info=True)
    assert "inconsistent" in info["flags"][0], info["flags"]
    for method in ["support", "nnls", "omp"]:
        assert fbgforge.reconstruct(a, y[:1], method=method).shape == (1, 8)


def test_reconstruct_equals_the_cli_on_the_fixture(cli, tmp_path):
    shifts = FIXTURES / "array" / "paper-model-shifts.csv"
    out = tmp_path / "loads.csv"
    cli("reconstruct", "--design", ARRAY, "--shifts", shifts, "--out", out)
    m = fbgforge.sensing_matrix(ARRAY)
    y = read_columns(shifts, m["gratings"])
    want = read_columns(out, m["cells"])
    got = fbgforge.reconstruct(m["sensitivity_pm_per_g"], y, ulimit_g=m["ulimit_g"])
    assert np.allclose(got, want, atol=1e-6), (got, want)


def test_reconstruct_releases_the_gil():
    """A Python thread runs while reconstruct works. Holding the GIL, the call would
    keep that thread from running any bytecode until it returns, so none of the
    thread's time stamps could fall inside the call, whatever the machine's speed or
    load. The call is sized (doubling the frames) to last at least 0.3 s, and only the
    middle half of it is counted, away from the Python code around the call. (Against a
    call that holds the GIL, a backtracking `re.match` of 0.34 s, the same count is 0,
    with one stamp at the call's edge.)"""
    m = fbgforge.sensing_matrix(ARRAY)
    a = m["sensitivity_pm_per_g"]
    rng = np.random.default_rng(5)

    def frames(n):
        x = np.zeros((n, 8))
        x[np.arange(n), rng.integers(0, 8, n)] = rng.uniform(50, 200, n)
        return x, x @ a.T

    stamps = []
    done = threading.Event()

    def ticker():
        while not done.is_set():
            stamps.append(time.perf_counter())
            time.sleep(0.0005)

    t = threading.Thread(target=ticker)
    t.start()
    try:
        n = 5000
        while True:
            x, y = frames(n)
            t0 = time.perf_counter()
            got = fbgforge.reconstruct(a, y)
            t1 = time.perf_counter()
            if t1 - t0 >= 0.3 or n >= 1 << 20:
                break
            n *= 2
    finally:
        done.set()
        t.join()
    assert np.allclose(got, x, atol=1.0)
    if t1 - t0 < 0.3:
        pytest.skip(f"{n} frames take only {t1 - t0:.3f} s here: no call lasts long enough to watch")
    lo, hi = t0 + 0.25 * (t1 - t0), t1 - 0.25 * (t1 - t0)
    inside = sum(lo < s < hi for s in stamps)
    assert inside >= 1, (n, t1 - t0, len(stamps))


# ---------------------------------------------------------------- errors


def read_columns(path, names):
    """Named columns of a CSV file (lines starting with # skipped) as a 2-D array."""
    rows = [l.split(",") for l in Path(path).read_text().splitlines() if l.strip() and not l.startswith("#")]
    header = [h.strip() for h in rows[0]]
    return np.array([[float(r[header.index(n)]) for n in names] for r in rows[1:]])


def write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text)
    return p


@pytest.fixture
def spec_text():
    return (DESIGNS / "clip-on-34mm.toml").read_text()


@pytest.mark.parametrize(
    "case, edit",
    [
        ("malformed TOML", lambda s: s.replace('name = "clip-on-34mm"', 'name = "clip-on-34mm', 1)),
        ("unknown field", lambda s: s.replace("[module]\n", "[module]\ncolour = \"red\"\n", 1)),
        ("impossible geometry", lambda s: s.replace("cap_wall_mm = 1.5", "cap_wall_mm = 30.0", 1)),
        ("wrong units", lambda s: s.replace("outer_diameter_mm = 34.0", "outer_diameter_mm = \"34 mm\"", 1)),
    ],
)
def test_a_bad_design_raises_the_cli_message(cli, tmp_path, spec_text, case, edit):
    bad = write(tmp_path, "bad.toml", edit(spec_text))
    want = cli_error(cli, "predict", bad)
    with pytest.raises(fbgforge.FbgforgeError) as e:
        fbgforge.load_design(bad)
    assert str(e.value) == want, case
    assert "bad.toml" in str(e.value)
    with pytest.raises(ValueError):
        fbgforge.predict(bad)


def test_a_missing_file_raises_naming_it(cli):
    want = cli_error(cli, "predict", "no/such/design.toml")
    with pytest.raises(fbgforge.FbgforgeError, match="no/such/design.toml") as e:
        fbgforge.load_design("no/such/design.toml")
    assert str(e.value) == want


@pytest.mark.parametrize(
    "name, words",
    [
        ("mostly_garbage.txt", "unreadable"),
        ("metadata_only.txt", "cannot tell the log format"),
    ],
)
def test_a_bad_log_raises_the_cli_message(cli, name, words):
    log = FIXTURES / "logs" / name
    force = FIXTURES / "logs" / "force_stand.csv"
    want = cli_error(cli, "verify", DESIGNS / "clip-on-34mm.toml", "--log", log, "--force", force)
    with pytest.raises(fbgforge.FbgforgeError, match=words) as e:
        fbgforge.read_log(log)
    assert str(e.value) == want
    with pytest.raises(fbgforge.FbgforgeError) as e:
        fbgforge.verify(DESIGNS / "clip-on-34mm.toml", log, force)
    assert str(e.value) == want


def test_a_truncated_or_ragged_log_is_read_with_its_bad_rows_counted(tmp_path):
    truncated = fbgforge.read_log(FIXTURES / "logs" / "enlight_peaks_104_metadata_dropped_truncated.txt")
    w = truncated["warnings"]["truncated_last_line"]
    assert w["count"] == 1 and w["first"].endswith(":109: fewer wavelengths than the peak counts announce")
    ragged = fbgforge.read_log(FIXTURES / "logs" / "enlight_peaks_garbage_missing_channel.txt")
    assert ragged["rows"] == 6
    assert {k: v["count"] for k, v in ragged["warnings"].items()} == {
        "missing_channel": 1,
        "peak_count_mismatch": 1,
        "unreadable_line": 2,
    }
    assert ":7: row ends before the peak count of channel 3" in ragged["warnings"]["missing_channel"]["first"]


def test_a_force_log_running_backwards_raises_the_cli_message(cli, tmp_path, synth_logs):
    lines = (synth_logs / "force.csv").read_text().splitlines()
    backwards = write(tmp_path, "force.csv", "\n".join([lines[0], *lines[1:][::-1]]) + "\n")
    want = cli_error(cli, "verify", DESIGNS / "clip-on-34mm.toml", "--log", synth_logs / "log.txt", "--force", backwards)
    with pytest.raises(fbgforge.FbgforgeError) as e:
        fbgforge.verify(DESIGNS / "clip-on-34mm.toml", synth_logs / "log.txt", backwards)
    assert str(e.value) == want


def test_bad_arrays_and_options_raise_clear_errors():
    a = fbgforge.sensing_matrix(ARRAY)["sensitivity_pm_per_g"]
    y = np.zeros((2, 6))
    y[1, 2] = np.nan
    with pytest.raises(fbgforge.FbgforgeError, match=r"Y\[1, 2\] is NaN; expected a finite shift in pm"):
        fbgforge.reconstruct(a, y)
    with pytest.raises(fbgforge.FbgforgeError, match="a frame holds 5 shifts but the sensing matrix has 6 gratings"):
        fbgforge.reconstruct(a, np.zeros((3, 5)))
    with pytest.raises(fbgforge.FbgforgeError, match="unknown method `magic`"):
        fbgforge.reconstruct(a, np.zeros(6), method="magic")
    with pytest.raises(fbgforge.FbgforgeError, match="ulimit must be a positive load"):
        fbgforge.reconstruct(a, np.zeros(6), ulimit_g=-1.0)
    bad_a = a.copy()
    bad_a[0, 0] = np.inf
    with pytest.raises(fbgforge.FbgforgeError, match="sensing matrix entry"):
        fbgforge.reconstruct(bad_a, np.zeros(6))
    with pytest.raises(fbgforge.FbgforgeError, match="expected \"I\""):
        fbgforge.predict(DESIGNS / "clip-on-34mm.toml", case="III")
    with pytest.raises(fbgforge.FbgforgeError, match="--force-n must be a finite number"):
        fbgforge.predict(DESIGNS / "clip-on-34mm.toml", force_n=float("nan"))
    with pytest.raises(fbgforge.FbgforgeError, match="format `xml`"):
        fbgforge.read_log(FIXTURES / "logs" / "plain.csv", format="xml")
    with pytest.raises(fbgforge.FbgforgeError, match="has no \\[array\\] section"):
        fbgforge.sensing_matrix(DESIGNS / "clip-on-34mm.toml")
    assert issubclass(fbgforge.FbgforgeError, ValueError)


# ---------------------------------------------------------------- packaging


def test_the_type_stubs_cover_the_public_api():
    pkg = Path(fbgforge.__file__).parent
    stub = ast.parse((pkg / "__init__.pyi").read_text())
    defined = {n.name for n in stub.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
    defined |= {t.id for n in stub.body if isinstance(n, ast.AnnAssign) for t in [n.target]}
    assert set(fbgforge.__all__) <= defined, set(fbgforge.__all__) - defined
    assert (pkg / "py.typed").exists()
    assert fbgforge.__version__ == "0.1.0"


def test_reconstruct_takes_the_cli_defaults_resolution_and_load_cap():
    m = fbgforge.sensing_matrix(ARRAY)
    a = m["sensitivity_pm_per_g"]
    x = np.zeros((2, 8))
    x[0, 3] = 120.0
    x[1, [1, 5]] = [80.0, 150.0]
    y = x @ a.T
    # The interrogator's noise sets the l0 penalty (16 sigma^2), as --resolution-pm does.
    _, info = fbgforge.reconstruct(a, y, method="bnb", resolution_pm=0.25, return_info=True)
    assert info["penalty"] == 1.0 and info["max_loads"] == 4
    _, info = fbgforge.reconstruct(a, y, method="bnb", return_info=True)
    assert info["penalty"] == 4.0
    # The default choice says which method it took and why.
    got, info = fbgforge.reconstruct(a, y, max_loads=2, return_info=True)
    assert info["method"] in fbgforge.methods() and info["reason"]
    assert np.allclose(got, x, atol=0.5)
    # A penalty belongs to a named method; a bad resolution or load cap is refused.
    for kwargs, needle in [
        ({"penalty": 2.0}, "method"),
        ({"resolution_pm": 0.0}, "resolution"),
        ({"max_loads": 0}, "max_loads"),
    ]:
        with pytest.raises(fbgforge.FbgforgeError, match=needle):
            fbgforge.reconstruct(a, y, **kwargs)
