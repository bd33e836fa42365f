//! How a reconstruction run is shown on the terminal (`fbgforge reconstruct`): the
//! method and why, the frames, the time per frame, the trust flags and the gratings
//! left out ([`summary_text`]).

use fbgforge_array::run::ReconstructSummary;
use std::fmt::Write as _;

/// The run's summary in a few lines.
pub fn summary_text(summary: &ReconstructSummary) -> String {
    let mut s = String::new();
    if let Some(c) = &summary.choice {
        let _ = writeln!(s, "method choice: {}", c.reason);
    }
    let _ = writeln!(
        s,
        "{} frames, method {} (penalty {}, ≤ {} loads), set-up {:.1} ms, {:.1} µs/frame ({} thread{}), {} {} → {}",
        summary.frames,
        summary.method,
        summary.penalty,
        summary.max_loads,
        summary.setup_ms,
        summary.time_per_frame_us,
        summary.threads,
        if summary.threads == 1 { "" } else { "s" },
        summary.not_converged,
        if summary.method == "bnb" {
            "stopped at the work budget (best support found, not certified)"
        } else {
            "not converged"
        },
        summary.out.display()
    );
    let f = &summary.flags;
    let _ = writeln!(
        s,
        "trusted {} of {} frames ({} certified); flagged: inconsistent {}, ceiling {}, overload {}, below_range {}, ambiguous {}, unusable {}; stopped short (a note, not a flag) {}",
        f.trusted,
        summary.frames,
        summary.certified,
        f.inconsistent,
        f.ceiling,
        f.overload,
        f.below_range,
        f.ambiguous,
        f.unusable,
        f.unconverged
    );
    let cm = &summary.common_mode_note;
    if cm.fitted || cm.decided == "auto" {
        let _ = writeln!(s, "common offset ({}): {}", cm.decided, cm.reason);
    }
    if let Some(b) = &summary.budget {
        let _ = writeln!(s, "budget {} µs per frame: {}", b.budget_us, b.note);
    }
    for g in &summary.suspect_gratings {
        let partner = g
            .partner_name
            .as_ref()
            .map_or(String::new(), |p| format!(" with {p}"));
        let _ = writeln!(
            s,
            "grating {} is {}{partner}: {}; {}",
            g.name,
            g.reason.words(),
            g.evidence,
            g.remedy
        );
    }
    crate::terminal::fit(&s)
}
