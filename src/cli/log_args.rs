//! How a wavelength log is read, as the flags say: the format, the date order and the
//! spectrum flags that every command reading a log shares (`verify`, `calibrate-array`,
//! `peaks`, `live`, `reconstruct --log`).

use clap::{Args, ValueEnum};
use fbgforge::logs::{num::DateOrder, LogFormat, ReadOptions};

/// The request fields these flags fill (`cli::hiargs`).
pub const FLAGS: &[(&str, &str)] = &[
    ("ReadOptions.imon_calibration", "--imon-calibration"),
    ("ReadOptions.estimator", "--estimator"),
];

/// Wavelength log format on the command line ([`LogFormat`], the library's).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum LogFormatArg {
    /// ENLIGHT "Peaks" export: timestamp, peak count per channel, then the peaks.
    EnlightPeaks,
    /// ENLIGHT "Sensors" export: timestamp then one column per sensor.
    EnlightSensors,
    /// Ibsen I-MON log: date, time, then a varying number of wavelengths.
    Imon,
    /// Plain CSV (or TSV / semicolon-separated): time then wavelength columns, nm.
    Csv,
    /// I-MON log read by its pixel columns (needs --imon-calibration).
    ImonPixels,
    /// Luna ENLIGHT / Hyperion spectrum export (one acquisition).
    EnlightSpectrum,
    /// OSA / swept-laser CSV (one acquisition).
    OsaCsv,
}

impl From<LogFormatArg> for LogFormat {
    fn from(f: LogFormatArg) -> Self {
        match f {
            LogFormatArg::EnlightPeaks => LogFormat::EnlightPeaks,
            LogFormatArg::EnlightSensors => LogFormat::EnlightSensors,
            LogFormatArg::Imon => LogFormat::Imon,
            LogFormatArg::Csv => LogFormat::Csv,
            LogFormatArg::ImonPixels => LogFormat::ImonPixels,
            LogFormatArg::EnlightSpectrum => LogFormat::EnlightSpectrum,
            LogFormatArg::OsaCsv => LogFormat::OsaCsv,
        }
    }
}

/// Day/month order on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum DateOrderArg {
    /// 17/04/2025.
    Dmy,
    /// 04/17/2025.
    Mdy,
}

/// The library's day/month order.
pub fn date_order(d: DateOrderArg) -> DateOrder {
    match d {
        DateOrderArg::Dmy => DateOrder::DayMonthYear,
        DateOrderArg::Mdy => DateOrder::MonthDayYear,
    }
}

/// How to read a wavelength log, as the flags say.
pub fn read_options(
    format: Option<LogFormatArg>,
    d: Option<DateOrderArg>,
    spectrum: &SpectrumArgs,
) -> ReadOptions {
    ReadOptions {
        format: format.map(LogFormat::from),
        date_order: d.map(date_order),
        imon_calibration: spectrum.calibration(),
        estimator: spectrum.estimator(),
    }
}

/// A peak estimator on the command line (`fbgforge::logs::estimator_names`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum EstimatorArg {
    /// Gaussian least squares (the default: within 2× the Cramér–Rao bound wherever it
    /// can be met).
    Gaussian,
    /// 3-point parabola on log power (as good at 1.5–2 samples per FWHM, ~65× faster).
    Parabola,
    /// Centroid over the half maximum (pixel-locked on narrow peaks).
    Centroid,
    /// Cross-correlation with each grating's spectrum in the first acquisition.
    Xcorr,
}

impl EstimatorArg {
    fn name(self) -> &'static str {
        match self {
            EstimatorArg::Gaussian => "gaussian",
            EstimatorArg::Parabola => "parabola",
            EstimatorArg::Centroid => "centroid",
            EstimatorArg::Xcorr => "xcorr",
        }
    }
}

/// How spectra are read: the flags every command reading a wavelength log takes.
#[derive(Debug, Clone, Default, Args)]
pub struct SpectrumArgs {
    /// I-MON pixel-to-wavelength polynomial a0,a1,… (nm; pixel index from 1 as the
    /// header writes it, pixels in the file's order). With it an I-MON log's pixel
    /// columns are read as spectra and their peaks found; without it the peaks the
    /// I-MON software wrote are read.
    #[arg(
        long,
        value_name = "A0,A1,…",
        value_delimiter = ',',
        allow_negative_numbers = true
    )]
    pub imon_calibration: Vec<f64>,
    /// Peak estimator for spectra (default: gaussian).
    #[arg(long, value_enum)]
    pub estimator: Option<EstimatorArg>,
}

impl SpectrumArgs {
    /// The library's calibration (`None` when not given).
    pub fn calibration(&self) -> Option<Vec<f64>> {
        (!self.imon_calibration.is_empty()).then(|| self.imon_calibration.clone())
    }

    /// The library's estimator name.
    pub fn estimator(&self) -> Option<String> {
        self.estimator.map(|e| e.name().to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The command line's format names are the library's registered ones, every
    /// format has one, in the library's order.
    #[test]
    fn registered_names_are_the_command_line_names() {
        let args = LogFormatArg::value_variants();
        let all: Vec<LogFormat> = LogFormat::ALL
            .into_iter()
            .chain(LogFormat::SPECTRA)
            .collect();
        assert_eq!(args.len(), all.len());
        for (arg, &format) in args.iter().zip(&all) {
            let cli = arg.to_possible_value().expect("every format is a value");
            assert_eq!(cli.get_name(), format.name());
            assert_eq!(LogFormat::from(*arg), format);
        }
    }
}
