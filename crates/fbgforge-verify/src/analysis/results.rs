//! What an analysis reports: per segment, per grating and for the whole measurement
//! (the verifier JSON), and the time series behind the plots.

use crate::logs::LogWarnings;
use crate::segment::{Protocol, SegmentKind};
use serde::Serialize;

/// One segment of the loading (a press, a cycle, a ramp or a step; see
/// [`crate::segment`]) as seen by one grating. The JSON keeps the name `pulses` for
/// the list.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PulseResult {
    /// Segment number, from 1.
    pub index: usize,
    /// The pulse (excursion above rest) it belongs to, from 1.
    pub pulse: usize,
    /// What it is: `pulse`, `cycle`, `press`, `release`, `step-up`, `step-down`.
    pub kind: SegmentKind,
    /// Start of the change of force, s.
    pub start_s: f64,
    /// End of the change of force, s.
    pub end_s: f64,
    /// Largest force in the segment's window, N.
    pub peak_force_n: f64,
    /// Time of the force peak (vertex of a parabola through its top 5 %), s; for a
    /// pulse or a cycle only (NaN for ramps and steps, whose peak is a plateau).
    pub peak_force_time_s: f64,
    /// Peak shift (drift removed; signed), pm; pulses and cycles only.
    pub peak_shift_pm: f64,
    /// Time of the peak shift, s; pulses and cycles only (informational: the lag is
    /// `lag_s`, not the difference of the two peak times).
    pub peak_shift_time_s: f64,
    /// Lag of the shift behind the force: the time shift that best lines the shift up
    /// with the force over the segment's window (sub-sample cross-correlation), s.
    pub lag_s: f64,
    /// Standard uncertainty of `lag_s`: the noise, and 2 % of the wavelength log's
    /// sample period for a segment seen in few samples, s (not the timestamps'
    /// resolution, which every segment shares: see `max_lag_uncertainty_s`).
    pub lag_uncertainty_s: f64,
}

