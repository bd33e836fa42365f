//! OSA / swept-laser CSV: `Wavelength (nm),Rx (dB),Tx (dB)` or
//! `Wavelength (nm),Amplitude (AU)`, one row per wavelength. Lines before the header
//! are kept as metadata (`key,value…`).

use super::text;
use crate::error::{parse_error, SpectrumError};
use crate::formats::SpectrumFormat;
use crate::spectrum::{PowerUnit, Spectrum, SpectrumLog, SpectrumRow};

fn delimiter_of(line: &str) -> char {
    if line.contains('\t') {
        '\t'
    } else if line.contains(';') {
        ';'
    } else {
        ','
    }
}

pub(crate) fn is_header(line: &str) -> bool {
    let f = text::fields(line, delimiter_of(line));
    f.len() >= 2 && f[0].to_ascii_lowercase().starts_with("wavelength")
}

pub(crate) fn looks_numeric(line: &str) -> bool {
    let f = text::fields(line, delimiter_of(line));
    f.len() >= 2 && f.iter().all(|x| x.replace(',', ".").parse::<f64>().is_ok())
}

/// The unit text inside `(…)` or `[…]` of a column label, and the label without it.
fn split_unit(label: &str) -> (String, Option<String>) {
    for (open, close) in [('(', ')'), ('[', ']')] {
        if let (Some(a), Some(b)) = (label.rfind(open), label.rfind(close)) {
            if a < b {
                let unit = label[a + 1..b].trim().to_string();
                let name = format!("{}{}", label[..a].trim(), label[b + 1..].trim());
                return (name.trim().to_string(), Some(unit));
            }
        }
    }
    (label.trim().to_string(), None)
}

/// Power unit of a column and the factor that brings its values to that unit.
fn power_unit(
    unit: Option<&str>,
    line: usize,
    label: &str,
) -> Result<(PowerUnit, f64), SpectrumError> {
    let u = unit.unwrap_or("").to_ascii_lowercase();
    let u = u.trim();
    Ok(match u {
        "dbm" => (PowerUnit::Dbm, 1.0),
        "db" => (PowerUnit::Db, 1.0),
        "mw" => (PowerUnit::Mw, 1.0),
        "w" => (PowerUnit::Mw, 1e3),
        "uw" | "µw" | "μw" => (PowerUnit::Mw, 1e-3),
        "nw" => (PowerUnit::Mw, 1e-6),
        "" | "au" | "a.u." | "arb" | "arb." | "arb. units" | "a.u" | "linear" | "ratio" => {
            (PowerUnit::Linear, 1.0)
        }
        "counts" | "count" => (PowerUnit::Counts, 1.0),
        _ => {
            return Err(parse_error(
                line,
                "a power unit in the column label: dBm, dB, mW, µW, nW, W, AU, linear or counts",
                label,
            ))
        }
    })
}

fn wavelength_scale(unit: Option<&str>, line: usize, label: &str) -> Result<f64, SpectrumError> {
    match unit.map(|u| u.to_ascii_lowercase()).as_deref() {
        None | Some("nm") => Ok(1.0),
        Some("um") | Some("µm") | Some("μm") => Ok(1e3),
        _ => Err(parse_error(line, "a wavelength column in nm or µm", label)),
    }
}

