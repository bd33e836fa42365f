//! The loading protocol and its segments, read from the force log alone.
//!
//! Force stands run a few protocols, and each needs its own cut before a lag can be
//! measured (see `docs/verify.md` §4):
//! - **impulse**: short presses (haversine, triangle) with rest between them; one
//!   segment per press;
//! - **press-hold-release**: a ramp up, a plateau, a ramp down (a trapezoid); the peak
//!   of a plateau is set by noise, so the segments are the two edges (press, release);
//! - **staircase**: the force climbs (and falls) through several held levels without
//!   returning to rest (0–250 g in 25 g steps); every step is a segment, and the held
//!   levels give K;
//! - **sine**: back-to-back cycles (or oscillation riding on a preload); one segment
//!   per cycle.
//!
//! A pulse is an excursion of the force above its resting level; plateaus are stretches
//! where the (lightly smoothed) force stays within a band of 2 % of the log's force
//! range (or six noise deviations) for at least 1 s; the time scale of the steadiness
//! test grows with the pulse (1 % of its length) so that the slow flank of a long
//! press is not mistaken for a held level.

use serde::Serialize;

/// Pulse boundaries in force-sample indices.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PulseSpan {
    /// First index above threshold.
    pub start: usize,
    /// Last index above the exit threshold.
    pub end: usize,
}

/// The protocol a force log follows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Protocol {
    /// Short presses with rest between them.
    Impulse,
    /// Press, hold on a plateau, release (trapezoid).
    PressHoldRelease,
    /// Held levels climbing and falling without rest between them.
    Staircase,
    /// Back-to-back cycles.
    Sine,
    /// Pulses of several kinds, none of them a clear majority.
    Mixed,
}

impl Protocol {
    /// Name as printed in reports.
    pub fn name(self) -> &'static str {
        match self {
            Protocol::Impulse => "impulse",
            Protocol::PressHoldRelease => "press-hold-release",
            Protocol::Staircase => "staircase",
            Protocol::Sine => "sine",
            Protocol::Mixed => "mixed",
        }
    }
}

/// What a segment is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SegmentKind {
    /// A whole press (impulse protocol).
    Pulse,
    /// One cycle of a sine.
    Cycle,
    /// The loading ramp of a press-hold-release.
    Press,
    /// The unloading ramp of a press-hold-release.
    Release,
    /// A step up of a staircase.
    StepUp,
    /// A step down of a staircase.
    StepDown,
}

/// One stretch of the force log whose lag is measured on its own.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    /// What it is.
    pub kind: SegmentKind,
    /// The pulse it belongs to (index into the pulses, from 0).
    pub pulse: usize,
    /// First force index of the change of force (the ramp or the pulse).
    pub start: usize,
    /// Last force index of the change.
    pub end: usize,
    /// Force indices bounding the lag window: the change with the steady force around
    /// it (to the middle of the neighbouring plateaus or rests).
    pub window: (usize, usize),
}

/// A held level of force.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plateau {
    /// First force index.
    pub start: usize,
    /// Last force index.
    pub end: usize,
    /// Median force over it, N.
    pub level_n: f64,
    /// True for the rest between pulses.
    pub rest: bool,
}

/// The protocol, its pulses, their segments and the held levels.
#[derive(Debug, Clone, PartialEq)]
pub struct Segmentation {
    /// Protocol of the log (majority of its pulses).
    pub protocol: Protocol,
    /// Excursions above rest.
    pub pulses: Vec<PulseSpan>,
    /// Protocol of each pulse.
    pub pulse_protocols: Vec<Protocol>,
    /// Segments, in time order.
    pub segments: Vec<Segment>,
    /// Held levels inside pulses and the rests between them, in time order.
    pub plateaus: Vec<Plateau>,
}

/// Percentile of the finite values; vectors of more than a million values are
/// subsampled evenly (plenty for thresholds and spreads).
pub fn percentile(v: &[f64], p: f64) -> f64 {
    percentile_of(|| v.iter().copied(), p)
}

