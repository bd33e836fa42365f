//! The analysis assembled: the stages run in order ([`analyse`]), and the measured
//! gratings collected into the measurement (spec order, the series behind the plots,
//! the warnings their results call for).

use super::clocks::{align_clocks, span_times, timing_uncertainty_s};
use super::force::{
    check_coverage, force_at_rows, force_frame, loading_pulses, place_force_times, trusted_force,
    TrustedForce,
};
use super::gratings::{grating_shifts, GratingShifts};
use super::measure::{measure_all, Measured, MeasuredGrating};
use super::options::AnalysisOptions;
use super::quality::warn_q_undefined;
use super::results::{GratingResult, Measurement, Series};
use super::series::{plot_series, PlotGrating, Rows};
use super::{AlignedClocks, GratingContext};
use crate::logs::time::median_period;
use crate::logs::{Clock, ForceLog, LogWarnings, PeakLog};
use crate::segment::Segmentation;
use crate::skew::{self, SkewFit};
use crate::spec::Design;
use anyhow::{bail, Result};
use std::borrow::Cow;

/// Run the analysis: the stages read and aligned ([`Stages`]), every grating measured
/// on the aligned clocks, again on warped ones when a clock skew stands out, and the
/// measurement put together.
pub fn analyse(
    design: &Design,
    log: &PeakLog,
    force: &ForceLog,
    opts: &AnalysisOptions,
) -> Result<(Measurement, Series)> {
    analyse_log(
        design,
        (Cow::Borrowed(log), None),
        Cow::Borrowed(force),
        opts,
    )
}

/// [`analyse`] of logs handed over: the wavelength log's peaks are freed once assigned
/// to gratings (the table is most of a long log's memory), the two logs' times become
/// the analysis's own (shifted in place), the answers the same.
pub fn analyse_owned(
    design: &Design,
    log: PeakLog,
    force: ForceLog,
    opts: &AnalysisOptions,
) -> Result<(Measurement, Series)> {
    analyse_log(design, (Cow::Owned(log), None), Cow::Owned(force), opts)
}

/// [`analyse`] of a log whose peaks were assigned to gratings as it was read
/// ([`crate::logs::read_peak_log_assigned`] with [`super::grating_windows`]): `tracks`
/// are its gratings' tracks, the answers the same. The logs are handed over as to
/// [`analyse_owned`].
pub fn analyse_assigned(
    design: &Design,
    log: PeakLog,
    tracks: Vec<crate::logs::assign::GratingTrack>,
    force: ForceLog,
    opts: &AnalysisOptions,
) -> Result<(Measurement, Series)> {
    analyse_log(
        design,
        (Cow::Owned(log), Some(tracks)),
        Cow::Owned(force),
        opts,
    )
}

