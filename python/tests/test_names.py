"""Shifts reach the gratings by name, never by position: a DataFrame in any column
order reconstructs as the command line does; an unnamed array is refused unless its
columns are named or stated to be in the matrix's order; a mismatch is refused."""

import numpy as np
import pandas as pd
import pytest

import fbgforge
from conftest import ARRAY, FIXTURES

SHIFTS = FIXTURES / "array" / "paper-model-shifts.csv"
# The fixture's shifts were made with the paper's kernel, so the truth is recovered with
# the kernel's matrix (the design's default model is the sheet model, docs/array.md §12).
KERNEL = fbgforge.load_design(ARRAY).replace({"array.model": "kernel"})
# The fixture's four frames (its comment line): B=100; A=200 + G=50; C=100 + E=50 + H=200; none.
TRUTH = np.zeros((4, 8))
TRUTH[0, 1] = 100.0
TRUTH[1, [0, 6]] = [200.0, 50.0]
TRUTH[2, [2, 4, 7]] = [100.0, 50.0, 200.0]


def read_fixture():
    return pd.read_csv(SHIFTS, comment="#")


def test_a_dataframe_with_the_columns_in_another_order_reconstructs_100_g_on_b():
    df = read_fixture()
    assert list(df.columns)[:3] == ["time_s", "fbg6", "fbg1"]  # not the matrix's order
    r = fbgforge.reconstruct(KERNEL, df)
    assert r.loads_g.shape == (4, 8) and r.cells == list("ABCDEFGH")
    assert np.allclose(r.loads_g, TRUTH, atol=0.5), r.loads_g
    assert r.loads_g[0, 1] == pytest.approx(100.0, abs=0.5)
    assert np.array_equal(r.time_s, df["time_s"].to_numpy())
    # Any other order of the same columns gives the same loads.
    shuffled = df[["fbg3", "fbg5", "time_s", "fbg1", "fbg6", "fbg2", "fbg4"]]
    assert np.allclose(fbgforge.reconstruct(KERNEL, shuffled).loads_g, r.loads_g, atol=1e-9)
    # The table keeps the DataFrame's index and names the cells.
    t = r.to_pandas()
    assert list(t.columns[:8]) == list("ABCDEFGH") and t.index.equals(df.index)
    assert t.loc[0, "B"] == pytest.approx(100.0, abs=0.5)


def test_the_dataframe_gives_what_the_command_line_gives_on_the_same_file(cli, tmp_path):
    out = tmp_path / "loads.csv"
    cli("reconstruct", "--design", ARRAY, "--shifts", SHIFTS, "--out", out)
    want = pd.read_csv(out, comment="#")
    got = fbgforge.reconstruct(ARRAY, read_fixture()).to_pandas()
    assert np.allclose(got[list("ABCDEFGH")].to_numpy(), want[list("ABCDEFGH")].to_numpy(), atol=5e-4)  # the CSV holds 3 decimals


def test_an_array_without_names_is_refused_unless_its_columns_are_named():
    df = read_fixture()
    bare = df.drop(columns="time_s").to_numpy()  # columns fbg6, fbg1, ... lost
    with pytest.raises(fbgforge.InputError, match="shifts without names") as e:
        fbgforge.reconstruct(ARRAY, bare)
    assert isinstance(e.value, ValueError)
    # Named by gratings=: right.
    named = fbgforge.reconstruct(KERNEL, bare, gratings=["fbg6", "fbg1", "fbg2", "fbg3", "fbg4", "fbg5"])
    assert np.allclose(named.loads_g, TRUTH, atol=0.5)
    # Stated to be in the matrix's order: taken at its word (this file is not, so the
    # loads are not the truth: the caller said so), and the count is checked.
    as_stated = fbgforge.reconstruct(ARRAY, bare, gratings="matrix")
    assert not np.allclose(as_stated.loads_g, TRUTH, atol=0.5)
    with pytest.raises(fbgforge.InputError, match="gratings='matrix' states one column per grating"):
        fbgforge.reconstruct(ARRAY, bare[:, :5], gratings="matrix")


@pytest.mark.parametrize(
    "columns, needle",
    [
        (["fbg1", "fbg2", "fbg3", "fbg4", "fbg5", "fbg7"], "column `fbg7` is not a grating"),
        (["fbg1", "fbg2", "fbg3", "fbg4", "fbg5"], "no column for grating `fbg6`"),
        (["fbg1", "fbg2", "fbg3", "fbg4", "fbg5", "fbg5"], "column `fbg5` appears twice"),
    ],
)
def test_a_mismatch_of_names_is_refused(columns, needle):
    df = pd.DataFrame(np.zeros((2, len(columns))), columns=columns)
    with pytest.raises(fbgforge.InputError, match=needle):
        fbgforge.reconstruct(ARRAY, df)
    with pytest.raises(fbgforge.InputError, match=needle):
        fbgforge.reconstruct(ARRAY, np.zeros((2, len(columns))), gratings=columns)


def test_a_series_a_dict_and_a_measured_matrix_are_matched_by_name():
    m = fbgforge.sensing_matrix(ARRAY)
    y = dict(zip(m.gratings, m.sensitivity_pm_per_g @ TRUTH[2]))
    reversed_y = dict(reversed(list(y.items())))
    one = fbgforge.reconstruct(m, pd.Series(reversed_y))
    assert one.loads_g.shape == (8,) and np.allclose(one.loads_g, TRUTH[2], atol=0.5)
    assert np.allclose(fbgforge.reconstruct(m, reversed_y).loads_g, TRUTH[2], atol=0.5)
    # A matrix under other names: the shifts must use those names.
    renamed = fbgforge.SensingMatrix(m.sensitivity_pm_per_g, gratings=[f"g{i}" for i in range(6)], cells=m.cells)
    with pytest.raises(fbgforge.InputError, match="not a grating of the sensing matrix"):
        fbgforge.reconstruct(renamed, pd.Series(y))
    got = fbgforge.reconstruct(renamed, {f"g{i}": v for i, v in enumerate(y.values())})
    assert np.allclose(got.loads_g, TRUTH[2], atol=0.5)
    with pytest.raises(fbgforge.InputError, match="gratings= is for arrays"):
        fbgforge.reconstruct(m, pd.Series(y), gratings="matrix")
