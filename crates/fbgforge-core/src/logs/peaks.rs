//! The `peaks` use case: a spectrum file in, its peaks out, each with its uncertainty,
//! matched to the design's gratings when a design is given, and optionally written as
//! a peaks log the other commands read (a CSV with each peak's standard error and the
//! estimator named in a comment).

use super::num::civil_from_days;
use super::plain_csv::STD_ERROR_SUFFIX;
use super::spectrum::{read_spectrum_peaks, SpectrumPeaks};
use super::ReadOptions;
use crate::spec::Design;
use anyhow::{bail, Result};
use fbgforge_spectra::{match_gratings, ExpectedGrating, Peak, PeakFlags};
use serde::Serialize;
use std::io::Write;
use std::path::PathBuf;

/// What to read and how.
#[derive(Debug, Clone, Default)]
pub struct PeaksRequest {
    /// The spectrum file (ENLIGHT / Hyperion export, I-MON log with pixels, OSA CSV).
    pub spectrum: PathBuf,
    /// Format, pixel calibration and estimator.
    pub read: ReadOptions,
    /// Half-width of each grating's window around its nominal wavelength, nm (default:
    /// half the smallest spacing, at most 2.5 nm, as `verify` takes it).
    pub window_half_width_nm: Option<f64>,
    /// Write the peaks as a log the other commands read (CSV, atomically).
    pub out: Option<PathBuf>,
}

impl PeaksRequest {
    /// Checks the settings that do not need the file.
    pub fn validate(&self) -> Result<()> {
        if let Some(w) = self.window_half_width_nm {
            if !(w.is_finite() && w > 0.0 && w <= 10.0) {
                bail!("PeaksRequest.window_half_width_nm must be in (0, 10] nm, got {w}");
            }
        }
        super::spectrum::Estimator::of(&self.read)?;
        super::spectrum::imon_calibration(&self.read)?;
        Ok(())
    }
}

/// One peak as `fbgforge peaks` reports it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReportedPeak {
    /// The channel (spectrum column) it was found in, as the file names it.
    pub channel: String,
    /// The design's grating it belongs to (`null` without a design or outside every
    /// grating's window).
    pub grating: Option<String>,
    /// Peak wavelength, nm.
    pub wavelength_nm: f64,
    /// Standard error of the wavelength from the fit's residuals, pm.
    pub std_error_pm: f64,
    /// Cramér–Rao bound for the peak's width, noise and sampling grid, pm.
    pub crb_pm: f64,
    /// Full width at half maximum, pm.
    pub fwhm_pm: f64,
    /// Peak height over the noise standard deviation.
    pub snr: f64,
    /// Quality flags by name.
    pub flags: PeakFlags,
}

/// One acquisition's peaks.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PeaksRow {
    /// Time of the acquisition, s (since 1970 on the recording PC's clock when the file
    /// states it, else 0).
    pub time_s: f64,
    /// Its peaks, channel after channel, by wavelength.
    pub peaks: Vec<ReportedPeak>,
}

/// What `fbgforge peaks` reports: `{format, estimator, rows}` in JSON.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PeaksReport {
    /// The spectrum format read (`enlight-spectrum`, `imon-pixels`, `osa-csv`).
    pub format: String,
    /// The estimator that found the peaks.
    pub estimator: String,
    /// The acquisitions.
    pub rows: Vec<PeaksRow>,
    /// The file read.
    #[serde(skip)]
    pub source: PathBuf,
    /// The channels as the file names them.
    #[serde(skip)]
    pub channels: Vec<String>,
    /// The columns of the peaks log: the design's gratings, or (without a design) each
    /// channel's peaks of the first acquisition.
    #[serde(skip)]
    pub columns: Vec<String>,
    /// The peaks log written, if asked.
    #[serde(skip)]
    pub out: Option<PathBuf>,
}

/// The gratings a design names, with their nominal wavelengths (module or array).
fn design_gratings(design: &Design) -> Vec<(String, f64)> {
    let module = design.module.iter().flat_map(|m| {
        m.gratings
            .iter()
            .map(|g| (g.name.clone(), g.bragg_wavelength_nm))
    });
    let array = design.array.iter().flat_map(|a| {
        a.gratings
            .iter()
            .map(|g| (g.name.clone(), g.bragg_wavelength_nm))
    });
    module.chain(array).collect()
}

