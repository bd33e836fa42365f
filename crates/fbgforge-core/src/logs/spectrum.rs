//! Spectrum files read as peak logs: the spectrum formats' detection (before the peak
//! formats'), the peak-finding settings a reading names, and the whole-file formats
//! (a Luna ENLIGHT / Hyperion spectrum export, an OSA CSV: one acquisition each). The
//! I-MON log with pixels is read row by row like the other logs (`imon_pixels.rs`).
//!
//! Each spectrum's peaks are found by `fbgforge_spectra::find_peaks` with the estimator
//! [`ReadOptions::estimator`] names; every peak keeps its standard error, Cramér–Rao
//! bound, FWHM, SNR and flags ([`PeakQuality`]), so the rows are the ones a peak log
//! gives plus how well each peak is known.

use super::detect::{detect_format, Detected};
use super::rows::{lines_with_offsets, strip_bom};
use super::{
    Clock, LogFormat, LogReader, LogStyle, LogTable, LogWarnings, PeakLog, PeakQuality,
    PeakUncertainty, ReadOptions, Rows,
};
use anyhow::{anyhow, bail, Context, Result};
use fbgforge_spectra as spectra;
use rayon::prelude::*;
use serde::Serialize;
use spectra::{EstimatorChoice, FindOptions, Peak, PixelCalibration, Spectrum, SpectrumFormat};
use std::io::Write;
use std::path::Path;

pub(crate) use super::imon_pixels::IMON_PIXELS;

/// The estimator used when a reading names none: Gaussian least squares, the cheapest
/// that stays within 2× the Cramér–Rao bound wherever the bound can be met (the
/// speed-against-accuracy table of `crates/fbgforge-spectra/README.md`).
pub const DEFAULT_ESTIMATOR: &str = "gaussian";

/// The estimators a reading may name.
pub fn estimator_names() -> &'static [&'static str] {
    &["gaussian", "parabola", "centroid", "xcorr"]
}

/// The pixel-to-wavelength polynomial a reading gives, checked.
pub fn imon_calibration(opts: &ReadOptions) -> Result<Option<PixelCalibration>> {
    opts.imon_calibration
        .as_ref()
        .map(|c| {
            PixelCalibration::new(c.clone()).map_err(|e| {
                anyhow!("ReadOptions.imon_calibration (a0,a1,… in nm, pixel from 1): {e}")
            })
        })
        .transpose()
}

/// The estimator a reading names, before any template exists.
#[derive(Debug, Clone)]
pub(crate) enum Estimator {
    /// Gaussian, parabola or centroid.
    Plain(EstimatorChoice),
    /// Cross-correlation with each grating's spectrum in the first acquisition.
    Xcorr,
}

impl Estimator {
    /// The estimator `opts.estimator` names (default [`DEFAULT_ESTIMATOR`]), with its name.
    pub(crate) fn of(opts: &ReadOptions) -> Result<(Estimator, String)> {
        let name = opts.estimator.as_deref().unwrap_or(DEFAULT_ESTIMATOR);
        let est = match name {
            "xcorr" => Estimator::Xcorr,
            other => Estimator::Plain(EstimatorChoice::from_name(other).ok_or_else(|| {
                anyhow!(
                    "ReadOptions.estimator: unknown peak estimator `{other}`; known: {}",
                    estimator_names().join(", ")
                )
            })?),
        };
        Ok((est, name.to_string()))
    }

    /// The settings of one channel's peak finder; for `xcorr` the templates are that
    /// channel's peaks in `first` (its first acquisition, taken as unloaded).
    pub(crate) fn options_for(&self, first: &Spectrum) -> Result<FindOptions> {
        let estimator = match self {
            Estimator::Plain(choice) => choice.clone(),
            Estimator::Xcorr => EstimatorChoice::CrossCorrelation(templates_of(first)?),
        };
        Ok(FindOptions {
            estimator,
            ..FindOptions::default()
        })
    }
}

