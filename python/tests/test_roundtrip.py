"""Round trips against the command line's JSON on the shipped designs and fixtures:
each binding calls the same library use case, so the documents agree (the command
line's null being the binding's NaN), and the result objects' arrays hold the same
numbers, with NaN, never None, where a number is missing."""

import json
import math
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import fbgforge
from conftest import ARRAY, DESIGNS, FIXTURES, MODULE, cli_json, close, in_python_words, no_none_in_numbers

MODULES = ["clip-on-10mm.toml", "clip-on-16mm.toml", "clip-on-22mm.toml", "clip-on-34mm.toml"]


@pytest.mark.parametrize("name", MODULES)
def test_predict_equals_the_cli_json(cli, name):
    path = DESIGNS / name
    want = cli_json(cli, "predict", path, "--json", "--fidelity", "closed-form", "--force-n", "3", "--delta-t-k", "2")
    got = fbgforge.predict(path, force_n=3.0, delta_t_k=2.0, fidelity="closed-form")
    close(got.to_dict(), want)
    no_none_in_numbers(got.to_dict())
    # The arrays are the rows' numbers, NaN where a row has no band.
    rows = want["predictions"]
    assert got.gratings == [r["grating"] for r in rows]
    assert np.allclose(got.sensitivity_pm_per_n, [r["sensitivity_pm_per_n"] for r in rows], rtol=1e-12)
    for r, lo in zip(rows, got.band_low_pm_per_n):
        assert (r.get("band_pm_per_n") is None) == math.isnan(lo)
    t = got.to_pandas()
    assert len(t) == len(rows) and "sensitivity_pm_per_n" in t.columns
    # A Design object and a path give the same answer.
    close(fbgforge.predict(fbgforge.load_design(path), force_n=3.0, delta_t_k=2.0, fidelity="closed-form").to_dict(), want)


def test_predict_case_ii_auto_equals_the_cli_and_k_is_linear(cli):
    want = cli_json(cli, "predict", MODULE, "--json", "--case", "II")
    got = fbgforge.predict(MODULE, case="II")
    close(got.to_dict(), want)
    one = fbgforge.predict(MODULE, force_n=1.0, case="II")
    assert one.models == ["closed-form"] * len(one.models)
    assert np.allclose(got.shift_pm, 10 * one.shift_pm, rtol=1e-12)


def test_predict_spectrum_is_the_cli_s_and_its_shift_per_newton_is_k(cli):
    # Off, the rows carry no spectrum, as `--no-spectrum`; on (the default, as the
    # command line), each row's peak shift per newton is its K (a uniform-enough
    # strain along the grating: the forward model moves the peak by the mean strain).
    want = cli_json(cli, "predict", MODULE, "--json", "--case", "II", "--no-spectrum")
    off = fbgforge.predict(MODULE, case="II", spectrum=False)
    close(off.to_dict(), want)
    assert all("spectrum" not in r for r in off.to_dict()["predictions"])
    on = fbgforge.predict(MODULE, case="II").to_dict()["predictions"]
    for r in on:
        k = r["sensitivity_pm_per_n"]
        assert abs(r["spectrum"]["peak_shift_per_n_pm_per_n"] - k) <= 0.01 * abs(k), r


def test_predict_mesh_level_equals_the_cli_and_states_its_discretisation(cli):
    path = DESIGNS / "clip-on-16mm.toml"
    want = in_python_words(cli_json(cli, "predict", path, "--json", "--case", "I", "--mesh-level", "2"))
    got = fbgforge.predict(path, case="I", mesh_level=2)
    close(got.to_dict(), want)
    assert got.to_dict()["starting_mesh_level"] == 2
    assert got.to_dict()["mesh_levels_used"] == [2]
    coarse = fbgforge.predict(path, case="I", mesh_level=1, band=False).to_dict()["predictions"]
    fine = got.to_dict()["predictions"]
    # A finer mesh states a smaller discretisation error (the Richardson step), and
    # every row states its error with the nominal inside its design interval.
    for c, f in zip(coarse, fine):
        assert f["model_error"]["discretisation_fraction"] < c["model_error"]["discretisation_fraction"]
        lo, hi = f["design_interval_pm_per_n"]
        assert lo <= f["sensitivity_pm_per_n"] <= hi
        assert f["model_error_fraction"] <= 0.15
    for bad in (0, 7):
        with pytest.raises(fbgforge.InputError, match=f"mesh_level {bad}"):
            fbgforge.predict(path, mesh_level=bad)


