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
use super::results::{OffsetCandidate, ShiftPress};
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
                && (i + 1 == r2.len()
                    || r2[i + 1].partial_cmp(&r2[i]) != Some(std::cmp::Ordering::Greater))
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
        if distinct
            .iter()
            .all(|d| (d.1.offset_s - c.1.offset_s).abs() >= w)
        {
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

/// Most presses at rest kept (the largest): enough to name and to match.
pub const MAX_SHIFT_PRESSES: usize = 64;

/// The presses the shift shows where the aligned force is at rest or absent: rows
/// more than `margin_s` from every force press (`presses`: start and end on the
/// wavelength clock, s) whose shift departs from its block's rest level (the median of
/// those rows, blocks of `block_s`) by more than `threshold_pm`, in runs of at least
/// two rows (gaps of up to three periods bridged); each with its largest departure,
/// signed. The sign is the shift's own: the verdict compares it with the model's K,
/// which this stage does not know.
pub(super) fn shift_presses_at_rest(
    tw: &[f64],
    s: &[f64],
    presses: &[(f64, f64)],
    margin_s: f64,
    block_s: f64,
    threshold_pm: f64,
) -> Vec<ShiftPress> {
    let mut busy: Vec<(f64, f64)> = presses
        .iter()
        .map(|&(a, b)| (a - margin_s, b + margin_s))
        .collect();
    busy.sort_by(|a, b| a.0.total_cmp(&b.0));
    // Rows at rest: outside every widened press (one sweep over sorted intervals).
    let mut at_rest = Vec::with_capacity(tw.len());
    let (mut j, mut reach) = (0usize, f64::NEG_INFINITY);
    for (i, &t) in tw.iter().enumerate() {
        while j < busy.len() && busy[j].0 <= t {
            reach = reach.max(busy[j].1);
            j += 1;
        }
        if t > reach && s[i].is_finite() {
            at_rest.push(i);
        }
    }
    let period = median_period(tw).max(1e-9);
    // Each row's rest level: the median of its block's rows at rest; the runs are then
    // followed across the blocks' edges (a press is not cut in two at one).
    let mut rest = Vec::with_capacity(at_rest.len());
    let mut a = 0;
    while a < at_rest.len() {
        let t0 = tw[at_rest[a]];
        let b = (a + at_rest[a..].partition_point(|&i| tw[i] < t0 + block_s)).max(a + 1);
        let vals: Vec<f64> = at_rest[a..b].iter().map(|&i| s[i]).collect();
        let level = crate::segment::percentile(&vals, 0.5);
        rest.extend(std::iter::repeat_n(level, b - a));
        a = b;
    }
    let mut out: Vec<ShiftPress> = Vec::new();
    runs_off_rest(tw, s, (&at_rest, &rest), threshold_pm, period, &mut out);
    out.sort_by(|p, q| q.amplitude_pm.abs().total_cmp(&p.amplitude_pm.abs()));
    out.truncate(MAX_SHIFT_PRESSES);
    out.sort_by(|p, q| p.start_s.total_cmp(&q.start_s));
    out
}

/// Runs of the rows at rest (`rows`, each with its rest level) departing from it by
/// more than `threshold_pm` (one sign per run), appended to `out`.
fn runs_off_rest(
    tw: &[f64],
    s: &[f64],
    (rows, rest): (&[usize], &[f64]),
    threshold_pm: f64,
    period: f64,
    out: &mut Vec<ShiftPress>,
) {
    // (first row, last row, largest signed departure)
    let mut run: Option<(usize, usize, f64)> = None;
    let close = |r: Option<(usize, usize, f64)>, out: &mut Vec<ShiftPress>| {
        if let Some((p, q, amp)) = r.filter(|(p, q, _)| q > p) {
            out.push(ShiftPress {
                start_s: tw[p],
                end_s: tw[q],
                amplitude_pm: amp,
            });
        }
    };
    for (&i, &level) in rows.iter().zip(rest) {
        let d = s[i] - level;
        let up = d.abs() > threshold_pm;
        run = match run {
            Some((p, q, amp))
                if up && d.signum() == amp.signum() && tw[i] - tw[q] <= 3.0 * period =>
            {
                Some((p, i, if d.abs() > amp.abs() { d } else { amp }))
            }
            prev => {
                close(prev, out);
                up.then_some((i, i, d))
            }
        };
    }
    close(run, out);
}

/// The offset change that starts the force log's presses (`force`: starts on the
/// wavelength clock, s) where the shift's presses at rest start, within `tol_s`: the
/// change d (force times − d), and how many shift presses it lines up; None when
/// fewer than [`MIN_PRESSES`] line up at any d.
pub(super) fn press_match(shift: &[ShiftPress], force: &[f64], tol_s: f64) -> Option<(f64, usize)> {
    let mut starts: Vec<f64> = force.iter().copied().filter(|t| t.is_finite()).collect();
    starts.sort_by(f64::total_cmp);
    let lined_up = |d: f64| -> (usize, f64) {
        let (mut n, mut sum) = (0usize, 0.0);
        for p in shift {
            let want = p.start_s + d;
            let k = starts.partition_point(|&t| t < want - tol_s);
            if let Some(&t) = starts.get(k).filter(|&&t| t <= want + tol_s) {
                n += 1;
                sum += t - want;
            }
        }
        (n, sum)
    };
    let mut best: Option<(f64, usize)> = None;
    for p in shift {
        for &f in &starts {
            let (n, sum) = lined_up(f - p.start_s);
            // Ties go to the smaller move: the nearest rival.
            let d = f - p.start_s + sum / n.max(1) as f64;
            let better = best.is_none_or(|(bd, bn)| n > bn || n == bn && d.abs() < bd.abs());
            if n >= MIN_PRESSES && better {
                best = Some((d, n));
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A shift at 10 Hz with presses of `amp` pm from each (start, end), s, and a slow
    /// ramp of `ramp_pm` over the run.
    fn shift(presses: &[(f64, f64)], amp: f64, ramp_pm: f64) -> (Vec<f64>, Vec<f64>) {
        let t: Vec<f64> = (0..6000).map(|i| f64::from(i) * 0.1).collect();
        let s = t
            .iter()
            .map(|&x| {
                let on = presses.iter().any(|&(a, b)| x >= a && x <= b);
                (if on { amp } else { 0.0 }) + ramp_pm * x / 600.0
            })
            .collect();
        (t, s)
    }

    #[test]
    fn presses_where_the_force_rests_are_found_with_their_sign_and_matched() {
        // The shift shows presses at 100, 200, 300 and 400 s; the force log, placed
        // 250 s late, has its presses at 350 … 650 s: all four lie where it rests or
        // has no samples, and moving it 250 s back starts its presses on them.
        let shift_presses = [
            (100.0, 110.0),
            (200.0, 215.0),
            (300.0, 320.0),
            (400.0, 405.0),
        ];
        let (t, s) = shift(&shift_presses, -800.0, 60.0);
        let force: Vec<(f64, f64)> = shift_presses
            .iter()
            .map(|&(a, b)| (a + 250.0, b + 250.0))
            .collect();
        let found = shift_presses_at_rest(&t, &s, &force, 5.0, 60.0, 100.0);
        let starts: Vec<f64> = found.iter().map(|p| p.start_s).collect();
        assert_eq!(starts, vec![100.0, 200.0, 300.0, 400.0], "{found:?}");
        assert!(
            found.iter().all(|p| (p.amplitude_pm + 800.0).abs() < 20.0),
            "{found:?}"
        );
        let f_starts: Vec<f64> = force.iter().map(|p| p.0).collect();
        let (d, n) = press_match(&found, &f_starts, 1.5).unwrap();
        assert_eq!(n, 4);
        assert!((d - 250.0).abs() < 1e-9, "{d}");
    }

    #[test]
    fn a_press_across_the_edge_of_two_rest_blocks_is_one_press() {
        // Blocks of 40 s from 0 s: the press from 30 s to 45 s spans the edge at 40 s.
        let (t, s) = shift(&[(30.0, 45.0)], -800.0, 0.0);
        let found = shift_presses_at_rest(&t, &s, &[], 5.0, 40.0, 100.0);
        assert_eq!(found.len(), 1, "{found:?}");
        assert!((found[0].start_s - 30.0).abs() < 1e-9 && (found[0].end_s - 45.0).abs() < 1e-9);
    }

    #[test]
    fn a_slow_ramp_and_presses_the_force_explains_are_no_presses_at_rest() {
        // The force's presses lie on the shift's; a 60 pm ramp stays below 100 pm.
        let presses = [(100.0, 110.0), (200.0, 215.0), (300.0, 320.0)];
        let (t, s) = shift(&presses, -800.0, 60.0);
        assert!(shift_presses_at_rest(&t, &s, &presses, 5.0, 60.0, 100.0).is_empty());
        // Two presses lined up are not a rival alignment: one or two fit anywhere.
        let two = [ShiftPress {
            start_s: 10.0,
            end_s: 20.0,
            amplitude_pm: -800.0,
        }; 2];
        assert!(press_match(&two, &[50.0, 60.0], 1.5).is_none());
    }
}
