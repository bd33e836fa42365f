//! What of the force log can be trusted before a K is fitted to it: a saturated force
//! channel and gaps in the log inside a press.
//!
//! - **Saturation**: a load cell or amplifier driven past its range reads the same
//!   value for as long as the force stays above it: flat tops at a repeated maximum,
//!   with the noise collapsed there. A pulse is clipped when at least
//!   [`MIN_FLAT_SAMPLES`] consecutive samples lie within a quarter of the force noise of
//!   the log's maximum (an unclipped noisy top reaches its maximum in one sample; a
//!   held plateau wanders by the noise). Without force noise (a noise-free synthetic
//!   force) a flat top cannot be told from a held one, so nothing is flagged.
//! - **Gaps**: a step in the force log's time longer than [`GAP_PERIODS`] median
//!   periods. Inside a press (the samples on either side belong to it) the press's
//!   shape is unknown, and interpolating across it bends K; at rest it may hide a
//!   whole press.
//!
//! The pulses either touches are left out of the fits, from their start to the next
//! pulse (the lag model remembers a press for a few time constants), and each gap at
//! rest with 5 s after it ([`ForceCheck::excluded_spans`]); when fewer than
//! [`MIN_USABLE_PULSES`] pulses are left, the run is not judged.

use super::segment::{percentile, Segmentation};
use serde::Serialize;

/// Fewest trusted pulses a verdict needs once the untrusted ones are left out.
pub(crate) const MIN_USABLE_PULSES: usize = 2;
/// Consecutive samples at the log's maximum that make a flat (clipped) top.
pub(crate) const MIN_FLAT_SAMPLES: usize = 5;
/// A step in the force log's time longer than this many median periods is a gap.
pub(crate) const GAP_PERIODS: f64 = 5.0;
/// How long after an untrusted stretch the shift is still left out at least, s (the
/// lag model's memory of the force).
const MEMORY_S: f64 = 5.0;

/// A pulse whose top is clipped.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub(crate) struct ClippedPulse {
    /// The pulse (index into the segmentation's pulses, from 0).
    pub pulse: usize,
    /// How long its top stays flat at the saturation level, s.
    pub flat_s: f64,
}

/// A gap in the force log.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub(crate) struct ForceGap {
    /// Index of the sample before the gap (the next one is after it).
    pub before: usize,
    /// Length of the gap, s.
    pub length_s: f64,
    /// The pulse it lies in or touches (index from 0), or None at rest.
    pub pulse: Option<usize>,
}

/// What the force log's samples say about themselves.
#[derive(Debug, Clone, PartialEq, Default)]
pub(crate) struct ForceCheck {
    /// The level the channel saturates at, N (when any pulse is clipped).
    pub saturation_n: Option<f64>,
    /// Clipped pulses.
    pub clipped: Vec<ClippedPulse>,
    /// Gaps in the force log.
    pub gaps: Vec<ForceGap>,
}

impl ForceCheck {
    /// The pulses that cannot be trusted (clipped, or with a gap), sorted.
    pub(crate) fn untrusted_pulses(&self) -> Vec<usize> {
        let mut v: Vec<usize> = self
            .clipped
            .iter()
            .map(|c| c.pulse)
            .chain(self.gaps.iter().filter_map(|g| g.pulse))
            .collect();
        v.sort_unstable();
        v.dedup();
        v
    }

    /// The force-sample index spans (inclusive, sorted, disjoint) whose shift is left
    /// out of the fits: each untrusted pulse from half a second before its start to
    /// the next pulse's start (at most 5 s or two pulse lengths after its end), and
    /// each gap at rest with 5 s after it (never into the next pulse).
    pub(crate) fn excluded_spans(&self, t: &[f64], seg: &Segmentation) -> Vec<(usize, usize)> {
        let n = t.len();
        if n == 0 {
            return Vec::new();
        }
        let at = |x: f64| t.partition_point(|&v| v < x).min(n - 1);
        let mut spans: Vec<(usize, usize)> = Vec::new();
        for k in self.untrusted_pulses() {
            let Some(p) = seg.pulses.get(k) else { continue };
            let dur = t[p.end] - t[p.start];
            let before = if k > 0 { seg.pulses[k - 1].end + 1 } else { 0 };
            let mut a = at(t[p.start] - 0.5).max(before).min(p.start);
            // A gap that opens before the pulse's first sample hides its rise.
            for g in self.gaps.iter().filter(|g| g.pulse == Some(k)) {
                a = a.min(g.before);
            }
            let next = seg
                .pulses
                .get(k + 1)
                .map_or(n - 1, |q| q.start.saturating_sub(1));
            let b = at(t[p.end] + MEMORY_S.max(2.0 * dur)).min(next).max(p.end);
            spans.push((a, b));
        }
        for g in self.gaps.iter().filter(|g| g.pulse.is_none()) {
            let after = (g.before + 1).min(n - 1);
            // Never into the next press: the gap cannot have hidden anything there.
            let next = seg
                .pulses
                .iter()
                .find(|p| p.start > g.before)
                .map_or(n - 1, |p| p.start.saturating_sub(1));
            spans.push((g.before, at(t[after] + MEMORY_S).min(next).max(after)));
        }
        spans.sort_unstable();
        let mut merged: Vec<(usize, usize)> = Vec::new();
        for (a, b) in spans {
            match merged.last_mut() {
                Some(last) if a <= last.1 + 1 => last.1 = last.1.max(b),
                _ => merged.push((a, b)),
            }
        }
        merged
    }
}

