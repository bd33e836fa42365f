//! The `reconstruct` study's scaling part (`-- reconstruct --part scaling`): time per
//! frame and RR per method against the array's size, from 6 × 8 to 32 × 256 cells,
//! with the automatic default choice at each size.
//!
//! Arrays: `kernel::fiber_grid_layout` (gratings on parallel fibers under a grid of
//! 20 × 30 mm cells) with Table 1's power law and a 3 mm core
//! (`DistanceKernel::table1_power_law(3.0)`). Frames (as in issue 14): 1 to 4 loads
//! on distinct random cells, masses 50/100/200 g, each reading off by 3 % (Gaussian,
//! relative) and 0.25 pm (Gaussian); a separate validation set tunes each penalised
//! method's weight (RR first, then mean SNR). The methods see the true matrix. The
//! frames are written as CSV (`scaling-frames/n<cells>/`, the validation frames in its
//! `val/`) so that other tools can be tuned and measured on the same frames:
//! `studies/peers/scaling_vs_peers.py` runs this study and the SciPy / scikit-learn
//! peers in one go and writes the side-by-side table of docs/array.md §10.8.
//!
//! Times are single-thread wall times of one `reconstruct` call (median over the
//! frames), set-up (building the method for the matrix) apart; the default method's
//! stream throughput on every thread is measured as well.

use anyhow::Result;
use fbgforge::array::choice::{default_choice, DEFAULT_BUDGET_US};
use fbgforge::array::kernel::{fiber_grid_layout, matrix_from_positions, DistanceKernel};
use fbgforge::array::methods::{
    build, reconstruct_frames, Method, MethodSettings, ReadingSettings,
};
use fbgforge::array::problem::{SensingProblem, PAPER_MIN_LOAD_G};
use fbgforge::array::protocol::{snr_db, RECOVERY_THRESHOLD_DB};
use fbgforge::output::{ensure_dir, write_csv, write_json};
use fbgforge::plot::{Chart, Mark, Series};
use fbgforge::progress::Progress;
use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

/// Array sizes: (gratings, cells, cells_x, cells_y, fibers, gratings per fiber).
pub const SIZES: [(usize, usize, usize, usize, usize, usize); 6] = [
    (6, 8, 4, 2, 2, 3),
    (8, 16, 4, 4, 2, 4),
    (12, 32, 8, 4, 2, 6),
    (16, 64, 8, 8, 4, 4),
    (24, 128, 16, 8, 4, 6),
    (32, 256, 16, 16, 8, 4),
];

/// Relative (3 %) and absolute (0.25 pm) reading noise of the scaling frames.
const NOISE_REL: f64 = 0.03;
const NOISE_PM: f64 = 0.25;
const MASSES_G: [f64; 3] = [50.0, 100.0, 200.0];
const ULIMIT_G: f64 = 250.0;

/// One row of the scaling table: one method at one size, over one load count (0 =
/// all frames).
#[derive(Debug, Clone, Serialize)]
pub struct ScalingRow {
    /// Gratings.
    pub m: usize,
    /// Cells.
    pub n: usize,
    /// Method (for the default: `default → <picked>`).
    pub method: String,
    /// Penalty used (tuned on the validation frames where the method has one).
    pub penalty: f64,
    /// Loads per frame (0: all frames).
    pub loads: usize,
    /// Frames.
    pub frames: usize,
    /// RR, %.
    pub rr_pct: f64,
    /// Mean SNR, dB.
    pub mean_snr_db: f64,
    /// Median time per frame, µs, one thread.
    pub median_us: f64,
    /// Mean time per frame, µs, one thread.
    pub mean_us: f64,
    /// Set-up (building the method), ms.
    pub setup_ms: f64,
    /// Frames reported not converged (bnb: stopped at its node budget).
    pub not_converged: usize,
    /// Frames reported converged whose objective is above the truth's (must be 0).
    pub converged_but_worse_than_truth: usize,
    /// Frames answered with all-zero loads.
    pub all_zero: usize,
}

