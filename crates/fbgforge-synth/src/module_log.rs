//! Synthetic logs with known answers: a force profile of haversine pulses, a known
//! static sensitivity K, the standard-linear-solid lag (τ, r), a clock offset between
//! the two recordings, noise, drift, dropped peaks and a temperature ramp, written in
//! any supported format together with the matching force CSV and a `truth.json` that
//! holds the values the verifier should recover.
//!
//! The truth is computed from the noise-free model on a fine time grid: the lag of each
//! pulse is the time from the force peak (the middle of the haversine) to the peak of
//! the model response, and the expected R² adds the white noise of the sensor and
//! reference gratings to the noise-free scatter.

pub use crate::logs::LogStyle;
use crate::logs::{self, Clock, LogFormat, LogTable};
use crate::output::write_atomic_with;
use crate::spec::{Design, GratingRole};
use crate::verify::{fit, lag, segment};
use anyhow::{bail, Result};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::Serialize;
use std::path::Path;

/// The shape of one loading pulse (a force-stand protocol).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Default)]
#[serde(rename_all = "kebab-case", tag = "shape")]
pub enum PulseShape {
    /// F = peak·(1 − cos 2π(t − start)/duration)/2: an impulse-like press.
    #[default]
    Haversine,
    /// Press-hold-release: linear ramps of `ramp_s` up and down, the peak held between.
    Trapezoid {
        /// Duration of each ramp, s.
        ramp_s: f64,
    },
    /// A staircase: `steps` equal steps up to the peak, then back down step by step;
    /// every change a linear ramp of `ramp_s`, the holds between of equal length.
    Staircase {
        /// Number of steps up (as many down).
        steps: u32,
        /// Duration of each step's ramp, s.
        ramp_s: f64,
    },
    /// A sine from rest: `cycles` back-to-back haversines filling the duration
    /// (0 to the peak and back, at cycles/duration Hz).
    Sine {
        /// Number of cycles.
        cycles: u32,
    },
}

/// One loading pulse.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Pulse {
    /// Start, s from the wavelength log's first row.
    pub start_s: f64,
    /// Duration, s.
    pub duration_s: f64,
    /// Peak force, N.
    pub peak_n: f64,
    /// Shape.
    pub shape: PulseShape,
}

impl Pulse {
    /// Force at time `t`, N (0 outside the pulse).
    pub fn force_at(&self, t: f64) -> f64 {
        let x = t - self.start_s;
        let d = self.duration_s;
        if !(0.0..=d).contains(&x) || d <= 0.0 {
            return 0.0;
        }
        let hav = |u: f64| (1.0 - (std::f64::consts::TAU * u).cos()) / 2.0;
        self.peak_n
            * match self.shape {
                PulseShape::Haversine => hav(x / d),
                PulseShape::Trapezoid { ramp_s } => {
                    let r = ramp_s.clamp(1e-9, d / 2.0);
                    (x / r).min(1.0).min((d - x) / r)
                }
                PulseShape::Staircase { steps, ramp_s } => {
                    let n = steps.max(1) as f64;
                    let changes = 2.0 * n;
                    let r = ramp_s.clamp(1e-9, d / changes);
                    let hold = (d - changes * r) / (changes - 1.0);
                    // Change k (0-based) starts at k (r + hold).
                    let k = (x / (r + hold)).floor().min(changes - 1.0);
                    let within = x - k * (r + hold);
                    let level = |j: f64| if j < n { j + 1.0 } else { 2.0 * n - j - 1.0 };
                    let before = if k == 0.0 { 0.0 } else { level(k - 1.0) };
                    let after = level(k);
                    let v = if within < r {
                        before + (after - before) * within / r
                    } else {
                        after
                    };
                    v / n
                }
                PulseShape::Sine { cycles } => hav(x * cycles.max(1) as f64 / d),
            }
    }
}

/// Haversine pulses of the given peaks, each `duration_s` long, separated by `rest_s`,
/// the first starting at `lead_s`.
pub fn pulse_train(peaks_n: &[f64], duration_s: f64, rest_s: f64, lead_s: f64) -> Vec<Pulse> {
    shaped_train(peaks_n, duration_s, rest_s, lead_s, PulseShape::Haversine)
}

/// Pulses of one shape, as [`pulse_train`].
pub fn shaped_train(
    peaks_n: &[f64],
    duration_s: f64,
    rest_s: f64,
    lead_s: f64,
    shape: PulseShape,
) -> Vec<Pulse> {
    peaks_n
        .iter()
        .enumerate()
        .map(|(i, &p)| Pulse {
            start_s: lead_s + i as f64 * (duration_s + rest_s),
            duration_s,
            peak_n: p,
            shape,
        })
        .collect()
}