/// [`percentile`] of the values `values()` yields, without a copy of them all (it is
/// called twice: to count them, then to take the subsample).
pub fn percentile_of<I: Iterator<Item = f64>>(values: impl Fn() -> I, p: f64) -> f64 {
    let step = values().count().div_ceil(1 << 20).max(1);
    let mut s: Vec<f64> = values().step_by(step).filter(|x| x.is_finite()).collect();
    if s.is_empty() {
        return f64::NAN;
    }
    let k = ((s.len() - 1) as f64 * p).round() as usize;
    *s.select_nth_unstable_by(k, |a, b| a.total_cmp(b)).1
}

/// Noise standard deviation of a sampled signal from the median absolute first
/// difference (robust to the signal's own steps).
pub fn noise_sigma(v: &[f64]) -> f64 {
    noise_sigma_of(|| v.iter().copied())
}

/// [`noise_sigma`] of the values `values()` yields, without a copy of them or of their
/// differences.
pub fn noise_sigma_of<I: Iterator<Item = f64>>(values: impl Fn() -> I) -> f64 {
    let diffs = || {
        let mut it = values();
        let mut prev = it.next();
        it.map(move |x| {
            let d = prev.map_or(f64::NAN, |p| (x - p).abs());
            prev = Some(x);
            d
        })
    };
    1.4826 * percentile_of(diffs, 0.5) / std::f64::consts::SQRT_2
}

