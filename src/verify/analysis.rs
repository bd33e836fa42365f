//! The analysis of one verification run: alignment of the two clocks, the lag model,
//! loading pulses, and the figures of merit per grating.
//!
//! Frames: every time in the results is in seconds from the first row of the
//! wavelength log, on the wavelength log's clock. The clock offset is
//! `force clock − wavelength clock` for the same instant.
//!
//! Steps (see `docs/verify.md` for the reasoning):
//! 1. peaks → gratings by window, temperature removed with the reference grating;
//! 2. clock offset: cross-correlation of the force with the largest shift gives a
//!    coarse value (offset minus the response's lag), then the lag model
//!    ([`super::fit`]) is fitted jointly with the offset, first on a decimated copy of
//!    the whole overlap, then at full rate on its first stretch;
//! 3. per grating: the lag model with the offset fixed gives K (static sensitivity,
//!    with its standard error), τ and r; baseline and linear drift are removed;
//! 4. the force is resampled onto the wavelength log's times (the common time base),
//!    and Δλ against F gives the linear slope, R², hysteresis and non-linearity;
//! 5. pulses are found in the force log; per pulse the peak force, the peak shift and
//!    the lag between the two peaks (vertices of parabolas through the top 5 %).

use super::assign::{self, GratingTrack, GratingWindow};
use super::fit::{self, LagModelCost, LagModelFit};
use super::lag;
pub use super::segment::{detect_pulses, percentile, PulseSpan};
use super::segment::{Protocol, SegmentKind, Segmentation};
use crate::logs::{median_period, Clock, ForceLog, LogWarnings, PeakLog};
use crate::spec::{Design, GratingRole};
use anyhow::{bail, Result};
use rayon::prelude::*;
use serde::Serialize;

/// Options of the analysis.
#[derive(Debug, Clone)]
pub struct AnalysisOptions {
    /// Analyse only the strain gratings of this core (all present ones otherwise).
    pub core: Option<String>,
    /// Half-width of the wavelength windows, nm (default: see [`assign`]).
    pub window_half_width_nm: Option<f64>,
    /// A known clock offset (force clock − wavelength clock), s; estimated if None.
    pub clock_offset_s: Option<f64>,
    /// How far the estimated offset may lie from the prior (0 for two wall clocks,
    /// aligned starts otherwise), s.
    pub max_clock_offset_s: f64,
    /// Interrogator resolution, pm (default: typical for the log format).
    pub resolution_pm: Option<f64>,
}

impl Default for AnalysisOptions {
    fn default() -> Self {
        AnalysisOptions {
            core: None,
            window_half_width_nm: None,
            clock_offset_s: None,
            max_clock_offset_s: 60.0,
            resolution_pm: None,
        }
    }
}

/// One segment of the loading (a press, a cycle, a ramp or a step; see
/// [`super::segment`]) as seen by one grating. The JSON keeps the name `pulses` for
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
    /// Static sensitivity K from the lag model (the one compared with the model), pm/N.
    pub sensitivity_pm_per_n: f64,
    /// Standard error of K (white-noise assumption), pm/N.
    pub sensitivity_std_error_pm_per_n: f64,
    /// Lag-1 autocorrelation of the straight-line residuals: near 1 when the residual
    /// wanders slowly (drift, an unrelated signal), which makes the samples far from
    /// independent.
    pub residual_autocorrelation: f64,
    /// Effective number of independent samples, n (1 − ρ) / (1 + ρ).
    pub effective_samples: f64,
    /// Standard error of K allowing for the autocorrelated residuals:
    /// `sensitivity_std_error_pm_per_n` × √(n / n_eff), pm/N.
    pub sensitivity_std_error_effective_pm_per_n: f64,
    /// Largest peak force of the pulses, N.
    pub peak_force_n: f64,
    /// Slope of a straight line through Δλ against F (no lag model), pm/N.
    pub linear_slope_pm_per_n: f64,
    /// R² of that straight line.
    pub r_squared: f64,
    /// R² of the lag model.
    pub lag_model_r_squared: f64,
    /// Largest gap between loading and unloading branches, % of full-scale output.
    pub hysteresis_percent_span: f64,
    /// Largest deviation of the bin means from the straight line, % of full-scale output.
    pub nonlinearity_percent_span: f64,
    /// Smallest resolvable force: interrogator resolution / |K|, N.
    pub resolution_n: f64,
    /// The same in grams-force, g.
    pub resolution_g: f64,
    /// Δt_max, s: the weighted mean of the segment lags when they agree within their
    /// uncertainties (`max_lag_method` = `pooled`), else the largest (`largest`); see
    /// [`super::lag`].
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
    /// Q = |K|·R²/Δt_max, pm/(N·s); None when Δt_max is not resolved from zero
    /// (Δt_max ≤ 2 × its uncertainty).
    pub quality_q_pm_per_n_s: Option<f64>,
    /// Standard uncertainty of Q from those of Δt_max and K, pm/(N·s).
    pub quality_q_uncertainty_pm_per_n_s: Option<f64>,
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

/// The whole measurement.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Measurement {
    /// Wavelength log file.
    pub wavelength_log: String,
    /// Its format.
    pub wavelength_format: String,
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
    /// True when the clock offset was estimated: the estimate absorbs any pure delay
    /// between force and wavelength, so the lags, Δt_max and Q are relative to it, not
    /// absolute. Give the offset (`--clock-offset-s`) for absolute lags.
    pub lag_is_relative: bool,
    /// When the force log's first sample was taken, s from the wavelength log's first
    /// row (negative: the force recording started first). Easier to read than the
    /// offset when one log has wall-clock and the other relative times.
    pub force_log_start_s: f64,
    /// Duration both logs cover after alignment, s.
    pub overlap_s: f64,
    /// The reference grating used, if any.
    pub reference_grating: Option<String>,
    /// Interrogator resolution used, pm.
    pub interrogator_resolution_pm: f64,
    /// Pulses found in the force log.
    pub pulse_count: usize,
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

/// Strided copy of the samples inside [a, b] for fitting.
struct FitData {
    st: Vec<f64>,
    sv: Vec<f64>,
    ft: Vec<f64>,
    fv: Vec<f64>,
    t_mid: f64,
}

impl FitData {
    /// Shift samples (tw, s) inside [a, b], strided to at most `max_wl`; force samples
    /// (u, f) over the same span plus `memory_s` before and after, strided to at most
    /// `max_force`.
    #[allow(clippy::too_many_arguments)]
    fn new(
        tw: &[f64],
        s: &[f64],
        u: &[f64],
        f: &[f64],
        a: f64,
        b: f64,
        max_wl: usize,
        max_force: usize,
        memory_s: f64,
    ) -> Self {
        let idx: Vec<usize> = (0..tw.len())
            .filter(|&i| tw[i] >= a && tw[i] <= b && s[i].is_finite())
            .collect();
        let stride = idx.len().div_ceil(max_wl.max(1)).max(1);
        let st: Vec<f64> = idx.iter().step_by(stride).map(|&i| tw[i]).collect();
        let sv: Vec<f64> = idx.iter().step_by(stride).map(|&i| s[i]).collect();
        let lo = u.partition_point(|&x| x < a - memory_s).saturating_sub(1);
        let hi = (u.partition_point(|&x| x <= b + memory_s) + 1).min(u.len());
        let n = hi.saturating_sub(lo);
        let fs = n.div_ceil(max_force.max(1)).max(1);
        let ft: Vec<f64> = (lo..hi).step_by(fs).map(|i| u[i]).collect();
        let fv: Vec<f64> = (lo..hi).step_by(fs).map(|i| f[i]).collect();
        let t_mid = if st.is_empty() {
            0.0
        } else {
            (st[0] + st[st.len() - 1]) / 2.0
        };
        FitData {
            st,
            sv,
            ft,
            fv,
            t_mid,
        }
    }

