//! The `reconstruct` study's budget part (`-- reconstruct --part budget`, issue 35):
//! at 16 × 64 with 1–4 loads, the default method within its per-frame budget against
//! `bnb` run to its certified optimum on the same objective (the same λ and load
//! cap, no work budget), per load count: RR, mean time per frame measured here
//! (method and frame test, one thread) and the cost model's mean estimate, at the
//! default budget and at larger ones (the trade between time and recovery).
//!
//! Frames: the scaling study's 16 × 64 grid and frames
//! ([`crate::reconstruct_scaling::scaling_problem_and_frames`], 1–4 loads of
//! 50/100/200 g, 3 % relative and 0.25 pm reading noise, seed 1), the problem told
//! the interrogator's 0.25 pm as a user would.

use anyhow::Result;
use fbgforge::array::choice::{default_choice, estimated_frame_ns, DEFAULT_BUDGET_US};
use fbgforge::array::methods::{build, MethodSettings, ReadingSettings, Reconstructor};
use fbgforge::array::protocol::{snr_db, RECOVERY_THRESHOLD_DB};
use fbgforge::array::trust::FrameTest;
use fbgforge::output::{write_csv, write_json};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

/// Budgets of the default compared, µs per frame (the first is the default's).
pub const BUDGETS_US: [f64; 3] = [DEFAULT_BUDGET_US, 300.0, 1000.0];

/// The interrogator resolution the problem is told, pm (the frames' absolute noise).
const RESOLUTION_PM: f64 = 0.25;

/// One row: one entry at one load count.
#[derive(Debug, Clone, Serialize)]
pub struct BudgetRow {
    /// `certified bnb` or `default <budget> µs → <method>`.
    pub entry: String,
    /// Loads per frame.
    pub loads: usize,
    /// Frames.
    pub frames: usize,
    /// RR, %.
    pub rr_pct: f64,
    /// Frames whose answer is the certified optimum of the method's objective.
    pub certified: usize,
    /// Mean measured time per frame here (method and frame test, one thread), µs.
    pub mean_us: f64,
    /// Mean estimated time per frame on the reference machine (the cost model), µs.
    pub estimated_us: f64,
    /// The budget, µs (None for certified `bnb`).
    pub budget_us: Option<f64>,
}

/// Run one reconstructor with the frame test on every frame: per load count 1–4,
/// (recovered, certified, µs measured, µs estimated) sums and frame counts.
fn evaluate(
    r: &dyn Reconstructor,
    settings: &MethodSettings,
    test: &FrameTest,
    (loads, truth, shifts): (&[usize], &[Vec<f64>], &[Vec<f64>]),
) -> [(usize, usize, usize, f64, f64); 5] {
    let (m, n) = (test.problem().n_gratings(), test.problem().n_cells());
    let mut acc = [(0usize, 0usize, 0usize, 0.0f64, 0.0f64); 5];
    for ((y, x), &k) in shifts.iter().zip(truth).zip(loads) {
        let t = Instant::now();
        let mut rec = r.reconstruct(y);
        test.assess(y, &mut rec);
        let us = 1e6 * t.elapsed().as_secs_f64();
        let a = &mut acc[k.min(4)];
        a.0 += 1;
        a.1 += usize::from(snr_db(x, &rec.loads_g) >= RECOVERY_THRESHOLD_DB);
        a.2 += usize::from(rec.certified);
        a.3 += us;
        a.4 += 1e-3 * estimated_frame_ns(settings, m, n, &rec);
    }
    acc
}

fn rows_of(
    entry: &str,
    budget_us: Option<f64>,
    acc: &[(usize, usize, usize, f64, f64); 5],
) -> Vec<BudgetRow> {
    (1..=4)
        .filter(|&k| acc[k].0 > 0)
        .map(|k| {
            let (f, rec, cert, us, est) = acc[k];
            let nf = f as f64;
            BudgetRow {
                entry: entry.to_string(),
                loads: k,
                frames: f,
                rr_pct: 100.0 * rec as f64 / nf,
                certified: cert,
                mean_us: us / nf,
                estimated_us: est / nf,
                budget_us,
            }
        })
        .collect()
}

