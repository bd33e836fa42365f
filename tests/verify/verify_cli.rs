//! The `synth-log`, `verify` and `calibrate-array` commands end to end.

use std::path::Path;

use crate::common::bin;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn synth_log_then_verify_writes_json_and_a_report() {
    let dir = tempfile::tempdir().unwrap();
    let design = root().join("designs/clip-on-34mm.toml");
    let out = bin()
        .args([
            "synth-log",
            design.to_str().unwrap(),
            "--format",
            "imon",
            "--core",
            "psc2",
            "--k-pm-per-n",
            "-20",
            "--temperature-ramp-k-per-s",
            "0.05",
            "--out",
        ])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report = dir.path().join("report");
    let out = bin()
        .args([
            "verify",
            design.to_str().unwrap(),
            "--core",
            "psc2",
            "--case",
            "II",
            "--json",
            "--log",
        ])
        .arg(dir.path().join("log.txt"))
        .arg("--force")
        .arg(dir.path().join("force.csv"))
        .arg("--report")
        .arg(&report)
        .output()
        .unwrap();
    // 0 = pass or not judged, 2 = fail; both wrote the report.
    let code = out.status.code().unwrap();
    assert!(
        code == 0 || code == 2,
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let truth: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("truth.json")).unwrap())
            .unwrap();
    let g = &v["measurement"]["gratings"][0];
    assert_eq!(g["grating"], "lambda_21");
    let k = g["sensitivity_pm_per_n"].as_f64().unwrap();
    assert!((k + 20.0).abs() < 0.2, "{k}");
    assert!(g["sls_time_constant_s"].as_f64().unwrap() > 0.0);
    let off = v["measurement"]["clock_offset_s"].as_f64().unwrap();
    assert!(
        (off - truth["clock_offset_s"].as_f64().unwrap()).abs() <= 0.05,
        "{off}"
    );
    for f in [
        "report.md",
        "report.json",
        "shift_vs_force.svg",
        "force_vs_time.svg",
        "shift_vs_time.svg",
        "lag_per_pulse.svg",
        "timeseries.csv",
        "pulses.csv",
    ] {
        assert!(report.join(f).is_file(), "{f} missing");
    }
    let md = std::fs::read_to_string(report.join("report.md")).unwrap();
    assert!(md.contains("lambda_21") && md.contains("![shift against force](shift_vs_force.svg)"));
}

#[test]
fn verify_errors_exit_1_with_a_message() {
    let design = root().join("designs/clip-on-34mm.toml");
    let out = bin()
        .args(["verify", design.to_str().unwrap(), "--log"])
        .arg(root().join("fixtures/logs/metadata_only.txt"))
        .arg("--force")
        .arg(root().join("fixtures/logs/force_stand.csv"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.starts_with("error: ") && err.contains("metadata_only.txt"),
        "{err}"
    );
    let out = bin()
        .args([
            "verify",
            design.to_str().unwrap(),
            "--insert",
            "purple",
            "--log",
            "x",
            "--force",
            "y",
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no insert named `purple`"));
}

#[test]
fn calibrate_array_from_a_synthetic_run() {
    let dir = tempfile::tempdir().unwrap();
    let design = root().join("designs/tactile-array-60x80.toml");
    let sched = dir.path().join("schedule.csv");
    let mut text = String::from("# 200 g on each cell in turn\nstart_s,end_s,cell,load_g\n");
    for (k, c) in ["A", "B", "C", "D", "E", "F", "G", "H"].iter().enumerate() {
        text += &format!("{},{},{c},200\n", 10 + 20 * k, 20 + 20 * k);
    }
    std::fs::write(&sched, text).unwrap();
    let out = bin()
        .args([
            "synth-log",
            design.to_str().unwrap(),
            "--format",
            "enlight-sensors",
            "--rate-hz",
            "10",
            "--noise-pm",
            "0.1",
            "--schedule",
        ])
        .arg(&sched)
        .arg("--out")
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let matrix = dir.path().join("A.csv");
    let out = bin()
        .args(["calibrate-array", design.to_str().unwrap(), "--log"])
        .arg(dir.path().join("log.txt"))
        .arg("--schedule")
        .arg(&sched)
        .arg("--out")
        .arg(&matrix)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let read = |p: &Path| -> Vec<Vec<f64>> {
        std::fs::read_to_string(p)
            .unwrap()
            .lines()
            .filter(|l| !l.starts_with('#') && !l.starts_with("grating"))
            .map(|l| l.split(',').skip(1).map(|v| v.parse().unwrap()).collect())
            .collect()
    };
    let (got, want) = (read(&matrix), read(&dir.path().join("matrix_truth.csv")));
    assert_eq!(got.len(), 6);
    for (r, w) in got.iter().zip(&want) {
        for (a, b) in r.iter().zip(w) {
            assert!((a - b).abs() < 0.005f64.max(0.02 * b), "{a} vs {b}");
        }
    }
    // The sheet's unknowns fitted to the measured matrix (`--fit-modulus` is the old
    // name of `--fit-sheet`): each parameter has a value only where identifiable.
    let out = bin()
        .args(["calibrate-array", design.to_str().unwrap(), "--log"])
        .arg(dir.path().join("log.txt"))
        .arg("--schedule")
        .arg(&sched)
        .arg("--out")
        .arg(&matrix)
        .arg("--fit-modulus")
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("sheet fit: ") && stdout.contains("youngs_modulus_mpa"), "{stdout}");
    let fit: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(matrix.with_extension("sheet-fit.json")).unwrap(),
    )
    .unwrap();
    let params = fit["parameters"].as_array().unwrap();
    assert_eq!(params.len(), 3, "{fit}");
    for p in params {
        assert_eq!(p["value"].is_null(), !p["identifiable"].as_bool().unwrap(), "{p}");
    }
}
