//! The force log as the analysis uses it: placed on the wavelength log's clock by the
//! prior offset (with the check that the two logs can overlap), compression positive,
//! cut into loading pulses, and resampled at the wavelength log's rows.

use super::clocks::AlignedClocks;
use super::options::AnalysisOptions;
use crate::logs::{Clock, ForceLog, LogWarnings, PeakLog};
use crate::verify::fit;
use crate::verify::segment::{percentile, Segmentation};
use anyhow::{bail, Result};

/// The force log's times on the wavelength log's clock, before the residual offset.
pub(super) struct ForceFrame {
    /// Prior for the clock offset: 0 for two wall clocks, aligned starts otherwise, s.
    pub(super) prior: f64,
    /// How far the estimated offset may lie from the prior, s.
    pub(super) range: f64,
    /// Force times in the wavelength frame, before the residual offset, s.
    pub(super) u: Vec<f64>,
    /// Force, N (compression positive).
    pub(super) fval: Vec<f64>,
    /// The span searched for the offset, s.
    pub(super) a: f64,
    pub(super) b: f64,
}

/// Place the force log on the wavelength log's clock by the prior offset, check that
/// the two logs can overlap, and turn the force compression-positive.
pub(super) fn force_frame(
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

/// Cut the force log into its loading pulses and segments, and check that the
/// wavelength log covers at least one pulse (else K would be fitted to rest alone).
pub(super) fn loading_pulses(
    (log, force): (&PeakLog, &ForceLog),
    fval: &[f64],
    fu: &[f64],
    (wa, wb): (f64, f64),
) -> Result<Segmentation> {
    let seg = crate::verify::segment::segment(&force.time_s, fval);
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

/// The force at the wavelength log's rows (the common time base), NaN outside the
/// force log.
pub(super) fn force_at_rows(tw: &[f64], clocks: &AlignedClocks, fval: &[f64]) -> Vec<f64> {
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
