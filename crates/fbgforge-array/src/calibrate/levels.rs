//! What each grating reads in each load state, and the unloaded baseline under it.
//!
//! A state's level is the median of its settled samples: the first quarter (at least
//! two samples) is left for the silicone to settle after the change and the last
//! sample for the next change's approach; the median keeps a bump on the table out.
//! Its standard error is 1.25 σ/√n with σ the grating's noise. The baseline is the
//! unloaded states' levels, interpolated linearly in time between them (constant
//! before the first and after the last), so a slow linear drift cancels.

use super::steps::median;
use serde::Serialize;

/// One grating's reading of one state.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Level {
    /// Median shift over the settled samples, pm (NaN when none).
    pub shift_pm: f64,
    /// Its standard error, pm.
    pub sem_pm: f64,
}

/// Every grating's reading of one state.
#[derive(Debug, Clone, Serialize)]
pub struct StateLevels {
    /// First and one-past-last sample of the state in the data.
    pub samples: (usize, usize),
    /// Settled samples used.
    pub used: usize,
    /// Mean time of the settled samples, s.
    pub time_s: f64,
    /// One per grating.
    pub gratings: Vec<Level>,
}

/// The level of every state: state k spans samples `starts[k]..starts[k + 1]` (the last
/// to the end of the data).
pub fn state_levels(
    time_s: &[f64],
    shifts_pm: &[Vec<f64>],
    noise_pm: &[f64],
    starts: &[usize],
) -> Vec<StateLevels> {
    let n = time_s.len();
    let mut buf = Vec::new();
    (0..starts.len())
        .map(|k| {
            let (a, b) = (
                starts[k],
                starts.get(k + 1).copied().unwrap_or(n).max(starts[k]),
            );
            let len = b - a;
            let guard = if k == 0 { 0 } else { (len / 4).max(2) };
            let tail = usize::from(len > 4 && k + 1 < starts.len());
            let (u0, u1) = (a + guard.min(len), b - tail.min(len.saturating_sub(guard)));
            let used = u1.saturating_sub(u0);
            let time = if used > 0 {
                time_s[u0..u1].iter().sum::<f64>() / used as f64
            } else {
                time_s
                    .get(a.min(n.saturating_sub(1)))
                    .copied()
                    .unwrap_or(0.0)
            };
            let gratings = shifts_pm
                .iter()
                .zip(noise_pm)
                .map(|(x, &s)| {
                    buf.clear();
                    buf.extend_from_slice(&x[u0..u0 + used]);
                    let m = median(&mut buf);
                    Level {
                        shift_pm: m,
                        sem_pm: 1.2533 * s / (buf.len().max(1) as f64).sqrt(),
                    }
                })
                .collect();
            StateLevels {
                samples: (a, b),
                used,
                time_s: time,
                gratings,
            }
        })
        .collect()
}

/// The unloaded baseline of one grating: its unloaded levels in time order.
#[derive(Debug, Clone)]
pub struct Baseline {
    points: Vec<(f64, f64, f64)>,
}

impl Baseline {
    /// From (time s, level pm, sem pm) of the unloaded states.
    pub fn new(mut points: Vec<(f64, f64, f64)>) -> Self {
        points.retain(|p| p.1.is_finite());
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
        Baseline { points }
    }

    /// No unloaded state was read.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The unloaded levels (time s, level pm, sem pm).
    pub fn points(&self) -> &[(f64, f64, f64)] {
        &self.points
    }

    /// The baseline at `t` and its standard error, pm.
    pub fn at(&self, t: f64) -> (f64, f64) {
        let p = &self.points;
        match p.iter().position(|q| q.0 >= t) {
            _ if p.is_empty() => (f64::NAN, f64::NAN),
            Some(0) => (p[0].1, p[0].2),
            Some(i) => {
                let (a, b) = (p[i - 1], p[i]);
                let f = ((t - a.0) / (b.0 - a.0).max(1e-12)).clamp(0.0, 1.0);
                (
                    a.1 + f * (b.1 - a.1),
                    ((1.0 - f).powi(2) * a.2 * a.2 + f * f * b.2 * b.2).sqrt(),
                )
            }
            None => {
                let l = p[p.len() - 1];
                (l.1, l.2)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levels_skip_the_settling_and_the_baseline_interpolates() {
        let t: Vec<f64> = (0..40).map(f64::from).collect();
        // 0 for 10 samples, 10 with a 2-sample overshoot, then back to 1 (drift).
        let x: Vec<f64> = (0..40)
            .map(|i| match i {
                0..=9 => 0.0,
                10..=11 => 30.0,
                12..=29 => 10.0,
                _ => 1.0,
            })
            .collect();
        let l = state_levels(&t, &[x], &[0.5], &[0, 10, 30]);
        assert_eq!(l[1].gratings[0].shift_pm, 10.0);
        assert_eq!(l[1].used, 20 - 5 - 1);
        let b = Baseline::new(vec![
            (l[0].time_s, l[0].gratings[0].shift_pm, 0.1),
            (l[2].time_s, l[2].gratings[0].shift_pm, 0.1),
        ]);
        // Halfway between the two unloaded states, the baseline is halfway.
        let mid = 0.5 * (l[0].time_s + l[2].time_s);
        assert!((b.at(mid).0 - 0.5).abs() < 1e-12);
        assert_eq!(b.at(-5.0).0, 0.0);
        assert_eq!(b.at(100.0).0, 1.0);
    }
}
