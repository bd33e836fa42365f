//! `fbgforge peaks`: a spectrum file's peaks with their uncertainty (the work is
//! `fbgforge::logs::peaks::run`), and the spectrum flags every command that reads a
//! wavelength log shares ([`SpectrumArgs`]).

use anyhow::Result;
use clap::{Args, ValueEnum};
use fbgforge::logs::peaks::{self, PeaksRequest};
use fbgforge::report::peaks::{json, summary_text};
use std::path::PathBuf;

/// This subcommand's request fields and the flags that fill them (`cli::hiargs`); the
/// spectrum flags serve `verify`, `calibrate-array` and `live` too.
pub const FLAGS: &[(&str, &str)] = &[
    ("ReadOptions.imon_calibration", "--imon-calibration"),
    ("ReadOptions.estimator", "--estimator"),
    ("PeaksRequest.window_half_width_nm", "--window-nm"),
    ("PeaksRequest.out", "--out"),
];

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

/// Arguments of `fbgforge peaks`.
#[derive(Debug, Args)]
pub struct PeaksArgs {
    /// Spectrum file: a Luna ENLIGHT / Hyperion spectrum export, an I-MON log with
    /// pixel columns (needs --imon-calibration) or an OSA CSV.
    pub spectrum: PathBuf,
    /// Design spec (TOML) or a shipped design's name: match the peaks to its gratings.
    #[arg(long, value_parser = super::designs::design_arg)]
    pub design: Option<PathBuf>,
    /// Format of the spectrum file (detected if omitted).
    #[arg(long, value_enum)]
    pub format: Option<super::verify::LogFormatArg>,
    #[command(flatten)]
    pub spectrum_args: SpectrumArgs,
    /// Half-width of each grating's window, nm (default: half the smallest spacing, at
    /// most 2.5 nm).
    #[arg(long)]
    pub window_nm: Option<f64>,
    /// Write the peaks as a log the other commands read (CSV: time, then per grating its
    /// wavelength and standard error; the estimator named in a comment).
    #[arg(long, value_name = "PEAKS.csv")]
    pub out: Option<PathBuf>,
    /// Print `{format, estimator, rows: [{time_s, peaks: [...]}]}` as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Run `fbgforge peaks`.
pub fn run(a: PeaksArgs) -> Result<()> {
    let design = a
        .design
        .as_deref()
        .map(fbgforge::design::load)
        .transpose()?;
    let req = PeaksRequest {
        spectrum: a.spectrum.clone(),
        read: super::verify::read_options(a.format, None, &a.spectrum_args),
        window_half_width_nm: a.window_nm,
        out: a.out.clone(),
    };
    let report = peaks::run(design.as_ref(), &req)?;
    if a.json {
        println!("{}", json(&report)?);
    } else {
        print!("{}", summary_text(&report));
    }
    Ok(())
}