def test_build_writes_the_same_manifest_and_stl_as_the_cli(cli, tmp_path):
    path = DESIGNS / "clip-on-10mm.toml"
    cli("build", path, "--out", tmp_path / "cli", "--parts", "cap,core")
    for parts in (["cap", "core"], "cap,core"):
        got = fbgforge.build(path, tmp_path / "py", parts=parts)
        want = json.loads((tmp_path / "cli" / "manifest.json").read_text())
        assert got.manifest == want
        # The files the command line wrote for the same parts (the STL and STEP of each,
        # the manifest, and whatever the build adds beside them).
        cli_files = sorted(p.name for p in (tmp_path / "cli").iterdir())
        assert {"cap.step", "cap.stl", "core.step", "core.stl", "manifest.json"} <= set(cli_files)
        assert sorted(f.name for f in got.files) == cli_files
        for part in ["cap.stl", "core.stl"]:
            assert (tmp_path / "py" / part).read_bytes() == (tmp_path / "cli" / part).read_bytes()
    # A single part as a str: the issue's `parts="cap"`.
    one = fbgforge.build(path, tmp_path / "one", parts="cap")
    assert one.parts == ["cap"] and one.to_pandas().index.tolist() == ["cap"]


def test_read_log_gives_numpy_columns_and_a_long_table():
    log = fbgforge.read_log(FIXTURES / "logs" / "plain.csv")
    assert (log.format, log.clock) == ("csv", "relative")
    assert log.column_names == ["lambda_11", "lambda_12", "lambda_temp"]
    t = log.time_s
    assert isinstance(t, np.ndarray) and t.dtype == np.float64
    assert log.rows == len(t) and t[:3].tolist() == [0.0, 0.05, 0.10]
    starts = log.row_start
    assert starts[0] == 0 and len(starts) == len(t) + 1 and starts[-1] == len(log.peaks["wavelength_nm"])
    # Row 1 (t = 0.05) lacks lambda_12: two peaks, channels 0 and 2.
    row1 = log.peaks["row"] == 1
    assert log.peaks["channel"][row1].tolist() == [0, 2]
    assert log.peaks["wavelength_nm"][row1].tolist() == [1546.2953, 1560.1460]
    table = log.to_pandas()
    assert list(table.columns) == ["row", "time_s", "channel", "wavelength_nm"] and len(table) == starts[-1]


@pytest.mark.parametrize(
    "name, fmt",
    [
        ("enlight_peaks_bom_decimal_comma.txt", "enlight-peaks"),
        ("enlight_peaks_garbage_missing_channel.txt", "enlight-peaks"),
        ("enlight_sensors.txt", "enlight-sensors"),
        ("imon.txt", "imon"),
        ("plain.csv", "csv"),
    ],
)
def test_read_log_reads_every_fixture_format(name, fmt):
    log = fbgforge.read_log(FIXTURES / "logs" / name)
    assert log.format == fmt and log.rows >= 2


def test_a_truncated_or_ragged_log_is_read_with_its_bad_rows_counted():
    truncated = fbgforge.read_log(FIXTURES / "logs" / "enlight_peaks_104_metadata_dropped_truncated.txt")
    w = truncated.warnings["truncated_last_line"]
    assert w["count"] == 1 and w["first"].endswith(":109: fewer wavelengths than the peak counts announce")
    ragged = fbgforge.read_log(FIXTURES / "logs" / "enlight_peaks_garbage_missing_channel.txt")
    assert ragged.rows == 6
    assert {k: v["count"] for k, v in ragged.warnings.items()} == {
        "missing_channel": 1,
        "peak_count_mismatch": 1,
        "unreadable_line": 2,
    }


def test_verify_equals_the_cli_json_and_finds_the_synthetic_k(cli, synth_logs, tmp_path):
    args = [MODULE, "--log", synth_logs / "log.txt", "--force", synth_logs / "force.csv"]
    # The same document, its reasons and warnings naming Python's parameters.
    want = in_python_words(cli_json(cli, "verify", *args, "--json", ok_codes=(0, 2, 3, 4)))
    got = fbgforge.verify(MODULE, synth_logs / "log.txt", synth_logs / "force.csv", report_dir=tmp_path / "report")
    close(got.to_dict(), want)
    no_none_in_numbers(got.to_dict())
    assert got.gratings[0] == "lambda_11" and abs(got.measured_sensitivity_pm_per_n[0] - 12.0) < 0.5
    assert got.verdict == want["verdict"]["overall"]
    assert got.measurement["wavelength_rows"] == fbgforge.read_log(synth_logs / "log.txt").rows
    t = got.to_pandas()
    assert t.loc["lambda_11", "verdict.status"] == want["verdict"]["gratings"][0]["status"]
    assert (tmp_path / "report" / "report.json").exists()


