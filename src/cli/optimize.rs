//! `fbgforge optimize`, `fbgforge place` and `fbgforge bench optimize`: design
//! optimisation from the command line (the work is in [`fbgforge::optimize`]).

use anyhow::{Context, Result};
use clap::Args;
use fbgforge::optimize::materials::MaterialLibrary;
use fbgforge::optimize::module::{
    landscape, model_predictor, optimise_module, parse_bounds, ModuleOutcome, ModuleProblem,
    ModuleSettings, Objective, Predictor, Variable,
};
use fbgforge::optimize::place::{place, PlaceObjective, PlaceOutcome, PlaceSettings};
use fbgforge::optimize::quality::MeasuredPrototype;
use fbgforge::optimize::solve::SolverKind;
use fbgforge::output::{write_atomic, write_csv, write_json};
use fbgforge::plot::{Chart, Mark, Series};
use fbgforge::spec::{self, Design};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `fbgforge optimize`.
#[derive(Debug, Args)]
pub struct OptimizeArgs {
    /// Start design (TOML with a [module] section).
    pub design: PathBuf,
    /// What to maximise: q (|K|·R²/Δt_max) or sensitivity (|K|).
    #[arg(long, default_value = "q")]
    pub objective: String,
    /// Variables to search, comma-separated (outer_diameter_mm, cap_wall_mm,
    /// core_wall_mm, dome_height_ratio, overall_height_mm).
    #[arg(
        long,
        default_value = "outer_diameter_mm,cap_wall_mm,core_wall_mm,dome_height_ratio"
    )]
    pub vary: String,
    /// Search bounds replacing the defaults, e.g. `outer_diameter_mm=10:22,cap_wall_mm=0.5:2`.
    #[arg(long)]
    pub bounds: Option<String>,
    /// Largest force the module must take, N (strain and window constraints).
    #[arg(long, default_value_t = 20.0)]
    pub max_force_n: f64,
    /// Largest allowed grating strain at that force, microstrain.
    #[arg(long, default_value_t = 3000.0)]
    pub max_strain_microstrain: f64,
    /// Smallest printable fit clearance, mm (default: the printer's resolution).
    #[arg(long)]
    pub min_clearance_mm: Option<f64>,
    /// Core materials to try, comma-separated (default: the design's and the library's
    /// for this printer).
    #[arg(long)]
    pub cores: Option<String>,
    /// Inserts to try, comma-separated; `none` is a hollow core (default: the design's,
    /// the library's for this printer, and none).
    #[arg(long)]
    pub inserts: Option<String>,
    /// Material library TOML replacing the shipped `designs/library/materials.toml`.
    #[arg(long)]
    pub materials: Option<PathBuf>,
    /// JSON of `fbgforge verify --json` for a print of this design: calibrates the Q model.
    #[arg(long)]
    pub measured: Option<PathBuf>,
    /// Solver: nelder-mead, particle-swarm or both.
    #[arg(long, default_value = "both")]
    pub solver: String,
    /// Random starts per solver besides the design's own point.
    #[arg(long, default_value_t = 2)]
    pub starts: usize,
    /// Iteration limit per Nelder–Mead run.
    #[arg(long, default_value_t = 200)]
    pub max_iters: u64,
    /// Iteration limit of the particle swarm.
    #[arg(long, default_value_t = 80)]
    pub swarm_iters: u64,
    /// Seed of starts and swarms.
    #[arg(long, default_value_t = 2024)]
    pub seed: u64,
    /// The two variables of the Q landscape plot (default: the first two varied).
    #[arg(long)]
    pub landscape: Option<String>,
    /// Where to write the optimised design (default `out/optimize/<name>-optimised.toml`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Folder for the JSON summary, CSVs and SVG plots (default: beside --out).
    #[arg(long)]
    pub report_dir: Option<PathBuf>,
    /// Print the JSON summary on stdout instead of the table.
    #[arg(long)]
    pub json: bool,
}

fn split_list(s: &str) -> Vec<String> {
    s.split(',')
        .map(|x| x.trim().to_string())
        .filter(|x| !x.is_empty())
        .collect()
}

