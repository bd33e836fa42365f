//! The spectrum each grating will make (`ModelledPrediction.spectrum`), as a table
//! below the prediction's.

use anyhow::Result;
use fbgforge_model::prediction::spectrum::{GratingSpectrum, ProfileSource};
use fbgforge_model::prediction::ModelledPrediction;
use std::io::Write;

/// `psc1 I blue`.
fn config_label(row: &ModelledPrediction) -> String {
    let p = &row.detail.prediction;
    match &p.insert {
        Some(i) => format!("{} {} {i}", p.core, p.case),
        None => format!("{} {}", p.core, p.case),
    }
}

fn line(out: &mut impl Write, row: &ModelledPrediction, s: &GratingSpectrum) -> Result<()> {
    let p = &row.detail.prediction;
    let limit = match (s.clean_unloaded, s.clean_limit_force_n) {
        (false, _) => "no (unloaded)".to_string(),
        (true, Some(f)) => format!("to {f:.2} N"),
        (true, None) => format!("to {} N", s.force_range_n),
    };
    writeln!(
        out,
        "  {:<10} {:<18} {:>8.1} {:>8.2} {:>5.0} {:>+6.2} {:>6.3} {}{}",
        p.grating,
        config_label(row),
        s.peak_shift_pm,
        s.peak_shift_per_n_pm_per_n,
        s.fwhm_unloaded_pm,
        s.fwhm_change_pct,
        s.strain_span_microstrain_per_n,
        limit,
        match s.strain_profile {
            ProfileSource::Fem => "",
            ProfileSource::UniformClosedForm => " (uniform)",
            ProfileSource::Sheet => " (sheet)",
        }
    )?;
    Ok(())
}

/// The spectrum table (nothing when no row carries a spectrum).
pub(super) fn write(out: &mut impl Write, rows: &[ModelledPrediction]) -> Result<()> {
    let Some(first) = rows.iter().find_map(|r| r.spectrum.as_ref()) else {
        return Ok(());
    };
    writeln!(
        out,
        "Reflection spectrum (transfer-matrix model on the FE strain profile along each grating) at F = {} N, one clean peak checked over 0–{} N ({}); span: the strain's spread along the grating per newton; clean: one clean peak (uniform: no FE profile, a uniform strain):",
        first.at_force_n, first.force_range_n, first.force_range_from
    )?;
    writeln!(
        out,
        "  {:<10} {:<18} {:>8} {:>8} {:>5} {:>6} {:>6} clean",
        "grating", "configuration", "shift pm", "pm/N", "FWHM", "ΔFWHM", "span"
    )?;
    writeln!(
        out,
        "  {:<10} {:<18} {:>8} {:>8} {:>5} {:>6} {:>6}",
        "", "", "", "", "pm", "%", "µε/N"
    )?;
    for row in rows {
        if let Some(s) = &row.spectrum {
            line(out, row, s)?;
        }
    }
    Ok(())
}