    fn cost(&self, fixed: Option<f64>) -> LagModelCost<'_> {
        LagModelCost {
            shift_t: &self.st,
            shift_pm: &self.sv,
            force_t: &self.ft,
            force_n: &self.fv,
            fixed_offset_s: fixed,
            offset_range_s: None,
            t_mid: self.t_mid,
        }
    }

    /// The cost with the clocks aligned and a transport delay of at most `max_delay_s`
    /// free (parameters: −delay, ln τ, logit r).
    fn cost_with_delay(&self, max_delay_s: f64) -> LagModelCost<'_> {
        LagModelCost {
            offset_range_s: Some((-max_delay_s, max_delay_s)),
            ..self.cost(None)
        }
    }
}

/// Coarse offset by cross-correlation: the shift lag Δ (in the force frame u) that
/// maximises |corr(s(t), F(t + Δ))| over |Δ| ≤ range. Returns (Δ, sign of corr).
fn xcorr_offset(
    tw: &[f64],
    s: &[f64],
    u: &[f64],
    f: &[f64],
    a: f64,
    b: f64,
    range: f64,
) -> Option<(f64, f64)> {
    let dt_s = median_period(tw);
    let dt_f = median_period(u);
    let g = dt_s
        .max(dt_f)
        .max((b - a) / 20000.0)
        .max(2.0 * range / 4000.0);
    if g.is_nan() || g <= 0.0 || b <= a {
        return None;
    }
    let n = ((b - a) / g).floor() as usize + 1;
    // Shift on the grid (gaps bridged).
    let filled = assign::fill_gaps(tw, s);
    let mut h = 0;
    let sg: Vec<f64> = (0..n)
        .map(|j| fit::interp(tw, &filled, a + j as f64 * g, &mut h))
        .collect();
    let f0 = a - range;
    let nf = ((b + range - f0) / g).floor() as usize + 2;
    let mut h = 0;
    let fg: Vec<f64> = (0..nf)
        .map(|j| fit::interp(u, f, f0 + j as f64 * g, &mut h))
        .collect();
    let ms = sg.iter().sum::<f64>() / n as f64;
    let mf = fg.iter().sum::<f64>() / nf as f64;
    let lags = (range / g).floor() as isize;
    let mut best = (0.0, 0.0f64, 1.0);
    for l in -lags..=lags {
        let off = (range / g).round() as isize + l;
        let mut acc = 0.0;
        for (j, sv) in sg.iter().enumerate() {
            let k = j as isize + off;
            if k >= 0 && (k as usize) < nf {
                acc += (sv - ms) * (fg[k as usize] - mf);
            }
        }
        if acc.abs() > best.1.abs() {
            best = (l as f64 * g, acc, acc.signum());
        }
    }
    Some((best.0, best.2))
}

/// The gratings a verification reads: the strain gratings (of one core, if asked),
/// the temperature reference, and their wavelength windows.
struct GratingSelection<'a> {
    strain: Vec<&'a crate::spec::ModuleGrating>,
    reference: Option<&'a crate::spec::ModuleGrating>,
    windows: Vec<GratingWindow>,
    /// Window half-width, nm.
    hw: f64,
}

/// Check the core asked for, and pick the gratings and their wavelength windows.
fn select_gratings<'a>(
    design: &Design,
    module: &'a crate::spec::Module,
    opts: &AnalysisOptions,
) -> Result<GratingSelection<'a>> {
    if let Some(c) = &opts.core {
        if !module.cores.iter().any(|x| &x.name == c) {
            let names: Vec<&str> = module.cores.iter().map(|c| c.name.as_str()).collect();
            bail!(
                "design `{}` has no core named `{c}`; its cores are: {}",
                design.name,
                names.join(", ")
            );
        }
    }
    let all_nominals: Vec<f64> = module
        .gratings
        .iter()
        .map(|g| g.bragg_wavelength_nm)
        .collect();
    let hw = opts
        .window_half_width_nm
        .unwrap_or_else(|| assign::default_half_width_nm(&all_nominals));
    if hw.is_nan() || hw <= 0.0 {
        bail!("the window half-width must be positive, got {hw} nm");
    }
    let strain: Vec<_> = module
        .gratings
        .iter()
        .filter(|g| g.role == GratingRole::Strain && (opts.core.is_none() || g.core == opts.core))
        .collect();
    let reference = module.gratings.iter().find(|g| {
        g.role == GratingRole::TemperatureReference
            && (g.core.is_none() || opts.core.is_none() || g.core == opts.core)
    });
    let mut windows: Vec<GratingWindow> = strain
        .iter()
        .map(|g| GratingWindow::new(&g.name, g.bragg_wavelength_nm, hw))
        .collect();
    if let Some(r) = reference {
        windows.push(GratingWindow::new(&r.name, r.bragg_wavelength_nm, hw));
    }
    Ok(GratingSelection {
        strain,
        reference,
        windows,
        hw,
    })
}

/// The strain gratings' shifts: peaks assigned to gratings, temperature removed.
struct GratingShifts<'a> {
    selection: GratingSelection<'a>,
    tracks: Vec<GratingTrack>,
    /// The reference grating used, if any.
    reference_grating: Option<String>,
    /// (strain grating index, compensated shift in pm per row) of each grating used.
    used: Vec<(usize, Vec<f64>)>,
}

/// Assign the peaks to the gratings and remove temperature with the reference grating.
fn grating_shifts<'a>(
    design: &Design,
    module: &'a crate::spec::Module,
    log: &PeakLog,
    opts: &AnalysisOptions,
    tw: &[f64],
    warnings: &mut LogWarnings,
) -> Result<GratingShifts<'a>> {
    let selection = select_gratings(design, module, opts)?;
    let tracks = assign::assign(log, &selection.windows);
    let tracked = Tracked {
        design,
        log,
        tracks: &tracks,
        min_rows: (log.rows() / 10).max(2),
        hw: selection.hw,
    };
    let ref_track = reference_track(&tracked, selection.reference, tw, warnings);
    let core_named = opts.core.is_some();
    let used = strain_shifts(
        &tracked,
        &selection.strain,
        ref_track.as_ref(),
        core_named,
        warnings,
    )?;
    let reference_grating = ref_track.as_ref().map(|(t, _)| t.window.name.clone());
    Ok(GratingShifts {
        selection,
        tracks,
        reference_grating,
        used,
    })
}

/// The force log's times on the wavelength log's clock, before the residual offset.
struct ForceFrame {
    /// Prior for the clock offset: 0 for two wall clocks, aligned starts otherwise, s.
    prior: f64,
    /// How far the estimated offset may lie from the prior, s.
    range: f64,
    /// Force times in the wavelength frame, before the residual offset, s.
    u: Vec<f64>,
    /// Force, N (compression positive).
    fval: Vec<f64>,
    /// The span searched for the offset, s.
    a: f64,
    b: f64,
}

