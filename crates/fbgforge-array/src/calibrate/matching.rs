//! The schedule's load changes matched to the changes found in the data, in order.
//!
//! The schedule's clock is a hint: a stopwatch started late, steps put on every
//! "about 5 s", a log whose clock is not the schedule's. What must hold is the order
//! and, roughly, the intervals. A dynamic programme pairs schedule transitions with
//! data changes, monotone in both, minimising
//! * for each pair after the first, the squared mismatch between the data's interval
//!   and the schedule's interval since the previous pair, in units of 20 % of that
//!   interval plus two samples (at least 0.5 s);
//! * for the first pair, the squared offset of the schedule's clock in units of
//!   max(30 s, 10 % of the run): a weak hint;
//! * for each pair, 2(1 − cos) between the data's jump and the jump the model predicts
//!   for that transition (0 when alike, 4 when opposite);
//! * 6 for each schedule transition left without a change, and for each data change
//!   left without a transition 6 × its score over the typical matched score (a creep
//!   tail or a chance peak is cheap to leave out; an unscheduled load is not).

use super::steps::Change;
use serde::Serialize;

/// Cost of a schedule transition the data do not show.
const SKIP_TRANSITION: f64 = 6.0;
/// Cost of a typical-size data change the schedule does not list.
const SKIP_CHANGE: f64 = 6.0;
/// Most schedule transitions skipped between two pairs.
const MAX_TRANSITION_GAP: usize = 4;
/// Most data changes skipped between two pairs.
const MAX_CHANGE_GAP: usize = 40;

/// One load change the schedule lists.
#[derive(Debug, Clone)]
pub struct Transition {
    /// Time by the schedule's clock, s.
    pub time_s: f64,
    /// The jump the model predicts for it, pm per grating (None when unknown).
    pub expected_pm: Option<Vec<f64>>,
}

/// The schedule matched to the data.
#[derive(Debug, Clone, Serialize)]
pub struct Alignment {
    /// For each transition, the index of its data change.
    pub change_of: Vec<Option<usize>>,
    /// Data changes no transition explains, by index into the changes.
    pub unexplained: Vec<usize>,
    /// Median of (data time − schedule time) over the matched transitions, s.
    pub clock_offset_s: f64,
    /// Largest |offset − median offset| over the matched transitions, s.
    pub clock_spread_s: f64,
    /// The typical (median) score of a matched change.
    pub typical_score: f64,
}

fn cosine(a: &[f64], b: &[f64]) -> f64 {
    let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        ab += x * y;
        aa += x * x;
        bb += y * y;
    }
    if aa > 0.0 && bb > 0.0 {
        ab / (aa * bb).sqrt()
    } else {
        1.0
    }
}

struct Costs<'a> {
    transitions: &'a [Transition],
    changes: &'a [Change],
    skip_change_prefix: Vec<f64>,
    sigma_abs: f64,
    sample_s: f64,
}

impl Costs<'_> {
    fn skip_changes(&self, from: usize, to: usize) -> f64 {
        self.skip_change_prefix[to] - self.skip_change_prefix[from]
    }
    fn pattern(&self, k: usize, m: usize) -> f64 {
        self.transitions[k]
            .expected_pm
            .as_ref()
            .map_or(0.0, |e| 2.0 * (1.0 - cosine(e, &self.changes[m].jump_pm)))
    }
    fn first(&self, k: usize, m: usize) -> f64 {
        let off = self.changes[m].time_s - self.transitions[k].time_s;
        (off / self.sigma_abs).powi(2)
            + k as f64 * SKIP_TRANSITION
            + self.skip_changes(0, m)
            + self.pattern(k, m)
    }
    fn step(&self, (k0, m0): (usize, usize), (k, m): (usize, usize)) -> f64 {
        let dt_sched = self.transitions[k].time_s - self.transitions[k0].time_s;
        let dt_data = self.changes[m].time_s - self.changes[m0].time_s;
        let sigma = 0.2 * dt_sched.abs() + (2.0 * self.sample_s).max(0.5);
        ((dt_data - dt_sched) / sigma).powi(2)
            + (k - k0 - 1) as f64 * SKIP_TRANSITION
            + self.skip_changes(m0 + 1, m)
            + self.pattern(k, m)
    }
}

/// Match `transitions` to `changes` (both in time order); `sample_s` is the log's
/// typical sample interval and `run_s` its length.
pub fn align(
    transitions: &[Transition],
    changes: &[Change],
    sample_s: f64,
    run_s: f64,
) -> Alignment {
    let (nk, nm) = (transitions.len(), changes.len());
    let mut top: Vec<f64> = changes.iter().map(|c| c.score).collect();
    top.sort_by(|a, b| b.total_cmp(a));
    top.truncate(nk.max(1));
    let reference = super::steps::median(&mut top).max(1e-12);
    let mut prefix = vec![0.0; nm + 1];
    for (m, c) in changes.iter().enumerate() {
        prefix[m + 1] = prefix[m] + SKIP_CHANGE * (c.score / reference).min(1.0);
    }
    let costs = Costs {
        transitions,
        changes,
        skip_change_prefix: prefix,
        sigma_abs: (0.1 * run_s).max(30.0),
        sample_s,
    };
    // best[k][m]: least cost with transition k paired to change m as the last pair.
    let mut best: Vec<Vec<f64>> = vec![vec![f64::INFINITY; nm]; nk];
    let mut back: Vec<Vec<Option<(usize, usize)>>> = vec![vec![None; nm]; nk];
    for k in 0..nk {
        for m in 0..nm {
            let mut b = costs.first(k, m);
            let mut from = None;
            for (k0, row) in best
                .iter()
                .enumerate()
                .take(k)
                .skip(k.saturating_sub(MAX_TRANSITION_GAP))
            {
                for (m0, &prev) in row
                    .iter()
                    .enumerate()
                    .take(m)
                    .skip(m.saturating_sub(MAX_CHANGE_GAP))
                {
                    if prev.is_finite() {
                        let c = prev + costs.step((k0, m0), (k, m));
                        if c < b {
                            b = c;
                            from = Some((k0, m0));
                        }
                    }
                }
            }
            best[k][m] = b;
            back[k][m] = from;
        }
    }
    let mut end: Option<(usize, usize)> = None;
    let mut total = nk as f64 * SKIP_TRANSITION + costs.skip_changes(0, nm);
    for (k, row) in best.iter().enumerate() {
        for (m, &b) in row.iter().enumerate() {
            let c = b + (nk - 1 - k) as f64 * SKIP_TRANSITION + costs.skip_changes(m + 1, nm);
            if c < total {
                total = c;
                end = Some((k, m));
            }
        }
    }
    let mut change_of = vec![None; nk];
    while let Some((k, m)) = end {
        change_of[k] = Some(m);
        end = back[k][m];
    }
    summarise(change_of, changes, transitions)
}

