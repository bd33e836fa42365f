//! `report.html` of `optimize`: one self-contained file, the verdict first (did the
//! search beat the start, and on what), then the design it chose, the tables, and the
//! charts inline (the same as the SVG files beside it).
//!
//! Sections are one function each, so a new part of the outcome is one more function
//! and one call in [`module_document`].

use crate::html::{Cell, Document, Table, Tone};
use crate::plot::Chart;
use anyhow::Result;
use fbgforge_optimize::module::{ChoiceResult, Evaluation, ModuleOutcome};

/// A chart and its caption.
pub(crate) type Figure<'a> = (&'a Chart, &'a str);

/// The module optimisation's report.
pub(crate) fn module_document(
    o: &ModuleOutcome,
    front: Option<&Chart>,
    figures: &[Figure],
) -> Result<Document> {
    let mut d = Document::new(format!("Optimised module: {}", o.design.name));
    module_verdict(&mut d, o);
    module_design(&mut d, o);
    module_constraints(&mut d, o);
    module_choices(&mut d, o);
    module_front(&mut d, o, front)?;
    d.section("Search");
    for (c, caption) in figures {
        d.chart(c, caption)?;
    }
    d.files(&[
        "summary.json",
        "pareto_front.svg",
        "pareto_front.csv",
        "convergence.svg",
        "convergence.csv",
        "landscape.svg",
        "landscape.csv",
    ]);
    Ok(d)
}

fn best_of(o: &ModuleOutcome) -> Option<&Evaluation> {
    o.choices.get(o.best_choice).and_then(|c| c.best.as_ref())
}

/// Smallest |K| over the strain gratings, pm/N (the one the objective is limited by).
fn weakest_k(e: &Evaluation) -> f64 {
    e.gratings
        .iter()
        .map(|g| g.sensitivity_pm_per_n)
        .fold(f64::NAN, |a, b| {
            if a.is_nan() || b.abs() < a.abs() {
                b
            } else {
                a
            }
        })
}

fn module_verdict(d: &mut Document, o: &ModuleOutcome) {
    let unit = o.objective_unit;
    let best = &o.choices[o.best_choice];
    let value = best_of(o).map_or(f64::NAN, |e| e.objective);
    let broken: Vec<String> = o
        .start
        .constraints
        .iter()
        .filter(|c| c.violation > 0.0)
        .map(|c| {
            format!(
                "the start breaks `{}`: {} ({})",
                c.name, c.detail, c.requirement
            )
        })
        .collect();
    let mut reasons = Vec::new();
    let (tone, headline) = if !o.start.feasible() {
        reasons.extend(broken);
        (Tone::Pass, "FEASIBLE DESIGN FOUND")
    } else if value > o.start.objective {
        reasons.push(format!(
            "objective {value:.4} {unit} against the start's {:.4} {unit} ({:+.1} %)",
            o.start.objective,
            100.0 * (value / o.start.objective.max(1e-300) - 1.0)
        ));
        (Tone::Pass, "IMPROVED")
    } else {
        reasons.push(format!(
            "no design beat the start's objective of {:.4} {unit}",
            o.start.objective
        ));
        (Tone::Warn, "NO IMPROVEMENT")
    };
    reasons.push(format!("model: {}", o.model));
    reasons.push(
        "the other choices were scored with the model policy anchored on their start; the winner was scored by the policy itself".into(),
    );
    d.verdict(
        tone,
        headline,
        &format!(
            "Best: {}, objective {value:.4} {unit}, in {:.2} s",
            best.choice, o.time_s
        ),
        &reasons,
    );
}

