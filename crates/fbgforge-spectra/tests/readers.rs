//! Readers and writers: round trips exact to the printed precision, detection, and
//! malformed input giving errors that name the line.

use fbgforge_spectra::synth::{SynthPeak, SynthSpectrum};
use fbgforge_spectra::{
    detect, read_enlight, read_imon, read_osa_csv, read_spectrum_log, write_enlight, write_imon,
    write_osa_csv, ImonWriteOptions, PixelCalibration, PowerUnit, ReadOptions, Spectrum,
    SpectrumError, SpectrumFormat, SpectrumLog, SpectrumRow,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn one_row(
    format: SpectrumFormat,
    spectra: Vec<Spectrum>,
    metadata: Vec<(String, String)>,
) -> SpectrumLog {
    SpectrumLog {
        format,
        metadata,
        rows: vec![SpectrumRow {
            time_s: 1_744_905_663.0,
            spectra,
            reported_peaks_nm: vec![],
        }],
    }
}

/// |a − b| within half a unit of the last printed decimal (plus rounding of the binary value).
fn within_printed(a: f64, b: f64, decimals: i32) -> bool {
    (a - b).abs() <= 0.5 * 10f64.powi(-decimals) * (1.0 + 1e-9) + 1e-12 * a.abs()
}

fn imon_calibration() -> PixelCalibration {
    // 512 pixels from about 1595 nm (Pixel 1) down to 1510 nm (Pixel 512), with a small
    // curvature: the reverse order of the I-MON 512.
    PixelCalibration::new(vec![1595.2, -0.1662, -1.0e-6]).unwrap()
}

#[test]
fn enlight_round_trip_is_exact_to_four_decimals() {
    let synth = SynthSpectrum::uniform(1545.0, 0.008, 1500, 1e-5)
        .with_floor(1.2e-6 * 1e3)
        .with_peak(SynthPeak::gaussian(1550.0, 0.25, 0.01));
    let ch1 = synth.spectrum_in(1, PowerUnit::Dbm).unwrap();
    let mut ch2 = synth.spectrum_in(2, PowerUnit::Dbm).unwrap();
    ch2.channel = "CH 2".into();
    ch2.metadata = vec![
        ("Detect Valley".into(), "False".into()),
        ("Detection Setting ID".into(), "128".into()),
    ];
    let metadata = vec![
        ("Module Type".into(), "Hyperion".into()),
        ("HW Acquisition Rate".into(), "1000 Hz".into()),
    ];
    let log = one_row(
        SpectrumFormat::EnlightSpectrum,
        vec![ch1.clone(), ch2.clone()],
        metadata,
    );
    let text = write_enlight(&log).unwrap();
    assert_eq!(detect(&text), Some(SpectrumFormat::EnlightSpectrum));
    let back = read_spectrum_log(&text, &ReadOptions::default()).unwrap();
    assert_eq!(back.format, SpectrumFormat::EnlightSpectrum);
    assert_eq!(back.meta("Module Type"), Some("Hyperion"));
    assert_eq!(back.rows[0].time_s, 1_744_905_663.0);
    let row = &back.rows[0];
    assert_eq!(row.spectra.len(), 2);
    assert_eq!(row.spectra[1].metadata, ch2.metadata);
    for (read, written) in row.spectra.iter().zip([&ch1, &ch2]) {
        assert_eq!(read.unit, PowerUnit::Dbm);
        for k in 0..written.len() {
            assert!(within_printed(
                read.wavelengths_nm[k],
                written.wavelengths_nm[k],
                4
            ));
            assert!(
                within_printed(read.power[k], written.power[k], 4),
                "{} vs {}",
                read.power[k],
                written.power[k]
            );
        }
    }
    // Reading back what was written and writing it again gives the same text.
    assert_eq!(write_enlight(&back).unwrap(), text);
}

#[test]
fn enlight_reads_the_public_layout_with_bom_crlf_and_decreasing_rows() {
    let text = "\u{feff}\r\nDate: 17/04/2025 3:44:56 pm\r\nModule Type: Hyperion\r\nWavelength Tracking: 400 pm / acquistion\r\nIP Address: 10.0.0.55\r\n      Port: 51971\r\n\r\nCH 1 Configuration:\r\n\tDetect Valley: False\r\nWvl (nm)\t CH 1 \r\n\r\n1460.0160\t-58.6302\r\n1460.0080\t-58.3009\r\n1460.0000\t-58.4822\r\n";
    let log = read_enlight(text).unwrap();
    let s = &log.rows[0].spectra[0];
    assert_eq!(s.wavelengths_nm, vec![1460.0, 1460.008, 1460.016]);
    assert_eq!(s.power, vec![-58.4822, -58.3009, -58.6302]);
    assert_eq!(log.meta("Wavelength Tracking"), Some("400 pm / acquistion"));
    assert_eq!(log.meta("Port"), Some("51971"));
    assert_eq!(s.meta("Detect Valley"), Some("False"));
    // 2025-04-17 15:44:56 = 20195 days after 1970-01-01.
    assert_eq!(
        log.rows[0].time_s,
        20_195.0 * 86_400.0 + 15.0 * 3600.0 + 44.0 * 60.0 + 56.0
    );
    let linear = s.linear_power();
    assert!((linear[0] - 10f64.powf(-5.84822)).abs() < 1e-18);
}

#[test]
fn imon_round_trip_keeps_pixel_order_counts_times_and_reported_peaks() {
    let calibration = imon_calibration();
    let truth_nm = 1530.3003;
    let synth = SynthSpectrum::imon(&calibration, 512, 15.0)
        .unwrap()
        .with_floor(1350.0)
        .with_peak(SynthPeak::gaussian(truth_nm, 0.33, 38_000.0));
    let text = synth.imon_log(&calibration, 5, 11).unwrap();
    assert!(text.starts_with("Date\tTime\tWavelength 1 [nm]\tPixel 1\tPixel 2\t"));
    assert!(text.lines().next().unwrap().ends_with("Pixel 512\t"));
    assert_eq!(text.lines().nth(1), Some(""));
    assert_eq!(detect(&text), Some(SpectrumFormat::ImonPixels));
    let options = ReadOptions {
        imon_calibration: Some(calibration.clone()),
        ..ReadOptions::default()
    };
    let log = read_spectrum_log(&text, &options).unwrap();
    assert_eq!(log.rows.len(), 5);
    let expected_w = {
        let mut w = calibration.pixel_wavelengths_nm(512).unwrap();
        w.reverse();
        w
    };
    for (k, row) in log.rows.iter().enumerate() {
        assert_eq!(row.time_s, 1_604_076_250.0 + k as f64);
        assert_eq!(row.reported_peaks_nm, vec![1530.3003]);
        let s = &row.spectra[0];
        assert_eq!(s.unit, PowerUnit::Counts);
        assert_eq!(s.wavelengths_nm, expected_w);
        let written = synth.spectrum(11 + k as u64);
        for (a, b) in s.power.iter().zip(&written.power) {
            // `1.349E+3`: 4 significant digits.
            let unit = 10f64.powi(b.abs().log10().floor() as i32 - 3);
            assert!((a - b).abs() <= 0.5 * unit * (1.0 + 1e-9), "{a} vs {b}");
        }
    }
    // The highest count sits at the true wavelength: pixels were put back in wavelength order.
    let s = &log.rows[0].spectra[0];
    let k = (0..s.len())
        .max_by(|&a, &b| s.power[a].total_cmp(&s.power[b]))
        .unwrap();
    assert!(
        (s.wavelengths_nm[k] - truth_nm).abs() < 0.17,
        "{}",
        s.wavelengths_nm[k]
    );
    let again = write_imon(
        &log,
        &ImonWriteOptions {
            calibration,
            wavelength_cells: 1,
        },
    )
    .unwrap();
    assert_eq!(again, text);
}

#[test]
fn imon_reads_rows_with_padded_wavelength_cells() {
    let calibration = PixelCalibration::linear(1595.0, 1510.0, 4).unwrap();
    let text = "Date\tTime\tWavelength 1 [nm]\tPixel 1\tPixel 2\tPixel 3\tPixel 4\t\n\n\
                10/30/2020\t4:44:10 PM\t1.5303003E+3\t0.000E+0\t1.349E+3\t3.938E+4\t1.365E+3\n\
                10/30/2020\t4:44:11 PM\t1.5303003E+3\t1.5400000E+3\t0.0000000E+0\t1.0E+0\t2.0E+0\t3.0E+0\t4.0E+0\n";
    let log = read_imon(text, Some(&calibration)).unwrap();
    assert_eq!(
        log.rows[0].spectra[0].power,
        vec![1365.0, 39380.0, 1349.0, 0.0]
    );
    let w = &log.rows[0].spectra[0].wavelengths_nm;
    for (a, b) in w
        .iter()
        .zip([1510.0, 1510.0 + 85.0 / 3.0, 1510.0 + 170.0 / 3.0, 1595.0])
    {
        assert!((a - b).abs() < 1e-9, "{w:?}");
    }
    assert_eq!(log.rows[1].reported_peaks_nm, vec![1530.3003, 1540.0]);
    assert_eq!(log.rows[1].spectra[0].power, vec![4.0, 3.0, 2.0, 1.0]);
    assert_eq!(log.rows[1].time_s - log.rows[0].time_s, 1.0);
}

#[test]
fn osa_round_trip_in_db_mw_and_linear_units() {
    let synth = SynthSpectrum::uniform(1549.0, 0.0024, 900, 1e-3)
        .with_peak(SynthPeak::gaussian(1550.0, 0.2, 0.5));
    for unit in [
        PowerUnit::Db,
        PowerUnit::Dbm,
        PowerUnit::Mw,
        PowerUnit::Linear,
    ] {
        let mut rx = synth.spectrum_in(3, unit).unwrap();
        rx.channel = "Rx".into();
        let mut tx = synth.spectrum_in(4, unit).unwrap();
        tx.channel = "Tx".into();
        let log = one_row(
            SpectrumFormat::OsaCsv,
            vec![rx.clone(), tx],
            vec![("Instrument".into(), "swept laser".into())],
        );
        let text = write_osa_csv(&log).unwrap();
        assert!(
            text.contains(&format!(
                "Wavelength (nm),Rx ({}),Tx ({})",
                unit.label(),
                unit.label()
            )),
            "{}",
            &text[..80]
        );
        assert_eq!(detect(&text), Some(SpectrumFormat::OsaCsv));
        let back = read_spectrum_log(&text, &ReadOptions::default()).unwrap();
        assert_eq!(back.meta("Instrument"), Some("swept laser"));
        let s = &back.rows[0].spectra[0];
        assert_eq!((s.channel.as_str(), s.unit), ("Rx", unit));
        for k in 0..s.len() {
            assert!(within_printed(s.wavelengths_nm[k], rx.wavelengths_nm[k], 5));
            if unit.is_logarithmic() {
                assert!(within_printed(s.power[k], rx.power[k], 4));
            } else {
                assert!(
                    (s.power[k] - rx.power[k]).abs() <= 5e-7 * rx.power[k].abs() * (1.0 + 1e-9)
                );
            }
        }
        assert_eq!(write_osa_csv(&back).unwrap(), text);
    }
}

#[test]
fn osa_detects_units_and_reverses_decreasing_sweeps() {
    let text = "Wavelength (nm);Amplitude (AU)\n1550,002;0,5\n1550,001;0,25\n1550,000;0,125\n";
    let log = read_osa_csv(text).unwrap();
    let s = &log.rows[0].spectra[0];
    assert_eq!(
        (s.channel.as_str(), s.unit),
        ("Amplitude", PowerUnit::Linear)
    );
    assert_eq!(s.wavelengths_nm, vec![1550.0, 1550.001, 1550.002]);
    assert_eq!(s.power, vec![0.125, 0.25, 0.5]);
    let w = read_osa_csv("\"Wavelength (um)\",\"Power (uW)\"\n1.55,2\n1.551,4\n").unwrap();
    let s = &w.rows[0].spectra[0];
    assert_eq!(s.unit, PowerUnit::Mw);
    assert!((s.wavelengths_nm[1] - 1551.0).abs() < 1e-9 && (s.power[1] - 0.004).abs() < 1e-15);
    for (label, unit) in [
        ("Rx (dB)", PowerUnit::Db),
        ("P [dBm]", PowerUnit::Dbm),
        ("P (mW)", PowerUnit::Mw),
        ("Signal", PowerUnit::Linear),
        ("I (counts)", PowerUnit::Counts),
    ] {
        let log = read_osa_csv(&format!("Wavelength (nm),{label}\n1550,1\n1551,2\n")).unwrap();
        assert_eq!(log.rows[0].spectra[0].unit, unit, "{label}");
    }
}

#[test]
fn detect_leaves_peak_logs_and_force_files_alone() {
    let peaks = "Date: 17/04/2025\nTimestamp Format: Full\nTimestamp\t# CH 1\t# CH 2\n17/04/2025 3:44:56 pm\t1\t0\t1550.1\n";
    let imon_peaks = "Date\tTime\tWavelength 1 [nm]\tWavelength 2 [nm]\n\n10/30/2020\t4:44:10 PM\t1.53E+3\t0.0E+0\n";
    let force = "time_s,force_N\n0.0,0.1\n";
    for text in [peaks, imon_peaks, force, ""] {
        assert_eq!(detect(text), None, "{text}");
        assert!(matches!(
            read_spectrum_log(text, &ReadOptions::default()),
            Err(SpectrumError::UnknownFormat(_))
        ));
    }
}

/// The error's line number, and its message names it.
fn line_of(e: &SpectrumError) -> usize {
    let line = match e {
        SpectrumError::Parse { line, .. }
        | SpectrumError::Ragged { line, .. }
        | SpectrumError::NotMonotonic { line, .. } => *line,
        other => panic!("expected an error with a line, got {other}"),
    };
    assert!(e.to_string().contains(&format!("line {line}")), "{e}");
    line
}

const ENLIGHT_HEAD: &str = "\nDate: 17/04/2025 4:01:03 pm\nCH 1 Configuration:\n\tDetect Valley: False\nWvl (nm)\t CH 1 \t CH 2 \n\n";

#[test]
fn malformed_enlight_files_name_the_line() {
    // The header is 6 lines, the first data row is line 7.
    let ragged = format!("{ENLIGHT_HEAD}1460.0000\t-58.1\t-58.2\n1460.0080\t-58.3\n");
    let e = read_enlight(&ragged).unwrap_err();
    assert!(matches!(e, SpectrumError::Ragged { found: 2, .. }));
    assert_eq!(line_of(&e), 8);
    let text = format!("{ENLIGHT_HEAD}1460.0000\t-58.1\t-58.2\n1460.0080\t-5x8.3\t-58.0\n");
    let e = read_enlight(&text).unwrap_err();
    assert!(matches!(&e, SpectrumError::Parse { found, .. } if found == "-5x8.3"));
    assert_eq!(line_of(&e), 8);
    let text = format!(
        "{ENLIGHT_HEAD}1460.0000\t-58.1\t-58.2\n1460.0080\t-58.3\t-58.0\n1460.0040\t-58.3\t-58.0\n"
    );
    let e = read_enlight(&text).unwrap_err();
    assert!(
        matches!(e, SpectrumError::NotMonotonic { previous_nm, current_nm, .. } if previous_nm == 1460.008 && current_nm == 1460.004)
    );
    assert_eq!(line_of(&e), 9);
    let e = read_enlight(&format!(
        "{ENLIGHT_HEAD}1460.0000\t-58.1\t-58.2\n1460.0000\t-58.3\t-58.0\n"
    ))
    .unwrap_err();
    assert_eq!(line_of(&e), 8);
}

fn imon_text(pixels: usize, rows: &[String]) -> String {
    let mut t = String::from("Date\tTime\tWavelength 1 [nm]\t");
    for p in 1..=pixels {
        t.push_str(&format!("Pixel {p}\t"));
    }
    t.push_str("\n\n");
    for r in rows {
        t.push_str(r);
        t.push('\n');
    }
    t
}

#[test]
fn malformed_imon_logs_name_the_line() {
    let cal = PixelCalibration::linear(1595.0, 1510.0, 4).unwrap();
    let good = "10/30/2020\t4:44:10 PM\t1.5303003E+3\t1.0E+3\t2.0E+3\t3.0E+3\t4.0E+3".to_string();
    // Wrong pixel count: 3 pixel values for 4 pixel columns leaves no wavelength cell.
    let short = "10/30/2020\t4:44:11 PM\t1.0E+3\t2.0E+3\t3.0E+3\t4.0E+3".to_string();
    let e = read_imon(&imon_text(4, &[good.clone(), short]), Some(&cal)).unwrap_err();
    assert!(matches!(e, SpectrumError::Ragged { found: 6, .. }), "{e}");
    assert_eq!(line_of(&e), 4);
    let bad = "10/30/2020\t4:44:11 PM\t1.5303003E+3\t1.0E+3\tn/a\t3.0E+3\t4.0E+3".to_string();
    let e = read_imon(
        &imon_text(4, &[good.clone(), good.clone(), bad]),
        Some(&cal),
    )
    .unwrap_err();
    assert_eq!(line_of(&e), 5);
    let bad_time =
        "10/30/2020\t16:44:11 PM\t1.5303003E+3\t1.0E+3\t2.0E+3\t3.0E+3\t4.0E+3".to_string();
    assert_eq!(
        line_of(&read_imon(&imon_text(4, &[bad_time]), Some(&cal)).unwrap_err()),
        3
    );
    // Pixel columns must run 1, 2, …
    let header = "Date\tTime\tWavelength 1 [nm]\tPixel 1\tPixel 3\t\n\n";
    assert_eq!(line_of(&read_imon(header, Some(&cal)).unwrap_err()), 1);
    // Missing polynomial: a clear error that says what to pass.
    let e = read_imon(&imon_text(4, std::slice::from_ref(&good)), None).unwrap_err();
    assert!(matches!(e, SpectrumError::MissingCalibration { pixels: 4 }));
    assert!(e.to_string().contains("a0,a1"), "{e}");
    let e = read_spectrum_log(
        &imon_text(4, std::slice::from_ref(&good)),
        &ReadOptions::default(),
    )
    .unwrap_err();
    assert!(matches!(e, SpectrumError::MissingCalibration { pixels: 4 }));
    // A polynomial that folds back over the pixels.
    let folded = PixelCalibration::new(vec![1500.0, 20.0, -5.0]).unwrap();
    assert!(matches!(
        read_imon(&imon_text(4, &[good]), Some(&folded)),
        Err(SpectrumError::Calibration(_))
    ));
    assert!(PixelCalibration::parse("1595.2, -0.1662").is_ok());
    assert!(matches!(
        PixelCalibration::parse("1595.2;-0.1662"),
        Err(SpectrumError::Calibration(_))
    ));
}

#[test]
fn malformed_osa_files_name_the_line() {
    let e = read_osa_csv("# sweep\nWavelength (nm),Rx (dB),Tx (dB)\n1550.000,-1,-2\n1550.001,-1\n")
        .unwrap_err();
    assert_eq!(line_of(&e), 4);
    let e = read_osa_csv("Wavelength (nm),Rx (dB)\n1550.000,-1\n1550.001,abc\n").unwrap_err();
    assert_eq!(line_of(&e), 3);
    let e = read_osa_csv("Wavelength (nm),Rx (dB)\n1550.000,-1\n1550.002,-1\n1550.001,-1\n")
        .unwrap_err();
    assert_eq!(line_of(&e), 4);
    let e = read_osa_csv("Wavelength (nm),Rx (furlongs)\n1550.000,-1\n").unwrap_err();
    assert_eq!(line_of(&e), 1);
}

#[test]
fn no_reader_panics_on_mangled_files() {
    let cal = imon_calibration();
    let synth = SynthSpectrum::uniform(1549.5, 0.01, 100, 1e-3)
        .with_peak(SynthPeak::gaussian(1550.0, 0.05, 0.1));
    let imon_synth = SynthSpectrum::imon(&cal, 512, 10.0).unwrap();
    let files = [
        synth
            .write(SpectrumFormat::EnlightSpectrum, 1, PowerUnit::Dbm)
            .unwrap(),
        synth
            .write(SpectrumFormat::OsaCsv, 1, PowerUnit::Db)
            .unwrap(),
        imon_synth.imon_log(&cal, 2, 1).unwrap(),
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let options = ReadOptions {
        imon_calibration: Some(cal),
        ..ReadOptions::default()
    };
    let junk = [
        '\t', '\n', ',', ';', '.', '-', 'E', '0', ' ', 'x', '\u{feff}', ':',
    ];
    for file in &files {
        let chars: Vec<char> = file.chars().collect();
        for _ in 0..300 {
            let mut c = chars.clone();
            for _ in 0..rng.random_range(1..6) {
                let at = rng.random_range(0..c.len());
                match rng.random_range(0..3) {
                    0 => c[at] = junk[rng.random_range(0..junk.len())],
                    1 => {
                        c.remove(at);
                    }
                    _ => c.truncate(at),
                }
                if c.is_empty() {
                    break;
                }
            }
            let text: String = c.into_iter().collect();
            // Any result is fine; a panic fails the test.
            let _ = read_spectrum_log(&text, &options);
            for f in [
                SpectrumFormat::EnlightSpectrum,
                SpectrumFormat::ImonPixels,
                SpectrumFormat::OsaCsv,
            ] {
                let _ = read_spectrum_log(
                    &text,
                    &ReadOptions {
                        format: Some(f),
                        ..options.clone()
                    },
                );
            }
        }
    }
}
