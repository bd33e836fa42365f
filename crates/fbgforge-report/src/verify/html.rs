//! `report.html`: a verification in one self-contained file — the verdict and its
//! reasons first, then K against the model on the shift–force chart (the model's K
//! and band drawn where the verdict compares them), the figures of merit, the time
//! series, the notes and warnings. The same charts as the SVG files beside it
//! ([`super::charts`]), inline; nothing is loaded from elsewhere.

use super::charts;
use super::phrases::{
    force_line, opt, plus_minus, protocol_line, q_text, skew_line, RELATIVE_LAG_NOTE,
};
use crate::html::{Cell, Document, Table, Tone};
use crate::model::LoadCase;
use anyhow::Result;
use fbgforge_verify::analysis::{Measurement, Series};
use fbgforge_verify::verdict::{GratingVerdict, Status};
use fbgforge_verify::VerifyReport;

/// The tone a status reads in.
fn tone(s: Status) -> Tone {
    match s {
        Status::Pass => Tone::Pass,
        Status::Fail | Status::NoResponse => Tone::Fail,
        Status::InBand | Status::NotJudged | Status::CalibrateContact => Tone::Warn,
    }
}

/// One grating's verdict as a sentence: what was compared and how it came out.
pub fn reason(v: &GratingVerdict) -> String {
    let k = v.measured_sensitivity_pm_per_n;
    let mut s = match (v.predicted_sensitivity_pm_per_n, v.relative_error) {
        (Some(p), Some(e)) => format!(
            "{}: {}: K = {k:.3} pm/N against the model's {p:.3} pm/N, {:.2} % error {} the tolerance of {:.1} %",
            v.grating,
            v.status.word(),
            100.0 * e,
            if e <= v.tolerance * (1.0 + 1e-12) {
                "within"
            } else {
                "above"
            },
            100.0 * v.tolerance
        ),
        _ => format!("{}: {}: K = {k:.3} pm/N", v.grating, v.status.word()),
    };
    if let Some(r) = &v.reason {
        s.push_str("; ");
        s.push_str(r);
    }
    s
}

/// Build the report as a document: the verdict and its reasons, K against the model,
/// the figures of merit, the inputs, the time series and the warnings.
pub fn document(r: &VerifyReport, series: &Series) -> Result<Document> {
    let m = &r.measurement;
    let mut d = Document::new(format!("Verification of {}", r.design));
    verdict_section(&mut d, r);
    sensitivity_section(&mut d, r, series)?;
    figures_section(&mut d, m);
    inputs_section(&mut d, m);
    series_section(&mut d, m, series)?;
    if m.warnings.total() > 0 {
        d.section("Warnings");
        let items: Vec<String> = m
            .warnings
            .counts
            .iter()
            .map(|(k, w)| format!("{k} × {}: {}", w.count, w.first))
            .collect();
        d.list(&items);
    }
    d.files(&[
        "report.json",
        "report.md",
        "timeseries.csv",
        "pulses.csv",
        "shift_vs_force.svg",
        "force_vs_time.svg",
        "shift_vs_time.svg",
    ]);
    Ok(d)
}

/// The verdict, what was compared, and every grating's reason.
fn verdict_section(d: &mut Document, r: &VerifyReport) {
    let m = &r.measurement;
    let case = if r.verdict.case == LoadCase::I {
        "I"
    } else {
        "II"
    };
    let tolerance = 100.0 * r.verdict.gratings.first().map_or(0.08, |g| g.tolerance);
    let mut reasons: Vec<String> = r.verdict.gratings.iter().map(reason).collect();
    if m.lag_is_relative {
        reasons.push(format!(
            "lags and Δt_max are relative, Q only bounded above: {RELATIVE_LAG_NOTE}"
        ));
    }
    d.verdict(
        tone(r.verdict.overall),
        r.verdict.overall.word(),
        &format!(
            "Measured K against the model's, Case {case}{}, tolerance on K {tolerance:.1} %",
            r.verdict
                .insert
                .as_deref()
                .map(|i| format!(", insert {i}"))
                .unwrap_or_default()
        ),
        &reasons,
    );
}