fn analyse_log(
    design: &Design,
    (log, assigned): (
        Cow<'_, PeakLog>,
        Option<Vec<crate::logs::assign::GratingTrack>>,
    ),
    force: Cow<'_, ForceLog>,
    opts: &AnalysisOptions,
) -> Result<(Measurement, Series)> {
    let Some(module) = &design.module else {
        bail!("design `{}` has no [module]: verify judges a clip-on module; for a flat array use calibrate-array", design.name);
    };
    let mut warnings = log.warnings.clone();
    warnings.merge(force.warnings.clone());
    // Rows on one clock: the stretch between jumps of the clock back that lies under
    // the force log (placed by the given offset, or on a shared wall clock), else the
    // longest.
    let (f0, f1) = (force.time_s[0], force.time_s[force.time_s.len() - 1]);
    let force_span = match opts.clock_offset_s {
        Some(o) => Some((f0 - o, f1 - o)),
        None => {
            (log.clock == Clock::Absolute && force.clock == Clock::Absolute).then_some((f0, f1))
        }
    };
    let (mut log, rows_set_aside) = match super::stretch::one_clock(&log, force_span, &mut warnings)
    {
        // The reader assigns as it reads only a log whose clock never runs back.
        Some(_) if assigned.is_some() => {
            bail!("internal: a log whose clock runs back was assigned as it was read")
        }
        Some((l, n)) => (Cow::Owned(l), n),
        None => (log, 0),
    };
    // A log handed over is assigned to the gratings here, before its times become `tw`
    // (the assignment counts its rows by them); windows the analysis refuses are left
    // for it to say why.
    let assigned = match (&log, assigned) {
        (Cow::Owned(l), None) => super::grating_windows(design, opts)
            .ok()
            .map(|w| crate::logs::assign::assign(l, &w)),
        (_, a) => a,
    };
    // What the report reads of the log's own times, taken before they become `tw`.
    let (w0, row_count, period_s) = (log.time_s[0], log.rows(), log.median_period_s());
    let tw = relative_times(&mut log, assigned.is_some());
    let force_rate_hz = 1.0 / median_period(&force.time_s);
    let (force, force_time) = force_times(force);
    let force: &ForceLog = &force;
    let shifts = grating_shifts(
        design,
        module,
        (&mut log, assigned),
        opts,
        &tw,
        &mut warnings,
    )?;
    let log: &PeakLog = &log;
    let mut st = stages(
        (design, module),
        (log, w0, force, force_time),
        opts,
        &tw,
        &shifts,
        &mut warnings,
    )?;
    let mut pass = st.measure(&st.clocks)?;
    let (skew, skew_corrected) = correct_skew(&mut st, &mut pass, &mut warnings)?;
    let Pass {
        mut first,
        mut rest,
        fc,
        row_ok,
        peak_force_n,
    } = pass;
    if skew_corrected && st.relative {
        // The offset was estimated on the skewed clock (an average alignment over the
        // fitted stretch), so the relative lags no longer sit below the true ones: the
        // upper bound on Q does not hold (it read 0.37–0.68 of the truth at ±1000 ppm).
        withhold_q_bound(&mut first.result);
        for r in rest.iter_mut().flatten() {
            withhold_q_bound(&mut r.result);
        }
    }
    let rows = Rows {
        tw: &tw,
        fc: &fc,
        row_ok: &row_ok,
    };
    let (results, series) = collect_results(first, rest, &shifts, &rows, &mut warnings)?;
    if !st.relative {
        warn_negative_lags(&results, skew.as_ref(), skew_corrected, &mut warnings);
    }
    let alignment = finish_alignment(&st, &results, peak_force_n, &mut warnings);
    let overlap_s = covered_s(&tw, (st.clocks.fa, st.clocks.fb));
    let m = Measurement {
        wavelength_log: log.source.display().to_string(),
        wavelength_format: log.format.name().into(),
        peak_estimator: log.estimator().map(str::to_string),
        wavelength_rows: row_count,
        wavelength_rate_hz: 1.0 / period_s,
        force_log: force.source.display().to_string(),
        force_samples: force.force_n.len(),
        force_rate_hz,
        clock_offset_s: st.clocks.offset,
        clock_offset_source: st.clocks.source.into(),
        clock_skew_ppm: skew.map(|s| s.ppm()),
        clock_skew_uncertainty_ppm: skew.map(|s| s.uncertainty_ppm()),
        clock_skew_corrected: skew_corrected,
        lag_is_relative: st.relative,
        force_log_start_s: st.clocks.fa,
        overlap_s,
        alignment,
        clock_jumps: log.clock_jumps.clone(),
        rows_set_aside,
        reference_grating: shifts.reference_grating.clone(),
        interrogator_resolution_pm: st.resolution_pm,
        pulse_count: st.seg.pulses.len(),
        peak_force_n,
        force_trust: st.trusted.trust,
        missing_gratings: shifts.missing.clone(),
        protocol: st.seg.protocol,
        segment_count: st.seg.segments.len(),
        timing_uncertainty_s: st.timing,
        gratings: results,
        warnings,
    };
    Ok((m, series))
}

/// The log's times from its first row, s: a log handed over with its tracks
/// (`assigned`) gives its own column, shifted in place (no second column of a long
/// log's length), and is left without times (its rows counted by `tw`).
fn relative_times(log: &mut Cow<'_, PeakLog>, assigned: bool) -> Vec<f64> {
    let w0 = log.time_s[0];
    match log {
        Cow::Owned(l) if assigned => {
            let mut t = std::mem::take(&mut l.time_s);
            for x in &mut t {
                *x -= w0;
            }
            t
        }
        _ => log.time_s.iter().map(|t| t - w0).collect(),
    }
}

