//! Reports of a verification: a short text summary for the terminal, JSON for
//! scripts (and for the optimiser, which reads the lag-model fields), a Markdown
//! report with SVG plots and the CSV files behind them, and the same as one
//! self-contained HTML file (`report_html`).

use super::charts;
use crate::output::{write_atomic, write_csv, write_json};
use crate::analysis::{Measurement, Series};
use crate::verdict::{Status, Verdict};
use anyhow::Result;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::Path;

/// What `verify --json` prints and `report.json` holds.
#[derive(Debug, Clone, Serialize)]
pub struct VerifyReport {
    /// Design name.
    pub design: String,
    /// Measurements.
    pub measurement: Measurement,
    /// Verdict against the model.
    pub verdict: Verdict,
}

/// Why an estimated clock offset leaves only relative lags, and what to do about it.
pub const RELATIVE_LAG_NOTE: &str = "the clock offset was estimated from the logs, and an estimated offset absorbs any pure delay between force and wavelength, so the absolute lag cannot be told from this data; give the offset between the two recorders' clocks with --clock-offset-s for absolute lags";

pub(super) fn status_word(s: Status) -> &'static str {
    s.word()
}

/// Q as a value with its uncertainty, a bound (`≤ 524.1`, `≥ 12.3`), or `—`.
pub(super) fn q_text(g: &crate::analysis::GratingResult, digits: usize) -> String {
    use crate::analysis::BoundKind;
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
pub(super) fn skew_line(m: &Measurement) -> Option<String> {
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
pub(super) fn force_line(m: &Measurement) -> Option<String> {
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
pub(super) fn plus_minus(v: Option<f64>, u: Option<f64>, digits: usize) -> String {
    match (v.filter(|x| x.is_finite()), u.filter(|x| x.is_finite())) {
        (Some(v), Some(u)) => format!("{v:.digits$} ± {u:.digits$}"),
        (Some(v), None) => format!("{v:.digits$}"),
        _ => "—".into(),
    }
}

/// The protocol, its pulses and segments, and how the lags were measured.
pub(super) fn protocol_line(m: &Measurement) -> String {
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

pub(super) fn opt(v: Option<f64>, digits: usize) -> String {
    v.filter(|x| x.is_finite())
        .map_or("—".into(), |x| format!("{x:.digits$}"))
}

/// The short printed report.
pub fn summary(r: &VerifyReport) -> String {
    let m = &r.measurement;
    let mut s = String::new();
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
            status_word(v.status),
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
        status_word(r.verdict.overall),
        r.verdict
            .reason
            .as_deref()
            .map(|why| format!(" ({why})"))
            .unwrap_or_default()
    );
    s
}

fn decimate(n: usize, max: usize) -> usize {
    n.div_ceil(max.max(1)).max(1)
}

/// Write `report.json`, `report.md`, `report.html`, the SVG plots and their CSVs into
/// the folder `dir`, whole or not at all: they are written into a temporary folder
/// beside it, which then replaces `dir` (a failure leaves `dir` as it was). A `dir` that
/// holds anything but a previous report is refused rather than replaced.
pub fn write_report(dir: &Path, r: &VerifyReport, series: &Series) -> Result<()> {
    check_report_dir(dir)?;
    crate::output::write_dir_atomic(dir, |tmp| write_report_files(tmp, r, series))
}

/// The names a report folder holds (a folder with anything else is not ours to replace).
fn is_report_file(name: &str) -> bool {
    name.starts_with("report.")
        || name.ends_with(".svg")
        || name.ends_with(".csv")
        || name.ends_with(".html")
        || name.ends_with(".json")
}

/// Refuse a report folder that exists and holds files a verify report does not write.
pub fn check_report_dir(dir: &Path) -> Result<()> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Ok(());
    };
    let foreign: Vec<String> = entries
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| !is_report_file(n))
        .collect();
    if !foreign.is_empty() {
        anyhow::bail!(
            "the report folder {} holds files a verify report does not write ({}): it would be replaced whole; name a new or empty folder",
            dir.display(),
            foreign.iter().take(5).cloned().collect::<Vec<_>>().join(", ")
        );
    }
    Ok(())
}

/// Remove a previous report folder (after a failed run: its files would be mistaken
/// for this run's). Only a folder holding nothing but report files is removed.
pub fn remove_stale_report(dir: &Path) -> Result<()> {
    if dir.is_dir() && check_report_dir(dir).is_ok() {
        std::fs::remove_dir_all(dir).map_err(|e| {
            anyhow::anyhow!(
                "cannot remove the stale report folder {}: {e}",
                dir.display()
            )
        })?;
    }
    Ok(())
}