/// Find loading pulses: runs where the force rises above its resting level by more
/// than 5 % of the largest pulse and 6 noise standard deviations, ending when it falls
/// below half that threshold (hysteresis keeps noise from splitting a pulse).
pub fn detect_pulses(force: &[f64]) -> Vec<PulseSpan> {
    if force.len() < 3 {
        return Vec::new();
    }
    let base = percentile(force, 0.1);
    let top = percentile(force, 0.999);
    let sigma = noise_sigma(force);
    let amp = top - base;
    if amp.is_nan() || amp <= 0.0 {
        return Vec::new();
    }
    let enter = base + (0.05 * amp).max(6.0 * sigma);
    let exit = base + 0.5 * (enter - base);
    let mut out = Vec::new();
    let mut start: Option<usize> = None;
    for (i, &f) in force.iter().enumerate() {
        match start {
            None if f > enter => start = Some(i),
            Some(s) if f < exit => {
                if i - s >= 3 {
                    out.push(PulseSpan {
                        start: s,
                        end: i - 1,
                    });
                }
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        if force.len() - s >= 3 {
            out.push(PulseSpan {
                start: s,
                end: force.len() - 1,
            });
        }
    }
    out
}

/// Shortest held level, s.
const MIN_PLATEAU_S: f64 = 1.0;
/// A single plateau makes a press-hold-release only when it lasts this share of its
/// pulse (a haversine's rounded top stays within 2 % for 9 % of its length).
const MIN_HOLD_SHARE: f64 = 0.2;
/// Back-to-back pulses (a gap shorter than this share of the pulse) are sine cycles.
const MAX_CYCLE_GAP_SHARE: f64 = 0.25;

/// The force's resting level, scale and noise, and the smoothed force the steadiness
/// test reads.
struct ForceLevels {
    /// Resting level, N.
    base: f64,
    /// Median sample period, s.
    dt: f64,
    /// Force smoothed over ±0.05 s, N.
    sm: Vec<f64>,
    /// How far a held level may wander, N.
    delta: f64,
}

/// Rest, scale and noise of the force, and its light smoothing (±0.05 s) so that the
/// steadiness test sees the level, not the noise.
fn force_levels(t: &[f64], f: &[f64]) -> ForceLevels {
    let base = percentile(f, 0.1);
    let amp = percentile(f, 0.999) - base;
    let sigma = noise_sigma(f);
    let dt = crate::logs::time::median_period(t).max(1e-9);
    let m = ((0.05 / dt).round() as usize).min(50);
    let sm = moving_average(f, m);
    let delta = (0.02 * amp).max(6.0 * sigma / ((2 * m + 1) as f64).sqrt());
    ForceLevels {
        base,
        dt,
        sm,
        delta,
    }
}

/// One pulse's shape: its held levels, its oscillation and its class.
struct Shape {
    plateaus: Vec<Plateau>,
    splits: Vec<usize>,
    class: Protocol,
}

/// Classify one pulse by its held levels and oscillation.
fn pulse_shape(t: &[f64], f: &[f64], lv: &ForceLevels, p: &PulseSpan) -> Shape {
    let (sm, delta) = (&lv.sm, lv.delta);
    let dur = t[p.end] - t[p.start];
    let h = (((0.25f64).max(0.01 * dur) / lv.dt).ceil() as usize).max(1);
    let plateaus = merge_levels(t, held_levels(t, f, sm, p.start, p.end, h, delta), delta);
    let longest = plateaus
        .iter()
        .map(|q| t[q.end] - t[q.start])
        .fold(0.0, f64::max);
    let top = sm[p.start..=p.end]
        .iter()
        .fold(f64::NEG_INFINITY, |a, &b| a.max(b));
    let splits = oscillation_minima(sm, p.start, p.end, 0.3 * (top - lv.base));
    let mut levels: Vec<f64> = plateaus.iter().map(|q| q.level_n).collect();
    levels.sort_by(f64::total_cmp);
    levels.dedup_by(|a, b| (*a - *b).abs() <= 2.0 * delta);
    let class = if !splits.is_empty() {
        Protocol::Sine
    } else if levels.len() >= 2 {
        Protocol::Staircase
    } else if plateaus.len() == 1 && longest >= MIN_HOLD_SHARE * dur {
        Protocol::PressHoldRelease
    } else {
        Protocol::Impulse
    };
    let plateaus = if matches!(class, Protocol::Staircase | Protocol::PressHoldRelease) {
        plateaus
    } else {
        Vec::new()
    };
    Shape {
        plateaus,
        splits,
        class,
    }
}

/// Reclassify runs of at least three back-to-back presses as the cycles of a sine.
fn mark_sine_runs(t: &[f64], pulses: &[PulseSpan], classes: &mut [Protocol]) {
    let back_to_back = |i: usize| {
        i + 1 < pulses.len() && {
            let gap = t[pulses[i + 1].start] - t[pulses[i].end];
            let dur = t[pulses[i].end] - t[pulses[i].start];
            gap < MAX_CYCLE_GAP_SHARE * dur
        }
    };
    let mut i = 0;
    while i < pulses.len() {
        let mut j = i;
        while back_to_back(j)
            && classes[j] == Protocol::Impulse
            && classes[j + 1] == Protocol::Impulse
        {
            j += 1;
        }
        if j >= i + 2 {
            for c in &mut classes[i..=j] {
                *c = Protocol::Sine;
            }
        }
        i = j + 1;
    }
}

/// The rest between force indices `ra` and `rb` as a plateau, if it lasts long enough.
fn rest_plateau(t: &[f64], f: &[f64], ra: usize, rb: usize) -> Option<Plateau> {
    (rb > ra && t[rb] - t[ra] >= MIN_PLATEAU_S).then(|| Plateau {
        start: ra,
        end: rb,
        level_n: percentile(&f[ra..=rb], 0.5),
        rest: true,
    })
}

/// What the segments of each pulse are cut from.
struct Cutter<'a> {
    t: &'a [f64],
    pulses: &'a [PulseSpan],
    classes: &'a [Protocol],
    shapes: &'a [Shape],
    /// Resting level, N.
    base: f64,
}

impl Cutter<'_> {
    /// The force index at time `x` (clamped to the log).
    fn at(&self, x: f64) -> usize {
        self.t.partition_point(|&v| v < x).min(self.t.len() - 1)
    }

    /// The force index halfway in time between indices `a` and `b`.
    fn mid(&self, a: usize, b: usize) -> usize {
        self.at((self.t[a] + self.t[b]) / 2.0)
    }

    /// Start of the rest before pulse k (the previous pulse's end + 1).
    fn prev_end(&self, k: usize) -> usize {
        if k == 0 {
            0
        } else {
            self.pulses[k - 1].end + 1
        }
    }

    /// End of the rest after pulse k (the next pulse's start − 1).
    fn next_start(&self, k: usize) -> usize {
        self.pulses
            .get(k + 1)
            .map_or(self.t.len() - 1, |q| q.start.saturating_sub(1))
    }

    /// The segments of pulse k by its class.
    fn segments(&self, k: usize) -> Vec<Segment> {
        let p = &self.pulses[k];
        let (lo, hi) = (self.prev_end(k).min(p.start), self.next_start(k).max(p.end));
        match self.classes[k] {
            Protocol::Impulse => {
                let (t, dur) = (self.t, self.t[p.end] - self.t[p.start]);
                let a = self.at(t[p.start] - dur / 2.0).max(lo);
                let b = self.at(t[p.end] + (2.0 * dur).max(2.0)).min(hi);
                vec![Segment {
                    kind: SegmentKind::Pulse,
                    pulse: k,
                    start: p.start,
                    end: p.end,
                    window: (a, b),
                }]
            }
            Protocol::Sine => self.cycles(k, lo, hi),
            Protocol::PressHoldRelease | Protocol::Staircase => self.level_changes(k, lo, hi),
            Protocol::Mixed => Vec::new(),
        }
    }

    /// The cycles of a sine pulse k: bounded by the middle of the gaps between
    /// back-to-back pulses, or by the troughs of an oscillation inside one pulse.
    fn cycles(&self, k: usize, lo: usize, hi: usize) -> Vec<Segment> {
        let (t, pulses, classes) = (self.t, self.pulses, self.classes);
        let p = &pulses[k];
        let dur = t[p.end] - t[p.start];
        let a = if k > 0 && classes[k - 1] == Protocol::Sine {
            self.mid(pulses[k - 1].end, p.start)
        } else {
            self.at(t[p.start] - dur / 2.0).max(lo)
        };
        let b = if k + 1 < pulses.len() && classes[k + 1] == Protocol::Sine {
            self.mid(p.end, pulses[k + 1].start)
        } else {
            self.at(t[p.end] + dur / 2.0).min(hi)
        };
        let cuts: Vec<usize> = std::iter::once(a)
            .chain(self.shapes[k].splits.iter().copied())
            .chain(std::iter::once(b))
            .collect();
        cuts.windows(2)
            .filter(|w| w[1] > w[0] + 2)
            .map(|w| Segment {
                kind: SegmentKind::Cycle,
                pulse: k,
                start: w[0].max(p.start),
                end: w[1].min(p.end),
                window: (w[0], w[1]),
            })
            .collect()
    }

    /// The changes of level of a press-hold-release or staircase pulse k: from the
    /// rest before to the first level, level to level, and from the last level to
    /// the rest after.
    fn level_changes(&self, k: usize, lo: usize, hi: usize) -> Vec<Segment> {
        let (t, p) = (self.t, &self.pulses[k]);
        let levels = &self.shapes[k].plateaus;
        let first = levels[0];
        let last = levels[levels.len() - 1];
        let half_first = (t[first.end] - t[first.start]) / 2.0;
        let half_last = (t[last.end] - t[last.start]) / 2.0;
        // (window start, start, end, window end, level from, level to)
        let mut bounds: Vec<(usize, usize, usize, usize, f64, f64)> = Vec::new();
        let pre = self.at(t[p.start] - half_first).max(lo);
        let first_mid = self.mid(first.start, first.end);
        bounds.push((
            pre,
            p.start,
            first.start,
            first_mid,
            self.base,
            first.level_n,
        ));
        for w in levels.windows(2) {
            bounds.push((
                self.mid(w[0].start, w[0].end),
                w[0].end,
                w[1].start,
                self.mid(w[1].start, w[1].end),
                w[0].level_n,
                w[1].level_n,
            ));
        }
        let post = self.at(t[p.end] + half_last).min(hi);
        let last_mid = self.mid(last.start, last.end);
        bounds.push((last_mid, last.end, p.end, post, last.level_n, self.base));
        let hold = self.classes[k] == Protocol::PressHoldRelease;
        let mut out = Vec::new();
        for (j, (wa, s, e, wb, from, to)) in bounds.into_iter().enumerate() {
            let kind = match (hold, j == 0, to > from) {
                (true, true, _) => SegmentKind::Press,
                (true, false, _) => SegmentKind::Release,
                (false, _, true) => SegmentKind::StepUp,
                (false, _, false) => SegmentKind::StepDown,
            };
            if wb > wa + 2 {
                out.push(Segment {
                    kind,
                    pulse: k,
                    start: s.min(e),
                    end: e.max(s),
                    window: (wa, wb),
                });
            }
        }
        out
    }
}

