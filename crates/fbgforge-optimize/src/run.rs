//! The optimisation use cases: [`run_module`] (module design for Q or sensitivity)
//! and [`run_placement`] (grating placement in a flat array). Each loads the design,
//! runs the search, writes the optimised design as TOML (it loads, builds, predicts
//! and verifies) and a report folder (summary JSON, SVG charts with their CSVs, and
//! `report.html` with the same charts inline: `report_html`).

use super::materials::MaterialLibrary;
use super::module::{
    landscape, model_predictor, optimise_module, ChoiceResult, LandscapePoint, ModuleOutcome,
    ModuleProblem, ModuleSettings, Objective, Predictor, Variable,
};
use super::place::{place, PlaceOutcome, PlaceSettings};
use super::quality::MeasuredPrototype;
use super::report_html;
use super::sheet;
use crate::output::{write_atomic, write_csv, write_json};
use crate::plot::{Chart, Mark, Series, Stroke};
use crate::progress::Progress;
use crate::solvers::SolverKind;
use crate::spec::Design;
use anyhow::Result;
use std::path::{Path, PathBuf};

/// What `run_module` optimises and where it writes.
#[derive(Debug, Clone)]
pub struct ModuleRequest {
    /// The start design (TOML).
    pub design: PathBuf,
    /// Material library (TOML); the shipped one when `None`.
    pub materials: Option<PathBuf>,
    /// Objective, variables, bounds, constraints and solvers.
    pub settings: ModuleSettings,
    /// `fbgforge verify --json` of a printed prototype, to calibrate lag and R².
    pub measured: Option<PathBuf>,
    /// The two variables of the landscape chart (the first two varied when `None`).
    pub landscape: Option<Vec<Variable>>,
    /// Where the optimised design goes (default: `out/optimize/<name>.toml`).
    pub out: Option<PathBuf>,
    /// Report folder (default: `<out stem>-report` beside the design).
    pub report_dir: Option<PathBuf>,
}

/// What `run_module` did.
#[derive(Debug, Clone)]
pub struct ModuleRun {
    /// The search's outcome (best design, every run).
    pub outcome: ModuleOutcome,
    /// Where the optimised design was written.
    pub design_path: PathBuf,
    /// Where the report was written.
    pub report_dir: PathBuf,
}

/// What `run_placement` optimises and where it writes.
#[derive(Debug, Clone)]
pub struct PlaceRequest {
    /// The array design (TOML).
    pub design: PathBuf,
    /// Objective, method, solvers.
    pub settings: PlaceSettings,
    /// Where the optimised design goes (default: `out/place/<name>.toml`).
    pub out: Option<PathBuf>,
    /// Report folder (default: `<out stem>-report` beside the design).
    pub report_dir: Option<PathBuf>,
}

/// What `run_placement` did.
#[derive(Debug, Clone)]
pub struct PlaceRun {
    /// The search's outcome.
    pub outcome: PlaceOutcome,
    /// Where the optimised design was written.
    pub design_path: PathBuf,
    /// Where the report was written.
    pub report_dir: PathBuf,
}