/// Build module settings from the arguments.
pub fn module_settings(a: &OptimizeArgs) -> Result<ModuleSettings> {
    let vary = Variable::parse_list(&a.vary)?;
    let mut s = ModuleSettings {
        objective: Objective::parse(&a.objective)?,
        max_force_n: a.max_force_n,
        max_grating_strain: a.max_strain_microstrain * 1e-6,
        min_fit_clearance_mm: a.min_clearance_mm,
        vary,
        bounds: a
            .bounds
            .as_deref()
            .map(parse_bounds)
            .transpose()?
            .unwrap_or_default(),
        cores: a.cores.as_deref().map(split_list),
        inserts: a.inserts.as_deref().map(split_list),
        solvers: SolverKind::parse(&a.solver)?,
        extra_starts: a.starts,
        seed: a.seed,
        ..ModuleSettings::default()
    };
    s.run.max_iters = a.max_iters;
    s.run.swarm_iters = a.swarm_iters;
    anyhow::ensure!(
        a.max_iters > 0 && a.swarm_iters > 0,
        "--max-iters and --swarm-iters must be at least 1"
    );
    if let Some(c) = a.min_clearance_mm {
        anyhow::ensure!(
            c.is_finite() && c > 0.0,
            "--min-clearance-mm must be a positive number of mm, got {c}"
        );
    }
    Ok(s)
}

/// Run `fbgforge optimize`.
pub fn run_optimize(a: OptimizeArgs) -> Result<()> {
    let design = spec::load(&a.design)?;
    let lib = match &a.materials {
        Some(p) => MaterialLibrary::load(p)?,
        None => MaterialLibrary::shipped(),
    };
    let settings = module_settings(&a)?;
    // Check the plot request before the work, so a typo costs nothing.
    let landscape_vars = match &a.landscape {
        Some(s) => {
            let v = Variable::parse_list(s)?;
            anyhow::ensure!(
                v.len() == 2,
                "--landscape needs exactly two variables, got {}",
                v.len()
            );
            if let Some(x) = v.iter().find(|x| !settings.vary.contains(x)) {
                anyhow::bail!("--landscape variable `{}` is not in --vary", x.name());
            }
            v
        }
        None => settings.vary.iter().take(2).copied().collect(),
    };
    let measured = a
        .measured
        .as_deref()
        .map(MeasuredPrototype::load)
        .transpose()?;
    let n_choices = fbgforge::optimize::module::choices(&design, &lib, &settings)?.len();
    let bar = fbgforge::progress::bar(n_choices as u64, "optimise");
    let outcome = optimise_module(
        &design,
        &lib,
        &settings,
        measured.as_ref(),
        model_predictor(),
        &|done| bar.set_position(done as u64),
    )?;
    bar.finish_and_clear();
    let out = a.out.clone().unwrap_or_else(|| {
        PathBuf::from("out/optimize").join(format!("{}.toml", outcome.design.name))
    });
    let report_dir = a.report_dir.clone().unwrap_or_else(|| report_beside(&out));
    write_design(&out, &outcome.design)?;
    write_module_report(
        &report_dir,
        &design,
        &lib,
        &settings,
        &outcome,
        &landscape_vars,
        model_predictor(),
    )?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&outcome)?);
    } else {
        print_module_table(&outcome);
        println!("design: {}", out.display());
        println!("report: {}", report_dir.display());
    }
    Ok(())
}

/// Default report folder: `<out stem>-report` beside the written design.
fn report_beside(out: &Path) -> PathBuf {
    let stem = out
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "design".into());
    out.parent()
        .unwrap_or(Path::new("."))
        .join(format!("{stem}-report"))
}

/// Write a design as TOML, atomically, after checking that it loads back.
fn write_design(path: &Path, d: &Design) -> Result<()> {
    let text = format!(
        "# Written by fbgforge; loads with `fbgforge build/predict/verify`.\n{}",
        d.to_toml()
    );
    spec::parse(&text)
        .map_err(|e| anyhow::anyhow!("internal: the written design does not load back: {e}"))?;
    write_atomic(path, text.as_bytes())
}