/// Measured K against the model's, per grating, and the shift–force chart.
fn sensitivity_section(d: &mut Document, r: &VerifyReport, series: &Series) -> Result<()> {
    let m = &r.measurement;
    d.section("Sensitivity against the model");
    let mut t = Table::new([
        "grating",
        "measured K pm/N",
        "± se pm/N",
        "model K pm/N",
        "model band pm/N",
        "error %",
        "tolerance %",
        "status",
    ]);
    for (g, v) in m.gratings.iter().zip(&r.verdict.gratings) {
        t.row([
            Cell::from(g.grating.clone()),
            format!("{:.4}", g.sensitivity_pm_per_n).into(),
            format!("{:.4}", g.sensitivity_std_error_pm_per_n).into(),
            opt(v.predicted_sensitivity_pm_per_n, 4).into(),
            v.band_pm_per_n
                .map_or("—".to_string(), |[lo, hi]| format!("{lo:.3} … {hi:.3}"))
                .into(),
            opt(v.relative_error.map(|e| 100.0 * e), 2).into(),
            format!("{:.1}", 100.0 * v.tolerance).into(),
            Cell::toned(v.status.word(), tone(v.status)),
        ]);
    }
    d.table("verdicts", &t);
    d.chart(
        &charts::shift_vs_force(r, series),
        "Shift against force: the measured points, the fitted K (solid), the model's K (dashed, through the fit's intercept) with the slopes that pass shaded around it, and the band between the bounding contact readings when the model gives one (dotted outline).",
    )?;
    if let Some(model) = r.verdict.gratings.iter().find_map(|v| v.model.as_ref()) {
        d.note(&format!("Model: {model}."));
    }
    Ok(())
}

/// R², hysteresis, non-linearity, resolution, Δt_max, Q and the lag model per grating.
fn figures_section(d: &mut Document, m: &Measurement) {
    d.section("Figures of merit");
    let mut t = Table::new([
        "grating",
        "R²",
        "hysteresis % span",
        "non-linearity % span",
        "resolution N",
        "Δt_max s",
        "Q pm/(N·s)",
        "τ s",
        "r",
        "delay s",
        "plateau K pm/N",
    ]);
    for g in &m.gratings {
        t.row([
            g.grating.clone(),
            format!("{:.4}", g.r_squared),
            format!("{:.2}", g.hysteresis_percent_span),
            format!("{:.2}", g.nonlinearity_percent_span),
            format!("{:.4}", g.resolution_n),
            format!(
                "{} ({})",
                plus_minus(Some(g.max_lag_s), Some(g.max_lag_uncertainty_s), 3),
                g.max_lag_method
            ),
            q_text(g, 3),
            format!("{:.3}", g.sls_time_constant_s),
            format!("{:.3}", g.sls_instant_fraction),
            format!("{:.3}", g.transport_delay_s),
            plus_minus(
                g.plateau_sensitivity_pm_per_n,
                g.plateau_sensitivity_std_error_pm_per_n,
                4,
            ),
        ]);
    }
    d.table("figures-of-merit", &t);
}

/// The logs, the clocks, the protocol and the force log's trust.
fn inputs_section(d: &mut Document, m: &Measurement) {
    d.section("Inputs");
    d.facts(&[
        (
            "wavelength log",
            format!(
                "{} ({}, {} rows, {:.2} Hz)",
                m.wavelength_log, m.wavelength_format, m.wavelength_rows, m.wavelength_rate_hz
            ),
        ),
        (
            "force log",
            format!(
                "{} ({} samples, {:.2} Hz)",
                m.force_log, m.force_samples, m.force_rate_hz
            ),
        ),
        (
            "clock offset",
            // A wall clock against a relative one gives ~1.7e9 s: correct but unreadable.
            if m.clock_offset_s.abs() < 1e6 {
                format!(
                    "{:.4} s, force − wavelength clock ({}); the force log starts at {:.4} s on the wavelength clock; overlap {:.1} s",
                    m.clock_offset_s, m.clock_offset_source, m.force_log_start_s, m.overlap_s
                )
            } else {
                format!(
                    "{} (a wall clock against a relative one; the value is in report.json); the force log starts at {:.4} s on the wavelength clock; overlap {:.1} s",
                    m.clock_offset_source, m.force_log_start_s, m.overlap_s
                )
            },
        ),
        ("protocol", protocol_line(m)),
        (
            "force log trust",
            force_line(m).unwrap_or_else(|| "no saturation, no gaps inside a press".into()),
        ),
        (
            "clock skew",
            skew_line(m).unwrap_or_else(|| "not estimated".into()),
        ),
        (
            "temperature reference",
            m.reference_grating
                .clone()
                .unwrap_or_else(|| "none (not compensated)".into()),
        ),
        (
            "interrogator resolution",
            format!("{} pm", m.interrogator_resolution_pm),
        ),
    ]);
}

/// The force and the shifts against time, and the lag per segment.
fn series_section(d: &mut Document, m: &Measurement, series: &Series) -> Result<()> {
    d.section("Time series");
    d.chart(
        &charts::force_vs_time(series),
        "The force, resampled onto the wavelength log's clock.",
    )?;
    d.chart(
        &charts::shift_vs_time(series),
        "Each grating's shift, temperature (reference grating) and drift removed.",
    )?;
    if let Some(c) = charts::lag_per_segment(m) {
        d.chart(
            &c,
            "Lag of the shift's peak behind the force's, per segment.",
        )?;
    }
    Ok(())
}