/// Cut the force log (times `t`, s, ascending; force `f`, N, compression positive)
/// into its protocol's segments.
pub fn segment(t: &[f64], f: &[f64]) -> Segmentation {
    let pulses = detect_pulses(f);
    let mut out = Segmentation {
        protocol: Protocol::Impulse,
        pulses: pulses.clone(),
        pulse_protocols: Vec::new(),
        segments: Vec::new(),
        plateaus: Vec::new(),
    };
    if pulses.is_empty() || t.len() != f.len() {
        return out;
    }
    let levels = force_levels(t, f);
    let shapes: Vec<Shape> = pulses
        .iter()
        .map(|p| pulse_shape(t, f, &levels, p))
        .collect();
    let mut classes: Vec<Protocol> = shapes.iter().map(|s| s.class).collect();
    mark_sine_runs(t, &pulses, &mut classes);
    let cutter = Cutter {
        t,
        pulses: &pulses,
        classes: &classes,
        shapes: &shapes,
        base: levels.base,
    };
    for (k, p) in pulses.iter().enumerate() {
        // Rest before the pulse (the one after is the next pulse's rest before).
        out.plateaus.extend(rest_plateau(
            t,
            f,
            cutter.prev_end(k),
            p.start.saturating_sub(1),
        ));
        out.segments.extend(cutter.segments(k));
        if matches!(classes[k], Protocol::PressHoldRelease | Protocol::Staircase) {
            out.plateaus.extend(shapes[k].plateaus.iter().copied());
        }
    }
    // The rest after the last pulse.
    if let Some(p) = pulses.last() {
        out.plateaus
            .extend(rest_plateau(t, f, p.end + 1, t.len() - 1));
    }
    out.protocol = majority(&classes);
    out.pulse_protocols = classes;
    out
}