/// Place the force log on the wavelength log's clock by the prior offset, check that
/// the two logs can overlap, and turn the force compression-positive.
fn force_frame(
    log: &PeakLog,
    force: &ForceLog,
    opts: &AnalysisOptions,
    tw: &[f64],
    warnings: &mut LogWarnings,
) -> Result<ForceFrame> {
    let w0 = log.time_s[0];
    let prior = if log.clock == Clock::Absolute && force.clock == Clock::Absolute {
        0.0
    } else {
        force.time_s[0] - w0
    };
    let range = opts.max_clock_offset_s.max(0.0);
    let u: Vec<f64> = force.time_s.iter().map(|t| t - w0 - prior).collect();
    let (wa, wb) = (tw[0], tw[tw.len() - 1]);
    let (fa, fb) = (u[0], u[u.len() - 1]);
    let gap = (fa - wb).max(wa - fb);
    if opts.clock_offset_s.is_none() && gap > range
        || opts
            .clock_offset_s
            .is_some_and(|o| fa - (o - prior) > wb || fb - (o - prior) < wa)
    {
        bail!(
            "the force log {} (covering {:.3} s to {:.3} s on the wavelength log's clock{}) does not overlap the wavelength log {} (0 s to {:.3} s){}",
            force.source.display(),
            fa,
            fb,
            if prior != 0.0 { ", starts aligned" } else { "" },
            log.source.display(),
            wb,
            if opts.clock_offset_s.is_none() { format!(", even allowing ±{range} s of clock offset (--max-offset-s)") } else { String::new() }
        );
    }
    Ok(ForceFrame {
        prior,
        range,
        u,
        fval: compression_positive(force, warnings),
        a: wa.max(fa - range).max(wa),
        b: wb.min(fb + range),
    })
}

/// The primary grating: the one with the largest response.
fn primary_grating(used: &[(usize, Vec<f64>)]) -> usize {
    let spread = |s: &[f64]| percentile(s, 0.98) - percentile(s, 0.02);
    (0..used.len())
        .max_by(|&x, &y| spread(&used[x].1).total_cmp(&spread(&used[y].1)))
        .unwrap_or(0)
}

/// The two clocks aligned.
struct AlignedClocks {
    /// Force clock − wavelength clock, s.
    offset: f64,
    /// `estimated` or `given`.
    source: &'static str,
    /// Force log times on the wavelength clock, s.
    fu: Vec<f64>,
    /// First and last force time on the wavelength clock, s.
    fa: f64,
    fb: f64,
    /// Duration both logs cover, s.
    overlap: f64,
}

/// Take the given clock offset or estimate it, and check the aligned logs overlap.
fn align_clocks(
    frame: &ForceFrame,
    tw: &[f64],
    shift_pm: &[f64],
    (log, force): (&PeakLog, &ForceLog),
    given_s: Option<f64>,
    warnings: &mut LogWarnings,
) -> Result<AlignedClocks> {
    let prior = frame.prior;
    let (delta, source) = match given_s {
        Some(o) => (o - prior, "given"),
        None => {
            let al = Alignment {
                tw,
                shift_pm,
                u: &frame.u,
                fval: &frame.fval,
                a: frame.a,
                b: frame.b,
                range: frame.range,
            };
            (estimate_clock_offset(&al, warnings)?, "estimated")
        }
    };
    let offset = prior + delta;
    let fu: Vec<f64> = frame.u.iter().map(|x| x - delta).collect();
    let (wa, wb) = (tw[0], tw[tw.len() - 1]);
    let (fa, fb) = (fu[0], fu[fu.len() - 1]);
    let overlap = (wb.min(fb) - wa.max(fa)).max(0.0);
    let min_len = (wb - wa).min(fb - fa);
    if overlap < 0.25 * min_len || overlap <= 0.0 {
        bail!(
            "after aligning the clocks (offset {offset:.3} s) the force log {} and the wavelength log {} overlap for only {overlap:.3} s",
            force.source.display(),
            log.source.display()
        );
    }
    Ok(AlignedClocks {
        offset,
        source,
        fu,
        fa,
        fb,
        overlap,
    })
}

/// The force at the wavelength log's rows (the common time base), NaN outside the
/// force log.
fn force_at_rows(tw: &[f64], clocks: &AlignedClocks, fval: &[f64]) -> Vec<f64> {
    let mut h = 0;
    tw.iter()
        .map(|&t| {
            if t < clocks.fa || t > clocks.fb {
                f64::NAN
            } else {
                fit::interp(&clocks.fu, fval, t, &mut h)
            }
        })
        .collect()
}

/// Cut the force log into its loading pulses and segments, and check that the
/// wavelength log covers at least one pulse (else K would be fitted to rest alone).
fn loading_pulses(
    (log, force): (&PeakLog, &ForceLog),
    fval: &[f64],
    fu: &[f64],
    (wa, wb): (f64, f64),
) -> Result<Segmentation> {
    let seg = super::segment::segment(&force.time_s, fval);
    let pulses = &seg.pulses;
    if pulses.is_empty() {
        bail!(
            "{}: no loading pulse found in the force log (the force never rises clearly above its resting level): nothing to fit",
            force.source.display()
        );
    }
    if !pulses.iter().any(|p| fu[p.start] < wb && fu[p.end] > wa) {
        bail!(
            "the wavelength log {} (0 s to {wb:.3} s) covers none of the {} loading pulses of the force log {} ({:.3} s to {:.3} s on the wavelength log's clock): nothing to fit",
            log.source.display(),
            pulses.len(),
            force.source.display(),
            fu[pulses[0].start],
            fu[pulses[pulses.len() - 1].end]
        );
    }
    Ok(seg)
}

/// The logs' timing uncertainty, s, with a warning when a given offset carries it into
/// the lags (whole-second timestamps leave each log's absolute times uncertain; an
/// estimated offset absorbs it).
fn timing_uncertainty_s(
    log: &PeakLog,
    force: &ForceLog,
    relative: bool,
    warnings: &mut LogWarnings,
) -> f64 {
    let timing = log.time_uncertainty_s.hypot(force.time_uncertainty_s);
    if timing > 0.0 && !relative {
        warnings.add("timing_uncertain", || {
            format!(
                "timestamps written in whole seconds leave the absolute time of each sample uncertain by up to ±{timing:.3} s; the lags, Δt_max and Q carry that uncertainty (a log with sub-second timestamps removes it)"
            )
        });
    }
    timing
}

/// Measure every grating: the primary first (its τ and r seed the others), the rest
/// in parallel.
#[allow(clippy::type_complexity)]
fn measure_all(
    ctx: &GratingContext,
    primary: usize,
) -> Result<((GratingResult, Vec<f64>, f64, f64), Vec<Measured>)> {
    let first = measure_grating(ctx, primary, None)?;
    let seed = Some((
        first.0.transport_delay_s,
        first.0.sls_time_constant_s,
        first.0.sls_instant_fraction,
    ));
    let rest: Vec<Measured> = (0..ctx.used.len())
        .filter(|&k| k != primary)
        .collect::<Vec<_>>()
        .par_iter()
        .map(|&k| measure_grating(ctx, k, seed))
        .collect();
    Ok((first, rest))
}