/// The force log's times, for the analysis to place on the wavelength clock: a log
/// handed over gives its own column (left without times), a borrowed one a copy.
fn force_times(mut force: Cow<'_, ForceLog>) -> (Cow<'_, ForceLog>, Vec<f64>) {
    let t = match &mut force {
        Cow::Owned(f) => std::mem::take(&mut f.time_s),
        Cow::Borrowed(f) => f.time_s.clone(),
    };
    (force, t)
}

/// What every measurement pass shares: the gratings' shifts, the force on the
/// wavelength clock cut into pulses, its trusted part, the aligned clocks, the
/// resolution and the timestamps' uncertainty.
struct Stages<'a> {
    design: &'a Design,
    module: &'a crate::spec::Module,
    shifts: &'a GratingShifts<'a>,
    tw: &'a [f64],
    fval: Cow<'a, [f64]>,
    seg: Segmentation,
    trusted: TrustedForce,
    clocks: AlignedClocks,
    primary: usize,
    resolution_pm: f64,
    /// The clock offset was estimated: lags relative to it.
    relative: bool,
    timing: f64,
}

/// The stages before any grating is measured: the force on the wavelength clock (the
/// prior), cut into pulses and checked before any fit (the pulses a saturated channel
/// or a gap leaves untrusted are left out), the clocks aligned on the primary grating.
fn stages<'a>(
    (design, module): (&'a Design, &'a crate::spec::Module),
    (log, w0, force, ft): (&PeakLog, f64, &'a ForceLog, Vec<f64>),
    opts: &AnalysisOptions,
    tw: &'a [f64],
    shifts: &'a GratingShifts<'a>,
    warnings: &mut LogWarnings,
) -> Result<Stages<'a>> {
    let mut frame = force_frame((log, w0), (force, &ft), opts, tw, warnings)?;
    let mut seg = loading_pulses((force, &ft), &frame.fval)?;
    let trusted = trusted_force((force, &ft), &frame.fval, &mut seg, warnings);
    // The force log's times are read no more: they become the frame's.
    place_force_times(&mut frame, ft, w0);
    let primary = shifts.primary;
    let logs = (log, force);
    let (shift_pm, given_s) = (shifts.primary_shift_pm(), opts.clock_offset_s);
    let spans = &trusted.spans;
    let clocks = align_clocks(&mut frame, tw, &shift_pm, logs, given_s, spans, warnings)?;
    drop(shift_pm);
    check_coverage(logs, &seg, &clocks.fu, (tw[0], tw[tw.len() - 1]))?;
    let resolution_pm = opts
        .resolution_pm
        .unwrap_or_else(|| log.format.typical_resolution_pm());
    let relative = clocks.source == "estimated";
    let timing = timing_uncertainty_s(log, force, relative, warnings);
    Ok(Stages {
        design,
        module,
        shifts,
        tw,
        fval: frame.fval,
        seg,
        trusted,
        clocks,
        primary,
        resolution_pm,
        relative,
        timing,
    })
}

impl Stages<'_> {
    /// Every grating measured on one alignment of the clocks.
    fn measure(&self, clocks: &AlignedClocks) -> Result<Pass> {
        let tw = self.tw;
        let (wa, wb) = (tw[0], tw[tw.len() - 1]);
        let fc = force_at_rows(tw, clocks, &self.fval);
        let excluded_s = span_times(&clocks.fu, &self.trusted.spans);
        let row_ok = rows_outside(tw, &excluded_s);
        let sel = &self.shifts.selection;
        let ctx = GratingContext {
            module: self.module,
            strain: &sel.strain,
            tracks: &self.shifts.tracks,
            shifts: self.shifts,
            tw,
            fu: &clocks.fu,
            fval: &self.fval,
            fc: &fc,
            span: (wa.max(clocks.fa), wb.min(clocks.fb)),
            seg: &self.seg,
            resolution_pm: self.resolution_pm,
            hw: sel.hw,
            timing_s: if self.relative { 0.0 } else { self.timing },
            relative: self.relative,
            row_timing_s: self.timing,
            excluded_s: &excluded_s,
            row_ok: &row_ok,
            untrusted: &self.trusted.untrusted,
            design: self.design,
        };
        let (first, rest) = measure_all(&ctx, self.primary)?;
        let peak_force_n = fc
            .iter()
            .zip(&row_ok)
            .filter(|(f, ok)| **ok && f.is_finite())
            .fold(f64::NAN, |a, (f, _)| a.max(*f));
        Ok(Pass {
            first,
            rest,
            fc,
            row_ok,
            peak_force_n,
        })
    }
}