fn x_text(vars: &[Variable], x: &[f64]) -> String {
    vars.iter()
        .zip(x)
        .map(|(v, x)| format!("{}={x:.3}", v.name()))
        .collect::<Vec<_>>()
        .join(" ")
}

fn print_module_table(o: &ModuleOutcome) {
    let unit = o.objective_unit;
    println!(
        "start ({}): objective {:.4} {unit}, feasible {}",
        o.start_choice,
        o.start.objective,
        o.start.feasible()
    );
    let mut rows: Vec<&fbgforge::optimize::module::ChoiceResult> = o.choices.iter().collect();
    rows.sort_by(|a, b| {
        let f = |c: &fbgforge::optimize::module::ChoiceResult| {
            c.best.as_ref().map(|e| e.objective).unwrap_or(-1.0)
        };
        f(b).total_cmp(&f(a))
    });
    println!(
        "{:<52} {:>12} {:>10} {:>7}  variables",
        "choice",
        format!("obj {unit}"),
        "K pm/N",
        "evals"
    );
    for c in rows {
        let evals: u64 = c.runs.iter().map(|r| r.evaluations).sum();
        match &c.best {
            Some(e) => {
                let k = e
                    .gratings
                    .iter()
                    .map(|g| g.sensitivity_pm_per_n)
                    .fold(f64::NAN, |a, b| {
                        if a.is_nan() || b.abs() < a.abs() {
                            b
                        } else {
                            a
                        }
                    });
                println!(
                    "{:<52} {:>12.4} {:>10.3} {:>7}  {}",
                    c.choice.to_string(),
                    e.objective,
                    k,
                    evals,
                    x_text(&o.variables, &e.x)
                );
            }
            None => println!(
                "{:<52} {:>12} {:>10} {:>7}  infeasible",
                c.choice.to_string(),
                "-",
                "-",
                evals
            ),
        }
    }
    let best = &o.choices[o.best_choice];
    let value = best.best.as_ref().map(|e| e.objective).unwrap_or(0.0);
    let versus = if o.start.feasible() {
        format!(
            "{:+.1} % on the start",
            100.0 * (value / o.start.objective.max(1e-300) - 1.0)
        )
    } else {
        let broken: Vec<String> = o
            .start
            .constraints
            .iter()
            .filter(|c| c.violation > 0.0)
            .map(|c| format!("`{}`: {}", c.name, c.detail))
            .collect();
        format!("the start is infeasible, {}", broken.join("; "))
    };
    println!(
        "best: {} objective {value:.4} {unit} ({versus}) in {:.2} s",
        best.choice, o.time_s
    );
    let m = o.design.module.as_ref().expect("module designs only");
    println!(
        "      D {:.3} mm, H {:.3} mm, dome {:.3} mm, cap wall {:.3} mm, core wall {:.3} mm",
        m.outer_diameter_mm, m.overall_height_mm, m.dome_height_mm, m.cap_wall_mm, m.core_wall_mm
    );
}