/// Everything measured for one grating.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GratingResult {
    /// Grating name.
    pub grating: String,
    /// Core it is bonded in.
    pub core: Option<String>,
    /// Material key of that core (the optimiser models lag per material).
    pub core_material: Option<String>,
    /// Nominal wavelength, nm.
    pub nominal_nm: f64,
    /// Window half-width used, nm.
    pub window_half_width_nm: f64,
    /// Rows of the log with a peak in the window.
    pub rows_with_peak: usize,
    /// Rows with more than one peak in the window.
    pub rows_ambiguous: usize,
    /// Static sensitivity K, the one compared with the model: the slope of the shift on
    /// the lag-corrected force over the loading branch and rest, beside the slow
    /// curve, pm/N.
    pub sensitivity_pm_per_n: f64,
    /// Standard error of K (white-noise assumption), pm/N.
    pub sensitivity_std_error_pm_per_n: f64,
    /// The lag model's K from every row with a baseline and a linear drift (the K of
    /// the lag fit, before the loading branch and the slow curve), pm/N.
    pub lag_model_sensitivity_pm_per_n: f64,
    /// Rows of the loading branch (and rest) behind K.
    pub loading_rows: usize,
    /// The response against a slow variation (temperature, drift).
    pub slow_test: Option<SlowTest>,
    /// Each trusted press's gain (1: explained).
    pub pulse_gains: Vec<PulseGain>,
    /// The interrogator's readings of this grating.
    pub instrument: InstrumentCheck,
    /// The hysteresis this grating's core material may show, % of span (the design's
    /// material, else the printer's default).
    pub hysteresis_limit_percent_span: f64,
    /// The loop the rows' own timing uncertainty could open on a perfectly elastic
    /// part, % of span: 2·u·|dx/dt| / x_max (u the timestamps' uncertainty, |dx/dt|
    /// the median rate of the lag-corrected force on its branches); a wider loop
    /// than the limit proves a loose bond only beyond this.
    pub hysteresis_timing_percent_span: f64,
    /// Lag-1 autocorrelation ρ of the lag model's residuals: near 1 when the residual
    /// wanders slowly (drift, an unrelated signal), which makes the samples far from
    /// independent.
    pub residual_autocorrelation: f64,
    /// Effective number of independent samples, n (1 − ρ) / (1 + ρ).
    pub effective_samples: f64,
    /// Standard error of K allowing for the autocorrelated residuals:
    /// `sensitivity_std_error_pm_per_n` × √(n / n_eff), pm/N, and never below
    /// `sensitivity_peak_std_error_pm_per_n` (the residuals hold the peaks' random noise
    /// already; the floor keeps K from claiming more than its peaks allow).
    pub sensitivity_std_error_effective_pm_per_n: f64,
    /// Standard error of K that the peaks' own standard errors alone make (a log of
    /// spectra or a peaks log with standard errors; `None` otherwise), pm/N:
    /// √(Σ (Fᵢ − F̄)² σᵢ²) / Σ (Fᵢ − F̄)². It is a floor under
    /// `sensitivity_std_error_effective_pm_per_n`.
    pub sensitivity_peak_std_error_pm_per_n: Option<f64>,
    /// |K| / `sensitivity_std_error_effective_pm_per_n`: how far K stands from zero.
    pub sensitivity_t_statistic: f64,
    /// Largest peak force of the pulses, N.
    pub peak_force_n: f64,
    /// Slope of a straight line through Δλ against F (no lag model), pm/N.
    pub linear_slope_pm_per_n: f64,
    /// R² of that straight line.
    pub r_squared: f64,
    /// R² of the lag model (baseline and drift included).
    pub lag_model_r_squared: f64,
    /// Share of the shift left after a slow variation (the slow curve of `slow_test`:
    /// temperature, drift) that the lag-corrected force explains. The response gate
    /// reads it (the straight-line R² counts the lag itself as misfit).
    pub response_r_squared: f64,
    /// Largest gap between the unloading and loading branches of the lag-corrected
    /// signal (shift against the lag model's response), % of span (the loading
    /// calibration line's full-scale output); NaN with too few rows on a branch.
    pub hysteresis_percent_span: f64,
    /// Largest distance of the loading branch's bin means from its calibration line, %
    /// of span.
    pub nonlinearity_percent_span: f64,
    /// Smallest resolvable force: interrogator resolution / |K|, N.
    pub resolution_n: f64,
    /// The same in grams-force, g.
    pub resolution_g: f64,
    /// Δt_max, s: the weighted mean of the segment lags when they agree within their
    /// uncertainties (`max_lag_method` = `pooled`), else the largest (`largest`); see
    /// [`crate::lag`].
    pub max_lag_s: f64,
    /// Standard uncertainty of Δt_max, s: the noise, 2 % of the sample period, and the
    /// timestamps' resolution when the lags are absolute (`timing_uncertainty_s` of
    /// the measurement, a bound b counted as b/√3).
    pub max_lag_uncertainty_s: f64,
    /// How Δt_max was taken: `pooled`, `largest` or `single`.
    pub max_lag_method: String,
    /// Mean lag over the segments, s.
    pub mean_lag_s: f64,
    /// Median lag over the segments, s.
    pub median_lag_s: f64,
    /// Robust spread of the segment lags (1.4826 × MAD), s.
    pub lag_spread_s: f64,
    /// Q = |K|·R²/Δt_max, pm/(N·s); given only with absolute lags (a known clock
    /// offset) and Δt_max resolved from zero (above 2 × its uncertainty). Otherwise
    /// None, with `quality_q_bound` and `quality_q_note`.
    pub quality_q_pm_per_n_s: Option<f64>,
    /// Standard uncertainty of Q from those of Δt_max and K, pm/(N·s).
    pub quality_q_uncertainty_pm_per_n_s: Option<f64>,
    /// What can be said of Q when it is not given: an upper bound (relative lags: an
    /// estimated offset absorbs any pure delay, so the true Δt_max is at least the
    /// relative one) or a lower bound (absolute Δt_max not resolved from zero), both
    /// at 2σ of Δt_max; None when nothing can be said.
    pub quality_q_bound: Option<QualityBound>,
    /// Why Q is a bound or withheld (None when Q is given).
    pub quality_q_note: Option<String>,
    /// Pure transport delay of the lag model (the shift follows the force delayed by
    /// this, on top of the SLS lag), s; relative to the clock offset.
    pub transport_delay_s: f64,
    /// K from the held levels (press-hold-release and staircase protocols): the slope
    /// of the mean shift against the mean force over the settled second half of every
    /// plateau and rest, pm/N.
    pub plateau_sensitivity_pm_per_n: Option<f64>,
    /// Its standard error, pm/N.
    pub plateau_sensitivity_std_error_pm_per_n: Option<f64>,
    /// Held levels (plateaus and rests) behind it.
    pub plateau_count: usize,
    /// Standard-linear-solid time constant τ, s (for the optimiser's lag model).
    pub sls_time_constant_s: f64,
    /// Fraction r of the response that follows the force without lag.
    pub sls_instant_fraction: f64,
    /// Drift removed from the shift, pm/s.
    pub drift_pm_per_s: f64,
    /// Residual RMS of the lag model, pm.
    pub residual_rms_pm: f64,
    /// Per pulse.
    pub pulses: Vec<PulseResult>,
}

