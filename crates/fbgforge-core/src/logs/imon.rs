//! Ibsen I-MON evaluation software log: the header `Date<TAB>Time<TAB>Wavelength 1 [nm]
//! <TAB>…` (with `Pixel n` columns when the spectrum is saved too); each row holds a
//! month-first date, a 12-hour time of day in whole seconds, a varying number of
//! wavelengths (one channel) and, if saved, the spectrum's intensities.

use super::detect::{Detected, HeadLine};
use super::num::{self, civil_from_days, trim, DateOrder};
use super::rows::{issue, LineIssue, Partial};
use super::{LogReader, LogStyle, LogTable, RowParser, Rows};
use anyhow::Result;
use std::io::Write;
use std::path::Path;

/// The I-MON format.
pub(crate) struct Imon;

impl LogReader for Imon {
    fn name(&self) -> &'static str {
        "imon"
    }

    fn title(&self) -> &'static str {
        "I-MON"
    }

    fn expected(&self) -> &'static str {
        "a line `Date<TAB>Time<TAB>Wavelength 1 [nm]<TAB>…`"
    }

    /// I-MON 512E: < 0.5 pm.
    fn typical_resolution_pm(&self) -> f64 {
        0.5
    }

    /// The I-MON software writes US dates (`10/30/2020`).
    fn default_date_order(&self) -> DateOrder {
        DateOrder::MonthDayYear
    }

    fn header_delimiter(&self, head: &HeadLine) -> Option<u8> {
        (head.first.eq_ignore_ascii_case(b"Date") && head.second.eq_ignore_ascii_case(b"Time"))
            .then_some(b'\t')
    }

    fn rows(
        &self,
        det: &Detected,
        _bytes: &[u8],
        _path: &Path,
        _opts: &super::ReadOptions,
    ) -> Result<Rows> {
        let pixels = det.header.iter().filter(|h| h.starts_with("Pixel")).count();
        Ok(Rows {
            channels: 1,
            column_names: Vec::new(),
            parser: Box::new(ImonRows {
                delimiter: det.delimiter,
                decimal_comma: det.decimal_comma(),
                pixels,
            }),
            estimator: None,
        })
    }

    fn write(&self, w: &mut dyn Write, table: &LogTable, _style: &LogStyle) -> std::io::Result<()> {
        write!(w, "Date\tTime\tWavelength 1 [nm]")?;
        for p in 1..=512 {
            write!(w, "\tPixel {p}")?;
        }
        writeln!(w, "\t")?;
        writeln!(w)?;
        for (i, row) in table.wavelength_nm.iter().enumerate() {
            write_date_time(w, table.start_epoch_s + table.time_s[i])?;
            let mut present: Vec<f64> = row.iter().copied().filter(|v| v.is_finite()).collect();
            present.sort_by(|a, b| a.total_cmp(b));
            for v in present {
                write!(w, "\t{:.7}E+3", v / 1e3)?;
            }
            writeln!(w, "\t")?;
        }
        Ok(())
    }
}

/// The date and time of day that open an I-MON row (its first two fields).
pub(crate) fn date_and_time<'a>(
    it: &mut impl Iterator<Item = &'a [u8]>,
) -> Result<(num::RawDate, f64), LineIssue> {
    let d = it.next().unwrap_or(b"");
    let t = it
        .next()
        .ok_or_else(|| issue("unreadable_line", "no time field"))?;
    let (date, n) =
        num::parse_date(trim(d)).ok_or_else(|| issue("unreadable_line", "unreadable date"))?;
    if n != trim(d).len() {
        return Err(issue("unreadable_line", "unreadable date"));
    }
    let sod = num::parse_time_of_day(t)
        .ok_or_else(|| issue("unreadable_line", "unreadable time of day"))?;
    Ok((date, sod))
}

/// An I-MON time stamp: `m/d/yyyy` and a 12-hour time in whole seconds (floored).
pub(crate) fn write_date_time(w: &mut dyn Write, t: f64) -> std::io::Result<()> {
    let days = (t / 86400.0).floor() as i64;
    let (y, m, d) = civil_from_days(days);
    let sod = (t - days as f64 * 86400.0).floor() as u32;
    let (h, mi, s) = (sod / 3600, sod / 60 % 60, sod % 60);
    let (h12, ampm) = match h {
        0 => (12, "AM"),
        1..=11 => (h, "AM"),
        12 => (12, "PM"),
        _ => (h - 12, "PM"),
    };
    write!(w, "{m}/{d}/{y}\t{h12}:{mi:02}:{s:02} {ampm}")
}

/// The rows of an I-MON table whose header names `pixels` spectrum columns.
struct ImonRows {
    delimiter: u8,
    decimal_comma: bool,
    pixels: usize,
}

impl RowParser for ImonRows {
    fn parse(
        &self,
        line: &[u8],
        out: &mut Partial,
        _scratch: &mut Vec<usize>,
    ) -> Result<(), LineIssue> {
        let mut it = line.split(|&c| c == self.delimiter);
        let (date, sod) = date_and_time(&mut it)?;
        let start = out.peaks.len();
        let rest: Vec<&[u8]> = it.map(trim).collect();
        let mut n = rest.len();
        while n > 0 && rest[n - 1].is_empty() {
            n -= 1;
        }
        // Rows that also carry the spectrum end with `pixels` intensities.
        let n_wl = if self.pixels > 0 && n > self.pixels {
            n - self.pixels
        } else {
            n
        };
        for f in &rest[..n_wl] {
            match num::parse_f64(f, self.decimal_comma) {
                Some(v) if v.is_finite() && v > 0.0 => {
                    out.peaks.push(v);
                    out.chans.push(0);
                }
                Some(_) => {}
                None => {
                    out.rollback(start);
                    return Err(issue("unreadable_line", "unreadable wavelength"));
                }
            }
        }
        out.end_row((Some(date), sod));
        Ok(())
    }
}
