//! One grating's response tested against its rivals, on the lag-corrected signal: the
//! shift against the lag model's response x (the force as the part follows it: delay
//! and relaxation included), where a part that follows its model draws a line.
//!
//! - **A slow variation** (temperature the reference does not remove, or all of it
//!   without a reference; drift): hat functions with knots [`slow_spacing_s`] apart.
//!   The force must explain the shift beyond it (a nested test: the share of what the
//!   slow curve leaves that x explains, and |K| over its standard error with the
//!   residuals' autocorrelation allowed for). The lag model's own time constant may
//!   not absorb it: x is taken at τ ≤ a quarter of the knot spacing.
//! - **K from the loading branch**: the slope of the shift on x over the rows where x
//!   rises, and at rest, beside the slow curve. A bond that lets go on unloading lifts
//!   the unloading branch, and a fit to every row read K up to 8 % high.
//! - **Hysteresis and non-linearity**, % of span as the tactile-array paper defines
//!   them, from that calibration line on the lag-corrected signal: a perfectly elastic
//!   part seen through a pure delay or a viscoelastic lag reads about 0 (it read 37 %
//!   against the raw force).
//! - **Each press explained**: the gain of the shift on x over each press's window, so
//!   that presses the force has and the shift does not (a clock jump, another run's
//!   force, a bond that broke) are seen.

use super::linearity::Branch;
use super::results::{PulseGain, SlowTest};
use super::slow::{SlowBasis, SlowFit, SlowNormal};
use super::GratingContext;
use crate::fit::{LagModelCost, LagModelFit};
use crate::segment::percentile_of;

/// Shortest knot spacing of the slow curve, s: temperature in a lab changes over
/// minutes.
const MIN_SLOW_SPACING_S: f64 = 60.0;

/// Knot spacing of the slow curve: at least a minute, four times the longest press
/// and twice the median spacing of the presses, so that it cannot draw a press.
pub(super) fn slow_spacing_s(ctx: &GratingContext) -> f64 {
    let fu = ctx.fu;
    let pulses = &ctx.seg.pulses;
    let longest = pulses
        .iter()
        .map(|p| fu[p.end] - fu[p.start])
        .fold(0.0, f64::max);
    let mut gaps: Vec<f64> = pulses
        .windows(2)
        .map(|w| fu[w[1].start] - fu[w[0].start])
        .collect();
    gaps.sort_by(f64::total_cmp);
    let spacing = gaps.get(gaps.len() / 2).copied().unwrap_or(0.0);
    MIN_SLOW_SPACING_S.max(4.0 * longest).max(2.0 * spacing)
}

/// The hysteresis a grating bonded in `core` may show, % of span: its material's
/// `hysteresis_limit_percent_span`, else the printer's default.
///
/// ```
/// let design = fbgforge_core::design::load(std::path::Path::new(concat!(
///     env!("CARGO_MANIFEST_DIR"),
///     "/../../designs/clip-on-34mm.toml"
/// )))?;
/// // The shipped materials state none: the PolyJet printer's default.
/// assert_eq!(fbgforge_verify::analysis::hysteresis_limit_percent_span(&design, Some("psc2")), 10.0);
/// # Ok::<(), anyhow::Error>(())
/// ```
pub fn hysteresis_limit_percent_span(design: &crate::spec::Design, core: Option<&str>) -> f64 {
    let stated = core
        .and_then(|c| design.module.as_ref()?.cores.iter().find(|x| x.name == c))
        .and_then(|c| design.materials.get(&c.material))
        .and_then(|m| m.hysteresis_limit_percent_span);
    stated.unwrap_or_else(|| design.printer.default_hysteresis_limit_percent_span())
}

/// One grating's response against its rivals.
pub(super) struct ResponseFigures {
    /// The lag-corrected force at each row, N (NaN where unused).
    pub x: Vec<f64>,
    /// The branch of each row.
    pub branch: Vec<Branch>,
    /// K from the loading branch and rest, beside the slow curve, pm/N.
    pub k_load: f64,
    /// Its standard error, white residuals, pm/N.
    pub k_load_std_error: f64,
    /// Its standard error allowing for the residuals' autocorrelation, pm/N.
    pub k_load_std_error_eff: f64,
    /// Lag-1 autocorrelation of the full fit's residuals, and the effective samples.
    pub rho: f64,
    /// Effective number of independent samples.
    pub n_eff: f64,
    /// The nested test.
    pub slow: SlowTest,
    /// Hysteresis and non-linearity, % of span (NaN when too few rows per branch).
    pub hysteresis_percent_span: f64,
    /// Largest distance of the loading branch from its line, % of span.
    pub nonlinearity_percent_span: f64,
    /// Each trusted press's gain.
    pub gains: Vec<PulseGain>,
    /// Largest x, N.
    pub x_max: f64,
}

