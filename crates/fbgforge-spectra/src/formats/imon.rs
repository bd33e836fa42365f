//! Ibsen I-MON evaluation-software log with pixel columns.
//!
//! ```text
//! Date<TAB>Time<TAB>Wavelength 1 [nm]<TAB>Pixel 1<TAB>…<TAB>Pixel 512<TAB>
//! <blank>
//! 10/30/2020<TAB>4:44:10 PM<TAB>1.5303003E+3<TAB>0.000E+0<TAB>1.349E+3<TAB>…
//! ```
//!
//! Each row: month-first date, 12-hour time with whole seconds, one or more peak
//! wavelengths the I-MON software found (padded with `0.0000000E+0`), then one count per
//! `Pixel n` header column. The pixels run in reverse wavelength order on the
//! instrument; the file does not say how pixels map to wavelengths, so the polynomial
//! is an input.

use serde::{Deserialize, Serialize};

use super::text::{self, DateOrder};
use crate::error::{parse_error, SpectrumError};
use crate::formats::SpectrumFormat;
use crate::spectrum::{PowerUnit, Spectrum, SpectrumLog, SpectrumRow};

/// The most peak-wavelength cells a row may carry before its pixels (real files: 1, 2, 38).
pub const MAX_WAVELENGTH_CELLS: usize = 64;

/// Pixel-to-wavelength polynomial λ(p) = a0 + a1·p + a2·p² + …, nm, with p the pixel
/// index from 1 as the header writes it (`Pixel 1` is p = 1), pixels in the file's order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PixelCalibration {
    /// a0, a1, … in nm, nm/pixel, nm/pixel², …
    pub coefficients_nm: Vec<f64>,
}

impl PixelCalibration {
    /// A polynomial from its coefficients (at least a0 and a1, all finite).
    pub fn new(coefficients_nm: Vec<f64>) -> Result<Self, SpectrumError> {
        if coefficients_nm.len() < 2 || coefficients_nm.iter().any(|c| !c.is_finite()) {
            return Err(SpectrumError::Calibration(format!(
                "need at least two finite coefficients a0,a1 (nm), got {coefficients_nm:?}"
            )));
        }
        Ok(PixelCalibration { coefficients_nm })
    }