/// Optimise a module design: load it, search every material choice, write the
/// optimised design and the report, and return what was done; `progress` hears one
/// step per material choice.
pub fn run_module(req: &ModuleRequest, progress: &dyn Progress) -> Result<ModuleRun> {
    let design = crate::design::load(&req.design)?;
    let lib = match &req.materials {
        Some(p) => MaterialLibrary::load(p)?,
        None => MaterialLibrary::shipped(),
    };
    let settings = &req.settings;
    // Check the plot request before the work, so a typo costs nothing.
    let landscape_vars = match &req.landscape {
        Some(v) => {
            let v = v.clone();
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
    let measured = req
        .measured
        .as_deref()
        .map(MeasuredPrototype::load)
        .transpose()?;
    let predictor = model_predictor();
    let outcome = optimise_module(
        &design,
        &lib,
        settings,
        measured.as_ref(),
        predictor.clone(),
        progress,
    )?;
    let out = req.out.clone().unwrap_or_else(|| {
        PathBuf::from("out/optimize").join(format!("{}.toml", outcome.design.name))
    });
    let report_dir = req
        .report_dir
        .clone()
        .unwrap_or_else(|| report_beside(&out));
    write_design(&out, &outcome.design)?;
    write_module_report(
        &report_dir,
        &design,
        &lib,
        settings,
        &outcome,
        &landscape_vars,
        predictor,
    )?;
    Ok(ModuleRun {
        outcome,
        design_path: out,
        report_dir,
    })
}

/// Optimise grating placement: load the array design, search, write the design and
/// the report; `progress` hears the search's three stages.
pub fn run_placement(req: &PlaceRequest, progress: &dyn Progress) -> Result<PlaceRun> {
    let design = crate::design::load(&req.design)?;
    let outcome = place(&design, &req.settings, progress)?;
    let out = req.out.clone().unwrap_or_else(|| {
        PathBuf::from("out/place").join(format!("{}.toml", outcome.design.name))
    });
    let report_dir = req
        .report_dir
        .clone()
        .unwrap_or_else(|| report_beside(&out));
    write_design(&out, &outcome.design)?;
    write_place_report(&report_dir, &design, &req.settings, &outcome)?;
    Ok(PlaceRun {
        outcome,
        design_path: out,
        report_dir,
    })
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
pub fn write_design(path: &Path, d: &Design) -> Result<()> {
    let text = format!(
        "# Written by fbgforge; loads with `fbgforge build/predict/verify`.\n{}",
        d.to_toml()
    );
    crate::design::parse(&text)
        .map_err(|e| anyhow::anyhow!("internal: the written design does not load back: {e}"))?;
    write_atomic(path, text.as_bytes())
}

/// Convergence chart, landscape chart, their CSVs, the JSON summary and
/// `report.html`.
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
    let win = &o.choices[o.best_choice];
    let convergence = write_convergence(dir, win)?;
    let front = write_front(dir, o)?;
    // Landscape over two variables at the optimum of the winning choice.
    let idx: Vec<usize> = landscape_vars
        .iter()
        .map(|v| {
            o.variables.iter().position(|w| w == v).ok_or_else(|| {
                anyhow::anyhow!("--landscape variable `{}` is not in --vary", v.name())
            })
        })
        .collect::<Result<_>>()?;
    let mut landscape_chart_done = None;
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
        let vars = (landscape_vars[0], landscape_vars[1]);
        let chart = landscape_chart(o, win, &grid, vars, steps)?;
        chart.write_svg(&dir.join("landscape.svg"))?;
        write_landscape_csv(dir, &grid, vars)?;
        landscape_chart_done = Some(chart);
    }
    let mut figures: Vec<report_html::Figure> = vec![(&convergence, CONVERGENCE_CAPTION)];
    if let Some(c) = &landscape_chart_done {
        figures.push((c, "The objective over the two landscape variables, the others at the optimum: slices of the second variable; points the constraints cut off drawn apart."));
    }
    report_html::module_document(o, front.as_ref(), &figures)?.write(&dir.join("report.html"))
}

/// How to read a convergence chart.
const CONVERGENCE_CAPTION: &str = "Convergence of every run: the best cost so far above the lowest cost any run reached, on a log axis (a run that reached the lowest ends on the bottom line, at a dot). Runs that end at the same cost stay apart while they converge; the cost is −objective/scale for a feasible design, above 1 for an infeasible one.";

/// One run's history for [`convergence_chart`]: label, solver, start index, best cost
/// per iteration.
pub type RunHistory<'a> = (String, SolverKind, usize, &'a [f64]);

/// The convergence chart of several runs: each run's best cost above the lowest cost
/// any run reached, on a log axis, so runs that converge to nearly the same cost stay
/// apart (on a linear axis of the cost they draw over one another); colour by start,
/// dash by solver, a dot where each run ends. Returns the chart and, per run and
/// iteration, the gap it draws.
pub fn convergence_chart(title: &str, runs: &[RunHistory]) -> (Chart, Vec<Vec<f64>>) {
    let lowest = runs
        .iter()
        .flat_map(|r| r.3.iter().copied())
        .filter(|c| c.is_finite())
        .fold(f64::INFINITY, f64::min);
    // The bottom line: a tenth of the smallest gap above the lowest, so a run that
    // reached the lowest cost still has a place on the log axis.
    let smallest = runs
        .iter()
        .flat_map(|r| r.3.iter().map(|c| c - lowest))
        .filter(|g| g.is_finite() && *g > 0.0)
        .fold(f64::INFINITY, f64::min);
    let floor = if smallest.is_finite() {
        smallest / 10.0
    } else {
        1e-12 * lowest.abs().max(1.0)
    };
    let mut chart = Chart::new(
        title,
        "iteration",
        "best cost above the lowest reached (log)",
    );
    chart.y_log = true;
    let mut gaps = Vec::new();
    let mut ends = Vec::new();
    for (label, solver, start, history) in runs {
        let g: Vec<f64> = history.iter().map(|c| (c - lowest).max(floor)).collect();
        let pts: Vec<(f64, f64)> = g
            .iter()
            .enumerate()
            .map(|(i, c)| (i as f64 + 1.0, *c))
            .collect();
        let dash = match solver {
            SolverKind::NelderMead => Stroke::Solid,
            SolverKind::ParticleSwarm => Stroke::Dashed,
            SolverKind::DifferentialEvolution => Stroke::DashDot,
        };
        if let Some(&last) = pts.last() {
            ends.push((last, *start));
        }
        chart = chart.with(
            Series::new(label.clone(), pts, Mark::Line)
                .with_color(*start)
                .with_stroke(dash)
                .with_role("run"),
        );
        gaps.push(g);
    }
    for (p, start) in ends {
        chart = chart.with(
            Series::new("", vec![p], Mark::Points)
                .with_color(start)
                .with_role("run-end"),
        );
    }
    (chart, gaps)
}

