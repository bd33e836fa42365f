//! Spectrum files through the one reader: detected, read into the rows a peak log gives,
//! each peak with its uncertainty; an I-MON log read by its pixels and by its own peak
//! cells gives the same rows and times.

use super::super::{
    num::days_from_civil, parse_wavelength_bytes, write_log, Clock, LogFormat, LogStyle, LogTable,
    ReadOptions, RowReader,
};
use super::*;
use fbgforge_spectra::synth::{SynthPeak, SynthSpectrum};
use fbgforge_spectra::PowerUnit;
use std::path::PathBuf;

/// Two gratings drifting apart over 40 rows, 0.05 s apart, one peak missing.
fn table() -> (f64, Vec<f64>, Vec<String>, Vec<Vec<f64>>) {
    let t0 = days_from_civil(2025, 4, 17) as f64 * 86400.0 + 56696.0;
    let time_s: Vec<f64> = (0..40).map(|i| 0.05 * f64::from(i)).collect();
    let names = vec!["fbg_a".to_string(), "fbg_b".into()];
    let rows = (0..40)
        .map(|i| {
            let d = f64::from(i) * 0.0123;
            let mut r = vec![1530.3 + d, 1546.3 - 0.5 * d];
            if i == 7 {
                r[1] = f64::NAN;
            }
            r
        })
        .collect();
    (t0, time_s, names, rows)
}

fn imon_pixel_bytes(style: &LogStyle) -> (Vec<u8>, Vec<Vec<f64>>) {
    let (t0, time_s, names, rows) = table();
    let table = LogTable {
        start_epoch_s: t0,
        time_s: &time_s,
        names: &names,
        wavelength_nm: &rows,
        sample_rate_hz: 20.0,
    };
    let mut bytes = Vec::new();
    write_log(&mut bytes, LogFormat::ImonPixels, &table, style).unwrap();
    (bytes, rows)
}

fn with_calibration(estimator: Option<&str>) -> ReadOptions {
    ReadOptions {
        imon_calibration: Some(SpectrumStyle::default().imon_calibration),
        estimator: estimator.map(str::to_string),
        ..ReadOptions::default()
    }
}

#[test]
fn an_imon_log_read_by_its_pixels_gives_the_rows_its_peak_cells_give() {
    let (bytes, truth) = imon_pixel_bytes(&LogStyle::default());
    let path = PathBuf::from("imon.txt");
    let peaks = parse_wavelength_bytes(&bytes, &path, &ReadOptions::default()).unwrap();
    let pixels = parse_wavelength_bytes(&bytes, &path, &with_calibration(None)).unwrap();
    assert_eq!(peaks.format, LogFormat::Imon);
    assert!(peaks.uncertainty.is_none());
    assert_eq!(pixels.format, LogFormat::ImonPixels);
    assert_eq!(pixels.estimator(), Some("gaussian"));
    // The same rows at the same (de-quantised) times.
    assert_eq!(pixels.time_s, peaks.time_s);
    assert_eq!(pixels.clock, Clock::Absolute);
    let mut z = Vec::new();
    for (i, want) in truth.iter().enumerate() {
        let (found, _) = pixels.row(i);
        let q = pixels.row_quality(i).unwrap();
        let want: Vec<f64> = want.iter().copied().filter(|v| v.is_finite()).collect();
        assert_eq!(found.len(), want.len(), "row {i}: {found:?}");
        for ((f, w), q) in found.iter().zip(&want).zip(q) {
            // 2 pixels per FWHM at SNR 3,000: a bound of about 0.05 pm.
            assert!(q.std_error_pm > 0.0 && q.std_error_pm < 0.5, "{q:?}");
            assert!(q.crb_pm > 0.0 && q.crb_pm < 0.2, "{q:?}");
            assert!((q.fwhm_pm - 330.0).abs() < 15.0, "{q:?}");
            z.push((f - w) * 1e3 / q.std_error_pm);
        }
    }
    // Errors consistent with the stated standard errors: |z| rarely beyond 3, and the
    // scatter of z near 1 (the counts are also rounded to 4 significant digits).
    let rms = (z.iter().map(|v| v * v).sum::<f64>() / z.len() as f64).sqrt();
    assert!(z.iter().filter(|v| v.abs() > 4.0).count() <= 1, "{z:?}");
    assert!((0.5..1.6).contains(&rms), "rms z {rms}");
}

