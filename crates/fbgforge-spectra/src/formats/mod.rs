//! Spectrum file formats: Luna ENLIGHT / Hyperion spectrum exports, Ibsen I-MON
//! evaluation logs with pixel columns, and OSA / swept-laser CSVs. Readers are pure
//! functions over text; writers produce text that reads back exactly to the printed
//! precision.

mod enlight;
mod imon;
mod osa;
pub(crate) mod text;

use std::io::BufRead;

use crate::error::SpectrumError;
use crate::spectrum::SpectrumLog;

pub use enlight::{read_enlight, write_enlight};
pub use imon::{read_imon, write_imon, ImonWriteOptions, PixelCalibration};
pub use osa::{read_osa_csv, write_osa_csv};

pub use crate::spectrum::SpectrumFormat;

/// How to read a spectrum file.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReadOptions {
    /// Force a format instead of detecting it.
    pub format: Option<SpectrumFormat>,
    /// Pixel-to-wavelength polynomial for I-MON logs (required for them).
    pub imon_calibration: Option<PixelCalibration>,
}

/// Recognises a spectrum format from the first lines of a file (pass at least the first
/// 200 lines: an ENLIGHT metadata block runs to 100 lines and more).
///
/// - ENLIGHT / Hyperion spectrum: a line whose first tab field is `Wvl (nm)`;
/// - I-MON log with pixels: a line starting `Date<TAB>Time<TAB>` that has a `Pixel 1` field
///   (an I-MON log without pixel columns is a peak log, not a spectrum: `None`);
/// - OSA CSV: a line whose first field (`,`, `;` or tab separated) starts with
///   `Wavelength` and which has at least two fields, followed by a numeric line.
///
/// Peak logs (ENLIGHT `Timestamp` tables, force CSVs) give `None`.
pub fn detect(first_lines: &str) -> Option<SpectrumFormat> {
    let lines: Vec<&str> = text::numbered_lines(first_lines).map(|(_, l)| l).collect();
    if lines.iter().any(|l| enlight::is_header(l)) {
        return Some(SpectrumFormat::EnlightSpectrum);
    }
    if lines.iter().any(|l| imon::is_pixel_header(l)) {
        return Some(SpectrumFormat::ImonPixels);
    }
    for (i, line) in lines.iter().enumerate() {
        if osa::is_header(line) {
            let next = lines[i + 1..].iter().find(|l| !l.trim().is_empty());
            if next.is_some_and(|l| osa::looks_numeric(l)) {
                return Some(SpectrumFormat::OsaCsv);
            }
        }
    }
    None
}

/// Reads a spectrum log of any supported format (detected unless `options.format` says).
///
/// ```
/// use fbgforge_spectra::{read_spectrum_log, PowerUnit, ReadOptions, SpectrumFormat};
/// let text = "\nDate: 17/04/2025 4:01:03 pm\nModule Type: Hyperion\nCH 1 Configuration:\n\
///             \tDetect Valley: False\nWvl (nm)\t CH 1 \n\n1550.0000\t-59.5000\n1550.0080\t-40.2500\n";
/// let log = read_spectrum_log(text, &ReadOptions::default()).unwrap();
/// assert_eq!(log.format, SpectrumFormat::EnlightSpectrum);
/// let s = &log.rows[0].spectra[0];
/// assert_eq!((s.channel.as_str(), s.unit), ("CH 1", PowerUnit::Dbm));
/// assert_eq!(s.wavelengths_nm, vec![1550.0, 1550.008]);
/// assert_eq!(s.meta("Detect Valley"), Some("False"));
/// assert_eq!(log.meta("Module Type"), Some("Hyperion"));
/// ```
pub fn read_spectrum_log(text: &str, options: &ReadOptions) -> Result<SpectrumLog, SpectrumError> {
    let format = match options.format {
        Some(f) => f,
        None => {
            let head: String = text.lines().take(400).collect::<Vec<_>>().join("\n");
            detect(&head).ok_or_else(|| {
                SpectrumError::UnknownFormat(
                    "no `Wvl (nm)` header (ENLIGHT spectrum), no `Date<TAB>Time…Pixel 1` header (I-MON log with pixels) \
                     and no `Wavelength (…),…` CSV header in the first 400 lines"
                        .into(),
                )
            })?
        }
    };
    match format {
        SpectrumFormat::EnlightSpectrum => read_enlight(text),
        SpectrumFormat::ImonPixels => read_imon(text, options.imon_calibration.as_ref()),
        SpectrumFormat::OsaCsv => read_osa_csv(text),
    }
}

/// [`read_spectrum_log`] over a reader (the whole input is read first).
pub fn read_spectrum_log_from<R: BufRead>(
    mut reader: R,
    options: &ReadOptions,
) -> Result<SpectrumLog, SpectrumError> {
    let mut bytes = Vec::new();
    reader.read_to_end(&mut bytes)?;
    let text = String::from_utf8_lossy(&bytes);
    read_spectrum_log(&text, options)
}

/// Writes a log in the given format (I-MON needs the calibration its wavelengths came from).
pub fn write_spectrum_log(
    log: &SpectrumLog,
    format: SpectrumFormat,
    imon: Option<&ImonWriteOptions>,
) -> Result<String, SpectrumError> {
    match format {
        SpectrumFormat::EnlightSpectrum => write_enlight(log),
        SpectrumFormat::OsaCsv => write_osa_csv(log),
        SpectrumFormat::ImonPixels => match imon {
            Some(options) => write_imon(log, options),
            None => Err(SpectrumError::Invalid(
                "writing an I-MON log needs its pixel calibration".into(),
            )),
        },
    }
}