/// Convergence of every run of the winning choice (best penalised cost per
/// iteration): chart and CSV.
fn write_convergence(dir: &Path, win: &ChoiceResult) -> Result<Chart> {
    let runs: Vec<RunHistory> = win
        .runs
        .iter()
        .map(|r| {
            (
                format!("{} start {}", r.solver.name(), r.start),
                r.solver,
                r.start,
                r.history.as_slice(),
            )
        })
        .collect();
    let (chart, gaps) = convergence_chart(&format!("Convergence, {}", win.choice), &runs);
    let mut rows = Vec::new();
    for (r, g) in win.runs.iter().zip(&gaps) {
        for (i, (c, gap)) in r.history.iter().zip(g).enumerate() {
            rows.push(vec![
                r.solver.name().to_string(),
                r.start.to_string(),
                (i + 1).to_string(),
                c.to_string(),
                gap.to_string(),
            ]);
        }
    }
    chart.write_svg(&dir.join("convergence.svg"))?;
    write_csv(
        &dir.join("convergence.csv"),
        &["solver", "start", "iteration", "best_cost", "above_lowest"],
        &rows,
    )?;
    Ok(chart)
}

/// The Pareto front: sensitivity against force range, one colour per lag, the knee and
/// the written design marked; chart and CSV of the same numbers.
fn write_front(dir: &Path, o: &ModuleOutcome) -> Result<Option<Chart>> {
    let mut chart = Chart::new(
        format!(
            "Pareto front ({} designs): sensitivity against force range, by lag",
            o.pareto_front.len()
        ),
        "force range before the strain or wavelength limit (N)",
        "sensitivity |K|, scored over the contact window (pm/N)",
    );
    let mut lags: Vec<f64> = o
        .pareto_front
        .iter()
        .map(|f| (f.objectives.max_lag_s * 1e3).round() / 1e3)
        .collect();
    lags.sort_by(f64::total_cmp);
    lags.dedup();
    for lag in &lags {
        let pts: Vec<(f64, f64)> = o
            .pareto_front
            .iter()
            .filter(|f| ((f.objectives.max_lag_s * 1e3).round() / 1e3 - lag).abs() < 1e-12)
            .map(|f| {
                (
                    f.objectives.force_range_n,
                    f.objectives.sensitivity_pm_per_n,
                )
            })
            .collect();
        chart = chart.with(Series::new(
            format!("Δt_max = {lag:.3} s"),
            pts,
            Mark::LinePoints,
        ));
    }
    let marked = |pick: &dyn Fn(usize, &super::module::FrontDesign) -> bool| -> Vec<(f64, f64)> {
        o.pareto_front
            .iter()
            .enumerate()
            .filter(|(i, f)| pick(*i, f))
            .map(|(_, f)| {
                (
                    f.objectives.force_range_n,
                    f.objectives.sensitivity_pm_per_n,
                )
            })
            .collect()
    };
    let knee = marked(&|_, f| f.knee);
    if !knee.is_empty() {
        chart = chart.with(Series::new("knee", knee, Mark::Points));
    }
    let written = marked(&|i, _| o.written_front_index == Some(i));
    if !written.is_empty() {
        chart = chart.with(Series::new(
            format!("written (--prefer {})", o.prefer.name()),
            written,
            Mark::Points,
        ));
    }
    let chart = if chart.series.is_empty() {
        None
    } else {
        chart.write_svg(&dir.join("pareto_front.svg"))?;
        Some(chart)
    };
    let mut header: Vec<String> = vec!["core_material".into(), "insert_material".into()];
    header.extend(o.variables.iter().map(|v| v.name().to_string()));
    header.extend(
        [
            "sensitivity_pm_per_n",
            "nominal_sensitivity_pm_per_n",
            "force_range_n",
            "force_range_limited_by",
            "max_lag_s",
            "r_squared",
            "quality_pm_per_n_s",
            "knee",
            "written",
        ]
        .map(String::from),
    );
    let rows: Vec<Vec<String>> = o
        .pareto_front
        .iter()
        .enumerate()
        .map(|(i, f)| {
            let ob = &f.objectives;
            let mut r = vec![
                f.choice.core_material.clone(),
                f.choice
                    .insert_material
                    .clone()
                    .unwrap_or_else(|| "none".into()),
            ];
            r.extend(f.evaluation.x.iter().map(|x| x.to_string()));
            r.extend([
                ob.sensitivity_pm_per_n.to_string(),
                ob.nominal_sensitivity_pm_per_n.to_string(),
                ob.force_range_n.to_string(),
                ob.force_range_limited_by.to_string(),
                ob.max_lag_s.to_string(),
                ob.r_squared.to_string(),
                ob.quality_pm_per_n_s.to_string(),
                f.knee.to_string(),
                (o.written_front_index == Some(i)).to_string(),
            ]);
            r
        })
        .collect();
    let header: Vec<&str> = header.iter().map(String::as_str).collect();
    write_csv(&dir.join("pareto_front.csv"), &header, &rows)?;
    Ok(chart)
}

