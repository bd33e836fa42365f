//! One grating measured: what every grating shares ([`GratingContext`]), the lag
//! model, the straight line, the segment lags, Q and the plateau K put together into a
//! [`GratingResult`]; the primary grating first, the rest in parallel.

use super::instrument::{instrument_check, Readings};
use super::lags::lag_figures;
use super::linearity::hysteresis_and_linearity;
use super::linearity::Branch;
use super::quality::quality_q;
use super::response::response_figures;
use super::results::GratingResult;
use super::sensitivity::{
    chart_intercept, drift_free_shift, fit_lag_model, full_cost, lag1_independence,
    plateau_sensitivity,
};
use super::series::DriftLine;
use super::GratingContext;
use crate::fit;
use anyhow::Result;
use rayon::prelude::*;

/// A measured grating: its result, how to rebuild its drift-free shift for the plots
/// (not kept per row: eight gratings of an hour at 1 kHz are 230 MB), and the chart's
/// line.
pub(super) struct MeasuredGrating {
    pub(super) result: GratingResult,
    /// Index into [`GratingContext::used`] of the grating's compensated shift.
    pub(super) used: usize,
    /// The lag model's baseline and drift, removed from the shift for the plots.
    pub(super) drift: DriftLine,
    /// The chart's line: the table's K and the baseline, pm/N and pm.
    pub(super) slope: f64,
    pub(super) intercept: f64,
}

/// A measured grating, or why it could not be measured.
pub(super) type Measured = Result<MeasuredGrating>;

/// The loop a timing error of ±`u` s per row opens on a perfectly elastic part, % of
/// span: the branches move apart by 2·u·|dx/dt| (the median rate over the loading and
/// unloading rows), over the span x_max.
fn timing_loop_percent(tw: &[f64], x: &[f64], branch: &[Branch], x_max: f64, u: f64) -> f64 {
    if !(u > 0.0 && x_max > 0.0) || x.len() < 3 {
        return 0.0;
    }
    let rates: Vec<f64> = (1..x.len() - 1)
        .filter(|&i| matches!(branch[i], Branch::Loading | Branch::Unloading))
        .map(|i| ((x[i + 1] - x[i - 1]) / (tw[i + 1] - tw[i - 1])).abs())
        .filter(|r| r.is_finite())
        .collect();
    if rates.is_empty() {
        return 0.0;
    }
    200.0 * u * crate::segment::percentile(&rates, 0.5) / x_max
}

