//! The report folder of a verification: `report.json`, `report.md`, `report.html`,
//! the SVG plots and the CSVs behind them, written whole or not at all; and the sink
//! that writes it ([`ReportFolder`]).

use super::{charts, html, markdown::markdown, Words};
use crate::output::{write_atomic, write_csv};
use anyhow::Result;
use fbgforge_verify::analysis::{Measurement, Series};
use fbgforge_verify::{VerifyReport, VerifySink};
use std::path::{Path, PathBuf};

fn decimate(n: usize, max: usize) -> usize {
    n.div_ceil(max.max(1)).max(1)
}

/// Write `report.json`, `report.md`, `report.html`, the SVG plots and their CSVs into
/// the folder `dir`, whole or not at all: they are written into a temporary folder
/// beside it, which then replaces `dir` (a failure leaves `dir` as it was). A `dir` that
/// holds anything but a previous report is refused rather than replaced. The texts
/// name the request's fields in the library's own words ([`super::own_words`]).
pub fn write_report(dir: &Path, r: &VerifyReport, series: &Series) -> Result<()> {
    write_report_in(dir, r, series, super::own_words)
}

/// [`write_report`] with the texts in a front end's `words`.
pub fn write_report_in(dir: &Path, r: &VerifyReport, series: &Series, words: Words) -> Result<()> {
    check_report_dir(dir)?;
    crate::output::write_dir_atomic(dir, |tmp| write_report_files(tmp, r, series, words))
}

/// The sink that writes a verification's report folder: the folder is checked when
/// the sink is made (before the run), written whole when the report comes, and
/// removed after a failed run ([`ReportFolder::failed`]) so that a previous report is
/// not mistaken for this run's.
pub struct ReportFolder {
    dir: PathBuf,
    words: Words,
}

impl ReportFolder {
    /// A sink writing into `dir`, its texts in `words`; refuses a `dir` that holds
    /// files a report does not write.
    pub fn new(dir: &Path, words: Words) -> Result<Self> {
        check_report_dir(dir)?;
        Ok(ReportFolder {
            dir: dir.to_path_buf(),
            words,
        })
    }

    /// The folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// After a failed run: remove a previous report in the folder, if there was one
    /// (its files would pass for this run's); whether one was removed.
    pub fn failed(&self) -> bool {
        self.dir.exists() && remove_stale_report(&self.dir).is_ok()
    }
}

impl VerifySink for ReportFolder {
    fn judged(&mut self, report: &VerifyReport, series: &Series) -> Result<()> {
        write_report_in(&self.dir, report, series, self.words)
    }
    fn in_words(&self, text: &str) -> String {
        (self.words)(text)
    }
}

/// The names a report folder holds (a folder with anything else is not ours to replace).
fn is_report_file(name: &str) -> bool {
    name.starts_with("report.")
        || name.ends_with(".svg")
        || name.ends_with(".csv")
        || name.ends_with(".html")
        || name.ends_with(".json")
}

/// Refuse a report folder that exists and holds files a verify report does not write.
pub fn check_report_dir(dir: &Path) -> Result<()> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Ok(());
    };
    let foreign: Vec<String> = entries
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| !is_report_file(n))
        .collect();
    if !foreign.is_empty() {
        anyhow::bail!(
            "the report folder {} holds files a verify report does not write ({}): it would be replaced whole; name a new or empty folder",
            dir.display(),
            foreign.iter().take(5).cloned().collect::<Vec<_>>().join(", ")
        );
    }
    Ok(())
}

/// Remove a previous report folder (after a failed run: its files would be mistaken
/// for this run's). Only a folder holding nothing but report files is removed.
pub fn remove_stale_report(dir: &Path) -> Result<()> {
    if dir.is_dir() && check_report_dir(dir).is_ok() {
        std::fs::remove_dir_all(dir).map_err(|e| {
            anyhow::anyhow!(
                "cannot remove the stale report folder {}: {e}",
                dir.display()
            )
        })?;
    }
    Ok(())
}

