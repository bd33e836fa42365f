//! `fbgforge optimize` and `fbgforge place`: design optimisation from the command
//! line (the work is in `fbgforge::optimize::run`).

use super::progress::Bar;
use anyhow::Result;
use clap::Args;
use fbgforge::optimize::module::{
    parse_bounds, ModuleOutcome, ModuleSettings, Objective, Preference, Variable,
};
use fbgforge::optimize::place::{PlaceObjective, PlaceOutcome, PlaceSettings};
use fbgforge::optimize::run::{run_module, run_placement, ModuleRequest, PlaceRequest};
use fbgforge::prediction::Robustness;
use fbgforge::solvers::SolverKind;
use std::path::PathBuf;

/// This subcommand's request fields and the flags that fill them (`cli::hiargs`).
pub const FLAGS: &[(&str, &str)] = &[];

/// Arguments of `fbgforge optimize`.
#[derive(Debug, Args)]
pub struct OptimizeArgs {
    /// Start design (TOML with a [module] section).
    pub design: PathBuf,
    /// What the table ranks by: q (|K|·R²/Δt_max), sensitivity (|K|) or force-range
    /// (the largest force before the strain or wavelength limit).
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
    /// How K is scored over the model's own uncertainty about the domes' contact
    /// (radius 1.30–1.48 × the apex patch): `worst` (smallest |K| scored, largest held
    /// to the limits), `quantile:P` (e.g. quantile:0.1) or `nominal`.
    #[arg(long, default_value = "worst")]
    pub robust: String,
    /// Interrogator sample rate, Hz: Δt_max is never below one sample period (default:
    /// the design's interrogator_rate_hz, 2 Hz when absent, or the --measured log's).
    #[arg(long)]
    pub rate_hz: Option<f64>,
    /// Which design of the Pareto front to write: knee, objective (the table's best by
    /// --objective), sensitivity, force-range, lag or r-squared.
    #[arg(long, default_value = "knee")]
    pub prefer: String,
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
        robustness: Robustness::parse(&a.robust)?,
        rate_hz: a.rate_hz,
        prefer: Preference::parse(&a.prefer)?,
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

/// Width the printed tables keep to, columns (a terminal's default).
const WIDTH: usize = 80;

/// Append `text` word-wrapped to [`WIDTH`] columns; continuation lines are indented
/// by `indent` spaces.
fn wrapped(out: &mut String, text: &str, indent: usize) {
    let lead = text.len() - text.trim_start_matches(' ').len();
    let mut line = " ".repeat(lead);
    let mut fresh = true;
    for word in text.split(' ').filter(|w| !w.is_empty()) {
        if !fresh && line.chars().count() + 1 + word.chars().count() > WIDTH {
            out.push_str(&line);
            out.push('\n');
            line = " ".repeat(indent);
            fresh = true;
        }
        if !fresh {
            line.push(' ');
        }
        line.push_str(word);
        fresh = false;
    }
    out.push_str(&line);
    out.push('\n');
}

/// The module optimisation as text, every line within [`WIDTH`] columns: the start,
/// one row per material choice with its variables on the lines below, the best.
pub fn module_table(o: &ModuleOutcome) -> String {
    use fbgforge::optimize::module::ChoiceResult;
    use std::fmt::Write as _;
    let unit = o.objective_unit;
    let mut s = String::new();
    wrapped(
        &mut s,
        &format!(
            "start ({}): objective {:.4} {unit} (nominal {:.4}), {}",
            o.start_choice,
            o.start.objective,
            o.start.nominal_objective,
            if o.start.feasible() {
                "feasible"
            } else {
                "infeasible"
            }
        ),
        4,
    );
    wrapped(
        &mut s,
        &format!(
            "scored: {}; Δt_max floor at {:.3} Hz",
            o.robustness, o.rate_hz
        ),
        4,
    );
    let mut rows: Vec<(usize, &ChoiceResult)> = o.choices.iter().enumerate().collect();
    let value = |c: &ChoiceResult| c.best.as_ref().map(|e| e.objective).unwrap_or(-1.0);
    rows.sort_by(|a, b| value(b.1).total_cmp(&value(a.1)));
    // mark 1 + choice 28 + objective 13 + nominal 11 + scored 9 + K 10 + evals 7 = 79.
    const NAME: usize = 28;
    let _ = writeln!(
        s,
        " {:<NAME$} {:>12} {:>10} {:>8} {:>9} {:>6}",
        "choice (variables below)",
        format!("obj {unit}"),
        "nominal",
        "scored",
        "K pm/N",
        "evals"
    );
    for (i, c) in rows {
        let evals: u64 = c.runs.iter().map(|r| r.evaluations).sum();
        let mark = if i == o.best_choice { "*" } else { " " };
        let mut name = c.choice.to_string();
        if name.chars().count() > NAME {
            // A long choice gets its own line; the numbers go on the next.
            let _ = writeln!(s, "{mark}{name}");
            name = String::new();
        }
        let scored = |exact: bool| if exact { "policy" } else { "estimate" };
        match &c.best {
            Some(e) => {
                let k = e
                    .gratings
                    .iter()
                    .map(|g| g.sensitivity_pm_per_n)
                    .fold(0.0f64, |a, k| if k.abs() > a.abs() { k } else { a });
                let _ = writeln!(
                    s,
                    "{mark}{name:<NAME$} {:>12.4} {:>10.4} {:>8} {:>9.3} {:>6}",
                    e.objective,
                    e.nominal_objective,
                    scored(e.exact),
                    k,
                    evals
                );
                wrapped(&mut s, &format!("    {}", x_text(&o.variables, &e.x)), 4);
            }
            None => {
                let lv = c.least_violating.as_ref();
                let _ = writeln!(
                    s,
                    "{mark}{name:<NAME$} {:>12} {:>10} {:>8} {:>9} {:>6}",
                    "infeasible",
                    "-",
                    scored(lv.is_some_and(|e| e.exact)),
                    "-",
                    evals
                );
                if let Some(k) = lv.and_then(|e| e.constraints.iter().find(|k| k.violation > 0.0)) {
                    wrapped(&mut s, &format!("    violates {}: {}", k.name, k.detail), 4);
                }
            }
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
    wrapped(
        &mut s,
        &format!(
            "best: {} objective {value:.4} {unit} ({versus}), the table's best (*); 'policy' rows are scored on the model policy at their design, 'estimate' rows (the search's estimate) lie below the best",
            best.choice
        ),
        6,
    );
    wrapped(
        &mut s,
        &format!(
            "Pareto front ({} designs; objectives: sensitivity ↑, force range ↑, lag ↓, R² ↑):",
            o.pareto_front.len()
        ),
        4,
    );
    for (i, f) in o.pareto_front.iter().enumerate() {
        let ob = &f.objectives;
        let tag = match o.front_tag(i) {
            "" => String::new(),
            t => format!(" ({t})"),
        };
        wrapped(&mut s, &format!("  {i:<2} {}{tag}", f.choice), 7);
        wrapped(
            &mut s,
            &format!(
                "     |K| {:.3} pm/N (nominal {:.3}), range {:.2} N (limited by {}), lag {:.3} s, R² {:.6}",
                ob.sensitivity_pm_per_n,
                ob.nominal_sensitivity_pm_per_n,
                ob.force_range_n,
                ob.force_range_limited_by,
                ob.max_lag_s,
                ob.r_squared
            ),
            7,
        );
        wrapped(
            &mut s,
            &format!("     {}", x_text(&o.variables, &f.evaluation.x)),
            7,
        );
    }
    for t in &o.ties {
        wrapped(&mut s, &format!("ties and spreads: {t}"), 4);
    }
    wrapped(
        &mut s,
        &format!(
            "written: {} ({}), objective {:.4} {unit} scored, {:.4} nominal, in {:.2} s",
            o.written_choice,
            o.written_because,
            o.written.objective,
            o.written.nominal_objective,
            o.time_s
        ),
        4,
    );
    for r in &o.written.readings {
        let window = r
            .contact_window_pm_per_n
            .map_or("-".to_string(), |[a, b]| format!("{a:+.1} … {b:+.1}"));
        wrapped(
            &mut s,
            &format!(
                "  {}: K {:+.3} pm/N nominal, contact window {window}, bounding readings {:+.1} (bonded) … {:+.1} (sliding) pm/N",
                r.grating, r.nominal_pm_per_n, r.bonded_pillars_pm_per_n, r.sliding_apex_patch_pm_per_n
            ),
            4,
        );
    }
    wrapped(
        &mut s,
        &format!(
            "model: {} (other choices: scored with the policy anchored on their start)",
            o.model
        ),
        6,
    );
    if let Some(m) = o.design.module.as_ref() {
        wrapped(
            &mut s,
            &format!(
                "      D {:.3} mm, H {:.3} mm, dome {:.3} mm, cap wall {:.3} mm, core wall {:.3} mm",
                m.outer_diameter_mm,
                m.overall_height_mm,
                m.dome_height_mm,
                m.cap_wall_mm,
                m.core_wall_mm
            ),
            6,
        );
        if m.contact_radius_is_default() && o.written_choice.insert_material.is_some() {
            wrapped(
                &mut s,
                &format!("note: {}", fbgforge::prediction::DEFAULT_CONTACT_WARNING),
                6,
            );
        }
    }
    s
}

fn x_text(vars: &[Variable], x: &[f64]) -> String {
    vars.iter()
        .zip(x)
        .map(|(v, x)| format!("{}={x:.3}", v.name()))
        .collect::<Vec<_>>()
        .join(" ")
}

fn print_module_table(o: &ModuleOutcome) {
    print!("{}", module_table(o));
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
    print!("{}", place_table(o));
}

/// The placement as text, every line within [`WIDTH`] columns.
pub fn place_table(o: &PlaceOutcome) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    wrapped(
        &mut s,
        &format!(
            "objective {:?}, method {}: start {:.4}, optimised {:.4} (training seeds)",
            o.objective, o.method, o.start_objective, o.best_objective
        ),
        4,
    );
    if let Some(a) = &o.design.array {
        let _ = writeln!(
            s,
            "{:<10} {:>8} {:>12} {:>12}",
            "grating", "fiber", "start y mm", "y mm"
        );
        for (i, g) in a.gratings.iter().enumerate() {
            let _ = writeln!(
                s,
                "{:<10} {:>8} {:>12.2} {:>12.2}",
                g.name, g.fiber, o.start_x[i], g.y_mm
            );
        }
        let xs: Vec<String> = a.fiber_x_mm.iter().map(|x| format!("{x:.2}")).collect();
        wrapped(
            &mut s,
            &format!("fiber x mm (mold slits): {}", xs.join(", ")),
            4,
        );
    }
    let _ = writeln!(
        s,
        "{:<16} {:>14} {:>10} {:>10} {:>10}",
        "solver", "best objective", "iters", "evals", "time s"
    );
    for r in &o.runs {
        let _ = writeln!(
            s,
            "{:<16} {:>14.4} {:>10} {:>10} {:>10.2}",
            r.solver.name(),
            r.best_objective,
            r.iterations,
            r.evaluations,
            r.time_s
        );
    }
    let _ = writeln!(
        s,
        "held-out protocol (penalty tuned):  RR %   mean SNR dB   coherence"
    );
    let row = |s: &mut String, name: &str, t: &fbgforge::optimize::place::LayoutScore| {
        let _ = writeln!(
            s,
            "  {name:<32} {:>6.1} {:>12.2} {:>11.3}",
            t.rr_pct, t.mean_snr_db, t.mutual_coherence
        );
    };
    row(&mut s, "start layout", &o.start_test);
    row(&mut s, "optimised layout", &o.best_test);
    wrapped(
        &mut s,
        &format!(
            "  gain on its own model ({}): RR {:+.1} points, RR + SNR {:+.2}",
            o.model.name(),
            o.best_test.rr_pct - o.start_test.rr_pct,
            o.best_test.score() - o.start_test.score()
        ),
        4,
    );
    if let Some(g) = &o.perturbed {
        row(&mut s, "start, perturbed model", &g.start);
        row(&mut s, "optimised, perturbed model", &g.best);
        wrapped(
            &mut s,
            &format!(
                "  gain on frames from a perturbed model ({:.0} % scatter per entry, {} draws): RR {:+.1} points, RR + SNR {:+.2}",
                100.0 * g.scatter_per_entry,
                g.draws,
                g.gain_rr_pct,
                g.gain_score
            ),
            4,
        );
    }
    wrapped(
        &mut s,
        "  by number of loads (paper Table 3: RR 100/100/100/90 %, SNR 25.4/25.2/23.3/19.7 dB):",
        4,
    );
    let _ = writeln!(
        s,
        "    {:<8} {:>12} {:>12} {:>12} {:>12}",
        "loads", "start RR %", "SNR dB", "optim. RR %", "SNR dB"
    );
    for (a, b) in o
        .start_test
        .by_load_count
        .iter()
        .zip(&o.best_test.by_load_count)
    {
        let _ = writeln!(
            s,
            "    {:<8} {:>12.1} {:>12.2} {:>12.1} {:>12.2}",
            a.0, a.1, a.2, b.1, b.2
        );
    }
    if let Some(ag) = &o.agreement {
        wrapped(
            &mut s,
            &format!(
                "coherence proxy vs protocol score: Spearman {:.2} over {} random layouts",
                ag.spearman_coherence_vs_score, ag.samples
            ),
            4,
        );
    }
    let _ = writeln!(s, "in {:.1} s", o.time_s);
    s
}