/// Convergence chart, landscape chart, their CSVs, and the JSON summary.
fn write_module_report(
    dir: &Path,
    base: &Design,
    lib: &MaterialLibrary,
    settings: &ModuleSettings,
    o: &ModuleOutcome,
    landscape_vars: &[Variable],
    predictor: Predictor,
) -> Result<()> {
    write_json(&dir.join("summary.json"), o)?;
    // Convergence of every run of the winning choice (best penalised cost per iteration).
    let win = &o.choices[o.best_choice];
    let mut chart = Chart::new(
        format!("Convergence, {}", win.choice),
        "iteration",
        "best cost (−objective / start objective)",
    );
    let mut rows = Vec::new();
    for r in &win.runs {
        let pts: Vec<(f64, f64)> = r
            .history
            .iter()
            .enumerate()
            .map(|(i, c)| (i as f64 + 1.0, *c))
            .collect();
        for (i, c) in &pts {
            rows.push(vec![
                r.solver.name().to_string(),
                r.start.to_string(),
                i.to_string(),
                c.to_string(),
            ]);
        }
        chart = chart.with(Series::new(
            format!("{} start {}", r.solver.name(), r.start),
            pts,
            Mark::Line,
        ));
    }
    chart.write_svg(&dir.join("convergence.svg"))?;
    write_csv(
        &dir.join("convergence.csv"),
        &["solver", "start", "iteration", "best_cost"],
        &rows,
    )?;
    // Landscape over two variables at the optimum of the winning choice.
    let idx: Vec<usize> = landscape_vars
        .iter()
        .map(|v| {
            o.variables.iter().position(|w| w == v).ok_or_else(|| {
                anyhow::anyhow!("--landscape variable `{}` is not in --vary", v.name())
            })
        })
        .collect::<Result<_>>()?;
    if idx.len() == 2 {
        let cal = o.calibration;
        let p = ModuleProblem::new(base, win.choice.clone(), lib, settings, cal, predictor)?;
        let at = win
            .best
            .as_ref()
            .map(|e| e.x.clone())
            .unwrap_or_else(|| p.start_point());
        let steps = 15;
        let grid = landscape(&p, &at, idx[0], idx[1], steps);
        let (va, vb) = (landscape_vars[0], landscape_vars[1]);
        let mut chart = Chart::new(
            format!(
                "{} landscape, {}",
                if o.objective == Objective::Q {
                    "Q"
                } else {
                    "|K|"
                },
                win.choice
            ),
            va.name(),
            format!("objective, {}", o.objective_unit),
        );
        // Every third slice of the second variable, feasible points joined; the
        // points the constraints cut off drawn apart.
        for j in (0..steps).step_by(3) {
            let vbj = grid[j].b;
            let pts: Vec<(f64, f64)> = grid
                .iter()
                .filter(|g| (g.b - vbj).abs() < 1e-12 && g.feasible && g.objective.is_finite())
                .map(|g| (g.a, g.objective))
                .collect();
            if !pts.is_empty() {
                chart = chart.with(Series::new(
                    format!("{} = {vbj:.3}, feasible", vb.name()),
                    pts,
                    Mark::LinePoints,
                ));
            }
        }
        let cut: Vec<(f64, f64)> = grid
            .iter()
            .filter(|g| !g.feasible && g.objective.is_finite())
            .map(|g| (g.a, g.objective))
            .collect();
        if !cut.is_empty() {
            chart = chart.with(Series::new(
                "infeasible (strain or window limit)",
                cut,
                Mark::Points,
            ));
        }
        if chart.series.is_empty() {
            anyhow::bail!("the landscape has no point the model could evaluate");
        }
        chart.write_svg(&dir.join("landscape.svg"))?;
        let rows: Vec<Vec<String>> = grid
            .iter()
            .map(|g| {
                vec![
                    g.a.to_string(),
                    g.b.to_string(),
                    if g.objective.is_finite() {
                        g.objective.to_string()
                    } else {
                        String::new()
                    },
                    g.feasible.to_string(),
                ]
            })
            .collect();
        write_csv(
            &dir.join("landscape.csv"),
            &[va.name(), vb.name(), "objective", "feasible"],
            &rows,
        )?;
    }
    Ok(())
}

/// Arguments of `fbgforge place`.
#[derive(Debug, Args)]
pub struct PlaceArgs {
    /// Start design (TOML with an [array] section).
    pub design: PathBuf,
    /// Objective: protocol (RR + mean SNR on the seeded protocol) or coherence (proxy).
    #[arg(long, default_value = "protocol")]
    pub objective: String,
    /// Reconstruction method the protocol uses.
    #[arg(long, default_value = "wsupport")]
    pub method: String,
    /// Also move the fibers along x (the mold's slits follow).
    #[arg(long)]
    pub vary_fibers: bool,
    /// Solver: nelder-mead, particle-swarm or both.
    #[arg(long, default_value = "both")]
    pub solver: String,
    /// Iteration limit per run (Nelder–Mead and swarm).
    #[arg(long, default_value_t = 90)]
    pub max_iters: u64,
    /// Random layouts for measuring the coherence proxy against the protocol (0: skip).
    #[arg(long, default_value_t = 40)]
    pub agreement_samples: usize,
    /// Where to write the placed design (default `out/place/<name>-placed.toml`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Folder for the JSON summary, CSV and SVG plots (default: beside --out).
    #[arg(long)]
    pub report_dir: Option<PathBuf>,
    /// Print the JSON summary on stdout instead of the table.
    #[arg(long)]
    pub json: bool,
}

