//! One grating's lags: per segment (sub-sample cross-correlation against the fitted
//! lag model's response, with the peak times of presses and cycles), and summarised
//! as Δt_max with its uncertainty (the statistics are [`crate::lag`]'s).

use super::results::PulseResult;
use super::{GratingContext, LagFigures};
use crate::fit::{self, LagModelFit};
use crate::lag;
use crate::logs::time::median_period;
use crate::segment::SegmentKind;

/// Measure the lag of every segment and summarise them. A segment seen in a few
/// samples is fitted nearly exactly, so 2 % of the sample period (0.01 s at 2 Hz) is
/// allowed on top of the noise.
pub(super) fn lag_figures(
    ctx: &GratingContext,
    d: &[f64],
    lm: &LagModelFit,
    delay: f64,
) -> LagFigures {
    let mut pres = segment_lags(ctx, d, lm, delay);
    let systematic = 0.02 * median_period(ctx.tw);
    let lags: Vec<(f64, f64)> = pres
        .iter()
        .map(|p| (p.lag_s, p.lag_uncertainty_s))
        .collect();
    let summary = lag::summarise(&lags, systematic);
    for p in &mut pres {
        p.lag_uncertainty_s = p.lag_uncertainty_s.hypot(systematic);
    }
    let mean_lag_s = if pres.is_empty() {
        f64::NAN
    } else {
        pres.iter().map(|p| p.lag_s).sum::<f64>() / pres.len() as f64
    };
    let (max_lag_s, max_lag_uncertainty_s) = summary.map_or((f64::NAN, f64::NAN), |s| {
        // The timing bound is the half-width of a uniform error: its standard
        // uncertainty is bound/√3.
        (
            s.max_lag_s,
            s.max_lag_uncertainty_s.hypot(ctx.timing_s / 3f64.sqrt()),
        )
    });
    LagFigures {
        pulses: pres,
        summary,
        mean_lag_s,
        max_lag_s,
        max_lag_uncertainty_s,
    }
}

/// Per segment that the wavelength log covers whole: the lag of the drift-free shift
/// `d` behind the force by sub-sample cross-correlation over the segment's window
/// ([`lag::segment_lag`]), and for presses and cycles the peak times (vertices of
/// parabolas through the top 5 %).
fn segment_lags(
    ctx: &GratingContext,
    d: &[f64],
    lm: &LagModelFit,
    delay_s: f64,
) -> Vec<PulseResult> {
    let (tw, fu) = (ctx.tw, ctx.fu);
    let sign = if lm.k_pm_per_n < 0.0 { -1.0 } else { 1.0 };
    let model_lag_s = delay_s.abs() + (1.0 - lm.instant_fraction) * lm.tau_s;
    let (fval, model) = model_response(ctx, lm, delay_s);
    let (first, last) = (tw[0], tw[tw.len() - 1]);
    let mut pres = Vec::new();
    for s in &ctx.seg.segments {
        let (t_start, t_end) = (fu[s.start], fu[s.end]);
        // Only changes of force the log covers whole, of pulses whose force is trusted.
        if t_start < first || t_end > last || ctx.untrusted.contains(&s.pulse) {
            continue;
        }
        let window = (fu[s.window.0], fu[s.window.1]);
        let Some(l) = window_lag(ctx, d, (&fval, &model), window, model_lag_s, sign) else {
            continue;
        };
        let wf = &fval[s.window.0..=s.window.1];
        let peak_force = wf.iter().copied().fold(f64::NAN, f64::max);
        let (tf, ts, ps) = if matches!(s.kind, SegmentKind::Pulse | SegmentKind::Cycle) {
            peak_times(ctx, d, &fval, s, window, sign)
        } else {
            (f64::NAN, f64::NAN, f64::NAN)
        };
        pres.push(PulseResult {
            index: pres.len() + 1,
            pulse: s.pulse + 1,
            kind: s.kind,
            start_s: t_start,
            end_s: t_end,
            peak_force_n: peak_force,
            peak_force_time_s: tf,
            peak_shift_pm: ps,
            peak_shift_time_s: ts,
            lag_s: l.lag_s,
            lag_uncertainty_s: l.uncertainty_s,
        });
    }
    pres
}

