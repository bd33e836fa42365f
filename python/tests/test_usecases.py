"""The rest of the tool from Python: sweep, optimize, place, synth_log,
calibrate_array and live, each against known truth or the command line's JSON."""

import re
import subprocess

import numpy as np
import pytest

import fbgforge
from conftest import ARRAY, MODULE, cli_json, close


def test_sweep_equals_the_cli_and_log_spacing_spans_decades(cli, tmp_path):
    s = fbgforge.sweep(MODULE, "e1_mpa", start=1, stop=1000, steps=4, spacing="log", case="II", fidelity="closed-form")
    assert np.allclose(s.values, [1, 10, 100, 1000])
    assert s.shift_pm.shape == (len(s.series), 4) and all("Case II" in x for x in s.series)
    # Case II's K falls as the core stiffens: more of the force goes through the core.
    assert np.all(np.diff(np.abs(s.sensitivity_pm_per_n), axis=1) < 0)
    # Linear steps: the same numbers as the command line's CSV.
    lin = fbgforge.sweep(MODULE, "cap_wall_mm", start=1.0, stop=1.5, steps=3, case="II", fidelity="closed-form")
    csv = tmp_path / "s.csv"
    cli("sweep", MODULE, "--param", "cap_wall_mm", "--from", "1", "--to", "1.5", "--steps", "3", "--case", "II",
        "--fidelity", "closed-form", "--csv", csv, "--plot", tmp_path / "s.svg")
    import pandas as pd

    want = pd.read_csv(csv)
    got = lin.to_pandas()
    assert np.allclose(got["shift_pm"].to_numpy(), want["shift_pm"].to_numpy(), atol=1e-5)
    # Explicit values; no band for the closed form (NaN, not None).
    v = fbgforge.sweep(MODULE, "es_mpa", [5.0, 50.0], case="II", fidelity="closed-form")
    assert v.values.tolist() == [5.0, 50.0] and np.isnan(v.band_low_pm_per_n).all()