/// The response tested against a slow variation (temperature the reference does not
/// remove, or all of it without a reference; drift): a piecewise-linear curve with
/// knots `knot_spacing_s` apart, with and without the lag-corrected force.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SlowTest {
    /// Knot spacing of the slow curve, s (at least a minute, four times the longest
    /// press, twice the presses' spacing).
    pub knot_spacing_s: f64,
    /// Knots (hat functions) of the slow curve.
    pub knots: usize,
    /// The lag model's time constant is held at or below this in the test, s (a
    /// quarter of the knot spacing): a slower "lag" is the slow variation's.
    pub tau_bound_s: f64,
    /// The fitted τ was above the bound (and the test used the bound).
    pub tau_bounded: bool,
    /// Share of what the slow curve leaves that the force explains: 1 − SSR(force and
    /// slow curve) / SSR(slow curve alone).
    pub share_beyond_slow: f64,
    /// F statistic of the force term beside the slow curve, with the effective number
    /// of independent samples.
    pub f_statistic: f64,
    /// Peak-to-peak of the slow curve fitted alone, pm.
    pub slow_variation_pm: f64,
    /// K from every row beside the slow curve (not only the loading branch), pm/N.
    pub k_all_rows_pm_per_n: f64,
}

/// How well the shift explains one press of the force.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PulseGain {
    /// The press (pulse), from 1.
    pub pulse: usize,
    /// Its start and end, s.
    pub start_s: f64,
    /// End, s.
    pub end_s: f64,
    /// Gain of the shift on K·x over the press's window: 1 explained, 0 not seen.
    pub gain: f64,
    /// Its standard error.
    pub gain_std_error: f64,
}

/// What the interrogator's own readings of one grating say about themselves.
#[derive(Debug, Clone, PartialEq, Serialize, Default)]
pub struct InstrumentCheck {
    /// The peak sits at this shift (from nominal, pm) while the force moves it on: a
    /// ceiling of the interrogator's range.
    pub pinned_at_pm: Option<f64>,
    /// Rows pinned there.
    pub pinned_rows: usize,
    /// Runs of a frozen peak (the same value repeated while the force moves it).
    pub frozen_runs: usize,
    /// Rows in those runs.
    pub frozen_rows: usize,
    /// Share of rows without a peak at high load (x above half its largest value).
    pub missing_at_load: f64,
    /// Share of rows without a peak at rest.
    pub missing_at_rest: f64,
    /// What is wrong, when something is: the grating is then not judged.
    pub fault: Option<String>,
}

