//! The charts of a module optimisation's report, each with the CSV of its numbers:
//! convergence of every run, the Pareto front, and the landscape around the optimum.

use super::InWords;
use crate::output::write_csv;
use crate::plot::{Chart, Mark, Series, Stroke};
use anyhow::Result;
use fbgforge_model::solvers::SolverKind;
use fbgforge_optimize::module::{ChoiceResult, FrontDesign, ModuleOutcome};
use fbgforge_optimize::run::Landscape;
use std::path::Path;

/// How to read a convergence chart.
pub(crate) const CONVERGENCE_CAPTION: &str = "Convergence of every run: the best cost so far above the lowest cost any run reached, on a log axis (a run that reached the lowest ends on the bottom line, at a dot). Runs that end at the same cost stay apart while they converge; the cost is −objective/scale for a feasible design, above 1 for an infeasible one.";

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
pub(super) fn write_convergence(dir: &Path, win: &ChoiceResult) -> Result<Chart> {
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
/// the written design marked (`None` when the front is empty).
fn front_chart(o: &ModuleOutcome, words: InWords) -> Option<Chart> {
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
    let marked = |pick: &dyn Fn(usize, &FrontDesign) -> bool| -> Vec<(f64, f64)> {
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
            words(&format!(
                "written (ModuleSettings.prefer {})",
                o.prefer.name()
            )),
            written,
            Mark::Points,
        ));
    }
    (!chart.series.is_empty()).then_some(chart)
}

/// The front's designs as CSV rows, under their header: choice, variables, objectives,
/// knee and written.
fn front_rows(o: &ModuleOutcome) -> (Vec<String>, Vec<Vec<String>>) {
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
    (header, rows)
}

/// The Pareto front's chart (when it has a design) and CSV of the same numbers.
pub(super) fn write_front(dir: &Path, o: &ModuleOutcome, words: InWords) -> Result<Option<Chart>> {
    let chart = front_chart(o, words);
    if let Some(c) = &chart {
        c.write_svg(&dir.join("pareto_front.svg"))?;
    }
    let (header, rows) = front_rows(o);
    let header: Vec<&str> = header.iter().map(String::as_str).collect();
    write_csv(&dir.join("pareto_front.csv"), &header, &rows)?;
    Ok(chart)
}

/// The landscape chart: feasible slices of the second variable, infeasible points apart.
pub(super) fn landscape_chart(
    o: &ModuleOutcome,
    win: &ChoiceResult,
    l: &Landscape,
) -> Result<Chart> {
    let (grid, (va, vb), steps) = (&l.points, l.variables, l.steps);
    let mut chart = Chart::new(
        format!("{} landscape, {}", o.objective.symbol(), win.choice),
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
pub(super) fn write_landscape_csv(dir: &Path, l: &Landscape) -> Result<()> {
    let (grid, (va, vb)) = (&l.points, l.variables);
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
