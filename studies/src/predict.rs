//! Study `predict` (`cargo run --release -p fbgforge-studies -- predict`): the time of
//! one closed-form K, of deriving the model parameters from a design, and of a full
//! `predict`, per shipped module design; writes a chart, CSV and JSON.

use anyhow::{bail, Context, Result};
use clap::Args;
use fbgforge::model::{self, closed_form, LoadCase, ModuleModelParams, PredictOptions};
use fbgforge::output::{ensure_dir, write_csv, write_json};
use fbgforge::plot::{Chart, Mark, Series};
use fbgforge::progress::Progress;
use std::hint::black_box;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of the `predict` study.
#[derive(Debug, Args)]
pub struct BenchPredictArgs {
    /// Designs to time (default: designs/clip-on-*.toml).
    pub designs: Vec<PathBuf>,
    /// Closed-form evaluations timed per design.
    #[arg(long, default_value_t = 200_000)]
    pub iterations: usize,
    /// Output folder for the chart, CSV and JSON.
    #[arg(long, default_value = "out/bench")]
    pub out: PathBuf,
    /// Smoke run: 2,000 evaluations per design.
    #[arg(long)]
    pub quick: bool,
}

/// One row of the predict benchmark.
#[derive(Debug, Clone, serde::Serialize)]
struct BenchRow {
    design: String,
    outer_diameter_mm: f64,
    configurations_x_gratings: usize,
    closed_form_ns_per_k: f64,
    params_from_design_ns: f64,
    full_predict_us: f64,
}

fn default_designs() -> Result<Vec<PathBuf>> {
    let mut v: Vec<PathBuf> = std::fs::read_dir("designs")
        .context("cannot list designs/: run from the project folder or name the designs")?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("clip-on-") && n.ends_with(".toml"))
        })
        .collect();
    v.sort();
    Ok(v)
}

/// Time one design: a closed-form K over the parameter sets an optimiser would hold
/// (one per core and configuration), deriving those parameters from the design, and a
/// full `predict`.
fn time_design(path: &std::path::Path, iters: usize) -> Result<BenchRow> {
    let design = fbgforge::design::load(path)?;
    let m = design
        .module
        .as_ref()
        .with_context(|| format!("{}: no [module] section", path.display()))?;
    let mut sets: Vec<(ModuleModelParams, LoadCase, f64)> = Vec::new();
    for conf in model::configurations(&design)? {
        for g in m.gratings.iter().filter(|g| {
            g.role == fbgforge::spec::GratingRole::Strain
                && g.core.as_deref() == Some(conf.core.as_str())
        }) {
            let core = g.core.as_deref().unwrap_or_default();
            let p = ModuleModelParams::from_design(&design, core, conf.insert.as_deref())?;
            sets.push((p, conf.case, g.bragg_wavelength_nm));
        }
    }
    let optics = design.fiber;
    let opts = PredictOptions {
        force_n: 10.0,
        delta_t_k: 0.0,
    };
    // Warm caches and branch predictors before timing anything.
    for _ in 0..1000 {
        black_box(model::predict_with(black_box(&design), &opts)?);
    }
    let t = Instant::now();
    let mut acc = 0.0;
    for i in 0..iters {
        let (p, case, l) = &sets[i % sets.len()];
        acc += closed_form::sensitivity_pm_per_n(black_box(p), *case, *l, &optics).unwrap_or(0.0);
    }
    black_box(acc);
    let closed_ns = t.elapsed().as_secs_f64() * 1e9 / iters as f64;
    let n_params = (iters / 100).max(100);
    let core0 = m.cores[0].name.clone();
    let t = Instant::now();
    for _ in 0..n_params {
        black_box(ModuleModelParams::from_design(
            black_box(&design),
            &core0,
            None,
        )?);
    }
    let params_ns = t.elapsed().as_secs_f64() * 1e9 / n_params as f64;
    let n_full = (iters / 100).max(100);
    let t = Instant::now();
    for _ in 0..n_full {
        black_box(model::predict_with(black_box(&design), &opts)?);
    }
    let full_us = t.elapsed().as_secs_f64() * 1e6 / n_full as f64;
    Ok(BenchRow {
        design: design.name.clone(),
        outer_diameter_mm: m.outer_diameter_mm,
        configurations_x_gratings: sets.len(),
        closed_form_ns_per_k: closed_ns,
        params_from_design_ns: params_ns,
        full_predict_us: full_us,
    })
}

