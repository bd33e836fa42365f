//! The registry's contract, checked for every registered format: what a format writes,
//! detection recognises as that format and its reader gives back.

use super::num::days_from_civil;
use super::*;

/// Three gratings over six rows one second apart, two peaks missing; wavelengths with
/// four decimals (what every format writes exactly).
fn table_values() -> (Vec<f64>, Vec<String>, Vec<Vec<f64>>) {
    let time_s: Vec<f64> = (0..6).map(f64::from).collect();
    let names = vec!["fbg_a".to_string(), "fbg_b".into(), "fbg_ref".into()];
    let rows = (0..6)
        .map(|i| {
            let d = f64::from(i) * 0.0125;
            let mut r = vec![1524.5703 + d, 1546.2953 - d, 1560.1461];
            if i == 2 {
                r[0] = f64::NAN;
            }
            if i == 4 {
                r[2] = f64::NAN;
            }
            r
        })
        .collect();
    (time_s, names, rows)
}

/// 17/04/2025 15:44:56: the day (17) tells the date order in every format.
fn log_start_epoch_s() -> f64 {
    days_from_civil(2025, 4, 17) as f64 * 86400.0 + 56696.0
}

/// A long log's table: `rows` at 100 Hz from [`log_start_epoch_s`].
fn long_table<'a>(time_s: &'a [f64], names: &'a [String], rows: &'a [Vec<f64>]) -> LogTable<'a> {
    LogTable {
        start_epoch_s: log_start_epoch_s(),
        time_s,
        names,
        wavelength_nm: rows,
        sample_rate_hz: 100.0,
    }
}

/// `table` written in `format`, with a garbled line a third of the way in.
fn written_with_a_garbled_line(format: LogFormat, table: &LogTable) -> Vec<u8> {
    let mut bytes = Vec::new();
    write_log(&mut bytes, format, table, &LogStyle::default()).unwrap();
    let third = bytes.len() / 3;
    let at = third + memchr::memchr(b'\n', &bytes[third..]).unwrap() + 1;
    bytes.splice(at..at, b"garbled line\n".iter().copied());
    bytes
}

#[test]
fn every_format_reads_back_what_it_writes() {
    let (time_s, names, rows) = table_values();
    let table = LogTable {
        start_epoch_s: log_start_epoch_s(),
        time_s: &time_s,
        names: &names,
        wavelength_nm: &rows,
        sample_rate_hz: 1.0,
    };
    let styles = [
        LogStyle::default(),
        LogStyle {
            decimal_comma: true,
            bom: true,
            metadata_lines: 7,
            twelve_hour: true,
            ..LogStyle::default()
        },
    ];
    for format in LogFormat::ALL {
        for style in &styles {
            let mut bytes = Vec::new();
            write_log(&mut bytes, format, &table, style).unwrap();
            let path = PathBuf::from(format!("log.{}", format.extension()));
            let what = format!("{} {style:?}", format.name());
            let log = parse_wavelength_bytes(&bytes, &path, &ReadOptions::default())
                .unwrap_or_else(|e| panic!("{what}: {e:#}"));
            assert_eq!(log.format, format, "{what}");
            assert_eq!(log.clock, format.written_clock(), "{what}");
            let origin = match format.written_clock() {
                Clock::Absolute => log_start_epoch_s(),
                Clock::Relative => 0.0,
            };
            let want_t: Vec<f64> = time_s.iter().map(|t| origin + t).collect();
            assert_eq!(log.time_s, want_t, "{what}");
            assert_eq!(log.warnings.total(), 0, "{what}: {:?}", log.warnings);
            for (i, row) in rows.iter().enumerate() {
                let (peaks, chans) = log.row(i);
                let mut want: Vec<(f64, u16)> = row
                    .iter()
                    .enumerate()
                    .filter(|(_, v)| v.is_finite())
                    .map(|(g, &v)| (v, g as u16))
                    .collect();
                if format == LogFormat::Imon {
                    // One channel, peaks in wavelength order.
                    want.sort_by(|a, b| a.0.total_cmp(&b.0));
                    want.iter_mut().for_each(|w| w.1 = 0);
                }
                assert_eq!(peaks.len(), want.len(), "{what} row {i}");
                for ((p, c), (w, wc)) in peaks.iter().zip(chans).zip(&want) {
                    assert!((p - w).abs() < 1e-9, "{what} row {i}: {p} ≠ {w}");
                    assert_eq!(c, wc, "{what} row {i}");
                }
            }
            if matches!(format, LogFormat::EnlightSensors | LogFormat::Csv) {
                assert_eq!(log.column_names, names, "{what}");
            }
        }
    }
}

/// The JSON names are the registered ones (the command line's are checked beside its
/// flags, `cli::verify`).
#[test]
fn registered_names_are_the_json_names() {
    for format in LogFormat::ALL.into_iter().chain(LogFormat::SPECTRA) {
        assert_eq!(LogFormat::from_name(format.name()), Some(format));
        assert_eq!(
            serde_json::to_value(format).unwrap(),
            serde_json::Value::String(format.name().into())
        );
    }
}