/// Run the analysis.
pub fn analyse(
    design: &Design,
    log: &PeakLog,
    force: &ForceLog,
    opts: &AnalysisOptions,
) -> Result<(Measurement, Series)> {
    let Some(module) = &design.module else {
        bail!("design `{}` has no [module]: verify judges a clip-on module; for a flat array use calibrate-array", design.name);
    };
    let mut warnings = log.warnings.clone();
    warnings.merge(force.warnings.clone());
    let tw: Vec<f64> = log.time_s.iter().map(|t| t - log.time_s[0]).collect();
    let shifts = grating_shifts(design, module, log, opts, &tw, &mut warnings)?;
    let (sel, used) = (&shifts.selection, &shifts.used);
    // Clocks aligned on the primary grating, the force on the common time base.
    let frame = force_frame(log, force, opts, &tw, &mut warnings)?;
    let fval = &frame.fval;
    let primary = primary_grating(used);
    let logs = (log, force);
    let (shift_pm, given_s) = (&used[primary].1, opts.clock_offset_s);
    let clocks = align_clocks(&frame, &tw, shift_pm, logs, given_s, &mut warnings)?;
    let fc = force_at_rows(&tw, &clocks, fval);
    let resolution_pm = opts
        .resolution_pm
        .unwrap_or_else(|| log.format.typical_resolution_pm());
    let (wa, wb) = (tw[0], tw[tw.len() - 1]);
    let seg = loading_pulses(logs, fval, &clocks.fu, (wa, wb))?;
    let relative = clocks.source == "estimated";
    let timing = timing_uncertainty_s(log, force, relative, &mut warnings);
    // Per grating.
    let ctx = GratingContext {
        module,
        strain: &sel.strain,
        tracks: &shifts.tracks,
        used,
        tw: &tw,
        fu: &clocks.fu,
        fval,
        fc: &fc,
        span: (wa.max(clocks.fa), wb.min(clocks.fb)),
        seg: &seg,
        resolution_pm,
        hw: sel.hw,
        timing_s: if relative { 0.0 } else { timing },
    };
    let (first, rest) = measure_all(&ctx, primary)?;
    let (results, series) = collect_results(first, rest, &sel.strain, &tw, &fc, &mut warnings)?;
    let m = Measurement {
        wavelength_log: log.source.display().to_string(),
        wavelength_format: log.format.name().into(),
        wavelength_rows: log.rows(),
        wavelength_rate_hz: 1.0 / log.median_period_s(),
        force_log: force.source.display().to_string(),
        force_samples: force.force_n.len(),
        force_rate_hz: 1.0 / median_period(&force.time_s),
        clock_offset_s: clocks.offset,
        clock_offset_source: clocks.source.into(),
        lag_is_relative: relative,
        force_log_start_s: clocks.fa,
        overlap_s: clocks.overlap,
        reference_grating: shifts.reference_grating,
        interrogator_resolution_pm: resolution_pm,
        pulse_count: seg.pulses.len(),
        protocol: seg.protocol,
        segment_count: seg.segments.len(),
        timing_uncertainty_s: timing,
        gratings: results,
        warnings,
    };
    Ok((m, series))
}

/// What the grating tracks of a verification were read from and how.
struct Tracked<'a> {
    design: &'a Design,
    log: &'a PeakLog,
    tracks: &'a [GratingTrack],
    /// Fewest rows with a peak for a grating to count as present.
    min_rows: usize,
    /// Window half-width, nm.
    hw: f64,
}

/// The temperature-reference grating's track (the last one) with its gaps filled, or
/// `None` with a warning when the design has none or its peaks are too few.
fn reference_track<'a>(
    tr: &Tracked<'a>,
    reference: Option<&crate::spec::ModuleGrating>,
    tw: &[f64],
    warnings: &mut LogWarnings,
) -> Option<(&'a GratingTrack, Vec<f64>)> {
    let (design, log, tracks, min_rows, hw) = (tr.design, tr.log, tr.tracks, tr.min_rows, tr.hw);
    match reference {
        Some(r) => {
            let t = tracks.last().filter(|t| t.window.name == r.name);
            match t {
                Some(t) if t.rows_present >= min_rows => {
                    Some((t, assign::fill_gaps(tw, &t.wavelength_nm)))
                }
                _ => {
                    warnings.add("reference_missing", || {
                        format!(
                            "{}: the temperature-reference grating `{}` ({} ± {hw:.3} nm) has too few peaks; shifts are NOT temperature compensated",
                            log.source.display(),
                            r.name,
                            r.bragg_wavelength_nm
                        )
                    });
                    None
                }
            }
        }
        None => {
            warnings.add("reference_missing", || {
                format!(
                    "design `{}` has no temperature-reference grating; shifts are not compensated",
                    design.name
                )
            });
            None
        }
    }
}

/// The temperature-compensated shift of every strain grating present in the log, by
/// index into `strain`; a missing grating is a warning (an error when a core was named).
fn strain_shifts(
    tr: &Tracked,
    strain: &[&crate::spec::ModuleGrating],
    ref_track: Option<&(&GratingTrack, Vec<f64>)>,
    core_named: bool,
    warnings: &mut LogWarnings,
) -> Result<Vec<(usize, Vec<f64>)>> {
    let (log, tracks, min_rows, hw) = (tr.log, tr.tracks, tr.min_rows, tr.hw);
    let rows = log.rows();
    // A core none of whose gratings appears is not the core under test (a module is
    // tested with one core plugged in): its gratings are not missing, just absent.
    let present = |i: usize| tracks[i].rows_present >= min_rows;
    let core_in_log = |core: &Option<String>| {
        strain
            .iter()
            .enumerate()
            .any(|(i, g)| &g.core == core && present(i))
    };
    let mut used: Vec<(usize, Vec<f64>)> = Vec::new();
    for (i, g) in strain.iter().enumerate() {
        let t = &tracks[i];
        if !present(i) && !core_named && !core_in_log(&g.core) {
            continue;
        }
        if t.rows_present < min_rows {
            let msg = format!(
                "{}: grating `{}` ({} ± {hw:.3} nm) has a peak in only {} of {rows} rows: is its channel connected? (--window-nm widens the window)",
                log.source.display(),
                g.name,
                g.bragg_wavelength_nm,
                t.rows_present
            );
            if core_named {
                bail!("{msg}");
            }
            warnings.add("grating_missing", || msg);
            continue;
        }
        // A peak that leaves its window under load is dropped, and the fit then sees
        // only the low-force part of each pulse: K and R² come out biased low.
        let missing = rows - t.rows_present;
        if missing * 50 > rows {
            warnings.add_n("peaks_outside_window", missing, || {
                format!(
                    "{}: grating `{}` has no peak in its window {} ± {hw:.3} nm in {missing} of {rows} rows; if they gather at high force the shift leaves the window and K is biased low (--window-nm widens it)",
                    log.source.display(),
                    g.name,
                    g.bragg_wavelength_nm
                )
            });
        }
        let s = assign::compensated_shift_pm(t, ref_track.map(|(t, f)| (*t, f.as_slice())));
        used.push((i, s));
    }
    if used.is_empty() {
        bail!("{}: none of the design's strain gratings has peaks in the log (windows ± {hw:.3} nm around their nominal wavelengths)", log.source.display());
    }
    Ok(used)
}

