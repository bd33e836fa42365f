//! `report.html` of `place`: one self-contained file, the verdict first (did the
//! chosen layout beat the start on held-out seeds), then the layout, the tables, and
//! the charts inline (the same as the SVG files beside it).

use crate::array::protocol::ProtocolConfig;
use crate::html::{Document, Table, Tone};
use crate::optimize::Figure;
use anyhow::Result;
use fbgforge_optimize::place::{LayoutScore, PlaceOutcome};

/// Tests in one seed of the protocol the placement scores on.
fn protocol_tests_per_seed() -> usize {
    let p = ProtocolConfig::paper(0);
    p.masses_g.len() * p.singles_per_mass + p.multi_load_counts.len() * p.configs_per_count
}

/// The placement's report; `test_seeds`: how many held-out seeds scored the layouts.
pub(crate) fn place_document(
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
pub(crate) fn held_out_comparison(
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
