//! The spectrum each grating will make (`ModelledPrediction.spectrum`), as a table
//! below the prediction's.

use anyhow::Result;
use fbgforge_model::prediction::spectrum::{GratingSpectrum, ProfileSource};
use fbgforge_model::prediction::ModelledPrediction;
use std::io::Write;

/// `psc1 Case I blue`.
fn config_label(row: &ModelledPrediction) -> String {
    let p = &row.detail.prediction;
    let case = format!("Case {}", p.case);
    match &p.insert {
        Some(i) => format!("{} {case} {i}", p.core),
        None => format!("{} {case}", p.core),
    }
}

fn line(out: &mut impl Write, row: &ModelledPrediction, s: &GratingSpectrum) -> Result<()> {
    let p = &row.detail.prediction;
    let limit = match (s.clean_unloaded, s.clean_limit_force_n) {
        (false, _) => "not clean unloaded".to_string(),
        (true, Some(f)) => format!("stops at {f:.2} N"),
        (true, None) => format!("clean to {} N", s.force_range_n),
    };
    writeln!(
        out,
        "  {:<10} {:<24} {:>10.1} {:>9.3} {:>8.1} {:>+8.2} {:>9.3}  {}{}",
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
            ProfileSource::UniformClosedForm => " (uniform: no FE profile)",
            ProfileSource::Sheet => " (sheet model's profile)",
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
        "Reflection spectrum (transfer-matrix model on the FE strain profile along each grating) at F = {} N, one clean peak checked over 0–{} N ({}):",
        first.at_force_n, first.force_range_n, first.force_range_from
    )?;
    writeln!(
        out,
        "  {:<10} {:<24} {:>10} {:>9} {:>8} {:>8} {:>9}  one clean peak",
        "grating", "configuration", "shift pm", "pm/N", "FWHM pm", "ΔFWHM %", "span µε/N"
    )?;
    for row in rows {
        if let Some(s) = &row.spectrum {
            line(out, row, s)?;
        }
    }
    Ok(())
}