/// The force with compression positive: some stands log compression as negative
/// force; if the force's excursions go down rather than up, flip it (and say so) so
/// that pulses are peaks.
fn compression_positive(force: &ForceLog, warnings: &mut LogWarnings) -> Vec<f64> {
    // Some stands log compression as negative force: if the force's excursions go
    // down rather than up, flip it (and say so) so that pulses are peaks.
    let med = percentile(&force.force_n, 0.5);
    let flip = (percentile(&force.force_n, 0.001) - med).abs()
        > (percentile(&force.force_n, 0.999) - med).abs();
    if flip {
        warnings.add("force_sign_flipped", || {
            format!(
                "{}: the force pulses go negative (compression logged as negative); the force was negated",
                force.source.display()
            )
        });
        force.force_n.iter().map(|f| -f).collect()
    } else {
        force.force_n.clone()
    }
}

/// The measured gratings in spec order with their series, and the warnings their
/// results call for.
fn collect_results(
    first: (GratingResult, Vec<f64>, f64, f64),
    rest: Vec<Measured>,
    strain: &[&crate::spec::ModuleGrating],
    tw: &[f64],
    fc: &[f64],
    warnings: &mut LogWarnings,
) -> Result<(Vec<GratingResult>, Series)> {
    let mut series = Series {
        time_s: tw.to_vec(),
        force_n: fc.to_vec(),
        ..Default::default()
    };
    let mut results = Vec::new();
    for r in std::iter::once(Ok(first)).chain(rest) {
        let (res, d, slope, intercept) = r?;
        if res.quality_q_pm_per_n_s.is_none() {
            warnings.add("q_undefined", || {
                format!(
                    "grating `{}`: Δt_max = {:.4} ± {:.4} s is not resolved from zero (it must exceed twice its uncertainty): Q = |K|R²/Δt_max is undefined{}",
                    res.grating,
                    res.max_lag_s,
                    res.max_lag_uncertainty_s,
                    if res.max_lag_s > 0.0 {
                        format!(
                            "; Q > {:.3} pm/(N·s) at 2σ",
                            res.sensitivity_pm_per_n.abs() * res.r_squared
                                / (res.max_lag_s + 2.0 * res.max_lag_uncertainty_s)
                        )
                    } else {
                        String::new()
                    }
                )
            });
        }
        series.shift_pm.push((res.grating.clone(), d));
        series.fit.push((res.grating.clone(), slope, intercept));
        results.push(res);
    }
    // Report gratings in spec order.
    results.sort_by_key(|r| strain.iter().position(|g| g.name == r.grating));
    series
        .shift_pm
        .sort_by_key(|(n, _)| strain.iter().position(|g| &g.name == n));
    series
        .fit
        .sort_by_key(|(n, _, _)| strain.iter().position(|g| &g.name == n));
    for r in &results {
        if r.rows_ambiguous > 0 {
            warnings.add_n("ambiguous_peaks", r.rows_ambiguous, || format!("grating `{}`: rows with more than one peak in its window (the nearest to the previous value was taken)", r.grating));
        }
    }
    Ok((results, series))
}

/// The logs' time bases for estimating the clock offset: the wavelength log's times
/// `tw` and a strain grating's shifts, the force log's times `u` (wavelength frame,
/// before the residual offset) and forces, the usable span [a, b] and the search range.
struct Alignment<'a> {
    tw: &'a [f64],
    shift_pm: &'a [f64],
    u: &'a [f64],
    fval: &'a [f64],
    a: f64,
    b: f64,
    range: f64,
}

/// Estimate the residual clock offset: cross-correlation for a start, then the lag
/// model fitted with the offset free, coarse then at full rate.
fn estimate_clock_offset(al: &Alignment, warnings: &mut LogWarnings) -> Result<f64> {
    let (tw, s, u, fval, a, b, range) = (al.tw, al.shift_pm, al.u, al.fval, al.a, al.b, al.range);
    let (dx, _) = xcorr_offset(tw, s, u, fval, a, b, range)
        .ok_or_else(|| anyhow::anyhow!("the logs overlap too little to align their clocks"))?;
    let coarse = FitData::new(tw, s, u, fval, a, b, 20_000, 50_000, 30.0);
    let mut best: (Vec<f64>, f64) = (vec![dx, 0.0, 0.0], f64::MAX);
    let tries: Vec<(Vec<f64>, f64)> = [0.05f64, 0.5, 5.0]
        .par_iter()
        .map(|&tau0| {
            let start = [dx + 0.5 * tau0, tau0.ln(), 0.0];
            let step = [(0.2 * tau0).max(2.0 * median_period(&coarse.st)), 1.0, 1.5];
            fit::nelder_mead(coarse.cost(None), &start, &step, 300)
        })
        .collect();
    for r in tries {
        if r.1 < best.1 {
            best = r;
        }
    }
    // Polish at full rate on the first stretch of the overlap.
    let span = (b - a)
        .min(100_000.0 * median_period(u).max(1e-6))
        .min(50_000.0 * median_period(tw).max(1e-6));
    let fine = FitData::new(tw, s, u, fval, a, a + span.max(1.0), 50_000, 100_000, 30.0);
    let p = best.0.clone();
    let step = [
        2.0 * median_period(&fine.st).max(median_period(&fine.ft)),
        0.3,
        0.5,
    ];
    let r = fit::nelder_mead(fine.cost(None), &p, &step, 300);
    let d = if r.1 < f64::MAX { r.0[0] } else { p[0] };
    if (d.abs() - range).abs() < 1e-9 || d.abs() > range {
        warnings.add("clock_offset_at_limit", || format!("the estimated clock offset reached the search limit ±{range} s; widen it with --max-offset-s or give --clock-offset-s"));
    }
    // The search range is a bound the user set: the polished fit may not leave it.
    Ok(d.clamp(-range, range))
}

/// Measurement of one grating in a verification: what every grating shares.
struct GratingContext<'a> {
    module: &'a crate::spec::Module,
    strain: &'a [&'a crate::spec::ModuleGrating],
    tracks: &'a [GratingTrack],
    used: &'a [(usize, Vec<f64>)],
    /// Wavelength log times, s from its first row.
    tw: &'a [f64],
    /// Force log times, aligned to the wavelength clock, s.
    fu: &'a [f64],
    /// Force, N (compression positive).
    fval: &'a [f64],
    /// Force at the wavelength log's rows, N (NaN outside the force log).
    fc: &'a [f64],
    /// Time span both logs cover, s.
    span: (f64, f64),
    /// The force log's protocol and segments (force-sample indices).
    seg: &'a Segmentation,
    resolution_pm: f64,
    /// Window half-width, nm.
    hw: f64,
    /// Timing uncertainty carried into absolute lags (0 when the lags are relative), s.
    timing_s: f64,
}

/// A measured grating, its drift-free shift series and its straight-line fit.
type Measured = Result<(GratingResult, Vec<f64>, f64, f64)>;