/// Write `report.json`, `report.md`, `report.html`, the SVG plots and their CSVs into `dir`.
fn write_report_files(dir: &Path, r: &VerifyReport, series: &Series) -> Result<()> {
    crate::output::ensure_dir(dir)?;
    write_json(&dir.join("report.json"), r)?;
    let m = &r.measurement;
    write_timeseries_csv(dir, series)?;
    write_pulses_csv(dir, m)?;
    plot_shift_vs_force(dir, r, series)?;
    plot_against_time(dir, series)?;
    let lag_plot = plot_lag_per_pulse(dir, m)?;
    write_atomic(&dir.join("report.md"), markdown(r, lag_plot).as_bytes())?;
    super::report_html::write(&dir.join("report.html"), r, series)
}

/// `timeseries.csv`: time, force and each grating's shift, at most 20 000 rows.
fn write_timeseries_csv(dir: &Path, series: &Series) -> Result<()> {
    let step = decimate(series.time_s.len(), 20_000);
    let idx: Vec<usize> = (0..series.time_s.len()).step_by(step).collect();
    let mut header: Vec<String> = vec!["time_s".into(), "force_n".into()];
    header.extend(series.shift_pm.iter().map(|(n, _)| format!("{n}_shift_pm")));
    let rows: Vec<Vec<String>> = idx
        .iter()
        .map(|&i| {
            let mut row = vec![
                format!("{:.6}", series.time_s[i]),
                format!("{:.5}", series.force_n[i]),
            ];
            row.extend(series.shift_pm.iter().map(|(_, v)| format!("{:.4}", v[i])));
            row
        })
        .collect();
    let h: Vec<&str> = header.iter().map(|s| s.as_str()).collect();
    write_csv(&dir.join("timeseries.csv"), &h, &rows)
}

/// `pulses.csv`: per grating and segment, the peaks of force and shift and the lag.
fn write_pulses_csv(dir: &Path, m: &Measurement) -> Result<()> {
    let prow: Vec<Vec<String>> = m
        .gratings
        .iter()
        .flat_map(|g| {
            g.pulses.iter().map(move |p| {
                vec![
                    g.grating.clone(),
                    p.index.to_string(),
                    p.pulse.to_string(),
                    serde_json::to_value(p.kind)
                        .ok()
                        .and_then(|v| v.as_str().map(String::from))
                        .unwrap_or_default(),
                    format!("{:.6}", p.start_s),
                    format!("{:.6}", p.end_s),
                    format!("{:.5}", p.peak_force_n),
                    format!("{:.6}", p.peak_force_time_s),
                    format!("{:.4}", p.peak_shift_pm),
                    format!("{:.6}", p.peak_shift_time_s),
                    format!("{:.6}", p.lag_s),
                    format!("{:.6}", p.lag_uncertainty_s),
                ]
            })
        })
        .collect();
    write_csv(
        &dir.join("pulses.csv"),
        &[
            "grating",
            "segment",
            "pulse",
            "kind",
            "start_s",
            "end_s",
            "peak_force_n",
            "peak_force_time_s",
            "peak_shift_pm",
            "peak_shift_time_s",
            "lag_s",
            "lag_uncertainty_s",
        ],
        &prow,
    )
}

/// `shift_vs_force.svg`: each grating's shift against force, its fitted line, and the
/// model's K with its band (`super::charts`).
fn plot_shift_vs_force(dir: &Path, r: &VerifyReport, series: &Series) -> Result<()> {
    charts::shift_vs_force(r, series).write_svg(&dir.join("shift_vs_force.svg"))
}

/// `force_vs_time.svg` and `shift_vs_time.svg` on the wavelength clock.
fn plot_against_time(dir: &Path, series: &Series) -> Result<()> {
    charts::force_vs_time(series).write_svg(&dir.join("force_vs_time.svg"))?;
    charts::shift_vs_time(series).write_svg(&dir.join("shift_vs_time.svg"))
}

/// `lag_per_pulse.svg` when any segment has a lag; returns whether it was written.
fn plot_lag_per_pulse(dir: &Path, m: &Measurement) -> Result<bool> {
    match charts::lag_per_segment(m) {
        Some(c) => c.write_svg(&dir.join("lag_per_pulse.svg")).map(|_| true),
        None => Ok(false),
    }
}

/// `report.md`: the verdict, the logs, the table per grating, notes and the plots.
fn markdown(r: &VerifyReport, lag_plot: bool) -> String {
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
        status_word(r.verdict.overall),
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
            status_word(v.status),
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