/// The force smoothed over ±0.05 s and the fitted lag model's response to it, on the
/// force log's own grid: the shape the data are matched against. Both come from the
/// smoothed force (a symmetric average moves no edge): the force noise the model
/// response carries along would otherwise pull the model's own lag towards its delay.
fn model_response(ctx: &GratingContext, lm: &LagModelFit, delay_s: f64) -> (Vec<f64>, Vec<f64>) {
    let fu = ctx.fu;
    let m = ((0.05 / median_period(fu).max(1e-9)).round() as usize).min(50);
    let fval = crate::segment::moving_average(ctx.fval, m);
    let mut y = Vec::new();
    fit::sls_response(fu, &fval, lm.tau_s, lm.instant_fraction, &mut y);
    let mut h = 0;
    let model: Vec<f64> = fu
        .iter()
        .map(|&t| fit::interp(fu, &y, t - delay_s, &mut h))
        .collect();
    (fval, model)
}

/// The lag of the data behind the force in one window: the model's own lag behind the
/// force plus the data's behind the model, with the data's uncertainty; None when
/// either is at the search range's edge, uncertain beyond measure, or the window
/// holds no clear response.
fn window_lag(
    ctx: &GratingContext,
    d: &[f64],
    (fval, model): (&[f64], &[f64]),
    window: (f64, f64),
    model_lag_s: f64,
    sign: f64,
) -> Option<lag::SegmentLag> {
    let fu = ctx.fu;
    // The model's lag behind the force in this window, in continuous time (both at the
    // force log's rate, noise-free) ...
    let range = lag::search_range_s(window, model_lag_s);
    // The force and the model over the window and the search range, at most 4 000
    // samples (both are smooth): every scan step then costs the window's samples, not
    // a walk through a kHz log.
    let lo = fu
        .partition_point(|&x| x < window.0 - range)
        .saturating_sub(1);
    let hi = (fu.partition_point(|&x| x <= window.1 + range) + 1).min(fu.len());
    let stride = (hi - lo).div_ceil(4000).max(1);
    let lt: Vec<f64> = fu[lo..hi].iter().step_by(stride).copied().collect();
    let lf: Vec<f64> = fval[lo..hi].iter().step_by(stride).copied().collect();
    let lm_: Vec<f64> = model[lo..hi].iter().step_by(stride).copied().collect();
    let lm_lag = lag::segment_lag(&lt, &lm_, &lt, &lf, window, range, 1.0)?;
    // ... and how late the data run behind the model here, with its uncertainty:
    // matched against the model's shape, not the force's, the estimate does not depend
    // on where the samples fall (the force's shape gave 0.19 s for a 0.125 s lag at
    // 2 Hz).
    let l = lag::segment_lag(ctx.tw, d, &lt, &lm_, window, range, sign)?;
    if l.at_limit
        || lm_lag.at_limit
        || !l.uncertainty_s.is_finite()
        || l.r_squared < lag::MIN_SEGMENT_R_SQUARED
    {
        return None;
    }
    Some(lag::SegmentLag {
        lag_s: lm_lag.lag_s + l.lag_s,
        ..l
    })
}

/// A press's or cycle's peak times: of the force, and of the shift with its value
/// (vertices of parabolas through the top 5 %); (force peak s, shift peak s, shift
/// peak pm).
fn peak_times(
    ctx: &GratingContext,
    d: &[f64],
    fval: &[f64],
    s: &crate::segment::Segment,
    window: (f64, f64),
    sign: f64,
) -> (f64, f64, f64) {
    let (tw, fu) = (ctx.tw, ctx.fu);
    let wf = &fval[s.window.0..=s.window.1];
    let seg_t = &fu[s.start..=s.end];
    let seg_f = &fval[s.start..=s.end];
    let base = seg_f
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min)
        .min(wf[0]);
    let im = (0..seg_f.len())
        .max_by(|&x, &y| seg_f[x].total_cmp(&seg_f[y]))
        .unwrap_or(0);
    let tf = fit::peak_vertex(seg_t, seg_f, im, base + 0.95 * (seg_f[im] - base)).0;
    let (mut ts, mut ps) = (f64::NAN, f64::NAN);
    let i0 = tw.partition_point(|&x| x < window.0);
    let i1 = tw.partition_point(|&x| x <= window.1);
    let seg_d: Vec<f64> = d[i0..i1].iter().map(|v| sign * v).collect();
    if let Some(jm) = (0..seg_d.len())
        .filter(|&j| seg_d[j].is_finite())
        .max_by(|&x, &y| seg_d[x].total_cmp(&seg_d[y]))
    {
        let (a, b) = fit::peak_vertex(&tw[i0..i1], &seg_d, jm, 0.95 * seg_d[jm]);
        (ts, ps) = (a, sign * b);
    }
    (tf, ts, ps)
}
