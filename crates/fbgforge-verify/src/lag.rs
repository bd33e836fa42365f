//! The lag of the wavelength response behind the force, per segment, and Δt_max.
//!
//! **Per segment** the lag is the time shift Δ that best lines the shift up with the
//! force inside the segment's window: Δλ(t_i) ≈ a + g·F(t_i − Δ) by least squares,
//! with a and g free (so drift, level and gain do not matter) and g of the sign of K.
//! The force comes from the force log at its own (usually much higher) rate, so Δ is
//! not tied to the wavelength log's sample grid: the residual sum of squares is
//! scanned on a coarse then a fine grid of Δ and its minimum located by a parabola
//! through the three best points (sub-sample cross-correlation). Its uncertainty comes
//! from the curvature of that parabola and the residual variance:
//! se(Δ) = √(σ² / c) with SSR(Δ) ≈ SSR_min + c (Δ − Δ̂)². For a pure delay Δ is the
//! delay whatever the pulse shape; a plateau adds samples that fix a and g but no
//! noise-driven peak time.
//!
//! **Δt_max** (reference §1: the largest lag between a force peak and the matching
//! wavelength peak). The maximum of noisy estimates of equal lags is biased upwards
//! (by about one standard deviation for six pulses), which made Q read low. So the
//! per-segment lags are first tested for a common value: when their scatter about
//! the weighted mean is what their uncertainties allow (χ² below its 99.9 % point),
//! the pulses share one lag and Δt_max is that weighted mean (`pooled`); otherwise the
//! lags really differ and Δt_max is the largest of them (`largest`), as the paper
//! defines it.

use super::fit::interp;
use serde::Serialize;

/// The lag of one segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SegmentLag {
    /// Lag of the shift behind the force, s.
    pub lag_s: f64,
    /// Its standard uncertainty from the noise, s.
    pub uncertainty_s: f64,
    /// Gain g of the local fit, pm/N.
    pub gain: f64,
    /// The best shift lay at the edge of the searched range: not a real minimum.
    pub at_limit: bool,
    /// Share of the window's shift variance the shifted force explains.
    pub r_squared: f64,
}

/// Least share of a window's variance the shifted force must explain for its lag to
/// count (below it the window holds no clear response).
pub(crate) const MIN_SEGMENT_R_SQUARED: f64 = 0.5;

/// Most response samples a segment's fit uses (evenly strided beyond).
const MAX_SAMPLES: usize = 600;

/// Lag of the response (`resp_t`, `resp`, NaN = gap) behind the force (`force_t`,
/// `force`, same clock) inside `window` (s), searched over |Δ| ≤ `max_lag_s`, with the
/// gain of the sign of `sign` (the sign of K). None when the window holds fewer than
/// four samples or the force does not vary in it.
pub fn segment_lag(
    resp_t: &[f64],
    resp: &[f64],
    force_t: &[f64],
    force: &[f64],
    window: (f64, f64),
    max_lag_s: f64,
    sign: f64,
) -> Option<SegmentLag> {
    if force_t.len() < 2 || !(max_lag_s > 0.0 && max_lag_s.is_finite()) {
        return None;
    }
    let scan = LagScan::new((resp_t, resp), (force_t, force), window, sign)?;
    // Coarse scan, then a fine one around its best point.
    let coarse_n = 61;
    let c = 2.0 * max_lag_s / (coarse_n - 1) as f64;
    let coarse = scan.scan(-max_lag_s, c, coarse_n);
    if scan.sst.is_nan() || scan.sst <= 0.0 || coarse.iter().all(|p| p.2 == 0.0) {
        return None;
    }
    let best = argmin(&coarse);
    let fine_n = 61;
    let h = 3.0 * c / (fine_n - 1) as f64;
    let fine = scan.scan(coarse[best].0 - 1.5 * c, h, fine_n);
    let (lag, ssr, curv) = parabola_minimum(&fine, scan.n);
    let sigma2 = ssr.max(0.0) / (scan.n - 3.0).max(1.0);
    let uncertainty = if curv > 0.0 {
        (sigma2 / curv).sqrt()
    } else {
        f64::INFINITY
    };
    Some(SegmentLag {
        lag_s: lag,
        uncertainty_s: uncertainty,
        gain: scan.eval(lag).1,
        at_limit: lag.abs() >= max_lag_s - c,
        r_squared: 1.0 - ssr.max(0.0) / scan.sst,
    })
}

