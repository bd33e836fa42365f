//! How a verification is shown: the short text summary ([`summary`]), the JSON
//! document, the report folder ([`ReportFolder`]: `report.json`, `report.md`,
//! `report.html` with its [`charts`], the plots and CSVs), and the contact calibration
//! in one line ([`calibration_line`]). [`Printer`] and [`ReportFolder`] are
//! [`VerifySink`]s: `fbgforge verify` hands both to `fbgforge_verify::run_with`.
//!
//! The texts name the request's fields in the library's own words
//! (`AnalysisOptions.clock_offset_s`); a front end gives its [`Words`] (the command
//! line's flags, Python's parameters) to the sinks, which apply them to everything
//! they write.

pub mod charts;
mod folder;
pub mod html;
mod markdown;
mod phrases;
mod summary;

pub use folder::{
    check_report_dir, remove_stale_report, write_report, write_report_in, ReportFolder,
};
pub use phrases::RELATIVE_LAG_NOTE;
pub use summary::summary;

use crate::prediction::ContactCalibration;
use anyhow::Result;
use fbgforge_verify::analysis::Series;
use fbgforge_verify::{VerifyReport, VerifySink};
use std::io::Write;
use std::path::{Path, PathBuf};

/// How a front end names the library's fields in text: `VerifyRequest.force_start` as
/// `--force-start` (the command line's `cli::hiargs`) or `force_start` (Python).
pub(crate) type Words = fn(&str) -> String;

/// The library's own words: the text unchanged.
pub(crate) fn own_words(text: &str) -> String {
    text.to_owned()
}

/// The contact calibration in one line: the radius before and after, the FE solves,
/// each grating's K measured and modelled before and after, and the file written.
pub(crate) fn calibration_line(c: &ContactCalibration, path: &Path) -> String {
    format!(
        "calibrated {}: dome_contact_radius_mm {:.4} → {:.4} mm ({} FE solves); {}; written to {}",
        c.configuration.label(),
        c.previous_radius_mm,
        c.radius_mm,
        c.evaluations,
        c.gratings
            .iter()
            .map(|g| format!(
                "{} measured {:+.3}, model {:+.3} → {:+.3} pm/N",
                g.grating, g.measured_pm_per_n, g.before_pm_per_n, g.after_pm_per_n
            ))
            .collect::<Vec<_>>()
            .join("; "),
        path.display()
    )
}

/// The terminal's sink: the summary (and where the report folder's page is), or the
/// JSON document on standard output; the contact calibration's line after it (on
/// standard error with JSON, so standard output stays one document).
pub struct Printer {
    json: bool,
    report_html: Option<PathBuf>,
    words: Words,
}

impl Printer {
    /// The summary (`json` false) or the JSON document, in `words`; `report_dir`: the
    /// report folder written beside, named after the summary.
    pub fn new(json: bool, report_dir: Option<&Path>, words: Words) -> Self {
        Printer {
            json,
            report_html: report_dir.map(|d| d.join("report.html")),
            words,
        }
    }
}

impl VerifySink for Printer {
    fn judged(&mut self, report: &VerifyReport, _: &Series) -> Result<()> {
        let mut out = std::io::stdout().lock();
        if self.json {
            writeln!(
                out,
                "{}",
                (self.words)(&serde_json::to_string_pretty(report)?)
            )?;
        } else {
            write!(
                out,
                "{}",
                crate::terminal::fit(&(self.words)(&summary(report)))
            )?;
            if let Some(page) = &self.report_html {
                writeln!(out, "report: {}", page.display())?;
            }
        }
        Ok(())
    }

    fn calibrated(&mut self, calibration: &ContactCalibration, path: &Path) -> Result<()> {
        let line = calibration_line(calibration, path);
        if self.json {
            writeln!(std::io::stderr(), "{line}")?;
        } else {
            write!(
                std::io::stdout(),
                "{}",
                crate::terminal::fit(&format!("{line}\n"))
            )?;
        }
        Ok(())
    }

    fn in_words(&self, text: &str) -> String {
        (self.words)(text)
    }
}