/// Force of a pulse train at time t, N.
pub fn force_at(pulses: &[Pulse], t: f64) -> f64 {
    pulses.iter().map(|p| p.force_at(t)).sum()
}

/// Everything a synthetic run is made of.
#[derive(Debug, Clone)]
pub struct SynthConfig {
    /// Core whose gratings respond (default: the first core).
    pub core: Option<String>,
    /// K of the core's first strain grating, pm/N; the k-th grating gets K·(1 − 0.15 k).
    pub sensitivity_pm_per_n: f64,
    /// Wavelength sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Force sample rate, Hz.
    pub force_rate_hz: f64,
    /// Loading pulses.
    pub pulses: Vec<Pulse>,
    /// Length of the wavelength log, s.
    pub duration_s: f64,
    /// SLS time constant τ, s.
    pub tau_s: f64,
    /// Fraction r of the response without lag.
    pub instant_fraction: f64,
    /// Pure transport delay of the response behind the force, s (on top of the SLS
    /// lag): the shift at t is the SLS response to the force at t − delay.
    pub transport_delay_s: f64,
    /// Wavelength-log time at which the force recording starts (its time zero), s.
    pub force_start_s: f64,
    /// White noise on every peak, pm (standard deviation).
    pub noise_pm: f64,
    /// White noise on the force, N.
    pub force_noise_n: f64,
    /// Drift of the strain gratings (not seen by the reference), pm/s.
    pub drift_pm_per_s: f64,
    /// Temperature ramp seen by every grating, K/s: the temperature rises at this rate
    /// for the first half of the run and falls back at it in the second half (a linear
    /// drift term cannot absorb it; only the reference grating removes it).
    pub temperature_ramp_k_per_s: f64,
    /// Probability that a peak is missing from a row.
    pub dropout_fraction: f64,
    /// Wall-clock time of the first row (for formats with timestamps), s since 1970.
    pub start_epoch_s: f64,
    /// Random seed.
    pub seed: u64,
    /// Gratings whose K is set by name instead of the K·(1 − 0.15 k) rule, pm/N (0 for a
    /// dead grating).
    pub grating_sensitivity_pm_per_n: Vec<(String, f64)>,
    /// The force channel saturates at this force, N: the logged force is
    /// min(F + noise, this), flat tops with the noise collapsed (a clipped load cell).
    pub force_saturation_n: Option<f64>,
    /// How much faster the force stand's clock runs than the interrogator's, ppm: a
    /// force sample taken t s after the force log's start is stamped t·(1 + ppm·1e-6).
    pub force_clock_skew_ppm: f64,
    /// Stretches of the wavelength log's time (s from its first row) the force log has
    /// no samples for (a stalled logger).
    pub force_gaps_s: Vec<(f64, f64)>,
    /// The interrogator's wavelength step, pm: every peak is rounded to a multiple of
    /// it (an SM125 reports 1 pm steps); 0 leaves them unrounded.
    pub quantization_pm: f64,
}

/// Most wavelength rows a synthetic log may have (about 1 GB of ENLIGHT text).
pub(crate) const MAX_ROWS: f64 = 1e7;
/// Most force samples a synthetic force log may have.
pub(crate) const MAX_FORCE_SAMPLES: f64 = 2e7;

impl Default for SynthConfig {
    fn default() -> Self {
        SynthConfig {
            core: None,
            sensitivity_pm_per_n: 12.0,
            sample_rate_hz: 20.0,
            force_rate_hz: 100.0,
            pulses: pulse_train(&[10.0, 20.0, 30.0, 40.0, 50.0, 25.0], 4.0, 6.0, 5.0),
            duration_s: 65.0,
            tau_s: 0.4,
            instant_fraction: 0.3,
            transport_delay_s: 0.0,
            force_start_s: -1.7,
            noise_pm: 0.3,
            force_noise_n: 0.01,
            drift_pm_per_s: 0.05,
            temperature_ramp_k_per_s: 0.0,
            dropout_fraction: 0.0,
            // 17/04/2025 15:44:56
            start_epoch_s: crate::logs::num::days_from_civil(2025, 4, 17) as f64 * 86400.0
                + 56696.0,
            seed: 1,
            grating_sensitivity_pm_per_n: Vec::new(),
            force_saturation_n: None,
            force_clock_skew_ppm: 0.0,
            force_gaps_s: Vec::new(),
            quantization_pm: 0.0,
        }
    }
}

