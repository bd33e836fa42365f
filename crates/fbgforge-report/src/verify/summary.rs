//! The short printed report of a verification (`fbgforge verify` without `--json`).

use super::phrases::{
    force_line, opt, plus_minus, protocol_line, q_text, skew_line, RELATIVE_LAG_NOTE,
};
use fbgforge_verify::VerifyReport;
use std::fmt::Write as _;

/// The short printed report: the logs and clocks, the table of gratings, the notes,
/// the warnings and the verdict.
pub fn summary(r: &VerifyReport) -> String {
    let mut s = String::new();
    summary_header(&mut s, r);
    summary_table(&mut s, r);
    summary_notes(&mut s, r);
    s
}

/// The logs, the clock offset, the protocol and what the force log and the clocks say.
fn summary_header(s: &mut String, r: &VerifyReport) {
    let m = &r.measurement;
    let _ = writeln!(
        s,
        "design {}: {} ({} rows at {:.1} Hz) against {} ({} samples at {:.1} Hz)",
        r.design,
        m.wavelength_log,
        m.wavelength_rows,
        m.wavelength_rate_hz,
        m.force_log,
        m.force_samples,
        m.force_rate_hz
    );
    // A wall clock against a relative one gives an offset of ~1.7e9 s: correct but
    // unreadable, so only the force log's start is printed then (JSON has both).
    let offset = if m.clock_offset_s.abs() < 1e6 {
        format!(
            "clock offset {:.4} s ({}), ",
            m.clock_offset_s, m.clock_offset_source
        )
    } else {
        format!("clock offset {} (", m.clock_offset_source)
    };
    let close = if m.clock_offset_s.abs() < 1e6 {
        ""
    } else {
        ")"
    };
    let _ = writeln!(
        s,
        "{offset}force log starts at {:.4} s{close}, overlap {:.1} s, temperature reference: {}",
        m.force_log_start_s,
        m.overlap_s,
        m.reference_grating.as_deref().unwrap_or("none")
    );
    let _ = writeln!(s, "protocol: {}", protocol_line(m));
    if let Some(line) = force_line(m) {
        let _ = writeln!(s, "force: {line}");
    }
    if let Some(line) = skew_line(m) {
        let _ = writeln!(s, "clock skew: {line}");
    }
    if m.lag_is_relative {
        let _ = writeln!(
            s,
            "lags and Δt_max are RELATIVE, Q only bounded above: {RELATIVE_LAG_NOTE}"
        );
    }
}

/// One line per grating: K, R², hysteresis, linearity, Δt_max, Q, τ, the model's K and
/// the status, with the reason beneath.
fn summary_table(s: &mut String, r: &VerifyReport) {
    let m = &r.measurement;
    let _ = writeln!(
        s,
        "{:<12} {:>14} {:>10} {:>8} {:>9} {:>9} {:>17} {:>17} {:>8} {:>11}",
        "grating",
        "K pm/N",
        "±se",
        "R²",
        "hyst %",
        "lin %",
        "Δt_max s",
        "Q pm/(N·s)",
        "τ s",
        "model pm/N"
    );
    for (g, v) in m.gratings.iter().zip(&r.verdict.gratings) {
        let _ = writeln!(
            s,
            "{:<12} {:>14.4} {:>10.2e} {:>8.4} {:>9.2} {:>9.2} {:>17} {:>17} {:>8.3} {:>11}  {}{}",
            g.grating,
            g.sensitivity_pm_per_n,
            g.sensitivity_std_error_pm_per_n,
            g.r_squared,
            g.hysteresis_percent_span,
            g.nonlinearity_percent_span,
            plus_minus(Some(g.max_lag_s), Some(g.max_lag_uncertainty_s), 3),
            q_text(g, 3),
            g.sls_time_constant_s,
            opt(v.predicted_sensitivity_pm_per_n, 3),
            v.status.word(),
            v.relative_error
                .map(|e| format!(
                    " ({:.2} % error, tolerance {:.1} %)",
                    100.0 * e,
                    100.0 * v.tolerance
                ))
                .unwrap_or_default()
        );
        if let Some(reason) = &v.reason {
            let _ = writeln!(s, "{:<12} {reason}", "");
        }
    }
}

/// The model, the bands, the missing gratings, the warnings and the verdict.
fn summary_notes(s: &mut String, r: &VerifyReport) {
    let m = &r.measurement;
    if let Some(model) = r.verdict.gratings.iter().find_map(|v| v.model.as_ref()) {
        let _ = writeln!(s, "model: {model}");
    }
    for v in &r.verdict.gratings {
        if let Some([lo, hi]) = v.band_pm_per_n {
            let _ = writeln!(
                s,
                "band of {} between the bounding contact readings: {lo:.3} … {hi:.3} pm/N",
                v.grating
            );
        }
    }
    for g in &r.verdict.missing_gratings {
        let _ = writeln!(s, "{:<12} missing: {}", g.grating, g.reason);
    }
    if m.warnings.total() > 0 {
        let _ = writeln!(s, "warnings ({}):", m.warnings.total());
        for (k, w) in &m.warnings.counts {
            let _ = writeln!(s, "  {k} ×{}: {}", w.count, w.first);
        }
    }
    let _ = writeln!(
        s,
        "verdict: {}{}",
        r.verdict.overall.word(),
        r.verdict
            .reason
            .as_deref()
            .map(|why| format!(" ({why})"))
            .unwrap_or_default()
    );
}