#[test]
fn an_unknown_file_names_every_registered_format() {
    let e = detect_format(b"hello\nworld\n", Path::new("x.txt"), None)
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("x.txt: cannot tell the log format"), "{e}");
    for format in LogFormat::ALL {
        assert!(e.contains(format.reader().title()), "{e}");
        assert!(e.contains(format.reader().expected()), "{e}");
    }
    assert!(
        e.ends_with("name the format with ReadOptions.format"),
        "{e}"
    );
}

#[test]
fn a_wall_clock_set_back_or_forward_is_named_with_its_line() {
    // Issue #33, class 5: 100 rows at 10 Hz, the clock set back 1 h at row 40 and
    // forward 1 h at row 70 (a DST change and its return): both named, nothing else.
    let mut t: Vec<f64> = (0..100).map(|i| 1000.0 + 0.1 * i as f64).collect();
    for v in &mut t[40..] {
        *v -= 3600.0;
    }
    for v in &mut t[70..] {
        *v += 3600.0;
    }
    let lines: Vec<u32> = (0..100).map(|i| i + 2).collect();
    let mut w = LogWarnings::default();
    let jumps = time::clock_jumps(Path::new("log.txt"), &t, &lines, &mut w);
    assert_eq!(jumps.len(), 2, "{jumps:?}");
    assert!(jumps[0].backwards() && (jumps[0].step_s + 3599.9).abs() < 1e-6);
    assert_eq!(jumps[0].line, 42);
    assert!(!jumps[1].backwards() && (jumps[1].step_s - 3600.1).abs() < 1e-6);
    assert_eq!(w.count("clock_jump"), 1);
    assert_eq!(w.count("clock_gap"), 1);
}

#[test]
fn whole_second_stamps_with_pauses_keep_every_row_in_its_second() {
    // Issue #33, class 6: 10 rows per second written in whole seconds, with pauses of
    // 171, 83, 39 and 8 s (the I-MON log): one grid over all of it put rows up to
    // 187 s late; per stretch, every row stays inside the second written on it.
    let mut written = Vec::new();
    let mut t = 0.37f64; // the true time of the first row
    for (rows, pause) in [
        (400, 171.0),
        (300, 83.0),
        (250, 39.0),
        (200, 8.0),
        (300, 0.0),
    ] {
        for _ in 0..rows {
            written.push(t.floor());
            t += 0.1;
        }
        t += pause;
    }
    let mut spread = written.clone();
    let mut w = LogWarnings::default();
    let half = time::dequantize(Path::new("imon.txt"), &mut spread, &mut w);
    assert!(half > 0.0 && half <= 0.5, "{half}");
    for (s, wr) in spread.iter().zip(&written) {
        assert!(*s >= *wr && *s < wr + 1.0, "row at {s} written {wr}");
    }
    assert!(spread.windows(2).all(|p| p[1] > p[0]));
    let text = w.counts["whole_second_timestamps"].first.clone();
    assert!(text.contains("5 stretches between pauses"), "{text}");
}

#[test]
fn a_units_column_is_read_row_by_row_or_refused_naming_it() {
    // Issue #33, item 7: a Mark-10 style `Units` column (lbF in every row) was ignored
    // and newtons assumed, K 4.45 times off.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("mark10.csv");
    std::fs::write(
        &p,
        "Time_s,Force,Units\n0.0,1.000,lbF\n0.1,2.000,lbF\n0.2,3.000,N\n",
    )
    .unwrap();
    let f = read_force_log(&p, &ForceReadOptions::default()).unwrap();
    assert!(
        (f.force_n[0] - 4.448_221_615).abs() < 1e-9,
        "{:?}",
        f.force_n
    );
    assert!((f.force_n[1] - 8.896_443_23).abs() < 1e-8);
    assert!((f.force_n[2] - 3.0).abs() < 1e-12);
    assert_eq!(f.warnings.count("force_unit_per_row"), 1);
    std::fs::write(&p, "Time_s,Force,Units\n0.0,1.000,lbF\n0.1,2.000,psi\n").unwrap();
    let err = format!(
        "{:#}",
        read_force_log(&p, &ForceReadOptions::default()).unwrap_err()
    );
    assert!(
        err.contains("mark10.csv:3:")
            && err.contains("units column (column 3)")
            && err.contains("psi"),
        "{err}"
    );
}

