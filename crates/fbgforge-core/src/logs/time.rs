//! Times of a log's rows: the accumulator of the times as written (a date and seconds
//! of day, or plain seconds), their resolution to seconds once the whole file is known,
//! sorting rows that run backwards, and spreading whole-second timestamps onto the grid
//! they were sampled on; and the median sample period of any series of times
//! ([`median_period`]).

use super::num::{self, DateOrder, RawDate};
use super::{at, Clock, LogWarnings, PeakLog};
use anyhow::{anyhow, bail, Result};
use serde::Serialize;
use std::path::Path;

/// Times of the rows parsed so far: either a wall-clock date + seconds of day, or
/// plain seconds.
#[derive(Default)]
pub(crate) struct TimeAcc {
    /// Distinct dates, as written.
    pub(crate) dates: Vec<RawDate>,
    /// Index into `dates` of each row's date, or [`NO_DATE`].
    pub(crate) date_of_row: Vec<u32>,
    /// Seconds of day (with a date) or plain seconds of each row.
    pub(crate) sec: Vec<f64>,
}

/// A row whose time is plain seconds, without a date.
pub(crate) const NO_DATE: u32 = u32::MAX;

impl TimeAcc {
    /// Add one row's time.
    #[inline]
    pub(crate) fn push(&mut self, t: (Option<RawDate>, f64)) {
        let idx = match t.0 {
            None => NO_DATE,
            Some(d) => match self.dates.iter().rposition(|x| *x == d) {
                Some(i) => i as u32,
                None => {
                    self.dates.push(d);
                    (self.dates.len() - 1) as u32
                }
            },
        };
        self.date_of_row.push(idx);
        self.sec.push(t.1);
    }
}

/// The rows' times in seconds and their clock: plain seconds (wall-clock when they
/// are that large), or dates resolved in the day/month order the file tells, the user
/// names (`date_order`) or the format's `default_order`. `lines` are the rows' file
/// lines, for messages.
pub(crate) fn wavelength_times(
    times: &mut TimeAcc,
    lines: &[u32],
    default_order: DateOrder,
    date_order: Option<DateOrder>,
    path: &Path,
) -> Result<(Vec<f64>, Clock)> {
    let rows = lines.len();
    let with_dates = times.date_of_row.iter().filter(|&&d| d != NO_DATE).count();
    if with_dates == 0 {
        let sec = std::mem::take(&mut times.sec);
        let clock = if sec.first().is_some_and(|&s| s > 1e8) {
            Clock::Absolute
        } else {
            Clock::Relative
        };
        return Ok((sec, clock));
    }
    if with_dates != rows {
        let i = times
            .date_of_row
            .iter()
            .position(|&d| d == NO_DATE)
            .unwrap_or(0);
        bail!(
            "{}: this row has a plain number for time while other rows have dates",
            at(path, lines[i] as usize)
        );
    }
    let order = match date_order {
        Some(o) => o,
        None => num::resolve_order(&times.dates, default_order).map_err(|e| {
            anyhow!(
                "{}: {e}; name the order with ReadOptions.date_order",
                path.display()
            )
        })?,
    };
    let mut days = Vec::with_capacity(times.dates.len());
    for (k, d) in times.dates.iter().enumerate() {
        match num::date_to_days(d, order) {
            Ok(v) => days.push(v),
            Err(e) => {
                let i = times
                    .date_of_row
                    .iter()
                    .position(|&x| x as usize == k)
                    .unwrap_or(0);
                bail!("{}: {e} (read as {:?})", at(path, lines[i] as usize), order);
            }
        }
    }
    let t = times
        .date_of_row
        .iter()
        .zip(&times.sec)
        .map(|(&d, &s)| days[d as usize] as f64 * 86400.0 + s)
        .collect();
    Ok((t, Clock::Absolute))
}

/// Sort rows by time if needed (counting every backward step): the order to put them
/// in, or None when they already are.
pub(crate) fn finish_times(
    path: &Path,
    time_s: &mut [f64],
    lines: &[u32],
    warnings: &mut LogWarnings,
) -> Option<Vec<usize>> {
    let mut backward = 0;
    let mut first_line = 0;
    let jump = (JUMP_PERIODS * median_period(time_s)).max(JUMP_MIN_S);
    let mut any_back = false;
    for i in 1..time_s.len() {
        any_back |= time_s[i] < time_s[i - 1];
        // A jump of the clock is named on its own (`clock_jump`).
        if time_s[i] < time_s[i - 1] && time_s[i - 1] - time_s[i] <= jump {
            if backward == 0 {
                first_line = lines[i];
            }
            backward += 1;
        }
    }
    if !any_back {
        return None;
    }
    warnings.add_n("non_monotonic_timestamp", backward, || {
        format!(
            "{}: time runs backwards; rows were sorted by time ({backward} backward steps)",
            at(path, first_line as usize)
        )
    });
    let mut idx: Vec<usize> = (0..time_s.len()).collect();
    idx.sort_by(|&a, &b| time_s[a].total_cmp(&time_s[b]));
    Some(idx)
}

