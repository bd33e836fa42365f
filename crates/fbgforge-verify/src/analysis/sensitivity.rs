//! The K fit pieces of one grating: the lag model fitted with the clocks aligned (K,
//! τ, r, delay, drift), the shift with drift removed, the residuals' independence
//! (effective samples for K's standard error), K from held levels, and the chart's line.

use super::fit_data::FitData;
use super::GratingContext;
use crate::fit::{self, LagModelCost, LagModelFit};
use crate::logs::time::median_period;
use anyhow::{bail, Result};
use rayon::prelude::*;

/// Fit the lag model to one grating's shift `s` with the clocks aligned: delay, τ and
/// r searched on a strided copy of the overlap (from `prev`'s values, or three time
/// constants for the first grating), then evaluated on every sample. Returns the fit
/// and its residual at every row (NaN where it was not used).
pub(super) fn fit_lag_model(
    ctx: &GratingContext,
    s: &[f64],
    name: &str,
    prev: Option<(f64, f64, f64)>,
) -> Result<LagModelFit> {
    let (tw, fu, fval, fc) = (ctx.tw, ctx.fu, ctx.fval, ctx.fc);
    let (span_a, span_b) = ctx.span;
    let sub = FitData::new(
        tw,
        s,
        fu,
        fval,
        span_a,
        span_b,
        20_000,
        50_000,
        30.0,
        ctx.excluded_s,
    );
    let max_delay = max_transport_delay_s(ctx);
    let mut best: (Vec<f64>, f64) = (vec![0.0, 0.0, 0.0], f64::MAX);
    // The first grating searches from three time constants; the others from its
    // solution and from a short lag without delay (their dynamics are usually alike).
    let starts: Vec<(f64, f64, f64)> = match prev {
        None => vec![(0.0, 0.05, 0.5), (0.0, 0.5, 0.5), (0.0, 5.0, 0.5)],
        Some(p) => vec![p, (0.0, 0.05, 0.5)],
    };
    let step_delay = (2.0 * median_period(&sub.st)).max(0.25).min(max_delay);
    let tries: Vec<(Vec<f64>, f64)> = starts
        .par_iter()
        .map(|&(d0, tau0, r0)| {
            let r0 = r0.clamp(1e-6, 1.0 - 1e-6);
            let start = [-d0, tau0.max(fit::TAU_MIN_S).ln(), (r0 / (1.0 - r0)).ln()];
            let cost = sub.cost_with_delay(max_delay);
            fit::nelder_mead(cost, &start, &[step_delay, 1.0, 1.5], 300)
        })
        .collect();
    for r in tries {
        if r.1 < best.1 {
            best = r;
        }
    }
    let probe = sub.cost_with_delay(max_delay);
    let lm0 = probe
        .fit_at(&best.0)
        .ok_or_else(|| anyhow::anyhow!("the lag model could not be fitted for grating `{name}`"))?;
    // Final evaluation on every sample (NaN shifts and samples outside the force
    // log are skipped inside the cost).
    let n_used = (0..tw.len())
        .filter(|&i| s[i].is_finite() && fc[i].is_finite() && ctx.row_ok[i])
        .count();
    if n_used < 10 {
        bail!(
            "grating `{name}` has only {n_used} samples where the force log overlaps the wavelength log"
        );
    }
    let full = full_cost(ctx, s);
    Ok(full
        .evaluate(lm0.offset_s, lm0.tau_s, lm0.instant_fraction)
        .unwrap_or(lm0))
}

/// The lag model over every row of the shift `s`, the clocks aligned (the delay
/// free), the untrusted stretches left out.
pub(super) fn full_cost<'a>(ctx: &'a GratingContext, s: &'a [f64]) -> LagModelCost<'a> {
    LagModelCost {
        shift_t: ctx.tw,
        shift_pm: s,
        force_t: ctx.fu,
        force_n: ctx.fval,
        fixed_offset_s: Some(0.0),
        offset_range_s: None,
        t_mid: (ctx.span.0 + ctx.span.1) / 2.0,
        excluded_s: ctx.excluded_s,
    }
}