/// The protocol of pulses of the given classes: the class of more than half of them,
/// or [`Protocol::Mixed`] (impulse when there are none).
pub(crate) fn protocol_of(classes: &[Protocol]) -> Protocol {
    if classes.is_empty() {
        return Protocol::Impulse;
    }
    majority(classes)
}

/// The class of more than half the pulses, or [`Protocol::Mixed`].
fn majority(classes: &[Protocol]) -> Protocol {
    let kinds = [
        Protocol::Impulse,
        Protocol::PressHoldRelease,
        Protocol::Staircase,
        Protocol::Sine,
    ];
    kinds
        .into_iter()
        .find(|k| 2 * classes.iter().filter(|c| *c == k).count() > classes.len())
        .unwrap_or(Protocol::Mixed)
}

/// Centred moving average over ±m samples (shorter at the ends).
pub(crate) fn moving_average(v: &[f64], m: usize) -> Vec<f64> {
    if m == 0 {
        return v.to_vec();
    }
    let mut prefix = Vec::with_capacity(v.len() + 1);
    prefix.push(0.0);
    let mut acc = 0.0;
    for &x in v {
        acc += if x.is_finite() { x } else { 0.0 };
        prefix.push(acc);
    }
    (0..v.len())
        .map(|i| {
            let (a, b) = (i.saturating_sub(m), (i + m).min(v.len() - 1));
            (prefix[b + 1] - prefix[a]) / (b + 1 - a) as f64
        })
        .collect()
}

