//! A wavelength log whose clock ran back (a daylight-saving change, a PC clock set by
//! NTP) holds rows on two clocks: sorted by time, they interleave, and one clock
//! offset cannot align both sides with the force log (a fall back by an hour read as
//! an unloaded sensor). The rows between two jumps back share one clock: the longest
//! such stretch (in rows) is analysed and the others are set aside, named.

use crate::logs::{LogWarnings, PeakLog};

/// The rows of `log` on one clock: the longest stretch between its jumps back (file
/// lines), as a log of its own, and the rows set aside; None when the clock never ran
/// back.
pub(super) fn one_clock(log: &PeakLog, warnings: &mut LogWarnings) -> Option<(PeakLog, usize)> {
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
    let (a, b) = bounds
        .windows(2)
        .map(|w| (w[0], w[1]))
        .max_by_key(|&(a, b)| rows_in(a, b))?;
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
            "{}: the log's clock runs back {} time(s) (see clock_jump): only lines {} to {} ({} rows, the longest stretch on one clock) are analysed; {set_aside} rows on another clock are set aside",
            log.source.display(),
            backs.len(),
            lines.0,
            lines.1,
            keep.len()
        )
    });
    Some((out, set_aside))
}