/// Check the force log (times `t`, s, ascending; force `f`, N, compression positive)
/// cut into `seg`'s pulses for saturation and gaps.
pub fn check(t: &[f64], f: &[f64], seg: &Segmentation) -> ForceCheck {
    if t.len() != f.len() || t.len() < 3 {
        return ForceCheck::default();
    }
    let (saturation_n, clipped) = clipped_pulses(t, f, seg);
    ForceCheck {
        saturation_n,
        clipped,
        gaps: gaps(t, seg),
    }
}

/// Noise standard deviation of a sampled signal from its second differences (their
/// median absolute value): for white noise σ_d2 = √6 σ, and a smooth force's own
/// curvature hardly enters, where first differences would count a steep flank as
/// noise (and a sine's smooth top as flat). A channel saturated for most of the log
/// repeats its extreme exactly, and the median second difference is then 0 however
/// noisy the rest is: the noise is then read off the extremes, from fourth
/// differences (σ_d4 = √70 σ for white noise; a smooth flank's own shape hardly
/// enters), and counted only when the second differences there agree with it (a
/// noise-free log's flanks have curvature but no noise: it stays at 0).
pub(crate) fn noise_sigma_d2(v: &[f64]) -> f64 {
    let robust = |d: Vec<f64>, var: f64| 1.4826 * percentile(&d, 0.5) / var.sqrt();
    let all = robust(
        v.windows(3)
            .map(|w| (w[2] - 2.0 * w[1] + w[0]).abs())
            .collect(),
        6.0,
    );
    if all != 0.0 {
        return all;
    }
    let (lo, hi) = extremes(v);
    let off = |w: &[f64]| !w.iter().all(|x| *x == hi) && !w.iter().all(|x| *x == lo);
    let d2 = robust(
        v.windows(3)
            .filter(|w| off(w))
            .map(|w| (w[2] - 2.0 * w[1] + w[0]).abs())
            .collect(),
        6.0,
    );
    let d4 = robust(
        v.windows(5)
            .filter(|w| off(w))
            .map(|w| (w[0] - 4.0 * w[1] + 6.0 * w[2] - 4.0 * w[3] + w[4]).abs())
            .collect(),
        70.0,
    );
    if d4.is_finite() && d4 > 0.0 && d4 >= 0.5 * d2 {
        d4
    } else {
        all
    }
}

/// The smallest and largest finite value.
fn extremes(v: &[f64]) -> (f64, f64) {
    v.iter()
        .copied()
        .filter(|x| x.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(x), b.max(x))
        })
}

/// The first longest run of consecutive samples within a quarter of the noise
/// (`sigma`) of `level`, as (start, length): the one flat-level rule of a clipped top
/// and a saturated side.
fn longest_run_at(v: &[f64], level: f64, sigma: f64) -> (usize, usize) {
    let (mut best, mut run) = ((0usize, 0usize), (0usize, 0usize));
    for (i, x) in v.iter().enumerate() {
        if (x - level).abs() <= 0.25 * sigma {
            run = if run.1 == 0 {
                (i, 1)
            } else {
                (run.0, run.1 + 1)
            };
            if run.1 > best.1 {
                best = run;
            }
        } else {
            run.1 = 0;
        }
    }
    best
}

