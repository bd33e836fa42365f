//! Luna ENLIGHT / Hyperion spectrum export.
//!
//! ```text
//! <blank>
//! Date: 17/04/2025 4:01:03 pm
//! Module Type: Hyperion
//! …
//! CH 1 Configuration:
//! <TAB>Detect Valley: False
//! …
//! Wvl (nm)<TAB> CH 1 <TAB> CH 2
//! <blank>
//! 1460.0000<TAB>-58.4822<TAB>-60.1000
//! ```

use super::text::{self, DateOrder};
use crate::error::SpectrumError;
use crate::formats::SpectrumFormat;
use crate::spectrum::{PowerUnit, Spectrum, SpectrumLog, SpectrumRow};

pub(crate) fn is_header(line: &str) -> bool {
    line.split('\t')
        .next()
        .is_some_and(|f| f.trim().eq_ignore_ascii_case("wvl (nm)"))
}

/// The header block: top-level key/values and one block per channel.
#[derive(Default)]
struct Header {
    metadata: Vec<(String, String)>,
    channel_blocks: Vec<(String, Vec<(String, String)>)>,
    in_block: bool,
}

fn key_value(line: &str) -> (String, String) {
    match line.split_once(':') {
        Some((k, v)) => (k.trim().to_string(), v.trim().to_string()),
        None => (line.trim().to_string(), String::new()),
    }
}

impl Header {
    /// Takes one metadata line. Tab-indented lines after `CH n Configuration:` belong to
    /// that channel; any other non-blank line is a top-level `key: value` and closes the
    /// channel block.
    fn take(&mut self, line: &str) {
        let trimmed = line.trim();
        if trimmed.is_empty() {
            return;
        }
        if line.starts_with('\t') && self.in_block {
            if let Some((_, block)) = self.channel_blocks.last_mut() {
                block.push(key_value(line));
                return;
            }
        }
        if let Some(label) = trimmed.strip_suffix("Configuration:").map(str::trim) {
            if label.starts_with("CH") {
                self.channel_blocks.push((label.to_string(), Vec::new()));
                self.in_block = true;
                return;
            }
        }
        self.in_block = false;
        self.metadata.push(key_value(line));
    }

    fn channel_metadata(&self, label: &str) -> Vec<(String, String)> {
        self.channel_blocks
            .iter()
            .find(|(l, _)| l == label)
            .map(|(_, b)| b.clone())
            .unwrap_or_default()
    }
}

/// Reads an ENLIGHT / Hyperion spectrum export: one row (one acquisition), one spectrum
/// per `CH n` column, power in dBm. The header's `key: value` lines become the log's
/// metadata and each `CH n Configuration:` block the metadata of that channel's spectrum.
/// The row's time is the `Date:` line's (day-first unless the second number exceeds
/// 12; 0 when there is none).
pub fn read_enlight(text: &str) -> Result<SpectrumLog, SpectrumError> {
    let mut header = Header::default();
    let mut lines = text::numbered_lines(text);
    let mut channels: Option<Vec<String>> = None;
    for (_, line) in lines.by_ref() {
        if is_header(line) {
            channels = Some(
                text::fields(line, '\t')[1..]
                    .iter()
                    .map(|s| s.to_string())
                    .collect(),
            );
            break;
        }
        header.take(line);
    }
    let channels =
        channels.ok_or_else(|| SpectrumError::UnknownFormat("no `Wvl (nm)` header line".into()))?;
    if channels.is_empty() || channels.iter().any(|c| c.is_empty()) {
        return Err(SpectrumError::Invalid(
            "`Wvl (nm)` header line names no channel column".into(),
        ));
    }
    let mut wavelengths = Vec::new();
    let mut line_numbers = Vec::new();
    let mut power: Vec<Vec<f64>> = vec![Vec::new(); channels.len()];
    for (number, line) in lines {
        if line.trim().is_empty() {
            continue;
        }
        let f = text::fields(line, '\t');
        if f.len() != channels.len() + 1 {
            return Err(SpectrumError::Ragged {
                line: number,
                expected: format!(
                    "{} (wavelength + {} channel{})",
                    channels.len() + 1,
                    channels.len(),
                    plural(channels.len())
                ),
                found: f.len(),
            });
        }
        wavelengths.push(text::parse_number(f[0], number, "wavelength, nm", true)?);
        line_numbers.push(number);
        for (c, column) in power.iter_mut().enumerate() {
            column.push(text::parse_number(f[c + 1], number, "power, dBm", true)?);
        }
    }
    if text::check_monotonic(&wavelengths, &line_numbers)? {
        wavelengths.reverse();
        power.iter_mut().for_each(|p| p.reverse());
    }
    let time_s = header
        .metadata
        .iter()
        .find(|(k, _)| k == "Date")
        .and_then(|(_, v)| parse_date(v))
        .unwrap_or(0.0);
    let spectra = channels
        .iter()
        .zip(power)
        .map(|(label, p)| Spectrum {
            channel: label.clone(),
            wavelengths_nm: wavelengths.clone(),
            power: p,
            unit: PowerUnit::Dbm,
            metadata: header.channel_metadata(label),
        })
        .collect();
    Ok(SpectrumLog {
        format: SpectrumFormat::EnlightSpectrum,
        metadata: header.metadata,
        rows: vec![SpectrumRow {
            time_s,
            spectra,
            reported_peaks_nm: Vec::new(),
        }],
    })
}