/// The residual of a segment's window against the force shifted by Δ: the window's
/// response samples (at most [`MAX_SAMPLES`], evenly strided), their sum and total
/// sum of squares, and the force.
struct LagScan<'a> {
    ts: Vec<f64>,
    ys: Vec<f64>,
    n: f64,
    sy: f64,
    sst: f64,
    force_t: &'a [f64],
    force: &'a [f64],
    sign: f64,
}

impl<'a> LagScan<'a> {
    /// The window's finite response samples; None with fewer than four.
    fn new(
        (resp_t, resp): (&[f64], &[f64]),
        (force_t, force): (&'a [f64], &'a [f64]),
        (a, b): (f64, f64),
        sign: f64,
    ) -> Option<Self> {
        let lo = resp_t.partition_point(|&x| x < a);
        let hi = resp_t.partition_point(|&x| x <= b);
        let idx: Vec<usize> = (lo..hi).filter(|&i| resp[i].is_finite()).collect();
        if idx.len() < 4 {
            return None;
        }
        let stride = idx.len().div_ceil(MAX_SAMPLES).max(1);
        let ts: Vec<f64> = idx.iter().step_by(stride).map(|&i| resp_t[i]).collect();
        let ys: Vec<f64> = idx.iter().step_by(stride).map(|&i| resp[i]).collect();
        let n = ts.len() as f64;
        let (sy, syy) = ys.iter().fold((0.0, 0.0), |(s, q), y| (s + y, q + y * y));
        Some(LagScan {
            ts,
            ys,
            n,
            sy,
            sst: syy - sy * sy / n,
            force_t,
            force,
            sign,
        })
    }

    /// The residual sum of squares of the best line a + g·F(t − d) through the window,
    /// and g; the whole variance and 0 when the force does not change in view at this
    /// shift, or changes with the wrong sign (no match).
    fn eval(&self, d: f64) -> (f64, f64) {
        let (n, sy, sst) = (self.n, self.sy, self.sst);
        // Start the interpolation at the window (a walk from 0 costs the whole log).
        let mut hint = self
            .force_t
            .partition_point(|&v| v <= self.ts[0] - d)
            .saturating_sub(1);
        let (mut sx, mut sxx, mut sxy) = (0.0, 0.0, 0.0);
        for (&t, &y) in self.ts.iter().zip(&self.ys) {
            let x = interp(self.force_t, self.force, t - d, &mut hint);
            sx += x;
            sxx += x * x;
            sxy += x * y;
        }
        let vx = sxx - sx * sx / n;
        if vx.is_nan() || vx <= 1e-12 * (sxx.abs() + 1e-300) {
            return (sst, 0.0);
        }
        let cov = sxy - sx * sy / n;
        let g = cov / vx;
        if g * self.sign <= 0.0 || !g.is_finite() {
            return (sst, 0.0);
        }
        ((sst - g * cov).max(0.0), g)
    }

    /// (Δ, SSR, g) at `count` shifts `step` apart from `from`.
    fn scan(&self, from: f64, step: f64, count: usize) -> Vec<(f64, f64, f64)> {
        (0..count)
            .map(|k| {
                let d = from + k as f64 * step;
                let (s, g) = self.eval(d);
                (d, s, g)
            })
            .collect()
    }
}