impl SynthConfig {
    /// Wavelength rows the run writes.
    pub fn rows(&self) -> f64 {
        (self.duration_s * self.sample_rate_hz).floor()
    }

    /// Force samples the run writes.
    pub fn force_samples(&self) -> f64 {
        ((self.duration_s - self.force_start_s).max(self.duration_s) * self.force_rate_hz).floor()
            + 1.0
    }
}

/// A grating as written into the synthetic log.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SynthGrating {
    /// Name.
    pub name: String,
    /// Nominal wavelength, nm.
    pub nominal_nm: f64,
    /// True static K, pm/N (0 for the reference).
    pub sensitivity_pm_per_n: f64,
    /// True lag per segment (see [`crate::verify::lag`]), s.
    pub lags_s: Vec<f64>,
    /// True Δt_max (the largest segment lag), s.
    pub max_lag_s: f64,
    /// Expected R² of Δλ against F.
    pub r_squared_expected: f64,
    /// Expected Q = |K|·R²/Δt_max, pm/(N·s).
    pub quality_q_expected: f64,
    /// Temperature reference?
    pub reference: bool,
}

/// The known answers.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SynthTruth {
    /// Force clock − wavelength clock, s.
    pub clock_offset_s: f64,
    /// τ, s.
    pub sls_time_constant_s: f64,
    /// r.
    pub sls_instant_fraction: f64,
    /// Pure transport delay, s.
    pub transport_delay_s: f64,
    /// Protocol of the force profile, as the verifier names it.
    pub protocol: String,
    /// Wavelength sample period, s.
    pub sample_period_s: f64,
    /// Pulses.
    pub pulses: Vec<Pulse>,
    /// Gratings (strain then reference).
    pub gratings: Vec<SynthGrating>,
}

/// A generated wavelength log before formatting.
#[derive(Debug, Clone)]
pub struct SynthLog {
    /// Row times on the wavelength clock, s (absolute: `start_epoch_s` + t).
    pub time_s: Vec<f64>,
    /// Grating names in column order.
    pub names: Vec<String>,
    /// Wavelength per row and grating, nm; NaN = dropped.
    pub wavelength_nm: Vec<Vec<f64>>,
}

/// A generated force log.
#[derive(Debug, Clone)]
pub struct SynthForce {
    /// Time on the force clock (0 at its start), s.
    pub time_s: Vec<f64>,
    /// Force, N.
    pub force_n: Vec<f64>,
}

/// A train of pulses: what `fbgforge synth-log` describes with its peak forces, pulse
/// length, rest and shape.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainSettings {
    /// Peak force of each pulse, N.
    pub peaks_n: Vec<f64>,
    /// Duration of each pulse, s.
    pub pulse_s: f64,
    /// Rest between pulses (and after the last), s.
    pub rest_s: f64,
    /// Start of the first pulse, s.
    pub lead_s: f64,
    /// Shape of every pulse.
    pub shape: PulseShape,
}

/// The pulses of `t` ([`shaped_train`]) and the run's length (`rest_s` after the last
/// pulse, 30 s without pulses). Refuses lengths that are not finite and positive,
/// with the field named.
pub fn train(t: &TrainSettings) -> Result<(Vec<Pulse>, f64)> {
    let (pulse_s, rest_s) = (t.pulse_s, t.rest_s);
    if !(pulse_s > 0.0 && pulse_s.is_finite()) {
        bail!("the pulse length (TrainSettings.pulse_s) must be a finite number of seconds > 0, got {pulse_s}");
    }
    if !(rest_s >= 0.0 && rest_s.is_finite()) {
        bail!("the rest between pulses (TrainSettings.rest_s) must be a finite number of seconds ≥ 0, got {rest_s}");
    }
    if let Some(p) = t.peaks_n.iter().find(|p| !p.is_finite()) {
        bail!(
            "every peak force (TrainSettings.peaks_n) must be a finite number of newtons, got {p}"
        );
    }
    let pulses = shaped_train(&t.peaks_n, pulse_s, rest_s, t.lead_s, t.shape);
    let duration = pulses
        .last()
        .map_or(30.0, |p| p.start_s + p.duration_s + rest_s);
    if !duration.is_finite() {
        // A length of 1e308 s printed in full is 309 digits.
        let s = |v: f64| {
            if v.abs() < 1e9 {
                format!("{v}")
            } else {
                format!("{v:e}")
            }
        };
        bail!(
            "{} pulses of {} s with {} s between them make a run too long to write (TrainSettings.pulse_s, TrainSettings.rest_s)",
            t.peaks_n.len(),
            s(pulse_s),
            s(rest_s)
        );
    }
    Ok((pulses, duration))
}