/// Build placement settings from the arguments.
pub fn place_settings(a: &PlaceArgs) -> Result<PlaceSettings> {
    let mut s = PlaceSettings {
        objective: PlaceObjective::parse(&a.objective)?,
        method: fbgforge::array::methods::Method::from_name(&a.method)?,
        vary_fibers: a.vary_fibers,
        solvers: SolverKind::parse(&a.solver)?,
        agreement_samples: a.agreement_samples,
        ..PlaceSettings::default()
    };
    anyhow::ensure!(a.max_iters > 0, "--max-iters must be at least 1");
    s.run.max_iters = a.max_iters;
    s.run.swarm_iters = a.max_iters;
    Ok(s)
}

/// Run `fbgforge place`.
pub fn run_place(a: PlaceArgs) -> Result<()> {
    let design = spec::load(&a.design)?;
    let settings = place_settings(&a)?;
    let bar = fbgforge::progress::bar(3, "place");
    let outcome = place(&design, &settings, &|stage| {
        bar.set_message(stage.to_string());
        bar.inc(1)
    })?;
    bar.finish_and_clear();
    let out = a.out.clone().unwrap_or_else(|| {
        PathBuf::from("out/place").join(format!("{}.toml", outcome.design.name))
    });
    let report_dir = a.report_dir.clone().unwrap_or_else(|| report_beside(&out));
    write_design(&out, &outcome.design)?;
    write_place_report(&report_dir, &outcome)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&outcome)?);
    } else {
        print_place_table(&outcome);
        println!("design: {}", out.display());
        println!("report: {}", report_dir.display());
    }
    Ok(())
}

fn print_place_table(o: &PlaceOutcome) {
    println!(
        "objective {:?}, method {}: start {:.4}, optimised {:.4} (training seeds)",
        o.objective, o.method, o.start_objective, o.best_objective
    );
    if let Some(a) = &o.design.array {
        println!(
            "{:<10} {:>8} {:>12} {:>12}",
            "grating", "fiber", "start y mm", "y mm"
        );
        for (i, g) in a.gratings.iter().enumerate() {
            println!(
                "{:<10} {:>8} {:>12.2} {:>12.2}",
                g.name, g.fiber, o.start_x[i], g.y_mm
            );
        }
        let xs: Vec<String> = a.fiber_x_mm.iter().map(|x| format!("{x:.2}")).collect();
        println!("fiber x mm (mold slits): {}", xs.join(", "));
    }
    println!(
        "{:<16} {:>14} {:>10} {:>10} {:>10}",
        "solver", "best objective", "iters", "evals", "time s"
    );
    for r in &o.runs {
        println!(
            "{:<16} {:>14.4} {:>10} {:>10} {:>10.2}",
            r.solver.name(),
            r.best_objective,
            r.iterations,
            r.evaluations,
            r.time_s
        );
    }
    println!("held-out protocol (penalty tuned):  RR %   mean SNR dB   coherence");
    let row = |name: &str, s: &fbgforge::optimize::place::LayoutScore| {
        println!(
            "  {name:<32} {:>6.1} {:>12.2} {:>11.3}",
            s.rr_pct, s.mean_snr_db, s.mutual_coherence
        )
    };
    row("start layout", &o.start_test);
    row("optimised layout", &o.best_test);
    println!(
        "  by number of loads (paper Table 3: RR 100/100/100/90 %, SNR 25.4/25.2/23.3/19.7 dB):"
    );
    for (a, b) in o
        .start_test
        .by_load_count
        .iter()
        .zip(&o.best_test.by_load_count)
    {
        println!(
            "    {} load(s): start RR {:>5.1} % SNR {:>5.2} dB   optimised RR {:>5.1} % SNR {:>5.2} dB",
            a.0, a.1, a.2, b.1, b.2
        );
    }
    if let Some(ag) = &o.agreement {
        println!(
            "coherence proxy vs protocol score: Spearman {:.2} over {} random layouts",
            ag.spearman_coherence_vs_score, ag.samples
        );
    }
    println!("in {:.1} s", o.time_s);
}