/// One template per peak of the first acquisition: the spectrum within ±2 FWHM of it.
fn templates_of(first: &Spectrum) -> Result<spectra::peaks::TemplateMatch> {
    let peaks = spectra::find_peaks(first, &FindOptions::default())
        .map_err(|e| anyhow!("xcorr templates from channel {}: {e}", first.channel))?;
    let pitch = first.median_pitch_nm();
    let templates: Vec<_> = peaks
        .iter()
        .filter_map(|p| {
            let half = (2e-3 * p.fwhm_pm).max(6.0 * pitch);
            spectra::peaks::Template::from_spectrum(first, p.wavelength_nm, half).ok()
        })
        .collect();
    if templates.is_empty() {
        bail!(
            "ReadOptions.estimator xcorr: the first acquisition of channel {} has no peak to take as a template",
            first.channel
        );
    }
    Ok(spectra::peaks::TemplateMatch { templates })
}

/// The settings of the peak finder for a named estimator on spectra without templates
/// (gaussian, parabola, centroid): what Python's `find_peaks` and the studies use.
pub fn find_options(estimator: Option<&str>) -> Result<FindOptions> {
    let opts = ReadOptions {
        estimator: estimator.map(str::to_string),
        ..ReadOptions::default()
    };
    match Estimator::of(&opts)?.0 {
        Estimator::Plain(choice) => Ok(FindOptions {
            estimator: choice,
            ..FindOptions::default()
        }),
        Estimator::Xcorr => {
            bail!("ReadOptions.estimator xcorr needs a template spectrum (the grating unloaded)")
        }
    }
}

/// The head of a file as text: its first 400 lines (what `fbgforge_spectra::detect`
/// looks at).
fn head_text(bytes: &[u8]) -> String {
    let (b, _) = strip_bom(bytes);
    let end = lines_with_offsets(b)
        .nth(400)
        .map_or(b.len().min(4 << 20), |(o, _)| o);
    String::from_utf8_lossy(&b[..end]).into_owned()
}

/// A whole-file spectrum format's table: the file is read whole by its reader.
fn whole_file(format: LogFormat) -> Detected {
    Detected {
        format,
        body_offset: 0,
        body_line: 1,
        header: Vec::new(),
        delimiter: b'\t',
    }
}

/// The one detection: a spectrum format is recognised first (an ENLIGHT spectrum
/// export, an OSA CSV; an I-MON log with pixel columns becomes
/// [`LogFormat::ImonPixels`] when a calibration is given), else a peak format.
pub(crate) fn detect_table(bytes: &[u8], path: &Path, opts: &ReadOptions) -> Result<Detected> {
    let spectral = spectra::detect(&head_text(bytes));
    match opts.format {
        Some(f @ (LogFormat::EnlightSpectrum | LogFormat::OsaCsv)) => Ok(whole_file(f)),
        Some(LogFormat::ImonPixels) => {
            if opts.imon_calibration.is_none() {
                bail!(
                    "{}: reading an I-MON log's pixels needs their wavelengths: give the pixel calibration ReadOptions.imon_calibration a0,a1,… (nm, pixel from 1)",
                    path.display()
                );
            }
            let mut d = detect_format(bytes, path, Some(LogFormat::Imon))?;
            if !d.header.iter().any(|h| h == "Pixel 1") {
                bail!(
                    "{}:{}: the I-MON header names no `Pixel 1` column: this log carries no spectra",
                    path.display(),
                    d.header_line()
                );
            }
            d.format = LogFormat::ImonPixels;
            Ok(d)
        }
        Some(f) => detect_format(bytes, path, Some(f)),
        None => match spectral {
            Some(SpectrumFormat::EnlightSpectrum) => Ok(whole_file(LogFormat::EnlightSpectrum)),
            Some(SpectrumFormat::OsaCsv) => Ok(whole_file(LogFormat::OsaCsv)),
            Some(SpectrumFormat::ImonPixels) => {
                let mut d = detect_format(bytes, path, None)?;
                if d.format == LogFormat::Imon && opts.imon_calibration.is_some() {
                    d.format = LogFormat::ImonPixels;
                }
                Ok(d)
            }
            None => detect_format(bytes, path, None),
        },
    }
}