/// The minimum of a fine scan and its curvature, (Δ, SSR, c), from a parabola through
/// the scan points inside the 2σ band (SSR within 4σ² of its least value), at least
/// the five around the best one: the curvature at the scale of the uncertainty
/// itself, not of the force log's sample spacing (`n`: the samples fitted).
fn parabola_minimum(fine: &[(f64, f64, f64)], n: f64) -> (f64, f64, f64) {
    let fine_n = fine.len();
    let k = argmin(fine).clamp(2, fine_n - 3);
    let sigma2_min = fine[k].1.max(0.0) / (n - 3.0).max(1.0);
    let band = fine[k].1 + 4.0 * sigma2_min;
    let (mut a0, mut b0) = (k - 2, k + 2);
    while a0 > 0 && fine[a0 - 1].1 <= band {
        a0 -= 1;
    }
    while b0 + 1 < fine_n && fine[b0 + 1].1 <= band {
        b0 += 1;
    }
    let x0 = fine[k].0;
    let mut ne = super::fit::NormalEq::new(3);
    for p in &fine[a0..=b0] {
        let x = p.0 - x0;
        ne.add(&[1.0, x, x * x], p.1);
    }
    match ne.solve() {
        Some(o) if o.coef[2] > 0.0 => {
            let x = (-o.coef[1] / (2.0 * o.coef[2])).clamp(fine[a0].0 - x0, fine[b0].0 - x0);
            (
                x0 + x,
                (o.coef[0] + o.coef[1] * x + o.coef[2] * x * x).min(fine[k].1),
                o.coef[2],
            )
        }
        _ => (x0, fine[k].1, 0.0),
    }
}

/// The range of lags searched in a segment's window: up to four times the lag the lag
/// model implies (at least 2 s), never more than half the window.
pub fn search_range_s(window: (f64, f64), model_lag_s: f64) -> f64 {
    let lag = if model_lag_s.is_finite() {
        model_lag_s.abs()
    } else {
        0.0
    };
    (4.0 * lag).max(2.0).min((window.1 - window.0) / 2.0)
}

fn argmin(v: &[(f64, f64, f64)]) -> usize {
    (0..v.len())
        .min_by(|&x, &y| v[x].1.total_cmp(&v[y].1))
        .unwrap_or(0)
}

/// Δt_max and a robust summary of the per-segment lags.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LagSummary {
    /// Δt_max, s.
    pub max_lag_s: f64,
    /// Its standard uncertainty from the noise, s.
    pub max_lag_uncertainty_s: f64,
    /// `pooled` (the segments agree on one lag: their weighted mean), `largest` (the
    /// lags differ: the largest one) or `single` (one segment).
    pub max_lag_method: &'static str,
    /// Weighted mean lag (weights 1/se²), s.
    pub weighted_mean_lag_s: f64,
    /// Median lag, s.
    pub median_lag_s: f64,
    /// Robust spread of the lags, 1.4826 × median absolute deviation, s.
    pub lag_spread_s: f64,
    /// χ² of the lags about their weighted mean, and its degrees of freedom.
    pub chi_squared: f64,
}

/// Upper 99.9 % point of χ² with `k` degrees of freedom (Wilson–Hilferty beyond 2).
pub(crate) fn chi2_999(k: usize) -> f64 {
    // Exact for one and two degrees of freedom, where the approximation is poorest.
    match k {
        0 | 1 => return 10.828,
        2 => return 13.816,
        _ => {}
    }
    let k = k as f64;
    let z = 3.090_232;
    let a = 2.0 / (9.0 * k);
    k * (1.0 - a + z * a.sqrt()).powi(3)
}

/// Summarise per-segment lags `(lag, se)` (se from the noise alone); segments with a
/// non-finite lag or se are left out. `systematic_s` is an uncertainty every segment
/// shares (a fraction of the sample period: the local fit of a segment seen in a few
/// samples fits them nearly exactly and understates its error), so pooling does not
/// shrink it; a quarter of it floors each se so that no one segment takes all the
/// weight. None without a usable segment.
pub fn summarise(lags: &[(f64, f64)], systematic_s: f64) -> Option<LagSummary> {
    let floor_s = 0.25 * systematic_s.max(0.0);
    let v: Vec<(f64, f64)> = lags
        .iter()
        .filter(|(l, s)| l.is_finite() && s.is_finite())
        .map(|&(l, s)| (l, s.max(floor_s).max(1e-9)))
        .collect();
    if v.is_empty() {
        return None;
    }
    let w: f64 = v.iter().map(|(_, s)| 1.0 / (s * s)).sum();
    let mean = v.iter().map(|(l, s)| l / (s * s)).sum::<f64>() / w;
    let se_mean = 1.0 / w.sqrt();
    let chi2: f64 = v.iter().map(|(l, s)| ((l - mean) / s).powi(2)).sum();
    let mut sorted: Vec<f64> = v.iter().map(|p| p.0).collect();
    sorted.sort_by(f64::total_cmp);
    let median = median_of(&sorted);
    let mut dev: Vec<f64> = sorted.iter().map(|l| (l - median).abs()).collect();
    dev.sort_by(f64::total_cmp);
    let spread = 1.4826 * median_of(&dev);
    let (max_lag, se, method) = if v.len() == 1 {
        (v[0].0, v[0].1, "single")
    } else if chi2 <= chi2_999(v.len() - 1) {
        (mean, se_mean, "pooled")
    } else {
        let top = v
            .iter()
            .copied()
            .max_by(|a, b| a.0.total_cmp(&b.0))
            .unwrap_or((f64::NAN, f64::NAN));
        (top.0, top.1, "largest")
    };
    Some(LagSummary {
        max_lag_s: max_lag,
        max_lag_uncertainty_s: se.hypot(systematic_s.max(0.0)),
        max_lag_method: method,
        weighted_mean_lag_s: mean,
        median_lag_s: median,
        lag_spread_s: spread,
        chi_squared: chi2,
    })
}

