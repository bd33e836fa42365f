"""The peer comparison script of docs/array.md §10.8 (studies/peers/scaling_vs_peers.py):
its own arithmetic and its frame-by-frame check that `bnb` returns the enumeration's
loads (the peers themselves need SciPy and scikit-learn, which the tests do not)."""

import importlib.util

import numpy as np
import pytest

from conftest import ROOT

spec = importlib.util.spec_from_file_location("scaling_vs_peers", ROOT / "studies" / "peers" / "scaling_vs_peers.py")
svp = importlib.util.module_from_spec(spec)
spec.loader.exec_module(svp)


def test_rr_counts_frames_at_or_above_12_db_per_load_count():
    x0 = np.array([[100.0, 0.0], [100.0, 0.0], [50.0, 50.0], [50.0, 50.0]])
    # Errors giving SNRs of 20 dB, 6 dB (frames of 1 load) and 40 dB, 12.04 dB (2 loads).
    xh = x0.copy()
    xh[0, 1] = 10.0
    xh[1, 1] = 50.0
    xh[2, 0] += np.linalg.norm(x0[2]) / 100.0
    xh[3, 0] += np.linalg.norm(x0[3]) / 4.0
    ks = np.array([1, 1, 2, 2])
    assert svp.snr_db(xh, x0) == pytest.approx([20.0, 20 * np.log10(2), 40.0, 20 * np.log10(4)])
    assert svp.rr_by_k(xh, x0, ks) == [50.0, 100.0]


def test_same_answers_as_bnb_counts_only_frames_with_the_same_loads(cli, tmp_path):
    # A well-conditioned 4 × 3 array and exact one-load frames: bnb recovers them exactly.
    a = np.array([[4.0, 1.0, 0.5], [1.0, 4.0, 1.0], [0.5, 1.0, 4.0], [2.0, 2.0, 2.0]])
    with open(tmp_path / "A.csv", "w") as f:
        f.write("grating,c000,c001,c002\n")
        for i, row in enumerate(a):
            f.write(f"g{i:02d}," + ",".join(str(v) for v in row) + "\n")
    truth = np.array([[100.0, 0.0, 0.0], [0.0, 50.0, 0.0], [0.0, 0.0, 200.0]])
    y = truth @ a.T
    assert svp.same_answers_as_bnb(cli.exe, str(tmp_path), a, y, truth, 1.0) == 3
    wrong = truth.copy()
    wrong[1, 1] += 1.0  # one frame off by 1 g
    assert svp.same_answers_as_bnb(cli.exe, str(tmp_path), a, y, wrong, 1.0) == 2