/// The time the wavelength log's rows cover inside the force log's span `[fa, fb]`:
/// the spacing of consecutive rows, each step at most five median periods (a pause or a
/// clock jump between rows covers nothing), s.
fn covered_s(tw: &[f64], (fa, fb): (f64, f64)) -> f64 {
    let cap = 5.0 * median_period(tw);
    tw.windows(2)
        .filter(|w| w[0] >= fa && w[1] <= fb)
        .map(|w| (w[1] - w[0]).min(cap))
        .sum()
}

/// The alignment's rivals counted once the force is cut into pulses and the primary
/// grating measured: the trusted presses inside and outside the wavelength log, the
/// presses the shift shows where the force log has none, and (for an estimated offset)
/// why the alignment is not definite.
fn finish_alignment(
    st: &Stages,
    results: &[GratingResult],
    peak_force_n: f64,
    warnings: &mut LogWarnings,
) -> super::results::AlignmentCheck {
    let mut check = st.clocks.check.clone();
    let fu = &st.clocks.fu;
    let (wa, wb) = (st.tw[0], st.tw[st.tw.len() - 1]);
    let trusted: Vec<(f64, f64)> = st
        .seg
        .pulses
        .iter()
        .enumerate()
        .filter(|(k, _)| !st.trusted.untrusted.contains(k))
        .map(|(_, p)| (fu[p.start], fu[p.end]))
        .collect();
    check.presses_in_overlap = presses_in_overlap(&st.seg, &st.trusted.untrusted, fu, (wa, wb));
    check.force_presses_outside = trusted.iter().filter(|(a, b)| *b < wa || *a > wb).count();
    let primary_shift = st.shifts.primary_shift_pm();
    let (gi, s) = (&st.shifts.used[st.primary], &*primary_shift);
    let name = &st.shifts.selection.strain[*gi].name;
    if let Some(g) = results.iter().find(|r| &r.grating == name) {
        let longest = trusted.iter().map(|(a, b)| b - a).fold(0.0, f64::max);
        check.shift_presses_outside = super::alignment::shift_presses_outside(
            st.tw,
            s,
            (st.clocks.fa, st.clocks.fb),
            (
                g.sensitivity_pm_per_n.signum(),
                g.sensitivity_pm_per_n.abs() * peak_force_n,
            ),
            (3.0 * longest).max(10.0),
        );
    }
    check.shift_grating.clone_from(name);
    let all: Vec<(f64, f64)> = st
        .seg
        .pulses
        .iter()
        .map(|p| (fu[p.start], fu[p.end]))
        .collect();
    let longest = all.iter().map(|(a, b)| b - a).fold(0.0, f64::max);
    let threshold = (10.0 * step_noise_pm(s)).max(5.0 * st.resolution_pm);
    check.shift_presses_at_rest = super::alignment::shift_presses_at_rest(
        st.tw,
        s,
        &all,
        PRESS_MARGIN_S,
        (3.0 * longest).max(10.0),
        threshold,
    );
    check.press_match = rival_by_presses(st, &check.shift_presses_at_rest, &all);
    let outside = check.shift_presses_outside.len();
    if outside > 0 {
        let (a, b) = check.shift_presses_outside[0];
        warnings.add_n("shift_presses_outside_force", outside, || {
            format!(
                "the shift shows presses where the force log has no samples (the first from {a:.2} s to {b:.2} s): the force log covers part of the run only{}",
                if st.relative { ", and an estimated clock offset may match the wrong presses" } else { "" }
            )
        });
    }
    if st.relative {
        check.ambiguous = alignment_doubt(&check);
    }
    check
}

/// The trusted presses of the force log that the wavelength log `[wa, wb]` covers
/// whole: a pulse counts once, but a pulse of sine cycles counts each cycle covered.
/// A preloaded sine never returns to rest, so its whole train is one pulse; its cycles,
/// each a rise and fall the shift must follow, pin the offset as separate presses do
/// (a rival offset a cycle away is the evidence test's to find, not the count's).
pub(super) fn presses_in_overlap(
    seg: &crate::segment::Segmentation,
    untrusted: &[usize],
    fu: &[f64],
    (wa, wb): (f64, f64),
) -> usize {
    let inside = |a: usize, b: usize| fu[a] >= wa && fu[b] <= wb;
    seg.pulses
        .iter()
        .enumerate()
        .filter(|(k, _)| !untrusted.contains(k))
        .map(|(k, p)| {
            let cycles: Vec<_> = seg
                .segments
                .iter()
                .filter(|s| s.pulse == k && s.kind == crate::segment::SegmentKind::Cycle)
                .collect();
            if cycles.is_empty() {
                usize::from(inside(p.start, p.end))
            } else {
                cycles.iter().filter(|s| inside(s.start, s.end)).count()
            }
        })
        .sum()
}