/// One peak of one channel of an acquisition.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ChannelPeak {
    /// Index of the channel (the spectrum's column) from 0.
    pub channel: usize,
    /// The peak with its uncertainty.
    pub peak: Peak,
}

/// One acquisition's peaks.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SpectrumPeaksRow {
    /// Time of the acquisition, s (wall clock since 1970 where the file states it, else 0).
    pub time_s: f64,
    /// Its peaks, channel after channel, by wavelength within a channel.
    pub peaks: Vec<ChannelPeak>,
}

/// The peaks of every acquisition of a spectrum file.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SpectrumPeaks {
    /// The file's format.
    pub format: LogFormat,
    /// The estimator that found the peaks.
    pub estimator: String,
    /// Channel labels as the file names them (`CH 1`, `Rx`, `I-MON`).
    pub channels: Vec<String>,
    /// The file's header metadata in file order (an ENLIGHT export's settings).
    pub metadata: Vec<(String, String)>,
    /// Each channel's metadata (an ENLIGHT export's `CH n Configuration:` block).
    pub channel_metadata: Vec<Vec<(String, String)>>,
    /// Acquisitions in file order.
    pub rows: Vec<SpectrumPeaksRow>,
}

/// Read a spectrum file whole and find the peaks of every acquisition (in parallel):
/// what `fbgforge peaks` shows. A peak log is refused (it has no spectra); an I-MON log
/// with pixels needs [`ReadOptions::imon_calibration`].
pub fn read_spectrum_peaks(path: &Path, opts: &ReadOptions) -> Result<SpectrumPeaks> {
    let bytes = std::fs::read(path)
        .with_context(|| format!("cannot read the spectrum file {}", path.display()))?;
    spectrum_peaks_of(&bytes, path, opts)
}

