"""Results in the SciPy manner: a repr shows the values that matter, every figure of
merit is an attribute, to_pandas() leads with the identifying columns and has flat
numeric columns; Design.replace takes plain keywords; synth_log(from_model=True) is a
log on which verify PASSes."""

import numpy as np
import pytest

import fbgforge
from conftest import ARRAY, MODULE


@pytest.fixture(scope="module")
def passing(tmp_path_factory):
    out = tmp_path_factory.mktemp("first")
    s = fbgforge.synth_log(MODULE, out, from_model=True)
    return fbgforge.verify(MODULE, s.log, s.force)


def test_a_log_that_follows_the_model_passes(passing):
    assert passing.verdict == "pass"
    assert np.allclose(passing.measured_sensitivity_pm_per_n, passing.predicted_sensitivity_pm_per_n, rtol=0.01)


def test_the_verify_report_shows_its_numbers(passing):
    text = repr(passing)
    assert text.startswith("<VerifyReport clip-on-34mm: pass (Case II)")
    for g, k in zip(passing.gratings, passing.sensitivity_pm_per_n):
        line = next(l for l in text.splitlines() if l.strip().startswith(g))
        assert f"{k:.4g}" in line and line.rstrip(" >").endswith("pass"), line
    # Figures of merit as arrays, one per measured grating.
    for name in ("r_squared", "max_lag_s", "quality_q_pm_per_n_s", "hysteresis_percent_span", "resolution_n"):
        v = getattr(passing, name)
        assert isinstance(v, np.ndarray) and v.shape == (len(passing.gratings),), name
    assert np.all((passing.r_squared > 0.5) & (passing.r_squared <= 1.0))
    assert np.all(passing.max_lag_s > 0)
    with pytest.raises(AttributeError):
        passing.no_such_figure


def test_the_prediction_shows_k_per_grating_and_leads_its_table_with_names():
    p = fbgforge.predict(MODULE, case="II")
    text = repr(p)
    for g, k in zip(p.gratings, p.sensitivity_pm_per_n):
        assert any(l.strip().startswith(g) and f"{k:.4g}" in l for l in text.splitlines()), (g, text)
    t = p.to_pandas()
    assert list(t.columns[:4]) == ["grating", "core", "case", "insert"]
    # No list-valued cells: pairs are two numeric columns, word lists one string.
    for c in t.columns:
        assert not any(isinstance(v, list) for v in t[c]), c
    assert {"band_low_pm_per_n", "band_high_pm_per_n"} <= set(t.columns)
    assert t["sensitivity_pm_per_n"].dtype.kind == "f"
    assert list(t.columns).index("sensitivity_pm_per_n") < list(t.columns).index("model_description")


def test_the_reconstruction_shows_its_loads():
    m = fbgforge.sensing_matrix(ARRAY)
    x = np.zeros((3, 8))
    x[:, 1] = 100.0
    r = fbgforge.reconstruct(m, x @ m.sensitivity_pm_per_g.T, gratings="matrix")
    text = repr(r)
    assert text.startswith("<Reconstruction: 3 frames × 8 cells")
    row = next(l for l in text.splitlines() if l.strip().startswith("0 "))
    assert "100" in row.split()[2], row


def test_other_results_show_their_scalars():
    s = repr(fbgforge.synth_log(MODULE, "out/py-repr", k_pm_per_n=8.0))
    assert s.startswith("<SynthLog: log=out/py-repr/log.txt, force=out/py-repr/force.csv"), s


def test_design_replace_takes_a_plain_keyword():
    d = fbgforge.shipped_design("clip-on-34mm")
    assert d.replace(cap_wall_mm=1.2).to_dict()["module"]["cap_wall_mm"] == 1.2
    assert d.replace(cap_wall_mm=1.2) == d.replace(**{"module.cap_wall_mm": 1.2})
    with pytest.raises(KeyError, match="no field of that name"):
        d.replace(no_such_field_mm=1.0)