fn median_of(sorted: &[f64]) -> f64 {
    let n = sorted.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        sorted[n / 2]
    } else {
        (sorted[n / 2 - 1] + sorted[n / 2]) / 2.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pure_delay_is_found_off_the_sample_grid_at_2_hz() {
        // A 1 s haversine press seen at 2 Hz, delayed by 0.3137 s.
        let ft: Vec<f64> = (0..2000).map(|i| i as f64 * 0.01).collect();
        let hav = |t: f64| {
            if (5.0..6.0).contains(&t) {
                20.0 * (1.0 - (std::f64::consts::TAU * (t - 5.0)).cos()) / 2.0
            } else {
                0.0
            }
        };
        let ff: Vec<f64> = ft.iter().map(|&t| hav(t)).collect();
        let rt: Vec<f64> = (0..40).map(|i| 0.13 + i as f64 * 0.5).collect();
        let rv: Vec<f64> = rt.iter().map(|&t| 3.0 + 12.0 * hav(t - 0.3137)).collect();
        let l = segment_lag(&rt, &rv, &ft, &ff, (4.0, 9.0), 2.0, 1.0).unwrap();
        assert!((l.lag_s - 0.3137).abs() < 1e-3, "{l:?}");
        assert!(
            (l.gain - 12.0).abs() < 0.01 && !l.at_limit && l.r_squared > 0.99999,
            "{l:?}"
        );
        // A response of the wrong sign is not a match.
        let neg: Vec<f64> = rv.iter().map(|v| -v).collect();
        let l = segment_lag(&rt, &neg, &ft, &ff, (4.0, 9.0), 2.0, 1.0);
        assert!(
            l.is_none_or(|l| l.r_squared < MIN_SEGMENT_R_SQUARED),
            "{l:?}"
        );
    }

    #[test]
    fn equal_lags_pool_and_different_ones_give_the_largest() {
        let same = [(0.30, 0.01), (0.31, 0.01), (0.29, 0.01), (0.305, 0.01)];
        let s = summarise(&same, 0.0).unwrap();
        assert_eq!(s.max_lag_method, "pooled");
        assert!((s.max_lag_s - 0.30125).abs() < 1e-12);
        assert!((s.max_lag_uncertainty_s - 0.005).abs() < 1e-12);
        // A shared uncertainty is not shrunk by pooling.
        let s = summarise(&same, 0.012).unwrap();
        assert!((s.max_lag_uncertainty_s - 0.013).abs() < 1e-12);
        let differ = [(0.30, 0.01), (0.60, 0.01), (0.29, 0.01)];
        let s = summarise(&differ, 0.0).unwrap();
        assert_eq!(s.max_lag_method, "largest");
        assert_eq!(s.max_lag_s, 0.60);
        // The χ² point: 99.9 % of χ²(1) is 10.83, of χ²(10) 29.59.
        assert!((chi2_999(1) - 10.83).abs() < 0.3);
        assert!((chi2_999(10) - 29.59).abs() < 0.2);
    }
}