/// Check the run's settings against the design; returns the core whose gratings
/// respond. Every number must be finite and in its range, and the log writable (at
/// most [`MAX_ROWS`] rows and [`MAX_FORCE_SAMPLES`] force samples).
pub fn check_config(design: &Design, cfg: &SynthConfig) -> Result<String> {
    let Some(m) = &design.module else {
        if design.array.is_some() {
            bail!(
                "design `{}` is a flat array, with no [module] to press: its synthetic log is a calibration run that follows a loading schedule (SynthLogRequest.schedule: a CSV of start_s,end_s,cell,load_g)",
                design.name
            )
        }
        bail!(
            "design `{}` has no [module] to synthesise a log for",
            design.name
        )
    };
    let core = cfg
        .core
        .clone()
        .or_else(|| m.cores.first().map(|c| c.name.clone()))
        .unwrap_or_default();
    if !m.cores.iter().any(|c| c.name == core) {
        bail!("design `{}` has no core named `{core}`", design.name);
    }
    check_numbers(cfg)?;
    check_size(cfg)?;
    check_pulses(cfg)?;
    Ok(core)
}

/// Rates, lengths, noises and the force channel's faults: finite and in range.
fn check_numbers(cfg: &SynthConfig) -> Result<()> {
    let positive = |v: f64| v > 0.0 && v.is_finite();
    if !(positive(cfg.sample_rate_hz)
        && positive(cfg.force_rate_hz)
        && positive(cfg.duration_s)
        && positive(cfg.tau_s))
    {
        bail!(
            "rates (SynthConfig.sample_rate_hz {}, SynthConfig.force_rate_hz {}), the run's length ({} s) and τ (SynthConfig.tau_s {}) must be finite and positive",
            cfg.sample_rate_hz,
            cfg.force_rate_hz,
            cfg.duration_s,
            cfg.tau_s
        );
    }
    for (name, v) in [
        (
            "the sensitivity (SynthConfig.sensitivity_pm_per_n)",
            cfg.sensitivity_pm_per_n,
        ),
        (
            "the force log's start (SynthConfig.force_start_s)",
            cfg.force_start_s,
        ),
        ("the drift (SynthConfig.drift_pm_per_s)", cfg.drift_pm_per_s),
        (
            "the temperature ramp (SynthConfig.temperature_ramp_k_per_s)",
            cfg.temperature_ramp_k_per_s,
        ),
        ("the first row's wall-clock time", cfg.start_epoch_s),
        ("the force clock's skew", cfg.force_clock_skew_ppm),
    ] {
        if !v.is_finite() {
            bail!("{name} must be a finite number, got {v}");
        }
    }
    for (name, v) in [
        ("the peak noise (SynthConfig.noise_pm)", cfg.noise_pm),
        (
            "the force noise (SynthConfig.force_noise_n)",
            cfg.force_noise_n,
        ),
        (
            "the wavelength step (SynthConfig.quantization_pm)",
            cfg.quantization_pm,
        ),
    ] {
        if !(v >= 0.0 && v.is_finite()) {
            bail!("{name} must be a finite number ≥ 0, got {v}");
        }
    }
    // A step coarser than a nanometre rounds every peak far from its grating (1e308
    // put them all at 0 nm).
    if cfg.quantization_pm > MAX_STEP_PM {
        bail!(
            "the wavelength step (SynthConfig.quantization_pm) must be at most {MAX_STEP_PM} pm, got {}",
            cfg.quantization_pm
        );
    }
    if cfg.force_clock_skew_ppm.abs() >= 1e5 {
        bail!(
            "the force clock's skew must be below 100 000 ppm, got {}",
            cfg.force_clock_skew_ppm
        );
    }
    if let Some(f) = cfg.force_saturation_n.filter(|f| !f.is_finite()) {
        bail!("the force saturation must be a finite number of newtons, got {f}");
    }
    if let Some((a, b)) = cfg
        .force_gaps_s
        .iter()
        .find(|(a, b)| !(a.is_finite() && b.is_finite() && a < b))
    {
        bail!("a force gap must run from one finite time to a later one, got {a} s to {b} s");
    }
    if let Some((g, k)) = cfg
        .grating_sensitivity_pm_per_n
        .iter()
        .find(|(_, k)| !k.is_finite())
    {
        bail!("grating `{g}`: its sensitivity must be a finite number, got {k}");
    }
    Ok(())
}

