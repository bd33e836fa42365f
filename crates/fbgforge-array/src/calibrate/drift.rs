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
//! the likelier cause is temperature (every grating reads ≈ 10 pm/°C) than a bond.

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

/// Unloaded readings of one grating: (time s, level pm, sem pm, allowance pm).
fn unloaded_points(states: &[LoadState], levels: &[StateLevels], g: usize) -> Vec<[f64; 4]> {
    let mut out: Vec<[f64; 4]> = Vec::new();
    let mut peak_since = 0.0f64;
    for (s, l) in states.iter().zip(levels) {
        let lv = l.gratings[g];
        if l.used == 0 || !lv.shift_pm.is_finite() {
            continue;
        }
        if s.is_unloaded() {
            out.push([l.time_s, lv.shift_pm, lv.sem_pm, HYSTERESIS_ALLOWANCE * peak_since]);
            peak_since = 0.0;
        } else if let Some(last) = out.last() {
            peak_since = peak_since.max((lv.shift_pm - last[1]).abs());
        }
    }
    out
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

/// Drift faults: one per drifting grating, or one naming them all when most gratings
/// drift the same way (temperature).
pub fn drift_faults(
    states: &[LoadState],
    levels: &[StateLevels],
    gratings: &[String],
    resolution_pm: f64,
) -> Vec<Fault> {
    let worst: Vec<Option<Worst>> = (0..gratings.len())
        .map(|g| worst_pair(&unloaded_points(states, levels, g), resolution_pm))
        .collect();
    let drifting: Vec<usize> = (0..gratings.len()).filter(|&g| worst[g].is_some()).collect();
    if drifting.is_empty() {
        return Vec::new();
    }
    let ups = drifting
        .iter()
        .filter(|&&g| worst[g].as_ref().is_some_and(|w| w.diff_pm > 0.0))
        .count();
    let same_way = ups.max(drifting.len() - ups);
    let evidence = |w: &Worst| {
        BTreeMap::from([
            ("baseline_change_pm".to_string(), w.diff_pm),
            ("allowance_pm".to_string(), w.allowance_pm),
            ("resolution_pm".to_string(), resolution_pm),
            ("from_s".to_string(), w.times_s.0),
            ("to_s".to_string(), w.times_s.1),
        ])
    };
    if gratings.len() >= 3 && 3 * same_way >= 2 * gratings.len() {
        let w = drifting
            .iter()
            .filter_map(|&g| worst[g].clone())
            .max_by(|a, b| a.diff_pm.abs().total_cmp(&b.diff_pm.abs()))
            .expect("one drifts");
        return vec![Fault {
            kind: FaultKind::Drift,
            severity: Severity::Unusable,
            gratings: drifting.iter().map(|&g| gratings[g].clone()).collect(),
            cells: Vec::new(),
            reason: format!(
                "{} of {} gratings' unloaded baselines moved the same way during the run (up to {:+.2} pm between {:.1} s and {:.1} s, beyond the {resolution_pm} pm resolution and what hysteresis allows): common to the sheet, most likely temperature (≈ {:.2} °C at 10 pm/°C); hold the room steadier or add a free reference grating, then repeat",
                drifting.len(),
                gratings.len(),
                w.diff_pm,
                w.times_s.0,
                w.times_s.1,
                w.diff_pm.abs() / 10.0
            ),
            evidence: evidence(&w),
        }];
    }
    drifting
        .iter()
        .map(|&g| {
            let w = worst[g].clone().expect("drifting");
            Fault {
                kind: FaultKind::Drift,
                severity: Severity::Unusable,
                gratings: vec![gratings[g].clone()],
                cells: Vec::new(),
                reason: format!(
                    "the unloaded baseline of {} moved {:+.2} pm between {:.1} s and {:.1} s, beyond the {resolution_pm} pm resolution by {:.2} pm after allowing {:.2} pm for hysteresis and noise, while most other gratings held still: a loose bond or the fiber slipping in its slit (temperature would move every grating)",
                    gratings[g], w.diff_pm, w.times_s.0, w.times_s.1, w.excess_pm, w.allowance_pm
                ),
                evidence: evidence(&w),
            }
        })
        .collect()
}
