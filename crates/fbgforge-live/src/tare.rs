//! The tare: each grating's zero-load wavelength, taken only from a window of frames in
//! which every grating is at rest.
//!
//! A window is the last [`TareSettings::frames`] frames and at least
//! [`TareSettings::min_s`] of frame time (whichever holds more frames). It is **at
//! rest** when, for every grating, the scatter of its wavelength about a straight line
//! through the window (the *spread*, a standard deviation) and the line's change across
//! the window (the *trend*) are what the interrogator's noise alone gives: the spread
//! within the resolution σ (with the allowance a sample of n frames needs, the 99.9 %
//! point of χ² with n − 2 degrees of freedom: 1.32 σ at 50 frames, 1.07 σ at 1000) and
//! the trend within σ, or within 3.29 standard errors of a fitted change when a short
//! window cannot resolve σ (1.58 σ at 50 frames). Until a window is at rest the run
//! waits, naming the gratings that move; [`TareSettings::wait_s`] after the first full
//! window it gives up and refuses to read, naming them, until asked to tare again.
//!
//! A steady load looks at rest too. Two things guard against taring on one: the window
//! must last [`TareSettings::min_s`] (1 s: a touch, or one step of the demo script,
//! does not hold that still for that long), and a tare that later proves to have held
//! a load is replaced: when a window at rest settles below the tare on every grating
//! (the sensor reads less than nothing: the load came off, or the temperature fell),
//! the run re-tares on it ([`Tare::retare_on_window`], origin `below_tare`).

use serde::Serialize;
use std::collections::VecDeque;

/// How the tare is taken.
#[derive(Debug, Clone, PartialEq)]
pub struct TareSettings {
    /// Frames in the window at least (0: no tare, shifts from the nominal wavelengths).
    pub frames: usize,
    /// Frame time the window spans at least, s.
    pub min_s: f64,
    /// After the first full window, how long to wait for one at rest before refusing, s.
    pub wait_s: f64,
    /// The interrogator's noise, the standard deviation of one wavelength reading, pm.
    pub resolution_pm: f64,
}

/// The fewest frames a window judged at rest may hold: with fewer, its spread says
/// nothing (2 frames always lie on a line).
pub const MIN_TARE_FRAMES: usize = 8;

impl TareSettings {
    /// Check the settings: no tare, or at least [`MIN_TARE_FRAMES`] frames; times ≥ 0.
    pub fn validate(&self) -> anyhow::Result<()> {
        if self.frames != 0 && self.frames < MIN_TARE_FRAMES {
            anyhow::bail!(
                "InterpretOptions.tare_frames must be 0 (no tare) or at least {MIN_TARE_FRAMES} frames (fewer cannot show that the sensor is at rest), got {}",
                self.frames
            );
        }
        if !(self.min_s.is_finite() && self.min_s >= 0.0) {
            anyhow::bail!(
                "InterpretOptions.tare_s must be a number of seconds ≥ 0, got {}",
                self.min_s
            );
        }
        if !(self.wait_s.is_finite() && self.wait_s >= 0.0) {
            anyhow::bail!(
                "InterpretOptions.tare_wait_s must be a number of seconds ≥ 0, got {}",
                self.wait_s
            );
        }
        Ok(())
    }
}

/// The largest spread (standard deviation about the window's line) a grating at rest
/// shows over `n` frames, pm: σ times the square root of the 99.9 % point of χ²/ν with
/// ν = n − 2 (Wilson–Hilferty).
pub fn spread_limit_pm(n: usize, resolution_pm: f64) -> f64 {
    let nu = n.saturating_sub(2).max(1) as f64;
    let a = 2.0 / (9.0 * nu);
    let ratio = (1.0 - a + Z_999 * a.sqrt()).powi(3);
    resolution_pm * ratio.sqrt()
}

/// The largest change across a window of `n` frames that is not a trend, pm: the
/// resolution, or 3.29 standard errors of the fitted change (two-sided 99.9 %) when
/// that is larger, as it is for short windows.
pub fn trend_limit_pm(n: usize, resolution_pm: f64) -> f64 {
    let n = n.max(3) as f64;
    let se = resolution_pm * (12.0 * (n - 1.0) / (n * (n + 1.0))).sqrt();
    resolution_pm.max(Z_999_TWO_SIDED * se)
}

