//! Study `optimize` (`cargo run --release -p fbgforge-studies -- optimize [--quick]`):
//! module optimisation per shipped design and solver, and placement per solver, on a
//! fixed number of threads; a table, CSV, JSON and chart.

use anyhow::{Context, Result};
use clap::Args;
use fbgforge::optimize::materials::MaterialLibrary;
use fbgforge::optimize::module::{model_predictor, optimise_module, ModuleSettings};
use fbgforge::optimize::place::{place, PlaceSettings};
use fbgforge::output::{write_csv, write_json};
use fbgforge::plot::{Chart, Mark, Series};
use fbgforge::progress::Quiet;
use fbgforge::solvers::SolverKind;
use fbgforge::spec::Design;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of the `optimize` study.
#[derive(Debug, Clone, Args)]
pub struct BenchOptimizeArgs {
    /// Worker threads (the target machine has 2 cores).
    #[arg(long, default_value_t = 2)]
    pub threads: usize,
    /// Folder for the table (CSV, JSON) and chart.
    #[arg(long, default_value = "out/bench")]
    pub out_dir: PathBuf,
    /// Smoke run: the 34 mm module with Nelder–Mead only, no placement.
    #[arg(long)]
    pub quick: bool,
}

/// One benchmark row.
#[derive(Debug, Clone, serde::Serialize)]
struct BenchRow {
    task: String,
    solver: String,
    time_s: f64,
    evaluations: u64,
    objective: f64,
    start_objective: f64,
    target_s: f64,
}

/// Run the study: module optimisation per design and solver, and
/// placement per solver, on `--threads` threads.
pub fn run(a: &BenchOptimizeArgs) -> Result<()> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads.max(1))
        .build()
        .context("cannot start the thread pool")?;
    pool.install(|| bench_inner(a))
}

fn shipped(name: &str) -> Result<Design> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../designs")
        .join(name);
    Ok(fbgforge::design::load(&p)?)
}

fn bench_inner(a: &BenchOptimizeArgs) -> Result<()> {
    let lib = MaterialLibrary::shipped();
    let mut rows = Vec::new();
    let files: &[&str] = if a.quick {
        &["clip-on-34mm.toml"]
    } else {
        &["clip-on-34mm.toml", "clip-on-16mm.toml"]
    };
    let solver_sets = if a.quick {
        vec![vec![SolverKind::NelderMead]]
    } else {
        vec![
            vec![SolverKind::NelderMead],
            vec![SolverKind::ParticleSwarm],
            SolverKind::BOTH.to_vec(),
        ]
    };
    for file in files {
        let design = shipped(file)?;
        for solvers in &solver_sets {
            let s = ModuleSettings {
                solvers: solvers.clone(),
                ..ModuleSettings::default()
            };
            let t0 = Instant::now();
            let o = optimise_module(&design, &lib, &s, None, model_predictor(), &Quiet)?;
            let t = t0.elapsed().as_secs_f64();
            rows.push(BenchRow {
                task: format!("optimize {file} ({} choices)", o.choices.len()),
                solver: if solvers.len() == 1 {
                    solvers[0].name().into()
                } else {
                    "both".into()
                },
                time_s: t,
                evaluations: o
                    .choices
                    .iter()
                    .flat_map(|c| &c.runs)
                    .map(|r| r.evaluations)
                    .sum(),
                objective: o.choices[o.best_choice]
                    .best
                    .as_ref()
                    .map(|e| e.objective)
                    .unwrap_or(0.0),
                start_objective: o.start.objective,
                target_s: 2.0,
            });
        }
    }
    let array = shipped("tactile-array-60x80.toml")?;
    let place_solvers: &[SolverKind] = if a.quick { &[] } else { &SolverKind::BOTH };
    for &solver in place_solvers {
        let s = PlaceSettings {
            solvers: vec![solver],
            agreement_samples: 0,
            ..PlaceSettings::default()
        };
        let t0 = Instant::now();
        let o = place(&array, &s, &Quiet)?;
        let t = t0.elapsed().as_secs_f64();
        rows.push(BenchRow {
            task: "place tactile-array-60x80.toml".into(),
            solver: solver.name().into(),
            time_s: t,
            evaluations: o.runs.iter().map(|r| r.evaluations).sum(),
            objective: o.best_objective,
            start_objective: o.start_objective,
            target_s: 60.0,
        });
    }
    println!(
        "{:<44} {:<15} {:>9} {:>9} {:>12} {:>12} {:>7}",
        "task", "solver", "time s", "target s", "evaluations", "objective", "start"
    );
    for r in &rows {
        println!(
            "{:<44} {:<15} {:>9.3} {:>9.0} {:>12} {:>12.4} {:>7.3}",
            r.task, r.solver, r.time_s, r.target_s, r.evaluations, r.objective, r.start_objective
        );
    }
    write_json(&a.out_dir.join("optimize.json"), &rows)?;
    let csv_rows: Vec<Vec<String>> = rows
        .iter()
        .map(|r| {
            vec![
                r.task.clone(),
                r.solver.clone(),
                r.time_s.to_string(),
                r.target_s.to_string(),
                r.evaluations.to_string(),
                r.objective.to_string(),
                r.start_objective.to_string(),
            ]
        })
        .collect();
    write_csv(
        &a.out_dir.join("optimize.csv"),
        &[
            "task",
            "solver",
            "time_s",
            "target_s",
            "evaluations",
            "objective",
            "start_objective",
        ],
        &csv_rows,
    )?;
    let mut chart = Chart::new(
        "fbgforge-studies optimize: time against target",
        "benchmark row",
        "time / target",
    );
    for solver in ["nelder-mead", "particle-swarm", "both"] {
        let pts: Vec<(f64, f64)> = rows
            .iter()
            .enumerate()
            .filter(|(_, r)| r.solver == solver)
            .map(|(i, r)| (i as f64, r.time_s / r.target_s))
            .collect();
        if !pts.is_empty() {
            chart = chart.with(Series::new(solver, pts, Mark::Points));
        }
    }
    chart.write_svg(&a.out_dir.join("optimize.svg"))?;
    println!(
        "wrote {}",
        a.out_dir.join("optimize.{json,csv,svg}").display()
    );
    Ok(())
}
