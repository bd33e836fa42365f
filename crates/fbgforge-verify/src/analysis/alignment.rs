//! The clock offset estimated against its rivals: the lag model's fit profiled over
//! the whole search range (not only from the cross-correlation's start), every local
//! best polished, and the best compared with the runner-up. A rival offset whose fit
//! is within the margin (one press period away, say, when a short recording's presses
//! fit other presses as well) leaves the offset ambiguous; so do fewer than
//! [`MIN_PRESSES`] presses in the overlap. The decision is the verdict's; this stage
//! measures.
//!
//! The comparison: the share of the shift (beyond a baseline and a drift) each
//! candidate's response explains, R², on its own overlap; the evidence for the best is
//! Λ = n_eff · ln((1 − R²_rival) / (1 − R²_best)) (a likelihood ratio of two Gaussian
//! fits, with n_eff independent samples allowing for autocorrelated residuals), and the
//! offset is definite when Λ ≥ [`EVIDENCE_MARGIN`].

use super::fit_data::FitData;
use super::results::OffsetCandidate;
use super::sensitivity::lag1_independence;
use crate::fit::{self, LagModelCost, LagModelFit};
use crate::logs::time::median_period;
use rayon::prelude::*;

/// Evidence a best offset needs over its runner-up: Λ = 20 is a likelihood ratio of
/// e¹⁰ (about 22 000 to 1).
pub const EVIDENCE_MARGIN: f64 = 20.0;
/// Fewest presses an estimated offset needs in the overlap: one or two presses fit
/// another press as well, scaled by their amplitude ratio.
pub const MIN_PRESSES: usize = 3;
/// Time constants of the profile's responses, s.
const PROFILE_TAUS: [f64; 3] = [0.05, 0.5, 3.0];
/// Most offsets the profile evaluates.
const PROFILE_POINTS: f64 = 1500.0;
/// Candidates polished.
const MAX_CANDIDATES: usize = 4;

/// The search's result: the candidates (best first), the evidence for the best.
pub(super) struct OffsetSearch {
    /// Best first.
    pub candidates: Vec<OffsetCandidate>,
    /// Λ of the best over the runner-up (None with no runner-up).
    pub evidence: Option<f64>,
    /// The best candidate's parameters (offset, ln τ, logit r).
    pub best: Vec<f64>,
}

/// The response share R² (beyond baseline and drift) of one offset over the coarse
/// data, for responses precomputed at each profile time constant.
fn profile_point(data: &FitData, responses: &[Vec<f64>], delta: f64) -> f64 {
    let (st, sv) = data.shift();
    let (ft, _) = data.force();
    let (f0, f1) = (ft[0], ft[ft.len() - 1]);
    let t_mid = data.t_mid();
    let mut best = f64::NAN;
    for y in responses {
        let mut full = fit::NormalEq::new(3);
        let mut base = fit::NormalEq::new(2);
        let (mut hint, mut ex) = (0, 0usize);
        for (&t, &s) in st.iter().zip(sv) {
            let u = t + delta;
            if u < f0 || u > f1 || data.excluded(u, &mut ex) {
                continue;
            }
            let yv = fit::interp(ft, y, u, &mut hint);
            full.add(&[yv, 1.0, t - t_mid], s);
            base.add(&[1.0, t - t_mid], s);
        }
        if let (Some(a), Some(b)) = (full.solve(), base.solve()) {
            // Too small an overlap says nothing.
            if a.n >= 20 && 4 * a.n >= st.len() && b.ssr > 0.0 {
                let r2 = 1.0 - a.ssr / b.ssr;
                if best.is_nan() || r2.is_nan() || r2 > best {
                    best = r2;
                }
            }
        }
    }
    best
}

/// Local maxima of the profile, best first, at least `sep` apart.
fn local_maxima(deltas: &[f64], r2: &[f64], sep: f64) -> Vec<f64> {
    let mut idx: Vec<usize> = (0..r2.len())
        .filter(|&i| {
            r2[i].is_finite()
                && (i == 0 || r2[i - 1].partial_cmp(&r2[i]) != Some(std::cmp::Ordering::Greater))
                && (i + 1 == r2.len() || r2[i + 1].partial_cmp(&r2[i]) != Some(std::cmp::Ordering::Greater))
        })
        .collect();
    idx.sort_by(|&a, &b| r2[b].total_cmp(&r2[a]));
    let mut out: Vec<f64> = Vec::new();
    for i in idx {
        if out.iter().all(|d| (d - deltas[i]).abs() >= sep) {
            out.push(deltas[i]);
        }
        if out.len() == MAX_CANDIDATES {
            break;
        }
    }
    out
}

/// A candidate polished: the lag model fitted with the offset held within `w` of
/// `delta`, from two time constants; its fit, R² and effective samples.
fn polish(data: &FitData, delta: f64, w: f64) -> Option<(Vec<f64>, LagModelFit, f64, f64, usize)> {
    let step0 = (2.0 * median_period(data.shift().0)).max(1e-3);
    let mut best: Option<(Vec<f64>, f64)> = None;
    for tau0 in [0.1f64, 1.0] {
        let cost = data.cost_around(delta, w);
        let start = [delta + 0.5 * tau0.min(w), tau0.ln(), 0.0];
        let r = fit::nelder_mead(cost, &start, &[step0.min(w), 1.0, 1.5], 300);
        if best.as_ref().is_none_or(|b| r.1 < b.1) {
            best = Some(r);
        }
    }
    let (p, _) = best?;
    let cost = data.cost_around(delta, w);
    let lm = cost.fit_at(&p)?;
    let (r2, n_eff, n) = explained(&cost, &lm, data);
    Some((p, lm, r2, n_eff, n))
}