/// Put the log's rows (peaks, channels, lines, times) in the order `order`.
pub(crate) fn reorder_rows(log: &mut PeakLog, time_s: &mut Vec<f64>, order: &[usize]) {
    // The times being finished live beside the log until the end of reading.
    log.time_s = std::mem::take(time_s);
    *log = log.with_rows(order);
    *time_s = std::mem::take(&mut log.time_s);
}

/// Spread timestamps quantised to whole seconds (several rows per second) onto the
/// grid they were sampled on, stretch by stretch: a written second that skips one or
/// more seconds is a pause of the recording, and each stretch between pauses gets its
/// own uniform grid t_i = t0 + i·dt (dt from its first and last change of the written
/// second, t0 the centre of the offsets allowed by floor(t_i) = written time). A stretch
/// whose rows no steady rate fits (the offsets allowed do not overlap), or with too few
/// changes of second to measure a rate, is spread run by run: the m rows written with
/// one second sit at (k + ½)/m into it. Every row stays inside its written second (one
/// grid over a log with pauses moved rows by up to 187 s, and by 21.7 h over a pause of
/// 78 189 s). Returns the bound on each time's error (0.25 s at 2 Hz, 0.5 s for rows
/// spread run by run), or 0 when the times were left as they are.
pub(crate) fn dequantize(path: &Path, time_s: &mut [f64], warnings: &mut LogWarnings) -> f64 {
    let n = time_s.len();
    if n < 4 || time_s.iter().any(|t| t.fract() != 0.0) {
        return 0.0;
    }
    let repeats = time_s.windows(2).filter(|w| w[0] == w[1]).count();
    // Rows sharing their second with the one before: half of them at exactly 2 Hz
    // (fewer still with pauses), so a third is the mark of several rows per second.
    if repeats * 3 < n {
        return 0.0;
    }
    // Stretches between pauses (a second with no row).
    let mut starts: Vec<usize> = vec![0];
    starts.extend((1..n).filter(|&i| time_s[i] - time_s[i - 1] >= 2.0));
    let pauses = starts.len() - 1;
    let longest_pause = (1..n)
        .map(|i| time_s[i] - time_s[i - 1] - 1.0)
        .fold(0.0, f64::max);
    starts.push(n);
    let (mut half, mut by_run, mut rate_rows) = (0.0f64, 0usize, (0.0, 0usize));
    for w in starts.windows(2) {
        let stretch = &mut time_s[w[0]..w[1]];
        match spread_on_grid(stretch) {
            Some((h, dt)) => {
                half = half.max(h);
                if stretch.len() > rate_rows.1 {
                    rate_rows = (1.0 / dt, stretch.len());
                }
            }
            None => {
                spread_by_run(stretch);
                half = half.max(0.5);
                by_run += stretch.len();
            }
        }
    }
    warnings.add("whole_second_timestamps", || {
        let rate = if rate_rows.1 > 0 {
            format!("rows were spread uniformly at {:.4} Hz", rate_rows.0)
        } else {
            "rows were spread evenly within each written second".to_string()
        };
        format!(
            "{}: timestamps have a resolution of 1 s with several rows per second; {rate}{}{}, each time uncertain by up to ±{half:.3} s",
            path.display(),
            if pauses > 0 {
                format!(
                    ", each of the {} stretches between pauses (the longest pause {longest_pause:.0} s) on its own grid",
                    pauses + 1
                )
            } else {
                String::new()
            },
            if by_run > 0 {
                format!("; {by_run} rows without a steady rate spread within their written second")
            } else {
                String::new()
            }
        )
    });
    half
}

