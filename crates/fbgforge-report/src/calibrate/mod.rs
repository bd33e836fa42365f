//! How an array calibration is shown on the terminal (`fbgforge calibrate-array`): the
//! measured matrix as a table, the log's warnings, the file written, and the modulus
//! fit with its largest misfit ([`Table`], a `CalibrationSink`).

use crate::array::calibrate::{ArrayCalibration, CalibrationSink};
use crate::array::sheet::fit::ModulusFit;
use anyhow::Result;
use std::fmt::Write as _;
use std::io::Write;
use std::path::Path;

/// The measured matrix, one row per grating (pm/g), the warnings and the file written.
pub(crate) fn matrix_table(cal: &ArrayCalibration, out: Option<&Path>) -> String {
    let (m, warnings) = (&cal.matrix, &cal.warnings);
    let mut s = format!("{:<8}", "grating");
    for c in &m.cells {
        let _ = write!(s, "{c:>10}");
    }
    s.push('\n');
    for (g, row) in m.gratings.iter().zip(m.sensitivity_pm_per_g.row_iter()) {
        let _ = write!(s, "{g:<8}");
        for v in row.iter() {
            let _ = write!(s, "{v:>10.5}");
        }
        s.push('\n');
    }
    for (k, w) in &warnings.counts {
        let _ = writeln!(s, "warning {k} ×{}: {}", w.count, w.first);
    }
    if let Some(out) = out {
        let _ = writeln!(s, "wrote {}", out.display());
    }
    s
}

/// The modulus fit: the design's and the fitted modulus with their misfits, and the
/// entry the model misses most (every entry's misfit is in `path`).
pub(crate) fn modulus_lines(f: &ModulusFit, path: &Path) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "sheet model's modulus: design {} MPa (misfit {:.1} %), fitted {:.4} MPa (misfit {:.1} %; {:.1} % at half, {:.1} % at twice){}",
        f.design_modulus_mpa,
        100.0 * f.design_rel_rms,
        f.fitted_modulus_mpa,
        100.0 * f.fitted_rel_rms,
        100.0 * f.rel_rms_at_half_and_double.0,
        100.0 * f.rel_rms_at_half_and_double.1,
        if f.at_search_limit {
            " — at the end of the search range (0.05–50 MPa): the modulus alone cannot reach this matrix's level"
        } else {
            ""
        }
    );
    let worst = f
        .entries
        .iter()
        .filter_map(|e| e.misfit_pct.map(|p| (p, e)))
        .max_by(|x, y| x.0.abs().total_cmp(&y.0.abs()));
    if let Some((p, e)) = worst {
        let _ = writeln!(
            s,
            "largest misfit: {} × cell {}: measured {:.5}, model {:.5} pm/g ({p:+.1} %); every entry in {}",
            e.grating,
            e.cell,
            e.measured_pm_per_g,
            e.model_pm_per_g,
            path.display()
        );
    }
    s
}

/// The terminal's sink of a calibration: [`matrix_table`], then [`modulus_lines`], on
/// standard output.
pub struct Table;

impl CalibrationSink for Table {
    fn measured(&mut self, cal: &ArrayCalibration, out: Option<&Path>) -> Result<()> {
        write!(std::io::stdout().lock(), "{}", matrix_table(cal, out))?;
        Ok(())
    }
    fn modulus_fitted(&mut self, fit: &ModulusFit, path: &Path) -> Result<()> {
        write!(std::io::stdout().lock(), "{}", modulus_lines(fit, path))?;
        Ok(())
    }
}
