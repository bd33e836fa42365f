//! The two clocks aligned: the clock offset given, or estimated (cross-correlation for
//! a start, then the lag model fitted with the offset free, coarse then at full rate),
//! the aligned logs' overlap, and the timestamps' own uncertainty.

use super::alignment::{search, OffsetSearch, EVIDENCE_MARGIN};
use super::fit_data::FitData;
use super::results::AlignmentCheck;
use super::{AlignedClocks, ForceFrame};
use crate::fit;
use crate::logs::time::median_period;
use crate::logs::{assign, ForceLog, LogWarnings, PeakLog};
use anyhow::{bail, Result};
use rayon::prelude::*;

/// Take the given clock offset or estimate it (leaving out the force-sample `spans`
/// whose force is not trusted), and check the aligned logs overlap.
#[allow(clippy::too_many_arguments)]
pub(super) fn align_clocks(
    frame: &mut ForceFrame,
    tw: &[f64],
    shift_pm: &[f64],
    (log, force): (&PeakLog, &ForceLog),
    given_s: Option<f64>,
    spans: &[(usize, usize)],
    warnings: &mut LogWarnings,
) -> Result<AlignedClocks> {
    let prior = frame.prior;
    let (delta, source, found) = match given_s {
        Some(o) => (o - prior, "given", None),
        None => {
            let excluded = span_times(&frame.u, spans);
            let al = Alignment {
                tw,
                shift_pm,
                u: &frame.u,
                fval: &frame.fval,
                a: frame.a,
                b: frame.b,
                range: frame.range,
                excluded: &excluded,
            };
            let (d, found) = estimate_clock_offset(&al, warnings)?;
            (d, "estimated", found)
        }
    };
    let offset = prior + delta;
    // The frame's times become the aligned ones in place (no second column).
    let mut fu = std::mem::take(&mut frame.u);
    for x in &mut fu {
        *x -= delta;
    }
    let (wa, wb) = (tw[0], tw[tw.len() - 1]);
    let (fa, fb) = (fu[0], fu[fu.len() - 1]);
    let overlap = (wb.min(fb) - wa.max(fa)).max(0.0);
    let min_len = (wb - wa).min(fb - fa);
    if overlap < 0.25 * min_len || overlap <= 0.0 {
        bail!(
            "after aligning the clocks (offset {offset:.3} s) the force log {} and the wavelength log {} overlap for only {overlap:.3} s",
            force.source.display(),
            log.source.display()
        );
    }
    let check = alignment_check(found, prior, offset);
    Ok(AlignedClocks {
        offset,
        source,
        fu,
        fa,
        fb,
        check,
    })
}

/// The search's candidates as absolute offsets (the best at the polished offset), or
/// the given offset alone.
fn alignment_check(found: Option<OffsetSearch>, prior: f64, offset: f64) -> AlignmentCheck {
    let mut check = AlignmentCheck {
        evidence_margin: EVIDENCE_MARGIN,
        ..Default::default()
    };
    if let Some(f) = found {
        check.evidence = f.evidence;
        check.candidates = f
            .candidates
            .into_iter()
            .map(|mut c| {
                c.clock_offset_s += prior;
                c
            })
            .collect();
        if let Some(first) = check.candidates.first_mut() {
            first.clock_offset_s = offset;
        }
    }
    check
}

impl AlignedClocks {
    /// The same clocks with the force log's times warped to remove a clock skew
    /// (`(wa, wb)`: the wavelength log's span, for the overlap).
    pub(super) fn warped(
        &self,
        skew: &crate::skew::SkewFit,
        (wa, wb): (f64, f64),
    ) -> AlignedClocks {
        let _ = (wa, wb);
        let fu: Vec<f64> = self.fu.iter().map(|&u| skew.warp(u)).collect();
        let (fa, fb) = (fu[0], fu[fu.len() - 1]);
        AlignedClocks {
            offset: self.offset,
            source: self.source,
            fu,
            fa,
            fb,
            check: self.check.clone(),
        }
    }
}

/// The times of force-sample index spans in the time base `t`, s.
pub(super) fn span_times(t: &[f64], spans: &[(usize, usize)]) -> Vec<(f64, f64)> {
    spans
        .iter()
        .filter(|(a, b)| a <= b && *b < t.len())
        .map(|&(a, b)| (t[a], t[b]))
        .collect()
}

/// The logs' timing uncertainty, s, with a warning when a given offset carries it into
/// the lags (whole-second timestamps leave each log's absolute times uncertain; an
/// estimated offset absorbs it).
pub(super) fn timing_uncertainty_s(
    log: &PeakLog,
    force: &ForceLog,
    relative: bool,
    warnings: &mut LogWarnings,
) -> f64 {
    let timing = log.time_uncertainty_s.hypot(force.time_uncertainty_s);
    if timing > 0.0 && !relative {
        warnings.add("timing_uncertain", || {
            format!(
                "timestamps written in whole seconds leave the absolute time of each sample uncertain by up to ±{timing:.3} s; the lags, Δt_max and Q carry that uncertainty (a log with sub-second timestamps removes it)"
            )
        });
    }
    timing
}

/// The logs' time bases for estimating the clock offset: the wavelength log's times
/// `tw` and a strain grating's shifts, the force log's times `u` (wavelength frame,
/// before the residual offset) and forces, the usable span [a, b] and the search range.
struct Alignment<'a> {
    tw: &'a [f64],
    shift_pm: &'a [f64],
    u: &'a [f64],
    fval: &'a [f64],
    a: f64,
    b: f64,
    range: f64,
    /// Force-clock stretches (in `u`) left out of the fit, s.
    excluded: &'a [(f64, f64)],
}

