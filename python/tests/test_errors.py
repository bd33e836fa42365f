"""Errors: each a subclass of the built-in it is a kind of, with the command line's
message where both read the same input, and the parameters named as Python names
them (never a command-line flag)."""

import numpy as np
import pytest

import fbgforge
from conftest import ARRAY, DESIGNS, FIXTURES, MODULE, cli_error


def write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text)
    return p


@pytest.mark.parametrize(
    "case, edit",
    [
        ("malformed TOML", lambda s: s.replace('name = "clip-on-34mm"', 'name = "clip-on-34mm', 1)),
        ("unknown field", lambda s: s.replace("[module]\n", "[module]\ncolour = \"red\"\n", 1)),
        ("impossible geometry", lambda s: s.replace("cap_wall_mm = 1.5", "cap_wall_mm = 30.0", 1)),
        ("wrong units", lambda s: s.replace("outer_diameter_mm = 34.0", "outer_diameter_mm = \"34 mm\"", 1)),
    ],
)
def test_a_bad_design_is_a_design_error_with_the_cli_message(cli, tmp_path, case, edit):
    bad = write(tmp_path, "bad.toml", edit(MODULE.read_text()))
    want = cli_error(cli, "predict", bad)
    with pytest.raises(fbgforge.DesignError) as e:
        fbgforge.load_design(bad)
    assert str(e.value) == want, case
    assert e.value.file == str(bad)
    assert isinstance(e.value, ValueError) and isinstance(e.value, fbgforge.FbgforgeError)
    with pytest.raises(ValueError):
        fbgforge.predict(bad)


def test_a_missing_file_is_a_file_not_found_error():
    for call in [
        lambda: fbgforge.load_design("no/such/design.toml"),
        lambda: fbgforge.predict("no/such/design.toml"),
        lambda: fbgforge.read_log("no/such/log.txt"),
        lambda: fbgforge.verify(MODULE, "no/such/log.txt", FIXTURES / "logs" / "force_stand.csv"),
        lambda: fbgforge.calibrate_array(ARRAY, "no/such/log.txt", "no/such/schedule.csv"),
    ]:
        with pytest.raises(FileNotFoundError) as e:
            call()
        assert isinstance(e.value, OSError) and isinstance(e.value, fbgforge.MissingFileError)
        assert "no/such/" in str(e.value) and e.value.filename.startswith("no/such/")
        assert not isinstance(e.value, ValueError)


def test_an_unwritable_output_is_an_os_error(tmp_path):
    blocker = write(tmp_path, "file", "not a folder")
    with pytest.raises(OSError) as e:
        fbgforge.build(DESIGNS / "clip-on-10mm.toml", blocker / "out", parts="cap")
    assert isinstance(e.value, fbgforge.FileError)


@pytest.mark.parametrize(
    "name, words",
    [("mostly_garbage.txt", "unreadable"), ("metadata_only.txt", "cannot tell the log format")],
)
def test_a_bad_log_raises_the_cli_message(cli, name, words):
    log = FIXTURES / "logs" / name
    force = FIXTURES / "logs" / "force_stand.csv"
    want = cli_error(cli, "verify", MODULE, "--log", log, "--force", force)
    with pytest.raises(fbgforge.InputError, match=words) as e:
        fbgforge.read_log(log)
    assert str(e.value) == want
    with pytest.raises(fbgforge.InputError) as e:
        fbgforge.verify(MODULE, log, force)
    assert str(e.value) == want


def test_a_force_log_running_backwards_raises_the_cli_message(cli, tmp_path, synth_logs):
    lines = (synth_logs / "force.csv").read_text().splitlines()
    backwards = write(tmp_path, "force.csv", "\n".join([lines[0], *lines[1:][::-1]]) + "\n")
    want = cli_error(cli, "verify", MODULE, "--log", synth_logs / "log.txt", "--force", backwards)
    with pytest.raises(fbgforge.InputError) as e:
        fbgforge.verify(MODULE, synth_logs / "log.txt", backwards)
    assert str(e.value) == want


def test_bad_values_are_value_errors_naming_python_parameters():
    m = fbgforge.sensing_matrix(ARRAY)
    y = np.zeros((2, 6))
    y[1, 2] = np.nan
    cases = [
        (lambda: fbgforge.reconstruct(m, y, gratings="matrix"), "frame 1, grating `fbg3`: NaN is not a finite shift"),
        (lambda: fbgforge.reconstruct(m, np.zeros(6), gratings="matrix", method="magic"), "unknown method `magic`"),
        (lambda: fbgforge.reconstruct(m, np.zeros(6), gratings="matrix", ulimit_g=-1.0), "ulimit must be a positive load"),
        (lambda: fbgforge.reconstruct(m, np.zeros(6), gratings="matrix", penalty=2.0), "give method= as well"),
        (lambda: fbgforge.reconstruct(m, np.zeros(6), gratings="matrix", resolution_pm=0.0), "resolution"),
        (lambda: fbgforge.reconstruct(m, np.zeros(6), gratings="matrix", max_loads=0), "max_loads must be at least 1"),
        (lambda: fbgforge.reconstruct(np.full((6, 8), np.inf), np.zeros(6), gratings="matrix"), "sensing matrix entry"),
        (lambda: fbgforge.predict(MODULE, case="III"), 'expected "I"'),
        (lambda: fbgforge.predict(MODULE, force_n=float("nan")), "force_n must be a finite number of newtons"),
        (lambda: fbgforge.read_log(FIXTURES / "logs" / "plain.csv", format="xml"), "format `xml`"),
        (lambda: fbgforge.sensing_matrix(MODULE), "has no [array] section"),
        (lambda: fbgforge.sweep(MODULE, "e1_mpa", start=5, stop=1, case="II"), "start 5 must be smaller than stop 1"),
        (lambda: fbgforge.sweep(MODULE, "e1_mpa", start=1, stop=5, steps=1, case="II"), "steps must be between 2"),
        (lambda: fbgforge.sweep(MODULE, "wall_colour", start=1, stop=5), "unknown sweep parameter"),
        (lambda: fbgforge.build(MODULE, "out/never", tolerance_mm=-1.0), "tolerance"),
        (lambda: fbgforge.live(ARRAY, "-", duration_s=-1.0), "duration_s must be a positive number"),
        (lambda: fbgforge.live(ARRAY, "-", give_up_s=-1.0), "give_up_s must be"),
    ]
    for call, needle in cases:
        with pytest.raises(fbgforge.InputError) as e:
            call()
        assert needle in str(e.value), (needle, str(e.value))
        assert "--" not in str(e.value), str(e.value)
        assert isinstance(e.value, ValueError)


def test_wrong_types_are_type_errors():
    with pytest.raises(TypeError, match="parts must be a str or a list"):
        fbgforge.build(MODULE, "out/never", parts=5)
    with pytest.raises(TypeError, match="design must be a Design or a path"):
        fbgforge.predict(42)
    with pytest.raises(TypeError):
        fbgforge.Design.from_dict([1, 2])
