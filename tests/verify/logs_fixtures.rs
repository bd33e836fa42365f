//! Readers against small hand-written fixtures covering the edge cases of real exports.

use fbgforge::logs::num::days_from_civil;
use fbgforge::logs::{self, Clock, ForceReadOptions, LogFormat, ReadOptions};
use std::path::{Path, PathBuf};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures/logs")
        .join(name)
}

fn read(name: &str) -> logs::PeakLog {
    logs::read_peak_log(&fixture(name), &ReadOptions::default())
        .unwrap_or_else(|e| panic!("{name}: {e:#}"))
}

fn epoch(y: i64, m: u32, d: u32, h: f64, mi: f64, s: f64) -> f64 {
    days_from_civil(y, m, d) as f64 * 86400.0 + h * 3600.0 + mi * 60.0 + s
}

#[test]
fn bom_decimal_commas_and_twelve_hour_timestamps() {
    let log = read("enlight_peaks_bom_decimal_comma.txt");
    assert_eq!(log.format, LogFormat::EnlightPeaks);
    assert_eq!(log.channels, 4);
    assert_eq!(log.rows(), 6);
    assert_eq!(log.clock, Clock::Absolute);
    let (p, ch) = log.row(1);
    assert_eq!(p, &[1524.5703, 1546.2961, 1560.1461]);
    assert_eq!(ch, &[0, 0, 1]);
    // Two rows per whole second: spread uniformly at 2 Hz, within the second written.
    let t0 = epoch(2025, 4, 17, 15.0, 44.0, 56.0);
    assert!((log.median_period_s() - 0.5).abs() < 1e-9);
    assert!(
        log.time_s[0] >= t0 && log.time_s[0] < t0 + 0.5,
        "{}",
        log.time_s[0] - t0
    );
    for (i, t) in log.time_s.iter().enumerate() {
        let written = t0 + (i / 2) as f64;
        assert!(*t >= written && *t < written + 1.0, "row {i}");
    }
    assert_eq!(log.warnings.count("whole_second_timestamps"), 1);
}

#[test]
fn long_metadata_block_dropped_peaks_and_a_truncated_last_line() {
    let log = read("enlight_peaks_104_metadata_dropped_truncated.txt");
    assert_eq!(log.format, LogFormat::EnlightPeaks);
    assert_eq!(log.channels, 2);
    // The metadata line `Timestamp Format: Full` was not taken for the header.
    assert_eq!(log.line_of_row[0], 106);
    assert_eq!(log.rows(), 3, "the truncated last row is dropped");
    assert_eq!(log.warnings.count("truncated_last_line"), 1);
    assert!(
        log.warnings.counts["truncated_last_line"]
            .first
            .contains(":109:"),
        "{:?}",
        log.warnings
    );
    // Row 2 lost the 1524 nm peak: one peak on channel 1, one on channel 2.
    assert_eq!(log.row(1), (&[1546.296, 1560.1461][..], &[0u16, 1][..]));
    assert_eq!(log.time_s[1] - log.time_s[0], 0.5);
    assert_eq!(log.time_s[0], epoch(2025, 4, 17, 15.0, 44.0, 56.0));
}

#[test]
fn non_monotonic_timestamps_are_sorted_and_counted() {
    let log = read("enlight_peaks_non_monotonic.txt");
    assert_eq!(log.rows(), 5);
    assert!(log.time_s.windows(2).all(|w| w[1] >= w[0]));
    assert_eq!(log.warnings.count("non_monotonic_timestamp"), 1);
    assert!(log.warnings.counts["non_monotonic_timestamp"]
        .first
        .contains(":7:"));
    // The row written fourth (56.75 s) now sits third, with its own peaks.
    assert_eq!(log.row(2).0[0], 1524.5703);
    assert_eq!(log.line_of_row, vec![4, 5, 7, 6, 8]);
}

