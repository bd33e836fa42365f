//! Times of a log's rows: the accumulator of the times as written (a date and seconds
//! of day, or plain seconds), their resolution to seconds once the whole file is known,
//! sorting rows that run backwards, and spreading whole-second timestamps onto the grid
//! they were sampled on; and the median sample period of any series of times
//! ([`median_period`]).

use super::num::{self, DateOrder, RawDate};
use super::{at, Clock, LogWarnings, PeakLog};
use anyhow::{anyhow, bail, Result};
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
    for i in 1..time_s.len() {
        if time_s[i] < time_s[i - 1] {
            if backward == 0 {
                first_line = lines[i];
            }
            backward += 1;
        }
    }
    if backward == 0 {
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
    let rows = order.len();
    let mut rs = Vec::with_capacity(rows + 1);
    rs.push(0);
    let mut pk = Vec::with_capacity(log.peaks_nm.len());
    let mut ch = Vec::with_capacity(log.peaks_nm.len());
    let mut qu = Vec::new();
    let mut ln = Vec::with_capacity(rows);
    let mut ts = Vec::with_capacity(rows);
    for &i in order {
        let (a, b) = (log.row_start[i], log.row_start[i + 1]);
        pk.extend_from_slice(&log.peaks_nm[a..b]);
        ch.extend_from_slice(&log.peak_channel[a..b]);
        if let Some(u) = &log.uncertainty {
            qu.extend_from_slice(&u.peaks[a..b]);
        }
        rs.push(pk.len());
        ln.push(log.line_of_row[i]);
        ts.push(time_s[i]);
    }
    log.row_start = rs;
    log.peaks_nm = pk;
    log.peak_channel = ch;
    if let Some(u) = &mut log.uncertainty {
        u.peaks = qu;
    }
    log.line_of_row = ln;
    *time_s = ts;
}

/// Spread timestamps quantised to whole seconds (several rows per second) onto the
/// uniform grid they were sampled on: t_i = t0 + i·dt with dt from the first and last
/// change of the written second, and t0 the centre of the offsets allowed by
/// floor(t_i) = written time. Returns the half-width of that range of offsets, the
/// bound on each time's error (0.25 s at 2 Hz), or 0 when the times were left as
/// they are.
pub(crate) fn dequantize(path: &Path, time_s: &mut [f64], warnings: &mut LogWarnings) -> f64 {
    let n = time_s.len();
    if n < 4 || time_s.iter().any(|t| t.fract() != 0.0) {
        return 0.0;
    }
    let repeats = time_s.windows(2).filter(|w| w[0] == w[1]).count();
    if repeats * 2 < n {
        return 0.0;
    }
    let base = time_s[0];
    // The written second changes where the true time crosses a whole second; the
    // first and last such crossings give the period without the bias a regression
    // on floored values has.
    let changes: Vec<usize> = (1..n).filter(|&i| time_s[i] != time_s[i - 1]).collect();
    let dt = match (changes.first(), changes.last()) {
        (Some(&a), Some(&b)) if b > a => (time_s[b] - time_s[a]) / (b - a) as f64,
        _ => {
            let (mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0);
            for (i, &t) in time_s.iter().enumerate() {
                let (x, y) = (i as f64, t - base);
                sx += x;
                sy += y;
                sxx += x * x;
                sxy += x * y;
            }
            let nf = n as f64;
            (nf * sxy - sx * sy) / (nf * sxx - sx * sx)
        }
    };
    if dt.is_nan() || dt <= 0.0 {
        return 0.0;
    }
    let (mut lo, mut hi) = (f64::MIN, f64::MAX);
    for (i, &t) in time_s.iter().enumerate() {
        let q = t - base - i as f64 * dt;
        lo = lo.max(q);
        hi = hi.min(q + 1.0);
    }
    let (t0, half) = if lo <= hi {
        ((lo + hi) / 2.0, (hi - lo) / 2.0)
    } else {
        (lo, 0.5)
    };
    for (i, t) in time_s.iter_mut().enumerate() {
        *t = base + t0 + i as f64 * dt;
    }
    warnings.add("whole_second_timestamps", || {
        format!(
            "{}: timestamps have a resolution of 1 s with several rows per second; rows were spread uniformly at {:.4} Hz, each time uncertain by up to ±{half:.3} s",
            path.display(),
            1.0 / dt
        )
    });
    half
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