/// Run the budget part: its table to `report`, `budget.csv/json` to `out`.
pub fn run(out: &Path, quick: bool, seed: u64, report: &mut String) -> Result<Vec<BudgetRow>> {
    let per_load = if quick { 4 } else { 200 };
    let (problem, loads, truth, shifts) =
        crate::reconstruct_scaling::scaling_problem_and_frames(64, per_load, seed)?;
    let prior = ReadingSettings {
        max_loads: 4,
        resolution_pm: RESOLUTION_PM,
    };
    let (m, n) = (problem.n_gratings(), problem.n_cells());
    let problem = problem.with_uncertainty(fbgforge::array::problem::Uncertainty::paper(
        m,
        n,
        RESOLUTION_PM,
    ))?;
    let test = FrameTest::new(&problem, prior.max_loads);
    let frames = (&loads[..], &truth[..], &shifts[..]);
    let mut rows = Vec::new();
    // bnb to its certified optimum: the same objective as the default's bnb.
    let mut settings =
        MethodSettings::for_prior(fbgforge::array::methods::Method::BranchAndBound, &prior);
    if let MethodSettings::BranchAndBound(b) = &mut settings {
        b.node_budget = u64::MAX / 4;
    }
    let full = build(&problem, &settings)?;
    rows.extend(rows_of(
        "certified bnb",
        None,
        &evaluate(full.as_ref(), &settings, &test, frames),
    ));
    for budget in BUDGETS_US {
        let choice = default_choice(&problem, &prior, budget)?;
        let label = format!("default {budget:.0} µs → {}", choice.method.name());
        let acc = evaluate(
            choice.reconstructor.as_ref(),
            &choice.settings,
            &test,
            frames,
        );
        rows.extend(rows_of(&label, Some(budget), &acc));
    }
    write_files(out, &rows)?;
    table(report, &rows, per_load, seed)?;
    Ok(rows)
}

fn write_files(out: &Path, rows: &[BudgetRow]) -> Result<()> {
    let csv: Vec<Vec<String>> = rows
        .iter()
        .map(|r| {
            vec![
                r.entry.clone(),
                r.loads.to_string(),
                r.frames.to_string(),
                format!("{:.2}", r.rr_pct),
                r.certified.to_string(),
                format!("{:.1}", r.mean_us),
                format!("{:.1}", r.estimated_us),
                r.budget_us.map_or(String::new(), |b| format!("{b}")),
            ]
        })
        .collect();
    write_csv(
        &out.join("budget.csv"),
        &[
            "entry",
            "loads",
            "frames",
            "rr_pct",
            "certified",
            "mean_us",
            "estimated_us",
            "budget_us",
        ],
        &csv,
    )?;
    write_json(&out.join("budget.json"), &rows)?;
    Ok(())
}

fn table(report: &mut String, rows: &[BudgetRow], per_load: usize, seed: u64) -> Result<()> {
    writeln!(
        report,
        "## 16 × 64: the default within its budget against certified bnb ({per_load} frames per load count, seed {seed})\n"
    )?;
    writeln!(report, "| entry | loads | RR % | vs certified bnb, points | certified | mean µs (here) | estimated µs |")?;
    writeln!(report, "|---|---|---|---|---|---|---|")?;
    for r in rows {
        let full = rows
            .iter()
            .find(|q| q.entry == "certified bnb" && q.loads == r.loads)
            .map_or(0.0, |q| q.rr_pct);
        writeln!(
            report,
            "| {} | {} | {:.1} | {:+.1} | {}/{} | {:.0} | {:.0} |",
            r.entry,
            r.loads,
            r.rr_pct,
            r.rr_pct - full,
            r.certified,
            r.frames,
            r.mean_us,
            r.estimated_us
        )?;
    }
    writeln!(report)?;
    Ok(())
}