/// One clock offset the search found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OffsetCandidate {
    /// Force clock − wavelength clock, s.
    pub clock_offset_s: f64,
    /// The primary grating's K at that offset (lag model, all rows), pm/N.
    pub sensitivity_pm_per_n: f64,
    /// Share of the shift beyond baseline and drift its response explains.
    pub response_r_squared: f64,
    /// Shift samples of its overlap (of the strided copy the search fits).
    pub samples: usize,
}

/// How the two clocks were aligned, and whether the alignment beats its rivals.
#[derive(Debug, Clone, PartialEq, Serialize, Default)]
pub struct AlignmentCheck {
    /// The offsets the search found, best first (the given one alone when given).
    pub candidates: Vec<OffsetCandidate>,
    /// Evidence for the best over the runner-up, Λ = n_eff·ln((1 − R²₂)/(1 − R²₁)).
    pub evidence: Option<f64>,
    /// Λ the best needs.
    pub evidence_margin: f64,
    /// Trusted presses of the force log that the wavelength log covers whole (a sine's
    /// cycles each count: a preloaded sine never returns to rest and is one pulse).
    pub presses_in_overlap: usize,
    /// Presses of the force log outside the wavelength log.
    pub force_presses_outside: usize,
    /// Presses the shift shows where the force log has no samples (start and end, s).
    pub shift_presses_outside: Vec<(f64, f64)>,
    /// Why the alignment is not definite, when it is not (an estimated offset only).
    pub ambiguous: Option<String>,
    /// The grating the presses below are read from (the primary strain grating).
    pub shift_grating: String,
    /// Presses the shift shows where the aligned force is at rest or absent (at most
    /// [`super::alignment::MAX_SHIFT_PRESSES`], the largest kept).
    pub shift_presses_at_rest: Vec<ShiftPress>,
    /// The clock offset at which the force log's presses start where those presses
    /// do, when at least [`super::alignment::MIN_PRESSES`] of them line up: the rival
    /// alignment the shift itself points to.
    pub press_match: Option<PressMatch>,
}

/// A press the shift shows where the aligned force is at rest or absent.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ShiftPress {
    /// Start and end on the wavelength log's clock, s.
    pub start_s: f64,
    pub end_s: f64,
    /// Largest departure from the rest level, signed, pm.
    pub amplitude_pm: f64,
}

/// The force log's presses moved onto the shift's presses.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PressMatch {
    /// Force clock − wavelength clock at which they line up, s.
    pub clock_offset_s: f64,
    /// Shift presses (of those at rest) that a force press then starts with.
    pub presses: usize,
    /// Shift presses at rest in all.
    pub of: usize,
}

/// A bound on Q when Q itself cannot be given.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct QualityBound {
    /// `upper` (Q ≤ value) or `lower` (Q ≥ value).
    pub kind: BoundKind,
    /// The bound, pm/(N·s).
    pub value_pm_per_n_s: f64,
}

/// Which side a bound is on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum BoundKind {
    /// The quantity is at most the value.
    Upper,
    /// The quantity is at least the value.
    Lower,
}

/// The force log's trouble spots and what was done about them.
#[derive(Debug, Clone, PartialEq, Serialize, Default)]
pub struct ForceTrust {
    /// The level the force channel saturates at, N (flat tops at a repeated maximum).
    pub saturation_n: Option<f64>,
    /// Pulses with a clipped top (numbered from 1).
    pub clipped_pulses: Vec<usize>,
    /// Pulses with a gap in the force log (numbered from 1).
    pub gapped_pulses: Vec<usize>,
    /// Gaps in the force log at rest.
    pub gaps_at_rest: usize,
    /// Pulses left out of the fits (numbered from 1).
    pub excluded_pulses: Vec<usize>,
    /// Pulses the fits use.
    pub usable_pulses: usize,
    /// Why the force log cannot be judged on (too few trusted pulses left), if so.
    pub not_judged: Option<String>,
}