/// Fit the lag model to one grating's shift `s` with the clocks aligned: delay, τ and
/// r searched on a strided copy of the overlap (from `prev`'s values, or three time
/// constants for the first grating), then evaluated on every sample.
fn fit_lag_model(
    ctx: &GratingContext,
    s: &[f64],
    name: &str,
    prev: Option<(f64, f64, f64)>,
) -> Result<LagModelFit> {
    let (tw, fu, fval, fc) = (ctx.tw, ctx.fu, ctx.fval, ctx.fc);
    let (span_a, span_b) = ctx.span;
    let sub = FitData::new(tw, s, fu, fval, span_a, span_b, 20_000, 50_000, 30.0);
    let max_delay = max_transport_delay_s(ctx);
    let mut best: (Vec<f64>, f64) = (vec![0.0, 0.0, 0.0], f64::MAX);
    // The first grating searches from three time constants; the others from its
    // solution and from a short lag without delay (their dynamics are usually alike).
    let starts: Vec<(f64, f64, f64)> = match prev {
        None => vec![(0.0, 0.05, 0.5), (0.0, 0.5, 0.5), (0.0, 5.0, 0.5)],
        Some(p) => vec![p, (0.0, 0.05, 0.5)],
    };
    let step_delay = (2.0 * median_period(&sub.st)).max(0.25).min(max_delay);
    let tries: Vec<(Vec<f64>, f64)> = starts
        .par_iter()
        .map(|&(d0, tau0, r0)| {
            let r0 = r0.clamp(1e-6, 1.0 - 1e-6);
            let start = [-d0, tau0.max(fit::TAU_MIN_S).ln(), (r0 / (1.0 - r0)).ln()];
            let cost = sub.cost_with_delay(max_delay);
            fit::nelder_mead(cost, &start, &[step_delay, 1.0, 1.5], 300)
        })
        .collect();
    for r in tries {
        if r.1 < best.1 {
            best = r;
        }
    }
    let probe = sub.cost_with_delay(max_delay);
    let lm0 = probe
        .fit_at(&best.0)
        .ok_or_else(|| anyhow::anyhow!("the lag model could not be fitted for grating `{name}`"))?;
    // Final evaluation on every sample (NaN shifts and samples outside the force
    // log are skipped inside the cost).
    let n_used = (0..tw.len())
        .filter(|&i| s[i].is_finite() && fc[i].is_finite())
        .count();
    if n_used < 10 {
        bail!(
            "grating `{name}` has only {n_used} samples where the force log overlaps the wavelength log"
        );
    }
    let full = LagModelCost {
        shift_t: tw,
        shift_pm: s,
        force_t: fu,
        force_n: fval,
        fixed_offset_s: Some(0.0),
        offset_range_s: None,
        t_mid: (span_a + span_b) / 2.0,
    };
    Ok(full
        .evaluate(lm0.offset_s, lm0.tau_s, lm0.instant_fraction)
        .unwrap_or(lm0))
}

/// The shift with the lag model's baseline and drift removed, NaN outside the force log.
fn drift_free_shift(ctx: &GratingContext, s: &[f64], lm: &LagModelFit) -> Vec<f64> {
    let (tw, fc) = (ctx.tw, ctx.fc);
    let t_mid = (ctx.span.0 + ctx.span.1) / 2.0;
    (0..tw.len())
        .map(|i| {
            if fc[i].is_finite() {
                s[i] - lm.baseline_pm - lm.drift_pm_per_s * (tw[i] - t_mid)
            } else {
                f64::NAN
            }
        })
        .collect()
}

/// A grating's lags: per segment, and summarised.
struct LagFigures {
    /// Per segment, with the systematic allowance in each uncertainty.
    pulses: Vec<PulseResult>,
    summary: Option<lag::LagSummary>,
    mean_lag_s: f64,
    /// Δt_max and its uncertainty (timing included), s.
    max_lag_s: f64,
    max_lag_uncertainty_s: f64,
}

/// Measure the lag of every segment and summarise them. A segment seen in a few
/// samples is fitted nearly exactly, so 2 % of the sample period (0.01 s at 2 Hz) is
/// allowed on top of the noise.
fn lag_figures(ctx: &GratingContext, d: &[f64], lm: &LagModelFit, delay: f64) -> LagFigures {
    let mut pres = segment_lags(ctx, d, lm, delay);
    let systematic = 0.02 * median_period(ctx.tw);
    let lags: Vec<(f64, f64)> = pres
        .iter()
        .map(|p| (p.lag_s, p.lag_uncertainty_s))
        .collect();
    let summary = lag::summarise(&lags, systematic);
    for p in &mut pres {
        p.lag_uncertainty_s = p.lag_uncertainty_s.hypot(systematic);
    }
    let mean_lag_s = if pres.is_empty() {
        f64::NAN
    } else {
        pres.iter().map(|p| p.lag_s).sum::<f64>() / pres.len() as f64
    };
    let (max_lag_s, max_lag_uncertainty_s) = summary.map_or((f64::NAN, f64::NAN), |s| {
        // The timing bound is the half-width of a uniform error: its standard
        // uncertainty is bound/√3.
        (
            s.max_lag_s,
            s.max_lag_uncertainty_s.hypot(ctx.timing_s / 3f64.sqrt()),
        )
    });
    LagFigures {
        pulses: pres,
        summary,
        mean_lag_s,
        max_lag_s,
        max_lag_uncertainty_s,
    }
}

/// Q = |K|·R²/Δt_max and its uncertainty, when Δt_max is clearly above zero.
fn quality_q(k: f64, se_k: f64, r_squared: f64, lags: &LagFigures) -> (Option<f64>, Option<f64>) {
    let (max_lag, max_lag_u) = (lags.max_lag_s, lags.max_lag_uncertainty_s);
    if max_lag > 2.0 * max_lag_u && max_lag > 0.0 {
        let q = k.abs() * r_squared / max_lag;
        (
            Some(q),
            Some(q * (max_lag_u / max_lag).hypot(se_k / k.abs())),
        )
    } else {
        (None, None)
    }
}

/// The intercept of the chart's line of slope `k` through the centre of the data, so
/// that the plot and the table never show two numbers (`fallback` without data).
fn chart_intercept(fc: &[f64], d: &[f64], k: f64, fallback: f64) -> f64 {
    let (sum, count) = fc
        .iter()
        .zip(d)
        .filter(|(f, v)| f.is_finite() && v.is_finite())
        .fold((0.0, 0usize), |(s, n), (f, v)| (s + v - k * f, n + 1));
    if count > 0 {
        sum / count as f64
    } else {
        fallback
    }
}

