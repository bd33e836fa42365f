//! Spectrum logs end to end (issue 36): `synth-log` writes an I-MON log with pixels
//! whose peaks are known, `peaks` finds them with their uncertainty, and `verify` on the
//! spectrum log (or on the peaks log `peaks --out` wrote) gives the K the equivalent
//! peak log gives.

use crate::common::{bin, shipped_path};
use std::path::Path;

/// The pixel calibration `synth-log` writes with by default: 512 pixels from 1595 down
/// to 1510 nm.
const CAL: &str = "1595.1663405088063,-0.16634050880626223";

fn synth(dir: &Path, format: &str, extra: &[&str]) {
    let out = bin()
        .args(["synth-log"])
        .arg(shipped_path("clip-on-34mm.toml"))
        .args([
            "--format",
            format,
            "--core",
            "psc2",
            "--k-pm-per-n",
            "-20",
            "--seed",
            "5",
        ])
        .args(extra)
        .arg("--out")
        .arg(dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// `verify --json` on `log` (with `extra` flags): the primary grating's K and the JSON.
fn verify_k(dir: &Path, log: &Path, extra: &[&str]) -> (f64, serde_json::Value) {
    let out = bin()
        .arg("verify")
        .arg(shipped_path("clip-on-34mm.toml"))
        .args(["--core", "psc2", "--case", "II", "--json", "--log"])
        .arg(log)
        .arg("--force")
        .arg(dir.join("force.csv"))
        .args(extra)
        .output()
        .unwrap();
    let code = out.status.code().unwrap();
    assert!(
        code == 0 || code == 2,
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let g = &v["measurement"]["gratings"][0];
    assert_eq!(g["grating"], "lambda_21");
    (g["sensitivity_pm_per_n"].as_f64().unwrap(), v)
}

#[test]
fn verify_on_a_spectrum_log_gives_the_peak_logs_k_within_one_percent() {
    let peaks_dir = tempfile::tempdir().unwrap();
    let spectra_dir = tempfile::tempdir().unwrap();
    synth(peaks_dir.path(), "imon", &[]);
    // The same run (same seed: same shifts) written as 512-pixel spectra of Gaussian
    // lines 0.33 nm wide (2 pixels, as on real I-MON frames).
    synth(
        spectra_dir.path(),
        "imon-pixels",
        &["--line-shape", "gaussian"],
    );
    let (k_peaks, _) = verify_k(peaks_dir.path(), &peaks_dir.path().join("log.txt"), &[]);
    let log = spectra_dir.path().join("log.txt");
    let (k_spectra, v) = verify_k(spectra_dir.path(), &log, &["--imon-calibration", CAL]);
    assert_eq!(v["measurement"]["wavelength_format"], "imon-pixels");
    assert!((k_peaks + 20.0).abs() < 0.2, "{k_peaks}");
    assert!(
        ((k_spectra - k_peaks) / k_peaks).abs() < 0.01,
        "K from spectra {k_spectra} vs from peaks {k_peaks}"
    );

    // `peaks --out` writes a peaks log that verify reads back to the same K.
    let csv = spectra_dir.path().join("peaks.csv");
    let out = bin()
        .arg("peaks")
        .arg(&log)
        .args(["--imon-calibration", CAL, "--design"])
        .arg(shipped_path("clip-on-34mm.toml"))
        .arg("--out")
        .arg(&csv)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(
        text.contains("# estimator: gaussian"),
        "{}",
        &text[..200.min(text.len())]
    );
    assert!(text.contains("lambda_21 std_error_pm"));
    let (k_csv, _) = verify_k(spectra_dir.path(), &csv, &[]);
    assert!(
        ((k_csv - k_spectra) / k_spectra).abs() < 1e-3,
        "{k_csv} vs {k_spectra}"
    );
}

#[test]
fn peaks_json_names_format_estimator_and_every_peak_field() {
    let dir = tempfile::tempdir().unwrap();
    synth(dir.path(), "imon-pixels", &["--line-shape", "gaussian"]);
    let out = bin()
        .arg("peaks")
        .arg(dir.path().join("log.txt"))
        .args([
            "--imon-calibration",
            CAL,
            "--estimator",
            "parabola",
            "--json",
            "--design",
        ])
        .arg(shipped_path("clip-on-34mm.toml"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let keys = |o: &serde_json::Value| -> Vec<String> {
        let mut k: Vec<String> = o.as_object().unwrap().keys().cloned().collect();
        k.sort();
        k
    };
    assert_eq!(keys(&v), ["estimator", "format", "rows"]);
    assert_eq!(v["format"], "imon-pixels");
    assert_eq!(v["estimator"], "parabola");
    let rows = v["rows"].as_array().unwrap();
    assert!(rows.len() > 10);
    assert_eq!(keys(&rows[0]), ["peaks", "time_s"]);
    let p = &rows[0]["peaks"][0];
    assert_eq!(
        keys(p),
        [
            "channel",
            "crb_pm",
            "flags",
            "fwhm_pm",
            "grating",
            "snr",
            "std_error_pm",
            "wavelength_nm"
        ]
    );
    // Every grating of the design is found in every row, near its nominal wavelength
    // (the synthetic shifts stay within a nanometre), 2 pixels wide.
    let gratings: Vec<&str> = rows[0]["peaks"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["grating"].as_str().unwrap())
        .collect();
    assert!(gratings.contains(&"lambda_21"), "{gratings:?}");
    for p in rows[0]["peaks"].as_array().unwrap() {
        let fwhm = p["fwhm_pm"].as_f64().unwrap();
        assert!((fwhm - 330.0).abs() < 40.0, "{p}");
        assert!(p["std_error_pm"].as_f64().unwrap() > 0.0);
        assert!(p["flags"].as_array().unwrap().is_empty(), "{p}");
    }
}

#[test]
fn a_spectrum_file_without_its_calibration_is_refused_naming_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    synth(dir.path(), "imon-pixels", &[]);
    let out = bin()
        .arg("peaks")
        .arg(dir.path().join("log.txt"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--imon-calibration"), "{err}");
}