#[test]
fn a_log_streamed_in_small_blocks_reads_as_the_whole_file() {
    // Every format, 20 000 rows (about 1 MB, far over the 64 KiB head and 4 KiB blocks
    // a test streams with), a garbled line in the middle and the last line cut short:
    // streamed block by block it gives the same rows, times, peaks, line numbers and
    // warnings as the file parsed at once.
    let n = 20_000;
    let time_s: Vec<f64> = (0..n).map(|i| f64::from(i) * 0.01).collect();
    let names = vec!["fbg_a".to_string(), "fbg_b".into()];
    let rows: Vec<Vec<f64>> = (0..n)
        .map(|i| vec![1524.5703 + f64::from(i % 97) * 1e-4, 1546.2953])
        .collect();
    let table = long_table(&time_s, &names, &rows);
    let dir = tempfile::tempdir().unwrap();
    for format in LogFormat::ALL {
        let mut bytes = written_with_a_garbled_line(format, &table);
        // The last line cut in its middle.
        let last = memchr::memrchr(b'\n', &bytes[..bytes.len() - 1]).unwrap();
        bytes.truncate(last + 6);
        let path = dir.path().join(format!("log.{}", format.extension()));
        std::fs::write(&path, &bytes).unwrap();
        let whole = parse_wavelength_bytes(&bytes, &path, &ReadOptions::default()).unwrap();
        let streamed = read_peak_log_in_blocks(&path, &ReadOptions::default(), 4096).unwrap();
        assert!(whole.rows() > 19_000, "{}", format.name());
        assert_eq!(streamed, whole, "{}", format.name());
    }
}

/// Peaks assigned block by block as a long log is read ([`read_peak_log_assigned`])
/// give the tracks [`assign::assign`] gives on the whole log, for every format: a
/// second peak in a window now and then (the tracker's choice depends on the row
/// before, across the blocks' seams), peaks missing, a garbled line; the log comes back
/// as the whole read with its peaks dropped. A log whose rows must be sorted by time is
/// read whole instead (its peaks kept, no tracks).
#[test]
fn peaks_assigned_while_streaming_are_the_whole_logs_assignment() {
    use assign::{assign, GratingWindow};
    let n = 20_000;
    let time_s: Vec<f64> = (0..n).map(|i| f64::from(i) * 0.01).collect();
    let names = vec!["fbg_a".to_string(), "fbg_b".into(), "fbg_c".into()];
    let rows: Vec<Vec<f64>> = (0..n)
        .map(|i| {
            let a = 1524.5703 + f64::from(i % 97) * 1e-4;
            // Every 7th row a rival peak in fbg_a's window, every 11th fbg_b missing.
            let c = if i % 7 == 0 { 1525.1 } else { f64::NAN };
            let b = if i % 11 == 0 { f64::NAN } else { 1546.2953 };
            vec![a, b, c]
        })
        .collect();
    let table = long_table(&time_s, &names, &rows);
    let windows = [
        GratingWindow::new("a", 1524.6, 2.0),
        GratingWindow::new("b", 1546.3, 2.0),
    ];
    let opts = ReadOptions::default();
    let dir = tempfile::tempdir().unwrap();
    for format in LogFormat::ALL {
        let bytes = written_with_a_garbled_line(format, &table);
        let path = dir.path().join(format!("log.{}", format.extension()));
        std::fs::write(&path, &bytes).unwrap();
        let mut whole = parse_wavelength_bytes(&bytes, &path, &opts).unwrap();
        let want = assign(&whole, &windows);
        let (log, tracks) = read_blocks(&path, &opts, 4096, Some(&windows)).unwrap();
        let name = format.name();
        if whole.uncertainty.is_some() {
            // Peaks with standard errors are read whole, for the caller to assign.
            assert!(tracks.is_none(), "{name}");
            assert_eq!(log, whole, "{name}");
            continue;
        }
        let tracks = tracks.unwrap_or_else(|| panic!("{name}: not assigned while read"));
        assert!(
            want[0].rows_ambiguous > 2000,
            "{name}: {}",
            want[0].rows_ambiguous
        );
        assert!(want[1].rows_present < n as usize - 1000, "{name}");
        // NaN offsets compare unequal: compare their bits.
        for (got, want) in tracks.iter().zip(&want) {
            let bits = |t: &assign::GratingTrack| -> Vec<u32> {
                t.offset_pm.iter().map(|o| o.to_bits()).collect()
            };
            assert_eq!(bits(got), bits(want), "{name}");
            assert_eq!(
                (got.rows_present, got.rows_ambiguous, &got.window),
                (want.rows_present, want.rows_ambiguous, &want.window),
                "{name}"
            );
            assert_eq!(got.std_error_pm, want.std_error_pm, "{name}");
        }
        whole.drop_peaks();
        assert_eq!(log, whole, "{name}");
    }
    // Two rows swapped: the rows are sorted by time, so the log is read whole.
    let mut text = String::from("time_s,a,b\n");
    for i in 0..2000 {
        let k = match i {
            500 => 501,
            501 => 500,
            _ => i,
        };
        text.push_str(&format!(
            "{:.2},{:.4},1546.2953\n",
            f64::from(k) * 0.01,
            1524.5703 + f64::from(k % 13) * 1e-4
        ));
    }
    let path = dir.path().join("swapped.csv");
    std::fs::write(&path, &text).unwrap();
    let (log, tracks) = read_blocks(&path, &opts, 4096, Some(&windows)).unwrap();
    assert!(tracks.is_none());
    assert_eq!(log, read_peak_log(&path, &opts).unwrap());
    assert_eq!(log.rows(), 2000);
    assert!(!log.row(0).0.is_empty());
}