/// Rows this close to a force press count as explained by it (a lag, a slow
/// relaxation), s.
const PRESS_MARGIN_S: f64 = 5.0;

/// Standard deviation of the shift's noise from its row-to-row steps (robust to the
/// presses' few edges), pm.
fn step_noise_pm(s: &[f64]) -> f64 {
    let steps: Vec<f64> = s
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .filter(|d| d.is_finite())
        .collect();
    if steps.is_empty() {
        return 0.0;
    }
    1.4826 * crate::segment::percentile(&steps, 0.5) / std::f64::consts::SQRT_2
}

/// The clock offset at which the force log's presses (`all`, wavelength clock) start
/// where the shift's larger presses at rest start (a quarter of the largest or more).
fn rival_by_presses(
    st: &Stages,
    at_rest: &[super::results::ShiftPress],
    all: &[(f64, f64)],
) -> Option<super::results::PressMatch> {
    let largest = at_rest
        .iter()
        .map(|p| p.amplitude_pm.abs())
        .fold(0.0, f64::max);
    let big: Vec<super::results::ShiftPress> = at_rest
        .iter()
        .filter(|p| p.amplitude_pm.abs() >= 0.25 * largest)
        .copied()
        .collect();
    let starts: Vec<f64> = all.iter().map(|p| p.0).collect();
    let tol = 1.5 + 2.0 * median_period(st.tw).max(median_period(&st.clocks.fu));
    let (d, n) = super::alignment::press_match(&big, &starts, tol)?;
    Some(super::results::PressMatch {
        clock_offset_s: st.clocks.offset + d,
        presses: n,
        of: big.len(),
    })
}

/// Why an estimated clock offset is not definite, if it is not: a rival within the
/// margin, too few presses in the overlap, presses on one side the other does not
/// explain.
fn alignment_doubt(c: &super::results::AlignmentCheck) -> Option<String> {
    let mut why = Vec::new();
    if let (Some(e), Some(best), Some(rival)) =
        (c.evidence, c.candidates.first(), c.candidates.get(1))
    {
        if e < c.evidence_margin {
            why.push(format!(
                "a second clock offset, {:.3} s (K = {:.3} pm/N, R² {:.4}), fits almost as well as the best, {:.3} s (K = {:.3} pm/N, R² {:.4}): evidence Λ = {e:.1} < {}",
                rival.clock_offset_s,
                rival.sensitivity_pm_per_n,
                rival.response_r_squared,
                best.clock_offset_s,
                best.sensitivity_pm_per_n,
                best.response_r_squared,
                c.evidence_margin
            ));
        }
    }
    if c.presses_in_overlap < super::alignment::MIN_PRESSES {
        why.push(format!(
            "only {} press(es) of the force log lie in the overlap (at least {} pin an estimated offset: one or two presses fit another press as well)",
            c.presses_in_overlap,
            super::alignment::MIN_PRESSES
        ));
    }
    if c.force_presses_outside > 0 || !c.shift_presses_outside.is_empty() {
        why.push(format!(
            "presses on one side are not explained by the other ({} in the force log outside the wavelength log, {} in the shift where the force log has none)",
            c.force_presses_outside,
            c.shift_presses_outside.len()
        ));
    }
    (!why.is_empty()).then(|| {
        format!(
            "the estimated clock offset is not definite: {}; give the offset (VerifyRequest.force_start or AnalysisOptions.clock_offset_s)",
            why.join("; ")
        )
    })
}