/// Test or validation frames of one size.
struct Frames {
    loads: Vec<usize>,
    truth_g: Vec<Vec<f64>>,
    shifts_pm: Vec<Vec<f64>>,
}

fn frames(a: &DMatrix<f64>, per_load: usize, rng: &mut ChaCha8Rng) -> Frames {
    let (m, n) = a.shape();
    let mut f = Frames {
        loads: Vec::new(),
        truth_g: Vec::new(),
        shifts_pm: Vec::new(),
    };
    for k in 1..=4usize {
        for _ in 0..per_load {
            let (_, x) = random_loads(n, k, rng);
            let y: Vec<f64> = (0..m)
                .map(|i| {
                    let clean: f64 = (0..n).map(|j| a[(i, j)] * x[j]).sum();
                    let (e1, e2) = (normal(rng), normal(rng));
                    clean * (1.0 + NOISE_REL * e1) + NOISE_PM * e2
                })
                .collect();
            f.loads.push(k);
            f.truth_g.push(x);
            f.shifts_pm.push(y);
        }
    }
    f
}

/// The scaling study's array of `cells` cells (one of [`SIZES`]) as a problem, and its
/// test frames for `seed` (the study's default seed is 1): (loads per frame, true
/// loads g, shifts pm), `per_load` frames per load count. For calibration runs
/// (`studies/examples/reconstruct_cost.rs`) on exactly the study's frames.
#[allow(clippy::type_complexity)]
pub fn scaling_problem_and_frames(
    cells: usize,
    per_load: usize,
    seed: u64,
) -> Result<(SensingProblem, Vec<usize>, Vec<Vec<f64>>, Vec<Vec<f64>>)> {
    let &(_, n, cx, cy, nf, gpf) = SIZES
        .iter()
        .find(|s| s.1 == cells)
        .ok_or_else(|| anyhow::anyhow!("no scaling array with {cells} cells"))?;
    let (cells, gratings) = fiber_grid_layout(cx, cy, nf, gpf);
    let a = matrix_from_positions(&cells, &gratings, &DistanceKernel::table1_power_law(3.0));
    let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_mul(1000) + n as u64);
    let f = frames(&a, per_load, &mut rng);
    let problem = SensingProblem::new(a, ULIMIT_G, true)?.with_min_load_g(PAPER_MIN_LOAD_G)?;
    Ok((problem, f.loads, f.truth_g, f.shifts_pm))
}

/// A standard normal draw (Box–Muller).
/// `k` loads on distinct random cells of `n`, each 50, 100 or 200 g: the loaded
/// cells and the load vector, g (the draws of the scaling and fault studies).
pub fn random_loads(n: usize, k: usize, rng: &mut ChaCha8Rng) -> (Vec<usize>, Vec<f64>) {
    let mut cells: Vec<usize> = (0..n).collect();
    for i in 0..k {
        let j = rng.random_range(i..n);
        cells.swap(i, j);
    }
    cells.truncate(k);
    let mut x = vec![0.0; n];
    for &c in &cells {
        x[c] = MASSES_G[rng.random_range(0..MASSES_G.len())];
    }
    (cells, x)
}