fn plural(n: usize) -> &'static str {
    if n == 1 {
        ""
    } else {
        "s"
    }
}

/// `17/04/2025 4:01:03 pm` → seconds since 1970 (day-first unless the second number
/// exceeds 12).
fn parse_date(value: &str) -> Option<f64> {
    let (date, time) = value.trim().split_once(' ')?;
    let parts = text::date_parts(date)?;
    let order = if parts.1 > 12 {
        DateOrder::MonthFirst
    } else {
        DateOrder::DayFirst
    };
    text::date_time_s(parts, time, order)
}

/// Writes one acquisition as an ENLIGHT spectrum export: wavelengths and power with 4
/// decimals, power in dBm (spectra in mW are converted; other units are refused), the
/// log's metadata as `key: value` lines and each spectrum's metadata as its
/// `CH n Configuration:` block. `Date:` is written from the row's time (day-first,
/// 12-hour clock as ENLIGHT writes it).
pub fn write_enlight(log: &SpectrumLog) -> Result<String, SpectrumError> {
    let row = match log.rows.as_slice() {
        [row] => row,
        rows => {
            return Err(SpectrumError::Invalid(format!(
                "an ENLIGHT spectrum export holds one acquisition; the log has {}",
                rows.len()
            )))
        }
    };
    let first = row
        .spectra
        .first()
        .ok_or_else(|| SpectrumError::Invalid("the row holds no spectrum".into()))?;
    let mut columns = Vec::with_capacity(row.spectra.len());
    for s in &row.spectra {
        s.validate()?;
        if s.wavelengths_nm != first.wavelengths_nm {
            return Err(SpectrumError::Invalid(
                "ENLIGHT export: every channel must share one wavelength grid".into(),
            ));
        }
        columns.push(dbm_values(s)?);
    }
    let mut out = String::from("\n");
    let (date, time) = text::format_date_time(row.time_s, DateOrder::DayFirst, true);
    out.push_str(&format!("Date: {date} {time}\n"));
    for (k, v) in log.metadata.iter().filter(|(k, _)| k != "Date") {
        out.push_str(&format!("{k}: {v}\n"));
    }
    for s in &row.spectra {
        if !s.metadata.is_empty() {
            out.push_str(&format!("{} Configuration:\n", s.channel));
            for (k, v) in &s.metadata {
                out.push_str(&format!("\t{k}: {v}\n"));
            }
        }
    }
    out.push_str("Wvl (nm)");
    for s in &row.spectra {
        out.push_str(&format!("\t {} ", s.channel));
    }
    out.push_str("\n\n");
    for (i, w) in first.wavelengths_nm.iter().enumerate() {
        out.push_str(&format!("{w:.4}"));
        for c in &columns {
            out.push_str(&format!("\t{:.4}", c[i]));
        }
        out.push('\n');
    }
    Ok(out)
}

fn dbm_values(s: &Spectrum) -> Result<Vec<f64>, SpectrumError> {
    match s.unit {
        PowerUnit::Dbm => Ok(s.power.clone()),
        PowerUnit::Mw => s
            .power
            .iter()
            .map(|&p| {
                if p > 0.0 {
                    Ok(10.0 * p.log10())
                } else {
                    Err(SpectrumError::Invalid(format!(
                        "channel {}: {p} mW cannot be written in dBm",
                        s.channel
                    )))
                }
            })
            .collect(),
        other => Err(SpectrumError::Invalid(format!(
            "ENLIGHT export writes dBm; channel {} is in {}",
            s.channel,
            other.label()
        ))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_blocks_and_indented_keys() {
        let text = "\nDate: 17/04/2025 4:01:03 pm\nIP Address: 10.0.0.55\n      Port: 51971\n\nCH 1 Configuration:\n\tDetect Valley: False\n\tDetection Setting ID: 128\nCH 2 Configuration:\n\tDetect Valley: True\nWvl (nm)\t CH 1 \t CH 2 \n\n1460.0000\t-58.4822\t-60.0\n1460.0080\t-58.3009\t-61.5\n";
        let log = read_enlight(text).unwrap();
        assert_eq!(log.meta("Port"), Some("51971"));
        let row = &log.rows[0];
        assert_eq!(row.spectra[0].meta("Detection Setting ID"), Some("128"));
        assert_eq!(row.spectra[1].meta("Detect Valley"), Some("True"));
        assert_eq!(row.spectra[1].power, vec![-60.0, -61.5]);
        let expected = text::date_time_s((17, 4, 2025), "4:01:03 pm", DateOrder::DayFirst).unwrap();
        assert_eq!(row.time_s, expected);
    }
}