/// Spread one stretch of whole-second times onto a uniform grid, if one fits every row
/// inside its written second: (half-width of the phases allowed, period).
fn spread_on_grid(t: &mut [f64]) -> Option<(f64, f64)> {
    let n = t.len();
    let changes: Vec<usize> = (1..n).filter(|&i| t[i] != t[i - 1]).collect();
    // The written second changes where the true time crosses a whole second; the first
    // and last such crossings give the period without the bias a regression on floored
    // values has. Two crossings at least, some rows apart.
    let (&a, &b) = (changes.first()?, changes.last()?);
    if b <= a || changes.len() < 2 {
        return None;
    }
    let dt = (t[b] - t[a]) / (b - a) as f64;
    if dt.is_nan() || dt <= 0.0 {
        return None;
    }
    let base = t[0];
    let (mut lo, mut hi) = (f64::MIN, f64::MAX);
    for (i, &v) in t.iter().enumerate() {
        let q = v - base - i as f64 * dt;
        lo = lo.max(q);
        hi = hi.min(q + 1.0);
    }
    if lo > hi {
        return None;
    }
    let t0 = (lo + hi) / 2.0;
    for (i, v) in t.iter_mut().enumerate() {
        *v = base + t0 + i as f64 * dt;
    }
    Some(((hi - lo) / 2.0, dt))
}

/// Spread each run of rows written with one second evenly inside it.
fn spread_by_run(t: &mut [f64]) {
    let mut i = 0;
    while i < t.len() {
        let s = t[i];
        let j = i + t[i..].iter().take_while(|&&v| v == s).count();
        let m = (j - i) as f64;
        for (k, v) in t[i..j].iter_mut().enumerate() {
            *v = s + (k as f64 + 0.5) / m;
        }
        i = j;
    }
}

/// A discontinuity of a log's clock found from its rows' spacing.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ClockJump {
    /// File line of the first row after it.
    pub line: u32,
    /// The step of the written time there, s: negative when the clock went back (a
    /// daylight-saving change, a clock set by NTP); positive for a gap far longer than
    /// the rows' period (a pause of the recording, or the clock set forward).
    pub step_s: f64,
}

impl ClockJump {
    /// The clock went back: the rows after it are on another clock for certain.
    pub fn backwards(&self) -> bool {
        self.step_s < 0.0
    }
}

/// A backward step of the written time longer than this many median periods (and at
/// least [`JUMP_MIN_S`]) is the clock going back, not rows written out of order.
const JUMP_PERIODS: f64 = 10.0;
/// Shortest backward step counted as a clock jump, s.
const JUMP_MIN_S: f64 = 1.0;
/// A gap longer than this many median periods (and at least [`GAP_MIN_S`]) is named:
/// a pause, or the clock set forward.
const GAP_PERIODS: f64 = 50.0;
/// Shortest gap named, s.
const GAP_MIN_S: f64 = 5.0;

/// The clock's jumps back and long gaps, in file order (`time_s` as read, before any
/// sorting), each named in a warning (`clock_jump`, `clock_gap`).
pub(crate) fn clock_jumps(
    path: &Path,
    time_s: &[f64],
    lines: &[u32],
    warnings: &mut LogWarnings,
) -> Vec<ClockJump> {
    let p = median_period(time_s);
    let (back, gap) = (
        (JUMP_PERIODS * p).max(JUMP_MIN_S),
        (GAP_PERIODS * p).max(GAP_MIN_S),
    );
    let mut jumps = Vec::new();
    for i in 1..time_s.len() {
        let step = time_s[i] - time_s[i - 1];
        if step < -back || step > gap {
            jumps.push(ClockJump {
                line: lines[i],
                step_s: step,
            });
        }
    }
    for j in &jumps {
        let at_line = at(path, j.line as usize);
        if j.backwards() {
            warnings.add("clock_jump", || {
                format!(
                    "{at_line}: the log's clock runs back by {:.3} s here (a daylight-saving change, or the PC clock set by NTP): the rows after it are on another clock",
                    -j.step_s
                )
            });
        } else {
            warnings.add("clock_gap", || {
                format!(
                    "{at_line}: no rows for {:.3} s before this one ({:.0} periods): a pause of the recording, or the PC clock set forward",
                    j.step_s,
                    j.step_s / p.max(1e-9)
                )
            });
        }
    }
    jumps
}

/// Reject logs with fewer rows than an analysis can use.
pub(crate) fn require_rows(path: &Path, rows: usize, what: &str) -> Result<()> {
    if rows < 2 {
        bail!(
            "{}: {what} holds {rows} readable rows; at least 2 are needed",
            path.display()
        );
    }
    Ok(())
}

/// Median of the positive time steps of `t`, s (0 when fewer than two samples).
pub fn median_period(t: &[f64]) -> f64 {
    let mut d: Vec<f64> = t
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|d| *d > 0.0)
        .collect();
    if d.is_empty() {
        return 0.0;
    }
    let mid = d.len() / 2;
    *d.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1
}