/// One-sided 99.9 % point of the standard normal distribution.
const Z_999: f64 = 3.0902;
/// Two-sided 99.9 % point of the standard normal distribution.
const Z_999_TWO_SIDED: f64 = 3.2905;

/// Running sums of one grating over the window: index k (from an origin) and value x
/// (pm from a reference wavelength).
#[derive(Debug, Clone, Copy, Default)]
struct Sums {
    n: f64,
    k: f64,
    kk: f64,
    x: f64,
    xx: f64,
    kx: f64,
}

impl Sums {
    fn add(&mut self, k: f64, x: f64, sign: f64) {
        self.n += sign;
        self.k += sign * k;
        self.kk += sign * k * k;
        self.x += sign * x;
        self.xx += sign * x * x;
        self.kx += sign * k * x;
    }
}

/// One grating over a window: how many frames held it, its mean, spread and trend.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GratingStats {
    /// Frames in which the grating had a peak.
    pub n: usize,
    /// Mean wavelength, nm.
    pub mean_nm: f64,
    /// Standard deviation about the window's straight line, pm.
    pub spread_pm: f64,
    /// The line's change from the window's first frame to its last, pm.
    pub trend_pm: f64,
}

/// The last frames, with running sums per grating so that each frame costs O(gratings).
#[derive(Debug, Clone)]
pub(crate) struct RestWindow {
    min_frames: usize,
    min_s: f64,
    /// (frame time s, frame index) per frame, oldest first.
    times: VecDeque<(f64, u64)>,
    /// Wavelengths, nm, frame after frame (gratings per frame), NaN where missing.
    values: VecDeque<f64>,
    gratings: usize,
    sums: Vec<Sums>,
    /// Reference wavelength per grating, nm (NaN until the grating is first seen).
    refs_nm: Vec<f64>,
    /// Index origin of the sums.
    k0: u64,
    /// Frames removed since the sums were last rebuilt.
    removed: usize,
}

impl RestWindow {
    pub(crate) fn new(gratings: usize, min_frames: usize, min_s: f64) -> Self {
        RestWindow {
            min_frames,
            min_s,
            times: VecDeque::new(),
            values: VecDeque::new(),
            gratings,
            sums: vec![Sums::default(); gratings],
            refs_nm: vec![f64::NAN; gratings],
            k0: 0,
            removed: 0,
        }
    }

    pub(crate) fn clear(&mut self) {
        self.times.clear();
        self.values.clear();
        self.sums.fill(Sums::default());
        self.refs_nm.fill(f64::NAN);
        self.removed = 0;
    }

    fn frames(&self) -> usize {
        self.times.len()
    }

    fn span_s(&self) -> f64 {
        match (self.times.front(), self.times.back()) {
            (Some(a), Some(b)) => b.0 - a.0,
            _ => 0.0,
        }
    }

    /// Whether the window holds its frames and its time.
    pub(crate) fn full(&self) -> bool {
        self.frames() >= self.min_frames && self.span_s() >= self.min_s
    }

    fn add_frame(&mut self, k: u64, row: &[f64], sign: f64) {
        for (i, &w) in row.iter().enumerate() {
            if w.is_finite() {
                if self.refs_nm[i].is_nan() {
                    self.refs_nm[i] = w;
                }
                let x = (w - self.refs_nm[i]) * 1e3;
                self.sums[i].add((k - self.k0) as f64, x, sign);
            }
        }
    }

