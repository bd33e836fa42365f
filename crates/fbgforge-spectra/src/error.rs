//! The one error type of the crate. Every reader error names the 1-based line of the
//! file and what was expected there; no reader panics on malformed input.

use thiserror::Error;

/// What went wrong while reading, writing or analysing a spectrum.
#[derive(Debug, Error)]
pub enum SpectrumError {
    /// A line could not be read as the format requires.
    #[error("line {line}: expected {expected}, found {found:?}")]
    Parse {
        /// 1-based line number in the file.
        line: usize,
        /// What the reader expected at that place.
        expected: String,
        /// The offending text (shortened when long).
        found: String,
    },
    /// A row holds a different number of values than the header declares.
    #[error("line {line}: expected {expected}, found {found} values")]
    Ragged {
        /// 1-based line number in the file.
        line: usize,
        /// The number (or range) of values the header asks for.
        expected: String,
        /// How many values the row holds.
        found: usize,
    },
    /// Wavelengths neither strictly increase nor strictly decrease.
    #[error("line {line}: wavelengths must change monotonically (strictly increasing or strictly decreasing): {previous_nm} nm is followed by {current_nm} nm")]
    NotMonotonic {
        /// 1-based line number of the wavelength that breaks the order.
        line: usize,
        /// The wavelength before it, nm.
        previous_nm: f64,
        /// The wavelength on that line, nm.
        current_nm: f64,
    },
    /// An I-MON log with pixel columns was read without the pixel-to-wavelength polynomial.
    #[error("the I-MON log has {pixels} pixel columns but no pixel-to-wavelength polynomial was given: pass the calibration a0,a1,… (nm, pixel index from 1 as written in the header, pixels in the file's order)")]
    MissingCalibration {
        /// Number of `Pixel n` columns in the header.
        pixels: usize,
    },
    /// The pixel-to-wavelength polynomial is unusable (not monotonic over the pixels…).
    #[error("pixel-to-wavelength polynomial: {0}")]
    Calibration(String),
    /// The text matches none of the spectrum formats.
    #[error("not a spectrum file this crate reads: {0}")]
    UnknownFormat(String),
    /// An argument or a data structure that cannot be used (writers, estimators, model).
    #[error("{0}")]
    Invalid(String),
    /// A peak estimator could not produce an estimate for this window.
    #[error("{estimator}: {reason}")]
    Estimate {
        /// The estimator's name.
        estimator: &'static str,
        /// Why it failed.
        reason: String,
    },
    /// Reading from a `BufRead` failed.
    #[error("I/O: {0}")]
    Io(#[from] std::io::Error),
}

/// Short form of a text for an error message (at most 60 characters).
pub(crate) fn shorten(text: &str) -> String {
    let mut out: String = text.chars().take(60).collect();
    if text.chars().count() > 60 {
        out.push('…');
    }
    out
}

pub(crate) fn parse_error(line: usize, expected: impl Into<String>, found: &str) -> SpectrumError {
    SpectrumError::Parse {
        line,
        expected: expected.into(),
        found: shorten(found),
    }
}