def test_synth_log_writes_what_the_cli_writes(cli, tmp_path):
    py = fbgforge.synth_log(MODULE, tmp_path / "py", k_pm_per_n=9.0, rate_hz=10, seed=3)
    cli("synth-log", MODULE, "--out", tmp_path / "cli", "--k-pm-per-n", "9", "--rate-hz", "10", "--seed", "3")
    for name in ["log.txt", "force.csv", "truth.json"]:
        assert (tmp_path / "py" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes(), name
    assert py.truth_values["gratings"][0]["sensitivity_pm_per_n"] == 9.0
    # Every format reads back with its rows.
    for fmt in ["enlight-sensors", "imon", "csv"]:
        s = fbgforge.synth_log(MODULE, tmp_path / fmt, format=fmt, rate_hz=5)
        assert fbgforge.read_log(s.log).format == fmt


def test_calibrate_array_recovers_the_true_matrix(tmp_path):
    sched = tmp_path / "schedule.csv"
    lines = ["start_s,end_s,cell,load_g"] + [f"{10 + 30 * i},{30 + 30 * i},{c},200" for i, c in enumerate("ABCDEFGH")]
    sched.write_text("\n".join(lines) + "\n")
    run = fbgforge.synth_log(ARRAY, tmp_path, schedule=sched, noise_pm=0.05, drift_pm_per_s=0.0, rate_hz=20)
    truth = run.matrix
    m = fbgforge.calibrate_array(ARRAY, run.log, sched, out=tmp_path / "A.csv")
    assert m.gratings == truth.gratings and m.cells == truth.cells
    assert np.allclose(m.sensitivity_pm_per_g, truth.sensitivity_pm_per_g, atol=2e-3)
    assert (tmp_path / "A.csv").exists()
    t = m.to_pandas()
    assert t.loc["fbg1", "A"] == pytest.approx(truth.sensitivity_pm_per_g[0, 0], abs=2e-3)
    # Usable, no unusable fault, the scatter beside the matrix as reconstruct reads it.
    assert m.usable and m.complete
    assert all(f["severity"] == "warning" for f in m.faults)
    assert m.sd_pm_per_g.shape == truth.sensitivity_pm_per_g.shape and (m.sd_pm_per_g > 0).all()
    assert (tmp_path / "A.sd.csv").exists()


def test_calibrate_array_staircase_and_faults_match_the_command_line(cli, tmp_path):
    # A staircase on cell C (25 g steps to 250 g, 5 s each, three cycles), then every
    # cell at 200 g: Table 2 and the matrix as `calibrate-array --json` gives them.
    rows, t = ["start_s,end_s,cell,load_g"], 10.0
    for _ in range(3):
        for k in [*range(1, 11), *range(9, 0, -1)]:
            rows.append(f"{t},{t + 5},C,{25 * k}")
            t += 5
        t += 5
    for c in "ABCDEFGH":
        rows.append(f"{t + 10},{t + 20},{c},200")
        t += 20
    sched = tmp_path / "schedule.csv"
    sched.write_text("\n".join(rows) + "\n")
    run = fbgforge.synth_log(ARRAY, tmp_path, schedule=sched, noise_pm=0.3, drift_pm_per_s=0.0, rate_hz=5)
    m = fbgforge.calibrate_array(ARRAY, run.log, sched)
    j = cli_json(cli, "calibrate-array", ARRAY, "--log", run.log, "--schedule", sched, "--out", tmp_path / "cli.csv", "--json")
    assert m.gratings == j["gratings"] and m.cells == j["cells"]
    assert np.allclose(m.sensitivity_pm_per_g, np.array(j["matrix_pm_per_g"], dtype=float), rtol=1e-9)
    assert [f["kind"] for f in m.faults] == [f["kind"] for f in j["faults"]]
    assert len(m.metrology) == len(j["metrology"]) == 6
    for a, b in zip(m.metrology, j["metrology"]):
        assert (a["cell"], a["grating"], a["cycles"]) == (b["cell"], b["grating"], 3)
        for k in ["sensitivity_pm_per_g", "r", "resolution_g", "linearity_percent_span", "hysteresis_percent_span"]:
            assert a[k] == pytest.approx(b[k], rel=1e-9)
    # The staircase's direct grating reads its true entry (a linear synthetic sheet).
    direct = max(m.metrology, key=lambda r: r["sensitivity_pm_per_g"])
    g = m.gratings.index(direct["grating"])
    assert direct["sensitivity_pm_per_g"] == pytest.approx(run.matrix.sensitivity_pm_per_g[g, 2], rel=0.01)
    assert direct["resolution_g"] == pytest.approx(0.5 / direct["sensitivity_pm_per_g"], rel=1e-9)


def test_optimize_finds_a_feasible_better_design_and_writes_it(tmp_path):
    out = tmp_path / "opt.toml"
    o = fbgforge.optimize(MODULE, objective="sensitivity", vary=["cap_wall_mm", "core_wall_mm"], inserts="none",
                          solver="nelder-mead", starts=0, max_iters=30, out=out, report_dir=tmp_path / "report")
    assert o.design_path == out and out.exists() and (tmp_path / "report" / "summary.json").exists()
    assert fbgforge.load_design(out) == o.design
    start = o.to_dict()["start"]["objective"]
    assert o.objective >= start > 0
    # The objective is the weakest grating's smallest |K| over its design interval (the
    # robust default, issue 38), as predict says of the written design.
    rows = fbgforge.predict(o.design, case="II").to_dict()["predictions"]
    worst = min(min(abs(r["design_interval_pm_per_n"][0]), abs(r["design_interval_pm_per_n"][1])) for r in rows)
    assert o.objective == pytest.approx(worst, rel=1e-6)
    assert o.objective < min(abs(r["sensitivity_pm_per_n"]) for r in rows)
    table = o.to_pandas()
    assert {"choice", "objective", "cap_wall_mm", "core_wall_mm"} <= set(table.columns)


def test_place_returns_the_placed_layout(tmp_path):
    p = fbgforge.place(ARRAY, objective="coherence", solver="nelder-mead", max_iters=10, agreement_samples=0,
                       out=tmp_path / "placed.toml")
    assert p.best_objective >= p.start_objective
    assert p.gratings == p.design.gratings and p.y_mm.shape == p.start_y_mm.shape == (6,)
    assert fbgforge.load_design(tmp_path / "placed.toml") == p.design
    start = fbgforge.shipped_design("tactile-array-60x80").to_dict()["array"]["gratings"]
    assert np.allclose(p.start_y_mm, [g["y_mm"] for g in start])


def write_growing_csv(path, rows):
    """A plain CSV log of the array at its nominal wavelengths plus 120 g on cell C."""
    d = fbgforge.shipped_design("tactile-array-60x80")
    m = fbgforge.sensing_matrix(d)
    nominal = np.array([g["bragg_wavelength_nm"] for g in d.to_dict()["array"]["gratings"]])
    lines = ["time_s," + ",".join(m.gratings)]
    for k in range(rows):
        load = np.zeros(8)
        if k >= 10:
            load[2] = 120.0
        lam = nominal + 1e-3 * (m.sensitivity_pm_per_g @ load)
        lines.append(f"{0.01 * k:.3f}," + ",".join(f"{x:.6f}" for x in lam))
    path.write_text("\n".join(lines) + "\n")


def test_live_frames_are_an_iterator_of_readings(tmp_path):
    log = tmp_path / "log.csv"
    write_growing_csv(log, 40)
    # At rest for its first 10 rows (0.09 s): a tare of 10 frames with no minimum time.
    with fbgforge.live(ARRAY, log, from_start=True, idle_exit_s=0.3, tare_frames=10, tare_s=0.0) as stream:
        frames = list(stream)
    assert stream.info["kind"] == "array" and stream.info["outputs"] == list("ABCDEFGH")
    assert len(frames) == 30 and stream.summary["frames_out"] == 30 and stream.summary["tare_frames"] == 10
    for f in frames:
        assert f.outputs == list("ABCDEFGH") and f.loads_g.shape == (8,)
        assert f.loads_g[2] == pytest.approx(120.0, abs=1.0)
        assert np.isnan(f.age_us)  # a relative clock: no age
    assert stream.summary["source_lost"] is False
    # A limit ends it early, with the same readings.
    first = list(fbgforge.live(ARRAY, log, from_start=True, idle_exit_s=5, tare_frames=10, tare_s=0.0, frames=5))
    assert len(first) == 5 and np.allclose(first[0].loads_g, frames[0].loads_g)


def synth_server(cli, script, duration_s):
    server = subprocess.Popen(
        [cli.exe, "synth-stream", str(ARRAY), "--port", "0", "--script", str(script), "--duration-s", duration_s,
         "--noise", "none", "--frame-clock", "client", "--json"],
        stdout=subprocess.PIPE, text=True,
    )
    port = int(re.search(r":(\d+)", server.stdout.readline()).group(1))
    return server, port


def test_live_reads_a_simulated_hyperion_re_tares_and_stops_at_its_end(cli, tmp_path):
    script = tmp_path / "script.csv"
    script.write_text("hold_s,A,B,C,D,E,F,G,H\n0.2,0,0,0,0,0,0,0,0\n10,0,100,0,0,0,0,0,0\n")
    server, port = synth_server(cli, script, "3")
    try:
        # The script rests 0.2 s: a tare window of 100 frames with no minimum time.
        stream = fbgforge.live(ARRAY, f"tcp://127.0.0.1:{port}", tare_frames=100, tare_s=0.0, give_up_s=0.5)
        frames = []
        for f in stream:  # the stream's own end stops the iterator: no exception
            frames.append(f)
            if len(frames) == 1000:
                stream.tare()  # under the steady 100 g: the new zero is the load
        assert stream.summary["source_lost"] is False and "end of stream" in stream.summary["ended"]
        assert stream.summary["frames_out"] == len(frames) and stream.summary["tare_requests"] == 1
        states = [(t["state"], t["origin"]) for t in stream.tares]
        assert states[0] == ("resting", "start") and ("waiting", "python") in states
        assert states[-1] == ("resting", "python")
        retared = stream.tares[-1]["frame"]
        loaded = [f for f in frames if f.serial >= 250 and f.frame <= 1000]
        assert loaded and all(abs(f.loads_g[1] - 100.0) < 2.0 for f in loaded)
        after = [f for f in frames if f.frame > retared]
        assert after and all(abs(f.loads_g[1]) < 2.0 for f in after)
        # The instrument's clock is this machine's: the age is measured.
        assert all(np.isfinite(f.age_us) for f in frames)
        assert ("connected", f"hyperion 127.0.0.1:{port}") in stream.events
    finally:
        server.kill()
        server.wait()


def test_live_reports_a_lost_instrument(cli, tmp_path):
    script = tmp_path / "script.csv"
    script.write_text("hold_s,A,B,C,D,E,F,G,H\n0.2,0,0,0,0,0,0,0,0\n10,0,100,0,0,0,0,0,0\n")
    server, port = synth_server(cli, script, "60")
    try:
        stream = fbgforge.live(ARRAY, f"tcp://127.0.0.1:{port}", tare_frames=100, tare_s=0.0, give_up_s=0.5)
        frames = []
        with pytest.raises(fbgforge.InstrumentLostError) as e:
            for f in stream:
                frames.append(f)
                if len(frames) == 50:
                    server.kill()  # gone without a word: lost, not ended
        assert isinstance(e.value, ConnectionError) and "gave up reconnecting" in str(e.value)
        assert e.value.summary["source_lost"] is True
    finally:
        server.kill()
        server.wait()