    /// Add a frame (`wl`: one wavelength per grating, NaN where missing) and drop the
    /// oldest frames the window no longer needs.
    pub(crate) fn push(&mut self, t_s: f64, k: u64, wl: &[f64]) {
        debug_assert_eq!(wl.len(), self.gratings);
        if self.times.is_empty() {
            self.k0 = k;
        }
        self.times.push_back((t_s, k));
        self.values.extend(wl.iter().copied());
        self.add_frame(k, wl, 1.0);
        // Drop the oldest frame while the rest still make a full window.
        while self.times.len() > self.min_frames
            && self.times.back().unwrap().0 - self.times[1].0 >= self.min_s
        {
            let (_, k_old) = self.times.pop_front().unwrap();
            let old: Vec<f64> = self.values.drain(..self.gratings).collect();
            self.add_frame(k_old, &old, -1.0);
            self.removed += 1;
        }
        // Sums updated by adding and removing drift from the exact values: rebuild them
        // from the window once it has turned over, about each grating's mean.
        if self.removed >= self.times.len().max(64) {
            self.rebuild();
        }
    }

    fn rebuild(&mut self) {
        let g = self.gratings;
        let mut mean = vec![0.0; g];
        let mut count = vec![0usize; g];
        for (j, &w) in self.values.iter().enumerate() {
            if w.is_finite() {
                mean[j % g] += w;
                count[j % g] += 1;
            }
        }
        for i in 0..g {
            self.refs_nm[i] = if count[i] > 0 {
                mean[i] / count[i] as f64
            } else {
                f64::NAN
            };
        }
        self.k0 = self.times.front().map_or(0, |t| t.1);
        self.sums.fill(Sums::default());
        let frames: Vec<(u64, Vec<f64>)> = self
            .times
            .iter()
            .enumerate()
            .map(|(f, &(_, k))| (k, (0..g).map(|i| self.values[f * g + i]).collect()))
            .collect();
        for (k, row) in frames {
            self.add_frame(k, &row, 1.0);
        }
        self.removed = 0;
    }

    /// Each grating's statistics over the window.
    pub(crate) fn stats(&self) -> Vec<GratingStats> {
        let span_k = match (self.times.front(), self.times.back()) {
            (Some(a), Some(b)) => (b.1 - a.1) as f64,
            _ => 0.0,
        };
        self.sums
            .iter()
            .zip(&self.refs_nm)
            .map(|(s, &r)| {
                if s.n < 0.5 {
                    return GratingStats {
                        n: 0,
                        mean_nm: f64::NAN,
                        spread_pm: f64::NAN,
                        trend_pm: f64::NAN,
                    };
                }
                let n = s.n;
                let (mk, mx) = (s.k / n, s.x / n);
                let var_k = (s.kk / n - mk * mk).max(0.0);
                let cov = s.kx / n - mk * mx;
                let var_x = (s.xx / n - mx * mx).max(0.0);
                let (slope, resid) = if var_k > 0.0 {
                    (cov / var_k, (var_x - cov * cov / var_k).max(0.0))
                } else {
                    (0.0, var_x)
                };
                let dof = (n - 2.0).max(1.0);
                GratingStats {
                    n: n.round() as usize,
                    mean_nm: r + mx * 1e-3,
                    spread_pm: (resid * n / dof).sqrt(),
                    trend_pm: slope * span_k,
                }
            })
            .collect()
    }

    /// Frame indices of the window's first and last frames, and its span, s.
    pub(crate) fn extent(&self) -> (u64, u64, f64) {
        (
            self.times.front().map_or(0, |t| t.1),
            self.times.back().map_or(0, |t| t.1),
            self.span_s(),
        )
    }
}

/// What the window says about each grating.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Verdict {
    /// Per grating.
    pub(crate) stats: Vec<GratingStats>,
    /// Gratings whose spread or trend is above its limit.
    pub(crate) moving: Vec<usize>,
    /// Gratings with a peak in fewer than half the window's frames (judged unseen: a
    /// tare keeps their nominal wavelength).
    pub(crate) unseen: Vec<usize>,
}

impl Verdict {
    pub(crate) fn at_rest(&self) -> bool {
        self.moving.is_empty() && self.unseen.len() < self.stats.len()
    }
}

