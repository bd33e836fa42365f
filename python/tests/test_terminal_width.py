"""Every command's default terminal output fits 80 columns (issue 40).

Each subcommand runs as a new user runs it on the shipped designs (no --json), from a
scratch folder so its out/ does not touch the repository, and every line it prints on
standard output and standard error must be at most 80 columns wide, counted as a
terminal counts them (East Asian wide and full-width characters two columns, combining
marks none). The wide detail is in the JSON and the report folders; each command's
output must also hold a fragment of its table, so an empty output cannot pass.
"""

import re
import subprocess
import unicodedata

import pytest

from conftest import DESIGNS, FIXTURES, ROOT

WIDTH = 80
ANSI = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")


def columns(line):
    """Terminal columns of `line`."""
    line = ANSI.sub("", line)
    return sum(
        0 if unicodedata.combining(c) else 2 if unicodedata.east_asian_width(c) in "WF" else 1
        for c in line
    )


def test_columns_counts_as_a_terminal_does():
    assert columns("K pm/N µε R² Δt_max …") == 21
    assert columns("日本") == 4
    assert columns("e\u0301") == 1
    assert columns("\x1b[2Jab") == 2


@pytest.fixture(scope="module")
def scratch(tmp_path_factory):
    return tmp_path_factory.mktemp("width")


def run(cli, scratch, *args, ok=(0,), stdin=None):
    p = subprocess.run(
        [cli.exe, *map(str, args)],
        cwd=scratch,
        input=stdin,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        timeout=900,
    )
    assert p.returncode in ok, f"{args}: exit {p.returncode}\n{p.stdout}"
    return p.stdout


def assert_fits(text, fragment, what):
    assert fragment in text, f"{what}: expected `{fragment}` in\n{text}"
    wide = [(columns(l), l) for l in text.splitlines() if columns(l) > WIDTH]
    assert not wide, f"{what}: {len(wide)} lines over {WIDTH} columns, e.g. ({wide[0][0]}):\n{wide[0][1]}\n\n{text}"


MODULE = DESIGNS / "clip-on-34mm.toml"
ARRAY = DESIGNS / "tactile-array-60x80.toml"


@pytest.mark.parametrize("design, fragment", [("clip-on-34mm", "strain"), ("clip-on-16mm", "strain"), ("tactile-array-60x80", "fbg1")])
def test_predict_fits(cli, scratch, design, fragment):
    assert_fits(run(cli, scratch, "predict", DESIGNS / f"{design}.toml"), fragment, f"predict {design}")


def test_synth_log_and_verify_with_and_without_report_fit(cli, scratch):
    out = run(cli, scratch, "synth-log", MODULE, "--from-model", "--out", "first")
    assert_fits(out, "K from the model", "synth-log --from-model")
    logs = ["--log", "first/log.txt", "--force", "first/force.csv"]
    assert_fits(run(cli, scratch, "verify", MODULE, *logs), "verdict: PASS", "verify")
    assert_fits(run(cli, scratch, "verify", MODULE, *logs, "--report", "rep"), "report:", "verify --report")
    # A failing run, with its reasons and warnings: the README's second example.
    run(cli, scratch, "synth-log", MODULE, "--temperature-ramp-k-per-s", "0.1", "--decimal-comma", "--bom", "--out", "ex")
    fail = run(cli, scratch, "verify", MODULE, "--log", "ex/log.txt", "--force", "ex/force.csv", "--core", "psc1", ok=(2,))
    assert_fits(fail, "verdict: FAIL", "verify (FAIL)")


def test_sweep_fits(cli, scratch):
    out = run(cli, scratch, "sweep", MODULE, "--param", "es_mpa", "--from", "10", "--to", "2000", "--steps", "21", "--case", "I")
    assert_fits(out, "Δλ first", "sweep")
    # A modulus without a range: the material library's, said in a line that fits.
    out = run(cli, scratch, "sweep", MODULE, "--param", "es_mpa", "--steps", "5", "--fidelity", "closed-form")
    assert_fits(out, "range from the material library", "sweep (library range)")


def test_build_fits(cli, scratch):
    assert_fits(run(cli, scratch, "build", MODULE), "triangles", "build module")
    assert_fits(run(cli, scratch, "build", ARRAY), "triangles", "build array")


def test_optimize_and_place_fit(cli, scratch):
    assert_fits(run(cli, scratch, "optimize", DESIGNS / "clip-on-16mm.toml"), "obj pm/(N·s)", "optimize")
    assert_fits(run(cli, scratch, "place", ARRAY), "held-out protocol", "place")


def test_array_commands_fit(cli, scratch):
    schedule = scratch / "schedule.csv"
    rows = [f"{2 + 5 * i},{5 + 5 * i},{c},100" for i, c in enumerate("ABCDEFGH")]
    schedule.write_text("start_s,end_s,cell,load_g\n" + "\n".join(rows) + "\n")
    assert_fits(run(cli, scratch, "synth-log", ARRAY, "--schedule", schedule, "--out", "cal"), "wrote", "synth-log --schedule")
    cal = run(cli, scratch, "calibrate-array", ARRAY, "--log", "cal/log.txt", "--schedule", schedule, "--out", "cal/A.csv")
    assert_fits(cal, "pm/g", "calibrate-array")
    rec = run(cli, scratch, "reconstruct", "--matrix", FIXTURES / "array" / "paper-model-matrix.csv",
              "--shifts", FIXTURES / "array" / "paper-model-shifts.csv")
    assert_fits(rec, "trusted 4 of 4 frames", "reconstruct")
    # The calibration run's wavelength log, tared and matched as `live` does.
    rec = run(cli, scratch, "reconstruct", ARRAY, "--log", "cal/log.txt", "--out", "cal/loads.csv")
    assert_fits(rec, "frames at rest", "reconstruct --log")


def test_peaks_fits(cli, scratch):
    run(cli, scratch, "synth-log", MODULE, "--format", "imon-pixels", "--line-shape", "gaussian", "--out", "spec")
    cal = "1595.1663405088063,-0.16634050880626223"
    out = run(cli, scratch, "peaks", "spec/log.txt", "--imon-calibration", cal, "--design", MODULE)
    assert_fits(out, "wavelength", "peaks")


def test_live_status_line_fits_with_a_large_residual(cli, scratch):
    """The terminal view on a finite stream (standard input): frames that no loads
    explain (residual > 10 pm), so the status line carries a two- or more-digit
    residual, on one line."""
    frame = "1520.857 1523.530 1526.687 1530.697 1534.128 1537.519\n"
    out = run(cli, scratch, "live", ARRAY, "--from", "-", "--no-tare", stdin=frame * 30)
    assert_fits(out, "residual", "live")
    line = next(l for l in out.splitlines() if "residual" in l)
    residual = float(re.search(r"residual (\d+(?:\.\d+)?) pm", line).group(1))
    assert residual >= 10, line
