//! The module optimisation as text, every line within [`super::WIDTH`] columns: the
//! start, one row per material choice with its variables on the lines below, the best,
//! the Pareto front, and the design written.

use super::{wrapped, InWords};
use fbgforge_optimize::module::{ChoiceResult, Evaluation, ModuleOutcome, Variable};
use std::fmt::Write as _;

/// Width of the choice column: mark 1 + choice 28 + objective 13 + nominal 11 +
/// scored 9 + K 10 + evals 7 = 79.
const NAME: usize = 28;

/// The module optimisation as text (see the module doc), naming options in `words`
/// (before the lines are wrapped, so they keep to the width in the reader's words).
pub fn module_table(o: &ModuleOutcome, words: InWords) -> String {
    let mut s = String::new();
    start_lines(&mut s, o);
    choice_rows(&mut s, o, words);
    best_line(&mut s, o, words);
    front_lines(&mut s, o, words);
    written_lines(&mut s, o, words);
    s
}

/// The start and how designs were scored.
fn start_lines(s: &mut String, o: &ModuleOutcome) {
    let unit = o.objective_unit;
    wrapped(
        s,
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
        s,
        &format!(
            "scored: {}; Δt_max floor at {:.3} Hz",
            o.robustness, o.rate_hz
        ),
        4,
    );
}

/// One row per choice, best first, its variables (or the constraint it breaks) below.
fn choice_rows(s: &mut String, o: &ModuleOutcome, words: InWords) {
    let unit = o.objective_unit;
    let mut rows: Vec<(usize, &ChoiceResult)> = o.choices.iter().enumerate().collect();
    let value = |c: &ChoiceResult| c.best.as_ref().map(|e| e.objective).unwrap_or(-1.0);
    rows.sort_by(|a, b| value(b.1).total_cmp(&value(a.1)));
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
        match &c.best {
            Some(e) => feasible_row(s, o, (mark, &name), e, evals),
            None => infeasible_row(s, c, (mark, &name), evals, words),
        }
    }
}

/// How a row was scored.
fn scored(exact: bool) -> &'static str {
    if exact {
        "policy"
    } else {
        "estimate"
    }
}

fn feasible_row(
    s: &mut String,
    o: &ModuleOutcome,
    (mark, name): (&str, &str),
    e: &Evaluation,
    evals: u64,
) {
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
    wrapped(s, &format!("    {}", x_text(&o.variables, &e.x)), 4);
}

fn infeasible_row(
    s: &mut String,
    c: &ChoiceResult,
    (mark, name): (&str, &str),
    evals: u64,
    words: InWords,
) {
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
        wrapped(
            s,
            &words(&format!("    violates {}: {}", k.name, k.detail)),
            4,
        );
    }
}

/// The table's best against the start.
fn best_line(s: &mut String, o: &ModuleOutcome, words: InWords) {
    let unit = o.objective_unit;
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
        words(&format!("the start is infeasible, {}", broken.join("; ")))
    };
    wrapped(
        s,
        &format!(
            "best: {} objective {value:.4} {unit} ({versus}), the table's best (*); 'policy' rows are scored on the model policy at their design, 'estimate' rows (the search's estimate) lie below the best",
            best.choice
        ),
        6,
    );
}

/// The Pareto front, one design a few lines, and where the objectives tie.
fn front_lines(s: &mut String, o: &ModuleOutcome, words: InWords) {
    wrapped(
        s,
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
        wrapped(s, &format!("  {i:<2} {}{tag}", f.choice), 7);
        wrapped(
            s,
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
            s,
            &format!("     {}", x_text(&o.variables, &f.evaluation.x)),
            7,
        );
        if !f.paper_statements_failed.is_empty() {
            wrapped(
                s,
                &format!(
                    "     paper_statements_failed: {}",
                    f.paper_statements_failed.join(", ")
                ),
                7,
            );
        }
    }
    for d in &o.front_dropped_objectives {
        wrapped(s, &words(&format!("dropped from the front: {d}")), 4);
    }
    for t in &o.ties {
        wrapped(s, &words(&format!("ties and spreads: {t}")), 4);
    }
}

/// The design written: why, its readings, the model and its dimensions.
fn written_lines(s: &mut String, o: &ModuleOutcome, words: InWords) {
    let unit = o.objective_unit;
    wrapped(
        s,
        &words(&format!(
            "written: {} ({}), objective {:.4} {unit} scored, {:.4} nominal, in {:.2} s",
            o.written_choice,
            o.written_because,
            o.written.objective,
            o.written.nominal_objective,
            o.time_s
        )),
        4,
    );
    wrapped(
        s,
        &format!(
            "paper_statements_failed: {}",
            if o.paper_statements_failed.is_empty() {
                "none (every statement predict checks holds on the written design)".to_string()
            } else {
                o.paper_statements_failed.join(", ")
            }
        ),
        4,
    );
    for r in &o.written.readings {
        let [lo, hi] = r.design_interval_pm_per_n;
        wrapped(
            s,
            &format!(
                "  {}: K {:+.3} pm/N nominal ± {:.1} % model error, design interval {lo:+.1} … {hi:+.1}, bounding readings {:+.1} (bonded) … {:+.1} (sliding) pm/N",
                r.grating,
                r.nominal_pm_per_n,
                100.0 * r.model_error_fraction,
                r.bonded_pillars_pm_per_n,
                r.sliding_apex_patch_pm_per_n
            ),
            4,
        );
    }
    if let Some(m) = o.written.margins {
        wrapped(
            s,
            &format!(
                "  margins at the far end of the design interval: strain {:.0} µε ({:.1} % of the limit; {:.0} % required), wavelength window {:.3} nm{}",
                m.grating_strain_microstrain,
                m.grating_strain_percent,
                m.required_strain_margin_percent,
                m.wavelength_window_nm,
                m.snap_strain_percent
                    .map_or(String::new(), |v| format!(", snap strain {v:.2} %"))
            ),
            4,
        );
    }
    wrapped(
        s,
        &format!(
            "model: {} (other choices: scored with the policy anchored on their start)",
            o.model
        ),
        6,
    );
    if let Some(m) = o.design.module.as_ref() {
        wrapped(
            s,
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
                s,
                &words(&format!(
                    "note: {}",
                    crate::prediction::DEFAULT_CONTACT_WARNING
                )),
                6,
            );
        }
    }
    // The outcome's other warnings (the default contact's is the note above).
    let contact = format!("Case I: {}", crate::prediction::DEFAULT_CONTACT_WARNING);
    for w in o.warnings.iter().filter(|w| **w != contact) {
        wrapped(s, &words(&format!("warning: {w}")), 6);
    }
}

fn x_text(vars: &[Variable], x: &[f64]) -> String {
    vars.iter()
        .zip(x)
        .map(|(v, x)| format!("{}={x:.3}", v.name()))
        .collect::<Vec<_>>()
        .join(" ")
}