#[test]
fn a_growing_imon_pixel_log_is_read_row_by_row_with_the_same_peaks() {
    let (bytes, _) = imon_pixel_bytes(&LogStyle::default());
    let path = PathBuf::from("imon.txt");
    let opts = with_calibration(Some("parabola"));
    let whole = parse_wavelength_bytes(&bytes, &path, &opts).unwrap();
    assert_eq!(whole.estimator(), Some("parabola"));
    let (mut reader, body) = RowReader::new(&bytes, &path, &opts).unwrap();
    assert_eq!(reader.format(), LogFormat::ImonPixels);
    assert_eq!(reader.describe(), "imon-pixels, peaks by parabola");
    let mut i = 0;
    for line in bytes[body..].split(|&c| c == b'\n') {
        if let Some(row) = reader.parse(line).unwrap() {
            assert_eq!(row.peaks_nm, whole.row(i).0);
            assert_eq!(row.quality.len(), row.peaks_nm.len());
            i += 1;
        }
    }
    assert_eq!(i, whole.rows());
}

#[test]
fn xcorr_tracks_each_grating_against_its_first_row() {
    let (bytes, truth) = imon_pixel_bytes(&LogStyle::default());
    let log = parse_wavelength_bytes(
        &bytes,
        &PathBuf::from("i.txt"),
        &with_calibration(Some("xcorr")),
    )
    .unwrap();
    assert_eq!(log.estimator(), Some("xcorr"));
    // Shifts from the first row equal the true shifts (the template's own offset cancels).
    let first = log.row(0).0.to_vec();
    for i in [10, 25, 39] {
        let got = log.row(i).0;
        for k in 0..2 {
            let want = truth[i][k] - truth[0][k];
            assert!(
                ((got[k] - first[k]) - want).abs() < 2e-3,
                "row {i}: {got:?}"
            );
        }
    }
}

#[test]
fn a_reading_names_unknown_estimators_and_bad_calibrations_by_their_fields() {
    let (bytes, _) = imon_pixel_bytes(&LogStyle::default());
    let path = PathBuf::from("i.txt");
    let e = parse_wavelength_bytes(&bytes, &path, &with_calibration(Some("maximum"))).unwrap_err();
    assert!(format!("{e:#}").contains("ReadOptions.estimator"), "{e:#}");
    let bad = ReadOptions {
        imon_calibration: Some(vec![1550.0]),
        ..ReadOptions::default()
    };
    let e = parse_wavelength_bytes(&bytes, &path, &bad).unwrap_err();
    assert!(
        format!("{e:#}").contains("ReadOptions.imon_calibration"),
        "{e:#}"
    );
    let forced = ReadOptions {
        format: Some(LogFormat::ImonPixels),
        ..ReadOptions::default()
    };
    let e = parse_wavelength_bytes(&bytes, &path, &forced).unwrap_err();
    assert!(
        format!("{e:#}").contains("ReadOptions.imon_calibration"),
        "{e:#}"
    );
}

/// Two gratings at known wavelengths on an 8 pm grid, SNR 300, FWHM 0.2 nm.
fn two_peaks() -> SynthSpectrum {
    SynthSpectrum::uniform(1545.0, 0.008, 1000, 0.01)
        .with_peak(SynthPeak::gaussian(1547.0123, 0.2, 3.0))
        .with_peak(SynthPeak::gaussian(1550.4567, 0.2, 2.0))
}

