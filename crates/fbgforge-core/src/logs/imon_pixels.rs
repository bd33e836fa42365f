//! An Ibsen I-MON evaluation log read by its pixels: each row's `Pixel 1 … Pixel P`
//! counts are a spectrum on the wavelengths the pixel calibration gives
//! ([`super::ReadOptions::imon_calibration`]), whose peaks are found row by row (in
//! parallel chunks, like every log) with the estimator the reading names. Dates and
//! times are read as in the I-MON peak log (`imon.rs`), so a log read by its pixels
//! and by the software's own peak cells has the same rows and times.

use super::detect::{Detected, HeadLine};
use super::imon::{date_and_time, write_date_time};
use super::num::{self, trim, DateOrder};
use super::rows::{issue, lines_with_offsets, LineIssue, Partial};
use super::spectrum::{imon_calibration, Estimator, LineShape as Shape, SpectrumStyle};
use super::{LogReader, LogStyle, LogTable, PeakQuality, ReadOptions, RowParser, Rows};
use anyhow::{anyhow, Result};
use fbgforge_spectra as spectra;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use spectra::{FindOptions, PixelCalibration, PowerUnit, Spectrum};
use std::io::Write;
use std::path::Path;

/// The I-MON-with-pixels format.
pub(crate) struct ImonPixels;

/// The registry's entry.
pub(crate) const IMON_PIXELS: ImonPixels = ImonPixels;

impl LogReader for ImonPixels {
    fn name(&self) -> &'static str {
        "imon-pixels"
    }

    fn title(&self) -> &'static str {
        "I-MON log with pixels"
    }

    fn expected(&self) -> &'static str {
        "a line `Date<TAB>Time<TAB>Wavelength 1 [nm]<TAB>Pixel 1<TAB>…` and the pixel calibration"
    }

    /// I-MON 512E: < 0.5 pm.
    fn typical_resolution_pm(&self) -> f64 {
        0.5
    }

    fn default_date_order(&self) -> DateOrder {
        DateOrder::MonthDayYear
    }

    /// Never found by its header alone: an I-MON header is the I-MON peak log's unless a
    /// calibration is given (`spectrum::detect_table`).
    fn header_delimiter(&self, _head: &HeadLine) -> Option<u8> {
        None
    }

    fn rows(&self, det: &Detected, bytes: &[u8], path: &Path, opts: &ReadOptions) -> Result<Rows> {
        let first_pixel = det
            .header
            .iter()
            .position(|h| h == "Pixel 1")
            .ok_or_else(|| {
                anyhow!(
                    "{}: the I-MON header names no `Pixel 1` column",
                    path.display()
                )
            })?;
        let pixels = det.header[first_pixel..]
            .iter()
            .take_while(|h| h.starts_with("Pixel "))
            .count();
        let calibration = imon_calibration(opts)?.ok_or_else(|| {
            anyhow!(
                "{}: reading an I-MON log's pixels needs ReadOptions.imon_calibration",
                path.display()
            )
        })?;
        let mut wavelengths_nm = calibration.pixel_wavelengths_nm(pixels).map_err(|e| {
            anyhow!(
                "ReadOptions.imon_calibration over the {pixels} pixels of {}: {e}",
                path.display()
            )
        })?;
        let reverse = wavelengths_nm[1] < wavelengths_nm[0];
        if reverse {
            wavelengths_nm.reverse();
        }
        let (estimator, name) = Estimator::of(opts)?;
        let mut parser = PixelRows {
            delimiter: det.delimiter,
            decimal_comma: det.decimal_comma(),
            pixels,
            wavelengths_nm,
            reverse,
            options: FindOptions::default(),
        };
        // The first row's spectrum: the templates of `xcorr` (taken as unloaded).
        let first = lines_with_offsets(&bytes[det.body_offset.min(bytes.len())..])
            .map(|(_, l)| l)
            .find(|l| !trim(l).is_empty() && !l.starts_with(b"#"));
        parser.options = match (first, &estimator) {
            (Some(line), _) => {
                let spectrum = parser
                    .spectrum(line)
                    .map_err(|e| anyhow!("{}:{}: {}", path.display(), det.body_line, e.message))?;
                estimator.options_for(&spectrum)?
            }
            (None, Estimator::Plain(choice)) => FindOptions {
                estimator: choice.clone(),
                ..FindOptions::default()
            },
            (None, Estimator::Xcorr) => {
                anyhow::bail!(
                    "{}: no row yet to take the xcorr templates from",
                    path.display()
                )
            }
        };
        Ok(Rows {
            channels: 1,
            column_names: Vec::new(),
            parser: Box::new(parser),
            estimator: Some(name),
        })
    }

    fn write(&self, w: &mut dyn Write, table: &LogTable, style: &LogStyle) -> std::io::Result<()> {
        write_pixels(w, table, &style.spectrum)
    }
}