fn normal(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = 1.0 - rng.random::<f64>();
    let u2: f64 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

/// Run one built method over the frames, frame by frame on one thread.
fn evaluate(
    r: &dyn fbgforge::array::methods::Reconstructor,
    f: &Frames,
) -> Vec<(usize, f64, f64, bool, bool, bool)> {
    f.shifts_pm
        .iter()
        .zip(&f.truth_g)
        .zip(&f.loads)
        .map(|((y, x0), &k)| {
            let t = Instant::now();
            let rec = r.reconstruct(y);
            let us = 1e6 * t.elapsed().as_secs_f64();
            let snr = snr_db(x0, &rec.loads_g);
            let worse = rec.converged
                && match (r.objective(y, &rec.loads_g), r.objective(y, x0)) {
                    (Some(got), Some(truth)) => got > truth + 1e-6 * (1.0 + truth.abs()),
                    _ => false,
                };
            let zero = rec.loads_g.iter().all(|&v| v == 0.0);
            (k, snr, us, rec.converged, worse, zero)
        })
        .collect()
}

fn rows_of(
    m: usize,
    n: usize,
    method: &str,
    penalty: f64,
    setup_ms: f64,
    res: &[(usize, f64, f64, bool, bool, bool)],
) -> Vec<ScalingRow> {
    (0..=4usize)
        .filter_map(|k| {
            let sel: Vec<_> = res.iter().filter(|r| k == 0 || r.0 == k).collect();
            if sel.is_empty() {
                return None;
            }
            let mut t: Vec<f64> = sel.iter().map(|r| r.2).collect();
            t.sort_by(f64::total_cmp);
            let nf = sel.len() as f64;
            Some(ScalingRow {
                m,
                n,
                method: method.to_string(),
                penalty,
                loads: k,
                frames: sel.len(),
                rr_pct: 100.0 * sel.iter().filter(|r| r.1 >= RECOVERY_THRESHOLD_DB).count() as f64
                    / nf,
                mean_snr_db: sel.iter().map(|r| r.1).sum::<f64>() / nf,
                median_us: t[t.len() / 2],
                mean_us: t.iter().sum::<f64>() / nf,
                setup_ms,
                not_converged: sel.iter().filter(|r| !r.3).count(),
                converged_but_worse_than_truth: sel.iter().filter(|r| r.4).count(),
                all_zero: sel.iter().filter(|r| r.5).count(),
            })
        })
        .collect()
}

/// RR first, then mean SNR, over the validation frames.
fn tune(problem: &SensingProblem, base: MethodSettings, val: &Frames) -> f64 {
    let Some(start) = base.penalty() else {
        return 0.0;
    };
    let mut best = (f64::NEG_INFINITY, start);
    for pen in base.method().penalty_grid().into_iter().step_by(2) {
        let Ok(r) = build(problem, &base.with_penalty(pen)) else {
            continue;
        };
        let res = evaluate(r.as_ref(), val);
        let nf = res.len().max(1) as f64;
        let rr = res.iter().filter(|r| r.1 >= RECOVERY_THRESHOLD_DB).count() as f64 / nf;
        let snr = res.iter().map(|r| r.1).sum::<f64>() / nf;
        let score = 1e3 * rr + snr;
        if score > best.0 {
            best = (score, pen);
        }
    }
    best.1
}

fn write_frames(dir: &Path, a: &DMatrix<f64>, f: &Frames) -> Result<()> {
    ensure_dir(dir)?;
    let (m, n) = a.shape();
    let cells: Vec<String> = (0..n).map(|j| format!("c{j:03}")).collect();
    let gratings: Vec<String> = (0..m).map(|i| format!("g{i:02}")).collect();
    let mut header = vec!["grating"];
    header.extend(cells.iter().map(String::as_str));
    let rows: Vec<Vec<String>> = (0..m)
        .map(|i| {
            let mut r = vec![gratings[i].clone()];
            r.extend((0..n).map(|j| format!("{:.9e}", a[(i, j)])));
            r
        })
        .collect();
    write_csv(&dir.join("A.csv"), &header, &rows)?;
    let gh: Vec<&str> = gratings.iter().map(String::as_str).collect();
    let ch: Vec<&str> = cells.iter().map(String::as_str).collect();
    let mut ys = Vec::new();
    let mut xs = Vec::new();
    for (y, x) in f.shifts_pm.iter().zip(&f.truth_g) {
        ys.push(y.iter().map(|v| format!("{v:.9e}")).collect());
        xs.push(x.iter().map(|v| format!("{v}")).collect());
    }
    write_csv(&dir.join("shifts.csv"), &gh, &ys)?;
    write_csv(&dir.join("truth.csv"), &ch, &xs)?;
    let loads: Vec<Vec<String>> = f.loads.iter().map(|k| vec![k.to_string()]).collect();
    write_csv(&dir.join("loads_per_frame.csv"), &["loads"], &loads)?;
    Ok(())
}

/// Figures of the Python peers on the same kind of frames (SciPy, scikit-learn;
/// measured for docs/array.md §10, quoted here so the table carries them).
pub const PEER_FIGURES: &str = "Peers: `python3 studies/peers/scaling_vs_peers.py --seed S` runs this study and SciPy / scikit-learn on the same frames in one run, median and mean side by side (docs/array.md §10.8; seed 20261125: `bnb` returns SciPy's exhaustive enumeration's loads on every frame compared, 24–222× faster on average; `lasso` 3.3–6× faster than scikit-learn up to 24×128, 1.44× slower on average at 32×256).";

/// Frames per load count of the scaling study: test, validation and `de` frames.
#[derive(Debug, Clone, Copy)]
struct Counts {
    per_load: usize,
    val_per_load: usize,
    de_per_load: usize,
}

/// The methods compared at every size, in the table's order.
const METHODS: [Method; 7] = [
    Method::WeightedSupport,
    Method::Support,
    Method::BranchAndBound,
    Method::Lasso,
    Method::Omp,
    Method::Nnls,
    Method::De,
];

/// The default method picked at one size (`m`, `n`): its name, why, and its stream
/// time per frame, µs.
type Picked = (usize, usize, String, String, f64);
/// The default at ten times the budget at one size: its label and why.
type LongPick = (usize, usize, String, String);

/// Run the scaling study; appends its tables to `report` and returns every row.
pub fn run(
    out: &Path,
    quick: bool,
    seed: u64,
    budget_us: Option<f64>,
    report: &mut String,
) -> Result<Vec<ScalingRow>> {
    ensure_dir(out)?;
    let counts = Counts {
        per_load: if quick { 2 } else { 200 },
        val_per_load: if quick { 2 } else { 10 },
        de_per_load: if quick { 1 } else { 3 },
    };
    let budget_us = budget_us.unwrap_or(DEFAULT_BUDGET_US);
    let kernel = DistanceKernel::table1_power_law(3.0);
    let mut rows: Vec<ScalingRow> = Vec::new();
    let mut picked: Vec<Picked> = Vec::new();
    let mut long_picks: Vec<LongPick> = Vec::new();
    let bar = crate::progress::Bar::with("scaling", (SIZES.len() * (METHODS.len() + 1)) as u64);
    for &(m, n, cx, cy, nf, gpf) in &SIZES {
        let (cells, gratings) = fiber_grid_layout(cx, cy, nf, gpf);
        let a = matrix_from_positions(&cells, &gratings, &kernel);
        let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_mul(1000) + n as u64);
        let test = frames(&a, counts.per_load, &mut rng);
        let mut rng_val = ChaCha8Rng::seed_from_u64(seed.wrapping_mul(1000) + 5000 + n as u64);
        let val = frames(&a, counts.val_per_load, &mut rng_val);
        let frames_dir = out.join("scaling-frames").join(format!("n{n}"));
        write_frames(&frames_dir, &a, &test)?;
        // The validation frames too, so a peer tunes its penalty as this study does.
        write_frames(&frames_dir.join("val"), &a, &val)?;
        let problem =
            SensingProblem::new(a.clone(), ULIMIT_G, true)?.with_min_load_g(PAPER_MIN_LOAD_G)?;
        rows.extend(method_rows(
            (m, n),
            &problem,
            (&test, &val),
            counts,
            quick,
            &bar,
        )?);
        let (r, p, l) = default_rows((m, n), &problem, &test, budget_us)?;
        rows.extend(r);
        picked.push(p);
        long_picks.push(l);
        bar.advance(1);
    }
    bar.end();
    let names: Vec<String> = METHODS.iter().map(|m| m.name().to_string()).collect();
    scaling_tables(
        report,
        &rows,
        &names,
        counts,
        budget_us,
        (&picked, &long_picks),
    )?;
    scaling_files(out, &rows, &names)?;
    Ok(rows)
}