/// Judge a full window against the resolution.
pub(crate) fn judge(window: &RestWindow, resolution_pm: f64) -> Verdict {
    let stats = window.stats();
    let frames = window.frames();
    let mut moving = Vec::new();
    let mut unseen = Vec::new();
    for (i, s) in stats.iter().enumerate() {
        if s.n < 3 || 2 * s.n < frames {
            unseen.push(i);
        } else if s.spread_pm > spread_limit_pm(s.n, resolution_pm)
            || s.trend_pm.abs() > trend_limit_pm(s.n, resolution_pm)
        {
            moving.push(i);
        }
    }
    Verdict {
        stats,
        moving,
        unseen,
    }
}

/// Where the tare stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TareState {
    /// Waiting for a window at rest: no readings yet.
    #[default]
    Waiting,
    /// Tared on a window at rest: frames are read.
    Resting,
    /// Gave up waiting: no readings until a re-tare.
    Refused,
    /// No tare: shifts from the nominal wavelengths.
    Nominal,
}

impl TareState {
    /// `waiting`, `resting`, `refused` or `nominal`.
    pub fn word(self) -> &'static str {
        match self {
            TareState::Waiting => "waiting",
            TareState::Resting => "resting",
            TareState::Refused => "refused",
            TareState::Nominal => "nominal",
        }
    }
}

/// A change of the tare, as the sinks are told it (the JSON `tare` line, the record's
/// marks, the views' tare state).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TareChange {
    /// The new state.
    pub state: TareState,
    /// What started this tare: `start`, `key`, `control`, `python`, `request` (a
    /// re-tare asked of the library), or `below_tare` (the sensor settled below the
    /// tare, which had held a load).
    pub origin: String,
    /// The frame (1 = the first frame with peaks) at which the change happened.
    pub frame: u64,
    /// Waiting or refused: the gratings whose spread or trend was above its limit.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub moving: Vec<String>,
    /// Gratings with no peak in most of the window (a tare keeps their nominal
    /// wavelength).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub unseen: Vec<String>,
    /// Resting: each grating's zero-load wavelength, nm.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub baseline_nm: Vec<f64>,
    /// Resting: the window's first and last frames (as `frame`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub window_frames: Option<(u64, u64)>,
    /// Resting: the window's span, s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub window_s: Option<f64>,
    /// Seconds of frame time waited since the first full window.
    pub waited_s: f64,
    /// What happened, in words.
    pub message: String,
}

/// The tare of a run: its window, its state and its baseline.
#[derive(Debug, Clone)]
pub(crate) struct Tare {
    settings: TareSettings,
    names: Vec<String>,
    nominal_nm: Vec<f64>,
    window: RestWindow,
    pub(crate) state: TareState,
    baseline_nm: Option<Vec<f64>>,
    origin: String,
    /// Frame time when this attempt's first window was full.
    full_since_s: Option<f64>,
    /// Frame time of the last `waiting` report, and the moving set reported.
    reported: Option<(f64, Vec<usize>)>,
    changes: Vec<TareChange>,
}

/// What the tare makes of a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Phase {
    /// Taken into the window while waiting for rest: no reading.
    Taring,
    /// The tare was refused: no reading.
    Refused,
    /// Read against the baseline (a frame after the tare's window).
    Read,
}

/// How often a run still waiting says so again when the moving gratings are the same,
/// s of frame time.
const WAITING_REPORT_S: f64 = 5.0;

impl Tare {
    pub(crate) fn new(settings: TareSettings, names: Vec<String>, nominal_nm: Vec<f64>) -> Self {
        let g = names.len();
        let nominal = settings.frames == 0;
        Tare {
            window: RestWindow::new(g, settings.frames.max(MIN_TARE_FRAMES), settings.min_s),
            settings,
            names,
            baseline_nm: nominal.then(|| nominal_nm.clone()),
            nominal_nm,
            state: if nominal {
                TareState::Nominal
            } else {
                TareState::Waiting
            },
            origin: "start".into(),
            full_since_s: None,
            reported: None,
            changes: Vec::new(),
        }
    }

    pub(crate) fn baseline_nm(&self) -> Option<&[f64]> {
        self.baseline_nm.as_deref()
    }

    pub(crate) fn settings(&self) -> &TareSettings {
        &self.settings
    }

