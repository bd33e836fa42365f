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

#[test]
fn every_format_reads_back_what_it_writes() {
    let (time_s, names, rows) = table_values();
    // 17/04/2025 15:44:56: the day (17) tells the date order in every format.
    let t0 = days_from_civil(2025, 4, 17) as f64 * 86400.0 + 56696.0;
    let table = LogTable {
        start_epoch_s: t0,
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
                Clock::Absolute => t0,
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
