//! Where a verification's results go: a [`VerifySink`] (ripgrep's `Sink`, the live
//! mode's `LiveSink`). [`crate::run_with`] hands it the judged report with the series
//! behind it, then the contact calibration when one was asked for; every method has a
//! no-op default, so a front end implements what it shows. The terminal summary, the
//! JSON document and the report folder are implementations in `fbgforge-report`
//! (`fbgforge_report::verify`); the Python package takes the returned outcome.

use crate::analysis::Series;
use crate::prediction::ContactCalibration;
use crate::report::VerifyReport;
use anyhow::Result;
use std::path::Path;

/// What a front end does with a verification's results.
pub trait VerifySink {
    /// The judged report and the aligned series behind it (for plots).
    fn judged(&mut self, _report: &VerifyReport, _series: &Series) -> Result<()> {
        Ok(())
    }

    /// The design's contact reading calibrated on the measured K, and the file the
    /// calibrated design was written to.
    fn calibrated(&mut self, _calibration: &ContactCalibration, _path: &Path) -> Result<()> {
        Ok(())
    }

    /// `text` in the front end's words: the request's fields that the use case names in
    /// what it writes itself (`VerifyRequest.calibrate_into` in the calibrated design's
    /// header) as the front end names them (`--calibrate-into`). Unchanged by default.
    fn in_words(&self, text: &str) -> String {
        text.to_owned()
    }
}

/// No sink: the outcome is only returned.
impl VerifySink for () {}

/// A sink by reference.
impl<S: VerifySink + ?Sized> VerifySink for &mut S {
    fn judged(&mut self, report: &VerifyReport, series: &Series) -> Result<()> {
        (**self).judged(report, series)
    }
    fn calibrated(&mut self, calibration: &ContactCalibration, path: &Path) -> Result<()> {
        (**self).calibrated(calibration, path)
    }
    fn in_words(&self, text: &str) -> String {
        (**self).in_words(text)
    }
}

/// A sink that may be absent (a report folder not asked for).
impl<S: VerifySink> VerifySink for Option<S> {
    fn judged(&mut self, report: &VerifyReport, series: &Series) -> Result<()> {
        self.as_mut().map_or(Ok(()), |s| s.judged(report, series))
    }
    fn calibrated(&mut self, calibration: &ContactCalibration, path: &Path) -> Result<()> {
        self.as_mut()
            .map_or(Ok(()), |s| s.calibrated(calibration, path))
    }
    fn in_words(&self, text: &str) -> String {
        self.as_ref()
            .map_or_else(|| text.to_owned(), |s| s.in_words(text))
    }
}

/// Two sinks, told in order; their words applied one after the other.
impl<A: VerifySink, B: VerifySink> VerifySink for (A, B) {
    fn judged(&mut self, report: &VerifyReport, series: &Series) -> Result<()> {
        self.0.judged(report, series)?;
        self.1.judged(report, series)
    }
    fn calibrated(&mut self, calibration: &ContactCalibration, path: &Path) -> Result<()> {
        self.0.calibrated(calibration, path)?;
        self.1.calibrated(calibration, path)
    }
    fn in_words(&self, text: &str) -> String {
        self.1.in_words(&self.0.in_words(text))
    }
}
