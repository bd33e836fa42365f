//! A wavelength log whose clock ran back (a daylight-saving change, a PC clock set by
//! NTP) holds rows on two clocks: sorted by time, they interleave, and one clock
//! offset cannot align both sides with the force log (a fall back by an hour read as
//! an unloaded sensor). The rows between two jumps back share one clock: the stretch
//! most under the force log (when the two logs share a wall clock or the offset is
//! given), else the longest, is analysed and the others are set aside, named.

use crate::logs::{LogWarnings, PeakLog};

/// The rows of `log` on one clock: of the stretches between its jumps back (file
/// lines), the one with the most rows inside `force_span` (the force log's span on the
/// same wall clock, when both logs carry one: the stretch on the force log's clock),
/// else the longest; as a log of its own, and the rows set aside. None when the clock
/// never ran back.
pub(super) fn one_clock(
    log: &PeakLog,
    force_span: Option<(f64, f64)>,
    warnings: &mut LogWarnings,
) -> Option<(PeakLog, usize)> {
    let backs: Vec<u32> = log
        .clock_jumps
        .iter()
        .filter(|j| j.backwards())
        .map(|j| j.line)
        .collect();
    if backs.is_empty() {
        return None;
    }
    // Stretches of file lines: [first, b0), [b0, b1), ..., [bn, ∞).
    let mut bounds = vec![0u32];
    bounds.extend(&backs);
    bounds.push(u32::MAX);
    let rows_in = |a: u32, b: u32| log.line_of_row.iter().filter(|&&l| l >= a && l < b).count();
    // An hour's jump can leave the longest stretch outside the force log altogether
    // (the rows under the force were written on the other clock).
    let under_force = |a: u32, b: u32| {
        force_span.map_or(0, |(f0, f1)| {
            (0..log.rows())
                .filter(|&i| {
                    let l = log.line_of_row[i];
                    l >= a && l < b && log.time_s[i] >= f0 && log.time_s[i] <= f1
                })
                .count()
        })
    };
    let (a, b) = bounds
        .windows(2)
        .map(|w| (w[0], w[1]))
        .max_by_key(|&(a, b)| (under_force(a, b), rows_in(a, b)))?;
    let keep: Vec<usize> = (0..log.rows())
        .filter(|&i| log.line_of_row[i] >= a && log.line_of_row[i] < b)
        .collect();
    let set_aside = log.rows() - keep.len();
    let out = log.with_rows(&keep);
    let lines = (
        out.line_of_row.first().copied().unwrap_or(0),
        out.line_of_row.last().copied().unwrap_or(0),
    );
    warnings.add_n("clock_rows_set_aside", set_aside, || {
        format!(
            "{}: the log's clock runs back {} time(s) (see clock_jump): only lines {} to {} ({} rows, {}) are analysed; {set_aside} rows on another clock are set aside",
            log.source.display(),
            backs.len(),
            lines.0,
            lines.1,
            keep.len(),
            if force_span.is_some() {
                "the stretch on one clock most under the force log's span"
            } else {
                "the longest stretch on one clock"
            }
        )
    });
    Some((out, set_aside))
}