fn spectrum_peaks_of(bytes: &[u8], path: &Path, opts: &ReadOptions) -> Result<SpectrumPeaks> {
    let det = detect_table(bytes, path, opts)?;
    let format = match det.format {
        LogFormat::ImonPixels => SpectrumFormat::ImonPixels,
        LogFormat::EnlightSpectrum => SpectrumFormat::EnlightSpectrum,
        LogFormat::OsaCsv => SpectrumFormat::OsaCsv,
        LogFormat::Imon if opts.imon_calibration.is_none() && det.header.iter().any(|h| h == "Pixel 1") => bail!(
            "{}: an I-MON log with pixels: give the pixel calibration ReadOptions.imon_calibration a0,a1,… (nm, pixel from 1 as the header writes it) to find its peaks",
            path.display()
        ),
        other => bail!(
            "{}: a peak log ({}), not a spectrum: its peaks are already found",
            path.display(),
            other.name()
        ),
    };
    let (b, _) = strip_bom(bytes);
    let text = String::from_utf8_lossy(b);
    let log = spectra::read_spectrum_log(
        &text,
        &spectra::ReadOptions {
            format: Some(format),
            imon_calibration: imon_calibration(opts)?,
        },
    )
    .map_err(|e| anyhow!("{}: {e}", path.display()))?;
    let (estimator, name) = Estimator::of(opts)?;
    let first = log
        .rows
        .first()
        .ok_or_else(|| anyhow!("{}: the file holds no acquisition", path.display()))?;
    let options = first
        .spectra
        .iter()
        .map(|s| estimator.options_for(s))
        .collect::<Result<Vec<_>>>()
        .with_context(|| path.display().to_string())?;
    let rows = log
        .rows
        .par_iter()
        .map(|row| {
            let mut peaks = Vec::new();
            for (c, (s, o)) in row.spectra.iter().zip(&options).enumerate() {
                let found = spectra::find_peaks(s, o).map_err(|e| {
                    anyhow!(
                        "{}: channel {} at {} s: {e}",
                        path.display(),
                        s.channel,
                        row.time_s
                    )
                })?;
                peaks.extend(
                    found
                        .into_iter()
                        .map(|peak| ChannelPeak { channel: c, peak }),
                );
            }
            Ok(SpectrumPeaksRow {
                time_s: row.time_s,
                peaks,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(SpectrumPeaks {
        format: det.format,
        estimator: name,
        channels: first.spectra.iter().map(|s| s.channel.clone()).collect(),
        metadata: log.metadata.clone(),
        channel_metadata: first.spectra.iter().map(|s| s.metadata.clone()).collect(),
        rows,
    })
}

/// A whole-file spectrum (ENLIGHT export, OSA CSV) as a peak log of its acquisitions.
pub(crate) fn read_whole_spectrum(
    bytes: &[u8],
    path: &Path,
    format: LogFormat,
    opts: &ReadOptions,
) -> Result<PeakLog> {
    let forced = ReadOptions {
        format: Some(format),
        ..opts.clone()
    };
    let sp = spectrum_peaks_of(bytes, path, &forced)?;
    let mut log = PeakLog {
        source: path.to_path_buf(),
        format,
        time_s: Vec::new(),
        clock: if sp.rows.iter().all(|r| r.time_s != 0.0) {
            Clock::Absolute
        } else {
            Clock::Relative
        },
        row_start: vec![0],
        peaks_nm: Vec::new(),
        peak_channel: Vec::new(),
        channels: sp.channels.len(),
        column_names: sp.channels.clone(),
        line_of_row: Vec::new(),
        time_uncertainty_s: 0.0,
        // A handful of acquisitions, not a sampled stream: no clock to check.
        clock_jumps: Vec::new(),
        warnings: LogWarnings::default(),
        uncertainty: Some(PeakUncertainty {
            estimator: sp.estimator.clone(),
            peaks: Vec::new(),
        }),
    };
    let quality = &mut log.uncertainty.as_mut().expect("set above").peaks;
    for row in &sp.rows {
        log.time_s.push(row.time_s);
        for cp in &row.peaks {
            log.peaks_nm.push(cp.peak.wavelength_nm);
            log.peak_channel.push(cp.channel as u16);
            quality.push(PeakQuality::from(&cp.peak));
        }
        log.row_start.push(log.peaks_nm.len());
        log.line_of_row.push(1);
    }
    Ok(log)
}

/// How the spectra of a synthetic I-MON log with pixels are made from its peak
/// wavelengths (`synth-log --format imon-pixels`).
#[derive(Debug, Clone, PartialEq)]
pub struct SpectrumStyle {
    /// Pixel-to-wavelength polynomial a0, a1, … (nm, pixel from 1), the one the reader
    /// needs (`ReadOptions.imon_calibration`). Default: 512 pixels from 1595 nm down to
    /// 1510 nm (166 pm per pixel, reverse order, as an I-MON 512 writes them).
    pub imon_calibration: Vec<f64>,
    /// Number of pixels (512).
    pub pixels: usize,
    /// Reflection line shape of the peaks (default: a Gaussian of 0.33 nm FWHM, about
    /// 2 pixels, as on real I-MON frames).
    pub line_shape: LineShape,
    /// Height of a peak above the floor, counts (30,000).
    pub peak_counts: f64,
    /// Floor, counts (1,000).
    pub floor_counts: f64,
    /// White noise on every pixel, counts (10: peak SNR 3,000).
    pub noise_counts: f64,
    /// Seed of the noise.
    pub seed: u64,
}

impl Default for SpectrumStyle {
    fn default() -> Self {
        let a1 = (1510.0 - 1595.0) / 511.0;
        SpectrumStyle {
            imon_calibration: vec![1595.0 - a1, a1],
            pixels: 512,
            line_shape: LineShape::Gaussian { fwhm_nm: 0.33 },
            peak_counts: 30_000.0,
            floor_counts: 1_000.0,
            noise_counts: 10.0,
            seed: 1,
        }
    }
}

/// The reflection line shape of a synthetic spectrum's peaks.
#[derive(Debug, Clone, PartialEq)]
pub enum LineShape {
    /// A Gaussian of this FWHM (nm) for every column.
    Gaussian {
        /// FWHM, nm.
        fwhm_nm: f64,
    },
    /// Each column's grating by the transfer-matrix model, in the table's column order.
    Gratings(Vec<spectra::Grating>),
    /// The design's gratings, by column name: `synth-log` resolves it into
    /// [`LineShape::Gratings`] (`fbgforge_core::grating::design_grating`).
    Design,
}

/// A whole-file spectrum format behind the registry: read whole
/// ([`read_whole_spectrum`]), never row by row, and not written from a peak table (it
/// holds one acquisition).
pub(crate) struct WholeSpectrum {
    name: &'static str,
    title: &'static str,
    expected: &'static str,
    extension: &'static str,
}

/// Luna ENLIGHT / Hyperion spectrum export.
pub(crate) const ENLIGHT_SPECTRUM: WholeSpectrum = WholeSpectrum {
    name: "enlight-spectrum",
    title: "ENLIGHT spectrum export",
    expected: "a line `Wvl (nm)<TAB>CH 1…` then wavelength and power (dBm) rows",
    extension: "txt",
};

/// OSA / swept-laser CSV.
pub(crate) const OSA_CSV: WholeSpectrum = WholeSpectrum {
    name: "osa-csv",
    title: "OSA CSV",
    expected: "a line `Wavelength (nm),<power column>…` then numeric rows",
    extension: "csv",
};

impl LogReader for WholeSpectrum {
    fn name(&self) -> &'static str {
        self.name
    }

    fn title(&self) -> &'static str {
        self.title
    }

    fn expected(&self) -> &'static str {
        self.expected
    }

    fn rows(&self, _det: &Detected, _b: &[u8], path: &Path, _o: &ReadOptions) -> Result<Rows> {
        bail!(
            "{}: a {} is one acquisition, read whole, not row by row (a growing file cannot be followed)",
            path.display(),
            self.title
        )
    }

    fn write(&self, _w: &mut dyn Write, table: &LogTable, _s: &LogStyle) -> std::io::Result<()> {
        Err(std::io::Error::other(format!(
            "a {} holds one acquisition; a log of {} rows is written as imon-pixels",
            self.title,
            table.time_s.len()
        )))
    }

    fn extension(&self) -> &'static str {
        self.extension
    }

    fn written_clock(&self) -> Clock {
        if self.name == OSA_CSV.name {
            Clock::Relative
        } else {
            Clock::Absolute
        }
    }
}

#[cfg(test)]
#[path = "spectrum_tests.rs"]
mod tests;

/// Warns, once per flag, how many of the log's peaks found in spectra are flagged: a
/// flagged peak's standard error understates its error (pixel-locking, a shape the
/// estimator does not model, a neighbour, noise, split lobes; docs/spectra.md §3), and
/// a K fitted through many of them can be off by more than its standard error says.
pub(crate) fn warn_flagged_peaks(log: &mut PeakLog) {
    let Some(u) = &log.uncertainty else {
        return;
    };
    let total = u.peaks.len();
    let mut counts: std::collections::BTreeMap<&'static str, usize> = Default::default();
    for q in &u.peaks {
        for name in q.flags.names() {
            *counts.entry(name).or_default() += 1;
        }
    }
    let estimator = u.estimator.clone();
    for (flag, n) in counts {
        let path = log.source.display().to_string();
        log.warnings.add_n(&format!("peaks_{flag}"), n, || {
            format!(
                "{path}: {n} of {total} peaks found in the spectra by `{estimator}` are flagged \
                 `{flag}`: their standard errors understate their error, and a fit through them \
                 may be biased (docs/spectra.md §3, §10)"
            )
        });
    }
}