/// The log writable: at least 10 and at most [`MAX_ROWS`] rows, at most
/// [`MAX_FORCE_SAMPLES`] force samples.
fn check_size(cfg: &SynthConfig) -> Result<()> {
    let rows = cfg.rows();
    if rows.is_nan() || rows > MAX_ROWS {
        bail!(
            "a run of {:e} s at {} Hz would be {rows:e} wavelength rows; a synthetic log has at most {MAX_ROWS:e} (shorten TrainSettings.pulse_s, TrainSettings.rest_s or the train, or lower SynthConfig.sample_rate_hz)",
            cfg.duration_s,
            cfg.sample_rate_hz
        );
    }
    if rows < 10.0 {
        bail!(
            "a run of {} s at {} Hz would be {rows} wavelength rows; at least 10 are needed",
            cfg.duration_s,
            cfg.sample_rate_hz
        );
    }
    let samples = cfg.force_samples();
    if samples.is_nan() || samples > MAX_FORCE_SAMPLES {
        bail!(
            "the force log would hold {samples:e} samples ({} Hz over {:e} s); at most {MAX_FORCE_SAMPLES:e} are written (lower SynthConfig.force_rate_hz, shorten the run or SynthConfig.force_start_s)",
            cfg.force_rate_hz,
            (cfg.duration_s - cfg.force_start_s).max(cfg.duration_s)
        );
    }
    Ok(())
}

/// The transport delay, every pulse's shape within its duration, a non-zero peak, and
/// the fractions in range.
fn check_pulses(cfg: &SynthConfig) -> Result<()> {
    if !(cfg.transport_delay_s.is_finite() && cfg.transport_delay_s >= 0.0) {
        bail!(
            "the transport delay must be a finite number of seconds ≥ 0, got {}",
            cfg.transport_delay_s
        );
    }
    for p in &cfg.pulses {
        let ok = match p.shape {
            PulseShape::Haversine => true,
            PulseShape::Trapezoid { ramp_s } => ramp_s > 0.0 && 2.0 * ramp_s <= p.duration_s,
            PulseShape::Staircase { steps, ramp_s } => {
                steps >= 1 && ramp_s > 0.0 && 2.0 * steps as f64 * ramp_s < p.duration_s
            }
            PulseShape::Sine { cycles } => cycles >= 1,
        };
        if !(ok
            && p.duration_s > 0.0
            && p.duration_s.is_finite()
            && p.peak_n.is_finite()
            && p.start_s.is_finite())
        {
            bail!("pulse at {} s: its shape {:?} does not fit its duration {} s (ramps must be positive and fit; at least one step or cycle)", p.start_s, p.shape, p.duration_s);
        }
    }
    if cfg.pulses.iter().all(|p| p.peak_n == 0.0) {
        bail!("the force profile needs at least one pulse with a non-zero peak");
    }
    if !(0.0..=1.0).contains(&cfg.instant_fraction) || !(0.0..1.0).contains(&cfg.dropout_fraction) {
        bail!("the instant fraction must be in [0, 1] and the dropout fraction in [0, 1)");
    }
    Ok(())
}

/// The noise-free response on a fine time grid, with the true lags it gives.
struct FineResponse {
    /// Grid times, s.
    ts: Vec<f64>,
    /// Response y (shift per unit K), delayed by the transport delay.
    ys: Vec<f64>,
    /// The verifier's segmentation of the noise-free force.
    seg: segment::Segmentation,
    /// True lag per segment, s.
    lags: Vec<f64>,
    /// True Δt_max, s.
    max_lag: f64,
}