/// The rows of an I-MON log read by their pixels.
struct PixelRows {
    delimiter: u8,
    decimal_comma: bool,
    pixels: usize,
    /// The pixels' wavelengths, increasing.
    wavelengths_nm: Vec<f64>,
    /// The file's pixels run from long to short wavelengths.
    reverse: bool,
    options: FindOptions,
}

impl PixelRows {
    /// The counts at the end of a row (after its date, time and wavelength cells), in
    /// increasing wavelength.
    fn counts<'a>(&self, fields: impl Iterator<Item = &'a [u8]>) -> Result<Vec<f64>, LineIssue> {
        let rest: Vec<&[u8]> = fields.map(trim).collect();
        let mut n = rest.len();
        while n > 0 && rest[n - 1].is_empty() {
            n -= 1;
        }
        if n < self.pixels + 1 {
            return Err(issue(
                "unreadable_line",
                format!(
                    "{n} fields after the time; expected at least one wavelength cell and the {} pixel counts",
                    self.pixels
                ),
            ));
        }
        let mut counts = Vec::with_capacity(self.pixels);
        for (k, f) in rest[n - self.pixels..n].iter().enumerate() {
            match num::parse_f64(f, self.decimal_comma) {
                Some(v) if v.is_finite() => counts.push(v),
                _ => {
                    return Err(issue(
                        "unreadable_line",
                        format!("pixel {} is not a count", k + 1),
                    ))
                }
            }
        }
        if self.reverse {
            counts.reverse();
        }
        Ok(counts)
    }

    /// The spectrum of one row.
    fn spectrum(&self, line: &[u8]) -> Result<Spectrum, LineIssue> {
        let mut it = line.split(|&c| c == self.delimiter);
        date_and_time(&mut it)?;
        let counts = self.counts(it)?;
        Spectrum::new(
            "I-MON",
            self.wavelengths_nm.clone(),
            counts,
            PowerUnit::Counts,
        )
        .map_err(|e| issue("unreadable_line", e.to_string()))
    }
}

impl RowParser for PixelRows {
    fn parse(
        &self,
        line: &[u8],
        out: &mut Partial,
        _scratch: &mut Vec<usize>,
    ) -> Result<(), LineIssue> {
        let mut it = line.split(|&c| c == self.delimiter);
        let (date, sod) = date_and_time(&mut it)?;
        let counts = self.counts(it)?;
        let peaks = spectra::peaks::find_peaks_in(&self.wavelengths_nm, &counts, &self.options)
            .map_err(|e| issue("unreadable_spectrum", e.to_string()))?;
        for p in &peaks {
            out.peaks.push(p.wavelength_nm);
            out.chans.push(0);
            out.quality.push(PeakQuality::from(p));
        }
        out.end_row((Some(date), sod));
        Ok(())
    }
}

/// One column's reflection line shape: the unstrained spectrum on a fine grid around
/// its peak (a transfer-matrix grating, or a Gaussian), shifted to each row's
/// wavelength (uniform strain shifts the spectrum without changing its shape, to
/// first order in the strain).
struct LineShape {
    /// Offsets from the peak, nm (increasing, uniform step).
    offset_nm: Vec<f64>,
    /// Reflectivity over its maximum at each offset.
    relative: Vec<f64>,
}

impl LineShape {
    fn gaussian(fwhm_nm: f64) -> Self {
        let s = fwhm_nm / spectra::peaks::FWHM_PER_SIGMA;
        let offset_nm: Vec<f64> = (-2000..=2000).map(|k| f64::from(k) * 4e-3 * s).collect();
        let relative = offset_nm
            .iter()
            .map(|d| (-0.5 * (d / s).powi(2)).exp())
            .collect();
        LineShape {
            offset_nm,
            relative,
        }
    }