#[test]
fn garbage_lines_and_a_missing_channel_are_skipped_and_counted() {
    let log = read("enlight_peaks_garbage_missing_channel.txt");
    assert_eq!(log.rows(), 6);
    let w = &log.warnings;
    assert_eq!(w.count("unreadable_line"), 2, "{w:?}");
    assert_eq!(w.count("missing_channel"), 1, "{w:?}");
    assert_eq!(w.count("peak_count_mismatch"), 1, "{w:?}");
    assert!(w.counts["unreadable_line"].first.contains(":5:"), "{w:?}");
    assert!(
        w.counts["missing_channel"].first.contains("channel 3"),
        "{w:?}"
    );
}

#[test]
fn sensors_export_keeps_gaps_per_column() {
    let log = read("enlight_sensors.txt");
    assert_eq!(log.format, LogFormat::EnlightSensors);
    assert_eq!(
        log.column_names,
        vec!["lambda_11", "lambda_12", "lambda_temp"]
    );
    assert_eq!(log.row(1), (&[1546.296, 1560.146][..], &[0u16, 2][..]));
    assert_eq!(log.warnings.total(), 0);
}

#[test]
fn imon_log_with_varying_wavelength_columns_and_pixels() {
    let log = read("imon.txt");
    assert_eq!(log.format, LogFormat::Imon);
    assert_eq!(log.rows(), 6);
    assert_eq!(log.row(1).0, &[1546.296, 1560.1461]);
    // Row 3 carries the four pixel intensities of the header after its wavelengths.
    assert_eq!(log.row(2).0, &[1524.571, 1546.297, 1560.146]);
    // Month-first dates (10/30/2020), 12-hour clock, 1 s resolution spread to 2 Hz.
    let t0 = epoch(2020, 10, 30, 16.0, 44.0, 10.0);
    assert!(log.time_s[0] >= t0 && log.time_s[0] < t0 + 0.5);
    assert!((log.median_period_s() - 0.5).abs() < 1e-9);
}

#[test]
fn plain_csv_with_comment_and_empty_cell() {
    let log = read("plain.csv");
    assert_eq!(log.format, LogFormat::Csv);
    assert_eq!(log.clock, Clock::Relative);
    assert_eq!(log.time_s, vec![0.0, 0.05, 0.10]);
    assert_eq!(log.row(1), (&[1546.2953, 1560.146][..], &[0u16, 2][..]));
}

#[test]
fn force_stand_columns_units_and_clocks() {
    let f =
        logs::read_force_log(&fixture("force_stand.csv"), &ForceReadOptions::default()).unwrap();
    assert_eq!(
        (f.time_column.as_str(), f.force_column.as_str()),
        ("RelTime", "force")
    );
    assert_eq!(f.clock, Clock::Relative);
    assert_eq!(f.force_n, vec![0.012, 5.25, 10.5, 5.2]);
    assert_eq!(f.warnings.count("force_unit_assumed"), 1);
    let cols = ForceReadOptions {
        time: Some("AbsTime".into()),
        ..Default::default()
    };
    let f = logs::read_force_log(&fixture("force_stand.csv"), &cols).unwrap();
    assert_eq!(f.clock, Clock::Absolute);
    assert_eq!(f.time_s[2], epoch(2025, 4, 17, 15.0, 44.0, 56.0));
    // `Force [kN]` with decimal commas and `;` separators: converted to N.
    let f = logs::read_force_log(
        &fixture("force_kn_semicolon.csv"),
        &ForceReadOptions::default(),
    )
    .unwrap();
    assert_eq!(f.scale_to_n, 1000.0);
    assert_eq!(f.force_n, vec![0.0, 12.5, 25.0]);
    assert_eq!(f.time_s, vec![0.0, 0.5, 1.0]);
    // A column that does not exist is named in the error.
    let cols = ForceReadOptions {
        force: Some("load_cell".into()),
        ..Default::default()
    };
    let e = logs::read_force_log(&fixture("force_stand.csv"), &cols)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("load_cell") && e.contains("AbsTime, RelTime"),
        "{e}"
    );
}

