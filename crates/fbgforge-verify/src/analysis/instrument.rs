//! What the interrogator's own readings of one grating say about themselves, the
//! wavelength side's twin of the force log's check ([`crate::force_check`]): a peak
//! pinned at the edge of the interrogator's range (saturation: flat tops at a repeated
//! extreme while the force moves the part on), a frozen peak (one value repeated while
//! the force moves it), and a peak lost under load (it leaves the detection range or
//! the window). Each is judged against what the force predicts over the same rows
//! (|K| times the lag-corrected force's change), so a held plateau, a quantised rest
//! or a press of equal height never counts.

use super::results::InstrumentCheck;
use crate::segment::percentile_of;

/// The grating's readings and what the force predicts for them.
pub(super) struct Readings<'a> {
    /// Wavelength per row as the track stores it: pm from the nominal (NaN: no peak).
    pub offset_pm: &'a [f32],
    /// The lag-corrected force per row, N (NaN outside the force log or left out).
    pub x: &'a [f64],
    /// K, pm/N.
    pub k: f64,
    /// Largest x, N.
    pub x_max: f64,
}

/// A pinned or frozen stretch must hide at least this share of the response's span
/// (and six reading tolerances) of predicted change to count.
const MIN_HIDDEN_SHARE: f64 = 0.1;

/// Check one grating's readings.
pub(super) fn instrument_check(r: &Readings) -> InstrumentCheck {
    let n = r.offset_pm.len();
    // The stored readings read as f64 where used (no f64 copy of the column: 29 MB at
    // 1 h × 1 kHz).
    let o = r.offset_pm;
    let v = |i: usize| f64::from(o[i]);
    let span = r.k.abs() * r.x_max;
    let mut out = InstrumentCheck::default();
    if span.is_nan() || span <= 0.0 || n < 10 {
        return out;
    }
    let tol = reading_tolerance(o, r.x, r.x_max);
    let hidden = |rows: &mut dyn Iterator<Item = usize>| -> f64 {
        let (lo, hi) = rows
            .filter(|&i| r.x[i].is_finite())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), i| {
                (a.min(r.x[i]), b.max(r.x[i]))
            });
        if hi >= lo {
            r.k.abs() * (hi - lo)
        } else {
            0.0
        }
    };
    let enough = (6.0 * tol).max(MIN_HIDDEN_SHARE * span);
    // Pinned: the extreme in the direction the load moves the peak.
    let dir = r.k.signum();
    let top = (0..n)
        .filter(|&i| v(i).is_finite() && r.x[i].is_finite())
        .map(|i| dir * v(i))
        .fold(f64::NEG_INFINITY, f64::max);
    let pinned: Vec<usize> = (0..n)
        .filter(|&i| v(i).is_finite() && r.x[i].is_finite() && dir * v(i) >= top - tol)
        .collect();
    if pinned.len() >= 3 && hidden(&mut pinned.iter().copied()) > enough {
        out.pinned_at_pm = Some(dir * top);
        out.pinned_rows = pinned.len();
    }
    // Frozen: runs of one value repeated exactly (not at the pinned extreme).
    let mut i = 0;
    while i < n {
        let mut j = i + 1;
        while j < n && v(j) == v(i) && v(i).is_finite() {
            j += 1;
        }
        let at_top = out.pinned_at_pm.is_some() && dir * v(i) >= top - tol;
        if j - i >= 3 && !at_top && hidden(&mut (i..j)) > enough {
            out.frozen_runs += 1;
            out.frozen_rows += j - i;
        }
        i = j;
    }
    let (at_load, at_rest) = missing_shares(o, r.x, r.x_max);
    out.missing_at_load = at_load;
    out.missing_at_rest = at_rest;
    out.fault = fault_words(&out, span);
    out
}

/// How close two readings must be to count as one: a quarter of the noise at rest,
/// or 0.6 of the interrogator's step when the readings are quantised, pm.
///
/// The rows at rest and the steps are read as they go, not copied (two f64 columns of
/// an hour at 1 kHz): the figures are those of the copies (the same values, in order).
fn reading_tolerance(o: &[f32], x: &[f64], x_max: f64) -> f64 {
    let v = |i: usize| f64::from(o[i]);
    let rest = || {
        (0..o.len())
            .filter(move |&i| v(i).is_finite() && x[i].is_finite() && x[i] < 0.03 * x_max)
            .map(v)
    };
    let noise = crate::segment::noise_sigma_of(rest);
    let steps = || {
        o.windows(2)
            .map(|w| (f64::from(w[1]) - f64::from(w[0])).abs())
            .filter(|d| d.is_finite() && *d > 1e-9)
    };
    let step = if steps().next().is_none() {
        0.0
    } else {
        percentile_of(steps, 0.05)
    };
    (0.25 * noise).max(0.6 * step).max(1e-6)
}

/// Share of rows without a peak at high load (x above half its largest value) and at
/// rest (x below 5 % of it), of the rows the force log covers.
fn missing_shares(v: &[f32], x: &[f64], x_max: f64) -> (f64, f64) {
    let share = |pick: &dyn Fn(f64) -> bool| {
        let (mut miss, mut all) = (0usize, 0usize);
        for (vi, xi) in v.iter().zip(x) {
            if xi.is_finite() && pick(*xi) {
                all += 1;
                miss += usize::from(!vi.is_finite());
            }
        }
        if all == 0 {
            0.0
        } else {
            miss as f64 / all as f64
        }
    };
    (
        share(&|xi| xi > 0.5 * x_max),
        share(&|xi| xi < 0.05 * x_max),
    )
}

/// The fault in words, when there is one.
fn fault_words(c: &InstrumentCheck, span: f64) -> Option<String> {
    let mut why = Vec::new();
    if let Some(p) = c.pinned_at_pm {
        why.push(format!(
            "the peak stays at {p:+.1} pm from nominal in {} rows while the force moves the part on (the response spans {span:.1} pm): the interrogator's range ends there (saturated), and K read from it is low",
            c.pinned_rows
        ));
    }
    if c.frozen_runs > 0 {
        why.push(format!(
            "the peak repeats one value in {} runs ({} rows) while the force moves it: a frozen peak (the interrogator repeated its last reading)",
            c.frozen_runs, c.frozen_rows
        ));
    }
    if c.missing_at_load >= 0.05 && c.missing_at_load > 3.0 * c.missing_at_rest + 0.02 {
        why.push(format!(
            "the peak is missing in {:.0} % of the rows at high load against {:.1} % at rest: it leaves the interrogator's detection (or the window, AnalysisOptions.window_half_width_nm) under load, and K read without those rows is biased",
            100.0 * c.missing_at_load,
            100.0 * c.missing_at_rest
        ));
    }
    (!why.is_empty()).then(|| why.join("; "))
}
