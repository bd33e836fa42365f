//! The series behind the plots, decimated to what a chart shows: a long log's rows
//! are cut into buckets (about a pixel column each), and each bucket keeps its first
//! row and the rows of the smallest and largest force and of each grating's smallest
//! and largest drift-free shift, so every chart's envelope is that of all the rows
//! while an hour at 1 kHz keeps some 50 000 rows, not 3.6 million per series.

use super::results::Series;
use super::GratingContext;
use crate::fit::LagModelFit;
use std::borrow::Cow;

/// A log with at most this many rows keeps them all.
pub(super) const PLOT_ROWS_ALL: usize = 20_000;
/// Buckets a longer log is cut into.
pub(super) const PLOT_BUCKETS: usize = 4_000;

/// The lag model's baseline and drift, removed from a compensated shift: the
/// drift-free shift of a row, rebuilt when the plots need it.
#[derive(Debug, Clone, Copy)]
pub(super) struct DriftLine {
    baseline_pm: f64,
    drift_pm_per_s: f64,
    /// The drift's origin, s.
    t_mid: f64,
}

impl DriftLine {
    /// The lag model's line over the span both logs cover.
    pub(super) fn of(ctx: &GratingContext, lm: &LagModelFit) -> Self {
        DriftLine {
            baseline_pm: lm.baseline_pm,
            drift_pm_per_s: lm.drift_pm_per_s,
            t_mid: (ctx.span.0 + ctx.span.1) / 2.0,
        }
    }

    /// The drift-free shift at row `i` (as `sensitivity::drift_free_shift` gives it):
    /// NaN outside the force log (`fc` NaN) and in the stretches left out (`row_ok`).
    #[inline]
    pub(super) fn at(&self, rows: &Rows, s: &[f64], i: usize) -> f64 {
        if rows.fc[i].is_finite() && rows.row_ok[i] {
            s[i] - self.baseline_pm - self.drift_pm_per_s * (rows.tw[i] - self.t_mid)
        } else {
            f64::NAN
        }
    }
}

/// What the drift-free shifts of every row are built from.
pub(super) struct Rows<'a> {
    /// Wavelength log times, s.
    pub(super) tw: &'a [f64],
    /// Force at the rows, N (NaN outside the force log).
    pub(super) fc: &'a [f64],
    /// Rows outside the stretches left out.
    pub(super) row_ok: &'a [bool],
}

/// One grating's plot: its name, which shift (index into the gratings used), its line
/// and chart line.
pub(super) struct PlotGrating {
    pub(super) name: String,
    pub(super) used: usize,
    pub(super) drift: DriftLine,
    pub(super) slope: f64,
    pub(super) intercept: f64,
}

/// The rows a plot keeps: all up to [`PLOT_ROWS_ALL`]; beyond, per bucket the first
/// row and those of each series' smallest and largest finite value, in order. One
/// grating's shift (`shift_of`) is built at a time.
fn plot_rows<'s>(
    rows: &Rows,
    gratings: &[PlotGrating],
    shift_of: &impl Fn(usize) -> Cow<'s, [f64]>,
) -> Vec<usize> {
    let n = rows.tw.len();
    if n <= PLOT_ROWS_ALL {
        return (0..n).collect();
    }
    let width = n.div_ceil(PLOT_BUCKETS);
    let buckets = || (0..n).step_by(width).map(move |a| a..(a + width).min(n));
    let mut keep = Vec::new();
    for b in buckets() {
        keep.push(b.start);
        extremes(b, |i| rows.fc[i], &mut keep);
    }
    for g in gratings {
        let s = shift_of(g.used);
        for b in buckets() {
            extremes(b, |i| g.drift.at(rows, &s, i), &mut keep);
        }
    }
    keep.sort_unstable();
    keep.dedup();
    keep
}

/// Push the rows of the smallest and the largest finite `value` over `range`.
fn extremes(range: std::ops::Range<usize>, value: impl Fn(usize) -> f64, out: &mut Vec<usize>) {
    let (mut lo, mut hi) = (None::<(usize, f64)>, None::<(usize, f64)>);
    for i in range {
        let v = value(i);
        if !v.is_finite() {
            continue;
        }
        if lo.is_none_or(|(_, x)| v < x) {
            lo = Some((i, v));
        }
        if hi.is_none_or(|(_, x)| v > x) {
            hi = Some((i, v));
        }
    }
    out.extend(lo.map(|p| p.0));
    out.extend(hi.map(|p| p.0));
}

/// The series behind the plots at the rows they keep (see [`plot_rows`]), gratings
/// in the order given.
pub(super) fn plot_series<'s>(
    rows: &Rows,
    gratings: &[PlotGrating],
    shift_of: impl Fn(usize) -> Cow<'s, [f64]>,
) -> Series {
    let keep = plot_rows(rows, gratings, &shift_of);
    Series {
        time_s: keep.iter().map(|&i| rows.tw[i]).collect(),
        force_n: keep.iter().map(|&i| rows.fc[i]).collect(),
        shift_pm: gratings
            .iter()
            .map(|g| {
                let s = shift_of(g.used);
                let v = keep.iter().map(|&i| g.drift.at(rows, &s, i)).collect();
                (g.name.clone(), v)
            })
            .collect(),
        fit: gratings
            .iter()
            .map(|g| (g.name.clone(), g.slope, g.intercept))
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_log_keeps_every_bucket_s_extremes_and_a_short_one_every_row() {
        // A 100 000-row log: a spike of one row in the force and one in the shift,
        // which a stride would step over, stay in the plot; the kept rows are in order.
        let n = 100_000;
        let tw: Vec<f64> = (0..n).map(|i| i as f64 * 1e-3).collect();
        let mut fc: Vec<f64> = (0..n).map(|i| (i as f64 * 1e-3).sin()).collect();
        fc[12_345] = 50.0;
        let mut s: Vec<f64> = (0..n).map(|i| 2.0 * (i as f64 * 1e-3).sin()).collect();
        s[67_891] = -80.0;
        let row_ok = vec![true; n];
        let rows = Rows {
            tw: &tw,
            fc: &fc,
            row_ok: &row_ok,
        };
        let drift = DriftLine {
            baseline_pm: 1.0,
            drift_pm_per_s: 0.5,
            t_mid: 50.0,
        };
        let g = PlotGrating {
            name: "a".into(),
            used: 0,
            drift,
            slope: 2.0,
            intercept: 0.0,
        };
        let series = plot_series(&rows, std::slice::from_ref(&g), |_| Cow::Borrowed(&s));
        let m = series.time_s.len();
        assert!((PLOT_BUCKETS..5 * PLOT_BUCKETS).contains(&m), "{m}");
        assert!(series.time_s.windows(2).all(|w| w[0] < w[1]));
        assert!(series.force_n.contains(&50.0));
        let v = &series.shift_pm[0].1;
        let spike = -80.0 - 1.0 - 0.5 * (tw[67_891] - 50.0);
        assert!(v.iter().any(|&x| (x - spike).abs() < 1e-12), "{spike}");
        // Every kept value is the row's own.
        for (k, &t) in series.time_s.iter().enumerate() {
            let i = (t * 1e3).round() as usize;
            assert_eq!(series.force_n[k], fc[i]);
            assert_eq!(v[k], drift.at(&rows, &s, i));
        }
        // A short log keeps every row.
        let short = Rows {
            tw: &tw[..1000],
            fc: &fc[..1000],
            row_ok: &row_ok[..1000],
        };
        let none = |_| Cow::Borrowed(&s[..0]);
        assert_eq!(plot_series(&short, &[], none).time_s.len(), 1000);
    }
}
