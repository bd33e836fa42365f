//! How an array calibration is shown (`fbgforge calibrate-array`): the terminal text
//! ([`Table`]: steps, faults, the matrix with its scatter, Table 2, additivity, the
//! verdicts, the sheet fit) and the charts with their CSVs beside the matrix
//! ([`Charts`]: additivity stacked bars, calibration curves). Both are
//! `CalibrationSink`s; `--json` prints the returned outcome instead of the text.

pub mod charts;
pub mod text;

use crate::array::calibrate::{Calibration, CalibrationFiles, CalibrationSink};
use crate::array::sheet::fit::SheetFit;
use crate::logs::LogWarnings;
use anyhow::Result;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The terminal's sink: the text on standard output.
pub struct Table;

impl CalibrationSink for Table {
    fn calibrated(&mut self, c: &Calibration, w: &LogWarnings, f: &CalibrationFiles) -> Result<()> {
        write!(
            std::io::stdout().lock(),
            "{}",
            crate::terminal::fit(&text::calibration_text(c, w, f))
        )?;
        Ok(())
    }
    fn sheet_fitted(&mut self, fit: &SheetFit, path: Option<&Path>) -> Result<()> {
        write!(
            std::io::stdout().lock(),
            "{}",
            crate::terminal::fit(&text::sheet_fit_text(fit, path))
        )?;
        Ok(())
    }
}

/// The charts and their CSVs, written beside a stem (the matrix's path); what was
/// written is kept in `written`.
pub struct Charts {
    stem: PathBuf,
    /// Files written.
    pub written: Vec<PathBuf>,
    /// Also name each file on standard output.
    pub announce: bool,
}

impl Charts {
    /// Charts beside `stem` (`<stem>.additivity.svg`, ...).
    pub fn beside(stem: impl Into<PathBuf>) -> Self {
        Charts {
            stem: stem.into(),
            written: Vec::new(),
            announce: false,
        }
    }
}

impl CalibrationSink for Charts {
    fn calibrated(
        &mut self,
        c: &Calibration,
        _w: &LogWarnings,
        _f: &CalibrationFiles,
    ) -> Result<()> {
        let written = charts::write_charts(c, &self.stem)?;
        if self.announce {
            let mut out = std::io::stdout().lock();
            for p in &written {
                writeln!(out, "wrote {}", p.display())?;
            }
        }
        self.written.extend(written);
        Ok(())
    }
}