#[test]
fn unreadable_files_give_errors_naming_file_and_line() {
    let e = logs::read_peak_log(&fixture("metadata_only.txt"), &ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("metadata_only.txt") && e.contains("ReadOptions.format"),
        "{e}"
    );
    let e = logs::read_peak_log(&fixture("mostly_garbage.txt"), &ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("mostly_garbage.txt") && e.contains("3 of 4") && e.contains(":4:"),
        "{e}"
    );
    let forced = ReadOptions {
        format: Some(LogFormat::Imon),
        ..Default::default()
    };
    let e = logs::read_peak_log(&fixture("plain.csv"), &forced)
        .unwrap_err()
        .to_string();
    assert!(e.contains("no imon table header"), "{e}");
    let e =
        logs::read_peak_log(&fixture("does_not_exist.txt"), &ReadOptions::default()).unwrap_err();
    assert!(format!("{e:#}").contains("does_not_exist.txt"));
}

mod properties {
    use fbgforge::logs::num::{date_to_days, format_dmy_24h, parse_datetime, parse_f64, DateOrder};
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn fast_float_parsing_equals_std(x in -1.0e7f64..1.0e7, decimals in 0usize..12, exp in any::<bool>()) {
            let s = if exp { format!("{x:.decimals$E}") } else { format!("{x:.decimals$}") };
            prop_assert_eq!(parse_f64(s.as_bytes(), false), s.parse::<f64>().ok());
            // The same number with a decimal comma.
            let c = s.replace('.', ",");
            prop_assert_eq!(parse_f64(c.as_bytes(), true), s.parse::<f64>().ok());
        }

        #[test]
        fn timestamps_round_trip_to_the_microsecond(micros in 0i64..4_102_444_800_000_000) {
            let t = micros as f64 / 1e6;
            let s = format_dmy_24h(t);
            let (d, sod) = parse_datetime(s.as_bytes()).unwrap();
            let back = date_to_days(&d, DateOrder::DayMonthYear).unwrap() as f64 * 86400.0 + sod;
            prop_assert!((back - t).abs() < 2e-6, "{} -> {} -> {}", t, s, back);
        }
    }
}

mod never_panics {
    use fbgforge::logs::{
        parse_force_bytes, parse_wavelength_bytes, ForceReadOptions, ReadOptions,
    };
    use proptest::prelude::*;
    use std::path::Path;

    const FIXTURES: [&str; 6] = [
        "enlight_peaks_bom_decimal_comma.txt",
        "enlight_peaks_104_metadata_dropped_truncated.txt",
        "enlight_peaks_garbage_missing_channel.txt",
        "enlight_sensors.txt",
        "imon.txt",
        "plain.csv",
    ];

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(
            std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(300)
        ))]
        /// Random byte edits and truncations of every fixture give Ok or an error.
        #[test]
        fn mutated_logs_are_read_or_rejected(which in 0usize..6, edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 0..12), cut in any::<prop::sample::Index>()) {
            let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/logs").join(FIXTURES[which]);
            let mut bytes = std::fs::read(&path).unwrap();
            for (at, b) in edits {
                let i = at.index(bytes.len());
                bytes[i] = b;
            }
            let keep = cut.index(bytes.len() + 1);
            bytes.truncate(keep.max(1));
            let _ = parse_wavelength_bytes(&bytes, &path, &ReadOptions::default());
            let _ = parse_force_bytes(&bytes, &path, &ForceReadOptions::default());
        }
    }
}

#[test]
fn windows_line_endings_read_the_same() {
    for name in [
        "enlight_peaks_bom_decimal_comma.txt",
        "enlight_sensors.txt",
        "imon.txt",
        "plain.csv",
    ] {
        let path = fixture(name);
        let bytes = std::fs::read(&path).unwrap();
        let text = String::from_utf8(bytes.clone()).unwrap();
        let crlf = text.replace('\n', "\r\n");
        let a = logs::parse_wavelength_bytes(&bytes, &path, &ReadOptions::default()).unwrap();
        let b =
            logs::parse_wavelength_bytes(crlf.as_bytes(), &path, &ReadOptions::default()).unwrap();
        assert_eq!(a.time_s, b.time_s, "{name}");
        assert_eq!(a.peaks_nm, b.peaks_nm, "{name}");
        assert_eq!(a.warnings, b.warnings, "{name}");
    }
    let path = fixture("force_stand.csv");
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace('\n', "\r\n");
    let f = logs::parse_force_bytes(text.as_bytes(), &path, &ForceReadOptions::default()).unwrap();
    assert_eq!(f.force_n, vec![0.012, 5.25, 10.5, 5.2]);
}

