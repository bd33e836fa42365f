//! fbgforge-spectra: fiber Bragg grating spectra in, peaks out, and the spectrum a
//! grating will make.
//!
//! - [`formats`]: readers and writers for Luna ENLIGHT / Hyperion spectrum exports, Ibsen
//!   I-MON logs with pixel columns and OSA / swept-laser CSVs, with [`detect`].
//! - [`peaks`]: peak estimators behind one trait ([`PeakEstimator`]), each peak with its
//!   standard error, Cramér–Rao bound, FWHM, SNR and quality flags; [`find_peaks`] and
//!   [`match_gratings`].
//! - [`grating`]: transfer-matrix (coupled-mode) reflection spectrum of a grating under a
//!   strain profile ([`grating_spectrum`]), its shape summary and the force at which it
//!   stops being one clean peak.
//! - [`synth`]: synthetic spectra with known truth in every format.

// `!(x > 0.0)` is meant: NaN must fail every such check.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod error;
pub mod formats;
pub mod spectrum;
pub mod stats;

pub use error::SpectrumError;
pub use formats::{
    detect, read_enlight, read_imon, read_osa_csv, read_spectrum_log, read_spectrum_log_from,
    write_enlight, write_imon, write_osa_csv, write_spectrum_log, ImonWriteOptions,
    PixelCalibration, ReadOptions, SpectrumFormat,
};
pub use spectrum::{PowerUnit, Spectrum, SpectrumLog, SpectrumRow};
pub mod grating;
pub mod peaks;
pub mod synth;

pub use grating::{
    clean_peak_limit, grating_spectrum, spectrum_shape, Apodisation, CleanPeakCriteria,
    CleanPeakLimit, Grating, LoadCase, SpectrumShape, StrainProfile,
};
pub use peaks::{
    find_grating_peaks, find_peaks, match_gratings, EstimatorChoice, ExpectedGrating, FindOptions,
    MatchedPeak, Peak, PeakEstimate, PeakEstimator, PeakFlags, PeakWindow,
};
