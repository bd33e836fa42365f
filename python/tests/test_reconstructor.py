"""fbgforge.Reconstructor: built once, per frame and per batch give the same answers;
the settings the one-shot call lacked (common mode, matrix uncertainty, gratings kept)
reach the library; absurd shifts are flagged, never read as zero loads."""

import numpy as np
import pytest

import fbgforge
from conftest import ARRAY

M = fbgforge.sensing_matrix(fbgforge.load_design(ARRAY).replace({"array.model": "kernel"}))


def loads(*pairs):
    x = np.zeros(8)
    for cell, g in pairs:
        x["ABCDEFGH".index(cell)] = g
    return x


def test_per_frame_and_batch_give_the_same_loads_and_flags():
    rec = fbgforge.Reconstructor(M, method="bnb")
    rng = np.random.default_rng(35)
    truth = [loads(("B", 100.0)), loads(("A", 200.0), ("G", 50.0)), loads(("C", 120.0))]
    y = np.array([M.sensitivity_pm_per_g @ x for x in truth]) + 0.1 * rng.standard_normal((3, 6))
    batch, per_frame = rec.frames(y)
    for row, want, x in zip(y, batch, truth):
        got, flags = rec(row)
        assert np.allclose(got, want, atol=1e-12)
        assert np.allclose(got, x, atol=5.0), got
    assert [list(f) for f in per_frame["flags"]] == [rec(row)[1] for row in y]


def test_the_default_choice_is_made_once_from_the_matrix():
    a = fbgforge.Reconstructor(M)
    b = fbgforge.Reconstructor(M)
    assert a.method == b.method and a.setup["reason"] == b.setup["reason"]
    assert a.setup["choice"]["probed_on_data"] is False


def test_a_common_offset_is_fitted_when_asked():
    y = M.sensitivity_pm_per_g @ loads(("B", 100.0)) + 2.0  # 2 pm on every grating
    plain, _ = fbgforge.Reconstructor(M, method="bnb")(y)
    cm, flags = fbgforge.Reconstructor(M, method="bnb", common_mode=True)(y)
    assert abs(cm[1] - 100.0) < abs(plain[1] - 100.0) and abs(cm[1] - 100.0) < 5.0, (plain, cm)


def test_gratings_kept_leave_a_dead_one_out():
    x = loads(("B", 100.0))
    y = M.sensitivity_pm_per_g @ x
    y[2] = 0.0  # fbg3 reads nothing
    keep = [g for g in M.gratings if g != M.gratings[2]]
    rec = fbgforge.Reconstructor(M, method="bnb", keep=keep)
    got, _ = rec(y)
    assert np.allclose(got, x, atol=1.0) and rec.kept == keep
    with pytest.raises(fbgforge.InputError, match="keep names"):
        fbgforge.Reconstructor(M, keep=["fbg9"])


@pytest.mark.parametrize("shift", [1e155, 1e300, np.inf, np.nan])
def test_absurd_shifts_are_flagged_unusable_never_zero_loads(shift):
    y = M.sensitivity_pm_per_g @ loads(("B", 100.0))
    y[0] = shift
    for method in (None, "bnb", "nnls", "lasso"):
        got, flags = fbgforge.Reconstructor(M, method=method)(y)
        assert "unusable" in flags and np.all(np.isnan(got)), (method, got, flags)
