//! The force log as the analysis uses it: placed on the wavelength log's clock by the
//! prior offset (with the check that the two logs can overlap), compression positive,
//! cut into loading pulses, checked for saturation and gaps (the pulses they touch
//! left out), and resampled at the wavelength log's rows.

use super::options::AnalysisOptions;
use super::results::ForceTrust;
use super::{AlignedClocks, ForceFrame};
use crate::logs::{Clock, ForceLog, LogWarnings, PeakLog};
use crate::segment::{percentile, Segmentation};
use crate::{fit, force_check};
use anyhow::{bail, Result};
use std::borrow::Cow;

/// Place the force log on the wavelength log's clock by the prior offset, check that
/// the two logs can overlap, and turn the force compression-positive (`w0`: the
/// wavelength log's first time, on its own clock, s; `ft`: the force log's times, s).
/// The frame's times are left to [`place_force_times`], once the force log's own
/// times are read no more.
pub(super) fn force_frame<'f>(
    (log, w0): (&PeakLog, f64),
    (force, ft): (&'f ForceLog, &[f64]),
    opts: &AnalysisOptions,
    tw: &[f64],
    warnings: &mut LogWarnings,
) -> Result<ForceFrame<'f>> {
    let prior = if log.clock == Clock::Absolute && force.clock == Clock::Absolute {
        0.0
    } else {
        ft[0] - w0
    };
    let range = opts.max_clock_offset_s.max(0.0);
    let (wa, wb) = (tw[0], tw[tw.len() - 1]);
    let (fa, fb) = (ft[0] - w0 - prior, ft[ft.len() - 1] - w0 - prior);
    // Where the force log lies on the wavelength clock: placed by the given offset, or
    // by the prior (the estimate may then move it by up to the range).
    let moved = opts.clock_offset_s.map_or(0.0, |o| o - prior);
    let (ga, gb) = (fa - moved, fb - moved);
    let gap = (ga - wb).max(wa - gb);
    let allowed = if opts.clock_offset_s.is_none() {
        range
    } else {
        0.0
    };
    if gap.is_nan() || gap > allowed {
        bail!(
            "the force log {} (covering {:.3} s to {:.3} s on the wavelength log's clock{}) does not overlap the wavelength log {} (0 s to {:.3} s){}",
            force.source.display(),
            ga,
            gb,
            match opts.clock_offset_s {
                Some(o) => format!(", placed by the given clock offset {o} s (AnalysisOptions.clock_offset_s or VerifyRequest.force_start)"),
                None if prior != 0.0 => ", starts aligned".to_string(),
                None => String::new(),
            },
            log.source.display(),
            wb,
            if opts.clock_offset_s.is_none() { format!(", even allowing ±{range} s of clock offset (AnalysisOptions.max_clock_offset_s)") } else { String::new() }
        );
    }
    Ok(ForceFrame {
        prior,
        range,
        u: Vec::new(),
        fval: compression_positive(force, warnings),
        a: wa.max(fa - range).max(wa),
        b: wb.min(fb + range),
    })
}

/// The frame's force times: the force log's times `ft` on the wavelength clock by the
/// prior offset (`w0`: the wavelength log's first time), shifted in place (no second
/// column of the force log's length).
pub(super) fn place_force_times(frame: &mut ForceFrame, mut ft: Vec<f64>, w0: f64) {
    for t in &mut ft {
        *t = *t - w0 - frame.prior;
    }
    frame.u = ft;
}

/// The force with compression positive: some stands log compression as negative
/// force; if the force's excursions go down rather than up, flip it (and say so) so
/// that pulses are peaks.
fn compression_positive<'f>(force: &'f ForceLog, warnings: &mut LogWarnings) -> Cow<'f, [f64]> {
    // Some stands log compression as negative force: if the force's excursions go
    // down rather than up, flip it (and say so) so that pulses are peaks. The
    // excursions are measured from the rest level: the quieter end of the log (a
    // preloaded protocol spends most of its time away from rest, so the median is no
    // rest level: it flipped a preloaded sine).
    // A channel saturated at one extreme names the compression side first: a load
    // cell saturates under load, and a preload held at its ceiling would otherwise
    // pass for the rest level (a clipped preloaded sine was flipped, and read as
    // silent).
    let rest = rest_level(&force.force_n);
    let flip = match force_check::saturated_side(&force.force_n) {
        Some(top) => !top,
        None => {
            (percentile(&force.force_n, 0.001) - rest).abs()
                > (percentile(&force.force_n, 0.999) - rest).abs()
        }
    };
    if flip {
        warnings.add("force_sign_flipped", || {
            format!(
                "{}: the force pulses go negative (compression logged as negative); the force was negated",
                force.source.display()
            )
        });
        Cow::Owned(force.force_n.iter().map(|f| -f).collect())
    } else {
        Cow::Borrowed(&force.force_n)
    }
}

/// The force's resting level: the median of whichever end of the log (its first or
/// last 2 %, at least 5 samples) varies least, a stand at rest before and after the
/// presses (the median of the whole log, when it is too short for ends).
fn rest_level(f: &[f64]) -> f64 {
    let n = f.len();
    let m = (n / 50).max(5);
    if n < 4 * m {
        return percentile(f, 0.5);
    }
    let spread = |s: &[f64]| percentile(s, 0.9) - percentile(s, 0.1);
    let (head, tail) = (&f[..m], &f[n - m..]);
    if spread(head) <= spread(tail) {
        percentile(head, 0.5)
    } else {
        percentile(tail, 0.5)
    }
}

