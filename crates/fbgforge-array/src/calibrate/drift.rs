//! Drift: a grating's unloaded baseline moves during the run.
//!
//! Every pair of unloaded states is compared, grating by grating (consecutive ones are
//! the baselines before and after a load; distant ones catch a slow creep that each
//! single load hides). Silicone does not always come straight back: after a load the
//! unloaded reading may stay off by up to a few per cent of what the load moved it
//! (the paper's hysteresis is 4.33 % of span), so each unloaded state may be off by
//! [`HYSTERESIS_ALLOWANCE`] of the largest shift of the loads just before it; beyond
//! that allowance and three standard errors, a difference larger than the
//! interrogator's resolution is drift. When most gratings drift the same way at once
//! the likelier cause is temperature (every grating reads ≈ 10 pm/°C) than a bond:
//! the sheet's common baseline (the gratings' median) is taken out first, a grating
//! moving apart from it is unusable drift, the common one a warning.

use super::levels::StateLevels;
use super::schedule::LoadState;
use super::{Fault, FaultKind, Severity};
use std::collections::BTreeMap;

/// How far an unloaded reading may stay off after a load, as a fraction of the
/// largest shift that load caused (the paper's hysteresis, 4.33 % of span, rounded up).
pub const HYSTERESIS_ALLOWANCE: f64 = 0.05;

/// The worst disagreement of one grating's baselines.
#[derive(Debug, Clone)]
struct Worst {
    excess_pm: f64,
    diff_pm: f64,
    times_s: (f64, f64),
    allowance_pm: f64,
}

/// Unloaded readings of one grating by state index: [time s, level pm, sem pm,
/// allowance pm].
fn unloaded_points(
    states: &[LoadState],
    levels: &[StateLevels],
    g: usize,
) -> Vec<(usize, [f64; 4])> {
    let mut out: Vec<(usize, [f64; 4])> = Vec::new();
    let mut peak_since = 0.0f64;
    for (k, (s, l)) in states.iter().zip(levels).enumerate() {
        let lv = l.gratings[g];
        if l.used == 0 || !lv.shift_pm.is_finite() {
            continue;
        }
        if s.is_unloaded() {
            out.push((
                k,
                [
                    l.time_s,
                    lv.shift_pm,
                    lv.sem_pm,
                    HYSTERESIS_ALLOWANCE * peak_since,
                ],
            ));
            peak_since = 0.0;
        } else if let Some(last) = out.last() {
            peak_since = peak_since.max((lv.shift_pm - last.1[1]).abs());
        }
    }
    out
}

/// The sheet's common baseline at each unloaded state: the median over the gratings
/// of each one's change since its first unloaded reading (temperature moves every
/// grating alike; one loose grating moves the median little). Points as
/// [`unloaded_points`], the allowance and sem the gratings' medians.
fn common_mode(points: &[Vec<(usize, [f64; 4])>]) -> Vec<(usize, [f64; 4])> {
    let mut ks: Vec<usize> = points.iter().flatten().map(|p| p.0).collect();
    ks.sort_unstable();
    ks.dedup();
    ks.iter()
        .filter_map(|&k| {
            let at: Vec<([f64; 4], f64)> = points
                .iter()
                .filter_map(|g| Some((g.iter().find(|p| p.0 == k)?.1, g.first()?.1[1])))
                .collect();
            let med = |f: fn(&([f64; 4], f64)) -> f64| {
                super::steps::median(&mut at.iter().map(f).collect())
            };
            let level = med(|(p, first)| p[1] - first);
            level.is_finite().then(|| {
                (
                    k,
                    [at[0].0[0], level, med(|(p, _)| p[2]), med(|(p, _)| p[3])],
                )
            })
        })
        .collect()
}

fn worst_pair(points: &[[f64; 4]], resolution_pm: f64) -> Option<Worst> {
    let mut worst: Option<Worst> = None;
    for i in 0..points.len() {
        for j in i + 1..points.len() {
            let (a, b) = (points[i], points[j]);
            let diff = b[1] - a[1];
            let allowance = a[3] + b[3] + 3.0 * (a[2] * a[2] + b[2] * b[2]).sqrt();
            let excess = diff.abs() - allowance;
            if excess > resolution_pm && worst.as_ref().is_none_or(|w| excess > w.excess_pm) {
                worst = Some(Worst {
                    excess_pm: excess,
                    diff_pm: diff,
                    times_s: (a[0], b[0]),
                    allowance_pm: allowance,
                });
            }
        }
    }
    worst
}

/// Drift faults: one per grating whose baseline moves apart from the others
/// (unusable: a loose bond), and a warning when the whole sheet's baseline moves
/// together (temperature: the entries are read against baselines interpolated between
/// the unloaded states, which take a slow common change out).
pub fn drift_faults(
    states: &[LoadState],
    levels: &[StateLevels],
    gratings: &[String],
    resolution_pm: f64,
) -> Vec<Fault> {
    let points: Vec<Vec<(usize, [f64; 4])>> = (0..gratings.len())
        .map(|g| unloaded_points(states, levels, g))
        .collect();
    let common = if gratings.len() >= 3 {
        common_mode(&points)
    } else {
        Vec::new()
    };
    let level_at = |k: usize| common.iter().find(|p| p.0 == k).map_or(0.0, |p| p.1[1]);
    let evidence = |w: &Worst| {
        BTreeMap::from([
            ("baseline_change_pm".to_string(), w.diff_pm),
            ("allowance_pm".to_string(), w.allowance_pm),
            ("resolution_pm".to_string(), resolution_pm),
            ("from_s".to_string(), w.times_s.0),
            ("to_s".to_string(), w.times_s.1),
        ])
    };
    let mut out: Vec<Fault> = points
        .iter()
        .enumerate()
        .filter_map(|(g, pts)| {
            let own: Vec<[f64; 4]> = pts.iter().map(|(k, p)| [p[0], p[1] - level_at(*k), p[2], p[3]]).collect();
            let w = worst_pair(&own, resolution_pm)?;
            Some(Fault {
                kind: FaultKind::Drift,
                severity: Severity::Unusable,
                gratings: vec![gratings[g].clone()],
                cells: Vec::new(),
                reason: format!(
                    "the unloaded baseline of {} moved {:+.2} pm apart from the other gratings' between {:.1} s and {:.1} s, beyond the {resolution_pm} pm resolution by {:.2} pm after allowing {:.2} pm for hysteresis and noise: a loose bond or the fiber slipping in its slit (temperature would move every grating alike); re-bond and repeat",
                    gratings[g], w.diff_pm, w.times_s.0, w.times_s.1, w.excess_pm, w.allowance_pm
                ),
                evidence: evidence(&w),
            })
        })
        .collect();
    let pts: Vec<[f64; 4]> = common.iter().map(|p| p.1).collect();
    if let Some(w) = worst_pair(&pts, resolution_pm) {
        out.push(Fault {
            kind: FaultKind::Drift,
            severity: Severity::Warning,
            gratings: gratings.to_vec(),
            cells: Vec::new(),
            reason: format!(
                "every grating's unloaded baseline moved together by {:+.2} pm between {:.1} s and {:.1} s (beyond the {resolution_pm} pm resolution): most likely temperature (≈ {:.2} °C at 10 pm/°C); the entries are read against baselines interpolated between the unloaded states, which take a slow common change out, so the matrix stands; hold the room steadier or add a free reference grating",
                w.diff_pm,
                w.times_s.0,
                w.times_s.1,
                w.diff_pm.abs() / 10.0
            ),
            evidence: evidence(&w),
        });
    }
    out
}