fn summarise(
    change_of: Vec<Option<usize>>,
    changes: &[Change],
    transitions: &[Transition],
) -> Alignment {
    let used: Vec<usize> = change_of.iter().flatten().copied().collect();
    let unexplained = (0..changes.len()).filter(|m| !used.contains(m)).collect();
    let mut offsets: Vec<f64> = change_of
        .iter()
        .enumerate()
        .filter_map(|(k, m)| m.map(|m| changes[m].time_s - transitions[k].time_s))
        .collect();
    let spread_of = offsets.clone();
    let clock_offset_s = super::steps::median(&mut offsets);
    let clock_spread_s = spread_of
        .iter()
        .map(|o| (o - clock_offset_s).abs())
        .fold(0.0, f64::max);
    let mut scores: Vec<f64> = used.iter().map(|&m| changes[m].score).collect();
    Alignment {
        change_of,
        unexplained,
        clock_offset_s: if clock_offset_s.is_finite() {
            clock_offset_s
        } else {
            0.0
        },
        clock_spread_s,
        typical_score: super::steps::median(&mut scores),
    }
}

/// The first sample of each state: state 0 starts at sample 0; state k ≥ 1 at its
/// transition's data change, or, for a transition the data do not show, at the
/// schedule's time moved by the clock offset of the nearest matched transitions.
pub fn state_starts(
    alignment: &Alignment,
    transitions: &[Transition],
    changes: &[Change],
    time_s: &[f64],
) -> Vec<usize> {
    let matched: Vec<(f64, f64)> = alignment
        .change_of
        .iter()
        .enumerate()
        .filter_map(|(k, m)| {
            m.map(|m| {
                (
                    transitions[k].time_s,
                    changes[m].time_s - transitions[k].time_s,
                )
            })
        })
        .collect();
    let offset_at = |t: f64| -> f64 {
        let after = matched.iter().position(|&(tk, _)| tk >= t);
        match after {
            Some(0) => matched[0].1,
            Some(i) => {
                let ((t0, o0), (t1, o1)) = (matched[i - 1], matched[i]);
                o0 + (o1 - o0) * (t - t0) / (t1 - t0).max(1e-12)
            }
            None => matched.last().map_or(alignment.clock_offset_s, |x| x.1),
        }
    };
    let mut starts = vec![0usize];
    for (k, tr) in transitions.iter().enumerate() {
        let i = match alignment.change_of[k] {
            Some(m) => changes[m].index,
            None => {
                let t = tr.time_s + offset_at(tr.time_s);
                time_s.partition_point(|&x| x < t)
            }
        };
        let prev = *starts.last().expect("state 0");
        starts.push(i.max(prev));
    }
    starts
}

#[cfg(test)]
mod tests {
    use super::*;

    fn change(t: f64, score: f64) -> Change {
        Change {
            index: (t * 10.0) as usize,
            time_s: t,
            score,
            jump_pm: vec![1.0],
        }
    }

    fn transitions(times: &[f64]) -> Vec<Transition> {
        times
            .iter()
            .map(|&t| Transition {
                time_s: t,
                expected_pm: None,
            })
            .collect()
    }

    #[test]
    fn a_late_clock_a_missing_step_and_a_creep_tail_are_told_apart() {
        // The schedule says 10, 15, 20, 25, 30; the data show them 4 s late, the step
        // at 19 s... is missing (24 s), plus a small creep peak 2 s after the first.
        let tr = transitions(&[10.0, 15.0, 20.0, 25.0, 30.0]);
        let ch = vec![
            change(14.1, 900.0),
            change(16.0, 40.0),
            change(19.0, 1000.0),
            change(29.0, 950.0),
            change(33.9, 1000.0),
        ];
        let a = align(&tr, &ch, 0.1, 60.0);
        assert_eq!(a.change_of, vec![Some(0), Some(2), None, Some(3), Some(4)]);
        assert_eq!(a.unexplained, vec![1]);
        assert!((a.clock_offset_s - 4.0).abs() < 0.1, "{a:?}");
        let t: Vec<f64> = (0..600).map(|i| i as f64 * 0.1).collect();
        let starts = state_starts(&a, &tr, &ch, &t);
        // The missing transition is put where the clock says, 4 s late: 24 s.
        assert_eq!(starts, vec![0, 141, 190, 240, 290, 339]);
    }
}