/// Clock skew: the primary grating's segment lags drifting over the run. When it stands
/// out of its uncertainty the force clock is warped and every grating measured again
/// (`pass` and the stages' clocks replaced). The warp holds the clocks together at the
/// force log's start when the offset was given (it holds there), at the lags' mean
/// time when it was estimated. Returns the skew and whether it was corrected.
fn correct_skew(
    st: &mut Stages,
    pass: &mut Pass,
    warnings: &mut LogWarnings,
) -> Result<(Option<SkewFit>, bool)> {
    let tw = st.tw;
    let pivot = (!st.relative).then_some(st.clocks.fa);
    // An offset stuck at its search limit leaves the lags misaligned by an unknown
    // amount: their drift says nothing about the clocks' rates.
    let skew = if warnings.count("clock_offset_at_limit") > 0 {
        None
    } else {
        skew_of(&pass.first.result, pivot)
    };
    let Some(sk) = skew.filter(SkewFit::significant) else {
        return Ok((skew, false));
    };
    let warped = st.clocks.warped(&sk, (tw[0], tw[tw.len() - 1]));
    *pass = st.measure(&warped)?;
    st.clocks = warped;
    if sk.drift_over_run_s.abs() >= SKEW_WARN_DRIFT_S {
        warnings.add("clock_skew", || {
            format!(
                "the force log's clock runs {:+.1} ± {:.1} ppm against the wavelength log's: the segment lags drifted by {:+.3} s over the run; the force clock was warped to remove it (log both recorders on one PC clock, or synchronise them)",
                sk.ppm(),
                sk.uncertainty_ppm(),
                sk.drift_over_run_s
            )
        });
    }
    Ok((skew, true))
}

/// A drift of the segment lags over the run that moves them by at least this much is
/// warned about (and corrected whenever it stands out of its uncertainty), s.
pub(crate) const SKEW_WARN_DRIFT_S: f64 = 0.05;

/// One measurement of every grating on one alignment of the clocks.
struct Pass {
    first: MeasuredGrating,
    rest: Vec<Measured>,
    /// Force at the rows, N.
    fc: Vec<f64>,
    /// Rows outside the stretches left out for an untrusted force.
    row_ok: Vec<bool>,
    /// Largest trusted force at the rows, N.
    peak_force_n: f64,
}

/// Drop the upper bound on Q of relative lags measured on a skew-corrected clock.
fn withhold_q_bound(g: &mut GratingResult) {
    if g.quality_q_pm_per_n_s.is_none() {
        g.quality_q_bound = None;
        g.quality_q_note = Some(
            "the clock offset was estimated on clocks that ran at different rates (a clock skew, corrected afterwards), so the relative lags say nothing certain about the absolute ones: Q is withheld, with no bound; give the offset between the recorders' clocks (AnalysisOptions.clock_offset_s or VerifyRequest.force_start) for Q".into(),
        );
    }
}

/// Which rows lie outside every excluded stretch (`excluded`: sorted, disjoint).
fn rows_outside(tw: &[f64], excluded: &[(f64, f64)]) -> Vec<bool> {
    let mut j = 0;
    tw.iter()
        .map(|&t| {
            while j < excluded.len() && excluded[j].1 < t {
                j += 1;
            }
            !(j < excluded.len() && excluded[j].0 <= t)
        })
        .collect()
}

/// The clock skew read from a grating's segment lags (time: the middle of each
/// change of force).
fn skew_of(g: &GratingResult, pivot: Option<f64>) -> Option<SkewFit> {
    let pts: Vec<(f64, f64, f64)> = g
        .pulses
        .iter()
        .map(|p| ((p.start_s + p.end_s) / 2.0, p.lag_s, p.lag_uncertainty_s))
        .collect();
    skew::fit_skew(&pts, pivot)
}

/// Absolute lags below zero beyond their uncertainty: the shift cannot lead the force
/// in a passive part, so the clocks are wrong (offset or rate); never silent.
fn warn_negative_lags(
    results: &[GratingResult],
    skew: Option<&SkewFit>,
    corrected: bool,
    warnings: &mut LogWarnings,
) {
    for g in results {
        let neg: Vec<_> = g
            .pulses
            .iter()
            .filter(|p| p.lag_s + 3.0 * p.lag_uncertainty_s < 0.0)
            .collect();
        if let Some(p) = neg.first() {
            warnings.add_n("negative_lag", neg.len(), || {
                format!(
                    "grating `{}` segment {}: lag {:.3} ± {:.3} s: the shift leads the force, which a passive part cannot do; the clock offset (AnalysisOptions.clock_offset_s, VerifyRequest.force_start) or the clocks' rates are wrong{}",
                    g.grating,
                    p.index,
                    p.lag_s,
                    p.lag_uncertainty_s,
                    match skew {
                        Some(s) => format!(
                            " (clock skew {:+.1} ± {:.1} ppm, {})",
                            s.ppm(),
                            s.uncertainty_ppm(),
                            if corrected { "corrected" } else { "not significant, not corrected" }
                        ),
                        None => String::new(),
                    }
                )
            });
        }
    }
}

