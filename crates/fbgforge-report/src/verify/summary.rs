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

/// Decimals that show a value of standard error `se` to its precision (the first
/// significant digit of the error), 0–4.
fn decimals_for(se: f64) -> usize {
    if se.is_finite() && se > 0.0 {
        (-se.log10()).ceil().clamp(0.0, 4.0) as usize
    } else {
        2
    }
}

/// `v±u` without spaces (a table cell), or `v` alone, or `—`.
fn cell_pm(v: Option<f64>, u: Option<f64>, digits: usize) -> String {
    plus_minus(v, u, digits).replace(" ± ", "±")
}

/// One line per grating, within 80 columns: K with its standard error, R², Δt_max, Q,
/// the model's K and the status with the relative error, with the reason beneath.
/// Hysteresis, linearity and the SLS time constant are in the JSON and the report.
fn summary_table(s: &mut String, r: &VerifyReport) {
    let m = &r.measurement;
    let gw = m
        .gratings
        .iter()
        .map(|g| g.grating.chars().count())
        .max()
        .unwrap_or(0)
        .max(7);
    let _ = writeln!(
        s,
        "{:<gw$} {:>9} {:>6} {:>6} {:>11} {:>12} {:>7}  status",
        "grating", "K pm/N", "±se", "R²", "Δt_max s", "Q pm/(N·s)", "model"
    );
    let mut tolerances: Vec<f64> = Vec::new();
    for (g, v) in m.gratings.iter().zip(&r.verdict.gratings) {
        let se = g.sensitivity_std_error_pm_per_n;
        let d = decimals_for(se);
        let q = match q_text(g, 1).as_str() {
            t if t.contains(" ± ") => t.replace(" ± ", "±"),
            t => t.to_string(),
        };
        let _ = writeln!(
            s,
            "{:<gw$} {:>9.d$} {:>6} {:>6.4} {:>11} {:>12} {:>7}  {}{}",
            g.grating,
            g.sensitivity_pm_per_n,
            format!("{se:.e$}", e = (d + 1).min(4)),
            g.r_squared,
            cell_pm(Some(g.max_lag_s), Some(g.max_lag_uncertainty_s), 3),
            q,
            opt(v.predicted_sensitivity_pm_per_n, 1),
            v.status.word(),
            v.relative_error
                .map(|e| {
                    if !tolerances.contains(&v.tolerance) {
                        tolerances.push(v.tolerance);
                    }
                    format!(" {:.2} %", 100.0 * e)
                })
                .unwrap_or_default()
        );
        if let Some(reason) = &v.reason {
            let _ = writeln!(s, "{:<gw$} {reason}", "");
        }
    }
    if !tolerances.is_empty() {
        let tol: Vec<String> = tolerances
            .iter()
            .map(|t| format!("{:.1} %", 100.0 * t))
            .collect();
        let _ = writeln!(
            s,
            "status: the fitted K against the model's (pm/N), |K − model|/|model|, tolerance {}",
            tol.join(", ")
        );
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
        let _ = writeln!(s, "{} missing: {}", g.grating, g.reason);
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
