//! The placement as text, every line within [`crate::optimize::WIDTH`] columns: the
//! objective, the layout, each solver's run, and the layouts on the held-out protocol.

use crate::optimize::wrapped;
use fbgforge_optimize::place::{LayoutScore, PlaceOutcome};
use std::fmt::Write as _;

/// The placement as text (see the module doc).
pub fn place_table(o: &PlaceOutcome) -> String {
    let mut s = String::new();
    layout_lines(&mut s, o);
    run_lines(&mut s, o);
    held_out_lines(&mut s, o);
    by_load_count_lines(&mut s, o);
    let _ = writeln!(s, "in {:.1} s", o.time_s);
    s
}

/// The objective, then each grating's start and chosen position and the fibers.
fn layout_lines(s: &mut String, o: &PlaceOutcome) {
    wrapped(
        s,
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
        wrapped(s, &format!("fiber x mm (mold slits): {}", xs.join(", ")), 4);
    }
}

/// One row per solver's run.
fn run_lines(s: &mut String, o: &PlaceOutcome) {
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
}

fn score_row(s: &mut String, name: &str, t: &LayoutScore) {
    let _ = writeln!(
        s,
        "  {name:<32} {:>6.1} {:>12.2} {:>11.3}",
        t.rr_pct, t.mean_snr_db, t.mutual_coherence
    );
}

/// Start and chosen layouts on the held-out protocol, on the search's model and on
/// perturbed ones.
fn held_out_lines(s: &mut String, o: &PlaceOutcome) {
    let _ = writeln!(
        s,
        "held-out protocol (penalty tuned):  RR %   mean SNR dB   coherence"
    );
    score_row(s, "start layout", &o.start_test);
    score_row(s, "optimised layout", &o.best_test);
    wrapped(
        s,
        &format!(
            "  gain on its own model ({}): RR {:+.1} points, RR + SNR {:+.2}",
            o.model.name(),
            o.best_test.rr_pct - o.start_test.rr_pct,
            o.best_test.score() - o.start_test.score()
        ),
        4,
    );
    if let Some(g) = &o.perturbed {
        score_row(s, "start, perturbed model", &g.start);
        score_row(s, "optimised, perturbed model", &g.best);
        wrapped(
            s,
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
}

/// RR and SNR by the number of loads, beside the paper's Table 3, and the proxy's
/// agreement with the protocol.
fn by_load_count_lines(s: &mut String, o: &PlaceOutcome) {
    wrapped(
        s,
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
            s,
            &format!(
                "coherence proxy vs protocol score: Spearman {:.2} over {} random layouts",
                ag.spearman_coherence_vs_score, ag.samples
            ),
            4,
        );
    }
}