    /// The changes since the last call, oldest first.
    pub(crate) fn take_changes(&mut self) -> Vec<TareChange> {
        std::mem::take(&mut self.changes)
    }

    fn names_of(&self, idx: &[usize]) -> Vec<String> {
        idx.iter().map(|&i| self.names[i].clone()).collect()
    }

    /// Start a new tare (a request: key, control line, Python, library). Ignored
    /// without a tare (`tare_frames` 0).
    pub(crate) fn request(&mut self, origin: &str, frame: u64) {
        if self.state == TareState::Nominal {
            return;
        }
        self.window.clear();
        self.state = TareState::Waiting;
        self.origin = origin.to_string();
        self.full_since_s = None;
        self.reported = None;
        self.changes.push(TareChange {
            state: TareState::Waiting,
            origin: origin.to_string(),
            frame,
            moving: Vec::new(),
            unseen: Vec::new(),
            baseline_nm: Vec::new(),
            window_frames: None,
            window_s: None,
            waited_s: 0.0,
            message: format!(
                "re-tare asked ({origin}): waiting for {} at rest; keep the sensor unloaded",
                self.window_words()
            ),
        });
    }

    /// `50 frames and 1.0 s`.
    fn window_words(&self) -> String {
        format!(
            "{} frames and {:.1} s",
            self.settings.frames.max(MIN_TARE_FRAMES),
            self.settings.min_s
        )
    }

    /// Take frame `frame` (time `t_s`; one wavelength per grating, NaN where missing).
    pub(crate) fn push(&mut self, t_s: f64, frame: u64, wl: &[f64]) -> Phase {
        match self.state {
            TareState::Nominal => return Phase::Read,
            TareState::Refused => return Phase::Refused,
            TareState::Waiting | TareState::Resting => {}
        }
        self.window.push(t_s, frame, wl);
        if self.state == TareState::Resting {
            return Phase::Read;
        }
        if !self.window.full() {
            return Phase::Taring;
        }
        let since = *self.full_since_s.get_or_insert(t_s);
        let verdict = judge(&self.window, self.settings.resolution_pm);
        if verdict.at_rest() {
            // The window's frames, this one included, made the tare: the next is read.
            self.accept(&verdict, frame, t_s - since);
            return Phase::Taring;
        }
        let waited = t_s - since;
        if waited > self.settings.wait_s {
            self.refuse(&verdict, frame, waited);
            return Phase::Refused;
        }
        self.report_waiting(&verdict, frame, t_s, waited);
        Phase::Taring
    }

    /// The window, when it is full and at rest: its statistics.
    pub(crate) fn settled(&self) -> Option<Verdict> {
        if !self.window.full() {
            return None;
        }
        let v = judge(&self.window, self.settings.resolution_pm);
        v.at_rest().then_some(v)
    }

    /// Tare again on the current window (at rest: [`Tare::settled`]), for `why`.
    pub(crate) fn retare_on_window(
        &mut self,
        verdict: &Verdict,
        frame: u64,
        origin: &str,
        why: &str,
    ) {
        self.origin = origin.to_string();
        self.accept(verdict, frame, 0.0);
        if let Some(c) = self.changes.last_mut() {
            c.message = format!("{why}; {}", c.message);
        }
    }

