#!/usr/bin/env python3
"""fbgforge's reconstruction methods against SciPy and scikit-learn on the same frames,
mean and median time per frame side by side, in one run (docs/array.md §10.8).

1. Runs the scaling study (`fbgforge-studies reconstruct --part scaling --seed S`), which
   draws the arrays' frames from seed S, tunes and times every fbgforge method and the
   default choice, and writes the frames (`scaling-frames/n<cells>/`, validation frames
   in `val/`).
2. Runs the peers (../shared/peers/recon/peers.py's classes) on those frames, one frame
   per call, one thread, timing every call:
   - `nnls`: scipy.optimize.nnls, clipped to the ceiling (fbgforge `nnls`);
   - `lasso`: scikit-learn Lasso(positive=True, precompute=True) on the normalised
     matrix, alpha = λ/m with fbgforge's tuned λ (the same objective as fbgforge
     `lasso`); its batched fit (all frames in one call) is timed as well;
   - `omp`: scikit-learn OrthogonalMatchingPursuit, its tol tuned on the validation
     frames (another stopping rule than fbgforge's `omp`, so not the same objective);
   - `enum`: scipy lsq_linear(bvls) over every support of ≤ 4 loads, screened, with
     fbgforge's tuned λ (the objective of fbgforge `support` / `bnb`), where the
     enumeration is small enough (≤ 16 × 64; a subset of frames at 16 × 64).
3. Writes `peers.csv`, `peers.json` and `side_by_side.md` (fbgforge's rows from the
   study's `scaling.csv` next to the peers').

usage: scaling_vs_peers.py [--seed S] [--out DIR] [--peers-src DIR] [--studies-bin BIN]
                           [--enum-frames K] [--skip-study]
Needs numpy, scipy and scikit-learn (pip install numpy scipy scikit-learn).
"""
import argparse, csv, json, os, platform, subprocess, sys, time
import numpy as np

# One thread for the peers, as fbgforge's timings (BLAS would otherwise use every core).
for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(var, "1")

ULIMIT = 250.0
SIZES = [(6, 8), (8, 16), (12, 32), (16, 64), (24, 128), (32, 256)]