/// The measured gratings in spec order with their series (decimated to what a chart
/// shows), and the warnings their results call for.
fn collect_results(
    first: MeasuredGrating,
    rest: Vec<Measured>,
    shifts: &GratingShifts,
    rows: &Rows,
    warnings: &mut LogWarnings,
) -> Result<(Vec<GratingResult>, Series)> {
    let strain = &shifts.selection.strain;
    let mut measured = Vec::new();
    for r in std::iter::once(Ok(first)).chain(rest) {
        let m = r?;
        warn_q_undefined(&m.result, warnings);
        measured.push(m);
    }
    // Report gratings in spec order.
    let order = |name: &str| strain.iter().position(|g| g.name == name);
    measured.sort_by_key(|m| order(&m.result.grating));
    let plots: Vec<PlotGrating> = measured
        .iter()
        .map(|m| PlotGrating {
            name: m.result.grating.clone(),
            used: m.used,
            drift: m.drift,
            slope: m.slope,
            intercept: m.intercept,
        })
        .collect();
    let series = plot_series(rows, &plots, |k| shifts.shift_pm(k));
    let results: Vec<GratingResult> = measured.into_iter().map(|m| m.result).collect();
    for r in &results {
        if r.rows_ambiguous > 0 {
            warnings.add_n("ambiguous_peaks", r.rows_ambiguous, || format!("grating `{}`: rows with more than one peak in its window (the nearest to the previous value was taken)", r.grating));
        }
    }
    Ok((results, series))
}

#[cfg(test)]
mod tests {
    use super::presses_in_overlap;
    use crate::segment::{Protocol, PulseSpan, Segment, SegmentKind, Segmentation};

    fn segment(kind: SegmentKind, pulse: usize, start: usize, end: usize) -> Segment {
        Segment {
            kind,
            pulse,
            start,
            end,
            window: (start, end),
        }
    }

    #[test]
    fn a_preloaded_sine_counts_its_cycles_in_the_overlap_and_a_press_counts_once() {
        // Force samples at 1 s. Pulse 0: a preloaded sine, one pulse of five cycles of
        // 10 s (10-20, ..., 50-60); pulse 1: a press-hold-release (press and release
        // segments, 70-80); pulse 2: an impulse (90-95). The wavelength log covers
        // 25-100 s: cycles 3, 4, 5 whole, the press whole, the impulse whole -> 5.
        // Counting pulses, as before, gave 2 (the sine cut at its start not counted).
        let fu: Vec<f64> = (0..120).map(f64::from).collect();
        let seg = Segmentation {
            protocol: Protocol::Sine,
            pulses: vec![
                PulseSpan { start: 10, end: 60 },
                PulseSpan { start: 70, end: 80 },
                PulseSpan { start: 90, end: 95 },
            ],
            pulse_protocols: vec![
                Protocol::Sine,
                Protocol::PressHoldRelease,
                Protocol::Impulse,
            ],
            segments: (0..5)
                .map(|c| segment(SegmentKind::Cycle, 0, 10 + 10 * c, 20 + 10 * c))
                .chain([
                    segment(SegmentKind::Press, 1, 70, 72),
                    segment(SegmentKind::Release, 1, 78, 80),
                    segment(SegmentKind::Pulse, 2, 90, 95),
                ])
                .collect(),
            plateaus: Vec::new(),
        };
        assert_eq!(presses_in_overlap(&seg, &[], &fu, (25.0, 100.0)), 5);
        // The whole sine covered: five cycles, two presses.
        assert_eq!(presses_in_overlap(&seg, &[], &fu, (0.0, 119.0)), 7);
        // An untrusted pulse (a clipped force) does not count, cycles and all.
        assert_eq!(presses_in_overlap(&seg, &[0], &fu, (0.0, 119.0)), 2);
        // A press cut by the log's end does not count.
        assert_eq!(presses_in_overlap(&seg, &[], &fu, (65.0, 75.0)), 0);
    }
}