/// Which extreme of a noisy force log is a saturated channel's flat level (at least
/// [`MIN_FLAT_SAMPLES`] consecutive samples within a quarter of the noise of it, the
/// noise collapsed there): `Some(true)` the maximum, `Some(false)` the minimum, `None`
/// neither or both (or no noise to tell a flat level from a held one). A channel
/// saturates under load, never at rest: that side is compression, whatever the
/// force's level elsewhere (a preload held at the ceiling for most of each cycle makes
/// the ceiling look like the rest level and the unclipped dips like presses).
pub(crate) fn saturated_side(v: &[f64]) -> Option<bool> {
    let sigma = noise_sigma_d2(v);
    if !(sigma > 0.0 && sigma.is_finite()) {
        return None;
    }
    let (lo, hi) = extremes(v);
    let top = longest_run_at(v, hi, sigma).1 >= MIN_FLAT_SAMPLES;
    let bottom = longest_run_at(v, lo, sigma).1 >= MIN_FLAT_SAMPLES;
    (top != bottom).then_some(top)
}

/// The pulses with a flat top at the log's maximum, and that maximum.
fn clipped_pulses(t: &[f64], f: &[f64], seg: &Segmentation) -> (Option<f64>, Vec<ClippedPulse>) {
    let sigma = noise_sigma_d2(f);
    // Without noise, a flat top cannot be told from a held one.
    if !(sigma > 0.0 && sigma.is_finite()) {
        return (None, Vec::new());
    }
    let top = extremes(f).1;
    if !top.is_finite() {
        return (None, Vec::new());
    }
    let mut clipped = Vec::new();
    for (k, p) in seg.pulses.iter().enumerate() {
        let end = p.end.min(f.len() - 1);
        if p.start > end {
            continue;
        }
        let (start, len) = longest_run_at(&f[p.start..=end], top, sigma);
        if len >= MIN_FLAT_SAMPLES {
            let a = p.start + start;
            clipped.push(ClippedPulse {
                pulse: k,
                flat_s: t[a + len - 1] - t[a],
            });
        }
    }
    ((!clipped.is_empty()).then_some(top), clipped)
}

