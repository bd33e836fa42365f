//! Study `fe-speed` (`cargo run --release -p fbgforge-studies -- fe-speed`): the time of
//! the finite-element-backed commands, measured on the library calls behind them, each
//! run from a cold geometry cache (a new `fem::GeometryCache` per run: the command
//! owns one, as the CLI's commands do), so a run pays every mesh, symbolic analysis
//! and factorisation a fresh process would:
//! - `predict` of the design with the default model policy and band (what
//!   `fbgforge predict DESIGN` computes), against the closed-form fast path
//!   (`--fidelity closed-form --no-band`), and their ratio (issue 22's goal: ≤ 20×);
//! - a 21-step Case I sweep of the core modulus E1 with the policy and band
//!   (`fbgforge sweep DESIGN --param e1_mpa --from 1 --to 5 --steps 21 --case i`;
//!   goal < 3 s), with the cache's hits and misses: a modulus sweep keeps every mesh,
//!   so after its first step it builds no structure.
//!
//! Writes `fe_speed.{csv,json}` into `--out`. Timings are wall-clock seconds, min /
//! median / max over `--runs`; quote the median with the machine's load.

use anyhow::{Context, Result};
use clap::Args;
use fbgforge::fem::cache::GeometryCache;
use fbgforge::fem::FemOptions;
use fbgforge::model::sweep;
use fbgforge::model::LoadCase;
use fbgforge::output::{ensure_dir, write_csv, write_json};
use fbgforge::prediction::{self, FidelityChoice, PredictionRequest};
use fbgforge::progress::Quiet;
use std::hint::black_box;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of the `fe-speed` study.
#[derive(Debug, Args)]
pub struct FeSpeedArgs {
    /// The design to time.
    #[arg(long, default_value = "designs/clip-on-34mm.toml")]
    pub design: PathBuf,
    /// Timed runs of each command (after one untimed warm-up of the thread pool).
    #[arg(long, default_value_t = 5)]
    pub runs: usize,
    /// Output folder for the CSV and JSON.
    #[arg(long, default_value = "out/bench-fe-speed")]
    pub out: PathBuf,
    /// Smoke run: one run each, a 3-step sweep.
    #[arg(long)]
    pub quick: bool,
}

/// One timed command.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SpeedRow {
    /// What was timed, as the CLI command that computes the same.
    pub command: String,
    /// Timed runs.
    pub runs: usize,
    /// Fastest run, s.
    pub min_s: f64,
    /// Median run, s.
    pub median_s: f64,
    /// Slowest run, s.
    pub max_s: f64,
    /// Structures built (cache misses) in the last run.
    pub structures_built: u64,
    /// Structures re-used (cache hits) in the last run.
    pub structures_reused: u64,
}

/// The study's JSON document.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SpeedReport {
    /// Design timed.
    pub design: String,
    /// Sweep steps.
    pub sweep_steps: usize,
    /// The timed commands.
    pub rows: Vec<SpeedRow>,
    /// Median default `predict` over median closed-form `predict`.
    pub predict_over_closed_form: f64,
}

/// Time `f` `runs` times, each with a cold cache of its own; the cache counters of
/// the last run.
fn time_cold(
    command: String,
    runs: usize,
    mut f: impl FnMut(&GeometryCache) -> Result<()>,
) -> Result<SpeedRow> {
    let mut t = Vec::with_capacity(runs);
    let (mut built, mut reused) = (0, 0);
    for _ in 0..runs {
        let cache = GeometryCache::default();
        let start = Instant::now();
        f(&cache)?;
        t.push(start.elapsed().as_secs_f64());
        let after = cache.stats();
        built = after.misses;
        reused = after.hits;
    }
    t.sort_by(f64::total_cmp);
    Ok(SpeedRow {
        command,
        runs,
        min_s: t[0],
        median_s: t[t.len() / 2],
        max_s: t[t.len() - 1],
        structures_built: built,
        structures_reused: reused,
    })
}