/// Held levels inside the pulse [s, e]: maximal runs of samples whose ±h neighbourhood
/// of the smoothed force stays within `delta`, widened by h, lasting at least
/// [`MIN_PLATEAU_S`] and standing clear of the rest level.
fn held_levels(
    t: &[f64],
    f: &[f64],
    sm: &[f64],
    s: usize,
    e: usize,
    h: usize,
    delta: f64,
) -> Vec<Plateau> {
    let n = e + 1 - s;
    if n < 2 * h + 1 {
        return Vec::new();
    }
    let (lo, hi) = sliding_min_max(&sm[s..=e], h);
    let steady: Vec<bool> = (0..n).map(|i| hi[i] - lo[i] <= delta).collect();
    let mut out = Vec::new();
    let mut i = h;
    while i + h < n {
        if !steady[i] {
            i += 1;
            continue;
        }
        let mut j = i;
        while j + 1 + h < n && steady[j + 1] {
            j += 1;
        }
        let (a, b) = (s + i - h, s + j + h);
        if t[b] - t[a] >= MIN_PLATEAU_S {
            out.push(Plateau {
                start: a,
                end: b,
                level_n: percentile(&f[a..=b], 0.5),
                rest: false,
            });
        }
        i = j + 1;
    }
    out
}

/// Neighbouring plateaus at the same level with less than [`MIN_PLATEAU_S`] between
/// them (a noisy hold split in two) become one.
fn merge_levels(t: &[f64], levels: Vec<Plateau>, delta: f64) -> Vec<Plateau> {
    let mut out: Vec<Plateau> = Vec::new();
    for p in levels {
        match out.last_mut() {
            Some(q)
                if (q.level_n - p.level_n).abs() <= 2.0 * delta
                    && t[p.start] - t[q.end] < MIN_PLATEAU_S =>
            {
                q.end = p.end;
            }
            _ => out.push(p),
        }
    }
    out
}

/// Min and max over the centred window ±h at every index (clipped at the ends),
/// with monotonic queues: O(n).
fn sliding_min_max(v: &[f64], h: usize) -> (Vec<f64>, Vec<f64>) {
    use std::collections::VecDeque;
    let n = v.len();
    let (mut lo, mut hi) = (vec![0.0; n], vec![0.0; n]);
    let (mut qmin, mut qmax): (VecDeque<usize>, VecDeque<usize>) =
        (VecDeque::new(), VecDeque::new());
    let mut next = 0;
    for i in 0..n {
        let right = (i + h).min(n - 1);
        while next <= right {
            while qmin.back().is_some_and(|&k| v[k] >= v[next]) {
                qmin.pop_back();
            }
            qmin.push_back(next);
            while qmax.back().is_some_and(|&k| v[k] <= v[next]) {
                qmax.pop_back();
            }
            qmax.push_back(next);
            next += 1;
        }
        let left = i.saturating_sub(h);
        while qmin.front().is_some_and(|&k| k < left) {
            qmin.pop_front();
        }
        while qmax.front().is_some_and(|&k| k < left) {
            qmax.pop_front();
        }
        lo[i] = qmin.front().map_or(f64::NAN, |&k| v[k]);
        hi[i] = qmax.front().map_or(f64::NAN, |&k| v[k]);
    }
    (lo, hi)
}