/// Cut the force log into its loading pulses and segments (force clock, before any
/// alignment; `ft`: the force log's times).
pub(super) fn loading_pulses(
    (force, ft): (&ForceLog, &[f64]),
    fval: &[f64],
) -> Result<Segmentation> {
    let seg = crate::segment::segment(ft, fval);
    if seg.pulses.is_empty() {
        bail!(
            "{}: no loading pulse found in the force log (the force never rises clearly above its resting level): nothing to fit",
            force.source.display()
        );
    }
    Ok(seg)
}

/// The force log's trusted part: saturation and gaps found ([`force_check`]), the
/// force-sample spans left out of the fits, and what the report says of them.
pub(super) struct TrustedForce {
    /// Force-sample index spans (inclusive) left out of the fits.
    pub(super) spans: Vec<(usize, usize)>,
    /// Pulses left out (indices from 0).
    pub(super) untrusted: Vec<usize>,
    /// For the report.
    pub(super) trust: ForceTrust,
}

/// Check the force log for saturation and gaps, warn, and decide what is left out: the
/// untrusted pulses, or nothing (and the run not judged) when fewer than
/// [`force_check::MIN_USABLE_PULSES`] trusted pulses would be left.
pub(super) fn trusted_force(
    (force, t): (&ForceLog, &[f64]),
    fval: &[f64],
    seg: &mut Segmentation,
    warnings: &mut LogWarnings,
) -> TrustedForce {
    let c = force_check::check(t, fval, seg);
    let file = force.source.display();
    let untrusted = c.untrusted_pulses();
    let total = seg.pulses.len();
    let usable = total - untrusted.len();
    let enough = untrusted.is_empty() || usable >= force_check::MIN_USABLE_PULSES;
    let left_out = if enough {
        "they are left out of the fits"
    } else {
        "too few pulses are left without them, so K is not judged"
    };
    if let (Some(top), false) = (c.saturation_n, c.clipped.is_empty()) {
        let longest = c.clipped.iter().map(|p| p.flat_s).fold(0.0, f64::max);
        warnings.add_n("force_clipped", c.clipped.len(), || {
            format!(
                "{file}: the force channel saturates at {top:.4} N: {} of {total} pulses have flat tops at that repeated maximum (up to {longest:.2} s, the noise collapsed there), so their true peak force is unknown; {left_out}",
                c.clipped.len()
            )
        });
    }
    for g in &c.gaps {
        let (a, b) = (t[g.before], t[(g.before + 1).min(t.len() - 1)]);
        match g.pulse {
            Some(k) => warnings.add("force_gap_in_press", || {
                format!(
                    "{file}: the force log has no samples for {:.3} s ({a:.3} s to {b:.3} s of its clock) inside press {}: the press's shape there is unknown (interpolating it bends K); {left_out}",
                    g.length_s,
                    k + 1
                )
            }),
            None => warnings.add("force_gap", || {
                format!(
                    "{file}: the force log has no samples for {:.3} s ({a:.3} s to {b:.3} s of its clock) at rest; the shift there is left out of the fits",
                    g.length_s
                )
            }),
        }
    }
    let spans = if enough {
        c.excluded_spans(t, seg)
    } else {
        Vec::new()
    };
    if enough && !untrusted.is_empty() {
        // The protocol is the class of the pulses that are measured.
        seg.protocol = crate::segment::protocol_of(
            &seg.pulse_protocols
                .iter()
                .enumerate()
                .filter(|(k, _)| !untrusted.contains(k))
                .map(|(_, p)| *p)
                .collect::<Vec<_>>(),
        );
    }
    let number = |v: &[usize]| v.iter().map(|k| k + 1).collect::<Vec<_>>();
    let not_judged = (!enough).then(|| {
        let mut why = Vec::new();
        if let Some(top) = c.saturation_n {
            why.push(format!(
                "the force channel saturates at {top:.4} N in {} of the {total} pulses (flat tops at a repeated maximum)",
                c.clipped.len()
            ));
        }
        let gapped = c.gaps.iter().filter(|g| g.pulse.is_some()).count();
        if gapped > 0 {
            why.push(format!("{gapped} gaps in the force log fall inside presses"));
        }
        format!(
            "{}: only {usable} of {total} pulses have a trusted force (at least {} are needed), so K cannot be judged; the K shown is fitted to the untrusted force (keep the peak force within the load cell's range, or log without gaps)",
            why.join(" and "),
            force_check::MIN_USABLE_PULSES
        )
    });
    TrustedForce {
        trust: ForceTrust {
            saturation_n: c.saturation_n,
            clipped_pulses: number(&c.clipped.iter().map(|p| p.pulse).collect::<Vec<_>>()),
            gapped_pulses: number(&c.gaps.iter().filter_map(|g| g.pulse).collect::<Vec<_>>()),
            gaps_at_rest: c.gaps.iter().filter(|g| g.pulse.is_none()).count(),
            excluded_pulses: if enough {
                number(&untrusted)
            } else {
                Vec::new()
            },
            usable_pulses: if enough { usable } else { total },
            not_judged,
        },
        untrusted: if enough { untrusted } else { Vec::new() },
        spans,
    }
}

/// Check that the wavelength log covers at least one pulse (else K would be fitted to
/// rest alone).
pub(super) fn check_coverage(
    (log, force): (&PeakLog, &ForceLog),
    seg: &Segmentation,
    fu: &[f64],
    (wa, wb): (f64, f64),
) -> Result<()> {
    let pulses = &seg.pulses;
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
    Ok(())
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