/// Run the study.
pub fn run(a: &FeSpeedArgs) -> Result<()> {
    let design = fbgforge::design::load(&a.design)?;
    let path = a.design.display().to_string();
    let runs = if a.quick { 1 } else { a.runs.max(1) };
    let steps = if a.quick { 3 } else { 21 };
    let default_request = |cache: &GeometryCache| PredictionRequest {
        band: true,
        cache: cache.clone(),
        ..PredictionRequest::default()
    };
    let closed_request = |cache: &GeometryCache| PredictionRequest {
        fidelity: FidelityChoice::ClosedForm,
        band: false,
        cache: cache.clone(),
        ..PredictionRequest::default()
    };
    // Warm the thread pool (a process pays that too, but once, and so does this).
    black_box(prediction::predict(
        &design,
        &closed_request(&GeometryCache::default()),
    )?);
    let predict = time_cold(format!("fbgforge predict {path}"), runs, |cache| {
        black_box(prediction::predict(&design, &default_request(cache))?);
        Ok(())
    })?;
    let closed = time_cold(
        format!("fbgforge predict {path} --fidelity closed-form --no-band"),
        runs,
        |cache| {
            black_box(prediction::predict(&design, &closed_request(cache))?);
            Ok(())
        },
    )?;
    let param = sweep::find_param("e1_mpa")?;
    let values = sweep::sweep_values(param, 1.0, 5.0, steps)?;
    let sweep_row = time_cold(
        format!("fbgforge sweep {path} --param e1_mpa --from 1 --to 5 --steps {steps} --case i"),
        runs,
        |cache| {
            let predictor = prediction::sweep_predictor_with_band(
                FidelityChoice::Auto,
                Some(LoadCase::I),
                FemOptions::default(),
                true,
                cache.clone(),
            );
            black_box(
                sweep::run_with(
                    &design,
                    param,
                    &values,
                    10.0,
                    Some(LoadCase::I),
                    predictor.as_deref(),
                    &Quiet,
                )
                .context("the sweep failed")?,
            );
            Ok(())
        },
    )?;
    let report = SpeedReport {
        design: design.name.clone(),
        sweep_steps: steps,
        predict_over_closed_form: predict.median_s / closed.median_s,
        rows: vec![predict, closed, sweep_row],
    };
    let profile = if cfg!(debug_assertions) {
        "dev"
    } else {
        "release"
    };
    println!("FE-backed command time ({profile} build, cold geometry cache, {runs} runs)");
    println!(
        "{:<96} {:>9} {:>9} {:>9} {:>6} {:>6}",
        "command", "min s", "median s", "max s", "built", "reused"
    );
    for r in &report.rows {
        println!(
            "{:<96} {:>9.4} {:>9.4} {:>9.4} {:>6} {:>6}",
            r.command, r.min_s, r.median_s, r.max_s, r.structures_built, r.structures_reused
        );
    }
    println!(
        "default predict / closed-form fast path: {:.1}×",
        report.predict_over_closed_form
    );
    ensure_dir(&a.out)?;
    write_json(&a.out.join("fe_speed.json"), &report)?;
    let header = [
        "command",
        "runs",
        "min_s",
        "median_s",
        "max_s",
        "structures_built",
        "structures_reused",
    ];
    let rows: Vec<Vec<String>> = report
        .rows
        .iter()
        .map(|r| {
            vec![
                r.command.clone(),
                r.runs.to_string(),
                format!("{:.6}", r.min_s),
                format!("{:.6}", r.median_s),
                format!("{:.6}", r.max_s),
                r.structures_built.to_string(),
                r.structures_reused.to_string(),
            ]
        })
        .collect();
    write_csv(&a.out.join("fe_speed.csv"), &header, &rows)?;
    println!(
        "wrote {} and fe_speed.json",
        a.out.join("fe_speed.csv").display()
    );
    Ok(())
}
