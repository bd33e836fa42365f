"""Per-frame cost of fbgforge.Reconstructor against its batch cost per frame (issue 35).

    python studies/peers/reconstructor_per_frame.py [--frames N] [--repeats R]

For the paper's 6 × 8 array and a 16 × 64 grid (synthetic matrices, seeded), the same
frames are reconstructed once as a batch (`frames`) and once a call per frame
(`__call__`), each R times; the table gives the median µs per frame of both and their
ratio (the goal: per-frame ≤ 1.5 × batch). A benchmark, not a test: the test suite
checks only the answers agree (python/tests/test_reconstructor.py).
"""

import argparse
import time

import numpy as np

import fbgforge


def paper_matrix():
    return fbgforge.sensing_matrix("designs/tactile-array-60x80.toml")


def grid_matrix(m, n, seed):
    """A smooth random m × n matrix, pm/g: each grating sees cells near it."""
    rng = np.random.default_rng(seed)
    gx = np.linspace(0.0, 1.0, m)
    cx = np.sort(rng.uniform(0.0, 1.0, n))
    d = np.abs(gx[:, None] - cx[None, :])
    return 0.05 * np.exp(-d / 0.15) * (1.0 + 0.1 * rng.standard_normal((m, n)))


def frames(a, count, seed, max_loads=4, resolution_pm=0.5):
    rng = np.random.default_rng(seed)
    m, n = a.shape
    x = np.zeros((count, n))
    for f in range(count):
        k = 1 + f % max_loads
        cells = rng.choice(n, size=k, replace=False)
        x[f, cells] = rng.uniform(30.0, 240.0, size=k)
    return x @ a.T + resolution_pm * rng.standard_normal((count, m))


def per_frame_and_batch_us(rec, y, repeats):
    """Median µs per frame of a batch call and of one call per frame."""
    batch, single = [], []
    for _ in range(repeats):
        t = time.perf_counter()
        rec.frames(y)
        batch.append((time.perf_counter() - t) / len(y))
        t = time.perf_counter()
        for row in y:
            rec(row)
        single.append((time.perf_counter() - t) / len(y))
    return 1e6 * float(np.median(single)), 1e6 * float(np.median(batch))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=400)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    cases = [("6 × 8 (paper)", paper_matrix().sensitivity_pm_per_g), ("16 × 64 (grid)", grid_matrix(16, 64, 35))]
    print("| array | method | per frame µs | batch µs/frame | ratio |")
    print("|---|---|---|---|---|")
    for name, a in cases:
        y = frames(a, args.frames, 3500)
        for method in (None, "bnb", "lasso"):
            # Batches below the parallel threshold: the comparison is one thread to one.
            rec = fbgforge.Reconstructor(a, ulimit_g=250.0, method=method)
            single, batch = per_frame_and_batch_us(rec, y[:60], args.repeats)
            label = rec.method + (" (default)" if method is None else "")
            print(f"| {name} | {label} | {single:.1f} | {batch:.1f} | {single / batch:.2f} |")


if __name__ == "__main__":
    main()
