//! `fbgforge peaks`: a spectrum file's peaks as a table or as JSON
//! (`{format, estimator, rows: [{time_s, peaks: [...]}]}`).

use crate::logs::peaks::{PeaksReport, ReportedPeak};
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// The report as JSON: `{format, estimator, rows}`.
pub fn json(report: &PeaksReport) -> anyhow::Result<String> {
    Ok(serde_json::to_string_pretty(report)?)
}

fn flags_text(p: &ReportedPeak) -> String {
    let names = p.flags.names();
    if names.is_empty() {
        "-".into()
    } else {
        names.join(",")
    }
}

fn peak_line(out: &mut String, p: &ReportedPeak) {
    let _ = writeln!(
        out,
        "  {:<7} {:<11} {:>10.4} {:>7.3} {:>6.3} {:>5.0} {:>6.0}  {}",
        p.channel,
        p.grating.as_deref().unwrap_or("-"),
        p.wavelength_nm,
        p.std_error_pm,
        p.crb_pm,
        p.fwhm_pm,
        p.snr,
        flags_text(p)
    );
}

/// The per-peak table's header: the names (the JSON's without their units), then
/// the units.
fn header() -> String {
    format!(
        "  {:<7} {:<11} {:>10} {:>7} {:>6} {:>5} {:>6}  flags\n  {:<7} {:<11} {:>10} {:>7} {:>6} {:>5}",
        "channel", "grating", "wavelength", "std_err", "crb", "fwhm", "snr", "", "", "nm", "pm", "pm", "pm"
    )
}

/// Median of a list (NaN when empty).
fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Per grating (or channel and unmatched), over the rows: how often seen, the median
/// figures and how often each flag was set.
fn summary_by_grating(out: &mut String, report: &PeaksReport) {
    let mut by: BTreeMap<(String, String), Vec<&ReportedPeak>> = BTreeMap::new();
    for row in &report.rows {
        for p in &row.peaks {
            let g = p.grating.clone().unwrap_or_else(|| "-".into());
            by.entry((p.channel.clone(), g)).or_default().push(p);
        }
    }
    let _ = writeln!(
        out,
        "  {:<7} {:<11} {:>6} {:>11} {:>7} {:>6} {:>5} {:>6}  flagged\n  {:<7} {:<11} {:>6} {:>11} {:>7} {:>6} {:>5}",
        "channel", "grating", "rows", "wavelength", "std_err", "crb", "fwhm", "snr",
        "", "(medians)", "", "nm", "pm", "pm", "pm"
    );
    for ((channel, grating), peaks) in &by {
        let med = |f: &dyn Fn(&ReportedPeak) -> f64| {
            median(&mut peaks.iter().map(|p| f(p)).collect::<Vec<_>>())
        };
        let mut flags: BTreeMap<&str, usize> = BTreeMap::new();
        for p in peaks {
            for n in p.flags.names() {
                *flags.entry(n).or_default() += 1;
            }
        }
        let flagged = if flags.is_empty() {
            "-".to_string()
        } else {
            flags
                .iter()
                .map(|(n, c)| format!("{n} {c}"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let _ = writeln!(
            out,
            "  {:<7} {:<11} {:>6} {:>11.4} {:>7.3} {:>6.3} {:>5.0} {:>6.0}  {}",
            channel,
            grating,
            peaks.len(),
            med(&|p| p.wavelength_nm),
            med(&|p| p.std_error_pm),
            med(&|p| p.crb_pm),
            med(&|p| p.fwhm_pm),
            med(&|p| p.snr),
            flagged
        );
    }
}

/// The report as text: the file, format and estimator, then every peak (up to 10
/// acquisitions) or a summary per grating over the acquisitions.
pub fn summary_text(report: &PeaksReport) -> String {
    let mut out = String::new();
    let peaks: usize = report.rows.iter().map(|r| r.peaks.len()).sum();
    let _ = writeln!(
        out,
        "{}: {} ({} acquisition{}, {} channel{}), {peaks} peaks by the {} estimator",
        report.source.display(),
        report.format,
        report.rows.len(),
        if report.rows.len() == 1 { "" } else { "s" },
        report.channels.len(),
        if report.channels.len() == 1 { "" } else { "s" },
        report.estimator
    );
    if report.rows.len() <= 10 {
        for row in &report.rows {
            let _ = writeln!(out, "time {:.3} s", row.time_s);
            let _ = writeln!(out, "{}", header());
            for p in &row.peaks {
                peak_line(&mut out, p);
            }
        }
    } else {
        summary_by_grating(&mut out, report);
    }
    let flagged = report
        .rows
        .iter()
        .flat_map(|r| &r.peaks)
        .filter(|p| !p.flags.is_clean())
        .count();
    if flagged > 0 {
        let _ = writeln!(
            out,
            "{flagged} of {peaks} peaks flagged: their std_error_pm may understate the error (docs/spectra.md, flags)"
        );
    }
    if let Some(path) = &report.out {
        let _ = writeln!(
            out,
            "peaks log: {} (columns {}; each with its std_error_pm)",
            path.display(),
            report.columns.join(", ")
        );
    }
    crate::terminal::fit(&out)
}