/// Fit the lag model, the straight line and the per-segment lags of `used[k]`; `prev`
/// seeds the delay, τ and r from an already measured grating.
fn measure_grating(ctx: &GratingContext, k: usize, prev: Option<(f64, f64, f64)>) -> Measured {
    let (gi, s) = &ctx.used[k];
    let g = ctx.strain[*gi];
    let t = &ctx.tracks[*gi];
    let fc = ctx.fc;
    let lm = fit_lag_model(ctx, s, &g.name, prev)?;
    let delay = -lm.offset_s;
    let d = drift_free_shift(ctx, s, &lm);
    let line = fit::fit_line(fc, &d).ok_or_else(|| {
        anyhow::anyhow!(
            "grating `{}`: the force does not vary; no line can be fitted",
            g.name
        )
    })?;
    let (hyst, nonlin) = hysteresis_and_linearity(fc, &d, &line);
    let (rho, n, n_eff) = residual_independence(fc, &d, line.slope, line.intercept);
    let k = lm.k_pm_per_n;
    let lags = lag_figures(ctx, &d, &lm, delay);
    let se_k_eff = lm.k_std_error_pm_per_n * (n as f64 / n_eff).sqrt();
    let (q, q_u) = quality_q(k, se_k_eff, line.r_squared, &lags);
    let plateau = plateau_sensitivity(ctx, &d);
    let summary = lags.summary;
    let result = GratingResult {
        grating: g.name.clone(),
        core: g.core.clone(),
        core_material: g
            .core
            .as_ref()
            .and_then(|c| ctx.module.cores.iter().find(|x| &x.name == c))
            .map(|c| c.material.clone()),
        nominal_nm: g.bragg_wavelength_nm,
        window_half_width_nm: ctx.hw,
        rows_with_peak: t.rows_present,
        rows_ambiguous: t.rows_ambiguous,
        sensitivity_pm_per_n: k,
        sensitivity_std_error_pm_per_n: lm.k_std_error_pm_per_n,
        residual_autocorrelation: rho,
        effective_samples: n_eff,
        sensitivity_std_error_effective_pm_per_n: se_k_eff,
        peak_force_n: lags
            .pulses
            .iter()
            .map(|p| p.peak_force_n)
            .fold(f64::NAN, f64::max),
        linear_slope_pm_per_n: line.slope,
        r_squared: line.r_squared,
        lag_model_r_squared: lm.r_squared,
        hysteresis_percent_span: hyst,
        nonlinearity_percent_span: nonlin,
        resolution_n: ctx.resolution_pm / k.abs(),
        resolution_g: ctx.resolution_pm / k.abs() / 9.80665e-3,
        max_lag_s: lags.max_lag_s,
        max_lag_uncertainty_s: lags.max_lag_uncertainty_s,
        max_lag_method: summary.map_or("none", |s| s.max_lag_method).into(),
        mean_lag_s: lags.mean_lag_s,
        median_lag_s: summary.map_or(f64::NAN, |s| s.median_lag_s),
        lag_spread_s: summary.map_or(f64::NAN, |s| s.lag_spread_s),
        quality_q_pm_per_n_s: q,
        quality_q_uncertainty_pm_per_n_s: q_u,
        transport_delay_s: delay,
        plateau_sensitivity_pm_per_n: plateau.map(|p| p.0),
        plateau_sensitivity_std_error_pm_per_n: plateau.map(|p| p.1),
        plateau_count: plateau.map_or(0, |p| p.2),
        sls_time_constant_s: lm.tau_s,
        sls_instant_fraction: lm.instant_fraction,
        drift_pm_per_s: lm.drift_pm_per_s,
        residual_rms_pm: lm.rms_pm,
        pulses: lags.pulses,
    };
    // The chart draws the table's K (the lag model's static sensitivity).
    let intercept = chart_intercept(fc, &d, k, line.intercept);
    Ok((result, d, k, intercept))
}

/// Lag-1 autocorrelation ρ of the straight-line residuals over consecutive samples
/// where both force and shift exist, the number n of such samples and the effective
/// number of independent ones, n (1 − ρ) / (1 + ρ) (an AR(1) reading of the residual;
/// at least 2, at most n).
fn residual_independence(
    force: &[f64],
    shift: &[f64],
    slope: f64,
    intercept: f64,
) -> (f64, usize, f64) {
    let r: Vec<f64> = force
        .iter()
        .zip(shift)
        .map(|(f, s)| s - (slope * f + intercept))
        .collect();
    let (mut num, mut den, mut n) = (0.0, 0.0, 0usize);
    for (i, v) in r.iter().enumerate() {
        if !v.is_finite() {
            continue;
        }
        n += 1;
        den += v * v;
        if let Some(next) = r.get(i + 1).filter(|x| x.is_finite()) {
            num += v * next;
        }
    }
    let rho = if den > 0.0 {
        (num / den).clamp(-1.0, 1.0)
    } else {
        0.0
    };
    let n_eff = (n as f64 * (1.0 - rho) / (1.0 + rho)).clamp(2.0_f64.min(n as f64), n as f64);
    (rho, n, n_eff)
}

/// Largest transport delay a grating's fit may take: a quarter of the median spacing
/// of the segments (beyond it a delay would match the next segment), at least 1 s.
fn max_transport_delay_s(ctx: &GratingContext) -> f64 {
    let mut starts: Vec<f64> = ctx.seg.segments.iter().map(|s| ctx.fu[s.start]).collect();
    starts.sort_by(f64::total_cmp);
    let mut gaps: Vec<f64> = starts.windows(2).map(|w| w[1] - w[0]).collect();
    gaps.sort_by(f64::total_cmp);
    gaps.get(gaps.len() / 2)
        .map_or(1.0, |g| (0.25 * g).max(1.0))
}