    fn accept(&mut self, v: &Verdict, frame: u64, waited_s: f64) {
        let baseline: Vec<f64> = v
            .stats
            .iter()
            .zip(&self.nominal_nm)
            .enumerate()
            .map(|(i, (s, &nominal))| {
                if v.unseen.contains(&i) {
                    nominal
                } else {
                    s.mean_nm
                }
            })
            .collect();
        let (first, last, span_s) = self.window.extent();
        let spread = v
            .stats
            .iter()
            .map(|s| s.spread_pm)
            .filter(|x| x.is_finite())
            .fold(0.0, f64::max);
        let trend = v
            .stats
            .iter()
            .map(|s| s.trend_pm.abs())
            .filter(|x| x.is_finite())
            .fold(0.0, f64::max);
        let mut message = format!(
            "tared at rest on frames {first}–{last} ({span_s:.2} s; spread ≤ {spread:.2} pm, trend ≤ {trend:.2} pm, resolution {} pm)",
            self.settings.resolution_pm
        );
        if !v.unseen.is_empty() {
            message.push_str(&format!(
                "; no peak during the tare for {}: shifts from the nominal wavelength",
                self.names_of(&v.unseen).join(", ")
            ));
        }
        self.state = TareState::Resting;
        self.baseline_nm = Some(baseline.clone());
        self.changes.push(TareChange {
            state: TareState::Resting,
            origin: self.origin.clone(),
            frame,
            moving: Vec::new(),
            unseen: self.names_of(&v.unseen),
            baseline_nm: baseline,
            window_frames: Some((first, last)),
            window_s: Some(span_s),
            waited_s,
            message,
        });
    }

    fn moving_words(&self, v: &Verdict) -> String {
        let detail: Vec<String> = v
            .moving
            .iter()
            .map(|&i| {
                let s = &v.stats[i];
                format!(
                    "{} (spread {:.2} pm, trend {:+.2} pm)",
                    self.names[i], s.spread_pm, s.trend_pm
                )
            })
            .collect();
        detail.join(", ")
    }

    fn refuse(&mut self, v: &Verdict, frame: u64, waited_s: f64) {
        self.state = TareState::Refused;
        let n = self.window.frames();
        let message = format!(
            "refused to tare: after {waited_s:.1} s no window of {} was at rest; moving: {} (limits at {n} frames: spread {:.2} pm, trend {:.2} pm, from the resolution {} pm); no loads are shown until a re-tare",
            self.window_words(),
            self.moving_words(v),
            spread_limit_pm(n, self.settings.resolution_pm),
            trend_limit_pm(n, self.settings.resolution_pm),
            self.settings.resolution_pm
        );
        let change = self.unsettled(TareState::Refused, v, frame, waited_s, message);
        self.changes.push(change);
    }

    /// A change with no window taken (waiting or refused): what moved and what was
    /// unseen, with the time waited so far.
    fn unsettled(
        &self,
        state: TareState,
        v: &Verdict,
        frame: u64,
        waited_s: f64,
        message: String,
    ) -> TareChange {
        TareChange {
            state,
            origin: self.origin.clone(),
            frame,
            moving: self.names_of(&v.moving),
            unseen: self.names_of(&v.unseen),
            baseline_nm: Vec::new(),
            window_frames: None,
            window_s: None,
            waited_s,
            message,
        }
    }

    fn report_waiting(&mut self, v: &Verdict, frame: u64, t_s: f64, waited_s: f64) {
        let due = match &self.reported {
            None => true,
            Some((t, moving)) => {
                *moving != v.moving && t_s - t >= 1.0 || t_s - t >= WAITING_REPORT_S
            }
        };
        if !due {
            return;
        }
        self.reported = Some((t_s, v.moving.clone()));
        let what = if v.moving.is_empty() {
            format!(
                "no grating had a peak in most frames: {}",
                self.names_of(&v.unseen).join(", ")
            )
        } else {
            format!("moving: {}", self.moving_words(v))
        };
        let message = format!(
            "waiting for the sensor to be at rest before taring ({:.1} of {:.1} s): {what}; keep it unloaded",
            waited_s, self.settings.wait_s
        );
        let change = self.unsettled(TareState::Waiting, v, frame, waited_s, message);
        self.changes.push(change);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    fn settings(frames: usize, min_s: f64) -> TareSettings {
        TareSettings {
            frames,
            min_s,
            wait_s: 2.0,
            resolution_pm: 0.5,
        }
    }

    #[test]
    fn the_limits_follow_the_chi_square_and_the_standard_error_of_a_trend() {
        // ν = 48: the 99.9 % point of χ² is 84.04 (tables), so √(84.04/48) σ.
        let exact = (84.04f64 / 48.0).sqrt() * 0.5;
        assert!(
            (spread_limit_pm(50, 0.5) / exact - 1.0).abs() < 0.005,
            "{}",
            spread_limit_pm(50, 0.5)
        );
        // ν = 998: 1141.78 → 1.0696 σ.
        let exact = (1141.78f64 / 998.0).sqrt() * 0.5;
        assert!((spread_limit_pm(1000, 0.5) / exact - 1.0).abs() < 0.003);
        // The trend: se of a fitted change over 50 frames is σ √(12·49/(50·51)) = 0.480 σ.
        assert!((trend_limit_pm(50, 0.5) - 3.2905 * 0.5 * (588.0f64 / 2550.0).sqrt()).abs() < 1e-9);
        assert_eq!(trend_limit_pm(1000, 0.5), 0.5);
    }

    /// Frames of `g` gratings at `nominal + offset(k)` with white noise σ = 0.5 pm.
    fn run(
        tare: &mut Tare,
        frames: u64,
        rate_hz: f64,
        offset_pm: impl Fn(u64, usize) -> f64,
        seed: u64,
    ) -> Vec<Phase> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let noise = Normal::new(0.0, 0.5).unwrap();
        let g = tare.names.len();
        (0..frames)
            .map(|k| {
                let wl: Vec<f64> = (0..g)
                    .map(|i| {
                        1530.0 + 3.0 * i as f64 + (offset_pm(k, i) + noise.sample(&mut rng)) * 1e-3
                    })
                    .collect();
                tare.push(k as f64 / rate_hz, k + 1, &wl)
            })
            .collect()
    }