/// The whole measurement.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Measurement {
    /// Wavelength log file.
    pub wavelength_log: String,
    /// Its format.
    pub wavelength_format: String,
    /// The peak estimator that made its peaks when it holds spectra (or is a peaks log
    /// naming one): `gaussian`, `parabola`, `centroid`, `xcorr`.
    pub peak_estimator: Option<String>,
    /// Rows read.
    pub wavelength_rows: usize,
    /// Median sample rate, Hz.
    pub wavelength_rate_hz: f64,
    /// Force log file.
    pub force_log: String,
    /// Force samples read.
    pub force_samples: usize,
    /// Median force sample rate, Hz.
    pub force_rate_hz: f64,
    /// Force clock − wavelength clock, s.
    pub clock_offset_s: f64,
    /// `estimated` or `given`.
    pub clock_offset_source: String,
    /// How much faster the force clock runs than the wavelength clock, ppm, from the
    /// drift of the primary grating's segment lags over the run (None with fewer than
    /// three segment lags); see [`crate::skew`].
    pub clock_skew_ppm: Option<f64>,
    /// Its standard uncertainty, ppm.
    pub clock_skew_uncertainty_ppm: Option<f64>,
    /// True when the skew stood out of its uncertainty and the force clock was warped
    /// to remove it (every figure is then of the corrected clock).
    pub clock_skew_corrected: bool,
    /// True when the clock offset was estimated: the estimate absorbs any pure delay
    /// between force and wavelength, so the lags, Δt_max and Q are relative to it, not
    /// absolute. Give the offset (`--clock-offset-s`) for absolute lags.
    pub lag_is_relative: bool,
    /// When the force log's first sample was taken, s from the wavelength log's first
    /// row (negative: the force recording started first). Easier to read than the
    /// offset when one log has wall-clock and the other relative times.
    pub force_log_start_s: f64,
    /// Duration both logs cover after alignment, s (rows of the wavelength log within
    /// the force log's span; pauses and gaps between rows not counted).
    pub overlap_s: f64,
    /// The alignment against its rivals.
    pub alignment: AlignmentCheck,
    /// Jumps of the wavelength log's clock (back: daylight saving, NTP) and long gaps.
    pub clock_jumps: Vec<crate::logs::time::ClockJump>,
    /// Rows of the wavelength log set aside: those on the other side of a jump of its
    /// clock back (another clock), file lines of the stretch used.
    pub rows_set_aside: usize,
    /// The reference grating used, if any.
    pub reference_grating: Option<String>,
    /// Interrogator resolution used, pm.
    pub interrogator_resolution_pm: f64,
    /// Pulses found in the force log.
    pub pulse_count: usize,
    /// Largest force of the trusted pulses the wavelength log covers, N.
    pub peak_force_n: f64,
    /// Saturation and gaps of the force log, and the pulses left out for them.
    pub force_trust: ForceTrust,
    /// Strain gratings of the core under test without peaks in the log (missing
    /// channels), not measured.
    pub missing_gratings: Vec<String>,
    /// Loading protocol detected in the force log: `impulse`, `press-hold-release`,
    /// `staircase`, `sine` or `mixed`.
    pub protocol: Protocol,
    /// Segments whose lag is measured (presses, cycles, ramps or steps).
    pub segment_count: usize,
    /// Bound on the error of the logs' absolute times, s: half the range the
    /// timestamps allow when they were written in whole seconds (±0.25 s at 2 Hz), 0
    /// otherwise. It enters the lags' uncertainty when the clock offset is given.
    pub timing_uncertainty_s: f64,
    /// Per grating.
    pub gratings: Vec<GratingResult>,
    /// Counted warnings of both logs and of the analysis.
    pub warnings: LogWarnings,
}

/// Time series behind the plots, on the common time base.
#[derive(Debug, Clone, Default)]
pub struct Series {
    /// Time, s from the wavelength log's start.
    pub time_s: Vec<f64>,
    /// Force resampled onto those times, N.
    pub force_n: Vec<f64>,
    /// (grating, drift-removed compensated shift, pm).
    pub shift_pm: Vec<(String, Vec<f64>)>,
    /// (grating, the static K of the table, pm/N, and the line's baseline, pm) for the fit
    /// line of the shift-against-force chart.
    pub fit: Vec<(String, f64, f64)>,
}