/// The noise-free response on a grid fine enough for the lag truth (capped at 4
/// million steps for long runs), and the true lags: the verifier's segments of the
/// noise-free force and its lag measure on the noise-free response.
fn fine_response(cfg: &SynthConfig) -> FineResponse {
    let dt_sim = (1.0 / (10.0 * cfg.sample_rate_hz))
        .min(cfg.tau_s / 20.0)
        .min(1e-2)
        .max(cfg.duration_s / 4e6);
    let n_sim = (cfg.duration_s / dt_sim).ceil() as usize + 2;
    let ts: Vec<f64> = (0..n_sim).map(|i| i as f64 * dt_sim).collect();
    let fs: Vec<f64> = ts.iter().map(|&t| force_at(&cfg.pulses, t)).collect();
    let mut y0 = Vec::new();
    fit::sls_response(&ts, &fs, cfg.tau_s, cfg.instant_fraction, &mut y0);
    // The delayed response: ys(t) = y0(t − delay).
    let mut h = 0;
    let ys: Vec<f64> = ts
        .iter()
        .map(|&t| {
            if t < cfg.transport_delay_s {
                y0[0]
            } else {
                fit::interp(&ts, &y0, t - cfg.transport_delay_s, &mut h)
            }
        })
        .collect();
    let seg = segment::segment(&ts, &fs);
    let model_lag = cfg.transport_delay_s.abs() + (1.0 - cfg.instant_fraction) * cfg.tau_s;
    let lags: Vec<f64> = seg
        .segments
        .iter()
        // As the verifier: only changes of force that the log covers whole.
        .filter(|s| ts[s.end] < cfg.duration_s)
        .filter_map(|s| {
            let w = (ts[s.window.0], ts[s.window.1]);
            let range = lag::search_range_s(w, model_lag);
            lag::segment_lag(&ts, &ys, &ts, &fs, w, range, 1.0).map(|l| l.lag_s)
        })
        .collect();
    let max_lag = lags.iter().copied().fold(f64::NAN, f64::max);
    FineResponse {
        ts,
        ys,
        seg,
        lags,
        max_lag,
    }
}

/// The seeded noise of a run, drawn in a fixed order so that a seed gives one run.
struct Noise {
    rng: ChaCha8Rng,
    normal: Normal<f64>,
}

impl Noise {
    /// Whether this peak is dropped from its row.
    fn dropped(&mut self, fraction: f64) -> bool {
        self.rng.random::<f64>() < fraction
    }

    /// One draw of the unit normal.
    fn unit(&mut self) -> f64 {
        self.normal.sample(&mut self.rng)
    }
}

/// What every grating's column is computed from: the rows of the wavelength log.
struct Rows<'a> {
    cfg: &'a SynthConfig,
    fiber: crate::grating::FiberOptics,
    /// Row times, s from the first row.
    t_rel: Vec<f64>,
    /// Noise-free response at the rows.
    y_rows: Vec<f64>,
    /// Force at the rows, N.
    f_rows: Vec<f64>,
    /// The reference grating's nominal wavelength, nm.
    reference_nm: Option<f64>,
}

impl Rows<'_> {
    /// The temperature profile's time factor: it rises for the first half of the run
    /// and falls back in the second.
    fn ramp_time_s(&self, t: f64) -> f64 {
        let half = self.cfg.duration_s / 2.0;
        if t < half {
            t
        } else {
            2.0 * half - t
        }
    }

    /// The k-th strain grating's column (nm, NaN = dropped) and its truth.
    fn strain_column(
        &self,
        k: usize,
        g: &crate::spec::ModuleGrating,
        fine: &FineResponse,
        noise: &mut Noise,
    ) -> Result<(Vec<f64>, SynthGrating)> {
        let cfg = self.cfg;
        let n = self.t_rel.len();
        let kg = cfg
            .grating_sensitivity_pm_per_n
            .iter()
            .find(|(n, _)| *n == g.name)
            .map_or(
                cfg.sensitivity_pm_per_n * (1.0 - 0.15 * k as f64),
                |(_, k)| *k,
            );
        let l0 = g.bragg_wavelength_nm;
        let ts_pm = self.fiber.temperature_sensitivity_pm_per_k(l0);
        let col: Vec<f64> = (0..n)
            .map(|i| {
                if noise.dropped(cfg.dropout_fraction) {
                    return f64::NAN;
                }
                let t = self.t_rel[i];
                let pm = kg * self.y_rows[i]
                    + cfg.drift_pm_per_s * t
                    + ts_pm * cfg.temperature_ramp_k_per_s * self.ramp_time_s(t)
                    + cfg.noise_pm * noise.unit();
                quantize_nm(l0, pm, cfg.quantization_pm)
            })
            .collect();
        let r2 = self.expected_r_squared(kg, l0)?;
        let truth = SynthGrating {
            name: g.name.clone(),
            nominal_nm: l0,
            sensitivity_pm_per_n: kg,
            lags_s: fine.lags.clone(),
            max_lag_s: fine.max_lag,
            r_squared_expected: r2,
            quality_q_expected: kg.abs() * r2 / fine.max_lag,
            reference: false,
        };
        Ok((col, truth))
    }

    /// Expected R² of a grating with sensitivity `kg` at `l0`: the noise-free scatter
    /// of K·y about the best line in F, plus the noise of it and the reference.
    fn expected_r_squared(&self, kg: f64, l0: f64) -> Result<f64> {
        let cfg = self.cfg;
        let n = self.t_rel.len();
        let clean: Vec<f64> = self.y_rows.iter().map(|y| kg * y).collect();
        let Some(line) = fit::fit_line(&self.f_rows, &clean) else {
            bail!(
                "no pulse falls inside the {} s log: the force does not vary",
                cfg.duration_s
            );
        };
        let mean = clean.iter().sum::<f64>() / n as f64;
        let sst0: f64 = clean.iter().map(|v| (v - mean).powi(2)).sum();
        let ssr0 = (1.0 - line.r_squared) * sst0;
        let ratio = self.reference_nm.map_or(0.0, |lr| l0 / lr);
        let var = cfg.noise_pm.powi(2) * (1.0 + ratio * ratio) * n as f64;
        Ok(1.0 - (ssr0 + var) / (sst0 + var))
    }

    /// The reference grating's column (temperature and noise only) and its truth.
    fn reference_column(
        &self,
        r: &crate::spec::ModuleGrating,
        noise: &mut Noise,
    ) -> (Vec<f64>, SynthGrating) {
        let cfg = self.cfg;
        let l0 = r.bragg_wavelength_nm;
        let ts_pm = self.fiber.temperature_sensitivity_pm_per_k(l0);
        let col: Vec<f64> = (0..self.t_rel.len())
            .map(|i| {
                if noise.dropped(cfg.dropout_fraction) {
                    return f64::NAN;
                }
                let pm = ts_pm * cfg.temperature_ramp_k_per_s * self.ramp_time_s(self.t_rel[i])
                    + cfg.noise_pm * noise.unit();
                quantize_nm(l0, pm, cfg.quantization_pm)
            })
            .collect();
        let truth = SynthGrating {
            name: r.name.clone(),
            nominal_nm: l0,
            sensitivity_pm_per_n: 0.0,
            lags_s: vec![],
            max_lag_s: f64::NAN,
            r_squared_expected: f64::NAN,
            quality_q_expected: f64::NAN,
            reference: true,
        };
        (col, truth)
    }
}