    fn tare(frames: usize, min_s: f64) -> Tare {
        let names: Vec<String> = (1..=6).map(|i| format!("fbg{i}")).collect();
        let nominal = (0..6).map(|i| 1530.0 + 3.0 * i as f64).collect();
        Tare::new(settings(frames, min_s), names, nominal)
    }

    #[test]
    fn noise_alone_is_at_rest_and_the_baseline_is_the_window_mean() {
        // Over 200 seeds, a window of pure noise is accepted at its first full frame in
        // nearly every run (false alarms are rare: 6 gratings × 2 tests at 99.9 %, about
        // 1 % of windows), and within 100 more frames in every run.
        let mut first_try = 0;
        for seed in 0..200 {
            let mut t = tare(50, 0.0);
            let phases = run(&mut t, 150, 1000.0, |_, _| 7.0, seed);
            let Some(read_from) = phases.iter().position(|p| *p == Phase::Read) else {
                panic!("seed {seed}: {:?}", t.take_changes());
            };
            first_try += usize::from(read_from == 50);
            let b = t.baseline_nm().unwrap();
            // The mean of 50 frames: within 4 standard errors (0.28 pm) of the truth.
            for (i, &w) in b.iter().enumerate() {
                assert!(
                    ((w - 1530.0 - 3.0 * i as f64) * 1e3 - 7.0).abs() < 0.3,
                    "{w}"
                );
            }
        }
        assert!(first_try >= 190, "{first_try} of 200 at the first window");
    }

    #[test]
    fn a_step_or_a_creep_keeps_the_run_waiting_and_names_the_grating() {
        // A 5 pm step on fbg3 at frame 30 of a 50-frame window.
        let mut t = tare(50, 0.0);
        let phases = run(
            &mut t,
            60,
            1000.0,
            |k, i| if i == 2 && k >= 30 { 5.0 } else { 0.0 },
            1,
        );
        assert!(phases.iter().all(|p| *p == Phase::Taring));
        let c = t.take_changes();
        assert_eq!(c[0].state, TareState::Waiting);
        assert_eq!(c[0].moving, vec!["fbg3".to_string()]);
        assert!(c[0].message.contains("fbg3 (spread"), "{}", c[0].message);
        // A creep of 2 pm per window (0.04 pm per frame) on fbg5, no step.
        let mut t = tare(50, 0.0);
        let phases = run(
            &mut t,
            200,
            1000.0,
            |k, i| if i == 4 { 0.04 * k as f64 } else { 0.0 },
            2,
        );
        assert!(phases.iter().all(|p| *p == Phase::Taring));
        assert_eq!(t.take_changes()[0].moving, vec!["fbg5".to_string()]);
    }