/// The rows a fit uses: shift and x finite.
fn usable(s: &[f64], x: &[f64], i: usize) -> bool {
    s[i].is_finite() && x[i].is_finite()
}

/// Fit the shift `s` on [x, hats] (or hats alone) over the rows `keep` admits.
fn fit_rows(
    ctx: &GratingContext,
    (s, x): (&[f64], &[f64]),
    basis: SlowBasis,
    with_x: bool,
    keep: impl Fn(usize) -> bool,
) -> Option<SlowFit> {
    let mut ne = SlowNormal::new(basis, with_x);
    for i in 0..s.len() {
        if usable(s, x, i) && keep(i) {
            ne.add(ctx.tw[i], x[i], s[i]);
        }
    }
    ne.solve()
}

/// Lag-1 autocorrelation of the residuals of `f` over consecutive used rows, and the
/// effective number of independent samples n (1 − ρ)/(1 + ρ).
fn independence(
    ctx: &GratingContext,
    (s, x): (&[f64], &[f64]),
    basis: &SlowBasis,
    f: &SlowFit,
) -> (f64, f64) {
    let (mut num, mut den, mut prev, mut n) = (0.0, 0.0, f64::NAN, 0usize);
    for i in 0..s.len() {
        if !usable(s, x, i) {
            prev = f64::NAN;
            continue;
        }
        let r = s[i] - f.k * x[i] - basis.value(&f.hats, ctx.tw[i]);
        den += r * r;
        if prev.is_finite() {
            num += r * prev;
        }
        prev = r;
        n += 1;
    }
    let rho = if den > 0.0 {
        (num / den).clamp(-1.0, 1.0)
    } else {
        0.0
    };
    let n_eff = (n as f64 * (1.0 - rho) / (1.0 + rho)).clamp(2.0f64.min(n as f64), n as f64);
    (rho, n_eff)
}

/// The branch of every row from the slope of x over ±`h` rows, with a dead band of
/// the slope's noise at rest (four robust deviations) and 3 % of x's range per second.
fn branches(tw: &[f64], x: &[f64], x_max: f64) -> Vec<Branch> {
    let n = x.len();
    let period = crate::logs::time::median_period(tw).max(1e-9);
    let h = ((0.1 / period).round() as usize).max(1);
    let slope = |i: usize| -> f64 {
        let (a, b) = (i.saturating_sub(h), (i + h).min(n - 1));
        if b <= a || !x[a].is_finite() || !x[b].is_finite() {
            return f64::NAN;
        }
        (x[b] - x[a]) / (tw[b] - tw[a])
    };
    let rest_level = 0.03 * x_max;
    // The slopes are computed where read, not kept: two columns of a long log (58 MB
    // at 1 h × 1 kHz) for a median and one comparison a row.
    let at_rest = || {
        (0..n)
            .filter(move |&i| x[i].is_finite() && x[i] < rest_level)
            .map(slope)
            .filter(|v| v.is_finite())
            .map(f64::abs)
    };
    let noise = if at_rest().nth(9).is_some() {
        1.4826 * percentile_of(at_rest, 0.5)
    } else {
        0.0
    };
    let band = (4.0 * noise).max(0.03 * x_max);
    (0..n)
        .map(|i| {
            if !x[i].is_finite() {
                return Branch::None;
            } else if x[i] < rest_level {
                return Branch::Rest;
            }
            let v = slope(i);
            if !v.is_finite() {
                Branch::Hold
            } else if v > band {
                Branch::Loading
            } else if v < -band {
                Branch::Unloading
            } else {
                Branch::Hold
            }
        })
        .collect()
}

