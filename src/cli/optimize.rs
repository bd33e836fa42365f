//! `fbgforge optimize` and `fbgforge place`: design optimisation from the command
//! line (the work is in `fbgforge::optimize::run`).

use super::progress::Bar;
use anyhow::Result;
use clap::Args;
use fbgforge::optimize::module::{
    parse_bounds, ModuleOutcome, ModuleSettings, Objective, Variable,
};
use fbgforge::optimize::place::{PlaceObjective, PlaceOutcome, PlaceSettings};
use fbgforge::optimize::run::{run_module, run_placement, ModuleRequest, PlaceRequest};
use fbgforge::solvers::SolverKind;
use std::path::PathBuf;

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
    let req = ModuleRequest {
        design: a.design.clone(),
        materials: a.materials.clone(),
        settings: module_settings(&a)?,
        measured: a.measured.clone(),
        landscape: a
            .landscape
            .as_deref()
            .map(Variable::parse_list)
            .transpose()?,
        out: a.out.clone(),
        report_dir: a.report_dir.clone(),
    };
    let run = run_module(&req, &Bar::new())?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&run.outcome)?);
    } else {
        print_module_table(&run.outcome);
        println!("design: {}", run.design_path.display());
        println!("report: {}", run.report_dir.display());
    }
    Ok(())
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
    println!(
        "model: {} (other choices: scored with the policy anchored on their start)",
        o.model
    );
    let m = o.design.module.as_ref().expect("module designs only");
    println!(
        "      D {:.3} mm, H {:.3} mm, dome {:.3} mm, cap wall {:.3} mm, core wall {:.3} mm",
        m.outer_diameter_mm, m.overall_height_mm, m.dome_height_mm, m.cap_wall_mm, m.core_wall_mm
    );
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
    let req = PlaceRequest {
        design: a.design.clone(),
        settings: place_settings(&a)?,
        out: a.out.clone(),
        report_dir: a.report_dir.clone(),
    };
    let run = run_placement(&req, &Bar::new())?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&run.outcome)?);
    } else {
        print_place_table(&run.outcome);
        println!("design: {}", run.design_path.display());
        println!("report: {}", run.report_dir.display());
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
        "  gain on its own model ({}): RR {:+.1} points, RR + SNR {:+.2}",
        o.model.name(),
        o.best_test.rr_pct - o.start_test.rr_pct,
        o.best_test.score() - o.start_test.score()
    );
    if let Some(g) = &o.perturbed {
        row("start, perturbed model", &g.start);
        row("optimised, perturbed model", &g.best);
        println!(
            "  gain on frames from a perturbed model ({:.0} % scatter per entry, {} draws): RR {:+.1} points, RR + SNR {:+.2}",
            100.0 * g.scatter_per_entry,
            g.draws,
            g.gain_rr_pct,
            g.gain_score
        );
    }
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