def test_reconstruct_recovers_known_loads_with_per_frame_columns():
    m = fbgforge.sensing_matrix(ARRAY)
    assert m.shape == (6, 8) and m.cells == list("ABCDEFGH") and m.ulimit_g == 250.0
    x = np.zeros((4, 8))
    x[0, 1] = 100.0
    x[1, [0, 6]] = [200.0, 50.0]
    x[2, [2, 4, 7]] = [100.0, 50.0, 200.0]
    y = x @ m.sensitivity_pm_per_g.T
    r = fbgforge.reconstruct(m, y, gratings="matrix")
    assert r.loads_g.shape == (4, 8) and r.loads_g.dtype == np.float64
    assert np.allclose(r.loads_g, x, atol=0.5), r.loads_g
    assert r.method in fbgforge.methods() and r.reason
    assert r.converged.dtype == np.bool_ and r.converged.all()
    assert r.residual_pm.shape == (4,) and (r.residual_pm < 0.1).all()
    # Every per-frame field of the library comes along as a column.
    assert set(r.per_frame) >= {"converged", "iterations", "residual_pm"}
    assert r.iterations.shape == (4,)
    # Issue 24: the same trust as the CLI's CSV. Noise-free frames of the model pass the
    # residual test and no grating is left out; a grating reading 25 pm below rest
    # cannot be explained by loads.
    assert len(r.flags) == 4 and r.suspect_gratings == []
    assert not any("inconsistent" in f for f in r.flags), r.flags
    assert r.certified.dtype == np.bool_ and r.chi2.shape == (4,)
    bad = y[:1].copy()
    bad[0, 0] -= 25.0
    assert "inconsistent" in fbgforge.reconstruct(m, bad, gratings="matrix").flags[0]
    for method in ["support", "nnls", "omp"]:
        assert fbgforge.reconstruct(m, y[:1], gratings="matrix", method=method).loads_g.shape == (1, 8)
    # The interrogator's noise sets the l0 penalty (16 sigma^2), as --resolution-pm does.
    assert fbgforge.reconstruct(m, y, gratings="matrix", method="bnb", resolution_pm=0.25).setup["penalty"] == 1.0
    assert fbgforge.reconstruct(m, y, gratings="matrix", method="bnb").setup["penalty"] == 4.0


def test_reconstruct_releases_the_gil():
    """A Python thread runs while reconstruct works. Holding the GIL, the call would
    keep that thread from running any bytecode until it returns, so none of the
    thread's time stamps could fall inside the middle half of the call, whatever the
    machine's speed or load. The call is sized (doubling the frames) to last at least
    0.3 s."""
    m = fbgforge.sensing_matrix(ARRAY)
    rng = np.random.default_rng(5)

    def frames(n):
        x = np.zeros((n, 8))
        x[np.arange(n), rng.integers(0, 8, n)] = rng.uniform(50, 200, n)
        return x, x @ m.sensitivity_pm_per_g.T

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
            got = fbgforge.reconstruct(m, y, gratings="matrix")
            t1 = time.perf_counter()
            if t1 - t0 >= 0.3 or n >= 1 << 20:
                break
            n *= 2
    finally:
        done.set()
        t.join()
    assert np.allclose(got.loads_g, x, atol=1.0)
    if t1 - t0 < 0.3:
        pytest.skip(f"{n} frames take only {t1 - t0:.3f} s here: no call lasts long enough to watch")
    lo, hi = t0 + 0.25 * (t1 - t0), t1 - 0.25 * (t1 - t0)
    assert sum(lo < s < hi for s in stamps) >= 1, (n, t1 - t0, len(stamps))


def test_verify_names_presses_the_force_does_not_explain(cli, tmp_path):
    # Issue #33: the wavelength log of one run (presses every 34 s) against the force
    # log of another (presses every 10 s, over by 65 s), the clock offset given. The
    # sensor reads silent, but its shift shows presses of the model's size where that
    # force log rests or has no samples: NOT JUDGED (unexplained), not NO RESPONSE,
    # the presses listed in the alignment, and the reason in Python's words.
    common = dict(core="psc2", format="csv", k_pm_per_n=-170.0, rate_hz=20, pulses_n=(2, 3, 4, 3.5, 2.5, 3))
    fbgforge.synth_log(MODULE, tmp_path / "part", rest_s=30.0, **common)
    fbgforge.synth_log(MODULE, tmp_path / "other", rest_s=6.0, seed=2, **common)
    log, force = tmp_path / "part" / "log.csv", tmp_path / "other" / "force.csv"
    got = fbgforge.verify(MODULE, log, force, case="II", core="psc2", clock_offset_s=1.7)
    want = in_python_words(
        cli_json(cli, "verify", MODULE, "--log", log, "--force", force, "--case", "II", "--core", "psc2",
                 "--clock-offset-s", "1.7", "--json", ok_codes=(3,))
    )
    close(got.to_dict(), want)
    v = got.to_dict()["verdict"]
    assert v["overall"] == "not_judged" and v["reason_code"] == "unexplained", v
    assert "at rest or has no samples" in v["reason"] and "clock_offset_s" in v["reason"], v["reason"]
    assert "--" not in v["reason"], v["reason"]
    presses = got.measurement["alignment"]["shift_presses_at_rest"]
    # The part's presses after 65 s (73, 107, 141, 175 s) lie beyond the force log.
    late = [p for p in presses if p["start_s"] > 66.0]
    assert len(late) >= 4 and all(p["amplitude_pm"] < -300.0 for p in late), presses
    assert got.measurement["alignment"]["shift_grating"] == "lambda_21"
