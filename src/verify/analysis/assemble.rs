//! The analysis assembled: the stages run in order ([`analyse`]), and the measured
//! gratings collected into the measurement (spec order, the series behind the plots,
//! the warnings their results call for).

use super::clocks::{align_clocks, timing_uncertainty_s};
use super::force::{force_at_rows, force_frame, loading_pulses};
use super::gratings::{grating_shifts, primary_grating};
use super::measure::{measure_all, GratingContext, Measured};
use super::options::AnalysisOptions;
use super::quality::warn_q_undefined;
use super::results::{GratingResult, Measurement, Series};
use crate::logs::{median_period, ForceLog, LogWarnings, PeakLog};
use crate::spec::Design;
use anyhow::{bail, Result};

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
        warn_q_undefined(&res, warnings);
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