/// Fit the lag model, the straight line and the per-segment lags of `used[k]`; `prev`
/// seeds the delay, τ and r from an already measured grating.
fn measure_grating(ctx: &GratingContext, k_used: usize, prev: Option<(f64, f64, f64)>) -> Measured {
    let gi = &ctx.shifts.used[k_used];
    let shift = ctx.shifts.shift_pm(k_used);
    let s: &[f64] = &shift;
    let g = ctx.strain[*gi];
    let t = &ctx.tracks[*gi];
    let fc = ctx.fc;
    let lm = fit_lag_model(ctx, s, &g.name, prev)?;
    let delay = -lm.offset_s;
    let drift = DriftLine::of(ctx, &lm);
    let d = drift_free_shift(ctx, s, &lm);
    let line = fit::fit_line(fc, &d).ok_or_else(|| {
        anyhow::anyhow!(
            "grating `{}`: the force does not vary; no line can be fitted",
            g.name
        )
    })?;
    // The response against its rivals on the lag-corrected signal: K from the
    // loading branch beside a slow variation, the loop, each press's gain; then the
    // interrogator's own readings. Without rows for it, the lag model's figures.
    let rf = response_figures(ctx, s, &lm, &full_cost(ctx, s));
    let (k, se_k, se_k_eff, rho, n_eff, response_r2, hyst, nonlin) = match &rf {
        Some(r) => (
            r.k_load,
            r.k_load_std_error,
            r.k_load_std_error_eff,
            r.rho,
            r.n_eff,
            r.slow.share_beyond_slow,
            r.hysteresis_percent_span,
            r.nonlinearity_percent_span,
        ),
        None => {
            // The lag model's residuals, for this fallback only (a column of their
            // own, not held through the rest).
            let residual = full_cost(ctx, s).residuals(&lm);
            let (h, l) = hysteresis_and_linearity(fc, &d, &line);
            let t_mid = (ctx.span.0 + ctx.span.1) / 2.0;
            let (rho, n, n_eff) = lag1_independence(&residual);
            let se = lm.k_std_error_pm_per_n;
            let r2 = fit::response_r_squared(ctx.tw, s, &residual, t_mid);
            (
                lm.k_pm_per_n,
                se,
                se * (n as f64 / n_eff).sqrt(),
                rho,
                n_eff,
                r2,
                h,
                l,
            )
        }
    };
    let instrument = rf.as_ref().map_or_else(Default::default, |r| {
        instrument_check(&Readings {
            offset_pm: &t.offset_pm,
            x: &r.x,
            k,
            x_max: r.x_max,
        })
    });
    let loading_rows = rf.as_ref().map_or(0, |r| {
        r.branch
            .iter()
            .filter(|b| matches!(b, Branch::Loading | Branch::Rest))
            .count()
    });
    let timing_loop = rf.as_ref().map_or(0.0, |r| {
        timing_loop_percent(ctx.tw, &r.x, &r.branch, r.x_max, ctx.row_timing_s)
    });
    // The shift, the lag-corrected force and the branches are read no more (columns of
    // their own at a long log's length): freed before the lags' columns are made.
    drop(shift);
    let rf = rf.map(|mut r| {
        r.x = Vec::new();
        r.branch = Vec::new();
        r
    });
    let lags = lag_figures(ctx, &d, &lm, delay);
    // Peaks found in spectra carry their own standard errors: propagated to K they
    // floor K's standard error (the residuals already hold their random part).
    let se_peaks = crate::logs::assign::slope_std_error_from_errors(fc, &t.std_error_pm);
    let se_k_eff = se_k_eff.max(se_peaks.unwrap_or(0.0));
    let q = quality_q(k, se_k_eff, line.r_squared, &lags, ctx.relative);
    let plateau = plateau_sensitivity(ctx, &d);
    let summary = lags.summary;
    let result = GratingResult {
        grating: g.name.clone(),
        core: g.core.clone(),
        core_material: g
            .core
            .as_ref()
            .and_then(|c| ctx.module.cores.iter().find(|x| &x.name == c))
            .map(|c| c.material.clone()),
        nominal_nm: g.bragg_wavelength_nm,
        window_half_width_nm: ctx.hw,
        rows_with_peak: t.rows_present,
        rows_ambiguous: t.rows_ambiguous,
        sensitivity_pm_per_n: k,
        sensitivity_std_error_pm_per_n: se_k,
        lag_model_sensitivity_pm_per_n: lm.k_pm_per_n,
        loading_rows,
        slow_test: rf.as_ref().map(|r| r.slow.clone()),
        pulse_gains: rf.as_ref().map(|r| r.gains.clone()).unwrap_or_default(),
        instrument,
        hysteresis_limit_percent_span: super::hysteresis_limit_percent_span(
            ctx.design,
            g.core.as_deref(),
        ),
        hysteresis_timing_percent_span: timing_loop,
        residual_autocorrelation: rho,
        effective_samples: n_eff,
        sensitivity_std_error_effective_pm_per_n: se_k_eff,
        sensitivity_peak_std_error_pm_per_n: se_peaks,
        sensitivity_t_statistic: k.abs() / se_k_eff,
        peak_force_n: lags
            .pulses
            .iter()
            .map(|p| p.peak_force_n)
            .fold(f64::NAN, f64::max),
        linear_slope_pm_per_n: line.slope,
        r_squared: line.r_squared,
        lag_model_r_squared: lm.r_squared,
        response_r_squared: response_r2,
        hysteresis_percent_span: hyst,
        nonlinearity_percent_span: nonlin,
        resolution_n: ctx.resolution_pm / k.abs(),
        resolution_g: ctx.resolution_pm / k.abs() / 9.80665e-3,
        max_lag_s: lags.max_lag_s,
        max_lag_uncertainty_s: lags.max_lag_uncertainty_s,
        max_lag_method: summary.map_or("none", |s| s.max_lag_method).into(),
        mean_lag_s: lags.mean_lag_s,
        median_lag_s: summary.map_or(f64::NAN, |s| s.median_lag_s),
        lag_spread_s: summary.map_or(f64::NAN, |s| s.lag_spread_s),
        quality_q_pm_per_n_s: q.value,
        quality_q_uncertainty_pm_per_n_s: q.uncertainty,
        quality_q_bound: q.bound,
        quality_q_note: q.note,
        transport_delay_s: delay,
        plateau_sensitivity_pm_per_n: plateau.map(|p| p.0),
        plateau_sensitivity_std_error_pm_per_n: plateau.map(|p| p.1),
        plateau_count: plateau.map_or(0, |p| p.2),
        sls_time_constant_s: lm.tau_s,
        sls_instant_fraction: lm.instant_fraction,
        drift_pm_per_s: lm.drift_pm_per_s,
        residual_rms_pm: lm.rms_pm,
        pulses: lags.pulses,
    };
    // The chart draws the table's K (the lag model's static sensitivity).
    let intercept = chart_intercept(fc, &d, k, line.intercept);
    Ok(MeasuredGrating {
        result,
        used: k_used,
        drift,
        slope: k,
        intercept,
    })
}

/// A log with more rows than this has its gratings measured one at a time: each
/// measurement holds some eight columns of its rows (230 MB at 1 h × 1 kHz), too much
/// to hold twice.
const PARALLEL_MAX_ROWS: usize = 1_000_000;

/// Measure every grating: the primary first (its τ and r seed the others), the rest
/// in parallel (one at a time for a long log, [`PARALLEL_MAX_ROWS`]).
pub(super) fn measure_all(
    ctx: &GratingContext,
    primary: usize,
) -> Result<(MeasuredGrating, Vec<Measured>)> {
    let first = measure_grating(ctx, primary, None)?;
    let seed = Some((
        first.result.transport_delay_s,
        first.result.sls_time_constant_s,
        first.result.sls_instant_fraction,
    ));
    let others: Vec<usize> = (0..ctx.shifts.used.len())
        .filter(|&k| k != primary)
        .collect();
    let rest: Vec<Measured> = if ctx.tw.len() > PARALLEL_MAX_ROWS {
        others
            .iter()
            .map(|&k| measure_grating(ctx, k, seed))
            .collect()
    } else {
        others
            .par_iter()
            .map(|&k| measure_grating(ctx, k, seed))
            .collect()
    };
    Ok((first, rest))
}