#[test]
fn enlight_and_osa_spectra_are_read_as_one_row_of_peaks() {
    for (format, unit, name) in [
        (
            spectra::SpectrumFormat::EnlightSpectrum,
            PowerUnit::Dbm,
            "spectrum.txt",
        ),
        (
            spectra::SpectrumFormat::OsaCsv,
            PowerUnit::Linear,
            "osa.csv",
        ),
        (spectra::SpectrumFormat::OsaCsv, PowerUnit::Db, "osa_db.csv"),
    ] {
        let text = two_peaks().write(format, 3, unit).unwrap();
        let log = parse_wavelength_bytes(
            text.as_bytes(),
            &PathBuf::from(name),
            &ReadOptions::default(),
        )
        .unwrap_or_else(|e| panic!("{name}: {e:#}"));
        let want = match format {
            spectra::SpectrumFormat::EnlightSpectrum => LogFormat::EnlightSpectrum,
            _ => LogFormat::OsaCsv,
        };
        assert_eq!(log.format, want, "{name}");
        assert_eq!(log.rows(), 1, "{name}");
        let (found, chans) = log.row(0);
        assert_eq!(chans, &[0, 0], "{name}");
        let q = log.row_quality(0).unwrap();
        for ((f, w), q) in found.iter().zip([1547.0123, 1550.4567]).zip(q) {
            assert!(
                (f - w).abs() * 1e3 < 4.0 * q.std_error_pm.max(q.crb_pm),
                "{name}: {f} {q:?}"
            );
        }
    }
}

#[test]
fn a_peaks_csv_keeps_its_standard_errors_and_names_its_estimator() {
    let text = "# fbgforge peaks of imon.txt\n# estimator: parabola\n\
                time_s,fbg_a,fbg_a std_error_pm,fbg_b,fbg_b std_error_pm\n\
                0.0,1530.3,0.25,1546.3,0.5\n0.5,1530.31,,1546.29,0.75\n1.0,,0.3,1546.28,1.0\n";
    let log = parse_wavelength_bytes(
        text.as_bytes(),
        &PathBuf::from("p.csv"),
        &ReadOptions::default(),
    )
    .unwrap();
    assert_eq!(log.format, LogFormat::Csv);
    assert_eq!(log.estimator(), Some("parabola"));
    assert_eq!(log.row(0).0, &[1530.3, 1546.3]);
    let se = |i: usize| -> Vec<f64> {
        log.row_quality(i)
            .unwrap()
            .iter()
            .map(|q| q.std_error_pm)
            .collect()
    };
    assert_eq!(se(0), vec![0.25, 0.5]);
    assert!(se(1)[0].is_nan() && se(1)[1] == 0.75);
    // A standard error without its peak is dropped with it.
    assert_eq!(log.row(2).0, &[1546.28]);
    assert_eq!(se(2), vec![1.0]);
    // A plain CSV has no uncertainty.
    let plain = "time_s,fbg_a\n0,1530.3\n1,1530.4\n";
    let log = parse_wavelength_bytes(
        plain.as_bytes(),
        &PathBuf::from("p.csv"),
        &ReadOptions::default(),
    )
    .unwrap();
    assert!(log.uncertainty.is_none());
    let orphan = "time_s,fbg_a,fbg_x std_error_pm\n0,1530.3,0.1\n1,1530.4,0.1\n";
    let e = parse_wavelength_bytes(
        orphan.as_bytes(),
        &PathBuf::from("p.csv"),
        &ReadOptions::default(),
    )
    .unwrap_err();
    assert!(
        format!("{e:#}").contains("names no wavelength column `fbg_x`"),
        "{e:#}"
    );
}

#[test]
fn counts_are_written_with_four_significant_digits() {
    assert_eq!(super::super::imon_pixels::counts_text(1349.2), "1.349E+3");
    assert_eq!(super::super::imon_pixels::counts_text(9999.7), "1.000E+4");
    assert_eq!(super::super::imon_pixels::counts_text(0.2), "0.000E+0");
}
