//! One row of a log at a time: the live mode's reader of a file an interrogator is
//! still writing, with the same detection and row parsers as the whole-file reader.

use super::num::{self, DateOrder};
use super::rows::{is_blank_or_comment, Partial};
use super::time::NO_DATE;
use super::{LogFormat, ReadOptions, RowParser};
use anyhow::Result;
use std::path::Path;

/// One row of a log read on its own: the live mode's tail of a file an interrogator
/// is still writing.
#[derive(Debug, Clone, PartialEq)]
pub struct LogRow {
    /// Time of the row, s: wall-clock seconds since 1970 when the row carries a date
    /// (resolved with the reader's date order), else the plain number written.
    pub time_s: f64,
    /// Peak wavelengths, nm.
    pub peaks_nm: Vec<f64>,
    /// Channel (ENLIGHT) or column (CSV, Sensors) of each peak, from 0.
    pub channels: Vec<u16>,
    /// Each peak's uncertainty, for peaks found in spectra (empty otherwise).
    pub quality: Vec<super::PeakQuality>,
}

/// Parses the rows of a log one line at a time with the same row parsers as
/// [`super::parse_wavelength_bytes`], for a file that is still growing.
pub struct RowReader {
    format: LogFormat,
    parser: Box<dyn RowParser>,
    date_order: DateOrder,
    estimator: Option<String>,
    scratch: Partial,
    counts: Vec<usize>,
}

impl RowReader {
    /// Detect the table in `head` (the complete lines written so far) and return the
    /// reader with the byte offset of the first body line. A slash date is read in
    /// `opts.date_order`, else the format's usual order (a single row cannot tell).
    pub fn new(head: &[u8], path: &Path, opts: &ReadOptions) -> Result<(RowReader, usize)> {
        let det = super::spectrum::detect_table(head, path, opts)?;
        let reader = det.format.reader();
        let rows = reader.rows(&det, head, path, opts)?;
        Ok((
            RowReader {
                format: det.format,
                parser: rows.parser,
                date_order: opts.date_order.unwrap_or(reader.default_date_order()),
                estimator: rows.estimator,
                scratch: Partial::default(),
                counts: Vec::new(),
            },
            det.body_offset,
        ))
    }

    /// The detected format.
    pub fn format(&self) -> LogFormat {
        self.format
    }

    /// The peak estimator of a spectrum log's rows (`None` for a peak log).
    pub fn estimator(&self) -> Option<&str> {
        self.estimator.as_deref()
    }

    /// The format in words, with the estimator of a spectrum log: `imon-pixels, peaks
    /// by gaussian`.
    pub fn describe(&self) -> String {
        match &self.estimator {
            Some(e) => format!("{}, peaks by {e}", self.format.name()),
            None => self.format.name().to_string(),
        }
    }

    /// Parse one line (without its newline). `Ok(None)` for a blank or comment line;
    /// `Err((kind, message))` for a line that cannot be used, with the warning kind the
    /// whole-file reader would count.
    pub fn parse(&mut self, line: &[u8]) -> Result<Option<LogRow>, (&'static str, String)> {
        let line = line.strip_suffix(b"\r").unwrap_or(line);
        if is_blank_or_comment(line) {
            return Ok(None);
        }
        let out = &mut self.scratch;
        *out = Partial::default();
        self.parser
            .parse(line, out, &mut self.counts)
            .map_err(|e| (e.kind, e.message))?;
        let (date, sec) = (out.times.date_of_row[0], out.times.sec[0]);
        let time_s = if date == NO_DATE {
            sec
        } else {
            let days = num::date_to_days(&out.times.dates[date as usize], self.date_order)
                .map_err(|e| ("unreadable_line", e))?;
            days as f64 * 86400.0 + sec
        };
        Ok(Some(LogRow {
            time_s,
            peaks_nm: std::mem::take(&mut out.peaks),
            channels: std::mem::take(&mut out.chans),
            quality: std::mem::take(&mut out.quality),
        }))
    }
}
