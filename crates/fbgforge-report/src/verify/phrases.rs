//! The phrases every verify printer shares: Q as a value or a bound, `v ± u`, the
//! protocol, the force log's trust and the clock skew in words.

use fbgforge_verify::analysis::{BoundKind, GratingResult, Measurement};

/// Why an estimated clock offset leaves only relative lags, and what to do about it.
pub const RELATIVE_LAG_NOTE: &str = "the clock offset was estimated from the logs, and an estimated offset absorbs any pure delay between force and wavelength, so the absolute lag cannot be told from this data; give the offset between the two recorders' clocks with AnalysisOptions.clock_offset_s for absolute lags";

/// Q as a value with its uncertainty, a bound (`≤ 524.1`, `≥ 12.3`), or `—`.
pub(crate) fn q_text(g: &GratingResult, digits: usize) -> String {
    match (g.quality_q_pm_per_n_s, g.quality_q_bound) {
        (Some(_), _) => plus_minus(
            g.quality_q_pm_per_n_s,
            g.quality_q_uncertainty_pm_per_n_s,
            digits,
        ),
        (None, Some(b)) => format!(
            "{} {:.digits$}",
            match b.kind {
                BoundKind::Upper => "≤",
                BoundKind::Lower => "≥",
            },
            b.value_pm_per_n_s
        ),
        (None, None) => "—".into(),
    }
}

/// The clock skew in words, when it was estimated.
pub(crate) fn skew_line(m: &Measurement) -> Option<String> {
    let (ppm, u) = (m.clock_skew_ppm?, m.clock_skew_uncertainty_ppm?);
    Some(format!(
        "{ppm:+.1} ± {u:.1} ppm (the force clock against the wavelength clock, from the drift of the segment lags; {})",
        if m.clock_skew_corrected {
            "corrected by a linear time warp"
        } else {
            "not significant, not corrected"
        }
    ))
}

/// The force log's saturation and gaps in words, when it has any.
pub(crate) fn force_line(m: &Measurement) -> Option<String> {
    let f = &m.force_trust;
    let list = |v: &[usize]| {
        v.iter()
            .map(|k| k.to_string())
            .collect::<Vec<_>>()
            .join(", ")
    };
    let mut parts = Vec::new();
    if let Some(top) = f.saturation_n {
        parts.push(format!(
            "saturates at {top:.4} N (flat tops in pulses {})",
            list(&f.clipped_pulses)
        ));
    }
    if !f.gapped_pulses.is_empty() {
        parts.push(format!("gaps inside pulses {}", list(&f.gapped_pulses)));
    }
    if f.gaps_at_rest > 0 {
        parts.push(format!("{} gaps at rest", f.gaps_at_rest));
    }
    if parts.is_empty() {
        return None;
    }
    let what = match (&f.not_judged, f.excluded_pulses.is_empty()) {
        (Some(_), _) => "too few trusted pulses left: NOT JUDGED".to_string(),
        (None, false) => format!(
            "pulses {} left out, {} used",
            list(&f.excluded_pulses),
            f.usable_pulses
        ),
        (None, true) => "the shift there is left out".to_string(),
    };
    Some(format!("{}; {what}", parts.join(", ")))
}

/// `v ± u`, or `—` when v is missing.
pub(crate) fn plus_minus(v: Option<f64>, u: Option<f64>, digits: usize) -> String {
    match (v.filter(|x| x.is_finite()), u.filter(|x| x.is_finite())) {
        (Some(v), Some(u)) => format!("{v:.digits$} ± {u:.digits$}"),
        (Some(v), None) => format!("{v:.digits$}"),
        _ => "—".into(),
    }
}

/// The protocol, its pulses and segments, and how the lags were measured.
pub(crate) fn protocol_line(m: &Measurement) -> String {
    let timing = if m.timing_uncertainty_s > 0.0 {
        format!(
            "; timestamps uncertain by ±{:.3} s{}",
            m.timing_uncertainty_s,
            if m.lag_is_relative {
                " (absorbed by the estimated offset)"
            } else {
                " (in the lags' uncertainty)"
            }
        )
    } else {
        String::new()
    };
    format!(
        "{} ({} pulses, {} segments: lag per segment by cross-correlation, Δt_max pooled when the segments agree){timing}",
        m.protocol.name(),
        m.pulse_count,
        m.segment_count
    )
}

/// `v` with `digits` decimals, or `—` when missing.
pub(crate) fn opt(v: Option<f64>, digits: usize) -> String {
    v.filter(|x| x.is_finite())
        .map_or("—".into(), |x| format!("{x:.digits$}"))
}