/// Every method's rows at one size, its penalty tuned on the validation frames (the
/// support objective's λ once, shared by `support`, `bnb` and `de`'s σ).
fn method_rows(
    (m, n): (usize, usize),
    problem: &SensingProblem,
    (test, val): (&Frames, &Frames),
    counts: Counts,
    quick: bool,
    bar: &crate::progress::Bar,
) -> Result<Vec<ScalingRow>> {
    let (per_load, de_per_load) = (counts.per_load, counts.de_per_load);
    let mut rows = Vec::new();
    // The support objective's λ is tuned once (on `support` where it can be
    // enumerated, else on `bnb` with a small node budget) and shared by both.
    let mut l0_penalty: Option<f64> = None;
    for method in METHODS {
        let mut settings = MethodSettings::for_method(method);
        if quick {
            match &mut settings {
                MethodSettings::De(de) => {
                    de.generations = 100;
                    de.reference_node_budget = 50_000;
                }
                MethodSettings::BranchAndBound(bnb) => bnb.node_budget = 50_000,
                _ => {}
            }
        }
        if build(problem, &settings).is_err() {
            bar.advance(1);
            continue; // an enumeration too large for this size: not applicable
        }
        let subset;
        let (frames_used, penalty) = if method == Method::De {
            // DE takes seconds per frame: the first frames of each count only,
            // σ = the tuned λ of the support objective (the paper's p → 0 limit).
            let keep: Vec<usize> = (0..test.loads.len())
                .filter(|&i| i % per_load < de_per_load)
                .collect();
            subset = Frames {
                loads: keep.iter().map(|&i| test.loads[i]).collect(),
                truth_g: keep.iter().map(|&i| test.truth_g[i].clone()).collect(),
                shifts_pm: keep.iter().map(|&i| test.shifts_pm[i].clone()).collect(),
            };
            (&subset, l0_penalty.unwrap_or(method.default_penalty()))
        } else if method == Method::Support || method == Method::BranchAndBound {
            let p = match l0_penalty {
                Some(p) => p,
                None => {
                    let mut tuning = settings;
                    if let MethodSettings::BranchAndBound(bnb) = &mut tuning {
                        bnb.node_budget = bnb.node_budget.min(200_000);
                    }
                    let p = tune(problem, tuning, val);
                    l0_penalty = Some(p);
                    p
                }
            };
            (test, p)
        } else if method == Method::WeightedSupport {
            (test, method.default_penalty()) // likelihood units, tuned on the protocol
        } else {
            (test, tune(problem, settings, val))
        };
        let settings = settings.with_penalty(penalty);
        let t0 = Instant::now();
        let r = build(problem, &settings)?;
        let setup_ms = 1e3 * t0.elapsed().as_secs_f64();
        let res = evaluate(r.as_ref(), frames_used);
        rows.extend(rows_of(m, n, method.name(), penalty, setup_ms, &res));
        bar.advance(1);
    }
    Ok(rows)
}