/// A peak at `l0` nm shifted by `pm`, rounded to a multiple of `step_pm` (none at 0), nm.
fn quantize_nm(l0: f64, pm: f64, step_pm: f64) -> f64 {
    if step_pm > 0.0 {
        ((l0 * 1e3 + pm) / step_pm).round() * step_pm * 1e-3
    } else {
        l0 + pm * 1e-3
    }
}

/// The force log, on its own clock (skewed when asked), covering the wavelength log:
/// saturated and with gaps when asked.
fn force_log(cfg: &SynthConfig, noise: &mut Noise) -> SynthForce {
    let nf = cfg.force_samples() as usize;
    let mut ft = Vec::with_capacity(nf);
    let mut ff = Vec::with_capacity(nf);
    let stamp = 1.0 + 1e-6 * cfg.force_clock_skew_ppm;
    let cap = cfg.force_saturation_n.unwrap_or(f64::INFINITY);
    for k in 0..nf {
        let tf = k as f64 / cfg.force_rate_hz;
        // Drawn for every sample, so that the noise does not depend on the gaps.
        let f = force_at(&cfg.pulses, tf + cfg.force_start_s) + cfg.force_noise_n * noise.unit();
        let t = tf + cfg.force_start_s;
        if cfg.force_gaps_s.iter().any(|(a, b)| t >= *a && t < *b) {
            continue;
        }
        ft.push(tf * stamp);
        ff.push(f.min(cap));
    }
    SynthForce {
        time_s: ft,
        force_n: ff,
    }
}