/// Estimate the residual clock offset: cross-correlation for a start, then the lag
/// model fitted with the offset free, coarse then at full rate.
fn estimate_clock_offset(
    al: &Alignment,
    warnings: &mut LogWarnings,
) -> Result<(f64, Option<OffsetSearch>)> {
    let (tw, s, u, fval, a, b, range) = (al.tw, al.shift_pm, al.u, al.fval, al.a, al.b, al.range);
    let (dx, _) = xcorr_offset(tw, s, u, fval, a, b, range)
        .ok_or_else(|| anyhow::anyhow!("the logs overlap too little to align their clocks"))?;
    let coarse = FitData::new(tw, s, u, fval, a, b, 20_000, 50_000, 30.0, al.excluded);
    // The fit profiled over the whole search range, its local bests polished and
    // weighed against each other (the cross-correlation's start alone landed a press
    // or two off on short recordings).
    let found = search(&coarse, range, dx);
    let mut best: (Vec<f64>, f64) = match &found {
        Some(f) => (f.best.clone(), 0.0),
        None => coarse_fit(&coarse, dx),
    };
    if best.0.is_empty() {
        best = coarse_fit(&coarse, dx);
    }
    // Polish at full rate on the first stretch of the overlap.
    let span = (b - a)
        .min(100_000.0 * median_period(u).max(1e-6))
        .min(50_000.0 * median_period(tw).max(1e-6));
    let fine = FitData::new(
        tw,
        s,
        u,
        fval,
        a,
        a + span.max(1.0),
        50_000,
        100_000,
        30.0,
        al.excluded,
    );
    let p = best.0.clone();
    let grid = 2.0 * median_period(&fine.st).max(median_period(&fine.ft));
    let step = [grid, 0.3, 0.5];
    // The polish stays in the best's basin: within a second (or two grid steps).
    let r = fit::nelder_mead(fine.cost_around(p[0], grid.max(1.0)), &p, &step, 300);
    let d = if r.1 < f64::MAX { r.0[0] } else { p[0] };
    if (d.abs() - range).abs() < 1e-9 || d.abs() > range {
        warnings.add("clock_offset_at_limit", || format!("the estimated clock offset reached the search limit ±{range} s; widen it with AnalysisOptions.max_clock_offset_s or give AnalysisOptions.clock_offset_s"));
    }
    // The search range is a bound the user set: the polished fit may not leave it.
    Ok((d.clamp(-range, range), found))
}

/// The lag model fitted with the offset free from the cross-correlation's start `dx`
/// and three time constants (when the profile found nothing).
fn coarse_fit(coarse: &FitData, dx: f64) -> (Vec<f64>, f64) {
    let tries: Vec<(Vec<f64>, f64)> = [0.05f64, 0.5, 5.0]
        .par_iter()
        .map(|&tau0| {
            let start = [dx + 0.5 * tau0, tau0.ln(), 0.0];
            let step = [(0.2 * tau0).max(2.0 * median_period(&coarse.st)), 1.0, 1.5];
            fit::nelder_mead(coarse.cost(None), &start, &step, 300)
        })
        .collect();
    tries
        .into_iter()
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap_or((vec![dx, 0.0, 0.0], f64::MAX))
}

/// Coarse offset by cross-correlation: the shift lag Δ (in the force frame u) that
/// maximises |corr(s(t), F(t + Δ))| over |Δ| ≤ range. Returns (Δ, sign of corr).
fn xcorr_offset(
    tw: &[f64],
    s: &[f64],
    u: &[f64],
    f: &[f64],
    a: f64,
    b: f64,
    range: f64,
) -> Option<(f64, f64)> {
    let dt_s = median_period(tw);
    let dt_f = median_period(u);
    let g = dt_s
        .max(dt_f)
        .max((b - a) / 20000.0)
        .max(2.0 * range / 4000.0);
    if g.is_nan() || g <= 0.0 || b <= a {
        return None;
    }
    let n = ((b - a) / g).floor() as usize + 1;
    // Shift on the grid (gaps bridged).
    let filled = assign::fill_gaps(tw, s);
    let mut h = 0;
    let sg: Vec<f64> = (0..n)
        .map(|j| fit::interp(tw, &filled, a + j as f64 * g, &mut h))
        .collect();
    let f0 = a - range;
    let nf = ((b + range - f0) / g).floor() as usize + 2;
    let mut h = 0;
    let fg: Vec<f64> = (0..nf)
        .map(|j| fit::interp(u, f, f0 + j as f64 * g, &mut h))
        .collect();
    let ms = sg.iter().sum::<f64>() / n as f64;
    let mf = fg.iter().sum::<f64>() / nf as f64;
    let lags = (range / g).floor() as isize;
    let mut best = (0.0, 0.0f64, 1.0);
    for l in -lags..=lags {
        let off = (range / g).round() as isize + l;
        let mut acc = 0.0;
        for (j, sv) in sg.iter().enumerate() {
            let k = j as isize + off;
            if k >= 0 && (k as usize) < nf {
                acc += (sv - ms) * (fg[k as usize] - mf);
            }
        }
        if acc.abs() > best.1.abs() {
            best = (l as f64 * g, acc, acc.signum());
        }
    }
    Some((best.0, best.2))
}