/// The default choice's rows at one size (at the budget and at ten times it), what it
/// picked and its stream throughput on every thread.
fn default_rows(
    (m, n): (usize, usize),
    problem: &SensingProblem,
    test: &Frames,
    budget_us: f64,
) -> Result<(Vec<ScalingRow>, Picked, LongPick)> {
    let mut rows = Vec::new();
    // The default: what `fbgforge reconstruct` picks without --method, told the
    // interrogator's resolution (0.25 pm here: λ = 16 σ² = 1 for `bnb`).
    // At 10× the budget too (the 1 ms goal at 32 × 256).
    let prior = ReadingSettings {
        max_loads: 4,
        resolution_pm: NOISE_PM,
    };
    let t_long = Instant::now();
    let long = default_choice(problem, &prior, 10.0 * budget_us)?;
    let long_setup_ms = 1e3 * t_long.elapsed().as_secs_f64();
    let res = evaluate(long.reconstructor.as_ref(), test);
    let label = format!(
        "default {:.0} µs → {}",
        10.0 * budget_us,
        long.method.name()
    );
    rows.extend(rows_of(
        m,
        n,
        &label,
        long.settings.penalty().unwrap_or(0.0),
        long_setup_ms,
        &res,
    ));
    let long_pick = (m, n, label, long.reason);
    let t0 = Instant::now();
    let choice = default_choice(problem, &prior, budget_us)?;
    let setup_ms = 1e3 * t0.elapsed().as_secs_f64();
    let res = evaluate(choice.reconstructor.as_ref(), test);
    let label = format!("default → {}", choice.method.name());
    rows.extend(rows_of(
        m,
        n,
        &label,
        choice.settings.penalty().unwrap_or(0.0),
        setup_ms,
        &res,
    ));
    // Stream throughput of the default on every thread (≥ 2048 frames).
    let stream: Vec<Vec<f64>> = (0..2048.max(test.shifts_pm.len()))
        .map(|i| test.shifts_pm[i % test.shifts_pm.len()].clone())
        .collect();
    let t1 = Instant::now();
    let _ = reconstruct_frames(
        choice.reconstructor.as_ref(),
        &stream,
        &fbgforge::progress::Quiet,
    );
    let stream_us = 1e6 * t1.elapsed().as_secs_f64() / stream.len() as f64;
    let picked = (
        m,
        n,
        choice.method.name().to_string(),
        choice.reason,
        stream_us,
    );
    Ok((rows, picked, long_pick))
}