/// The windows of the gratings (or of the first acquisition's peaks without a design).
fn expected(named: Vec<(String, f64)>, half_width_nm: Option<f64>) -> Result<Vec<ExpectedGrating>> {
    let nominals: Vec<f64> = named.iter().map(|g| g.1).collect();
    let hw = half_width_nm.unwrap_or_else(|| super::assign::default_half_width_nm(&nominals));
    if !(hw.is_finite() && hw > 0.0) {
        bail!("two gratings share a nominal wavelength: their peaks cannot be told apart");
    }
    Ok(named
        .into_iter()
        .map(|(name, nominal_nm)| ExpectedGrating {
            name,
            nominal_nm,
            window_nm: hw,
        })
        .collect())
}

fn reported(channel: &str, grating: Option<&str>, p: &Peak) -> ReportedPeak {
    ReportedPeak {
        channel: channel.to_string(),
        grating: grating.map(str::to_string),
        wavelength_nm: p.wavelength_nm,
        std_error_pm: p.std_error_pm,
        crb_pm: p.crb_pm,
        fwhm_pm: p.fwhm_pm,
        snr: p.snr,
        flags: p.flags,
    }
}

/// Each acquisition's peaks, matched channel by channel to `gratings` (a grating's
/// lobes merged into one peak flagged `split`; peaks outside every window kept with no
/// grating).
fn matched_rows(sp: &SpectrumPeaks, gratings: &[ExpectedGrating], named: bool) -> Vec<PeaksRow> {
    sp.rows
        .iter()
        .map(|row| {
            let mut peaks = Vec::new();
            for (c, label) in sp.channels.iter().enumerate() {
                let mine: Vec<Peak> = row
                    .peaks
                    .iter()
                    .filter(|p| p.channel == c)
                    .map(|p| p.peak.clone())
                    .collect();
                let matched = match_gratings(&mine, gratings);
                let mut out: Vec<ReportedPeak> = matched
                    .iter()
                    .filter_map(|m| {
                        let g = named.then_some(m.grating.as_str());
                        m.peak.as_ref().map(|p| reported(label, g, p))
                    })
                    .collect();
                // Peaks in no window (or side lobes the matching set aside) are kept.
                for p in &mine {
                    let inside = gratings
                        .iter()
                        .any(|g| (p.wavelength_nm - g.nominal_nm).abs() <= g.window_nm);
                    if !inside {
                        out.push(reported(label, None, p));
                    }
                }
                out.sort_by(|a, b| a.wavelength_nm.total_cmp(&b.wavelength_nm));
                peaks.extend(out);
            }
            PeaksRow {
                time_s: row.time_s,
                peaks,
            }
        })
        .collect()
}

/// Read a spectrum file, find every acquisition's peaks with their uncertainty, match
/// them to `design`'s gratings, and write the peaks log when asked.
///
/// ```
/// use fbgforge_core::logs::peaks::{run, PeaksRequest};
/// use fbgforge_spectra::synth::{SynthPeak, SynthSpectrum};
/// use fbgforge_spectra::{PowerUnit, SpectrumFormat};
/// let dir = tempfile::tempdir()?;
/// let path = dir.path().join("osa.csv");
/// // One grating at 1550.0123 nm, FWHM 0.2 nm on an 8 pm grid, SNR 300.
/// let truth = SynthSpectrum::uniform(1549.0, 0.008, 250, 0.01)
///     .with_peak(SynthPeak::gaussian(1550.0123, 0.2, 3.0));
/// std::fs::write(&path, truth.write(SpectrumFormat::OsaCsv, 7, PowerUnit::Linear)?)?;
/// let report = run(None, &PeaksRequest { spectrum: path, ..Default::default() })?;
/// assert_eq!((report.format.as_str(), report.estimator.as_str()), ("osa-csv", "gaussian"));
/// let p = &report.rows[0].peaks[0];
/// assert!((p.wavelength_nm - 1550.0123).abs() * 1e3 < 4.0 * p.std_error_pm);
/// assert!(p.flags.is_clean());
/// # Ok::<(), anyhow::Error>(())
/// ```
pub fn run(design: Option<&Design>, req: &PeaksRequest) -> Result<PeaksReport> {
    req.validate()?;
    let sp = read_spectrum_peaks(&req.spectrum, &req.read)?;
    let (named, gratings) = match design {
        Some(d) => {
            let g = design_gratings(d);
            if g.is_empty() {
                bail!("design `{}` names no grating", d.name);
            }
            (true, expected(g, req.window_half_width_nm)?)
        }
        None => (false, expected(first_peaks(&sp), req.window_half_width_nm)?),
    };
    let rows = matched_rows(&sp, &gratings, named);
    let columns: Vec<String> = gratings.iter().map(|g| g.name.clone()).collect();
    let mut report = PeaksReport {
        format: sp.format.name().to_string(),
        estimator: sp.estimator.clone(),
        rows,
        source: req.spectrum.clone(),
        channels: sp.channels.clone(),
        columns,
        out: None,
    };
    if let Some(out) = &req.out {
        let table = column_rows(&sp, &gratings);
        crate::output::write_atomic_with(out, |w| write_peaks_log(w, &report, &table))?;
        report.out = Some(out.clone());
    }
    Ok(report)
}