/// Write `report.json`, `report.md`, `report.html`, the SVG plots and their CSVs into
/// `dir`, the texts in `words`.
fn write_report_files(dir: &Path, r: &VerifyReport, series: &Series, words: Words) -> Result<()> {
    crate::output::ensure_dir(dir)?;
    let json = serde_json::to_string_pretty(r)?;
    write_atomic(&dir.join("report.json"), words(&json).as_bytes())?;
    let m = &r.measurement;
    write_timeseries_csv(dir, series)?;
    write_pulses_csv(dir, m)?;
    plot_shift_vs_force(dir, r, series)?;
    plot_against_time(dir, series)?;
    let lag_plot = plot_lag_per_pulse(dir, m)?;
    write_atomic(
        &dir.join("report.md"),
        words(&markdown(r, lag_plot)).as_bytes(),
    )?;
    let page = html::document(r, series)?.to_html();
    write_atomic(&dir.join("report.html"), words(&page).as_bytes())
}

/// `timeseries.csv`: time, force and each grating's shift, at most 20 000 rows.
fn write_timeseries_csv(dir: &Path, series: &Series) -> Result<()> {
    let step = decimate(series.time_s.len(), 20_000);
    let idx: Vec<usize> = (0..series.time_s.len()).step_by(step).collect();
    let mut header: Vec<String> = vec!["time_s".into(), "force_n".into()];
    header.extend(series.shift_pm.iter().map(|(n, _)| format!("{n}_shift_pm")));
    let rows: Vec<Vec<String>> = idx
        .iter()
        .map(|&i| {
            let mut row = vec![
                format!("{:.6}", series.time_s[i]),
                format!("{:.5}", series.force_n[i]),
            ];
            row.extend(series.shift_pm.iter().map(|(_, v)| format!("{:.4}", v[i])));
            row
        })
        .collect();
    let h: Vec<&str> = header.iter().map(|s| s.as_str()).collect();
    write_csv(&dir.join("timeseries.csv"), &h, &rows)
}

/// `pulses.csv`: per grating and segment, the peaks of force and shift and the lag.
fn write_pulses_csv(dir: &Path, m: &Measurement) -> Result<()> {
    let prow: Vec<Vec<String>> = m
        .gratings
        .iter()
        .flat_map(|g| {
            g.pulses.iter().map(move |p| {
                vec![
                    g.grating.clone(),
                    p.index.to_string(),
                    p.pulse.to_string(),
                    serde_json::to_value(p.kind)
                        .ok()
                        .and_then(|v| v.as_str().map(String::from))
                        .unwrap_or_default(),
                    format!("{:.6}", p.start_s),
                    format!("{:.6}", p.end_s),
                    format!("{:.5}", p.peak_force_n),
                    format!("{:.6}", p.peak_force_time_s),
                    format!("{:.4}", p.peak_shift_pm),
                    format!("{:.6}", p.peak_shift_time_s),
                    format!("{:.6}", p.lag_s),
                    format!("{:.6}", p.lag_uncertainty_s),
                ]
            })
        })
        .collect();
    write_csv(
        &dir.join("pulses.csv"),
        &[
            "grating",
            "segment",
            "pulse",
            "kind",
            "start_s",
            "end_s",
            "peak_force_n",
            "peak_force_time_s",
            "peak_shift_pm",
            "peak_shift_time_s",
            "lag_s",
            "lag_uncertainty_s",
        ],
        &prow,
    )
}

/// `shift_vs_force.svg`: each grating's shift against force, its fitted line, and the
/// model's K with its band ([`charts`]).
fn plot_shift_vs_force(dir: &Path, r: &VerifyReport, series: &Series) -> Result<()> {
    charts::shift_vs_force(r, series).write_svg(&dir.join("shift_vs_force.svg"))
}

/// `force_vs_time.svg` and `shift_vs_time.svg` on the wavelength clock.
fn plot_against_time(dir: &Path, series: &Series) -> Result<()> {
    charts::force_vs_time(series).write_svg(&dir.join("force_vs_time.svg"))?;
    charts::shift_vs_time(series).write_svg(&dir.join("shift_vs_time.svg"))
}

/// `lag_per_pulse.svg` when any segment has a lag; returns whether it was written.
fn plot_lag_per_pulse(dir: &Path, m: &Measurement) -> Result<bool> {
    match charts::lag_per_segment(m) {
        Some(c) => c.write_svg(&dir.join("lag_per_pulse.svg")).map(|_| true),
        None => Ok(false),
    }
}
