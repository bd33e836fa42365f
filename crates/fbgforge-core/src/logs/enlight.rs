//! What the two ENLIGHT exports (Micron Optics / Luna: "Peaks" and "Sensors") share:
//! the `Timestamp` header, the timestamps and the metadata block above the table.

use super::detect::HeadLine;
use super::num::split_epoch;
use super::LogStyle;
use std::io::Write;

/// The header line of an ENLIGHT table: `Timestamp`, then at least one more column.
pub(crate) fn is_timestamp_header(head: &HeadLine) -> bool {
    head.first.eq_ignore_ascii_case(b"Timestamp") && !head.second.is_empty()
}

/// A Peaks header column counting a channel's peaks (`# CH 1`).
pub(crate) fn is_channel_column(name: &[u8]) -> bool {
    name.starts_with(b"# CH") || name.starts_with(b"#CH")
}

/// Write an ENLIGHT timestamp `dd/mm/yyyy HH:MM:SS.ffffff` (or on a 12-hour clock).
pub(crate) fn write_timestamp(w: &mut dyn Write, t: f64, style: &LogStyle) -> std::io::Result<()> {
    let (_, y, m, d, sod) = split_epoch(t);
    let h = (sod / 3600.0).floor() as u32;
    let mi = ((sod - h as f64 * 3600.0) / 60.0).floor() as u32;
    let s = (sod - h as f64 * 3600.0 - mi as f64 * 60.0).max(0.0);
    let sep = if style.decimal_comma { "," } else { "." };
    let whole = s.floor() as u32;
    let micros = ((s - whole as f64) * 1e6).round().min(999_999.0) as u32;
    if style.twelve_hour {
        let (h12, ampm) = match h {
            0 => (12, "am"),
            1..=11 => (h, "am"),
            12 => (12, "pm"),
            _ => (h - 12, "pm"),
        };
        write!(
            w,
            "{d:02}/{m:02}/{y:04} {h12}:{mi:02}:{whole:02}{sep}{micros:06} {ampm}"
        )
    } else {
        write!(
            w,
            "{d:02}/{m:02}/{y:04} {h:02}:{mi:02}:{whole:02}{sep}{micros:06}"
        )
    }
}

/// Write `lines` lines of ENLIGHT metadata (date, module, rate, then detection
/// settings), as the software puts above the table.
pub(crate) fn write_metadata(
    w: &mut dyn Write,
    lines: usize,
    rate_hz: f64,
    t0: f64,
) -> std::io::Result<()> {
    let (_, y, m, d, _) = split_epoch(t0);
    let fixed = [
        format!("Date:\t{d:02}/{m:02}/{y:04}"),
        "Module Type:\tsm125-500".to_string(),
        format!("HW Acquisition Rate: {rate_hz} Hz"),
        "Timestamp Format: Full".to_string(),
        "Data Interleave:\t1".to_string(),
    ];
    for (i, l) in fixed.iter().enumerate() {
        if i < lines {
            writeln!(w, "{l}")?;
        }
    }
    for i in fixed.len()..lines {
        let ch = i % 4 + 1;
        writeln!(
            w,
            "CH {ch} Peak Detection Setting {}:\tThreshold {} dB",
            i,
            3 + i % 7
        )?;
    }
    Ok(())
}