/// The scaling tables: RR and time per method and size, the default's picks and
/// throughput, the default at ten times the budget, and the convergence reports.
fn scaling_tables(
    report: &mut String,
    rows: &[ScalingRow],
    names: &[String],
    counts: Counts,
    budget_us: f64,
    (picked, long_picks): (&[Picked], &[LongPick]),
) -> Result<()> {
    let (per_load, val_per_load, de_per_load) =
        (counts.per_load, counts.val_per_load, counts.de_per_load);
    writeln!(
        report,
        "\n## Scaling: time per frame and RR against the array's size\n\n{} frames per load count (1–4 loads), 3 % + 0.25 pm noise, Table 1 power law with a 3 mm core, gratings on parallel fibers under 20 × 30 mm cells; penalties tuned on a separate validation set ({} frames per load count); `de` on the first {} frames per load count with σ = the tuned λ of the support objective. Cells: RR % for 1/2/3/4 loads · median µs per frame (one thread). `–`: not applicable (an enumeration beyond 70 000 supports).\n",
        per_load, val_per_load, de_per_load
    )?;
    writeln!(report, "| m×n | {} | default (picked) |", names.join(" | "))?;
    writeln!(report, "|---|{}---|", "---|".repeat(names.len()))?;
    for &(m, n, ..) in &SIZES {
        let cell = |method: &str| -> String {
            let by_k: Vec<&ScalingRow> = rows
                .iter()
                .filter(|r| r.n == n && r.method == method && r.loads > 0)
                .collect();
            let all = rows
                .iter()
                .find(|r| r.n == n && r.method == method && r.loads == 0);
            match all {
                None => "–".into(),
                Some(a) => format!(
                    "{} · {:.0}",
                    by_k.iter()
                        .map(|r| format!("{:.0}", r.rr_pct))
                        .collect::<Vec<_>>()
                        .join("/"),
                    a.median_us
                ),
            }
        };
        let p = picked
            .iter()
            .find(|p| p.1 == n)
            .expect("every size has a default");
        let default = cell(&format!("default → {}", p.2));
        writeln!(
            report,
            "| {m}×{n} | {} | {} → {default} |",
            names
                .iter()
                .map(|nm| cell(nm))
                .collect::<Vec<_>>()
                .join(" | "),
            p.2
        )?;
    }
    writeln!(report, "\n{PEER_FIGURES}\n")?;
    writeln!(
        report,
        "Default method (budget {budget_us} µs per frame) and its stream throughput on {} threads:\n\n| m×n | picked | µs per frame, stream | why |\n|---|---|---|---|",
        rayon::current_num_threads()
    )?;
    for (m, n, name, reason, us) in picked {
        writeln!(report, "| {m}×{n} | {name} | {us:.1} | {reason} |")?;
    }
    writeln!(
        report,
        "\nThe default at {} µs per frame:\n\n| m×n | picked | RR % 1/2/3/4 | mean SNR dB | median / mean µs | not certified | why |\n|---|---|---|---|---|---|---|",
        10.0 * budget_us
    )?;
    for (m, n, label, reason) in long_picks {
        let by_k: Vec<String> = rows
            .iter()
            .filter(|r| r.n == *n && r.method == *label && r.loads > 0)
            .map(|r| format!("{:.1}", r.rr_pct))
            .collect();
        if let Some(all) = rows
            .iter()
            .find(|r| r.n == *n && r.method == *label && r.loads == 0)
        {
            writeln!(
                report,
                "| {m}×{n} | {label} | {} | {:.1} | {:.1} / {:.1} | {} | {reason} |",
                by_k.join("/"),
                all.mean_snr_db,
                all.median_us,
                all.mean_us,
                all.not_converged
            )?;
        }
    }
    let honesty: Vec<String> = rows
        .iter()
        .filter(|r| r.loads == 0 && (r.not_converged > 0 || r.converged_but_worse_than_truth > 0 || r.all_zero > 0))
        .map(|r| {
            format!(
                "{} at {}×{}: {} of {} not converged, {} converged but worse than the truth, {} all-zero",
                r.method, r.m, r.n, r.not_converged, r.frames, r.converged_but_worse_than_truth, r.all_zero
            )
        })
        .collect();
    writeln!(
        report,
        "\nConvergence reports: {}.\n",
        if honesty.is_empty() {
            "every method converged on every frame".to_string()
        } else {
            honesty.join("; ")
        }
    )?;
    Ok(())
}