/// Steps in time longer than [`GAP_PERIODS`] median periods, with the pulse each lies
/// in or touches.
fn gaps(t: &[f64], seg: &Segmentation) -> Vec<ForceGap> {
    let dt = crate::logs::time::median_period(t);
    if dt.is_nan() || dt <= 0.0 {
        return Vec::new();
    }
    (0..t.len() - 1)
        .filter(|&i| t[i + 1] - t[i] > GAP_PERIODS * dt)
        .map(|i| ForceGap {
            before: i,
            length_s: t[i + 1] - t[i],
            pulse: seg
                .pulses
                .iter()
                .position(|p| p.start <= i + 1 && i <= p.end),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::segment::segment;

    /// Six 4 s haversine presses of `peaks` N at 100 Hz with deterministic noise of
    /// about `noise` N, clipped at `cap` N.
    fn presses(peaks: &[f64], noise: f64, cap: f64) -> (Vec<f64>, Vec<f64>) {
        let t: Vec<f64> = (0..(10.0 * peaks.len() as f64 + 10.0) as usize * 100)
            .map(|i| i as f64 / 100.0)
            .collect();
        let f = t
            .iter()
            .enumerate()
            .map(|(i, &x)| {
                let k = ((x - 5.0) / 10.0).floor();
                let ph = x - 5.0 - 10.0 * k;
                let v = if k >= 0.0 && (k as usize) < peaks.len() && ph < 4.0 {
                    peaks[k as usize] * (1.0 - (std::f64::consts::TAU * ph / 4.0).cos()) / 2.0
                } else {
                    0.0
                };
                // A fixed pseudo-random sequence in [-1, 1].
                let r = ((i * 7919 + 13) % 1009) as f64 / 504.5 - 1.0;
                (v + noise * r).min(cap)
            })
            .collect();
        (t, f)
    }

    #[test]
    fn a_saturated_channel_is_found_and_an_unclipped_one_is_not() {
        let (t, f) = presses(&[3.5, 4.0, 4.5, 3.8], 0.01, 3.0);
        let s = segment(&t, &f);
        let c = check(&t, &f, &s);
        assert_eq!(c.clipped.len(), 4, "{c:?}");
        assert!((c.saturation_n.unwrap() - 3.0).abs() < 1e-12);
        // The flat top of a 3.5 N haversine above 3 N lasts 4 s × 2 acos(5/7)/(2π).
        let flat = 4.0 * (1.0 - (1.0f64 - 2.0 * 3.0 / 3.5).acos() / std::f64::consts::PI);
        assert!(
            (c.clipped[0].flat_s - flat).abs() < 0.05,
            "{:?} vs {flat}",
            c.clipped[0]
        );
        // Only the pulses above the cap are clipped.
        let (t, f) = presses(&[1.0, 2.0, 3.5, 2.5], 0.01, 3.0);
        let c = check(&t, &f, &segment(&t, &f));
        assert_eq!(
            c.clipped.iter().map(|p| p.pulse).collect::<Vec<_>>(),
            vec![2]
        );
        // Unclipped: nothing, whatever the peaks (equal peaks included).
        let (t, f) = presses(&[3.0, 3.0, 3.0, 3.0], 0.01, f64::INFINITY);
        let c = check(&t, &f, &segment(&t, &f));
        assert_eq!(c, ForceCheck::default());
        // Noise-free: a flat top cannot be told from a held one; nothing is flagged.
        let (t, f) = presses(&[3.5, 4.0], 0.0, 3.0);
        assert!(check(&t, &f, &segment(&t, &f)).clipped.is_empty());
    }

    #[test]
    fn a_ceiling_held_most_of_the_log_is_the_compression_side_and_clipped() {
        // A preload of 2.2 N with a 1 N sine of 12 s on it, clipped at 2 N (56 % of
        // each cycle at the ceiling), noisy: the ceiling, not the dips, is where
        // compression is, and every cycle's top is clipped.
        let t: Vec<f64> = (0..6000).map(|i| f64::from(i) / 10.0).collect();
        let f: Vec<f64> = t
            .iter()
            .enumerate()
            .map(|(i, &x)| {
                let r = ((i * 7919 + 13) % 1009) as f64 / 504.5 - 1.0;
                let ramp = (x / 5.0).min(1.0);
                (ramp * (2.2 + (std::f64::consts::TAU * x / 12.0).sin()) + 0.01 * r).min(2.0)
            })
            .collect();
        assert!(f.iter().filter(|v| **v == 2.0).count() > f.len() / 2);
        let sigma = noise_sigma_d2(&f);
        // The fixed sequence spans [-1, 1] with σ ≈ 0.01/√3, but is not white (its
        // steps repeat): the noise is read within a factor 2, and never as 0 (before,
        // the exact repeats of the ceiling made it 0).
        let ratio = sigma / (0.01 / 3f64.sqrt());
        assert!((0.5..2.0).contains(&ratio), "{sigma}");
        assert_eq!(saturated_side(&f), Some(true));
        let negated: Vec<f64> = f.iter().map(|v| -v).collect();
        assert_eq!(saturated_side(&negated), Some(false));
        let s = segment(&t, &f);
        let c = check(&t, &f, &s);
        // 50 cycles of 12 s in 600 s, each clipped (the segmentation may add a part
        // of a cycle at an end).
        assert!(
            c.clipped.len() >= 49 && c.clipped.len() + 1 >= s.pulses.len(),
            "{c:?}"
        );
        assert_eq!(c.saturation_n, Some(2.0));
        // Unclipped presses and a noise-free log name no side.
        let (_, f) = presses(&[3.5, 4.0, 4.5, 3.8], 0.01, f64::INFINITY);
        assert_eq!(saturated_side(&f), None);
        let (_, f) = presses(&[3.5, 4.0], 0.0, 3.0);
        assert_eq!(saturated_side(&f), None);
    }

    #[test]
    fn a_gap_inside_a_press_is_named_and_its_pulse_left_out() {
        let (t, f) = presses(&[2.0, 3.0, 4.0, 2.5], 0.01, f64::INFINITY);
        // Remove 1.5 s around the top of the second press (15.5 s to 17 s) and 2.5 s
        // of rest (30 s to 32.5 s).
        let keep: Vec<usize> = (0..t.len())
            .filter(|&i| !(15.5..17.0).contains(&t[i]) && !(30.0..32.5).contains(&t[i]))
            .collect();
        let t: Vec<f64> = keep.iter().map(|&i| t[i]).collect();
        let f: Vec<f64> = keep.iter().map(|&i| f[i]).collect();
        let s = segment(&t, &f);
        let c = check(&t, &f, &s);
        assert_eq!(c.gaps.len(), 2, "{c:?}");
        assert_eq!(c.gaps[0].pulse, Some(1));
        assert!((c.gaps[0].length_s - 1.51).abs() < 0.011);
        assert_eq!(c.gaps[1].pulse, None);
        assert_eq!(c.untrusted_pulses(), vec![1]);
        let spans = c.excluded_spans(&t, &s);
        assert_eq!(spans.len(), 2, "{spans:?}");
        // The press from before its start to the next press; the gap at rest until
        // the next press (5 s after it would reach into that press).
        let p = s.pulses[1];
        assert!(spans[0].0 < p.start && spans[0].1 < s.pulses[2].start && spans[0].1 > p.end);
        let next = s.pulses[3].start;
        assert!(
            (t[spans[1].0] - 29.99).abs() < 0.011 && spans[1].1 + 1 == next,
            "{spans:?}"
        );
    }
}