/// R² of the fit beyond baseline and drift on its own overlap, its residuals'
/// effective sample count and the samples used.
fn explained(cost: &LagModelCost, lm: &LagModelFit, data: &FitData) -> (f64, f64, usize) {
    let residual = cost.residuals(lm);
    let (st, sv) = data.shift();
    let r2 = fit::response_r_squared(st, sv, &residual, data.t_mid());
    let (_, n, n_eff) = lag1_independence(&residual);
    (r2, n_eff, n)
}

/// Profile the fit over offsets in ±`range` (the residual offset of the force frame),
/// polish the best local maxima (and the cross-correlation's start `dx`), and weigh
/// the best against the runner-up.
pub(super) fn search(data: &FitData, range: f64, dx: f64) -> Option<OffsetSearch> {
    let (st, _) = data.shift();
    let (ft, fv) = data.force();
    let g = median_period(st)
        .max(2.0 * range / PROFILE_POINTS)
        .max(1e-3);
    let points = ((2.0 * range / g).floor() as usize) + 1;
    let deltas: Vec<f64> = (0..points).map(|i| -range + i as f64 * g).collect();
    let responses: Vec<Vec<f64>> = PROFILE_TAUS
        .iter()
        .map(|&tau| {
            let mut y = Vec::new();
            fit::sls_response(ft, fv, tau, 0.5, &mut y);
            y
        })
        .collect();
    let r2: Vec<f64> = deltas
        .par_iter()
        .map(|&d| profile_point(data, &responses, d))
        .collect();
    // Candidates at least a press's rise apart (1 s, or four grid steps).
    let sep = (4.0 * g).max(1.0);
    let mut starts = local_maxima(&deltas, &r2, sep);
    if starts.iter().all(|d| (d - dx).abs() >= sep / 2.0) {
        starts.push(dx.clamp(-range, range));
    }
    let w = sep / 2.0;
    let mut polished: Vec<(Vec<f64>, LagModelFit, f64, f64, usize)> = starts
        .par_iter()
        .filter_map(|&d| polish(data, d, w))
        .filter(|c| c.2.is_finite())
        .collect();
    polished.sort_by(|a, b| b.2.total_cmp(&a.2));
    // Polishing may bring two starts to one offset: keep the distinct ones.
    let mut distinct: Vec<(Vec<f64>, LagModelFit, f64, f64, usize)> = Vec::new();
    for c in polished {
        if distinct.iter().all(|d| (d.1.offset_s - c.1.offset_s).abs() >= w) {
            distinct.push(c);
        }
    }
    let best = distinct.first()?.clone();
    // The independent samples are the best fit's: its residuals are the noise the
    // rival must match; a rival's own misfit is systematic (autocorrelated), and
    // counting its few effective samples would let a wrong fit weaken the evidence.
    let evidence = distinct.get(1).map(|r| {
        let n_eff = best.3;
        n_eff * ((1.0 - r.2).max(1e-12) / (1.0 - best.2).max(1e-12)).ln()
    });
    let candidates = distinct
        .iter()
        .map(|(_, lm, r2, _, n)| OffsetCandidate {
            clock_offset_s: lm.offset_s,
            sensitivity_pm_per_n: lm.k_pm_per_n,
            response_r_squared: *r2,
            samples: *n,
        })
        .collect();
    Some(OffsetSearch {
        candidates,
        evidence,
        best: best.0,
    })
}

/// The presses the shift shows where the force log has no samples: rows outside
/// `[fa, fb]` whose shift, in the direction of K (`k_sign`), rises above the rest level
/// of its block (blocks of `block_s`; rest: the block's 20th percentile) by half the
/// response's span |K|·x_max (`span_pm`), in runs of at least two rows; their start and
/// end, s.
pub(super) fn shift_presses_outside(
    tw: &[f64],
    s: &[f64],
    (fa, fb): (f64, f64),
    (k_sign, span_pm): (f64, f64),
    block_s: f64,
) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    if span_pm.is_nan() || span_pm <= 0.0 {
        return out;
    }
    let period = median_period(tw).max(1e-9);
    for (lo_t, hi_t) in [(f64::NEG_INFINITY, fa), (fb, f64::INFINITY)] {
        let rows: Vec<usize> = (0..tw.len())
            .filter(|&i| s[i].is_finite() && tw[i] > lo_t && tw[i] < hi_t)
            .collect();
        let mut a = 0;
        while a < rows.len() {
            let t0 = tw[rows[a]];
            let b = (a + rows[a..].partition_point(|&i| tw[i] < t0 + block_s)).max(a + 1);
            let block = &rows[a..b];
            let vals: Vec<f64> = block.iter().map(|&i| k_sign * s[i]).collect();
            let rest = crate::segment::percentile(&vals, 0.2);
            let mut run: Option<(usize, usize)> = None;
            for &i in block {
                let up = k_sign * s[i] - rest > 0.5 * span_pm;
                run = match (run, up) {
                    (Some((p, q)), true) if tw[i] - tw[q] <= 3.0 * period => Some((p, i)),
                    (prev, up) => {
                        if let Some((p, q)) = prev.filter(|(p, q)| q > p) {
                            out.push((tw[p], tw[q]));
                        }
                        up.then_some((i, i))
                    }
                };
            }
            if let Some((p, q)) = run.filter(|(p, q)| q > p) {
                out.push((tw[p], tw[q]));
            }
            a = b;
        }
    }
    out
}