fn module_design(d: &mut Document, o: &ModuleOutcome) {
    d.section("Optimised design");
    let mut facts = vec![("choice", o.choices[o.best_choice].choice.to_string())];
    if let Some(m) = &o.design.module {
        facts.push(("outer diameter", format!("{:.3} mm", m.outer_diameter_mm)));
        facts.push(("overall height", format!("{:.3} mm", m.overall_height_mm)));
        facts.push(("dome height", format!("{:.3} mm", m.dome_height_mm)));
        facts.push(("cap wall", format!("{:.3} mm", m.cap_wall_mm)));
        facts.push(("core wall", format!("{:.3} mm", m.core_wall_mm)));
    }
    d.facts(&facts);
    if let Some(e) = best_of(o) {
        let mut t = Table::new(["grating", "K pm/N", "Δt_max s", "R²", "Q pm/(N·s)"]);
        for g in &e.gratings {
            t.row([
                g.grating.clone(),
                format!("{:.3}", g.sensitivity_pm_per_n),
                format!("{:.4}", g.dt_max_s),
                format!("{:.4}", g.r_squared),
                format!("{:.3}", g.quality_pm_per_n_s),
            ]);
        }
        d.table("gratings", &t);
    }
}

fn module_constraints(d: &mut Document, o: &ModuleOutcome) {
    let Some(e) = best_of(o) else { return };
    d.section("Constraints at the optimum");
    let mut t = Table::new(["constraint", "requires", "value", "status"]);
    for c in &e.constraints {
        t.row([
            Cell::from(c.name.clone()),
            c.requirement.clone().into(),
            c.detail.clone().into(),
            if c.violation > 0.0 {
                Cell::toned("broken", Tone::Fail)
            } else {
                Cell::toned("met", Tone::Pass)
            },
        ]);
    }
    d.table("constraints", &t);
}

fn module_choices(d: &mut Document, o: &ModuleOutcome) {
    d.section("Every material choice");
    let unit = o.objective_unit;
    let mut rows: Vec<&ChoiceResult> = o.choices.iter().collect();
    let score = |c: &ChoiceResult| c.best.as_ref().map_or(f64::NEG_INFINITY, |e| e.objective);
    rows.sort_by(|a, b| score(b).total_cmp(&score(a)));
    let mut t = Table::new([
        "choice".to_string(),
        format!("objective {unit}"),
        "weakest K pm/N".into(),
        "evaluations".into(),
        "variables".into(),
    ]);
    for c in rows {
        let evals: u64 = c.runs.iter().map(|r| r.evaluations).sum();
        match &c.best {
            Some(e) => t.row([
                c.choice.to_string(),
                format!("{:.4}", e.objective),
                format!("{:.3}", weakest_k(e)),
                evals.to_string(),
                o.variables
                    .iter()
                    .zip(&e.x)
                    .map(|(v, x)| format!("{} = {x:.3}", v.name()))
                    .collect::<Vec<_>>()
                    .join(", "),
            ]),
            None => t.rows.push(vec![
                c.choice.to_string().into(),
                Cell::toned("infeasible", Tone::Fail),
                "—".into(),
                evals.to_string().into(),
                "—".into(),
            ]),
        }
    }
    d.table("choices", &t);
}

/// The Pareto front: the chart, one row per non-dominated design, the ties.
fn module_front(d: &mut Document, o: &ModuleOutcome, front: Option<&Chart>) -> Result<()> {
    d.section("Pareto front");
    if let Some(c) = front {
        d.chart(
            c,
            "Non-dominated designs: sensitivity (scored over the contact window) against the force range before the strain or wavelength limit, one series per Δt_max; the knee and the written design marked.",
        )?;
    }
    let mut t = Table::new([
        "#",
        "choice",
        "|K| pm/N",
        "nominal pm/N",
        "range N",
        "limited by",
        "lag s",
        "R²",
        "",
    ]);
    for (i, f) in o.pareto_front.iter().enumerate() {
        let ob = &f.objectives;
        t.row([
            i.to_string(),
            f.choice.to_string(),
            format!("{:.3}", ob.sensitivity_pm_per_n),
            format!("{:.3}", ob.nominal_sensitivity_pm_per_n),
            format!("{:.2}", ob.force_range_n),
            ob.force_range_limited_by.to_string(),
            format!("{:.3}", ob.max_lag_s),
            format!("{:.6}", ob.r_squared),
            o.front_tag(i).to_string(),
        ]);
    }
    d.table("pareto-front", &t);
    let mut notes: Vec<String> = o
        .ties
        .iter()
        .map(|t| format!("ties and spreads: {t}"))
        .collect();
    notes.push(format!(
        "written: {} ({})",
        o.written_choice, o.written_because
    ));
    d.list(&notes);
    Ok(())
}
