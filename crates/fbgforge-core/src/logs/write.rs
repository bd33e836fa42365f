//! Writing wavelength logs in a supported format: the synthetic logs of the tests,
//! the studies and `fbgforge synth-log`. Each format writes itself
//! ([`super::LogReader::write`]); this holds what they share.

use super::LogFormat;
use std::io::Write;

/// A wavelength table to write as a log.
#[derive(Debug, Clone, Copy)]
pub struct LogTable<'a> {
    /// Wall-clock time of the first row, s since 1970 (written by the formats with
    /// dates).
    pub start_epoch_s: f64,
    /// Time of each row from the first, s.
    pub time_s: &'a [f64],
    /// Grating names, in column order.
    pub names: &'a [String],
    /// Wavelength per row and grating, nm; NaN = no peak.
    pub wavelength_nm: &'a [Vec<f64>],
    /// Sample rate, Hz (stated in the ENLIGHT metadata).
    pub sample_rate_hz: f64,
}

/// How the log text looks.
#[derive(Debug, Clone, PartialEq)]
pub struct LogStyle {
    /// Decimal commas (ENLIGHT: in every number; CSV: with `;` as the delimiter).
    pub decimal_comma: bool,
    /// Lead the file with a UTF-8 BOM.
    pub bom: bool,
    /// Lines of ENLIGHT metadata before the table header.
    pub metadata_lines: usize,
    /// ENLIGHT timestamps on a 12-hour clock (`3:44:56.500000 pm`).
    pub twelve_hour: bool,
    /// How the spectra of an I-MON log with pixels are made (`imon-pixels` only).
    pub spectrum: super::SpectrumStyle,
}

impl Default for LogStyle {
    fn default() -> Self {
        LogStyle {
            decimal_comma: false,
            bom: false,
            metadata_lines: 45,
            twelve_hour: false,
            spectrum: super::SpectrumStyle::default(),
        }
    }
}

/// Write `table` as a log in `format`.
pub fn write_log(
    w: &mut dyn Write,
    format: LogFormat,
    table: &LogTable,
    style: &LogStyle,
) -> std::io::Result<()> {
    if style.bom {
        w.write_all(b"\xEF\xBB\xBF")?;
    }
    format.reader().write(w, table, style)
}

/// Write `v` with `decimals` decimals, with a decimal comma when `comma`.
pub(crate) fn write_number(
    w: &mut dyn Write,
    v: f64,
    decimals: usize,
    comma: bool,
) -> std::io::Result<()> {
    if comma {
        let s = format!("{v:.decimals$}").replace('.', ",");
        w.write_all(s.as_bytes())
    } else {
        write!(w, "{v:.decimals$}")
    }
}
