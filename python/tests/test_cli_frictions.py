"""The command line's small frictions of issue 40, as behaviours: a shipped design by
name (as Python finds it), the design as the first argument of `reconstruct` (the old
`--design` kept), and the verify table's numbers at their precision."""

import json
import re
import subprocess

import fbgforge

from conftest import DESIGNS, FIXTURES, ROOT


def run(cli, *args, ok=(0,), cwd=ROOT):
    p = subprocess.run([cli.exe, *map(str, args)], cwd=cwd, capture_output=True, text=True, timeout=600)
    assert p.returncode in ok, f"{args}: {p.returncode}\n{p.stderr}"
    return p


def test_a_shipped_name_is_the_design_python_finds_by_that_name(cli, tmp_path):
    by_name = json.loads(run(cli, "predict", "clip-on-34mm", "--json", "--fidelity", "closed-form").stdout)
    by_path = json.loads(run(cli, "predict", DESIGNS / "clip-on-34mm.toml", "--json", "--fidelity", "closed-form").stdout)
    assert by_name == by_path
    assert by_name["design"] == fbgforge.shipped_design("clip-on-34mm").name
    # From another folder too (the repository's designs/), and with `.toml`.
    other = json.loads(run(cli, "predict", "clip-on-34mm.toml", "--json", "--fidelity", "closed-form", cwd=tmp_path).stdout)
    assert other == by_path
    # An unknown name lists the shipped names: the ones Python lists.
    err = run(cli, "predict", "clip-on-99mm", ok=(2,)).stderr
    listed = re.search(r"the shipped designs: (.*)", err).group(1).split(", ")
    assert sorted(listed) == sorted(fbgforge.shipped_designs()), err


def test_reconstruct_takes_the_design_first_and_keeps_the_flag(cli, tmp_path):
    shifts = FIXTURES / "array" / "paper-model-shifts.csv"
    array = DESIGNS / "tactile-array-60x80.toml"
    first, flag = tmp_path / "first.csv", tmp_path / "flag.csv"
    run(cli, "reconstruct", array, "--shifts", shifts, "--out", first)
    run(cli, "reconstruct", "--design", array, "--shifts", shifts, "--out", flag)
    run(cli, "reconstruct", "tactile-array-60x80", "--shifts", shifts, "--out", tmp_path / "name.csv")
    assert first.read_text() == flag.read_text() == (tmp_path / "name.csv").read_text()
    # A design and a measured matrix at once is refused, naming both.
    err = run(cli, "reconstruct", array, "--matrix", FIXTURES / "array" / "paper-model-matrix.csv",
              "--shifts", shifts, ok=(2,)).stderr
    assert "--matrix" in err, err


def test_verify_prints_k_to_its_standard_error(cli, tmp_path):
    """K is printed to the first significant digit of its standard error (not four
    decimals whatever the noise), the model's K to 0.1 pm/N (its error is 8 %)."""
    run(cli, "synth-log", DESIGNS / "clip-on-34mm.toml", "--from-model", "--out", tmp_path)
    out = run(cli, "verify", DESIGNS / "clip-on-34mm.toml", "--log", tmp_path / "log.txt",
              "--force", tmp_path / "force.csv").stdout
    row = next(l for l in out.splitlines() if l.startswith("lambda_11"))
    k, se, _r2, _lag, _q, model = re.split(r"\s+", row.replace("≤ ", "≤"))[1:7]
    decimals = len(k.split(".")[1]) if "." in k else 0
    assert 10.0 ** -decimals <= float(se) < 10.0 ** (1 - decimals), row
    assert len(model.split(".")[1]) == 1, row


def test_the_lag_chart_draws_each_lag_with_its_uncertainty(cli, tmp_path):
    """The per-segment lag chart carries the ± that pulses.csv has, as a band around
    each grating's lags (issue 40: 1 ms of noise read as a trend)."""
    run(cli, "synth-log", DESIGNS / "clip-on-34mm.toml", "--from-model", "--out", tmp_path)
    run(cli, "verify", DESIGNS / "clip-on-34mm.toml", "--log", tmp_path / "log.txt",
        "--force", tmp_path / "force.csv", "--report", tmp_path / "rep")
    svg = (tmp_path / "rep" / "lag_per_pulse.svg").read_text()
    tagged = [l for l in svg.splitlines() if 'data-role="lag-with-uncertainty"' in l]
    bands = [l for l in tagged if "<polygon" in l or "<path" in l and " Z" in l]
    assert len(bands) >= 2, "a band per grating:\n" + "\n".join(tagged)


def test_a_profile_rule_names_an_unrounded_width_at_its_precision(cli, tmp_path):
    """The optimizer's designs carry unrounded numbers; the rules that name them print
    them to 0.001 mm (issue 40: `2.4658506093888226 mm` in the optimize report)."""
    text = (DESIGNS / "clip-on-10mm.toml").read_text()
    width = re.search(r"^width_mm = [0-9.]+$", text, re.M).group(0)
    bad = tmp_path / "wide.toml"
    # Within the field's range (up to the 5 mm radius), too wide for four pillars.
    bad.write_text(text.replace(width, "width_mm = 4.7658506093888226", 1))
    err = run(cli, "predict", bad, ok=(1,)).stderr
    assert "pillars of 4.766 mm overlap" in err and "4.7658506" not in err, err