fn write_place_report(dir: &Path, o: &PlaceOutcome) -> Result<()> {
    write_json(&dir.join("summary.json"), o)?;
    let mut chart = Chart::new(
        "Placement convergence",
        "iteration",
        "best cost (−objective)",
    );
    let mut rows = Vec::new();
    for r in &o.runs {
        let pts: Vec<(f64, f64)> = r
            .history
            .iter()
            .enumerate()
            .map(|(i, c)| (i as f64 + 1.0, *c))
            .collect();
        for (i, c) in &pts {
            rows.push(vec![
                r.solver.name().to_string(),
                i.to_string(),
                c.to_string(),
            ]);
        }
        chart = chart.with(Series::new(r.solver.name(), pts, Mark::Line));
    }
    chart.write_svg(&dir.join("convergence.svg"))?;
    write_csv(
        &dir.join("convergence.csv"),
        &["solver", "iteration", "best_cost"],
        &rows,
    )?;
    if let Some(ag) = &o.agreement {
        let chart = Chart::new(
            "Coherence proxy against the protocol",
            "mutual coherence",
            "RR % + mean SNR dB",
        )
        .with(Series::new(
            "random layouts",
            ag.points.clone(),
            Mark::Points,
        ));
        chart.write_svg(&dir.join("proxy_agreement.svg"))?;
        let rows: Vec<Vec<String>> = ag
            .points
            .iter()
            .map(|p| vec![p.0.to_string(), p.1.to_string()])
            .collect();
        write_csv(
            &dir.join("proxy_agreement.csv"),
            &["mutual_coherence", "protocol_score"],
            &rows,
        )?;
    }
    Ok(())
}

/// Arguments of `fbgforge bench optimize`.
#[derive(Debug, Args)]
pub struct BenchOptimizeArgs {
    /// Worker threads (the target machine has 2 cores).
    #[arg(long, default_value_t = 2)]
    pub threads: usize,
    /// Folder for the table (CSV, JSON) and chart.
    #[arg(long, default_value = "out/bench")]
    pub out_dir: PathBuf,
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

/// Run `fbgforge bench optimize`: module optimisation per design and solver, and
/// placement per solver, on `--threads` threads.
pub fn bench(a: BenchOptimizeArgs) -> Result<()> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads.max(1))
        .build()
        .context("cannot start the thread pool")?;
    pool.install(|| bench_inner(&a))
}

fn shipped(name: &str) -> Result<Design> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("designs")
        .join(name);
    Ok(spec::load(&p)?)
}

fn bench_inner(a: &BenchOptimizeArgs) -> Result<()> {
    let lib = MaterialLibrary::shipped();
    let mut rows = Vec::new();
    for file in ["clip-on-34mm.toml", "clip-on-16mm.toml"] {
        let design = shipped(file)?;
        for solvers in [
            vec![SolverKind::NelderMead],
            vec![SolverKind::ParticleSwarm],
            SolverKind::ALL.to_vec(),
        ] {
            let s = ModuleSettings {
                solvers: solvers.clone(),
                ..ModuleSettings::default()
            };
            let t0 = Instant::now();
            let o = optimise_module(&design, &lib, &s, None, model_predictor(), &|_| {})?;
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
    for solver in SolverKind::ALL {
        let s = PlaceSettings {
            solvers: vec![solver],
            agreement_samples: 0,
            ..PlaceSettings::default()
        };
        let t0 = Instant::now();
        let o = place(&array, &s, &|_| {})?;
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
        "fbgforge bench optimize: time against target",
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