/// Generate a run.
pub fn generate(design: &Design, cfg: &SynthConfig) -> Result<(SynthLog, SynthForce, SynthTruth)> {
    let core = check_config(design, cfg)?;
    let Some(m) = &design.module else {
        bail!(
            "design `{}` has no [module] to synthesise a log for",
            design.name
        )
    };
    let strain: Vec<_> = m
        .gratings
        .iter()
        .filter(|g| g.role == GratingRole::Strain && g.core.as_deref() == Some(&core))
        .collect();
    let reference = m
        .gratings
        .iter()
        .find(|g| g.role == GratingRole::TemperatureReference);
    let mut noise = Noise {
        rng: ChaCha8Rng::seed_from_u64(cfg.seed),
        normal: Normal::new(0.0, 1.0).expect("unit normal"),
    };
    let fine = fine_response(cfg);
    // The wavelength log's rows.
    let n = (cfg.duration_s * cfg.sample_rate_hz).floor() as usize;
    let t_rel: Vec<f64> = (0..n).map(|i| i as f64 / cfg.sample_rate_hz).collect();
    let mut h = 0;
    let rows = Rows {
        cfg,
        fiber: design.fiber,
        y_rows: t_rel
            .iter()
            .map(|&t| fit::interp(&fine.ts, &fine.ys, t, &mut h))
            .collect(),
        f_rows: t_rel.iter().map(|&t| force_at(&cfg.pulses, t)).collect(),
        t_rel,
        reference_nm: reference.map(|r| r.bragg_wavelength_nm),
    };
    let mut columns = Vec::new();
    let mut truth_gratings = Vec::new();
    for (k, g) in strain.iter().enumerate() {
        let (col, truth) = rows.strain_column(k, g, &fine, &mut noise)?;
        columns.push(col);
        truth_gratings.push(truth);
    }
    if let Some(r) = reference {
        let (col, truth) = rows.reference_column(r, &mut noise);
        columns.push(col);
        truth_gratings.push(truth);
    }
    let log = SynthLog {
        names: truth_gratings.iter().map(|g| g.name.clone()).collect(),
        wavelength_nm: (0..n)
            .map(|i| columns.iter().map(|c| c[i]).collect())
            .collect(),
        time_s: rows.t_rel,
    };
    let force = force_log(cfg, &mut noise);
    if force.time_s.len() < 2 {
        bail!("the force log would hold fewer than two samples (its gaps cover it)");
    }
    let truth = SynthTruth {
        clock_offset_s: -cfg.force_start_s,
        sls_time_constant_s: cfg.tau_s,
        sls_instant_fraction: cfg.instant_fraction,
        transport_delay_s: cfg.transport_delay_s,
        protocol: fine.seg.protocol.name().into(),
        sample_period_s: 1.0 / cfg.sample_rate_hz,
        pulses: cfg.pulses.clone(),
        gratings: truth_gratings,
    };
    Ok((log, force, truth))
}

/// The clock offset the verifier reports for a log written in `format`: the force
/// clock reads t − force_start, the wavelength clock `start_epoch_s` + t for formats
/// with wall-clock timestamps and t for the others (plain CSV).
pub fn reported_offset_s(cfg: &SynthConfig, format: LogFormat) -> f64 {
    let w0 = match format.written_clock() {
        Clock::Absolute => cfg.start_epoch_s,
        Clock::Relative => 0.0,
    };
    -cfg.force_start_s - w0
}

/// Write a wavelength log in `format` (atomically), its first row at
/// Largest wavelength step a synthetic log may round peaks to, pm (an interrogator's
/// step is 1-10 pm; 1 nm is already coarser than any).
pub const MAX_STEP_PM: f64 = 1000.0;
/// Most metadata lines a synthetic ENLIGHT log may lead with (the real ones hold ~45).
pub const MAX_METADATA_LINES: usize = 10_000;

/// `cfg.start_epoch_s`.
pub fn write_log(
    path: &Path,
    format: LogFormat,
    log: &SynthLog,
    cfg: &SynthConfig,
    style: &LogStyle,
) -> Result<()> {
    // Checked before the file is opened: no temporary file is left behind.
    if style.metadata_lines > MAX_METADATA_LINES {
        bail!(
            "the metadata lines before the header (LogStyle.metadata_lines) must be at most {MAX_METADATA_LINES}, got {}",
            style.metadata_lines
        );
    }
    let table = LogTable {
        start_epoch_s: cfg.start_epoch_s,
        time_s: &log.time_s,
        names: &log.names,
        wavelength_nm: &log.wavelength_nm,
        sample_rate_hz: cfg.sample_rate_hz,
    };
    write_atomic_with(path, |w| Ok(logs::write_log(w, format, &table, style)?))
}

/// Write the force log as `time_s,force_N` (atomically).
pub fn write_force_csv(path: &Path, force: &SynthForce) -> Result<()> {
    write_atomic_with(path, |w| {
        Ok(logs::write_force_csv(w, &force.time_s, &force.force_n)?)
    })
}

/// Write the force log as a force stand with a wall clock does (atomically):
/// `AbsTime,RelTime,position,force,stress`, AbsTime in `dd/mm/yyyy HH:MM:SS.ffffff`
/// from `start_epoch_s` (the wall-clock time of the force log's first sample).
pub fn write_force_stand_csv(path: &Path, force: &SynthForce, start_epoch_s: f64) -> Result<()> {
    write_atomic_with(path, |w| {
        Ok(logs::write_force_stand_csv(
            w,
            &force.time_s,
            &force.force_n,
            start_epoch_s,
        )?)
    })
}

/// File extension for a format.
pub fn extension(format: LogFormat) -> &'static str {
    format.extension()
}