/// Test one grating's response against the slow rival, take K from the loading
/// branch, measure the loop and each press's gain. `s`: the compensated shift at each
/// row; `lm`: its lag-model fit; `full`: the lag model over every row.
pub(super) fn response_figures(
    ctx: &GratingContext,
    s: &[f64],
    lm: &LagModelFit,
    full: &LagModelCost,
) -> Option<ResponseFigures> {
    let spacing = slow_spacing_s(ctx);
    let tau_bound = spacing / 4.0;
    let tau = lm.tau_s.min(tau_bound);
    let x = full.responses(lm, tau);
    // The usable rows are counted, not listed (a list is a column of its own).
    let mut used = (0usize, None::<usize>, 0usize, 0.0f64);
    for i in (0..s.len()).filter(|&i| usable(s, &x, i)) {
        used = (used.0 + 1, used.1.or(Some(i)), i, used.3.max(x[i]));
    }
    let (n_used, first, last, x_max) = (used.0, used.1?, used.2, used.3);
    let basis = SlowBasis::new((ctx.tw[first], ctx.tw[last]), spacing);
    let slow_only = fit_rows(ctx, (s, &x), basis, false, |_| true)?;
    let both = fit_rows(ctx, (s, &x), basis, true, |_| true)?;
    let (rho, n_eff) = independence(ctx, (s, &x), &basis, &both);
    let branch = branches(ctx.tw, &x, x_max);
    let loading = |i: usize| matches!(branch[i], Branch::Loading | Branch::Rest);
    let load = fit_rows(ctx, (s, &x), basis, true, loading).unwrap_or_else(|| both.clone());
    let p = basis.len() + 1;
    let inflate = (n_used as f64 / n_eff).sqrt();
    let dof = (n_eff - p as f64).max(1.0);
    let f_stat = (slow_only.rss - both.rss).max(0.0) / (both.rss / dof).max(1e-300);
    let d: Vec<f64> = (0..s.len())
        .map(|i| {
            if usable(s, &x, i) {
                s[i] - basis.value(&load.hats, ctx.tw[i])
            } else {
                f64::NAN
            }
        })
        .collect();
    let slow = SlowTest {
        knot_spacing_s: basis.spacing_s(),
        knots: basis.len(),
        tau_bound_s: tau_bound,
        tau_bounded: lm.tau_s > tau_bound,
        share_beyond_slow: if slow_only.rss > 0.0 {
            1.0 - both.rss / slow_only.rss
        } else {
            f64::NAN
        },
        f_statistic: f_stat,
        slow_variation_pm: peak_to_peak(&slow_only.hats),
        k_all_rows_pm_per_n: both.k,
    };
    let (hyst, nonlin) = super::linearity::lag_corrected_loop(&x, &d, &branch, load.k, x_max);
    let gains = pulse_gains(ctx, &x, &d, load.k, tau);
    Some(ResponseFigures {
        k_load: load.k,
        k_load_std_error: load.k_std_error,
        k_load_std_error_eff: load.k_std_error * inflate,
        rho,
        n_eff,
        slow,
        hysteresis_percent_span: hyst,
        nonlinearity_percent_span: nonlin,
        gains,
        x_max,
        x,
        branch,
    })
}

/// Peak-to-peak of the slow curve's knots, pm (how large a slow variation the log
/// holds).
fn peak_to_peak(v: &[f64]) -> f64 {
    let (lo, hi) = v
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    hi - lo
}

/// The gain of the shift on K·x over each trusted press the log covers: 1 when the
/// press is explained, 0 when the shift shows nothing of it. The window runs from a
/// quarter of the press before it to the next press (at most its length or two time
/// constants after it); a local baseline is fitted with the gain.
fn pulse_gains(ctx: &GratingContext, x: &[f64], d: &[f64], k: f64, tau: f64) -> Vec<PulseGain> {
    let (tw, fu) = (ctx.tw, ctx.fu);
    let pulses = &ctx.seg.pulses;
    let mut out = Vec::new();
    for (p, span) in pulses.iter().enumerate() {
        if ctx.untrusted.contains(&p) {
            continue;
        }
        let (a, b) = (fu[span.start], fu[span.end]);
        let len = b - a;
        let next = pulses.get(p + 1).map_or(f64::INFINITY, |q| fu[q.start]);
        let prev_end = if p > 0 {
            fu[pulses[p - 1].end]
        } else {
            f64::NEG_INFINITY
        };
        let lo = (a - 0.25 * len).max(prev_end);
        let hi = (b + len.max(2.0 * tau)).min(next);
        let i0 = tw.partition_point(|&t| t < lo);
        let i1 = tw.partition_point(|&t| t <= hi);
        let (mut sx, mut sy, mut sxx, mut sxy, mut syy, mut m) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        let mut covered = true;
        for i in i0..i1 {
            if !(x[i].is_finite() && d[i].is_finite()) {
                covered &= ctx.fc[i].is_finite();
                continue;
            }
            let v = k * x[i];
            sx += v;
            sy += d[i];
            sxx += v * v;
            sxy += v * d[i];
            syy += d[i] * d[i];
            m += 1.0;
        }
        // Only presses the log covers whole, with a swing to fit a gain to.
        if !covered || m < 4.0 || a < tw[0] || b > tw[tw.len() - 1] {
            continue;
        }
        let vxx = sxx - sx * sx / m;
        if vxx <= 0.0 {
            continue;
        }
        let gain = (sxy - sx * sy / m) / vxx;
        let rss = (syy - sy * sy / m - gain * gain * vxx).max(0.0);
        out.push(PulseGain {
            pulse: p + 1,
            start_s: a,
            end_s: b,
            gain,
            gain_std_error: (rss / (m - 2.0).max(1.0) / vxx).sqrt(),
        });
    }
    out
}