/// The rows as CSV and JSON, and the chart of the three times against the diameter.
fn write_outputs(a: &BenchPredictArgs, rows: &[BenchRow], profile: &str) -> Result<()> {
    ensure_dir(&a.out)?;
    write_json(&a.out.join("predict.json"), &rows)?;
    let header = [
        "design",
        "outer_diameter_mm",
        "configurations_x_gratings",
        "closed_form_ns_per_k",
        "params_from_design_ns",
        "full_predict_us",
    ];
    let csv_rows: Vec<Vec<String>> = rows
        .iter()
        .map(|r| {
            vec![
                r.design.clone(),
                format!("{}", r.outer_diameter_mm),
                format!("{}", r.configurations_x_gratings),
                format!("{:.2}", r.closed_form_ns_per_k),
                format!("{:.1}", r.params_from_design_ns),
                format!("{:.3}", r.full_predict_us),
            ]
        })
        .collect();
    write_csv(&a.out.join("predict.csv"), &header, &csv_rows)?;
    let pts = |f: fn(&BenchRow) -> f64| {
        rows.iter()
            .map(|r| (r.outer_diameter_mm, f(r)))
            .collect::<Vec<_>>()
    };
    let mut chart = Chart::new(
        format!("fbgforge predict timing ({profile} build)"),
        "module outer diameter (mm)",
        "time per call (µs)",
    )
    .with(Series::new(
        "closed form, one K",
        pts(|r| r.closed_form_ns_per_k / 1e3),
        Mark::LinePoints,
    ))
    .with(Series::new(
        "parameters from design",
        pts(|r| r.params_from_design_ns / 1e3),
        Mark::LinePoints,
    ))
    .with(Series::new(
        "full predict (all gratings, cases)",
        pts(|r| r.full_predict_us),
        Mark::LinePoints,
    ));
    chart.y_log = true;
    chart.write_svg(&a.out.join("predict.svg"))
}

/// Run the study.
pub fn run(a: &BenchPredictArgs) -> Result<()> {
    let designs = if a.designs.is_empty() {
        default_designs()?
    } else {
        a.designs.clone()
    };
    if designs.is_empty() {
        bail!("no designs to time");
    }
    let iters = if a.quick { 2_000 } else { a.iterations.max(1) };
    let mut rows = Vec::new();
    let pb = crate::progress::Bar::with("bench", designs.len() as u64);
    for path in &designs {
        rows.push(time_design(path, iters)?);
        pb.advance(1);
    }
    pb.end();
    let profile = if cfg!(debug_assertions) {
        "dev"
    } else {
        "release"
    };
    println!("closed-form prediction time ({profile} build, {iters} evaluations per design)");
    println!(
        "{:<16} {:>6} {:>8} {:>16} {:>18} {:>18}",
        "design", "D mm", "K/design", "closed form ns/K", "params build ns", "full predict µs"
    );
    for r in &rows {
        println!(
            "{:<16} {:>6.1} {:>8} {:>16.1} {:>18.0} {:>18.2}",
            r.design,
            r.outer_diameter_mm,
            r.configurations_x_gratings,
            r.closed_form_ns_per_k,
            r.params_from_design_ns,
            r.full_predict_us
        );
    }
    write_outputs(a, &rows, profile)?;
    println!("wrote {}/predict.{{svg,csv,json}}", a.out.display());
    Ok(())
}