    #[test]
    fn the_window_spans_its_time_and_a_later_rest_is_taken() {
        // 1 kHz, 50 frames and 0.3 s: a window of 301 frames. A load held 0.2 s at the
        // start cannot make a window; the rest after it does.
        let mut t = tare(50, 0.3);
        let phases = run(
            &mut t,
            700,
            1000.0,
            |k, i| if k < 200 { 10.0 + i as f64 } else { 0.0 },
            3,
        );
        let read_from = phases.iter().position(|p| *p == Phase::Read).unwrap();
        assert!((501..521).contains(&read_from), "{read_from}");
        let c = t.take_changes();
        let rest = c.iter().find(|c| c.state == TareState::Resting).unwrap();
        let (a, b) = rest.window_frames.unwrap();
        assert!(a > 200 && b - a == 300, "{a}–{b}");
        for (i, &w) in t.baseline_nm().unwrap().iter().enumerate() {
            assert!(((w - 1530.0 - 3.0 * i as f64) * 1e3).abs() < 0.15);
        }
    }

    #[test]
    fn waiting_ends_in_a_refusal_naming_the_moving_gratings_and_a_request_starts_again() {
        // fbg2 and fbg6 oscillate by ±5 pm forever.
        let mut t = tare(50, 0.0);
        let wobble = |k: u64, i: usize| {
            if i == 1 || i == 5 {
                5.0 * (k as f64 * 0.3).sin()
            } else {
                0.0
            }
        };
        let phases = run(&mut t, 3000, 1000.0, wobble, 4);
        let refused_at = phases.iter().position(|p| *p == Phase::Refused).unwrap();
        // The first window is full at frame 50 (t = 0.049 s); 2 s of waiting after it.
        assert!((2049..2052).contains(&refused_at), "{refused_at}");
        assert!(phases[refused_at..].iter().all(|p| *p == Phase::Refused));
        let c = t.take_changes();
        let r = c.last().unwrap();
        assert_eq!(r.state, TareState::Refused);
        assert_eq!(r.moving, vec!["fbg2".to_string(), "fbg6".to_string()]);
        assert!(r.message.contains("no loads are shown"), "{}", r.message);
        // Waiting was said once at first, then again only every 5 s or on a change.
        assert!(c.iter().filter(|c| c.state == TareState::Waiting).count() <= 2);
        t.request("key", 3001);
        assert_eq!(t.state, TareState::Waiting);
        let phases = run(&mut t, 60, 1000.0, |_, _| 0.0, 5);
        assert_eq!(phases.last(), Some(&Phase::Read));
        let c = t.take_changes();
        assert_eq!(c[0].origin, "key");
        assert_eq!(c.last().unwrap().origin, "key");
        assert_eq!(c.last().unwrap().state, TareState::Resting);
    }

    #[test]
    fn running_sums_stay_exact_over_a_long_run() {
        // After 20 000 frames the sums (updated by adding and removing) agree with a
        // window computed afresh.
        let mut w = RestWindow::new(2, 50, 0.0);
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let noise = Normal::new(0.0, 0.5).unwrap();
        for k in 0..20_000u64 {
            let wl = [
                1530.0 + (k as f64 * 0.001 + noise.sample(&mut rng)) * 1e-3,
                1540.2 + noise.sample(&mut rng) * 1e-3,
            ];
            w.push(k as f64 * 1e-3, k, &wl);
        }
        let got = w.stats();
        let mut fresh = w.clone();
        fresh.rebuild();
        let want = fresh.stats();
        for (a, b) in got.iter().zip(&want) {
            assert_eq!(a.n, 50);
            assert!(
                (a.spread_pm - b.spread_pm).abs() < 1e-6 && (a.trend_pm - b.trend_pm).abs() < 1e-6
            );
            assert!((a.mean_nm - b.mean_nm).abs() < 1e-12);
        }
        // The trend of 0.001 pm per frame over 49 frames.
        assert!((got[0].trend_pm - 0.049).abs() < 0.4);
    }
}