/// Reads an OSA / swept-laser CSV (`,`, `;` or tab separated; with `;` or tab a decimal
/// comma is accepted): the first field of the header starts with `Wavelength` (nm by
/// default, µm converted), each further column is one spectrum named by its label
/// without the unit, in the unit the label states (`(dB)`, `(dBm)`, `(mW)`, `(AU)`, …;
/// W, µW and nW are converted to mW; no unit means linear). A decreasing file is
/// reversed.
pub fn read_osa_csv(text: &str) -> Result<SpectrumLog, SpectrumError> {
    let mut lines = text::numbered_lines(text);
    let mut metadata = Vec::new();
    let mut header = None;
    for (number, line) in lines.by_ref() {
        if line.trim().is_empty() {
            continue;
        }
        if is_header(line) {
            header = Some((number, line));
            break;
        }
        let d = delimiter_of(line);
        let f = text::fields(line, d);
        if let Some((k, rest)) = f.split_first() {
            metadata.push((k.to_string(), rest.join(", ")));
        }
    }
    let (header_line, header) = header
        .ok_or_else(|| SpectrumError::UnknownFormat("no `Wavelength (nm),…` CSV header".into()))?;
    let delimiter = delimiter_of(header);
    let labels = text::fields(header, delimiter);
    let (_, wl_unit) = split_unit(labels[0]);
    let wl_scale = wavelength_scale(wl_unit.as_deref(), header_line, labels[0])?;
    let mut columns = Vec::new();
    for label in &labels[1..] {
        let (name, unit) = split_unit(label);
        let (unit, scale) = power_unit(unit.as_deref(), header_line, label)?;
        columns.push((name, unit, scale, Vec::new()));
    }
    let mut wavelengths = Vec::new();
    let mut line_numbers = Vec::new();
    for (number, line) in lines {
        if line.trim().is_empty() {
            continue;
        }
        let f = text::fields(line, delimiter);
        if f.len() != labels.len() {
            return Err(SpectrumError::Ragged {
                line: number,
                expected: format!("{} as in the header", labels.len()),
                found: f.len(),
            });
        }
        let comma = delimiter != ',';
        wavelengths.push(wl_scale * text::parse_number(f[0], number, "wavelength", comma)?);
        line_numbers.push(number);
        for (k, (name, _, scale, values)) in columns.iter_mut().enumerate() {
            values.push(
                *scale * text::parse_number(f[k + 1], number, &format!("power ({name})"), comma)?,
            );
        }
    }
    let reverse = text::check_monotonic(&wavelengths, &line_numbers)?;
    if reverse {
        wavelengths.reverse();
    }
    let spectra = columns
        .into_iter()
        .map(|(name, unit, _, mut power)| {
            if reverse {
                power.reverse();
            }
            Spectrum {
                channel: name,
                wavelengths_nm: wavelengths.clone(),
                power,
                unit,
                metadata: Vec::new(),
            }
        })
        .collect();
    Ok(SpectrumLog {
        format: SpectrumFormat::OsaCsv,
        metadata,
        rows: vec![SpectrumRow {
            time_s: 0.0,
            spectra,
            reported_peaks_nm: Vec::new(),
        }],
    })
}

/// Writes one acquisition as a comma-separated OSA CSV: the log's metadata lines
/// (`key,value`), the header `Wavelength (nm),<channel> (<unit>),…`, wavelengths with 5
/// decimals (0.01 pm), dB and dBm with 4 decimals, linear units with 7 significant
/// digits. Every spectrum must share one wavelength grid.
pub fn write_osa_csv(log: &SpectrumLog) -> Result<String, SpectrumError> {
    let row = match log.rows.as_slice() {
        [row] => row,
        rows => {
            return Err(SpectrumError::Invalid(format!(
                "an OSA CSV holds one acquisition; the log has {}",
                rows.len()
            )))
        }
    };
    let first = row
        .spectra
        .first()
        .ok_or_else(|| SpectrumError::Invalid("the row holds no spectrum".into()))?;
    for s in &row.spectra {
        s.validate()?;
        if s.wavelengths_nm != first.wavelengths_nm {
            return Err(SpectrumError::Invalid(
                "OSA CSV: every column must share one wavelength grid".into(),
            ));
        }
        if s.channel.contains([',', '(', ')', '"']) {
            return Err(SpectrumError::Invalid(format!(
                "OSA CSV: channel label `{}` holds , ( ) or \"",
                s.channel
            )));
        }
    }
    let mut out = String::new();
    for (k, v) in &log.metadata {
        out.push_str(&format!("{k},{v}\n"));
    }
    out.push_str("Wavelength (nm)");
    for s in &row.spectra {
        out.push_str(&format!(",{} ({})", s.channel, s.unit.label()));
    }
    out.push('\n');
    for (i, w) in first.wavelengths_nm.iter().enumerate() {
        out.push_str(&format!("{w:.5}"));
        for s in &row.spectra {
            if s.unit.is_logarithmic() {
                out.push_str(&format!(",{:.4}", s.power[i]));
            } else {
                out.push_str(&format!(",{:.6e}", s.power[i]));
            }
        }
        out.push('\n');
    }
    Ok(out)
}