def read_matrix(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    return np.array([[float(v) for v in r[1:]] for r in rows[1:]])


def read_table(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    return np.array([[float(v) for v in r] for r in rows[1:]])


def load_frames(d):
    Y = read_table(os.path.join(d, "shifts.csv"))
    X = read_table(os.path.join(d, "truth.csv"))
    k = read_table(os.path.join(d, "loads_per_frame.csv"))[:, 0].astype(int)
    return X, Y, k


def snr_db(x, x0):
    num = np.linalg.norm(x0, axis=-1)
    den = np.linalg.norm(x - x0, axis=-1)
    with np.errstate(divide="ignore"):
        s = 20 * np.log10(num / np.maximum(den, 1e-300))
    return np.minimum(np.where(np.isfinite(s), s, -300.0), 300.0)


def rr_by_k(Xh, X0, ks):
    s = snr_db(Xh, X0)
    return [100.0 * float(np.mean(s[ks == k] >= 12.0)) for k in (1, 2, 3, 4) if np.any(ks == k)]


def time_each(solve, Y):
    out, times = [], []
    for y in Y:
        t0 = time.perf_counter()
        x = solve(y)
        times.append(time.perf_counter() - t0)
        out.append(x)
    t = 1e6 * np.array(times)
    return np.array(out), float(np.median(t)), float(np.mean(t))


def same_answers_as_bnb(binary, d, A, Y, Xh, lam):
    """Frames on which `fbgforge reconstruct --method bnb` (same λ, ceiling and load cap,
    every grating kept) returns the enumeration's loads to the file's 1 mg."""
    m = A.shape[0]
    shifts = os.path.join(d, "enum-shifts.csv")
    loads = os.path.join(d, "enum-bnb-loads.csv")
    with open(shifts, "w") as f:
        f.write(",".join(f"g{i:02d}" for i in range(m)) + "\n")
        for row in Y:
            f.write(",".join(f"{v:.9e}" for v in row) + "\n")
    subprocess.run([binary, "reconstruct", "--matrix", os.path.join(d, "A.csv"), "--shifts", shifts,
                    "--method", "bnb", "--penalty", str(lam), "--max-loads", "4", "--ulimit-g", str(ULIMIT),
                    "--keep-all-gratings", "--out", loads, "--json"], check=True, stdout=subprocess.DEVNULL)
    with open(loads) as f:
        rows = list(csv.reader(f))
    cells = [j for j, name in enumerate(rows[0]) if name.startswith("c")]
    Xb = np.array([[float(r[j]) for j in cells] for r in rows[1:]])
    # The loads file has 1 mg resolution (3 decimals).
    return int(np.sum(np.max(np.abs(Xb - Xh), axis=1) <= 1e-3))


def fbgforge_rows(path):
    rows = {}
    with open(path) as f:
        for r in csv.DictReader(f):
            rows.setdefault((int(r["cells"]), r["method"]), {})[int(r["loads"])] = r
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=2)
    ap.add_argument("--out", default="out/scaling-vs-peers")
    ap.add_argument("--peers-src", default=os.environ.get("PEERS_SRC", "../shared/peers/recon"))
    ap.add_argument("--studies-bin", default="target/release/fbgforge-studies")
    ap.add_argument("--fbgforge-bin", default="target/release/fbgforge",
                    help="answers of `fbgforge reconstruct --method bnb` on the enumeration's frames are compared with it")
    ap.add_argument("--enum-frames", type=int, default=25,
                    help="frames per load count for the enumeration at 16 x 64 (it takes ~0.5 s a frame)")
    ap.add_argument("--skip-study", action="store_true", help="reuse the study's files in --out")
    a = ap.parse_args()
    sys.path.insert(0, os.path.abspath(a.peers_src))
    try:
        import scipy, sklearn
        from peers import NNLS, SkLasso, SkOMP, LsqEnum  # noqa: E402
    except ImportError as e:
        sys.exit(f"error: the peers need numpy, scipy and scikit-learn, and {a.peers_src}/peers.py: {e}")
    os.makedirs(a.out, exist_ok=True)
    load_before = os.getloadavg()
    if not a.skip_study:
        cmd = [a.studies_bin, "reconstruct", "--part", "scaling", "--seed", str(a.seed), "--out", a.out]
        print("running", " ".join(cmd), flush=True)
        subprocess.run(cmd, check=True)
    ours = fbgforge_rows(os.path.join(a.out, "scaling.csv"))
    recs = []
    for m, n in SIZES:
        d = os.path.join(a.out, "scaling-frames", f"n{n}")
        A = read_matrix(os.path.join(d, "A.csv"))
        X0, Y, ks = load_frames(d)
        Xv, Yv, _ = load_frames(os.path.join(d, "val"))
        lam_lasso = float(ours[(n, "lasso")][0]["penalty"])
        lam_l0 = float(ours[(n, "bnb")][0]["penalty"])

        def record(method, peer, ours_name, Xh, med, mean, frames_idx, **extra):
            rec = dict(m=m, n=n, method=method, peer=peer, frames=int(len(frames_idx)),
                       rr_pct=rr_by_k(Xh, X0[frames_idx], ks[frames_idx]),
                       mean_snr_db=float(np.mean(snr_db(Xh, X0[frames_idx]))),
                       median_us=med, mean_us=mean, fbgforge=ours_name, **extra)
            recs.append(rec)
            print(json.dumps({k: (round(v, 2) if isinstance(v, float) else v) for k, v in rec.items()}), flush=True)

        allf = np.arange(len(Y))
        est = NNLS(A)
        Xh, med, mean = time_each(est.solve, Y)
        record("nnls", "scipy.optimize.nnls", "nnls", Xh, med, mean, allf)
        est = SkLasso(A)
        est.set(lam_lasso)
        Xh, med, mean = time_each(est.solve, Y)
        t0 = time.perf_counter()
        est.solve_batch(Y)
        batched = 1e6 * (time.perf_counter() - t0) / len(Y)
        record("lasso", "sklearn Lasso(positive)", "lasso", Xh, med, mean, allf,
               penalty=lam_lasso, batched_mean_us=batched)
        est = SkOMP(A)
        tuned = est.tune(Xv, Yv)
        Xh, med, mean = time_each(est.solve, Y)
        record("omp", "sklearn OrthogonalMatchingPursuit (tol tuned)", "omp", Xh, med, mean, allf,
               penalty=tuned["penalty"])
        if n <= 64:
            est = LsqEnum(A)
            est.lam = lam_l0
            if n == 64:
                idx = np.concatenate([np.flatnonzero(ks == k)[: a.enum_frames] for k in (1, 2, 3, 4)])
            else:
                idx = allf
            Xh, med, mean = time_each(est.solve, Y[idx])
            same = same_answers_as_bnb(a.fbgforge_bin, d, A, Y[idx], Xh, lam_l0)
            record("enum", "scipy lsq_linear over supports of <= 4 loads (screened)", "bnb", Xh, med, mean,
                   idx, penalty=lam_l0, identical_to_bnb=same)
    load_after = os.getloadavg()
    env = dict(seed=a.seed, python=platform.python_version(), numpy=np.__version__, scipy=scipy.__version__,
               sklearn=sklearn.__version__, load_average_before=load_before[0], load_average_after=load_after[0],
               date=time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()))
    with open(os.path.join(a.out, "peers.json"), "w") as f:
        json.dump(dict(environment=env, rows=recs), f, indent=1)
    with open(os.path.join(a.out, "peers.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["gratings", "cells", "method", "peer", "frames", "rr_pct_1_2_3_4", "mean_snr_db",
                    "median_us_per_frame", "mean_us_per_frame"])
        for r in recs:
            w.writerow([r["m"], r["n"], r["method"], r["peer"], r["frames"], "/".join(f"{v:.1f}" for v in r["rr_pct"]),
                        f"{r['mean_snr_db']:.2f}", f"{r['median_us']:.2f}", f"{r['mean_us']:.2f}"])
    lines = [f"Seed {a.seed}; {env['date']}; load average {load_before[0]:.1f} before, {load_after[0]:.1f} after; "
             f"numpy {np.__version__}, SciPy {scipy.__version__}, scikit-learn {sklearn.__version__}; "
             "µs per frame on one thread, median / mean; RR % for 1/2/3/4 loads.", "",
             "| m×n | method | fbgforge RR % | fbgforge µs median / mean | peer | peer RR % | peer µs median / mean | mean ratio peer/fbgforge |",
             "|---|---|---|---|---|---|---|---|"]
    for r in recs:
        o = ours.get((r["n"], r["fbgforge"]))
        rr_o = "/".join(f"{float(o[k]['rr_pct']):.1f}" for k in (1, 2, 3, 4)) if o else "–"
        med_o, mean_o = (float(o[0]["median_us_per_frame"]), float(o[0]["mean_us_per_frame"])) if o else (np.nan, np.nan)
        peer = r["peer"] + (f", batched {r['batched_mean_us']:.0f} µs mean" if "batched_mean_us" in r else "")
        if r["frames"] < len(ks):
            peer += f" ({r['frames']} frames)"
        if "identical_to_bnb" in r:
            peer += f"; `bnb` gives the same loads on {r['identical_to_bnb']} of {r['frames']}"
        lines.append(f"| {r['m']}×{r['n']} | {r['fbgforge']} | {rr_o} | {med_o:.1f} / {mean_o:.1f} | {peer} | "
                     f"{'/'.join(f'{v:.1f}' for v in r['rr_pct'])} | {r['median_us']:.1f} / {r['mean_us']:.1f} | "
                     f"{r['mean_us'] / mean_o:.2f} |")
    lines += ["", "The default choice (this run):", "",
              "| m×n | picked | RR % | µs median / mean |", "|---|---|---|---|"]
    for m, n in SIZES:
        for (nn, meth), o in sorted(ours.items()):
            if nn == n and meth.startswith("default"):
                rr = "/".join(f"{float(o[k]['rr_pct']):.1f}" for k in (1, 2, 3, 4))
                lines.append(f"| {m}×{n} | {meth} | {rr} | {float(o[0]['median_us_per_frame']):.1f} / "
                             f"{float(o[0]['mean_us_per_frame']):.1f} |")
    with open(os.path.join(a.out, "side_by_side.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
