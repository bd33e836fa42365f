//! `fbgforge peaks`: a spectrum file's peaks with their uncertainty (the work is
//! `fbgforge::logs::peaks::run`).

use super::log_args::SpectrumArgs;
use anyhow::Result;
use clap::Args;
use fbgforge::logs::peaks::{self, PeaksRequest};
use fbgforge::report::peaks::{json, summary_text};
use std::path::PathBuf;

/// This subcommand's request fields and the flags that fill them (`cli::hiargs`).
pub const FLAGS: &[(&str, &str)] = &[
    ("PeaksRequest.window_half_width_nm", "--window-nm"),
    ("PeaksRequest.out", "--out"),
];

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
    pub format: Option<super::log_args::LogFormatArg>,
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
        read: super::log_args::read_options(a.format, None, &a.spectrum_args),
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
