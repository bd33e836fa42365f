//! `report.html` of `optimize` and of `place`: one self-contained file each, the
//! verdict first (did the search beat the start, and on what), then the design or
//! layout it chose, the tables, and the charts inline (the same as the SVG files
//! beside it).
//!
//! Sections are one function each, so a new part of the outcome is one more function
//! and one call in [`module_document`] or [`place_document`].

use super::module::{ChoiceResult, Evaluation, ModuleOutcome};
use super::place::{LayoutScore, PlaceOutcome};
use crate::array::protocol::ProtocolConfig;
use crate::html::{Cell, Document, Table, Tone};
use crate::plot::Chart;
use anyhow::Result;

/// A chart and its caption.
pub type Figure<'a> = (&'a Chart, &'a str);

/// The module optimisation's report.
pub fn module_document(
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

/// Tests in one seed of the protocol the placement scores on.
fn protocol_tests_per_seed() -> usize {
    let p = ProtocolConfig::paper(0);
    p.masses_g.len() * p.singles_per_mass + p.multi_load_counts.len() * p.configs_per_count
}

/// The placement's report; `test_seeds`: how many held-out seeds scored the layouts.
pub fn place_document(
    o: &PlaceOutcome,
    test_seeds: usize,
    layout_svg: &str,
    figures: &[Figure],
) -> Result<Document> {
    let mut d = Document::new(format!("Grating placement: {}", o.design.name));
    place_verdict(&mut d, o, test_seeds);
    d.section("Chosen layout");
    d.svg_figure(
        layout_svg,
        "The sheet to scale: each grating where the start layout had it (dashed outline) and where the chosen layout puts it (filled), on its fiber; the cells as the reconstruction labels them.",
    );
    if let Some(a) = &o.design.array {
        let mut t = Table::new(["grating", "fiber", "start y mm", "chosen y mm"]);
        for (i, g) in a.gratings.iter().enumerate() {
            t.row([
                g.name.clone(),
                g.fiber.to_string(),
                o.start_x
                    .get(i)
                    .map_or("—".to_string(), |y| format!("{y:.2}")),
                format!("{:.2}", g.y_mm),
            ]);
        }
        d.table("layout", &t);
        let xs: Vec<String> = a.fiber_x_mm.iter().map(|x| format!("{x:.2}")).collect();
        d.note(&format!("Fiber x (mold slits), mm: {}.", xs.join(", ")));
    }
    place_scores(&mut d, o);
    d.section("Search");
    let mut t = Table::new([
        "solver",
        "best objective",
        "iterations",
        "evaluations",
        "time s",
    ]);
    for r in &o.runs {
        t.row([
            r.solver.name().to_string(),
            format!("{:.4}", r.best_objective),
            r.iterations.to_string(),
            r.evaluations.to_string(),
            format!("{:.2}", r.time_s),
        ]);
    }
    d.table("solvers", &t);
    for (c, caption) in figures {
        d.chart(c, caption)?;
    }
    if let Some(ag) = &o.agreement {
        d.note(&format!(
            "Coherence proxy against the protocol score: Spearman {:.2} over {} random layouts.",
            ag.spearman_coherence_vs_score, ag.samples
        ));
    }
    d.files(&[
        "summary.json",
        "layout.svg",
        "layout.csv",
        "convergence.svg",
        "convergence.csv",
    ]);
    Ok(d)
}

/// The chosen layout against the start on the held-out protocol of `n` tests: the
/// tone, the headline and the reasons. Better only when RR and SNR both improve; mixed
/// when they disagree; an RR difference of two tests or fewer is named as noise.
pub fn held_out_comparison(
    s: &LayoutScore,
    b: &LayoutScore,
    n: usize,
) -> (Tone, &'static str, Vec<String>) {
    let d_tests = (b.rr_pct - s.rr_pct) / 100.0 * n as f64;
    let mut reasons = vec![format!(
        "held-out protocol ({n} tests, penalty tuned): RR {:.1} % against the start's {:.1} % ({d_tests:+.0} tests of {n}), mean SNR {:.2} dB against {:.2} dB",
        b.rr_pct, s.rr_pct, b.mean_snr_db, s.mean_snr_db
    )];
    if d_tests.abs() < 2.5 && d_tests != 0.0 {
        reasons.push(format!(
            "the RR difference is {d_tests:+.0} of {n} tests: another draw of seeds could change it"
        ));
    }
    let rr = b.rr_pct - s.rr_pct;
    let snr = b.mean_snr_db - s.mean_snr_db;
    let (tone, headline) = if rr >= 0.0 && snr >= 0.0 && (rr > 0.0 || snr > 0.0) {
        (Tone::Pass, "BETTER THAN THE START ON HELD-OUT SEEDS")
    } else if rr == 0.0 && snr == 0.0 {
        (Tone::Neutral, "SAME AS THE START ON HELD-OUT SEEDS")
    } else if rr <= 0.0 && snr <= 0.0 {
        reasons.push(
            "the gain on the training seeds did not carry over to the held-out ones: the start layout is at least as good".into(),
        );
        (Tone::Warn, "NOT BETTER THAN THE START ON HELD-OUT SEEDS")
    } else {
        reasons.push(format!(
            "RR and SNR disagree: RR {rr:+.1} points, mean SNR {snr:+.2} dB; the objective (RR % + SNR dB) moves by {:+.2}",
            b.score() - s.score()
        ));
        (Tone::Warn, "MIXED ON HELD-OUT SEEDS")
    };
    (tone, headline, reasons)
}

fn place_verdict(d: &mut Document, o: &PlaceOutcome, test_seeds: usize) {
    let n = protocol_tests_per_seed() * test_seeds.max(1);
    let (tone, headline, mut reasons) = held_out_comparison(&o.start_test, &o.best_test, n);
    reasons.push(format!(
        "training seeds: objective {:.4} against the start's {:.4}",
        o.best_objective, o.start_objective
    ));
    d.verdict(
        tone,
        headline,
        &format!(
            "Objective {:?}, reconstruction method {}, {test_seeds} held-out seeds, in {:.1} s",
            o.objective, o.method, o.time_s
        ),
        &reasons,
    );
}

fn place_scores(d: &mut Document, o: &PlaceOutcome) {
    d.section("Held-out protocol");
    let mut t = Table::new(["layout", "RR %", "mean SNR dB", "mutual coherence"]);
    let row = |t: &mut Table, name: &str, s: &LayoutScore| {
        t.row([
            name.to_string(),
            format!("{:.1}", s.rr_pct),
            format!("{:.2}", s.mean_snr_db),
            format!("{:.3}", s.mutual_coherence),
        ])
    };
    row(&mut t, "start", &o.start_test);
    row(&mut t, "chosen", &o.best_test);
    d.table("scores", &t);
    let mut t = Table::new([
        "loads",
        "start RR %",
        "start SNR dB",
        "chosen RR %",
        "chosen SNR dB",
    ]);
    for (a, b) in o
        .start_test
        .by_load_count
        .iter()
        .zip(&o.best_test.by_load_count)
    {
        t.row([
            a.0.to_string(),
            format!("{:.1}", a.1),
            format!("{:.2}", a.2),
            format!("{:.1}", b.1),
            format!("{:.2}", b.2),
        ]);
    }
    d.table("by-load-count", &t);
    d.note(
        "The paper's Table 3: RR 100/100/100/90 % and SNR 25.4/25.2/23.3/19.7 dB for 1–4 loads.",
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    fn score(rr_pct: f64, mean_snr_db: f64) -> LayoutScore {
        LayoutScore {
            rr_pct,
            mean_snr_db,
            mutual_coherence: 0.8,
            by_load_count: Vec::new(),
        }
    }

    #[test]
    fn the_chosen_layout_is_better_only_when_rr_and_snr_agree() {
        let start = score(96.2, 25.23);
        let (t, h, _) = held_out_comparison(&start, &score(97.1, 25.5), 420);
        assert_eq!(
            (t, h),
            (Tone::Pass, "BETTER THAN THE START ON HELD-OUT SEEDS")
        );
        // RR up by 4 tests, SNR down 0.7 dB: the objective rises by 0.2, yet mixed.
        let (t, h, why) = held_out_comparison(&start, &score(97.1, 24.53), 420);
        assert_eq!((t, h), (Tone::Warn, "MIXED ON HELD-OUT SEEDS"));
        assert!(why.iter().any(|r| r.contains("+4 tests of 420")), "{why:?}");
        let (t, _, why) = held_out_comparison(&start, &score(95.0, 25.0), 420);
        assert_eq!(t, Tone::Warn);
        assert!(why.iter().any(|r| r.contains("did not carry over")));
        assert_eq!(held_out_comparison(&start, &start, 420).0, Tone::Neutral);
        // One test of 420 more is named as what another draw of seeds could change.
        let (t, _, why) = held_out_comparison(&start, &score(96.2 + 100.0 / 420.0, 25.3), 420);
        assert_eq!(t, Tone::Pass);
        assert!(why.iter().any(|r| r.contains("+1 of 420 tests")), "{why:?}");
    }

    #[test]
    fn the_protocol_has_84_tests_per_seed() {
        // 3 masses × 8 singles + 3 load counts × 20 configurations (the paper's protocol).
        assert_eq!(protocol_tests_per_seed(), 84);
    }
}