/// Without a design, the first acquisition's peaks name the columns: `<channel>
/// <wavelength>` (a peak log's columns must hold one grating each).
fn first_peaks(sp: &SpectrumPeaks) -> Vec<(String, f64)> {
    let Some(first) = sp.rows.first() else {
        return Vec::new();
    };
    first
        .peaks
        .iter()
        .map(|p| {
            (
                format!("{} {:.3}", sp.channels[p.channel], p.peak.wavelength_nm),
                p.peak.wavelength_nm,
            )
        })
        .collect()
}

/// Per acquisition and column: (wavelength nm, standard error pm), NaN when absent.
fn column_rows(sp: &SpectrumPeaks, gratings: &[ExpectedGrating]) -> Vec<Vec<(f64, f64)>> {
    sp.rows
        .iter()
        .map(|row| {
            let mut cells = vec![(f64::NAN, f64::NAN); gratings.len()];
            for c in 0..sp.channels.len() {
                let mine: Vec<Peak> = row
                    .peaks
                    .iter()
                    .filter(|p| p.channel == c)
                    .map(|p| p.peak.clone())
                    .collect();
                for (k, m) in match_gratings(&mine, gratings).iter().enumerate() {
                    if let (Some(p), true) = (&m.peak, cells[k].0.is_nan()) {
                        cells[k] = (p.wavelength_nm, p.std_error_pm);
                    }
                }
            }
            cells
        })
        .collect()
}

/// A time as the peaks log writes it: a date and time of day where the file stated a
/// wall-clock time, else seconds.
fn time_cell(t: f64, dated: bool) -> String {
    if !dated {
        return format!("{t:.6}");
    }
    let days = (t / 86400.0).floor() as i64;
    let (y, m, d) = civil_from_days(days);
    let sod = t - days as f64 * 86400.0;
    let (h, mi) = ((sod / 3600.0).floor(), ((sod / 60.0) % 60.0).floor());
    let s = sod - h * 3600.0 - mi * 60.0;
    format!("{y:04}-{m:02}-{d:02} {h:02}:{mi:02}:{s:09.6}")
}

/// The peaks log: comment lines naming the source and the estimator, a `time` column,
/// then per column its wavelength (nm) and `<column> std_error_pm`.
fn write_peaks_log(
    w: &mut dyn Write,
    report: &PeaksReport,
    table: &[Vec<(f64, f64)>],
) -> Result<()> {
    let dated = report.rows.iter().all(|r| r.time_s > 86400.0);
    writeln!(
        w,
        "# fbgforge peaks of {} ({})",
        report.source.display(),
        report.format
    )?;
    writeln!(w, "# estimator: {}", report.estimator)?;
    write!(w, "{}", if dated { "time" } else { "time_s" })?;
    for c in &report.columns {
        write!(w, ",{c},{c} {STD_ERROR_SUFFIX}")?;
    }
    writeln!(w)?;
    for (row, cells) in report.rows.iter().zip(table) {
        write!(w, "{}", time_cell(row.time_s, dated))?;
        for (l, se) in cells {
            if l.is_finite() {
                write!(w, ",{l:.6},{se:.6}")?;
            } else {
                write!(w, ",,")?;
            }
        }
        writeln!(w)?;
    }
    Ok(())
}