/// The shift with the lag model's baseline and drift removed, NaN outside the force
/// log and in the stretches left out for an untrusted force.
pub(super) fn drift_free_shift(ctx: &GratingContext, s: &[f64], lm: &LagModelFit) -> Vec<f64> {
    let (tw, fc) = (ctx.tw, ctx.fc);
    let t_mid = (ctx.span.0 + ctx.span.1) / 2.0;
    (0..tw.len())
        .map(|i| {
            if fc[i].is_finite() && ctx.row_ok[i] {
                s[i] - lm.baseline_pm - lm.drift_pm_per_s * (tw[i] - t_mid)
            } else {
                f64::NAN
            }
        })
        .collect()
}

/// Lag-1 autocorrelation ρ of residuals `r` (NaN = not used) over consecutive
/// samples, the number n of used samples and the effective number of independent
/// ones, n (1 − ρ) / (1 + ρ) (an AR(1) reading of the residual; at least 2, at most n).
pub(super) fn lag1_independence(r: &[f64]) -> (f64, usize, f64) {
    let (mut num, mut den, mut n) = (0.0, 0.0, 0usize);
    for (i, v) in r.iter().enumerate() {
        if !v.is_finite() {
            continue;
        }
        n += 1;
        den += v * v;
        if let Some(next) = r.get(i + 1).filter(|x| x.is_finite()) {
            num += v * next;
        }
    }
    let rho = if den > 0.0 {
        (num / den).clamp(-1.0, 1.0)
    } else {
        0.0
    };
    let n_eff = (n as f64 * (1.0 - rho) / (1.0 + rho)).clamp(2.0_f64.min(n as f64), n as f64);
    (rho, n, n_eff)
}

/// Largest transport delay a grating's fit may take: a quarter of the median spacing
/// of the segments (beyond it a delay would match the next segment), at least 1 s.
fn max_transport_delay_s(ctx: &GratingContext) -> f64 {
    let mut starts: Vec<f64> = ctx.seg.segments.iter().map(|s| ctx.fu[s.start]).collect();
    starts.sort_by(f64::total_cmp);
    let mut gaps: Vec<f64> = starts.windows(2).map(|w| w[1] - w[0]).collect();
    gaps.sort_by(f64::total_cmp);
    gaps.get(gaps.len() / 2)
        .map_or(1.0, |g| (0.25 * g).max(1.0))
}

/// K from the held levels: (slope, its standard error, levels used) of the mean
/// drift-free shift against the mean force over the second half of every plateau and
/// rest; None unless the protocol holds levels inside its pulses and at least three
/// levels are covered by the wavelength log.
pub(super) fn plateau_sensitivity(ctx: &GratingContext, d: &[f64]) -> Option<(f64, f64, usize)> {
    if !ctx.seg.plateaus.iter().any(|p| !p.rest) {
        return None;
    }
    let (tw, fu, fc) = (ctx.tw, ctx.fu, ctx.fc);
    let mut mf = Vec::new();
    let mut md = Vec::new();
    for p in &ctx.seg.plateaus {
        let (a, b) = (fu[p.start], fu[p.end]);
        let settled = (a + b) / 2.0;
        let i0 = tw.partition_point(|&x| x < settled);
        let i1 = tw.partition_point(|&x| x <= b);
        let (mut sf, mut sd, mut n) = (0.0, 0.0, 0usize);
        for i in i0..i1 {
            if fc[i].is_finite() && d[i].is_finite() {
                sf += fc[i];
                sd += d[i];
                n += 1;
            }
        }
        if n > 0 {
            mf.push(sf / n as f64);
            md.push(sd / n as f64);
        }
    }
    if mf.len() < 3 {
        return None;
    }
    let line = fit::fit_line(&mf, &md)?;
    Some((line.slope, line.slope_std_error, mf.len()))
}

/// The intercept of the chart's line of slope `k` through the centre of the data, so
/// that the plot and the table never show two numbers (`fallback` without data).
pub(super) fn chart_intercept(fc: &[f64], d: &[f64], k: f64, fallback: f64) -> f64 {
    let (sum, count) = fc
        .iter()
        .zip(d)
        .filter(|(f, v)| f.is_finite() && v.is_finite())
        .fold((0.0, 0usize), |(s, n), (f, v)| (s + v - k * f, n + 1));
    if count > 0 {
        sum / count as f64
    } else {
        fallback
    }
}