/// Per segment that the wavelength log covers whole: the lag of the drift-free shift
/// `d` behind the force by sub-sample cross-correlation over the segment's window
/// ([`lag::segment_lag`]), and for presses and cycles the peak times (vertices of
/// parabolas through the top 5 %).
fn segment_lags(
    ctx: &GratingContext,
    d: &[f64],
    lm: &LagModelFit,
    delay_s: f64,
) -> Vec<PulseResult> {
    let (tw, fu, fval) = (ctx.tw, ctx.fu, ctx.fval);
    let sign = if lm.k_pm_per_n < 0.0 { -1.0 } else { 1.0 };
    let model_lag_s = delay_s.abs() + (1.0 - lm.instant_fraction) * lm.tau_s;
    // The fitted lag model's response on the force log's own grid: the shape the
    // data are matched against. Both come from the force smoothed over ±0.05 s (a
    // symmetric average moves no edge): the force noise the model response carries
    // along would otherwise pull the model's own lag towards its delay.
    let m = ((0.05 / median_period(fu).max(1e-9)).round() as usize).min(50);
    let fval = &super::segment::moving_average(fval, m)[..];
    let mut y = Vec::new();
    fit::sls_response(fu, fval, lm.tau_s, lm.instant_fraction, &mut y);
    let mut h = 0;
    let model: Vec<f64> = fu
        .iter()
        .map(|&t| fit::interp(fu, &y, t - delay_s, &mut h))
        .collect();
    let (first, last) = (tw[0], tw[tw.len() - 1]);
    let mut pres = Vec::new();
    for s in &ctx.seg.segments {
        let (t_start, t_end) = (fu[s.start], fu[s.end]);
        if t_start < first || t_end > last {
            continue;
        }
        let window = (fu[s.window.0], fu[s.window.1]);
        // The model's lag behind the force in this window, in continuous time (both
        // at the force log's rate, noise-free) ...
        let range = lag::search_range_s(window, model_lag_s);
        // The force and the model over the window and the search range, at most
        // 4 000 samples (both are smooth): every scan step then costs the window's
        // samples, not a walk through a kHz log.
        let lo = fu
            .partition_point(|&x| x < window.0 - range)
            .saturating_sub(1);
        let hi = (fu.partition_point(|&x| x <= window.1 + range) + 1).min(fu.len());
        let stride = (hi - lo).div_ceil(4000).max(1);
        let lt: Vec<f64> = fu[lo..hi].iter().step_by(stride).copied().collect();
        let lf: Vec<f64> = fval[lo..hi].iter().step_by(stride).copied().collect();
        let lm_: Vec<f64> = model[lo..hi].iter().step_by(stride).copied().collect();
        let Some(lm_lag) = lag::segment_lag(&lt, &lm_, &lt, &lf, window, range, 1.0) else {
            continue;
        };
        // ... and how late the data run behind the model here, with its uncertainty:
        // matched against the model's shape, not the force's, the estimate does not
        // depend on where the samples fall (the force's shape gave 0.19 s for a
        // 0.125 s lag at 2 Hz).
        let Some(l) = lag::segment_lag(tw, d, &lt, &lm_, window, range, sign) else {
            continue;
        };
        if l.at_limit
            || lm_lag.at_limit
            || !l.uncertainty_s.is_finite()
            || l.r_squared < lag::MIN_SEGMENT_R_SQUARED
        {
            continue;
        }
        let l = lag::SegmentLag {
            lag_s: lm_lag.lag_s + l.lag_s,
            ..l
        };
        let wf = &fval[s.window.0..=s.window.1];
        let peak_force = wf.iter().copied().fold(f64::NAN, f64::max);
        let (mut tf, mut ts, mut ps) = (f64::NAN, f64::NAN, f64::NAN);
        if matches!(s.kind, SegmentKind::Pulse | SegmentKind::Cycle) {
            let seg_t = &fu[s.start..=s.end];
            let seg_f = &fval[s.start..=s.end];
            let base = seg_f
                .iter()
                .copied()
                .fold(f64::INFINITY, f64::min)
                .min(wf[0]);
            let im = (0..seg_f.len())
                .max_by(|&x, &y| seg_f[x].total_cmp(&seg_f[y]))
                .unwrap_or(0);
            tf = fit::peak_vertex(seg_t, seg_f, im, base + 0.95 * (seg_f[im] - base)).0;
            let i0 = tw.partition_point(|&x| x < window.0);
            let i1 = tw.partition_point(|&x| x <= window.1);
            let seg_d: Vec<f64> = d[i0..i1].iter().map(|v| sign * v).collect();
            if let Some(jm) = (0..seg_d.len())
                .filter(|&j| seg_d[j].is_finite())
                .max_by(|&x, &y| seg_d[x].total_cmp(&seg_d[y]))
            {
                let (a, b) = fit::peak_vertex(&tw[i0..i1], &seg_d, jm, 0.95 * seg_d[jm]);
                (ts, ps) = (a, sign * b);
            }
        }
        pres.push(PulseResult {
            index: pres.len() + 1,
            pulse: s.pulse + 1,
            kind: s.kind,
            start_s: t_start,
            end_s: t_end,
            peak_force_n: peak_force,
            peak_force_time_s: tf,
            peak_shift_pm: ps,
            peak_shift_time_s: ts,
            lag_s: l.lag_s,
            lag_uncertainty_s: l.uncertainty_s,
        });
    }
    pres
}

/// K from the held levels: (slope, its standard error, levels used) of the mean
/// drift-free shift against the mean force over the second half of every plateau and
/// rest; None unless the protocol holds levels inside its pulses and at least three
/// levels are covered by the wavelength log.
fn plateau_sensitivity(ctx: &GratingContext, d: &[f64]) -> Option<(f64, f64, usize)> {
    if !ctx.seg.plateaus.iter().any(|p| !p.rest) {
        return None;
    }
    let (tw, fu, fc) = (ctx.tw, ctx.fu, ctx.fc);
    let mut mf = Vec::new();
    let mut md = Vec::new();
    for p in &ctx.seg.plateaus {
        let (a, b) = (fu[p.start], fu[p.end]);
        let settled = (a + b) / 2.0;
        let i0 = tw.partition_point(|&x| x < settled);
        let i1 = tw.partition_point(|&x| x <= b);
        let (mut sf, mut sd, mut n) = (0.0, 0.0, 0usize);
        for i in i0..i1 {
            if fc[i].is_finite() && d[i].is_finite() {
                sf += fc[i];
                sd += d[i];
                n += 1;
            }
        }
        if n > 0 {
            mf.push(sf / n as f64);
            md.push(sd / n as f64);
        }
    }
    if mf.len() < 3 {
        return None;
    }
    let line = fit::fit_line(&mf, &md)?;
    Some((line.slope, line.slope_std_error, mf.len()))
}

/// Hysteresis and non-linearity, % of the full-scale output |slope|·(F_max − F_min):
/// samples are binned by force (20 bins); hysteresis is the largest difference between
/// the mean shift while loading (force rising) and unloading in one bin, non-linearity
/// the largest distance of a bin's mean from the fitted line (both from residuals
/// about the line).
pub fn hysteresis_and_linearity(force: &[f64], shift: &[f64], line: &fit::LineFit) -> (f64, f64) {
    let n = force.len();
    if n < 5 {
        return (f64::NAN, f64::NAN);
    }
    let (fmin, fmax) = force
        .iter()
        .filter(|f| f.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &f| {
            (lo.min(f), hi.max(f))
        });
    let span = line.slope.abs() * (fmax - fmin);
    if span.is_nan() || span <= 0.0 {
        return (f64::NAN, f64::NAN);
    }
    const BINS: usize = 20;
    let mut acc = [[0.0f64; 6]; BINS]; // sum_load, n_load, sum_unload, n_unload, sum_all, n_all
    for i in 1..n - 1 {
        let b = (((force[i] - fmin) / (fmax - fmin)) * BINS as f64)
            .floor()
            .clamp(0.0, (BINS - 1) as f64) as usize;
        // Residuals from the line, so that samples spread across a bin compare fairly.
        let res = shift[i] - (line.intercept + line.slope * force[i]);
        let df = force[i + 1] - force[i - 1];
        if !res.is_finite() || !df.is_finite() {
            continue;
        }
        if df > 0.0 {
            acc[b][0] += res;
            acc[b][1] += 1.0;
        } else if df < 0.0 {
            acc[b][2] += res;
            acc[b][3] += 1.0;
        }
        acc[b][4] += res;
        acc[b][5] += 1.0;
    }
    let (mut hyst, mut lin) = (0.0f64, 0.0f64);
    for a in acc.iter() {
        if a[1] >= 3.0 && a[3] >= 3.0 {
            hyst = hyst.max((a[0] / a[1] - a[2] / a[3]).abs());
        }
        if a[5] >= 3.0 {
            lin = lin.max((a[4] / a[5]).abs());
        }
    }
    (100.0 * hyst / span, 100.0 * lin / span)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_straight_reversible_response_has_no_hysteresis() {
        let f: Vec<f64> = (0..400)
            .map(|i| 10.0 * (1.0 - (i as f64 * 0.05).cos()))
            .collect();
        let s: Vec<f64> = f.iter().map(|x| 3.0 * x).collect();
        let line = fit::fit_line(&f, &s).unwrap();
        let (h, l) = hysteresis_and_linearity(&f, &s, &line);
        assert!(h < 1e-9 && l < 1e-9, "{h} {l}");
        // A response that lags shows up as hysteresis.
        let s2: Vec<f64> = (0..400)
            .map(|i| 30.0 * (1.0 - (i as f64 * 0.05 - 0.3).cos()))
            .collect();
        let line2 = fit::fit_line(&f, &s2).unwrap();
        assert!(hysteresis_and_linearity(&f, &s2, &line2).0 > 5.0);
    }
}
