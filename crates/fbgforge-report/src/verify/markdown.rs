//! `report.md`: the verdict, the logs, the table per grating, notes and the plots.

use super::phrases::{
    force_line, opt, plus_minus, protocol_line, q_text, skew_line, RELATIVE_LAG_NOTE,
};
use fbgforge_verify::verdict::Status;
use fbgforge_verify::VerifyReport;
use std::fmt::Write as _;

/// `report.md`: the verdict, the logs, the table per grating, notes and the plots.
pub(super) fn markdown(r: &VerifyReport, lag_plot: bool) -> String {
    let mut md = String::new();
    markdown_header(&mut md, r);
    markdown_table(&mut md, r);
    markdown_notes(&mut md, r);
    let _ = writeln!(md, "\n## Plots\n\n![shift against force](shift_vs_force.svg)\n\n![force against time](force_vs_time.svg)\n\n![shift against time](shift_vs_time.svg)\n");
    if lag_plot {
        let _ = writeln!(md, "![lag per pulse](lag_per_pulse.svg)\n");
    }
    let _ = writeln!(
        md,
        "Numbers behind the plots: `timeseries.csv`, `pulses.csv`, `report.json`."
    );
    md
}

/// The report's title, verdict line and what was measured from which logs.
fn markdown_header(md: &mut String, r: &VerifyReport) {
    let m = &r.measurement;
    let _ = writeln!(md, "# Verification of `{}`\n", r.design);
    let _ = writeln!(
        md,
        "**Verdict: {}** (Case {}{}, tolerance on K {:.1} %)\n",
        r.verdict.overall.word(),
        if r.verdict.case == crate::model::LoadCase::I {
            "I"
        } else {
            "II"
        },
        r.verdict
            .insert
            .as_deref()
            .map(|i| format!(", insert `{i}`"))
            .unwrap_or_default(),
        100.0 * r.verdict.gratings.first().map_or(0.08, |g| g.tolerance)
    );
    let _ = writeln!(
        md,
        "- wavelength log: `{}` ({}, {} rows, {:.2} Hz)",
        m.wavelength_log, m.wavelength_format, m.wavelength_rows, m.wavelength_rate_hz
    );
    let _ = writeln!(
        md,
        "- force log: `{}` ({} samples, {:.2} Hz)",
        m.force_log, m.force_samples, m.force_rate_hz
    );
    let _ = writeln!(md, "- clock offset (force − wavelength clock): {:.4} s ({}); the force log starts at {:.4} s on the wavelength log's time axis; overlap {:.1} s", m.clock_offset_s, m.clock_offset_source, m.force_log_start_s, m.overlap_s);
    let _ = writeln!(md, "- protocol: {}", protocol_line(m));
    if let Some(line) = force_line(m) {
        let _ = writeln!(md, "- force: {line}");
    }
    if let Some(line) = skew_line(m) {
        let _ = writeln!(md, "- clock skew: {line}");
    }
    if m.lag_is_relative {
        let _ = writeln!(
            md,
            "- **lags, Δt_max and Q are relative** (Q is only bounded above): {RELATIVE_LAG_NOTE}"
        );
    }
    if let Some(why) = &r.verdict.reason {
        let _ = writeln!(md, "- verdict: {why}");
    }
    let _ = writeln!(
        md,
        "- temperature reference: {}; interrogator resolution {} pm\n",
        m.reference_grating
            .as_deref()
            .unwrap_or("none (not compensated)"),
        m.interrogator_resolution_pm
    );
}

/// The table of figures of merit, one row per grating.
fn markdown_table(md: &mut String, r: &VerifyReport) {
    let m = &r.measurement;
    let _ = writeln!(md, "| grating | K pm/N | ± se | model pm/N | error % | status | R² | hysteresis % | non-linearity % | resolution N | Δt_max s | Q pm/(N·s) | τ s | r | delay s | plateau K pm/N |");
    let _ = writeln!(
        md,
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    for (g, v) in m.gratings.iter().zip(&r.verdict.gratings) {
        let _ = writeln!(
            md,
            "| {} | {:.4} | {:.4} | {} | {} | {} | {:.4} | {:.2} | {:.2} | {:.4} | {} ({}) | {} | {:.3} | {:.3} | {:.3} | {} |",
            g.grating,
            g.sensitivity_pm_per_n,
            g.sensitivity_std_error_pm_per_n,
            opt(v.predicted_sensitivity_pm_per_n, 4),
            opt(v.relative_error.map(|e| 100.0 * e), 2),
            v.status.word(),
            g.r_squared,
            g.hysteresis_percent_span,
            g.nonlinearity_percent_span,
            g.resolution_n,
            plus_minus(Some(g.max_lag_s), Some(g.max_lag_uncertainty_s), 3),
            g.max_lag_method,
            q_text(g, 3),
            g.sls_time_constant_s,
            g.sls_instant_fraction,
            g.transport_delay_s,
            plus_minus(
                g.plateau_sensitivity_pm_per_n,
                g.plateau_sensitivity_std_error_pm_per_n,
                4
            )
        );
    }
}

/// Why a grating was not judged, the model used, the contact bands and the warnings.
fn markdown_notes(md: &mut String, r: &VerifyReport) {
    let m = &r.measurement;
    for v in &r.verdict.gratings {
        if let Some(reason) = &v.reason {
            let what = match v.status {
                Status::InBand => "in band",
                Status::Fail => "fails",
                Status::CalibrateContact => "needs the contact calibrated",
                Status::NoResponse => "shows no response",
                Status::Pass => "passes",
                Status::NotJudged => "not judged",
            };
            let _ = writeln!(md, "\n`{}` {what}: {reason}", v.grating);
        }
    }
    for g in &r.verdict.missing_gratings {
        let _ = writeln!(md, "\n`{}` missing: {}", g.grating, g.reason);
    }
    for g in &m.gratings {
        if let Some(note) = &g.quality_q_note {
            let _ = writeln!(md, "\nQ of `{}`: {note}.", g.grating);
        }
    }
    if let Some(model) = r.verdict.gratings.iter().find_map(|v| v.model.as_ref()) {
        let _ = writeln!(md, "\nModel: {model}.");
    }
    for v in &r.verdict.gratings {
        if let Some([lo, hi]) = v.band_pm_per_n {
            let _ = writeln!(
                md,
                "\nBand of `{}` between the bounding contact readings: {lo:.3} … {hi:.3} pm/N.",
                v.grating
            );
        }
    }
    if m.warnings.total() > 0 {
        let _ = writeln!(md, "\n## Warnings\n");
        for (k, w) in &m.warnings.counts {
            let _ = writeln!(md, "- `{k}` × {}: {}", w.count, w.first);
        }
    }
}