    fn grating(g: &spectra::Grating) -> std::io::Result<Self> {
        let half = 4.0 * g.uniform_bandwidth_nm();
        let step = g.uniform_bandwidth_nm() / 400.0;
        let n = (2.0 * half / step) as i64;
        let grid: Vec<f64> = (0..=n)
            .map(|k| g.bragg_wavelength_nm - half + k as f64 * step)
            .collect();
        let r = spectra::grating_spectrum(g, &spectra::StrainProfile::Uniform(0.0), &grid)
            .map_err(|e| std::io::Error::other(e.to_string()))?
            .power;
        let (imax, rmax) =
            r.iter()
                .copied()
                .enumerate()
                .fold((0, 0.0), |m, (i, v)| if v > m.1 { (i, v) } else { m });
        let peak = grid[imax];
        Ok(LineShape {
            offset_nm: grid.iter().map(|l| l - peak).collect(),
            relative: r.iter().map(|v| v / rmax.max(f64::MIN_POSITIVE)).collect(),
        })
    }

    /// The relative reflectivity `d` nm from the peak (0 beyond the table).
    fn at(&self, d: f64) -> f64 {
        let (x, y) = (&self.offset_nm, &self.relative);
        if d <= x[0] || d >= x[x.len() - 1] {
            return 0.0;
        }
        let step = x[1] - x[0];
        let k = (((d - x[0]) / step) as usize).min(x.len() - 2);
        let t = (d - x[k]) / step;
        y[k] + t * (y[k + 1] - y[k])
    }
}

/// Write `table` as an I-MON log with pixels: each row's spectrum is the floor plus
/// one line per present peak (height `peak_counts`) plus white noise, on the pixels of
/// `style.imon_calibration`; the wavelength cells hold the table's own wavelengths (the
/// truth), so the same file read without a calibration is the equivalent peak log.
fn write_pixels(w: &mut dyn Write, table: &LogTable, style: &SpectrumStyle) -> std::io::Result<()> {
    let invalid = |e: String| std::io::Error::new(std::io::ErrorKind::InvalidInput, e);
    let cal = PixelCalibration::new(style.imon_calibration.clone())
        .map_err(|e| invalid(e.to_string()))?;
    let pixel_nm = cal
        .pixel_wavelengths_nm(style.pixels)
        .map_err(|e| invalid(e.to_string()))?;
    let shapes = match &style.line_shape {
        Shape::Gaussian { fwhm_nm } => (0..table.names.len())
            .map(|_| LineShape::gaussian(*fwhm_nm))
            .collect(),
        Shape::Gratings(g) if g.len() == table.names.len() => {
            g.iter()
                .map(LineShape::grating)
                .collect::<std::io::Result<Vec<_>>>()?
        }
        Shape::Gratings(g) => {
            return Err(invalid(format!(
                "{} gratings for the {} columns of the table",
                g.len(),
                table.names.len()
            )))
        }
        Shape::Design => {
            return Err(invalid(
                "the design's gratings were not resolved into line shapes".into(),
            ))
        }
    };
    write!(w, "Date\tTime\tWavelength 1 [nm]")?;
    for p in 1..=style.pixels {
        write!(w, "\tPixel {p}")?;
    }
    writeln!(w, "\t")?;
    writeln!(w)?;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(style.seed);
    let noise =
        Normal::new(0.0, style.noise_counts.max(0.0)).map_err(|e| invalid(e.to_string()))?;
    let cells = table
        .wavelength_nm
        .iter()
        .map(|r| r.iter().filter(|v| v.is_finite()).count())
        .max()
        .unwrap_or(1)
        .max(1);
    for (i, row) in table.wavelength_nm.iter().enumerate() {
        write_date_time(w, table.start_epoch_s + table.time_s[i])?;
        let mut present: Vec<f64> = row.iter().copied().filter(|v| v.is_finite()).collect();
        present.sort_by(|a, b| a.total_cmp(b));
        for k in 0..cells {
            match present.get(k) {
                Some(v) => write!(w, "\t{:.7}E+3", v / 1e3)?,
                None => write!(w, "\t0.0000000E+0")?,
            }
        }
        for &l in &pixel_nm {
            let line: f64 = row
                .iter()
                .zip(&shapes)
                .filter(|(v, _)| v.is_finite())
                .map(|(v, s)| s.at(l - v))
                .sum();
            let c = style.floor_counts + style.peak_counts * line + noise.sample(&mut rng);
            write!(w, "\t{}", counts_text(c.max(0.0)))?;
        }
        writeln!(w, "\t")?;
    }
    Ok(())
}

/// A count as the I-MON software writes it: four significant digits, `1.349E+3`.
pub(crate) fn counts_text(c: f64) -> String {
    if c < 1.0 {
        return "0.000E+0".into();
    }
    let e = c.log10().floor() as i32;
    let mut m = (c / 10f64.powi(e) * 1e3).round() / 1e3;
    let mut e = e;
    if m >= 10.0 {
        m /= 10.0;
        e += 1;
    }
    format!("{m:.3}E+{e}")
}