/// Troughs between the peaks of an oscillation inside [s, e] (zigzag with hysteresis
/// `swing`): empty for a pulse with a single peak.
fn oscillation_minima(sm: &[f64], s: usize, e: usize, swing: f64) -> Vec<usize> {
    if swing.is_nan() || swing <= 0.0 {
        return Vec::new();
    }
    let mut minima = Vec::new();
    let mut rising = true;
    let (mut ext, mut ext_i) = (sm[s], s);
    let mut peaks = 0;
    for (i, &v) in sm.iter().enumerate().take(e + 1).skip(s) {
        if rising {
            if v > ext {
                (ext, ext_i) = (v, i);
            } else if v < ext - swing {
                peaks += 1;
                rising = false;
                (ext, ext_i) = (v, i);
            }
        } else if v < ext {
            (ext, ext_i) = (v, i);
        } else if v > ext + swing {
            minima.push(ext_i);
            rising = true;
            (ext, ext_i) = (v, i);
        }
    }
    if rising {
        peaks += usize::from(ext > sm[s] + swing);
    }
    if peaks >= 2 {
        minima.truncate(peaks - 1);
        minima
    } else {
        Vec::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The percentile and noise of values read as they go (the instrument check and the
    /// branches of a long log, no copy of the column) are those of the collected copy,
    /// subsample and all: written out here as the copies were taken before.
    #[test]
    fn figures_of_values_read_as_they_go_are_those_of_their_copy() {
        // 3 M values (more than 2^20: percentile subsamples), a third NaN or filtered.
        let v: Vec<f64> = (0..3_000_000u32)
            .map(|i| {
                let x = f64::from(i.wrapping_mul(2_654_435_761) % 1_000_003) * 1e-3;
                if i % 5 == 0 {
                    f64::NAN
                } else {
                    x
                }
            })
            .collect();
        let keep = |x: &f64| x.is_nan() || *x > 100.0;
        let copy: Vec<f64> = v.iter().copied().filter(keep).collect();
        let by_copy = |c: &[f64], p: f64| {
            let step = c.len().div_ceil(1 << 20);
            let mut s: Vec<f64> = c
                .iter()
                .step_by(step)
                .copied()
                .filter(|x| x.is_finite())
                .collect();
            let k = ((s.len() - 1) as f64 * p).round() as usize;
            *s.select_nth_unstable_by(k, f64::total_cmp).1
        };
        for p in [0.05, 0.5, 0.999] {
            let got = percentile_of(|| v.iter().copied().filter(keep), p);
            assert_eq!(got.to_bits(), by_copy(&copy, p).to_bits(), "p {p}");
        }
        let diffs: Vec<f64> = copy.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
        let want = 1.4826 * by_copy(&diffs, 0.5) / std::f64::consts::SQRT_2;
        let got = noise_sigma_of(|| v.iter().copied().filter(keep));
        assert_eq!(got.to_bits(), want.to_bits());
        assert!(want > 0.0);
    }

    fn grid(dur: f64, rate: f64) -> Vec<f64> {
        (0..=(dur * rate) as usize)
            .map(|i| i as f64 / rate)
            .collect()
    }

    fn hav(x: f64) -> f64 {
        (1.0 - (std::f64::consts::TAU * x).cos()) / 2.0
    }

    #[test]
    fn pulses_are_found_with_noise_and_different_heights() {
        let mut f = Vec::new();
        for (k, amp) in [5.0, 50.0, 20.0].iter().enumerate() {
            for i in 0..200 {
                let x = i as f64 / 100.0;
                let v = if x < 1.0 { amp * hav(x) } else { 0.0 };
                let noise = 0.02 * (((i * 7919 + k * 104729) % 101) as f64 / 50.0 - 1.0);
                f.push(v + noise);
            }
        }
        let p = detect_pulses(&f);
        assert_eq!(p.len(), 3, "{p:?}");
        for (k, s) in p.iter().enumerate() {
            assert!(s.start > k * 200 && s.end < k * 200 + 100, "{s:?}");
        }
    }

    // Each protocol is named and cut into its segments: impulses, press-hold-release,
    // a staircase, and sines (from rest and on a preload).
    #[test]
    fn impulses_are_named_and_cut_into_pulses() {
        let t = grid(120.0, 50.0);
        // Three 4 s haversines, 16 s apart: impulse, one segment each.
        let f: Vec<f64> = t
            .iter()
            .map(|&x| {
                let ph = (x - 5.0).rem_euclid(20.0);
                if (5.0..65.0).contains(&x) && ph < 4.0 {
                    30.0 * hav(ph / 4.0)
                } else {
                    0.0
                }
            })
            .collect();
        let s = segment(&t, &f);
        assert_eq!(s.protocol, Protocol::Impulse);
        assert_eq!(s.segments.len(), 3);
        assert!(s.segments.iter().all(|g| g.kind == SegmentKind::Pulse));
    }

    #[test]
    fn press_hold_release_is_named_and_cut_into_presses_and_releases() {
        let t = grid(120.0, 50.0);
        // Trapezoids: 2 s ramps, 10 s hold: a press and a release each.
        let trap = |x: f64| {
            if !(0.0..=14.0).contains(&x) {
                0.0
            } else {
                (x / 2.0).min(1.0).min((14.0 - x) / 2.0)
            }
        };
        let f: Vec<f64> = t
            .iter()
            .map(|&x| 20.0 * (trap(x - 5.0) + trap(x - 45.0) + trap(x - 85.0)))
            .collect();
        let s = segment(&t, &f);
        assert_eq!(s.protocol, Protocol::PressHoldRelease);
        let kinds: Vec<SegmentKind> = s.segments.iter().map(|g| g.kind).collect();
        assert_eq!(kinds.len(), 6);
        assert!(kinds
            .chunks(2)
            .all(|c| c == [SegmentKind::Press, SegmentKind::Release]));
    }

    #[test]
    fn a_staircase_is_named_and_cut_into_steps() {
        // A staircase of 10 steps up and 10 down, 4 s holds, 0.3 s ramps.
        let stair = |x: f64| -> f64 {
            let period = 4.3;
            let k = (x / period).floor();
            let within = x - k * period;
            let up = |k: f64| if k < 10.0 { k + 1.0 } else { 19.0 - k };
            if !(0.0..19.0 * period + 0.3).contains(&x) {
                return 0.0;
            }
            let prev = if k == 0.0 { 0.0 } else { up(k - 1.0) };
            let cur = if k >= 19.0 { 0.0 } else { up(k) };
            if within < 0.3 {
                prev + (cur - prev) * within / 0.3
            } else {
                cur
            }
        };
        let t2 = grid(110.0, 50.0);
        let f: Vec<f64> = t2.iter().map(|&x| 0.245 * stair(x - 10.0)).collect();
        let s = segment(&t2, &f);
        assert_eq!(s.protocol, Protocol::Staircase);
        let ups = s
            .segments
            .iter()
            .filter(|g| g.kind == SegmentKind::StepUp)
            .count();
        let downs = s
            .segments
            .iter()
            .filter(|g| g.kind == SegmentKind::StepDown)
            .count();
        assert_eq!((ups, downs), (10, 10), "{:?}", s.segments);
        assert_eq!(s.plateaus.iter().filter(|p| !p.rest).count(), 19);
    }

    #[test]
    fn sines_are_named_and_cut_into_cycles() {
        let t = grid(120.0, 50.0);
        // A sine from rest, 0.25 Hz, 8 cycles: eight cycles.
        let f: Vec<f64> = t
            .iter()
            .map(|&x| {
                if (10.0..42.0).contains(&x) {
                    40.0 * hav((x - 10.0) / 4.0)
                } else {
                    0.0
                }
            })
            .collect();
        let s = segment(&t, &f);
        assert_eq!(s.protocol, Protocol::Sine);
        assert_eq!(s.segments.len(), 8);
        // The same sine riding on a 20 N preload: one excursion, eight cycles.
        let f: Vec<f64> = t
            .iter()
            .map(|&x| {
                if (10.0..42.0).contains(&x) {
                    20.0 + 20.0 * hav((x - 10.0) / 4.0)
                } else if (5.0..47.0).contains(&x) {
                    20.0
                } else {
                    0.0
                }
            })
            .collect();
        let s = segment(&t, &f);
        assert_eq!(s.protocol, Protocol::Sine, "{:?}", s.pulse_protocols);
        assert_eq!(s.segments.len(), 8);
    }
}