/// The landscape chart: feasible slices of the second variable, infeasible points apart.
fn landscape_chart(
    o: &ModuleOutcome,
    win: &ChoiceResult,
    grid: &[LandscapePoint],
    (va, vb): (Variable, Variable),
    steps: usize,
) -> Result<Chart> {
    let mut chart = Chart::new(
        format!(
            "{} landscape, {}",
            match o.objective {
                Objective::Q => "Q",
                Objective::Sensitivity => "|K|",
                Objective::ForceRange => "force range",
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
    Ok(chart)
}

/// The landscape's points as CSV (objective empty where the model could not evaluate).
fn write_landscape_csv(
    dir: &Path,
    grid: &[LandscapePoint],
    (va, vb): (Variable, Variable),
) -> Result<()> {
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
    )
}

/// The placement's report: summary JSON, the layout on the sheet (`layout.svg` and
/// `layout.csv`), convergence, the proxy's agreement, and `report.html`.
fn write_place_report(
    dir: &Path,
    start: &Design,
    settings: &PlaceSettings,
    o: &PlaceOutcome,
) -> Result<()> {
    write_json(&dir.join("summary.json"), o)?;
    let (Some(from), Some(to)) = (&start.array, &o.design.array) else {
        anyhow::bail!("internal: a placement without an [array] section");
    };
    // The start as the search saw it (clamped into the box), so start and chosen are
    // drawn on the same terms.
    let mut from = from.clone();
    for (g, &y) in from.gratings.iter_mut().zip(&o.start_x) {
        g.y_mm = y;
    }
    if o.start_x.len() == from.gratings.len() + from.fiber_x_mm.len() {
        let n = from.gratings.len();
        from.fiber_x_mm = o.start_x[n..].to_vec();
    }
    let title = format!("Layout of {}: start and chosen", o.design.name);
    let (svg, _, _) = sheet::layout_svg(&from, to, &title, true);
    write_atomic(&dir.join("layout.svg"), svg.as_bytes())?;
    let (inline, _, _) = sheet::layout_svg(&from, to, &title, false);
    write_csv(
        &dir.join("layout.csv"),
        &sheet::LAYOUT_HEADER,
        &sheet::layout_rows(&from, to),
    )?;
    let runs: Vec<RunHistory> = o
        .runs
        .iter()
        .enumerate()
        .map(|(i, r)| {
            (
                r.solver.name().to_string(),
                r.solver,
                i,
                r.history.as_slice(),
            )
        })
        .collect();
    let (chart, gaps) = convergence_chart("Placement convergence", &runs);
    let mut rows = Vec::new();
    for (r, g) in o.runs.iter().zip(&gaps) {
        for (i, (c, gap)) in r.history.iter().zip(g).enumerate() {
            rows.push(vec![
                r.solver.name().to_string(),
                (i + 1).to_string(),
                c.to_string(),
                gap.to_string(),
            ]);
        }
    }
    chart.write_svg(&dir.join("convergence.svg"))?;
    write_csv(
        &dir.join("convergence.csv"),
        &["solver", "iteration", "best_cost", "above_lowest"],
        &rows,
    )?;
    let mut agreement = None;
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
        agreement = Some(chart);
    }
    let mut figures: Vec<report_html::Figure> = vec![(&chart, CONVERGENCE_CAPTION)];
    if let Some(c) = &agreement {
        figures.push((c, "Random layouts: the coherence proxy against the protocol score (lower coherence should score higher)."));
    }
    report_html::place_document(o, settings.test_seeds.len(), &inline, &figures)?
        .write(&dir.join("report.html"))
}