    /// Parses `a0,a1,…` (as given on a command line).
    pub fn parse(text: &str) -> Result<Self, SpectrumError> {
        let coefficients = text
            .split(',')
            .map(|c| {
                c.trim().parse::<f64>().map_err(|_| {
                    SpectrumError::Calibration(format!(
                        "`{}` in `{text}` is not a number",
                        c.trim()
                    ))
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        Self::new(coefficients)
    }

    /// The linear map with `Pixel 1` at `first_pixel_nm` and `Pixel P` at `last_pixel_nm`
    /// (for an I-MON 512 about 1595 → 1510 nm: reverse order).
    pub fn linear(
        first_pixel_nm: f64,
        last_pixel_nm: f64,
        pixels: usize,
    ) -> Result<Self, SpectrumError> {
        if pixels < 2 {
            return Err(SpectrumError::Calibration("need at least 2 pixels".into()));
        }
        let a1 = (last_pixel_nm - first_pixel_nm) / (pixels as f64 - 1.0);
        Self::new(vec![first_pixel_nm - a1, a1])
    }

    /// λ(p), nm.
    pub fn wavelength_nm(&self, pixel: f64) -> f64 {
        self.coefficients_nm
            .iter()
            .rev()
            .fold(0.0, |acc, &c| acc * pixel + c)
    }

    /// λ(1), …, λ(P) in the file's pixel order; an error unless strictly monotonic.
    pub fn pixel_wavelengths_nm(&self, pixels: usize) -> Result<Vec<f64>, SpectrumError> {
        let w: Vec<f64> = (1..=pixels).map(|p| self.wavelength_nm(p as f64)).collect();
        let increasing = w.windows(2).all(|p| p[1] > p[0]);
        let decreasing = w.windows(2).all(|p| p[1] < p[0]);
        if pixels < 2 || !(increasing || decreasing) {
            return Err(SpectrumError::Calibration(format!(
                "{self} is not strictly monotonic over pixels 1…{pixels}"
            )));
        }
        Ok(w)
    }
}

impl std::fmt::Display for PixelCalibration {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let parts: Vec<String> = self
            .coefficients_nm
            .iter()
            .map(|c| format!("{c}"))
            .collect();
        write!(f, "{}", parts.join(","))
    }
}

/// How to write an I-MON log.
#[derive(Debug, Clone, PartialEq)]
pub struct ImonWriteOptions {
    /// The polynomial the spectra's wavelengths came from (pixel order is its order).
    pub calibration: PixelCalibration,
    /// Peak-wavelength cells per row, padded with `0.0000000E+0` (at least the row's
    /// reported peaks, at least 1).
    pub wavelength_cells: usize,
}

pub(crate) fn is_pixel_header(line: &str) -> bool {
    let f = text::fields(line, '\t');
    f.len() > 3 && f[0] == "Date" && f[1] == "Time" && f.contains(&"Pixel 1")
}

/// Number of `Pixel n` columns, checked to run 1, 2, …, P at the end of the header.
fn pixel_columns(header: &[&str], line: usize) -> Result<usize, SpectrumError> {
    let first = header
        .iter()
        .position(|f| f.starts_with("Pixel "))
        .ok_or_else(|| {
            SpectrumError::UnknownFormat(
                "I-MON header without `Pixel n` columns: a peak log, not a spectrum log".into(),
            )
        })?;
    for (k, field) in header[first..].iter().enumerate() {
        if *field != format!("Pixel {}", k + 1) {
            return Err(parse_error(
                line,
                format!("header column `Pixel {}`", k + 1),
                field,
            ));
        }
    }
    Ok(header.len() - first)
}

struct RawRow {
    line: usize,
    date: (i64, i64, i64),
    time: String,
    reported: Vec<f64>,
    pixels: Vec<f64>,
}

fn read_row(line: &str, number: usize, pixels: usize) -> Result<RawRow, SpectrumError> {
    let f = text::fields(line, '\t');
    let n = f.len();
    if n < 3 + pixels || n > 2 + MAX_WAVELENGTH_CELLS + pixels {
        return Err(SpectrumError::Ragged {
            line: number,
            expected: format!("date, time, 1 to {MAX_WAVELENGTH_CELLS} wavelengths and {pixels} pixel counts: {} to {}", 3 + pixels, 2 + MAX_WAVELENGTH_CELLS + pixels),
            found: n,
        });
    }
    let date = text::date_parts(f[0])
        .ok_or_else(|| parse_error(number, "a date like 10/30/2020", f[0]))?;
    if text::time_of_day_s(f[1]).is_none() {
        return Err(parse_error(number, "a time like 4:44:10 PM", f[1]));
    }
    let cells = n - 2 - pixels;
    let mut reported = Vec::new();
    for field in &f[2..2 + cells] {
        let w = text::parse_number(field, number, "peak wavelength, nm", true)?;
        if w != 0.0 {
            reported.push(w);
        }
    }
    let counts = f[2 + cells..]
        .iter()
        .map(|field| text::parse_number(field, number, "pixel count", true))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(RawRow {
        line: number,
        date,
        time: f[1].to_string(),
        reported,
        pixels: counts,
    })
}

/// Reads an I-MON evaluation log with pixel columns: one row per acquisition, one
/// spectrum (`I-MON`, counts) per row on the wavelengths the polynomial gives, sorted to
/// increase (the pixel values follow). The row's own peak wavelengths (non-zero cells)
/// go to `reported_peaks_nm`. Dates are month-first unless one in the file has a first
/// number above 12.
pub fn read_imon(
    text: &str,
    calibration: Option<&PixelCalibration>,
) -> Result<SpectrumLog, SpectrumError> {
    let mut lines = text::numbered_lines(text).filter(|(_, l)| !l.trim().is_empty());
    let (header_line, header) = lines
        .next()
        .ok_or_else(|| SpectrumError::UnknownFormat("empty file".into()))?;
    let header_fields = text::fields(header, '\t');
    if header_fields.len() < 3 || header_fields[0] != "Date" || header_fields[1] != "Time" {
        return Err(parse_error(
            header_line,
            "the I-MON header `Date<TAB>Time<TAB>Wavelength 1 [nm]<TAB>Pixel 1…`",
            header,
        ));
    }
    let pixels = pixel_columns(&header_fields, header_line)?;
    let calibration = calibration.ok_or(SpectrumError::MissingCalibration { pixels })?;
    let mut wavelengths = calibration.pixel_wavelengths_nm(pixels)?;
    let reverse = wavelengths[1] < wavelengths[0];
    if reverse {
        wavelengths.reverse();
    }
    let raw = lines
        .map(|(n, l)| read_row(l, n, pixels))
        .collect::<Result<Vec<_>, _>>()?;
    let order = if raw.iter().any(|r| r.date.0 > 12) {
        DateOrder::DayFirst
    } else {
        DateOrder::MonthFirst
    };
    let mut rows = Vec::with_capacity(raw.len());
    for r in raw {
        let time_s = text::date_time_s(r.date, &r.time, order).ok_or_else(|| {
            parse_error(
                r.line,
                "a valid date and time",
                &format!("{}/{}/{} {}", r.date.0, r.date.1, r.date.2, r.time),
            )
        })?;
        let mut power = r.pixels;
        if reverse {
            power.reverse();
        }
        let spectrum = Spectrum {
            channel: "I-MON".into(),
            wavelengths_nm: wavelengths.clone(),
            power,
            unit: PowerUnit::Counts,
            metadata: Vec::new(),
        };
        rows.push(SpectrumRow {
            time_s,
            spectra: vec![spectrum],
            reported_peaks_nm: r.reported,
        });
    }
    Ok(SpectrumLog {
        format: SpectrumFormat::ImonPixels,
        metadata: vec![
            ("pixels".into(), pixels.to_string()),
            ("pixel calibration (nm)".into(), calibration.to_string()),
        ],
        rows,
    })
}

/// Writes an I-MON evaluation log with pixel columns: each row's single spectrum must lie
/// on the calibration's pixel wavelengths (any pixel count); pixels are written in the
/// calibration's order, counts as `1.349E+3` (4 significant digits, as the I-MON software
/// writes them), peak wavelengths as `1.5303003E+3`, time as whole seconds (floored).
pub fn write_imon(log: &SpectrumLog, options: &ImonWriteOptions) -> Result<String, SpectrumError> {
    let first = log
        .rows
        .first()
        .and_then(|r| r.spectra.first())
        .ok_or_else(|| SpectrumError::Invalid("the log holds no spectrum".into()))?;
    let pixels = first.len();
    let file_order = options.calibration.pixel_wavelengths_nm(pixels)?;
    let reverse = file_order[1] < file_order[0];
    let mut out = String::from("Date\tTime\tWavelength 1 [nm]\t");
    for p in 1..=pixels {
        out.push_str(&format!("Pixel {p}\t"));
    }
    out.push_str("\n\n");
    for (i, row) in log.rows.iter().enumerate() {
        let s = match row.spectra.as_slice() {
            [s] => s,
            other => {
                return Err(SpectrumError::Invalid(format!(
                    "row {i}: an I-MON row holds one spectrum, not {}",
                    other.len()
                )))
            }
        };
        check_on_pixels(s, &file_order, reverse, i)?;
        let (date, time) = text::format_date_time(row.time_s, DateOrder::MonthFirst, false);
        out.push_str(&format!("{date}\t{time}"));
        let cells = options
            .wavelength_cells
            .max(row.reported_peaks_nm.len())
            .max(1);
        for k in 0..cells {
            let w = row.reported_peaks_nm.get(k).copied().unwrap_or(0.0);
            out.push('\t');
            out.push_str(&text::fmt_sci(w, 7));
        }
        let mut push = |v: f64| {
            out.push('\t');
            out.push_str(&text::fmt_sci(v, 3));
        };
        if reverse {
            s.power.iter().rev().for_each(|&v| push(v));
        } else {
            s.power.iter().for_each(|&v| push(v));
        }
        out.push('\n');
    }
    Ok(out)
}

fn check_on_pixels(
    s: &Spectrum,
    file_order: &[f64],
    reverse: bool,
    row: usize,
) -> Result<(), SpectrumError> {
    if !matches!(s.unit, PowerUnit::Counts | PowerUnit::Linear) {
        return Err(SpectrumError::Invalid(format!(
            "row {row}: I-MON pixels are counts, the spectrum is in {}",
            s.unit.label()
        )));
    }
    if s.len() != file_order.len() {
        return Err(SpectrumError::Invalid(format!(
            "row {row}: {} samples, the first row has {}",
            s.len(),
            file_order.len()
        )));
    }
    let n = file_order.len();
    for (k, w) in s.wavelengths_nm.iter().enumerate() {
        let expected = if reverse {
            file_order[n - 1 - k]
        } else {
            file_order[k]
        };
        if (w - expected).abs() > 1e-9 * expected.abs().max(1.0) {
            return Err(SpectrumError::Invalid(format!(
                "row {row}: sample {k} at {w} nm is not on the calibration's pixel wavelength {expected} nm"
            )));
        }
    }
    Ok(())
}