/// `scaling.csv`, `scaling.json` and the time and RR charts.
fn scaling_files(out: &Path, rows: &[ScalingRow], names: &[String]) -> Result<()> {
    let csv_rows: Vec<Vec<String>> = rows
        .iter()
        .map(|r| {
            vec![
                r.m.to_string(),
                r.n.to_string(),
                r.method.clone(),
                format!("{}", r.penalty),
                r.loads.to_string(),
                r.frames.to_string(),
                format!("{:.1}", r.rr_pct),
                format!("{:.2}", r.mean_snr_db),
                format!("{:.2}", r.median_us),
                format!("{:.2}", r.mean_us),
                format!("{:.3}", r.setup_ms),
                r.not_converged.to_string(),
                r.converged_but_worse_than_truth.to_string(),
                r.all_zero.to_string(),
            ]
        })
        .collect();
    write_csv(
        &out.join("scaling.csv"),
        &[
            "gratings",
            "cells",
            "method",
            "penalty",
            "loads",
            "frames",
            "rr_pct",
            "mean_snr_db",
            "median_us_per_frame",
            "mean_us_per_frame",
            "setup_ms",
            "not_converged",
            "converged_but_worse_than_truth",
            "all_zero",
        ],
        &csv_rows,
    )?;
    write_json(&out.join("scaling.json"), &rows)?;
    let mut time_chart = Chart::new(
        "Reconstruction time per frame against the number of cells",
        "cells n",
        "median time per frame, µs (one thread)",
    );
    time_chart.x_log = true;
    time_chart.y_log = true;
    let mut rr_chart = Chart::new(
        "RR (1–4 loads) against the number of cells",
        "cells n",
        "RR (SNR ≥ 12 dB), %",
    );
    rr_chart.x_log = true;
    let mut labels: Vec<String> = names.to_vec();
    labels.push("default".into());
    for name in &labels {
        let pts: Vec<&ScalingRow> = rows
            .iter()
            .filter(|r| {
                r.loads == 0
                    && (r.method == *name
                        || (name == "default" && r.method.starts_with("default →")))
            })
            .collect();
        if pts.is_empty() {
            continue;
        }
        time_chart = time_chart.with(Series::new(
            name.clone(),
            pts.iter()
                .map(|r| (r.n as f64, r.median_us.max(1e-3)))
                .collect(),
            Mark::LinePoints,
        ));
        rr_chart = rr_chart.with(Series::new(
            name.clone(),
            pts.iter().map(|r| (r.n as f64, r.rr_pct)).collect(),
            Mark::LinePoints,
        ));
    }
    time_chart.write_svg(&out.join("scaling_time.svg"))?;
    rr_chart.write_svg(&out.join("scaling_rr.svg"))?;
    Ok(())
}