/// Write `text` as a force log in a temporary folder and read it with `cols`.
fn force_from(text: &str, cols: &ForceReadOptions) -> anyhow::Result<logs::ForceLog> {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("force.csv");
    std::fs::write(&p, text).unwrap();
    logs::read_force_log(&p, cols)
}

#[test]
fn force_logs_are_read_as_labs_write_them() {
    let cols = ForceReadOptions::default();
    // Milliseconds in the name: `time_ms` and `Time [ms]` are not seconds.
    for header in ["time_ms,force_N", "Time [ms],Force [N]"] {
        let f = force_from(&format!("{header}\n0,0\n500,1.5\n1000,3\n"), &cols).unwrap();
        assert_eq!(f.time_s, vec![0.0, 0.5, 1.0], "{header}");
        assert_eq!(f.force_n, vec![0.0, 1.5, 3.0], "{header}");
    }
    // An Instron/Bluehill units row under the header: seconds and kilonewtons.
    let f = force_from(
        "Time,Extension,Load\n(s),(mm),(kN)\n0.0,0.00,0.000\n0.5,0.10,0.012\n1.0,0.20,0.025\n",
        &cols,
    )
    .unwrap();
    assert_eq!(f.time_s, vec![0.0, 0.5, 1.0]);
    assert!((f.force_n[2] - 25.0).abs() < 1e-9, "{:?}", f.force_n);
    assert_eq!(f.warnings.count("force_unit_assumed"), 0);
    // A units row in milliseconds scales the time.
    let f = force_from("Time,Load\n(ms),(N)\n0,1\n250,2\n500,3\n", &cols).unwrap();
    assert_eq!(f.time_s, vec![0.0, 0.25, 0.5]);
    // Quoted CSV, as Excel and Bluehill write it.
    let f = force_from(
        "\"time_s\",\"force_N\"\n\"0.0\",\"1.0\"\n\"0.5\",\"2.0\"\n\"1.0\",\"3.0\"\n",
        &cols,
    )
    .unwrap();
    assert_eq!(f.time_s, vec![0.0, 0.5, 1.0]);
    assert_eq!(f.force_n, vec![1.0, 2.0, 3.0]);
}

#[test]
fn us_dates_in_a_force_log_follow_force_date_order() {
    // 04/05/2025: 4 May read day first, 5 April read month first.
    let text = "AbsTime,force_N\n04/05/2025 10:00:00.0,0\n04/05/2025 10:00:00.5,1\n04/05/2025 10:00:01.0,2\n";
    let dmy = force_from(text, &ForceReadOptions::default()).unwrap();
    let mdy = force_from(
        text,
        &ForceReadOptions {
            date_order: Some(fbgforge::logs::num::DateOrder::MonthDayYear),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(dmy.time_s[0] - mdy.time_s[0], 29.0 * 86400.0);
    assert_eq!(mdy.time_s[0], epoch(2025, 4, 5, 10.0, 0.0, 0.0));
}

#[test]
fn a_csv_whose_first_column_is_an_index_is_refused_not_read_as_seconds() {
    // A Hyperion CSV export without timestamps: `id` counts samples at 1 kHz.
    let dir = tempfile::tempdir().unwrap();
    for header in ["id,CH1,CH2", "Index;CH1;CH2", ",CH1,CH2"] {
        let d = if header.contains(';') { ";" } else { "," };
        let text = format!(
            "{header}\n0{d}1546.295{d}1524.570\n1{d}1546.296{d}1524.571\n2{d}1546.297{d}1524.569\n"
        );
        let p = dir.path().join("hyperion.csv");
        std::fs::write(&p, text).unwrap();
        let e = logs::read_peak_log(
            &p,
            &ReadOptions {
                format: Some(LogFormat::Csv),
                ..Default::default()
            },
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("sample index") && e.contains("hyperion.csv"),
            "{header}: {e}"
        );
    }
}
